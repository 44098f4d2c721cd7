"""``grainlab triaxial --shape polyhedron`` as a user runs it."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.run_config import RunConfig
from grainlab.result.test_result import read_test_result

runner = CliRunner()


def test_polyhedron_triaxial_from_the_command_line(tmp_path):
    out = tmp_path / "poly"
    # a faster compaction than the defaults (a few seconds in all)
    RunConfig.model_validate({"solver": {"compaction": {"inertia_number": 0.05,
                                                        "time_step_factor": 0.02}}}
                             ).write(tmp_path / "fast.toml")
    result = runner.invoke(app, [
        "triaxial", "--out", str(out), "--config", str(tmp_path / "fast.toml"), "--shape",
        "polyhedron", "--faces", "30", "--templates", "3", "-n", "8", "--eps-q", "0.01",
        "--inertia", "0.01", "--seed", "2", "--sweep", "serial", "--no-progress",
        "--record-every", "10"])
    assert result.exit_code == 0, result.output
    assert "polyhedra of 30 faces" in result.output and "contact types fv" in result.output
    table = read_test_result(out / "results.csv").table
    assert list(dict.fromkeys(table["stage"])) == ["compaction", "shear"]
    assert table["eps_q"].iloc[-1] >= 0.01
    assert {"z_c_points", "fraction_ff"} <= set(table.columns)


@pytest.mark.parametrize("arguments, field", [
    (["triaxial", "--shape", "polyhedron", "--faces", "31"], "--faces"),
    (["compaction", "--shape", "polyhedron", "--faces", "6"], "--faces"),
    (["oedometer", "--shape", "polyhedron", "--templates", "-1"], "--templates"),
])
def test_bad_polyhedron_options_name_the_field(tmp_path, arguments, field):
    result = runner.invoke(app, [*arguments, "--out", str(tmp_path / "r")])
    assert result.exit_code == 2, result.output
    assert field in result.output and "Traceback" not in result.output
