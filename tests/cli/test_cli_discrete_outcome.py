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
