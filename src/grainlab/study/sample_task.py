"""One sample of a study brought to its end: the task a Dask worker runs.

A sample is a run folder (:mod:`grainlab.lab.discrete_run`). :func:`run_sample` starts it,
or resumes it from its last checkpoint, and runs it to its end; a sample that has ended is
left as it is (never rerun). The task is idempotent, so a study survives a worker that dies
mid-run: Dask gives the task to another worker, which resumes the run from its checkpoint.

While it runs, the task writes ``progress.json`` in the run folder (at most every
``PROGRESS_PERIOD`` seconds: stage, fraction of the run done, a line of numbers), which the
study's display reads, and it stops as Ctrl-C would (checkpoint, then return) when the
study's stop file exists (:data:`STOP_FILE` in the study folder). Both need the study folder
on a file system the workers and the client share -- as the run folders do.

Sample states (:func:`sample_state`): ``"new"`` (nothing on disk), ``"started"`` (a config,
no checkpoint), ``"partial"`` (a checkpoint, not ended), ``"ended"`` (results.h5 written at
the end: finished as asked, or stopped with its outcome saying why).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

from grainlab.lab.discrete_run import (
    CONFIG,
    RESULTS_H5,
    RunInterrupted,
    resume_run,
    start_run,
)
from grainlab.lab.run_checkpoint import CHECKPOINT, PREVIOUS_CHECKPOINT
from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_operations import progress_fields

PROGRESS = "progress.json"
STOP_FILE = "stop-requested"
PROGRESS_PERIOD = 0.5
"""Seconds between two writes of progress.json (and two looks for the stop file)."""

SAMPLE_STATES = ("new", "started", "partial", "ended")


def sample_state(folder: str | Path) -> str:
    """Where the run in ``folder`` stands (module docstring)."""
    folder = Path(folder)
    if (folder / RESULTS_H5).exists():
        return "ended"
    if (folder / CHECKPOINT).exists() or (folder / PREVIOUS_CHECKPOINT).exists():
        return "partial"
    if (folder / CONFIG).exists():
        return "started"
    return "new"


def run_sample(folder: str, config: dict[str, Any], stop_file: str = "",
               threads: int = 0) -> dict[str, Any]:
    """Bring the run in ``folder`` to its end (module docstring) and return what happened:
    ``{"name", "state" ("ended" | "interrupted"), "resumed", "was": the state found}``.
    ``config`` is the sample's run config (plain data); ``threads`` > 0 sets Numba's
    threads for this worker."""
    if threads > 0:
        import numba

        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    path = Path(folder)
    was = sample_state(path)
    out = {"name": path.name, "was": was, "resumed": was == "partial"}
    if was == "ended":
        return {**out, "state": "ended"}
    if was == "partial":
        run = resume_run(path)
    else:  # a config without a checkpoint: nothing was done that a restart would lose
        run = start_run(path, RunConfig.model_validate(config), overwrite=was == "started")
    reporter = _Reporter(run, path, Path(stop_file) if stop_file else None)
    run.test.on_record = reporter.on_record
    try:
        run.run(progress=False)
    except RunInterrupted:
        reporter.write(final="interrupted")
        return {**out, "state": "interrupted"}
    reporter.write(final="ended")
    return {**out, "state": "ended"}


class _Reporter:
    """Writes progress.json and looks for the stop file, at most every PROGRESS_PERIOD s."""

    def __init__(self, run, folder: Path, stop_file: Path | None) -> None:
        self.run = run
        self.folder = folder
        self.stop_file = stop_file
        self.last = 0.0
        self.fraction = 0.0
        self.stage = ""
        self.info = ""

    def on_record(self, test, row: dict) -> None:
        now = time.monotonic()
        if now - self.last < PROGRESS_PERIOD:
            return
        self.last = now
        if test.stage is not None:
            done, info = progress_fields(test, row)
            n = max(len(test.stages), 1)
            self.fraction = min(1.0, (test.stage_index + done) / n)
            self.stage, self.info = test.stage.name, info
        self.write()
        if self.stop_file is not None and self.stop_file.exists():
            self.run.request_interrupt()

    def write(self, final: str = "") -> None:
        data = {"stage": self.stage, "fraction": 1.0 if final == "ended" else self.fraction,
                "info": self.info, "state": final or "running", "pid": os.getpid(),
                "time": time.time()}
        tmp = self.folder / (PROGRESS + ".tmp")
        try:
            tmp.write_text(json.dumps(data))
            os.replace(tmp, self.folder / PROGRESS)
        except OSError:  # the display is a convenience: a failed write never stops a run
            pass


def read_progress(folder: str | Path) -> dict[str, Any]:
    """The last progress.json of a run folder ({} when there is none or it is unreadable)."""
    try:
        return json.loads((Path(folder) / PROGRESS).read_text())
    except (OSError, ValueError):
        return {}
