"""Checks of the paths a user typed at the command line, made before anything runs or is
written: output folders and files, figure formats, input files. Each failure is an
:class:`~grainlab.errors.InputError` naming the option as typed.

>>> output_folder("--out", "results")
PosixPath('results')
>>> try:
...     figure_file("--out", "figure.xyz")
... except InputError as error:
...     print(error.field, error.value)
--out figure.xyz
"""

from __future__ import annotations

import os
from pathlib import Path

from grainlab.errors import InputError


def _nearest_existing(path: Path) -> Path:
    """``path`` or the closest of its parents that exists (the current folder at worst)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path(".")


def _check_parents(option: str, path: Path) -> None:
    """The folders above ``path`` are folders, or can be made, and can be written into."""
    for parent in path.parents:
        if parent.exists() and not parent.is_dir():
            raise InputError(option, str(path), f"a path inside a folder ({parent} is a file)")
    base = _nearest_existing(path.parent)
    if not os.access(base, os.W_OK | os.X_OK):
        raise InputError(option, str(path), f"a place you may write to ({base} is not "
                                            "writable)")


def output_folder(option: str, path: str | Path) -> Path:
    """``path`` as a folder that exists or can be made, and can be written into."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(option, str(path), "a folder (it is a file)")
    _check_parents(option, path)
    if path.is_dir() and not os.access(path, os.W_OK | os.X_OK):
        raise InputError(option, str(path), "a folder you may write to")
    return path


def output_file(option: str, path: str | Path, suffixes: tuple[str, ...] = ()) -> Path:
    """``path`` as a file that can be written (made or replaced), ending in one of
    ``suffixes`` (lower case, with the dot) when any are given."""
    path = Path(path)
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(option, str(path), "a file ending in " + ", ".join(suffixes))
    if path.is_dir():
        raise InputError(option, str(path), "a file name (it is a folder)")
    _check_parents(option, path)
    if path.exists() and not os.access(path, os.W_OK):
        raise InputError(option, str(path), "a file you may write to")
    return path


def figure_file(option: str, path: str | Path) -> Path:
    """``path`` as a figure file in a format Matplotlib writes (``.png``, ``.pdf``,
    ``.svg``, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    formats = tuple(f".{name}" for name in FigureCanvasBase.get_supported_filetypes())
    return output_file(option, path, formats)


def input_file(option: str, path: str | Path) -> Path:
    """``path`` as an existing file that can be read."""
    path = Path(path)
    if not path.exists():
        raise InputError(option, str(path), "an existing file")
    if not path.is_file():
        raise InputError(option, str(path), "a file (it is a folder)" if path.is_dir()
                         else "a regular file")
    if not os.access(path, os.R_OK):
        raise InputError(option, str(path), "a file you may read")
    return path

