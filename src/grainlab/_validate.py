"""Small checks that turn bad numbers into :class:`~grainlab.errors.InputError` messages."""

from __future__ import annotations

import math

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
