"""Turn grainlab's errors into short messages and exit status 2 at the command line."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TypeVar

import typer
from rich.console import Console

from grainlab.errors import GrainlabError

F = TypeVar("F", bound=Callable)
_console = Console(stderr=True)


def friendly_errors(command: F) -> F:
    """Decorator: a :class:`GrainlabError` becomes one red paragraph and exit code 2."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except GrainlabError as error:
            _console.print(f"[bold red]error:[/] {error}")
            raise typer.Exit(code=2) from None

    return wrapper  # type: ignore[return-value]
