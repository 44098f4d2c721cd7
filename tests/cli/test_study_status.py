"""``grainlab study status``: each sample's state from its run folder and its progress."""

from __future__ import annotations

import json
import time

from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.study.series_presets import series_spec
from grainlab.study.study_runner import Study


def test_status_reads_each_sample_from_its_folder(tmp_path):
    study = Study.create(tmp_path / "alpha", series_spec("angularity", n_particles=40))
    ended, running, stopped = (study.sample_folder(n) for n in ("S1", "S2", "S3"))
    for folder in (ended, running, stopped):
        folder.mkdir(parents=True)
    (ended / "results.h5").write_bytes(b"")
    (running / "checkpoint.h5").write_bytes(b"")
    (stopped / "checkpoint.h5").write_bytes(b"")
    now = time.time()
    (running / "progress.json").write_text(json.dumps(
        {"stage": "shear", "fraction": 0.42, "state": "running", "time": now}))
    (stopped / "progress.json").write_text(json.dumps(
        {"stage": "compaction", "fraction": 0.1, "state": "running", "time": now - 3600}))
    result = CliRunner().invoke(app, ["study", "status", str(tmp_path)], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    lines = {line.split("│")[1].strip(): line for line in result.output.splitlines()
             if line.count("│") > 4}
    assert "ended" in lines["S1"]
    assert "running" in lines["S2"] and "shear" in lines["S2"] and "42%" in lines["S2"]
    # progress written an hour ago: the run has stopped, its checkpoint waits
    assert "partial" in lines["S3"] and "compaction" in lines["S3"]
    assert "new" in lines["S4"]
    assert "1 of 8 samples ended" in result.output


def test_status_refuses_a_folder_without_a_study(tmp_path):
    result = CliRunner().invoke(app, ["study", "status", str(tmp_path)])
    assert result.exit_code != 0 and "study.toml" in result.output
