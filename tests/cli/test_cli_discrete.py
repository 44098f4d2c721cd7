"""``grainlab triaxial | compaction | oedometer | resume | vtk`` as a user runs them."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.run_config import RunConfig
from grainlab.lab.stage_numerics import SHEAR
from grainlab.result.test_result import read_test_result

runner = CliRunner()


def _unsolved_rigid_oedometer(result) -> None:
    """Rigid grains between fixed walls cannot follow the strain: most loading steps end at
    the sweep cap unsolved, and the run says so (exit 3), naming that alone."""
    assert result.exit_code == 3, result.output
    said = " ".join(result.output.split())
    why = [line for line in said.split("why: ")[1:]]
    assert why and all("ended at the solver's cap" in w and "capped_share_limit" in w
                       for w in why), said


def test_oedometer_runs_to_the_end_with_a_figure(tmp_path):
    out = tmp_path / "oedo"
    result = runner.invoke(app, [
        "oedometer", "--out", str(out), "-n", "30", "--seed", "3", "--axial-strain", "0.002",
        "--inertia", "0.01", "--sweep", "serial", "--no-progress", "--record-every", "2"])
    _unsolved_rigid_oedometer(result)
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


def test_oedometer_summary_and_figure_speak_of_k0(tmp_path):
    out = tmp_path / "oedo"
    result = runner.invoke(app, [
        "oedometer", "--out", str(out), "-n", "30", "--seed", "3", "--axial-strain", "0.002",
        "--unload-strain", "0.001", "--inertia", "0.01", "--sweep", "serial", "--no-progress",
        "--record-every", "50"])
    _unsolved_rigid_oedometer(result)
    said = " ".join(result.output.split())  # rich wraps long lines
    # each stage ends on its strain though a record was due every 50 steps only
    assert "loading: to eps_zz 0.002 (asked 0.002)" in said
    assert "unloading: by 0.001 (asked 0.001) to eps_zz 0.001" in said
    assert "K0" in said and "at the end of loading" in said and "at the end of unloading" in said
    assert "rigid grains" in said and "degenerate" in said
    assert "shear: peak" not in said  # no shear summary (solver.shear names the numerics)
    table = read_test_result(out / "results.csv").table
    assert list(dict.fromkeys(table["stage"])) == ["compaction", "loading", "unloading"]
    assert "K0" in table
    assert (out / "curves.png").stat().st_size > 0


def test_oedometer_help_defines_k0_and_warns_about_rigid_grains():
    result = runner.invoke(app, ["oedometer", "--help"], terminal_width=100)
    said = " ".join(result.output.split())
    assert "K0 = (sigma_xx + sigma_yy) / (2 sigma_zz)" in said
    assert "degenerate" in said and "rigid grains" in said


@pytest.mark.parametrize("arguments, field", [
    (["triaxial", "--mu", "-0.1"], "--mu"),
    (["triaxial", "-n", "0"], "--n-particles"),
    (["triaxial", "--shape", "cube"], "--shape"),
    (["compaction", "--d-min", "-1e-3"], "--d-min"),
    (["resume", "no-such-run"], "run folder"),
])
def test_bad_input_is_one_message_naming_the_field(tmp_path, arguments, field):
    result = runner.invoke(app, [*arguments, "--out", str(tmp_path / "r")]
                           if arguments[0] != "resume" else arguments)
    assert result.exit_code == 2, result.output
    assert field in result.output and "Traceback" not in result.output


def test_the_solver_options_set_the_numerics_of_the_stages_the_command_runs(tmp_path):
    out = tmp_path / "compaction"
    result = runner.invoke(app, ["compaction", "-n", "8", "--seed", "1", "--tolerance", "2e-4",
                                 "--sweep", "serial", "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, result.output
    solver = RunConfig.read(out / "config.toml").solver
    assert solver.compaction.tolerance == 2e-4 and solver.shear.tolerance == SHEAR.tolerance
    texts = {}
    for command in ("triaxial", "compaction", "resume"):
        shown = runner.invoke(app, [command, "--help"], env={"COLUMNS": "200"}).output
        texts[command] = " ".join(shown.replace("│", " ").split())
    for key in ("solver.shear.friction", "solver.shear.tolerance", "solver.shear.inertia_number",
                "solver.shear.max_iterations", "solver.compaction.tolerance"):
        assert key in texts["triaxial"], key
    assert "(solver.compaction.tolerance)" in texts["compaction"]
    assert "solver.shear.tolerance=1e-5" in texts["resume"]
    assert "solver.compaction.KEY and solver.shear.KEY" in texts["resume"]
