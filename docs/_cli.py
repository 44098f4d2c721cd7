"""The command-line reference, written from the CLI's own help when the site builds
(docs/reference/cli.md includes what :func:`write_cli_reference` writes), so that no option
is described twice."""

from __future__ import annotations

from pathlib import Path

import typer
from typer.testing import CliRunner

from grainlab.cli.main import app


def _paths(group, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    """Every command's words, groups first then their commands, in the CLI's order."""
    paths = []
    for name, command in getattr(group, "commands", {}).items():
        paths.append((*prefix, name))
        paths += _paths(command, (*prefix, name))
    return paths


def write_cli_reference(path: Path) -> None:
    """One section per command: its ``--help`` text as the terminal shows it (100 columns,
    no colour)."""
    runner = CliRunner()
    env = {"COLUMNS": "100", "NO_COLOR": "1", "TERM": "dumb"}
    sections = []
    for words in _paths(typer.main.get_command(app)):
        result = runner.invoke(app, [*words, "--help"], env=env, prog_name="grainlab")
        if result.exit_code != 0:
            raise RuntimeError(f"grainlab {' '.join(words)} --help failed:\n{result.output}")
        level = "#" * (len(words) + 1)
        sections.append(f"{level} `grainlab {' '.join(words)}`\n\n```text\n"
                        f"{result.output.rstrip()}\n```\n")
    path.write_text("\n".join(sections), encoding="utf-8")
