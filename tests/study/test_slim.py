"""A slimmed study: its ended samples lose their snapshots and checkpoints, and keep what
the summary and the report read, so that the same summary and figures come out of the small
folder and the study goes on with the samples it has not run."""

from __future__ import annotations

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
    return StudySpec.model_validate({
        "study": {"name": "tiny", "parameter": "eta", "window": [0.02, 0.04]},
        "base": {"sample": {"n_particles": 30, "seed": 3, "size_ratio": 3.0},
                 "test": {"eps_q_max": 0.04},
                 "output": {"snapshot_every": 10, "checkpoint_every": 50}},
        "samples": [{"name": n, "value": 0.1 * k, "set": {"sample": {"seed": 3 + k}}}
                    for k, n in enumerate(("a", "b"))]})


def test_a_slimmed_study_keeps_its_summary_and_figures_and_goes_on(tmp_path):
    study = Study.create(tmp_path / "s", spec())
    assert study.run(workers=1, progress=False, only=("a",)).complete
    before = study_summary(study)
    report = write_study_report(study, before)
    drawn = sorted(p.name for p in report.parent.glob("*.png"))
    assert any(n.startswith("polar_") for n in drawn)
    assert any(n.startswith("force_network_") for n in drawn)
    run = study.sample_folder("a")
    size = sum(p.stat().st_size for p in run.rglob("*") if p.is_file())

    result = CliRunner().invoke(app, ["study", "slim", str(study.folder)])
    assert result.exit_code == 0, result.output
    assert "slimmed 1 sample(s)" in result.output
    assert not (run / SNAPSHOTS).exists() and not (run / CHECKPOINT).exists()
    assert (run / RESULTS_H5).exists() and sample_state(run) == "ended"
    assert sum(p.stat().st_size for p in run.rglob("*") if p.is_file()) < 0.5 * size

    after = study_summary(study)
    assert list(after.columns) == list(before.columns)
    for column in before.columns:
        if pd.api.types.is_numeric_dtype(before[column]):
            np.testing.assert_array_equal(after[column].to_numpy(float),
                                          before[column].to_numpy(float), err_msg=column)
        else:
            assert after[column].tolist() == before[column].tolist(), column
    assert any(c.endswith("_residual") and c.startswith("a_c") for c in after.columns)
    for png in report.parent.glob("*.png"):
        png.unlink()
    write_study_report(study, after)
    assert sorted(p.name for p in report.parent.glob("*.png")) == drawn

    # the study goes on: the slimmed sample is not run again, the other one is
    stamp = (run / RESULTS_H5).stat().st_mtime_ns
    outcome = study.run(workers=1, progress=False)
    assert outcome.complete and outcome.skipped == ["a"] and outcome.ran == ["b"]
    assert (run / RESULTS_H5).stat().st_mtime_ns == stamp
    assert not (run / DIGEST / "snapshots.h5").stat().st_size == 0
    assert len(study_summary(study)) == 2
