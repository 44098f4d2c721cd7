"""``grainlab compile``: its parts, and a part it does not know named in one line."""

from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.cli.precompile import PARTS

runner = CliRunner()


def test_compile_names_an_unknown_part():
    result = runner.invoke(app, ["compile", "--part", "discrete,nope"])
    assert result.exit_code == 2
    assert "--part" in result.output and "nope" in result.output
    assert all(part in " ".join(result.output.split()) for part in PARTS)


def test_compile_help_says_what_it_does():
    result = runner.invoke(app, ["compile", "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0 and "cached" in result.output
