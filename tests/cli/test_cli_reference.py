"""The site's command-line reference (docs/_cli.py) is written from every command's own
``--help``: each command, nested ones included, appears with its options."""

from __future__ import annotations

import runpy
from pathlib import Path

import typer

from grainlab.cli.main import app

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_the_cli_reference_holds_every_command_with_its_help(tmp_path):
    write = runpy.run_path(str(DOCS / "_cli.py"))["write_cli_reference"]
    page = tmp_path / "cli_commands.md"
    write(page)
    text = page.read_text(encoding="utf-8")
    group = typer.main.get_command(app)
    for name, command in group.commands.items():
        assert f"`grainlab {name}`" in text
        for sub in getattr(command, "commands", {}):
            assert f"`grainlab {name} {sub}`" in text
    assert "Usage: grainlab theory-b-sweep" in text and "--distribution" in text
