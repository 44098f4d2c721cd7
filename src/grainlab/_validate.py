"""Small checks that turn bad numbers into :class:`~grainlab.errors.InputError` messages."""

from __future__ import annotations

import math
import operator
import tomllib
from pathlib import Path
from typing import Any

from grainlab.errors import InputError


def positive(field: str, value: float, unit: str = "") -> float:
    """Return ``value`` as a float if it is finite and > 0, else raise naming ``field``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(field, value, f"a positive number{unit and ' in ' + unit}") from None
    if not (math.isfinite(number) and number > 0.0):
        raise InputError(field, value, f"a positive number{unit and ' in ' + unit}")
    return number


def at_least(field: str, value, minimum: float = 0.0, strict: bool = True) -> float:
    """Return ``value`` as a float if it is finite and > ``minimum`` (>= when not
    ``strict``), else raise naming ``field``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not math.isfinite(number) or number < minimum or (strict and number == minimum):
        raise InputError(field, value, f"a finite number {'>' if strict else '>='} {minimum:g}")
    return number


def in_range(
    field: str, value: float, low: float, high: float, unit: str = "", closed: str = "()"
) -> float:
    """Return ``value`` if it lies in the interval (or [ ] per ``closed``), else raise."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    left_ok = number >= low if closed[0] == "[" else number > low
    right_ok = number <= high if closed[1] == "]" else number < high
    if not (math.isfinite(number) and left_ok and right_ok):
        where = f"{closed[0]}{low:g}, {high:g}{closed[1]}"
        raise InputError(field, value, f"a number in {where}{unit and ' ' + unit}")
    return number


MAX_SEED = 2**32 - 1
"""Largest random seed accepted (a 32-bit unsigned integer, as most generators take)."""


def seed(field: str, value) -> int:
    """Return ``value`` if it is an integer seed in [0, :data:`MAX_SEED`], else raise naming
    ``field``."""
    try:
        number = operator.index(value)  # an int or a NumPy integer, never a float
    except TypeError:
        number = -1
    if isinstance(value, bool) or not 0 <= number <= MAX_SEED:
        raise InputError(field, value, f"an integer in [0, {MAX_SEED}]")
    return number


def read_toml(path: str | Path, field: str) -> dict[str, Any]:
    """The data of the TOML file ``path``; a missing, unreadable or invalid file raises
    :class:`InputError` naming ``field`` and the path."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(field, str(path), "an existing TOML file") from None
    except IsADirectoryError:
        raise InputError(field, str(path), "a TOML file (it is a folder)") from None
    except UnicodeDecodeError:
        raise InputError(field, str(path), "a TOML text file (this one is not UTF-8 "
                                           "text)") from None
    except OSError as error:
        raise InputError(field, str(path), f"a readable TOML file "
                                           f"({error.strerror or error})") from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(field, str(path), f"valid TOML ({error})") from None
