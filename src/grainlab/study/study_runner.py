"""A study is a folder of independent runs, run on Dask and resumed across interruptions.

Layout of a study folder::

    study.toml        the study (grainlab.study.study_spec.StudySpec)
    samples/NAME/     one run folder per sample (grainlab.lab.discrete_run)
    summary.csv       one row per ended sample: the shape parameter, peak and residual
                      values with their standard deviations (grainlab.study.study_summary)
    report/           the figures and report.md (grainlab.report.study_report)
    study.log         what happened, with times

:meth:`Study.run` sends every sample that has not ended to a Dask cluster as one task
(:func:`~grainlab.study.sample_task.run_sample`): a local cluster sized for the machine by
default (one process per sample at a time, as many as cores, one Numba thread each: the
samples are independent, so that is where the parallelism pays), or an existing cluster
(``scheduler="tcp://host:8786"``; the study folder must then be at the same path on every
worker). A sample that has ended is never rerun; one interrupted (Ctrl-C on the study, a
worker killed, a machine gone) resumes from its last checkpoint the next time the study runs,
or at once on another worker when Dask retries its task. The samples with a checkpoint are
taken first (:func:`running_order`), so that a study gone on with ends what it began before
it starts anything new; they are sent to the cluster as its workers free up, as many as it
runs at once, so none waits queued behind an hours-long sample on a busy worker while a
later one starts on a free one. One display shows every sample's
stage and progress (read from the samples' progress.json), and the whole study's.

Ctrl-C stops the study cleanly: the study writes its stop file, every running sample
checkpoints and returns, and the study says how to go on (run the same command again).
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grainlab.errors import GrainlabError, InputError
from grainlab.study.sample_task import STOP_FILE, read_progress, run_sample, sample_state
from grainlab.study.study_spec import StudySpec

SPEC = "study.toml"
SAMPLES = "samples"
LOG = "study.log"
DISPLAY_PERIOD = 0.5
"""Seconds between two refreshes of the study's display."""
STOP_WAIT = 120.0
"""Seconds the study waits, after Ctrl-C, for its running samples to checkpoint."""


class StudyInterrupted(GrainlabError, KeyboardInterrupt):
    """The study was interrupted; every running sample checkpointed."""


@dataclass
class StudyOutcome:
    """What a call of :meth:`Study.run` did: samples ended by it, found ended, failed (name:
    message), left interrupted."""

    ran: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: dict[str, str] = field(default_factory=dict)
    interrupted: list[str] = field(default_factory=list)
    resumed: list[str] = field(default_factory=list)
    wall_time: float = 0.0

    @property
    def complete(self) -> bool:
        """Every sample ended."""
        return not self.failed and not self.interrupted

    def summary(self) -> str:
        parts = [f"{len(self.ran)} sample(s) run ({len(self.resumed)} resumed)",
                 f"{len(self.skipped)} already ended"]
        if self.failed:
            parts.append("failed: " + "; ".join(f"{k}: {v}" for k, v in self.failed.items()))
        if self.interrupted:
            parts.append("interrupted: " + ", ".join(self.interrupted))
        return ", ".join(parts) + f" in {self.wall_time:.1f} s"


class Study:
    """A study folder (module docstring). Make one with :meth:`create` or :meth:`open`."""

    def __init__(self, folder: Path, spec: StudySpec) -> None:
        self.folder = folder
        self.spec = spec

    # -- folders ------------------------------------------------------------------------------
    @classmethod
    def create(cls, folder: str | Path, spec: StudySpec) -> Study:
        """The study ``spec`` in ``folder``: a new folder gets study.toml; a folder that
        holds this same study is opened as it is (so that running the same command again
        resumes it), also where it differs only in :data:`KEPT_AS_HELD` (it goes on as held);
        a folder holding another study is refused with the first key that differs."""
        folder = Path(folder)
        if (folder / SPEC).exists():
            held = StudySpec.read(folder / SPEC)
            differences = _differences(held, spec)
            if differences and set(differences) <= set(KEPT_AS_HELD) | set(ANALYSED_AS_ASKED):
                asked = {key.split(".", 1)[1]: getattr(spec.study, key.split(".", 1)[1])
                         for key in differences if key in ANALYSED_AS_ASKED}
                if asked:
                    held = held.model_copy(update={"study": held.study.model_copy(
                        update=asked)})
                    held.write(folder / SPEC)
                    _logger(folder).info("analysis settings now as asked: %s", ", ".join(
                        f"study.{name} = {value!r}" for name, value in sorted(asked.items())))
                return cls(folder, held)  # its own snapshot schedule, the asked analysis
            if held != spec:
                raise InputError("study folder", str(folder), (
                    "a new folder, or the folder of this same study (it holds another: "
                    f"{_first_difference(held, spec)}); run `grainlab study run {folder}` to "
                    "go on with the study it holds"))
            return cls(folder, held)
        folder.mkdir(parents=True, exist_ok=True)
        spec.write(folder / SPEC)
        return cls(folder, spec)

    @classmethod
    def open(cls, folder: str | Path) -> Study:
        """The study in ``folder`` (its study.toml)."""
        folder = Path(folder)
        if not (folder / SPEC).exists():
            raise InputError("study folder", str(folder), f"a study folder with a {SPEC}")
        return cls(folder, StudySpec.read(folder / SPEC))

    def sample_folder(self, name: str) -> Path:
        """The run folder of sample ``name``."""
        return self.folder / SAMPLES / name

    def states(self) -> dict[str, str]:
        """Every sample's state (:func:`~grainlab.study.sample_task.sample_state`)."""
        return {n: sample_state(self.sample_folder(n)) for n in self.spec.names}

    # -- running ------------------------------------------------------------------------------
    def run(self, *, scheduler: str | None = None, workers: int | None = None,
            threads: int = 1, progress: bool = True, only: list[str] | None = None,
            on_update: Callable[[dict[str, dict]], None] | None = None) -> StudyOutcome:
        """Run every sample that has not ended (module docstring).

        Parameters
        ----------
        scheduler:
            Address of an existing Dask scheduler; None starts a local cluster.
        workers:
            Local cluster: worker processes (default: as many as cores / ``threads``, at
            most the samples left).
        threads:
            Numba threads per sample.
        progress:
            Show the study's display (rich).
        only:
            Run these samples only (names; the others are left as they are), in this order
            (:func:`running_order`: those with a checkpoint first).
        on_update:
            Called with every sample's progress at each refresh (tests, other displays).
        """
        from distributed import Client, as_completed

        threads = int(threads)
        if threads < 1:
            raise InputError("threads", threads, "an integer >= 1")
        log = _logger(self.folder)
        stop = self.folder / STOP_FILE
        stop.unlink(missing_ok=True)
        outcome = StudyOutcome()
        states = self.states()
        if only:
            for name in only:
                if name not in states:
                    raise InputError("only", name, "names of the study's samples: "
                                     + ", ".join(self.spec.names))
            states = {n: states[n] for n in dict.fromkeys(only)}
        todo = running_order(states)
        outcome.skipped = [n for n, s in states.items() if s == "ended"]
        start = time.perf_counter()
        if not todo:
            log.info("every sample has ended; nothing to run")
            return outcome
        cluster = None
        if scheduler is None:
            cores = os.cpu_count() or 1
            n_workers = workers or max(1, min(len(todo), cores // threads))
            if n_workers < 1:
                raise InputError("workers", workers, "an integer >= 1")
            cluster = LocalSampleCluster(n_workers, threads)
            client = Client(cluster.cluster)
        else:
            try:
                client = Client(scheduler, timeout=30)
            except OSError as error:
                raise InputError("scheduler", scheduler,
                                 f"the address of a running Dask scheduler ({error})") from None
        log.info("study %s: %d sample(s) to run on %s (%s)", self.spec.study.name, len(todo),
                 scheduler or f"a local cluster of {len(client.scheduler_info()['workers'])} "
                 "worker(s)", ", ".join(todo))
        display = _Display(self, todo, progress, on_update)
        waiting = list(todo)  # sent to the cluster as its workers free up, in this order
        futures: dict[Any, str] = {}
        pending = as_completed([], with_results=False)

        def send() -> None:
            """Send the next samples, as many as the cluster runs at once, unless the study
            is asked to stop."""
            running = sum(not future.done() for future in futures)
            while waiting and running < _slots(client) and not stop.exists():
                name = waiting.pop(0)
                folder = self.sample_folder(name)
                folder.parent.mkdir(parents=True, exist_ok=True)
                config = self.spec.sample_config(name).model_dump()
                future = client.submit(run_sample, str(folder), config, str(stop), threads,
                                       key=f"grainlab-sample-{name}-{os.getpid()}-{start}",
                                       pure=False)
                futures[future] = name
                pending.add(future)
                running += 1

        try:
            send()
            display.start()
            try:
                while not pending.is_empty() or (waiting and not stop.exists()):
                    for future in pending.next_batch(block=False):
                        self._collect(future, futures[future], outcome, log)
                    send()
                    display.refresh()
                    time.sleep(DISPLAY_PERIOD)
                outcome.interrupted += waiting  # asked to stop before they started
            except KeyboardInterrupt:
                stop.touch()
                display.on_update = None  # a caller's callback that interrupted is not recalled
                log.warning("interrupted: asking the running samples to checkpoint")
                display.note("interrupted: the running samples checkpoint ...")
                deadline = time.monotonic() + STOP_WAIT
                while not pending.is_empty() and time.monotonic() < deadline:
                    for future in pending.next_batch(block=False):
                        self._collect(future, futures[future], outcome, log)
                    display.refresh()
                    time.sleep(DISPLAY_PERIOD)
                left = [futures[f] for f in futures if not f.done()]
                outcome.interrupted += left + waiting
                outcome.wall_time = time.perf_counter() - start
                raise StudyInterrupted(
                    "study interrupted; every sample that was running checkpointed (or "
                    "resumes from its last checkpoint); go on with the same command or "
                    f"`grainlab study run {self.folder}`") from None
            display.refresh()
        finally:
            display.stop()
            stop.unlink(missing_ok=True)
            client.close()
            if cluster is not None:
                cluster.close()
        outcome.wall_time = time.perf_counter() - start
        log.info("%s", outcome.summary())
        return outcome

    def _collect(self, future, name: str, outcome: StudyOutcome, log) -> None:
        """Record what a finished task did."""
        if future.status == "error":
            error = future.exception()
            outcome.failed[name] = f"{type(error).__name__}: {error}"
            log.error("sample %s failed: %s", name, outcome.failed[name])
            return
        if future.status == "cancelled":
            outcome.interrupted.append(name)
            return
        result: dict[str, Any] = future.result()
        if result["resumed"]:
            outcome.resumed.append(name)
        if result["state"] == "ended":
            outcome.ran.append(name)
            log.info("sample %s ended%s", name, " (resumed)" if result["resumed"] else "")
        else:
            outcome.interrupted.append(name)
            log.info("sample %s interrupted; it resumes from its checkpoint", name)


class _Display:
    """The study's display: a line per sample (stage, progress, numbers) and one for the
    study, from the samples' progress.json (rich; in a terminal or a Jupyter notebook)."""

    def __init__(self, study: Study, names: list[str], show: bool,
                 on_update: Callable[[dict[str, dict]], None] | None) -> None:
        self.study = study
        self.names = names
        self.show = show
        self.on_update = on_update
        self.progress = None
        self.tasks: dict[str, Any] = {}

    def start(self) -> None:
        if not self.show:
            return
        from rich.progress import BarColumn, TextColumn, TimeElapsedColumn

        from grainlab._live_progress import LiveProgress

        self.progress = LiveProgress(TextColumn("[bold]{task.description}"), BarColumn(),
                                     TextColumn("{task.percentage:>3.0f} %"),
                                     TextColumn("{task.fields[info]}"), TimeElapsedColumn())
        self.tasks["study"] = self.progress.add_task(
            f"study {self.study.spec.study.name}", total=len(self.names), info="")
        for name in self.names:
            self.tasks[name] = self.progress.add_task(name, total=1.0, info="waiting")
        self.progress.start()

    def refresh(self) -> None:
        data = {n: read_progress(self.study.sample_folder(n)) for n in self.names}
        for name in self.names:
            if sample_state(self.study.sample_folder(name)) == "ended":
                data[name] = {**data[name], "fraction": 1.0, "state": "ended"}
        if self.on_update is not None:
            self.on_update(data)
        if self.progress is None:
            return
        done = 0.0
        for name, d in data.items():
            fraction = float(d.get("fraction", 0.0))
            if not math.isfinite(fraction):
                fraction = 0.0
            done += fraction
            info = d.get("state", "waiting")
            if info == "running":
                info = f"{d.get('stage', '')}: {d.get('info', '')}"
            self.progress.update(self.tasks[name], completed=fraction, info=info[:110])
        self.progress.update(self.tasks["study"], completed=done,
                             info=f"{sum(d.get('state') == 'ended' for d in data.values())}"
                                  f" of {len(self.names)} ended")

    def note(self, text: str) -> None:
        if self.progress is not None:
            self.progress.console.print(text)

    def stop(self) -> None:
        if self.progress is not None:
            self.progress.stop()


def _slots(client) -> int:
    """How many samples the cluster runs at once: its workers' threads (at least 1; read
    again each time, so a cluster that grows takes more)."""
    workers = client.scheduler_info().get("workers", {})
    return max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))


def running_order(states: dict[str, str]) -> list[str]:
    """The samples to run, in the order their workers take them: those with a checkpoint
    ("partial") first, so that work already done ends before new samples start, then the
    others; within each, the order of ``states`` (the study's, or the order ``only`` names
    them). Ended samples are left out.

    >>> running_order({"S1": "ended", "S2": "new", "S3": "started", "S4": "partial"})
    ['S4', 'S2', 'S3']
    """
    left = [name for name, state in states.items() if state != "ended"]
    return sorted(left, key=lambda name: states[name] != "partial")


def _logger(folder: Path) -> logging.Logger:
    log = logging.getLogger(f"grainlab.study.{folder.resolve()}")
    if not log.handlers:
        handler = logging.FileHandler(folder / LOG)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        log.addHandler(handler)
        log.setLevel(logging.INFO)
        log.propagate = False
    return log


KEPT_AS_HELD = ("base.output.snapshot_eps_q",)
"""Keys in which a study folder may differ from the study asked and still be that study,
opened as it is held: when to snapshot changes no run's physics, and a folder made before
the preset took more snapshots goes on with its own schedule (so its samples resume as they
started)."""


ANALYSED_AS_ASKED = ("study.core_margin",)
"""Keys of the ``[study]`` table that only the analysis reads: a study folder asked with
another value takes the asked one (its study.toml is rewritten; the summary is computed again
from each sample's snapshots, and a slimmed sample, whose digest holds the values of the
former setting, gives no core values until it is run again)."""


def _differences(held: StudySpec, asked: StudySpec) -> dict[str, tuple[Any, Any]]:
    """``{key: (held, asked)}`` of the keys where two studies differ."""
    from grainlab.lab.run_config import flat_keys

    a, b = flat_keys(held.model_dump(mode="json")), flat_keys(asked.model_dump(mode="json"))
    return {key: (a.get(key), b.get(key)) for key in sorted(set(a) | set(b))
            if a.get(key) != b.get(key)}


def _first_difference(held: StudySpec, asked: StudySpec) -> str:
    """The first key where two studies differ, in words; in the samples, the first sample
    whose settings differ and the key, or the sample names where those differ."""
    from grainlab.lab.run_config import flat_keys

    for key, (a, b) in _differences(held, asked).items():
        if key != "samples" or not isinstance(a, list) or not isinstance(b, list):
            return f"{key} = {a!r}, asked {b!r}"
        names = [s.get("name") for s in a], [s.get("name") for s in b]
        if names[0] != names[1]:
            only = ([n for n in names[0] if n not in names[1]],
                    [n for n in names[1] if n not in names[0]])
            if not any(only):
                return f"samples in the order {', '.join(names[0])}"
            return "; ".join(f"samples {', '.join(n)} {where}" for n, where in
                             zip(only, ("held, not asked", "asked, not held"), strict=True)
                             if n)
        for mine, theirs in zip(a, b, strict=True):
            x, y = flat_keys(mine), flat_keys(theirs)
            for inner in sorted(set(x) | set(y)):
                if x.get(inner) != y.get(inner):
                    return (f"sample {mine['name']}: {inner} = {x.get(inner)!r}, "
                            f"asked {y.get(inner)!r}")
    return "the same keys"



class LocalSampleCluster:
    """A Dask cluster on this machine: ``n_workers`` processes of one task each, whose
    Numba runs ``threads`` threads.

    Numba reads its thread count when a worker first imports it and refuses a later
    change once its threads run (a compilation re-reads it). The count is therefore in
    each worker's environment from its start (Dask's pre-spawn environment). Dask also
    writes that environment into this process's: :meth:`close` puts it back."""

    def __init__(self, n_workers: int, threads: int) -> None:
        import dask.config
        from distributed import LocalCluster

        self._parent_threads = os.environ.get("NUMBA_NUM_THREADS")
        environ = {**dask.config.get("distributed.nanny.pre-spawn-environ", {}),
                   "NUMBA_NUM_THREADS": str(threads)}
        with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
            self.cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1,
                                        processes=True, dashboard_address=":0",
                                        silence_logs=logging.CRITICAL)

    def close(self) -> None:
        self.cluster.close()
        if self._parent_threads is None:
            os.environ.pop("NUMBA_NUM_THREADS", None)
        else:
            os.environ["NUMBA_NUM_THREADS"] = self._parent_threads
