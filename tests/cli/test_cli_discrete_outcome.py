"""A discrete run at the command line says what it did: outcome in words, exit 3 when the
outcome is not the one asked, exit 2 when it cannot go on (no checkpoint, damaged checkpoints,
a target the box cannot take), and never destroys a run's files without ``--restart``."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app

runner = CliRunner()

TINY = """\
[sample]
n_particles = 30
seed = 3

[test]
kind = "{kind}"

[solver]
sweep = "serial"
inertia_number = 0.01
max_stage_steps = {max_stage_steps}

[output]
record_every = 5
checkpoint_every = 10
"""


def _config(tmp_path, kind="compaction", max_stage_steps=20):
    path = tmp_path / "input.toml"
    path.write_text(TINY.format(kind=kind, max_stage_steps=max_stage_steps))
    return path


def _said(result) -> str:
    return " ".join(result.output.split())  # rich wraps long lines


def test_a_stage_cut_by_max_stage_steps_is_not_a_success(tmp_path):
    out = tmp_path / "run"
    result = runner.invoke(app, ["compaction", "--out", str(out), "--config",
                                 str(_config(tmp_path)), "--no-progress"])
    said = _said(result)
    assert result.exit_code == 3, result.output
    assert "max_stage_steps" in said and "before settling" in said
    assert "unbalanced force ratio" in said
    assert "[{" not in said and "'reason'" not in said  # words, not a list of dicts
    assert "--set solver.max_stage_steps=" in said
    assert (out / "checkpoint.h5").exists()


def test_resume_without_a_checkpoint_stops_and_keeps_the_files(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    _config(tmp_path).rename(out / "config.toml")
    for name in ("results.csv", "snapshots.h5", "run.log"):
        (out / name).write_text(f"{name} of a run killed before its first checkpoint")
    result = runner.invoke(app, ["resume", str(out), "--no-progress"])
    said = _said(result)
    assert result.exit_code == 2, result.output
    assert "no checkpoint" in said and "--restart" in said
    for name in ("results.csv", "snapshots.h5", "run.log"):
        assert (out / name).read_text().startswith(name), name


@pytest.mark.parametrize("damage", ["truncated", "empty", "random"])
def test_a_damaged_checkpoint_is_one_message_naming_the_file(tmp_path, damage):
    out = tmp_path / "run"
    first = runner.invoke(app, ["compaction", "--out", str(out), "--config",
                                str(_config(tmp_path, max_stage_steps=10)), "--no-progress"])
    assert first.exit_code == 3, first.output
    path = out / "checkpoint.h5"
    for name in ("checkpoint.h5", "checkpoint.prev.h5"):
        if (out / name).exists():
            data = (out / name).read_bytes()
            (out / name).write_bytes({"truncated": data[: len(data) // 2], "empty": b"",
                                      "random": bytes(range(256)) * 8}[damage])
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    result = runner.invoke(app, ["resume", str(out), "--no-progress"])
    said = _said(result)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and str(path.name) in said and "damaged" in said
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before


def test_a_target_that_flattens_the_box_is_refused_before_the_run(tmp_path):
    out = tmp_path / "run"
    result = runner.invoke(app, ["triaxial", "--out", str(out), "-n", "30", "--seed", "3",
                                 "--eps-q", "1.5", "--no-progress"])
    said = _said(result)
    assert result.exit_code == 2, result.output
    assert "--eps-q = 1.5" in said and "largest diameter" in said  # the flag as typed
    assert not (out / "checkpoint.h5").exists()


# -- a blow-up names the setting that most likely caused it --------------------------------
QUICK = """\
[sample]
n_particles = 30
seed = 3

[test.quasi_static]
stress_tolerance = 0.5
unbalanced_force = inf
kinetic_energy = inf

[solver]
sweep = "serial"
"""
"""30 spheres whose compaction ends once the stresses are within 50 % of sigma0."""


def _blow_up_line(result) -> str:
    """The one line (never wrapped) that says the run blew up, with exit status 3."""
    assert result.exit_code == 3, result.output
    assert "Traceback" not in result.output
    lines = [line for line in result.output.splitlines() if line.startswith("blow-up:")]
    assert len(lines) == 1, result.output
    return lines[0]


def test_a_blow_up_from_a_long_time_step_names_dt(tmp_path):
    (tmp_path / "quick.toml").write_text(QUICK)
    out = tmp_path / "run"
    result = runner.invoke(app, ["triaxial", "--config", str(tmp_path / "quick.toml"),
                                 "--dt", "1e-2", "--eps-q", "0.02", "--out", str(out),
                                 "--no-progress"])
    line = _blow_up_line(result)
    assert "Likely cause: the time step solver.dt = 0.01 s (--dt) is" in line
    assert "times this compaction stage's own step" in line and "leave --dt out" in line
    assert "The box is only" not in line  # not put down to the box
    assert f"set solver.dt = 0 in {out / 'config.toml'}" in line
    assert f"`grainlab resume {out} --restart`" in line


def test_a_blow_up_from_a_low_sweep_cap_names_max_iterations(tmp_path):
    (tmp_path / "quick.toml").write_text(QUICK)
    out = tmp_path / "run"
    result = runner.invoke(app, ["triaxial", "--config", str(tmp_path / "quick.toml"),
                                 "--max-iterations", "1", "--eps-q", "0.02", "--out", str(out),
                                 "--no-progress"])
    line = _blow_up_line(result)
    assert "steps of this shear stage ended unconverged at the sweep cap " \
           "solver.shear.max_iterations = 1 (--max-iterations): raise it" in line
    assert "The box is only" not in line
    assert f"`grainlab resume {out} --set solver.shear.max_iterations=2000`" in line
    assert (out / "checkpoint.h5").exists()  # the last good one, to resume from


# -- grainlab vtk --------------------------------------------------------------------------
def test_vtk_refuses_a_damaged_checkpoint_and_says_how_to_recover(tmp_path):
    out = tmp_path / "run"
    first = runner.invoke(app, ["compaction", "--out", str(out), "--config",
                                str(_config(tmp_path, max_stage_steps=20)), "--no-progress"])
    assert first.exit_code == 3, first.output
    assert (out / "checkpoint.prev.h5").exists()
    data = (out / "checkpoint.h5").read_bytes()
    (out / "checkpoint.h5").write_bytes(data[: len(data) // 2])
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    result = runner.invoke(app, ["vtk", str(out)])
    said = _said(result)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1
    assert f"{out / 'checkpoint.h5'} is damaged (truncated" in said
    assert "checkpoint.prev.h5 (step 10) is older than the run's snapshots" in said
    assert f"`grainlab resume {out}`" in said and f"`grainlab vtk {out}`" in said
    assert not (out / "vtk-checkpoint").exists()  # nothing drawn
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    # the advice works: resumed, the run has a checkpoint that vtk draws
    assert runner.invoke(app, ["resume", str(out), "--no-progress"]).exit_code == 3
    drawn = runner.invoke(app, ["vtk", str(out)])
    assert drawn.exit_code == 0, drawn.output
    assert (out / "vtk-checkpoint" / "particles_000000.vtu").exists()


def test_vtk_on_a_folder_without_a_run_says_how_to_start_one(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    result = runner.invoke(app, ["vtk", str(empty)])
    said = _said(result)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1
    assert f"run folder = '{empty}'" in said and "holds no run" in said
    assert f"`grainlab triaxial --out {empty}`" in said and "--restart" not in said
    assert list(empty.iterdir()) == []
