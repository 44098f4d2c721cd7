"""A slimmed study: its ended samples lose their snapshots and checkpoints, and keep what
the summary and the report read, so that the same summary and figures come out of the small
folder, moved elsewhere, and the runner never runs the slimmed samples again."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.discrete_run import RESULTS_H5, SNAPSHOTS
from grainlab.lab.run_checkpoint import CHECKPOINT
from grainlab.lab.run_digest import DIGEST
from grainlab.report.study_report import write_study_report
from grainlab.study.sample_task import sample_state
from grainlab.study.study_runner import Study
from grainlab.study.study_spec import StudySpec
from grainlab.study.study_summary import study_summary

pytestmark = pytest.mark.long


def spec() -> StudySpec:
    """Two samples: one run and slimmed, one never run (left as it is)."""
    return StudySpec.model_validate({
        "study": {"name": "tiny", "parameter": "eta", "window": [0.015, 0.03]},
        "base": {"sample": {"n_particles": 24, "seed": 3, "size_ratio": 3.0},
                 "test": {"eps_q_max": 0.03},
                 "output": {"snapshot_every": 10, "checkpoint_every": 50}},
        "samples": [{"name": n, "value": 0.1 * k, "set": {"sample": {"seed": 3 + k}}}
                    for k, n in enumerate(("a", "b"))]})


def test_a_slimmed_study_keeps_its_summary_and_figures_and_goes_on_elsewhere(tmp_path):
    study = Study.create(tmp_path / "s", spec())
    assert study.run(workers=1, progress=False, only=["a"]).complete
    runs = [study.sample_folder("a")]
    size = sum(p.stat().st_size for run in runs for p in run.rglob("*") if p.is_file())
    assert all(list(run.glob("shapes-*.h5")) for run in runs)

    # the command writes the summary and report from the snapshots, then slims
    result = CliRunner().invoke(app, ["study", "slim", str(study.folder)])
    assert result.exit_code == 0, result.output
    assert "slimmed 1 sample(s)" in result.output
    before = pd.read_csv(study.folder / "summary.csv")
    drawn = sorted(p.name for p in (study.folder / "report").glob("*.png"))
    assert any(n.startswith("polar_") for n in drawn)
    assert any(n.startswith("force_network_") for n in drawn)
    for run in runs:
        assert not (run / SNAPSHOTS).exists() and not (run / CHECKPOINT).exists()
        assert not list(run.glob("shapes-*.h5"))  # the checkpoints' shape library
        assert (run / RESULTS_H5).exists() and sample_state(run) == "ended"
        assert (run / DIGEST / "snapshots.h5").stat().st_size > 0
    assert sum(p.stat().st_size for run in runs for p in run.rglob("*") if p.is_file()) \
        < 0.5 * size

    # moved to another machine: the same summary, the same figures, nothing run again
    shutil.move(tmp_path / "s", tmp_path / "elsewhere")
    moved = Study.open(tmp_path / "elsewhere")
    study_summary(moved)
    after = pd.read_csv(moved.folder / "summary.csv")
    assert list(after.columns) == list(before.columns)
    for column in before.columns:
        if pd.api.types.is_numeric_dtype(before[column]):
            np.testing.assert_array_equal(after[column].to_numpy(float),
                                          before[column].to_numpy(float), err_msg=column)
        else:
            assert after[column].tolist() == before[column].tolist(), column
    assert any(c.startswith("a_c") and c.endswith("_residual") for c in after.columns)
    for png in (moved.folder / "report").glob("*.png"):
        png.unlink()
    report = write_study_report(moved, after)
    assert sorted(p.name for p in report.parent.glob("*.png")) == drawn
    stamp = (moved.sample_folder("a") / RESULTS_H5).stat().st_mtime_ns
    outcome = moved.run(workers=1, progress=False, only=["a"])
    assert outcome.complete and outcome.skipped == ["a"] and not outcome.ran
    assert (moved.sample_folder("a") / RESULTS_H5).stat().st_mtime_ns == stamp
    assert sample_state(moved.sample_folder("b")) == "new"

    # asked with another core margin: the digest's core values were read at the former one,
    # so the row says so and holds none of them
    data = moved.spec.model_dump(mode="json")
    data["study"]["core_margin"] = 2.5
    other = Study.create(moved.folder, StudySpec.model_validate(data))
    row = study_summary(other).iloc[0]
    assert "slimmed with another core margin (1.5 <d>)" in row["note"]
    assert row["core_margin_diameters"] == 2.5
    core = [c for c in row.index if "_core" in c and c != "core_margin_diameters"]
    assert core and all(np.isnan(float(row[c])) for c in core)
    for column in ("q_over_trace_residual", "a_c_residual", "z_residual"):
        assert row[column] == before[column].iloc[0], column  # the whole box's, as kept


def test_a_kept_window_average_of_the_core_serves_its_own_margin_only(tmp_path):
    """digest/window.json names the core margin it was averaged with; a whole-box average (a
    periodic cell) holds for any margin, and one that names none was kept at 1."""
    import json

    from grainlab.lab.run_digest import WINDOW, read_window

    tables = tmp_path / DIGEST / WINDOW
    tables.mkdir(parents=True)
    pd.DataFrame({"theta_deg": [2.5], "c": [1.0]}).to_csv(tables / "polar.csv", index=False)
    kept = {"window": [0.6, 0.9], "n_snapshots": 3, "names": ["polar"]}
    for held, where, asked, served in [(1.5, "core", 1.5, True), (1.5, "core", 1.0, False),
                                       (None, "core", 1.0, True), (None, "core", 1.5, False),
                                       (1.0, "whole box", 2.0, True)]:
        record = dict(kept, where=where) | ({} if held is None else {"core_margin": held})
        (tmp_path / DIGEST / f"{WINDOW}.json").write_text(json.dumps(record))
        found = read_window(tmp_path, (0.6, 0.9), asked)
        assert (found is not None) == served, (held, where, asked)
        if served:
            assert found[1] == 3 and found[2] == where
            assert found[0]["polar"]["c"].tolist() == [1.0]
    assert read_window(tmp_path, (0.5, 0.9), 1.0) is None  # another window
