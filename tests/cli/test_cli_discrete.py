"""``grainlab triaxial | compaction | oedometer | resume | vtk`` as a user runs them."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.result.test_result import read_test_result

runner = CliRunner()


def test_oedometer_runs_to_the_end_with_a_figure(tmp_path):
    out = tmp_path / "oedo"
    result = runner.invoke(app, [
        "oedometer", "--out", str(out), "-n", "30", "--seed", "3", "--axial-strain", "0.002",
        "--inertia", "0.01", "--sweep", "serial", "--no-progress", "--record-every", "2"])
    assert result.exit_code == 0, result.output
    table = read_test_result(out / "results.csv").table
    assert list(dict.fromkeys(table["stage"])) == ["compaction", "loading"]
    loading = table[table["stage"] == "loading"]
    compaction = table[table["stage"] == "compaction"]
    # strains from the consolidated box (the end of compaction)
    assert loading["eps_zz"].iloc[-1] >= 0.002 * 0.99
    # rigid grains, lateral walls fixed: the vertical stress climbs steeply
    assert loading["wall_sigma_zz"].iloc[-1] > 2 * compaction["wall_sigma_zz"].iloc[-1]
    # lateral walls fixed: no lateral strain during loading
    assert abs(loading["eps_xx"].iloc[-1]) < 1e-12
    assert (out / "curves.png").stat().st_size > 0
    exported = runner.invoke(app, ["vtk", str(out), "--out", str(tmp_path / "vtk")])
    assert exported.exit_code == 0, exported.output
    assert (tmp_path / "vtk" / "particles_000000.vtu").exists()


@pytest.mark.parametrize("arguments, field", [
    (["triaxial", "--mu", "-0.1"], "solver.friction"),
    (["triaxial", "-n", "0"], "sample.n_particles"),
    (["triaxial", "--shape", "cube"], "--shape"),
    (["compaction", "--d-min", "-1e-3"], "sample.d_min"),
    (["resume", "no-such-run"], "run folder"),
])
def test_bad_input_is_one_message_naming_the_field(tmp_path, arguments, field):
    result = runner.invoke(app, [*arguments, "--out", str(tmp_path / "r")]
                           if arguments[0] != "resume" else arguments)
    assert result.exit_code == 2, result.output
    assert field in result.output and "Traceback" not in result.output
