"""Turn the failures a user can cause into one line and exit status 2 at the command line.

Two kinds are caught: grainlab's own errors (:class:`~grainlab.errors.GrainlabError`, which
name the field or option and what is allowed) and the operating system's refusals
(:class:`OSError` carrying an error number: a file that exists, a folder under a file, a
read-only file system, no permission, a full disk), printed as ``FILE: what went wrong``.
Anything else is a bug in grainlab and keeps its traceback.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TypeVar

import typer
from rich.console import Console
from rich.markup import escape

from grainlab.errors import GrainlabError

F = TypeVar("F", bound=Callable)
_console = Console(stderr=True)


def os_error_line(error: OSError) -> str:
    """``'FILE: reason'`` for an operating-system error (``'FILE -> OTHER: reason'`` when it
    names two files).

    >>> os_error_line(FileExistsError(17, "File exists", "out"))
    "'out': File exists"
    """
    reason = error.strerror or str(error)
    names = [repr(str(name)) for name in (error.filename, error.filename2) if name is not None]
    return f"{' -> '.join(names)}: {reason}" if names else reason


def print_error(message: str) -> None:
    """Print ``message`` as one red-labelled line on stderr (never wrapped)."""
    _console.print(f"[bold red]error:[/] {escape(message)}", soft_wrap=True)


def friendly_errors(command: F) -> F:
    """Decorator: a :class:`GrainlabError`, or an :class:`OSError` that carries an error
    number or a file name, becomes one line on stderr and exit code 2 (module docstring)."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except GrainlabError as error:
            print_error(str(error))
            raise typer.Exit(code=2) from None
        except OSError as error:
            if error.errno is None and error.filename is None:
                raise  # not a refusal by the system: a bug, keep the traceback
            print_error(os_error_line(error))
            raise typer.Exit(code=2) from None

    return wrapper  # type: ignore[return-value]
