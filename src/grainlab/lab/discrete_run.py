"""A discrete run is a folder that survives being killed (ARCHITECTURE.md "Runs").

Layout of a run folder::

    config.toml        the input (grainlab.lab.run_config.RunConfig)
    results.csv        the results table in the test-result format (rewritten at every
                       checkpoint and at the end; results.h5 too at the end)
    snapshots.h5       contact-network snapshots (grainlab.analysis snapshot files)
    checkpoint.h5      the last checkpoint: sample, walls, solver memory, progress, rows
    run.log            what happened, with times
    vtk/               ParaView files when output.vtk_every > 0 (particles, contacts, walls)

Checkpoints are written to ``checkpoint.h5.tmp`` and renamed over ``checkpoint.h5``
(atomic), every ``output.checkpoint_every`` steps, at the end of every stage and when the run
is interrupted (Ctrl-C, SIGTERM). A run killed at any moment, even by SIGKILL, resumes from
its last checkpoint (:func:`resume_run`, ``grainlab resume RUN``): the results table and the
snapshot file are cut back to that checkpoint and the run goes on, so nothing but the steps
since the checkpoint is lost. A run that blows up keeps its last good checkpoint and logs
the diagnosis.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import signal
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd

from grainlab.analysis.snapshot_files import append_snapshot
from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.sample_measures import PAIR_TYPE_NAMES
from grainlab.engine.simulation import SimulationBlowUp
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.wall_box import WallBox
from grainlab.errors import GrainlabError, InputError
from grainlab.lab.discrete_test import DiscreteTest
from grainlab.lab.run_config import RunConfig
from grainlab.prep.loose_sample import loose_sample
from grainlab.result.test_result import TestResult

CONFIG = "config.toml"
RESULTS = "results.csv"
RESULTS_H5 = "results.h5"
SNAPSHOTS = "snapshots.h5"
CHECKPOINT = "checkpoint.h5"
LOG = "run.log"
CHECKPOINT_FORMAT = "grainlab.discrete_checkpoint"
CHECKPOINT_VERSION = 1

_STATE_FIELDS = ("positions", "orientations", "velocities", "angular_velocities", "masses",
                 "inertias", "shape_ids")
_LIBRARY_FIELDS = tuple(f.name for f in dataclasses.fields(ShapeLibrary))
"""Every array of the shape library (member spheres and polyhedron vertices, faces, edges)."""


class RunInterrupted(GrainlabError, KeyboardInterrupt):
    """The run was interrupted by a signal; its checkpoint is on disk."""


def _logger(folder: Path) -> logging.Logger:
    logger = logging.getLogger(f"grainlab.run.{folder.resolve()}")
    if not logger.handlers:
        handler = logging.FileHandler(folder / LOG)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        logger.addHandler(handler)
        logger.setLevel(logging.INFO)
        logger.propagate = False
    return logger


def build_sample(config: RunConfig) -> DiscreteSample:
    """The loose random sample of ``config.sample``."""
    s = config.sample
    try:
        return loose_sample(shape=s.shape, n_particles=s.n_particles, d_min=s.d_min,
                            size_ratio=s.size_ratio, eta=s.eta, n_faces=s.n_faces,
                            templates=s.templates, density=s.density,
                            packing_fraction=s.packing_fraction,
                            wall_friction=s.wall_friction, seed=s.seed)
    except InputError as error:
        if error.field not in type(s).model_fields:
            raise
        # the keywords are the keys of [sample]: name the key as the config spells it
        raise InputError(f"sample.{error.field}", error.value, error.allowed) from None


class DiscreteRun:
    """A run folder and the test it runs (module docstring). Make one with
    :func:`start_run` or :func:`resume_run`."""

    def __init__(self, folder: Path, config: RunConfig, test: DiscreteTest) -> None:
        self.folder = folder
        self.config = config
        self.test = test
        self.log = _logger(folder)
        self.last_checkpoint_step = -1
        self.resumed = False
        self._vtk = None
        test.on_snapshot = self._write_snapshot
        test.on_stage_end = self._stage_ended
        out = config.output
        if out.checkpoint_every:
            test.simulation.add(_Every("checkpoint", out.checkpoint_every, self.checkpoint))
        if out.vtk_every:
            test.simulation.add(_Every("vtk", out.vtk_every, self.write_vtk))

    def _stage_ended(self, test: DiscreteTest) -> None:
        ended = test.outcome["stages"][-1]
        self.log.info("stage %s ended: %s", ended["name"], ended["reason"])
        self.checkpoint()

    # -- files --------------------------------------------------------------------------------
    def _write_snapshot(self, test: DiscreteTest, network) -> None:
        append_snapshot(self.folder / SNAPSHOTS, network)

    def write_vtk(self) -> None:
        """Write one ParaView frame of the sample (particles, contacts, walls) to vtk/."""
        from grainlab.report.vtk_export import BoxWalls, ContactLines, VtkSeries

        sim = self.test.simulation
        if self._vtk is None:
            self._vtk = VtkSeries(self.folder / "vtk", self.test.sample.library,
                                  continue_until=sim.time if self.resumed else None)
        contacts = None
        if sim.last_report is not None:
            contacts = ContactLines.from_step_report(sim.last_report,
                                                     self.test.sample.state.positions,
                                                     self.test.solver.dt,
                                                     friction=self.test.solver.friction)
        self._vtk.add_state(sim.time, self.test.sample.state, contacts=contacts,
                            walls=BoxWalls.from_wall_box(self.test.sample.box))

    def result(self) -> TestResult:
        """The results so far in the test-result format."""
        test = self.test
        table = pd.DataFrame(test.rows)
        return TestResult.create(
            table, specimen={"kind": "discrete sample", **test.sample.description},
            load_path={"name": test.path.name, "description": test.path.description,
                       "stages": [s.to_dict() for s in test.stages]},
            parameters={"settings": test.settings.to_dict(),
                        "config": self.config.model_dump()},
            outcome={**test.outcome, "finished": test.finished,
                     "unconverged_steps": test.simulation.unconverged_steps,
                     "steps": test.simulation.step_index},
            dimension=3, title=f"{test.path.name} on a discrete sample")

    def write_results(self, final: bool = False) -> None:
        """Rewrite results.csv (and results.h5 when ``final``)."""
        if not self.test.rows:
            return
        result = self.result()
        result.to_csv(self.folder / RESULTS)
        if final:
            result.to_hdf5(self.folder / RESULTS_H5)

    def checkpoint(self) -> Path:
        """Write the checkpoint atomically (module docstring); returns its path."""
        test = self.test
        path = self.folder / CHECKPOINT
        tmp = path.with_name(path.name + ".tmp")
        with h5py.File(tmp, "w") as handle:
            handle.attrs["format"] = CHECKPOINT_FORMAT
            handle.attrs["format_version"] = CHECKPOINT_VERSION
            state = handle.create_group("state")
            for name in _STATE_FIELDS:
                state[name] = getattr(test.sample.state, name)
            state.attrs["density"] = test.sample.state.density
            library = handle.create_group("library")
            for name in _LIBRARY_FIELDS:
                library[name] = getattr(test.sample.library, name)
            box = handle.create_group("box")
            for name, array in test.sample.box.to_arrays().items():
                box[name] = array
            warm = handle.create_group("warm_start")
            for name, array in test.solver.warm_start_arrays().items():
                warm[name] = array
            handle.attrs["rng_state"] = json.dumps(test.solver.rng_state)
            handle.attrs["progress"] = json.dumps(_plain(test.progress_arrays()))
            handle.attrs["outcome"] = json.dumps(_plain(test.outcome))
            handle.attrs["description"] = json.dumps(_plain(test.sample.description))
            handle["rows"] = json.dumps(_plain(test.rows))  # a dataset: no 64 kB limit
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
        self.write_results()
        self.last_checkpoint_step = test.simulation.step_index
        self.log.info("checkpoint at step %d (t = %.6g s, %d rows, %d snapshots)",
                      test.simulation.step_index, test.simulation.time, len(test.rows),
                      test.n_snapshots)
        return path

    # -- running ------------------------------------------------------------------------------
    def run(self, progress: bool = False, max_steps: int | None = None) -> TestResult:
        """Run to the end (or ``max_steps`` more steps). Ctrl-C / SIGTERM let the current step
        finish, checkpoint and raise :class:`RunInterrupted`; a blow-up is logged and
        re-raised with the last good checkpoint kept."""
        test = self.test
        interrupted: list[int] = []

        def on_signal(signum, frame):
            # deferred: the step in progress finishes, so the checkpoint is consistent
            interrupted.append(signum)
            test.simulation.request_stop()

        previous = {}
        for signum in (signal.SIGTERM, signal.SIGINT):
            try:
                previous[signum] = signal.signal(signum, on_signal)
            except ValueError:  # not the main thread: signals stay as they are
                break
        bar = _ProgressBar(test) if progress else None
        if bar is not None:
            test.on_record = bar.update
        start = time.perf_counter()
        try:
            if bar is not None:
                bar.start()
            while not test.finished and not interrupted:
                test.run(max_steps)
                if interrupted:
                    raise KeyboardInterrupt
                if max_steps is not None:
                    break
            if interrupted:
                raise KeyboardInterrupt
        except KeyboardInterrupt:
            self.checkpoint()
            self.log.warning("interrupted at step %d; resume with `grainlab resume %s`",
                             test.simulation.step_index, self.folder)
            raise RunInterrupted(
                f"run interrupted at step {test.simulation.step_index}; checkpoint written, "
                f"resume with: grainlab resume {self.folder}") from None
        except SimulationBlowUp as error:
            self.log.error("blow-up: %s (last good checkpoint: step %d)", error,
                           self.last_checkpoint_step)
            raise
        finally:
            if bar is not None:
                bar.stop()
            for signum, handler in previous.items():
                signal.signal(signum, handler)
        elapsed = time.perf_counter() - start
        if test.finished:
            for stage in test.outcome["stages"][-1:]:
                self.log.info("stage %s ended: %s", stage["name"], stage["reason"])
            self.checkpoint()
            self.write_results(final=True)
            if self._vtk is not None:
                self._vtk.close()
            self.log.info("run finished at step %d in %.1f s of this session",
                          test.simulation.step_index, elapsed)
        return self.result()


class _Every:
    """Calls ``action()`` every ``period`` steps."""

    def __init__(self, name: str, period: int, action: Callable[[], Any]) -> None:
        from grainlab.engine.simulation import Periodic

        self.name = name
        self.trigger = Periodic(period)
        self.action = action

    def act(self, simulation) -> None:
        self.action()


class _ProgressBar:
    """A rich progress bar over the stages (strain or quasi-static state)."""

    def __init__(self, test: DiscreteTest) -> None:
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        self.test = test
        self.progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(),
                                 TextColumn("{task.fields[info]}"), TimeElapsedColumn())
        self.task = None

    def start(self) -> None:
        self.progress.start()
        self.task = self.progress.add_task("starting", total=1.0, info="")

    def update(self, test: DiscreteTest, row: dict) -> None:
        stage = test.stage
        if stage is None or self.task is None:
            return
        if stage.moving_axes:
            stop = [c.limit for c in stage.stop if c.quantity == "eps_q"]
            done = row["eps_q"] / stop[0] if stop else max(
                abs(np.log(test.stage_start_lengths[a] / test.sample.box.lengths[a]))
                / abs(stage.targets[a]) for a in stage.moving_axes)
        else:
            done = min(1.0, row["packing_fraction"] / 0.64)
        info = (f"step {row['step']}  q/p {row['q_over_trace']:.3f}  "
                f"packing fraction {row['packing_fraction']:.4f}  z {row['z']:.2f}  "
                f"I {row['inertia_number']:.1e}")
        self.progress.update(self.task, completed=min(done, 1.0), description=stage.name,
                             info=info)

    def stop(self) -> None:
        self.progress.stop()


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating | float):
        return float(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def start_run(folder: str | Path, config: RunConfig, *, overwrite: bool = False
              ) -> DiscreteRun:
    """Build the sample and the test, then create the run folder (refusing to replace a run
    unless ``overwrite``) and write the config. An input rejected while building leaves the
    folder as it was: no new folder, the old run (if any) untouched."""
    folder = Path(folder)
    holds_run = (folder / CHECKPOINT).exists() or (folder / CONFIG).exists()
    if holds_run and not overwrite:
        raise InputError("run folder", str(folder),
                         "a new folder (this one holds a run: `grainlab resume` it, or "
                         "pass --overwrite)")
    sample = build_sample(config)
    test = DiscreteTest(sample, config.load_path(), config.settings())
    if holds_run:
        for name in (CHECKPOINT, RESULTS, RESULTS_H5, SNAPSHOTS, LOG):
            (folder / name).unlink(missing_ok=True)
    folder.mkdir(parents=True, exist_ok=True)
    config.write(folder / CONFIG)
    run = DiscreteRun(folder, config, test)
    run.log.info("run started: %s, %d %s particles", config.test.kind,
                 config.sample.n_particles, config.sample.shape)
    return run


def read_checkpoint(path: Path) -> dict[str, Any]:
    """Everything a checkpoint holds: ``library``, ``state``, ``box`` (objects),
    ``warm_start`` (arrays), ``rng_state``, ``progress``, ``outcome``, ``description``,
    ``rows`` (plain data)."""
    with h5py.File(path, "r") as handle:
        if handle.attrs.get("format") != CHECKPOINT_FORMAT:
            raise InputError("checkpoint", str(path), f"a {CHECKPOINT_FORMAT} file")
        saved: dict[str, Any] = {
            "library": ShapeLibrary(**{n: handle["library"][n][()] for n in _LIBRARY_FIELDS
                                       if n in handle["library"]}),
            "state": BodyState(**{n: handle["state"][n][()] for n in _STATE_FIELDS},
                               density=float(handle["state"].attrs["density"])),
            "box": WallBox.from_arrays({k: v[()] for k, v in handle["box"].items()}),
            "warm_start": {k: v[()] for k, v in handle["warm_start"].items()},
            "rows": json.loads(handle["rows"][()]),
        }
        for name in ("rng_state", "progress", "outcome", "description"):
            saved[name] = json.loads(handle.attrs[name])
    return saved


def resume_run(folder: str | Path) -> DiscreteRun:
    """Rebuild a run from its folder's config and last checkpoint (module docstring)."""
    folder = Path(folder)
    if not (folder / CONFIG).exists():
        raise InputError("run folder", str(folder), f"a run folder with a {CONFIG}")
    config = RunConfig.read(folder / CONFIG)
    path = folder / CHECKPOINT
    if not path.exists():
        run = start_run(folder, config, overwrite=True)
        run.log.info("no checkpoint: started again from the beginning")
        return run
    saved = read_checkpoint(path)
    box = saved["box"]
    sample = DiscreteSample(saved["library"], saved["state"], box, saved["description"])
    masses = box.masses.copy()
    test = DiscreteTest(sample, config.load_path(), config.settings())
    box.set_masses(masses)
    test.restore_progress(saved["progress"])
    test.outcome = saved["outcome"]
    test.rows = saved["rows"]
    test.solver.restore_warm_start(saved["warm_start"])
    test.solver.rng_state = saved["rng_state"]
    _truncate_snapshots(folder / SNAPSHOTS, test.n_snapshots)
    run = DiscreteRun(folder, config, test)
    run.last_checkpoint_step = test.simulation.step_index
    run.resumed = True
    run.write_results()
    run.log.info("resumed from the checkpoint at step %d", test.simulation.step_index)
    return run


def _truncate_snapshots(path: Path, keep: int) -> None:
    if not path.exists():
        return
    with h5py.File(path, "a") as handle:
        group = handle.get("snapshots")
        if group is None:
            return
        for name in sorted(group.keys()):
            if int(name) >= keep:
                del group[name]


def export_checkpoint_vtk(folder: str | Path, out: str | Path | None = None) -> list[Path]:
    """ParaView files of a run's last checkpoint (particles, walls) and of the contacts of
    its last snapshot (if any) in ``out`` (default RUN/vtk-checkpoint); returns the paths."""
    from grainlab.analysis.snapshot_files import count_snapshots, read_snapshot
    from grainlab.report.vtk_export import BoxWalls, ContactLines, write_vtk_frame

    folder = Path(folder)
    path = folder / CHECKPOINT
    if not path.exists():
        raise InputError("run folder", str(folder), f"a run folder with a {CHECKPOINT}")
    saved = read_checkpoint(path)
    library, state, box = saved["library"], saved["state"], saved["box"]
    contacts = None
    snapshots = folder / SNAPSHOTS
    if snapshots.exists() and count_snapshots(snapshots):
        net = read_snapshot(snapshots, -1)
        first = net.pair_particles[net.point_pairs, 0]
        start = net.positions[first]
        polyhedra = net.pair_types is not None and net.type_names == PAIR_TYPE_NAMES
        contacts = ContactLines(start=start, end=start + net.pair_branches[net.point_pairs],
                                force=net.point_forces, normal=net.point_normals,
                                sliding=net.point_sliding,
                                contact_type=net.pair_types[net.point_pairs] if polyhedra
                                else None)
    out = Path(out) if out is not None else folder / "vtk-checkpoint"
    files = write_vtk_frame(out, 0, float(saved["progress"]["time"]), positions=state.positions,
                            orientations=state.orientations, shape_ids=state.shape_ids,
                            library=library, contacts=contacts,
                            walls=BoxWalls.from_wall_box(box), velocities=state.velocities,
                            angular_velocities=state.angular_velocities)
    return sorted(files.values())
