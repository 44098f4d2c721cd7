"""A study of tiny samples on a local Dask cluster: it runs end to end, survives a worker
killed mid-run, and an interrupted study goes on without rerunning the samples that ended."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.lab.discrete_run import RESULTS_H5
from grainlab.lab.run_checkpoint import CHECKPOINT
from grainlab.report.study_report import write_study_report
from grainlab.study import study_runner
from grainlab.study.study_runner import Study, StudyInterrupted
from grainlab.study.study_spec import StudySpec
from grainlab.study.study_summary import study_summary

pytestmark = pytest.mark.long


def tiny_spec(names=("a", "b")) -> StudySpec:
    """Two small samples sheared to eps_q = 0.05: the runner's bookkeeping, not physics."""
    return StudySpec.model_validate({
        "study": {"name": "tiny", "parameter": "eta", "window": [0.025, 0.05]},
        "base": {"sample": {"n_particles": 30, "seed": 3, "size_ratio": 3.0},
                 "test": {"eps_q_max": 0.05},
                 "output": {"snapshot_every": 10, "checkpoint_every": 10}},
        "samples": [{"name": n, "value": 0.1 * k, "set": {"sample": {"seed": 3 + k}}}
                    for k, n in enumerate(names)]})


def results_stamp(study: Study, name: str) -> tuple[int, int]:
    stat = os.stat(study.sample_folder(name) / RESULTS_H5)
    return stat.st_mtime_ns, stat.st_ino


def test_worker_killed_mid_run_resumes_and_ended_samples_are_not_rerun(tmp_path, monkeypatch):
    # the study looks at its samples every 0.05 s: a sample says it runs from its first
    # record, with a checkpoint every 10 steps, for hundreds of steps
    monkeypatch.setattr(study_runner, "DISPLAY_PERIOD", 0.05)
    study = Study.create(tmp_path / "s", tiny_spec())
    killed: list[int] = []

    def kill_once(progress):
        a = progress["a"]
        if killed or a.get("state") != "running":
            return
        if (study.sample_folder("a") / CHECKPOINT).exists():
            killed.append(a["pid"])
            os.kill(a["pid"], signal.SIGKILL)

    outcome = study.run(workers=2, progress=False, on_update=kill_once)
    assert killed, "the test never saw sample a running with a checkpoint"
    assert outcome.complete and sorted(outcome.ran) == ["a", "b"]
    assert "a" in outcome.resumed
    assert "resumed from" in (study.sample_folder("a") / "run.log").read_text()
    with h5py.File(study.sample_folder("a") / RESULTS_H5) as f:
        assert f.attrs["outcome_status"] == "as asked"
    stamps = {n: results_stamp(study, n) for n in ("a", "b")}
    again = Study.create(tmp_path / "s", tiny_spec()).run(progress=False)
    assert sorted(again.skipped) == ["a", "b"] and not again.ran
    assert {n: results_stamp(study, n) for n in ("a", "b")} == stamps

    table = study_summary(study)
    assert list(table["name"]) == ["a", "b"]
    assert np.all(table["eps_q_end"] >= 0.05)
    assert np.all(np.isfinite(table["q_over_trace_residual"]))
    # the microstructure: from the compaction's last snapshot and the shear's in the window
    assert np.all(np.isfinite(table["coordination_number_initial"]))
    assert np.all(np.isfinite(table["a_c_residual"]))
    assert np.all(table["a_c_residual_std"] >= 0.0)
    stale = study.folder / "report" / "force_network_gone.png"  # an earlier report's
    stale.parent.mkdir(exist_ok=True)
    stale.write_bytes(b"")
    report = write_study_report(study, table)
    text = report.read_text()
    assert "| a |" in text and "| b |" in text
    shown = {line.split("(")[-1].rstrip(")") for line in text.splitlines()
             if line.startswith("![")}
    assert shown and shown == {p.name for p in report.parent.glob("*.png")}
    # the same report as one HTML file, every figure inline
    page = (report.parent / "report.html").read_text()
    assert "<table>" in page and page.count('src="data:image/png;base64,') == len(shown)


def test_interrupted_study_goes_on_where_it_stopped(tmp_path, monkeypatch):
    monkeypatch.setattr(study_runner, "DISPLAY_PERIOD", 0.05)  # see a sample end sooner
    study = Study.create(tmp_path / "s", tiny_spec(("a", "b")))

    def interrupt_after_a(progress):
        if progress["a"].get("state") == "ended" and progress["b"].get("state") == "running":
            raise KeyboardInterrupt

    with pytest.raises(StudyInterrupted):
        study.run(workers=1, progress=False, on_update=interrupt_after_a)
    states = study.states()
    assert states["a"] == "ended"
    assert states["b"] in ("partial", "started", "new")
    stamp = results_stamp(study, "a")
    # go on as a user does: the same folder by the command line, this time on a cluster the
    # user started (its scheduler's address)
    from distributed import LocalCluster
    from typer.testing import CliRunner

    from grainlab.cli.main import app

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster:
        result = CliRunner().invoke(app, ["study", "run", str(study.folder), "--scheduler",
                                          cluster.scheduler_address, "--no-progress"])
    assert result.exit_code == 0, result.output
    assert "1 sample(s) run" in result.output and "1 already ended" in result.output
    assert results_stamp(study, "a") == stamp
    assert study.states() == {"a": "ended", "b": "ended"}
    report = (study.folder / "report" / "report.md").read_text()
    assert "| a |" in report and "| b |" in report
    assert "### Shear strength (seed 003 Fig. 4)" in report  # the seed's figure it draws


def test_a_folder_holding_another_study_is_refused(tmp_path):
    Study.create(tmp_path / "s", tiny_spec())
    with pytest.raises(InputError) as caught:
        Study.create(tmp_path / "s", tiny_spec(("a", "c")))
    assert caught.value.field == "study folder"
    assert "samples b held, not asked; samples c asked, not held" in caught.value.allowed
    # the same samples, one set otherwise: the message names the sample and its key alone
    data = tiny_spec().model_dump(mode="json")
    data["samples"][1]["set"]["solver"] = {"shear": {"max_iterations": 4000}}
    with pytest.raises(InputError) as caught:
        Study.create(tmp_path / "s", StudySpec.model_validate(data))
    assert "sample b: set.solver.shear.max_iterations = None, asked 4000" \
        in caught.value.allowed
    assert "sample a" not in caught.value.allowed


def test_a_folder_differing_only_in_its_snapshot_strains_goes_on_as_it_is_held(tmp_path):
    held = Study.create(tmp_path / "s", tiny_spec()).spec
    data = tiny_spec().model_dump(mode="json")
    data["base"]["output"]["snapshot_eps_q"] = [0.01, 0.02]
    opened = Study.create(tmp_path / "s", StudySpec.model_validate(data))
    assert opened.spec == held
    assert opened.spec.sample_config("a").output.snapshot_eps_q == ()
    data["base"]["output"]["record_every"] = 7  # and another key: another study
    with pytest.raises(InputError, match="record_every"):
        Study.create(tmp_path / "s", StudySpec.model_validate(data))


def test_a_folder_asked_with_another_core_margin_takes_it(tmp_path):
    """The core margin is read by the analysis alone: a folder asked with another one takes
    it (its study.toml rewritten), the snapshot schedule it holds kept as held."""
    Study.create(tmp_path / "s", tiny_spec())
    data = tiny_spec().model_dump(mode="json")
    data["study"]["core_margin"] = 2.25
    data["base"]["output"]["snapshot_eps_q"] = [0.01, 0.02]
    opened = Study.create(tmp_path / "s", StudySpec.model_validate(data))
    assert opened.spec.study.core_margin == 2.25
    assert opened.spec.sample_config("a").output.snapshot_eps_q == ()
    assert Study.open(tmp_path / "s").spec == opened.spec
    assert "study.core_margin = 2.25" in (tmp_path / "s" / "study.log").read_text()



WORKER_SCRIPT = """
import os
import numba  # the main module imports Numba: so does each worker, when it starts
from distributed import Client
from grainlab.study.study_runner import LocalSampleCluster


def compile_after_threads_launched(threads):
    # what a sample does on a cold cache: set Numba's threads, then compile
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    numba.njit(lambda x: x + 1)(1)  # a compilation re-reads Numba's environment
    return numba.config.NUMBA_NUM_THREADS


if __name__ == "__main__":
    cluster = LocalSampleCluster(n_workers=1, threads=1)
    try:
        with Client(cluster.cluster) as client:
            print("worker", client.submit(compile_after_threads_launched, 1).result())
    finally:
        cluster.close()
    print("parent", os.environ.get("NUMBA_NUM_THREADS"))
"""


def test_workers_take_their_thread_count_from_their_start(tmp_path):
    """A worker whose main module imported Numba compiles after its threads run without
    Numba refusing the thread count, and the parent's environment is left as it was."""
    script = tmp_path / "study_main.py"
    script.write_text(WORKER_SCRIPT)
    environ = {k: v for k, v in os.environ.items() if k != "NUMBA_NUM_THREADS"}
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          env=environ, cwd=tmp_path, timeout=240)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["worker", "1", "parent", "None"]


def test_samples_with_a_checkpoint_run_first_then_in_the_order_asked(tmp_path, monkeypatch):
    """One worker takes the samples one at a time: the one that has a checkpoint first,
    then the others in the order ``only`` names them (not the study's order)."""
    from distributed import LocalCluster

    study = Study.create(tmp_path / "s", tiny_spec(("a", "b", "c", "d")))
    partial = study.sample_folder("c")
    partial.mkdir(parents=True)
    (partial / CHECKPOINT).write_bytes(b"")  # what sample_state reads: c has begun
    order = tmp_path / "order.txt"

    def record(folder, config, stop_file, threads):  # the sample task, without the run
        name = os.path.basename(folder)
        with open(order, "a") as taken:  # the task may be a copy: it writes what it takes
            taken.write(name + "\n")
        return {"name": name, "was": "", "resumed": name == "c", "state": "ended"}

    monkeypatch.setattr(study_runner, "run_sample", record)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as cluster:
        outcome = study.run(scheduler=cluster.scheduler_address, progress=False,
                            only=["d", "b", "c"])
    assert order.read_text().split() == ["c", "d", "b"]
    assert outcome.ran == ["c", "d", "b"] and outcome.resumed == ["c"]
    assert "a" not in outcome.skipped  # left as it is, neither run nor counted


def test_a_worker_gets_one_sample_at_a_time_so_none_waits_behind_a_long_one(tmp_path,
                                                                           monkeypatch):
    """Two workers: c (resumed first) runs long; d, b and e follow on the other worker in the
    order asked, none queued behind c (sent all at once, Dask would queue b on c's worker and
    start e before it)."""
    import time
    from pathlib import Path

    from distributed import LocalCluster

    study = Study.create(tmp_path / "s", tiny_spec(("b", "c", "d", "e")))
    (study.sample_folder("c")).mkdir(parents=True)
    (study.sample_folder("c") / CHECKPOINT).write_bytes(b"")
    order = tmp_path / "order.txt"

    def record(folder, config, stop_file, threads):
        name = os.path.basename(folder)
        with open(order, "a") as taken:
            taken.write(name + "\n")
        if name == "c":  # long: until the others have started, or a minute
            deadline = time.monotonic() + 60.0
            while "e" not in Path(order).read_text().split() and time.monotonic() < deadline:
                time.sleep(0.02)
        return {"name": name, "was": "", "resumed": name == "c", "state": "ended"}

    monkeypatch.setattr(study_runner, "run_sample", record)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as cluster:
        outcome = study.run(scheduler=cluster.scheduler_address, progress=False,
                            only=["d", "b", "e", "c"])
    assert order.read_text().split() in (["c", "d", "b", "e"], ["d", "c", "b", "e"])
    assert sorted(outcome.ran) == ["b", "c", "d", "e"]


def test_grainlab_study_stop_from_another_shell_stops_the_running_samples(tmp_path,
                                                                          monkeypatch):
    """``grainlab study stop FOLDER`` writes the file the running samples look for: each
    returns interrupted, the study ends not complete and removes the file."""
    import threading
    import time
    from pathlib import Path

    from distributed import LocalCluster
    from typer.testing import CliRunner

    from grainlab.cli.main import app

    study = Study.create(tmp_path / "s", tiny_spec(("a",)))
    started = tmp_path / "started"

    def wait_for_stop(folder, config, stop_file, threads):  # a sample that runs until asked
        started.touch()
        deadline = time.monotonic() + 60.0
        while not Path(stop_file).exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        return {"name": "a", "was": "new", "resumed": False,
                "state": "interrupted" if Path(stop_file).exists() else "ended"}

    monkeypatch.setattr(study_runner, "run_sample", wait_for_stop)
    outcomes = []
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as cluster:
        running = threading.Thread(target=lambda: outcomes.append(study.run(
            scheduler=cluster.scheduler_address, progress=False)))
        running.start()
        deadline = time.monotonic() + 60.0
        while not started.exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        result = CliRunner().invoke(app, ["study", "stop", str(study.folder)])
        running.join(timeout=60.0)
    assert result.exit_code == 0 and "checkpoint" in result.output
    assert outcomes and outcomes[0].interrupted == ["a"] and not outcomes[0].complete
    assert not (study.folder / "stop-requested").exists()
    refused = CliRunner().invoke(app, ["study", "stop", str(tmp_path / "nothing")])
    assert refused.exit_code != 0 and "study.toml" in refused.output
