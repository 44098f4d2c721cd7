"""The study report's angular distributions and force PDFs of a point repeated with other
packing seeds: averaged over the residual-window snapshots of every seed, whether a seed's
snapshots are still there or only its slimmed digest."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.run_digest import DIGEST
from grainlab.report.study_report import write_study_report
from grainlab.study.study_runner import Study
from grainlab.study.study_spec import StudySpec
from grainlab.study.study_summary import pooled_replicas, study_summary

pytestmark = pytest.mark.long


def spec() -> StudySpec:
    """One shape at two packing seeds, and another shape at one."""
    return StudySpec.model_validate({
        "study": {"name": "tiny", "parameter": "eta", "window": [0.015, 0.03]},
        "base": {"sample": {"n_particles": 24, "seed": 3, "size_ratio": 3.0},
                 "test": {"eps_q_max": 0.03},
                 "output": {"snapshot_every": 10, "checkpoint_every": 50}},
        "samples": [{"name": "a", "value": 0.0},
                    {"name": "b", "value": 0.1, "set": {"sample": {"seed": 4}}},
                    {"name": "a-seed1", "value": 0.0, "replica_of": "a",
                     "set": {"sample": {"seed": 5}}}]})


def _heading(report: str, title: str, name: str) -> str:
    return next(line for line in report.splitlines()
                if line.startswith(f"### {title}, {name} ("))


def test_a_points_distributions_pool_the_snapshots_of_all_its_seeds(tmp_path):
    study = Study.create(tmp_path / "s", spec())
    assert study.run(workers=1, progress=False, only=["a", "b"]).complete
    result = CliRunner().invoke(app, ["study", "slim", str(study.folder)])  # a and b slimmed
    assert result.exit_code == 0, result.output
    kept = json.loads((study.sample_folder("a") / DIGEST / "window.json").read_text())
    assert study.run(workers=1, progress=False, only=["a-seed1"]).complete  # not slimmed

    from grainlab.analysis.window_average import WindowAverage
    from grainlab.lab.discrete_run import SNAPSHOTS
    replica = WindowAverage(tuple(study.spec.study.window)).run(
        study.sample_folder("a-seed1") / SNAPSHOTS).n_snapshots
    assert kept["n_snapshots"] >= 1 and replica >= 1

    report = write_study_report(study, pooled_replicas(study_summary(study))).read_text()
    for title in ("Angular distributions", "Force PDFs"):
        pooled = _heading(report, title, "a")
        assert f"(2 packing seeds, {kept['n_snapshots'] + replica} snapshots" in pooled
        alone = _heading(report, title, "b")
        assert "packing seeds" not in alone
    assert (study.folder / "report" / "polar_a.png").stat().st_size > 0
