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


def test_the_config_and_column_references_hold_every_key_and_column(tmp_path):
    """docs/_registries.py: every key of a run config (walked from a config's own dump) and
    every standard column is on its page, each with what the registry says of it."""
    from grainlab.lab.run_config import RunConfig
    from grainlab.result.columns import COLUMNS

    written = runpy.run_path(str(DOCS / "_registries.py"))
    keys_page, columns_page = tmp_path / "keys.md", tmp_path / "columns.md"
    written["write_config_reference"](keys_page)
    written["write_columns_reference"](columns_page)
    keys = keys_page.read_text(encoding="utf-8")

    def leaves(data, prefix=""):
        for name, value in data.items():
            key = f"{prefix}.{name}" if prefix else name
            yield from leaves(value, key) if isinstance(value, dict) else [key]

    for key in leaves(RunConfig.model_validate({}).model_dump()):
        assert f"| `{key}` |" in keys, key
    assert "| `test.sigma0` | `float` | `10000.0` | > 0 | `--sigma0`" in keys
    tests_page = tmp_path / "tests.md"
    written["write_lab_tests_reference"](tests_page, tmp_path / "lab-tests")
    lab_tests = tests_page.read_text(encoding="utf-8")
    from grainlab.lab.run_config import TEST_KINDS, RunConfig

    for kind in TEST_KINDS:
        assert f"## `{kind}`" in lab_tests and f"`grainlab test {kind}" in lab_tests
        page = (tmp_path / "lab-tests" / f"{kind}.md").read_text(encoding="utf-8")
        assert page.startswith("---\nfile_format: mystnb") and f"# The `{kind}` test" in page
        assert f"'kind': '{kind}'" in page and "write_run_figures(folder, result)" in page
    assert "cubical test at sigma_3 = 10000 Pa and b = 0.5" in lab_tests
    # each page's small run asks for targets its test reads
    for kind, targets in written["SMALL_TARGETS"].items():
        RunConfig.model_validate({"test": {"kind": kind, **targets},
                                  "sample": {"boundary": "periodic"}})
    columns = columns_page.read_text(encoding="utf-8")
    for name, column in COLUMNS.items():
        assert f"| `{name}` | {column.unit} |" in columns
