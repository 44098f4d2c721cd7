"""A discrete run is a folder that survives being killed (ARCHITECTURE.md "Runs").

Layout of a run folder::

    config.toml        the input (grainlab.lab.run_config.RunConfig)
    results.csv        the results table in the test-result format (rewritten at every
                       checkpoint and at the end; results.h5 too at the end, with the
                       outcome in its attributes)
    snapshots.h5       contact-network snapshots (grainlab.analysis snapshot files)
    checkpoint.h5      the last checkpoint: sample, walls, solver memory, progress, rows,
                       config
    checkpoint.prev.h5 the checkpoint before it
    run.log            what happened, with times, and the outcome in words
    report/            report.md with its figures and tables, written when a run started
                       from the command line finishes (grainlab.report.run_report)
    vtk/               ParaView files when output.vtk_every > 0 (particles, contacts, walls)
    problems/          the contact problems of steps (FCLib HDF5) when output.problems_every
                       > 0 (contact dynamics; grainlab.engine.nscd.contact_problem)

Checkpoints (:mod:`grainlab.lab.run_checkpoint`: two kept, written atomically) are written
every ``output.checkpoint_every`` steps, at the end of every stage, when the run ends or stops
and when it is interrupted (Ctrl-C, SIGTERM). A run killed at any moment, even by SIGKILL,
resumes from its last checkpoint (:func:`resume_run`, ``grainlab resume RUN``), or from the
one before if the last is damaged (named, and kept as ``checkpoint.h5.damaged``): the results
table and the snapshot file are cut back to that checkpoint and the run goes on, so nothing
but the steps since the checkpoint is lost, and the run ends as it would have uninterrupted
(bit for bit, whatever the number of threads). Without a checkpoint, or with none usable,
resuming stops with a message and touches nothing; ``restart=True`` (``--restart``) starts
over after moving the run's files to ``previous-N/``. A resumed run may change the keys of
:data:`~grainlab.lab.run_config.CHANGEABLE_ON_RESUME`; the others are refused. A write that
fails (a full disk) stops the run with one message, the last good checkpoint kept
(:class:`~grainlab.lab.run_checkpoint.RunStorageError`). A run that blows up keeps its last
good checkpoint and logs the diagnosis, with the settings it can be resumed with.

When a run ends or stops, its outcome (:mod:`grainlab.lab.run_outcome`: every stage reached or
not, the inertia bound held or not, capped solver steps) goes into the results' metadata
(``outcome``; :meth:`RunOutcome.of_result <grainlab.lab.run_outcome.RunOutcome.of_result>`),
the attributes of results.h5 (``outcome_status``, ``outcome_summary``) and run.log.
"""

from __future__ import annotations

import json
import logging
import math
import os
import shutil
import signal
import time
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd

from grainlab.analysis.snapshot_files import append_snapshot
from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.shape_kinds import kinds_present
from grainlab.engine.simulation import SimulationBlowUp
from grainlab.errors import GrainlabError, InputError
from grainlab.lab.boundary_registry import boundary_record, preparing_names, quoted
from grainlab.lab.box_thickness import BOX_MIN_DIAMETERS
from grainlab.lab.discrete_test import DiscreteTest
from grainlab.lab.run_checkpoint import (
    CHECKPOINT,
    DAMAGED_SUFFIX,
    LIBRARY_FIELDS,
    PREVIOUS_CHECKPOINT,
    STATE_FIELDS,
    CheckpointContents,
    CheckpointDamaged,
    load_checkpoint,
    read_checkpoint,
    set_damaged_aside,
    storage_error,
    write_checkpoint,
)
from grainlab.lab.run_config import CHANGEABLE_ON_RESUME, RunConfig, parse_assignments
from grainlab.lab.run_estimate import refuse_endless_run
from grainlab.lab.run_operations import Every, ProblemWriter, ProgressBar
from grainlab.lab.run_outcome import RunCost, RunOutcome
from grainlab.lab.shape_library_file import library_files
from grainlab.lab.stage_numerics import COMPACTION, SHEAR
from grainlab.prep.inscribed_sample import deposited_sample, inscribed_sample
from grainlab.prep.loose_sample import loose_sample
from grainlab.prep.particle_files import read_particles
from grainlab.prep.sphere_skeleton import read_skeleton
from grainlab.result.test_result import TestResult

__all__ = ["CHECKPOINT", "PREVIOUS_CHECKPOINT", "DiscreteRun", "RunCannotGoOn",
           "RunInterrupted", "read_checkpoint", "resume_run", "start_run"]

CONFIG = "config.toml"
RESULTS = "results.csv"
RESULTS_H5 = "results.h5"
SNAPSHOTS = "snapshots.h5"
LOG = "run.log"
PROBLEMS = "problems"
RUN_FILES = (CHECKPOINT, PREVIOUS_CHECKPOINT, CHECKPOINT + DAMAGED_SUFFIX, RESULTS, RESULTS_H5,
             SNAPSHOTS, LOG, "curves.png", "vtk", "vtk-checkpoint", PROBLEMS, "report")
"""What ``--restart`` moves aside (config.toml stays, a copy goes with them), with the run's
shape library files (:mod:`grainlab.lab.shape_library_file`)."""
DT_BLAME_FACTOR = 10.0
"""A blow-up is put down to the given time step (``solver.dt``, ``--dt``) when it is at least
this many times the stage's own step (:meth:`DiscreteRun._blamed_setting`)."""
CAPPED_BLAME_SHARE = 0.9
"""... and to a sweep cap lowered below its default when at least this share of the stage's
steps ended at it."""


class RunInterrupted(GrainlabError, KeyboardInterrupt):
    """The run was interrupted by a signal; its checkpoint is on disk."""


class RunCannotGoOn(GrainlabError):
    """A run stopped for a reason that its settings still have (the message says which to
    change)."""


class _LogFile(logging.FileHandler):
    """run.log; a failed write (a full disk) is dropped, so that the error that stops the run
    stays the one message."""

    def handleError(self, record: logging.LogRecord) -> None:
        pass


def _logger(folder: Path) -> logging.Logger:
    """The run's logger, writing to a freshly opened run.log (a restart moves the old one)."""
    logger = logging.getLogger(f"grainlab.run.{folder.resolve()}")
    for handler in list(logger.handlers):
        logger.removeHandler(handler)
        handler.close()
    handler = _LogFile(folder / LOG)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = False
    return logger


def build_sample(config: RunConfig) -> DiscreteSample:
    """The sample of ``config.sample``: loose, inscribed in a deposited sphere packing or in
    the spheres of a skeleton file, or read from a particle file (``sample.preparation``)."""
    s = config.sample
    record = boundary_record(s.boundary)
    try:
        if s.preparation == "loose":
            sample = loose_sample(shape=s.shape, n_particles=s.n_particles, d_min=s.d_min,
                                  size_ratio=s.size_ratio, eta=s.eta, n_faces=s.n_faces,
                                  templates=s.templates, density=s.density,
                                  packing_fraction=s.packing_fraction,
                                  aspect=(1.0, 1.0, s.height_ratio),
                                  wall_friction=s.wall_friction, seed=s.seed,
                                  sizes=s.sizes, fine_fraction=s.fine_fraction,
                                  boundary=record.around)
            record.describe(sample.description)
            return sample
        if s.preparation not in record.preparations:
            raise InputError("preparation", s.preparation, (
                f'{quoted(record.preparations)} with boundary = "{record.name}" (a '
                'deposition fills a box of walls on a floor; use boundary = '
                f'{quoted(preparing_names(s.preparation))})'))
        shapes = {"shape": s.shape, "eta": s.eta, "n_faces": s.n_faces,
                  "templates": s.templates, "density": s.density,
                  "wall_friction": s.wall_friction, "seed": s.seed}
        if s.preparation == "deposition":
            return deposited_sample(n_particles=s.n_particles, d_min=s.d_min,
                                    size_ratio=s.size_ratio, height_ratio=s.height_ratio,
                                    **shapes)
        if bool(s.skeleton_file) == bool(s.particle_file):
            field = "particle_file" if s.particle_file else "skeleton_file"
            raise InputError(field, getattr(s, field),
                             'the path of one file (preparation = "file"): skeleton_file, a '
                             '.npz or .csv file of spheres to inscribe the particles in, or '
                             'particle_file, a .npz or .csv file of the particles themselves')
        if s.particle_file:
            sample = read_particles(s.particle_file, density=s.density,
                                    wall_friction=s.wall_friction, field="particle_file")
            sample.description["particle_file"] = s.particle_file
            return sample
        sample = inscribed_sample(read_skeleton(s.skeleton_file, field="skeleton_file"),
                                  **shapes)
        sample.description.update({"preparation": "file", "skeleton_file": s.skeleton_file})
        return sample
    except InputError as error:
        key = error.field.split(" ")[0]
        if key not in type(s).model_fields:
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
        self.notes: list[str] = []
        """What the user should know about this run besides its outcome (e.g. a damaged
        checkpoint passed over)."""
        self._vtk = None
        self._seconds = 0.0
        """Wall time [s] of the finished sessions (and of the run before its checkpoint)."""
        self._clock: float | None = None
        """``time.perf_counter()`` when the running session started; None between runs."""
        self._interrupted: list[int] = []
        """Why the running :meth:`run` was asked to stop (signal numbers; 0: a caller)."""
        test.on_snapshot = self._write_snapshot
        test.on_stage_end = self._stage_ended
        out = config.output
        if out.checkpoint_every:
            test.simulation.add(Every("checkpoint", out.checkpoint_every, self.checkpoint))
        if out.vtk_every:
            test.simulation.add(Every("vtk", out.vtk_every, self.write_vtk))
        if out.problems_every and hasattr(test.solver, "keep_problem"):
            test.simulation.add(ProblemWriter(folder / PROBLEMS, out.problems_every))

    def _stage_ended(self, test: DiscreteTest) -> None:
        ended = test.outcome["stages"][-1]
        self.log.info("stage %s ended: %s", ended["name"], ended["reason"])
        self.checkpoint()

    # -- files --------------------------------------------------------------------------------
    def _write_snapshot(self, test: DiscreteTest, network) -> None:
        append_snapshot(self.folder / SNAPSHOTS, network)

    def write_vtk(self) -> None:
        """Write one ParaView frame of the sample (particles, contacts, walls) to vtk/."""
        from grainlab.report.vtk_export import ContactLines, VtkSeries

        sim = self.test.simulation
        if self._vtk is None:
            self._vtk = VtkSeries(self.folder / "vtk", self.test.sample.library,
                                  continue_until=sim.time if self.resumed else None)
        contacts = None
        if sim.last_report is not None:
            sample = self.test.sample
            contacts = ContactLines.from_step_report(
                sim.last_report, sample.state.positions, sim.last_dt,
                friction=self.test.solver.friction,
                cell_matrix=sample.boundary.image_matrix if sample.periodic else None)
        self._vtk.add_state(sim.time, self.test.sample.state, contacts=contacts,
                            walls=_walls(self.test.sample.boundary))

    @property
    def outcome(self) -> RunOutcome:
        """The run so far judged against what was asked (:mod:`grainlab.lab.run_outcome`)."""
        outcome = self.test.run_outcome()
        if self.notes:
            outcome = RunOutcome(outcome.stages, outcome.finished, outcome.steps,
                                 outcome.stopped, tuple(self.notes))
        return outcome

    @property
    def wall_time(self) -> float:
        """Seconds spent running so far (:class:`~grainlab.lab.run_outcome.RunCost`): the
        sessions that made the steps kept, this one included; NaN for a run resumed from a
        checkpoint written before wall times were kept."""
        running = 0.0 if self._clock is None else time.perf_counter() - self._clock
        return self._seconds + running

    @property
    def cost(self) -> RunCost:
        """Wall time, steps and (soft-contact DEM) sub-steps so far."""
        test = self.test
        return RunCost(wall_time=self.wall_time, steps=test.simulation.step_index,
                       substeps=test.solver_record.substeps(test.solver))

    def result(self) -> TestResult:
        """The results so far in the test-result format; ``metadata["outcome"]`` is
        :meth:`RunOutcome.to_dict <grainlab.lab.run_outcome.RunOutcome.to_dict>`,
        ``metadata["cost"]`` :meth:`RunCost.to_dict
        <grainlab.lab.run_outcome.RunCost.to_dict>`."""
        test = self.test
        table = pd.DataFrame(test.rows)
        result = TestResult.create(
            table, specimen={"kind": "discrete sample", **test.sample.description},
            load_path={"name": test.path.name, "description": test.path.description,
                       "stages": [test.boundary_record.stage_data(s)
                                  for s in test.stages]},
            parameters={"settings": test.settings.to_dict(),
                        "config": self.config.model_dump()},
            outcome=_plain(self.outcome.to_dict()),
            dimension=test.path.dimension, title=f"{test.path.name} on a discrete sample")
        result.metadata["cost"] = _plain(self.cost.to_dict())
        return result

    def write_results(self, final: bool = False) -> None:
        """Rewrite results.csv (and results.h5, with the outcome in its attributes, when
        ``final``), each through a temporary file renamed over it: a failed write raises
        :class:`~grainlab.lab.run_checkpoint.RunStorageError` and keeps the previous file."""
        if not self.test.rows:
            return
        result = self.result()
        targets = [(RESULTS, result.to_csv)]
        if final:
            targets.append((RESULTS_H5, lambda path: self._results_h5(result, path)))
        for name, write in targets:
            path = self.folder / name
            tmp = path.with_name(path.name + ".tmp")
            try:
                write(tmp)
                os.replace(tmp, path)
            except OSError as error:
                tmp.unlink(missing_ok=True)
                raise storage_error(error, str(path), self._kept()) from None

    def _results_h5(self, result: TestResult, path: Path) -> None:
        result.to_hdf5(path)
        outcome = result.metadata["outcome"]
        with h5py.File(path, "a") as handle:
            handle.attrs["outcome_status"] = outcome["status"]
            handle.attrs["outcome_as_asked"] = bool(outcome["as_asked"])
            handle.attrs["outcome_summary"] = outcome["summary"]

    def _kept(self) -> str:
        if self.last_checkpoint_step < 0:
            return f"No checkpoint of this run is on disk yet ({self.folder})."
        return (f"The last good checkpoint (step {self.last_checkpoint_step}) is kept in "
                f"{self.folder / CHECKPOINT}.")

    def _checkpoint_contents(self) -> CheckpointContents:
        test = self.test
        return CheckpointContents(
            groups={"state": {n: getattr(test.sample.state, n) for n in STATE_FIELDS},
                    "library": {n: getattr(test.sample.library, n) for n in LIBRARY_FIELDS},
                    "box": test.sample.boundary.to_arrays(),
                    "warm_start": test.solver.warm_start_arrays()},
            group_attrs={"state": {"density": test.sample.state.density},
                         "box": {"kind": test.boundary_record.checkpoint_kind}},
            attrs={"rng_state": json.dumps(test.solver.rng_state),
                   "progress": json.dumps(_plain(test.progress_arrays())),
                   "outcome": json.dumps(_plain(test.outcome)),
                   "description": json.dumps(_plain(test.sample.description)),
                   "config": json.dumps(self.config.model_dump()),
                   "wall_time": self.wall_time},
            datasets={"rows": json.dumps(_plain(test.rows))})  # a dataset: no 64 kB limit

    def checkpoint(self) -> Path:
        """Write a checkpoint (module docstring), then results.csv; returns its path."""
        test = self.test
        # a second checkpoint at the same step (a stage's end, then the run's) replaces the
        # first, so that checkpoint.prev.h5 stays an earlier step
        path = write_checkpoint(self.folder, self._checkpoint_contents(), kept=self._kept(),
                                rotate=test.simulation.step_index != self.last_checkpoint_step)
        self.last_checkpoint_step = test.simulation.step_index
        self.write_results()
        self.log.info("checkpoint at step %d (t = %.6g s, %d rows, %d snapshots)",
                      test.simulation.step_index, test.simulation.time, len(test.rows),
                      test.n_snapshots)
        return path

    # -- running ------------------------------------------------------------------------------
    def request_interrupt(self, reason: int = 0) -> None:
        """Stop the running :meth:`run` as Ctrl-C does: the step in progress finishes, a
        checkpoint is written and :class:`RunInterrupted` is raised. Safe to call from a
        record callback (``test.on_record``) of the thread that runs the run (a study's
        sample asked to stop by its study)."""
        self._interrupted.append(reason)
        self.test.simulation.request_stop()

    def run(self, progress: bool = False, max_steps: int | None = None) -> TestResult:
        """Run to the end, or until the test halts in a stage (its outcome says why), or
        ``max_steps`` more steps. Ctrl-C / SIGTERM let the current step finish, checkpoint and
        raise :class:`RunInterrupted`; a blow-up is logged and re-raised with its diagnosis
        and the last good checkpoint kept."""
        test = self.test
        interrupted = self._interrupted
        interrupted.clear()

        def on_signal(signum, frame):
            # deferred: the step in progress finishes, so the checkpoint is consistent
            self.request_interrupt(signum)

        previous = {}
        for signum in (signal.SIGTERM, signal.SIGINT):
            try:
                previous[signum] = signal.signal(signum, on_signal)
            except ValueError:  # not the main thread: signals stay as they are
                break
        bar = ProgressBar(test) if progress else None
        if bar is not None:
            test.on_record = bar.update
        start = self._clock = time.perf_counter()
        try:
            if bar is not None:
                bar.start()
            while not test.finished and not test.halted and not interrupted:
                test.run(max_steps)
                if interrupted:
                    raise KeyboardInterrupt
                if max_steps is not None:
                    break
            self._stop_clock()  # the files written at the end carry the same wall time
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
            diagnosed = SimulationBlowUp(self._blow_up_diagnosis(error))
            self.log.error("blow-up: %s", diagnosed)
            raise diagnosed from None
        finally:
            self._stop_clock()
            if bar is not None:
                bar.stop()
            for signum, handler in previous.items():
                signal.signal(signum, handler)
        elapsed = time.perf_counter() - start
        if test.finished or test.halted:
            if test.finished:
                for stage in test.outcome["stages"][-1:]:
                    self.log.info("stage %s ended: %s", stage["name"], stage["reason"])
            else:
                self.log.warning("stage %s stopped: %s", test.halted["stage"],
                                 test.halted["reason"])
            self.checkpoint()
            self.write_results(final=True)
            if self._vtk is not None:
                self._vtk.close()
            self.log.info("run %s at step %d in %.1f s of this session",
                          "finished" if test.finished else "stopped",
                          test.simulation.step_index, elapsed)
            outcome = self.outcome
            (self.log.info if outcome.as_asked else self.log.warning)("%s", outcome.summary())
        return self.result()

    def _stop_clock(self) -> None:
        """Add the running session's seconds to the wall time and stop counting."""
        if self._clock is not None:
            self._seconds += time.perf_counter() - self._clock
            self._clock = None

    def _blow_up_diagnosis(self, error: SimulationBlowUp) -> str:
        """The blow-up's message, with the setting that most likely caused it
        (:meth:`_blamed_setting`: a given time step far above the stage's own, a sweep cap
        that every step of the stage hit) or else the box's thickness where the box is
        thinner than a few particles (then no time step helps), and how to go on."""
        test, folder = self.test, self.folder
        text = str(error)
        blamed = self._blamed_setting()
        if blamed is not None:
            text += f" Likely cause: {blamed[0]}"
        else:
            lengths = test.sample.box.lengths
            ratios = lengths / test.largest_diameter
            a = int(np.argmin(ratios))
            if ratios[a] < BOX_MIN_DIAMETERS:
                text += (f" The box is only {lengths[a] * 1e3:.3g} mm along {'xyz'[a]}, "
                         f"{ratios[a]:.2f} largest particle diameters (d_max = "
                         f"{test.largest_diameter * 1e3:.3g} mm): squeezed into one or two "
                         "layers the particles lock, and a smaller time step or tolerance "
                         "will not help; ask a smaller strain or use more particles.")
        if self.last_checkpoint_step < 0:
            change = (f"set {blamed[1]} = {blamed[2]} in {folder / CONFIG}" if blamed
                      else f"edit {folder / CONFIG}")
            return text + (f" No checkpoint was written: {change} and start over with "
                           f"`grainlab resume {folder} --restart`.")
        if blamed is not None:
            return text + (
                f" The last good checkpoint is at step {self.last_checkpoint_step}; resume it "
                f"with `grainlab resume {folder} --set {blamed[1]}={blamed[2]}`.")
        key, numerics = f"solver.{test.stage_kind}", test.stage_numerics
        return text + (
            f" The last good checkpoint is at step {self.last_checkpoint_step}; resume it with "
            f"other settings, e.g. `grainlab resume {folder} --set "
            f"{key}.time_step_factor={numerics.time_step_factor / 2:g} --set "
            f"{key}.tolerance={numerics.tolerance / 10:g}` (keys that can change on resume: "
            + ", ".join(CHANGEABLE_ON_RESUME) + ").")

    def _blamed_setting(self) -> tuple[str, str, str] | None:
        """The setting that most likely made the run blow up, as (words naming it, its
        value and what to try; its config key; the value to try), or None: a time step
        ``solver.dt`` (``--dt``) at least :data:`DT_BLAME_FACTOR` times the stage's own
        step (:meth:`~grainlab.lab.discrete_test.DiscreteTest.automatic_step`), or a sweep
        cap ``solver.<kind>.max_iterations`` below its default that at least
        :data:`CAPPED_BLAME_SHARE` of the stage's steps so far hit."""
        test = self.test
        if test.stage is None:
            return None
        kind, numerics, dt = test.stage_kind, test.stage_numerics, test.settings.dt
        own = test.automatic_step() if test.stage_wall_speed > 0.0 else math.nan
        if dt is not None and dt >= DT_BLAME_FACTOR * own:
            longest = own * (numerics.time_step_growth if test.solver_record.grows_step
                             else 1.0)
            return (f"the time step solver.dt = {dt:g} s (--dt) is {dt / own:.3g} times this "
                    f"{kind} stage's own step, {own:.3g} s (time_step_factor "
                    f"{numerics.time_step_factor:g} x d_min / wall speed): leave --dt out "
                    "(solver.dt = 0: each stage chooses its step, the lab's), or give at most "
                    f"{longest:.2g} s.", "solver.dt", "0")
        steps = test.simulation.step_index - test.stage_start_step
        capped = test.simulation.unconverged_steps - test.stage_start_unconverged
        default = {"compaction": COMPACTION, "shear": SHEAR}[kind].max_iterations
        if steps > 0 and capped >= CAPPED_BLAME_SHARE * steps \
                and numerics.max_iterations < default:
            option = " (--max-iterations)" if kind == "shear" else ""
            share = f"all {steps}" if capped >= steps else f"{capped} of the {steps}"
            return (f"{share} steps of this {kind} stage ended unconverged at the sweep cap "
                    f"solver.{kind}.max_iterations = {numerics.max_iterations}{option}: "
                    f"raise it (default {default}; 100 to 1000 is usual).",
                    f"solver.{kind}.max_iterations", str(default))
        return None


def _walls(boundary):
    """The walls to draw: a box of walls (a :class:`~grainlab.engine.boundaries.wall_box.
    WallBox` or a box derived from it) as six faces; None for any other boundary (a
    periodic cell has none)."""
    from grainlab.engine.boundaries.wall_box import WallBox
    from grainlab.report.vtk_export import BoxWalls

    return BoxWalls.from_wall_box(boundary) if isinstance(boundary, WallBox) else None


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
    """Build the sample and the test, refusing targets that would flatten the box
    (:meth:`~grainlab.lab.discrete_test.DiscreteTest.predicted_flattening`); then create the
    run folder (refusing to replace a run unless ``overwrite``) and write the config."""
    folder = Path(folder)
    if (folder / CHECKPOINT).exists() or (folder / CONFIG).exists():
        if not overwrite:
            raise InputError("run folder", str(folder),
                             "a new folder (this one holds a run: `grainlab resume` it, or "
                             "pass --overwrite)")
    test = _new_test(config)
    if overwrite:
        for name in (CHECKPOINT, PREVIOUS_CHECKPOINT, RESULTS, RESULTS_H5, SNAPSHOTS, LOG):
            (folder / name).unlink(missing_ok=True)
    return _create(folder, config, test)


def test_for(sample: DiscreteSample, config: RunConfig) -> DiscreteTest:
    """The lab test of ``config`` on ``sample`` (:class:`~grainlab.lab.discrete_test.
    DiscreteTest`, in the sample's box of walls or periodic cell)."""
    return DiscreteTest(sample, config.load_path(), config.settings())


def _new_test(config: RunConfig) -> DiscreteTest:
    """The sample and the test of ``config``, its targets checked against the box."""
    config.load_path()  # a path the boundary cannot run is refused before the sample is made
    config.check_solver()  # and a shape the solver cannot run
    sample = build_sample(config)
    config.check_solver(kinds_present(sample.library.kind))  # the file's shapes
    test = test_for(sample, config)
    _refuse_flattening(test)
    test.boundary_record.refuse_start(test, config.sample)
    refuse_endless_run(test, config)
    return test


def _create(folder: Path, config: RunConfig, test: DiscreteTest) -> DiscreteRun:
    folder.mkdir(parents=True, exist_ok=True)
    config.write(folder / CONFIG)
    run = DiscreteRun(folder, config, test)
    run.log.info("run started: %s, %d %s particles", config.test.kind,
                 test.sample.state.n_bodies, test.sample.description.get("shape", ""))
    return run


_TARGET_KEYS = {"eps_q": "test.eps_q_max", "eps_zz": "test.axial_strain"}


def _refuse_flattening(test: DiscreteTest) -> None:
    """An :class:`InputError` naming the config key of the first target that would flatten
    the box (:meth:`~grainlab.lab.discrete_test.DiscreteTest.predicted_flattening`)."""
    for flat in test.predicted_flattening():
        key = _TARGET_KEYS.get(flat.quantity, f"stage {flat.stage!r} target")
        raise InputError(key, flat.asked, (
            f"at most about {flat.largest:.3g} for this sample: {flat.words()} ("
            f"{test.sample.state.n_bodies} particles); "
            f"{flat.advice()}"))


def _move_aside(folder: Path) -> Path:
    """Move the run's files (:data:`RUN_FILES`) and a copy of config.toml to
    ``folder/previous-N`` (N the first free number); returns that folder."""
    n = 1
    while (folder / f"previous-{n}").exists():
        n += 1
    aside = folder / f"previous-{n}"
    aside.mkdir()
    shutil.copy2(folder / CONFIG, aside / CONFIG)
    for name in RUN_FILES + tuple(path.name for path in library_files(folder)):
        if (folder / name).exists():
            os.replace(folder / name, aside / name)
    return aside


def resume_run(folder: str | Path, changes: list[str] | dict | None = None, *,
               restart: bool = False) -> DiscreteRun:
    """Rebuild a run from its folder's config and last usable checkpoint (module docstring).

    Parameters
    ----------
    folder:
        The run folder.
    changes:
        Config keys to change, ``["solver.shear.tolerance=1e-5"]`` or ``{"solver": {...}}``
        (:data:`~grainlab.lab.run_config.CHANGEABLE_ON_RESUME`; keys edited in config.toml
        count too). Refused keys raise :class:`InputError` naming them.
    restart:
        Start the run over from step 0 with its config (and ``changes``, any key), after
        moving its files to ``folder/previous-N``. Without it, a folder without a usable
        checkpoint raises :class:`~grainlab.lab.run_checkpoint.NoCheckpoint` or
        :class:`~grainlab.lab.run_checkpoint.CheckpointDamaged` and is left as it is.
    """
    folder = _run_folder(folder)
    edited = RunConfig.read(folder / CONFIG, saved=True)
    if isinstance(changes, list):
        changes = parse_assignments(changes)
    config = edited.with_updates(changes) if changes else edited
    if restart:
        test = _new_test(config)  # refused before any file moves
        aside = _move_aside(folder)
        run = _create(folder, config, test)
        run.log.info("started over from step 0; the previous run's files are in %s", aside)
        run.notes.append(f"started over from step 0; the previous run's files are in {aside}")
        return run
    loaded = load_checkpoint(folder)
    saved = loaded.saved
    started = RunConfig.of_saved_run(saved["config"]) if saved["config"] else edited
    changed = config.changes_on_resume(started)
    box = saved["box"]
    sample = DiscreteSample(saved["library"], saved["state"], box, saved["description"])
    # the test's walls take their masses when it is made: the saved ones are put back
    masses = box.masses.copy() if hasattr(box, "set_masses") else None
    test = test_for(sample, config)
    if masses is not None:
        box.set_masses(masses)
    test.restore_progress(saved["progress"])
    test.outcome = saved["outcome"]
    test.rows = saved["rows"]
    test.solver.restore_warm_start(saved["warm_start"])
    test.solver.rng_state = saved["rng_state"]
    if any(_is_target(key) for key in changed):
        _check_stages(test, started, changed)
        _refuse_flattening(test)
    test.apply_settings(started.settings())
    why = test.resumable()
    if why:
        raise RunCannotGoOn(f"{folder} cannot go on: {why}.")
    notes = []
    if loaded.fell_back:
        for path, damage in loaded.passed_over:
            if damage == "missing":
                notes.append(f"{path.name} is missing")
            else:
                aside = set_damaged_aside(path)
                notes.append(f"{path.name} is damaged ({damage}); kept as {aside.name}")
        notes.append(f"resumed from the previous checkpoint {loaded.path.name} (step "
                     f"{test.simulation.step_index}): the steps since are run again")
    if changed:
        config.write(folder / CONFIG)
    _truncate_snapshots(folder / SNAPSHOTS, test.n_snapshots)
    run = DiscreteRun(folder, config, test)
    run.notes += notes
    run.last_checkpoint_step = test.simulation.step_index
    run._seconds = saved["wall_time"]
    run.resumed = True
    if not test.finished:
        (folder / RESULTS_H5).unlink(missing_ok=True)  # rewritten at the end
    run.write_results()
    for note in notes:
        run.log.warning("%s", note)
    for key, (before, after) in changed.items():
        run.log.info("changed on resume: %s = %r (was %r)", key, after, before)
    run.log.info("resumed from %s at step %d", loaded.path.name, test.simulation.step_index)
    return run


def _is_target(key: str) -> bool:
    """A key of ``[test]`` that sets a stage's target (not when a compaction has settled)."""
    return key.startswith("test.") and not key.startswith("test.quasi_static.")


def _check_stages(test: DiscreteTest, started: RunConfig, changed: dict) -> None:
    """Refuse target changes that touch a stage already ended (or the stage under way's
    kind): an :class:`InputError` naming the key."""
    key = next(k for k in changed if _is_target(k))
    before = test.load_stages(started.load_path())
    after = test.stages
    begun = test.stage_index + (1 if test.stage_started else 0)
    for i in range(min(begun, len(before))):
        ended = i < test.stage_index
        same = i < len(after) and after[i].name == before[i].name and \
            after[i].modes == before[i].modes and (not ended or after[i] == before[i])
        if not same:
            state = "has ended" if ended else "is under way"
            raise InputError(key, changed[key][1], (
                f"{changed[key][0]!r}: stage {before[i].name} {state} with it (a target can "
                "change only for a stage not ended yet)"))
    if test.finished and len(after) != len(before):
        raise InputError(key, changed[key][1], f"{changed[key][0]!r}: the run has finished")


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
    the snapshot taken at its step (none when no snapshot was taken at that step) in ``out``
    (default RUN/vtk-checkpoint); returns the paths. A folder that holds no run raises
    :class:`InputError` saying how to start one; a damaged ``checkpoint.h5`` is refused
    (:class:`~grainlab.lab.run_checkpoint.CheckpointDamaged`), not passed over for the
    previous checkpoint, whose particles would be drawn among later snapshots and results."""
    from grainlab.analysis.snapshot_files import count_snapshots, read_snapshot
    from grainlab.report.vtk_export import ContactLines, write_vtk_frame

    folder = _run_folder(folder)
    loaded = load_checkpoint(folder)
    for path, damage in loaded.passed_over:
        if damage != "missing":
            raise CheckpointDamaged(
                f"{path} is damaged ({damage}): the run's last checkpoint cannot be drawn, and "
                f"{loaded.path.name} (step {loaded.saved['progress']['step_index']}) is older "
                f"than the run's snapshots and results. `grainlab resume {folder}` goes on from "
                f"{loaded.path.name} (the damaged file kept as {path.name}{DAMAGED_SUFFIX}) "
                f"and writes a new checkpoint; then `grainlab vtk {folder}` draws it.")
    saved = loaded.saved
    library, state, box = saved["library"], saved["state"], saved["box"]
    progress = saved["progress"]
    step = progress["step_index"]
    contacts = None
    snapshots = folder / SNAPSHOTS
    present = count_snapshots(snapshots) if snapshots.exists() else 0
    # the checkpoint's own last snapshot (a run killed after a later one holds more)
    own = min(int(progress.get("n_snapshots", present)), present)
    if own:
        net = read_snapshot(snapshots, own - 1)
        if net.state.get("step", step) == step:
            contacts = ContactLines.from_network(
                net, float(state.positions[0, 2]) if state.n_bodies else 0.0,
                library.thickness)
    out = Path(out) if out is not None else folder / "vtk-checkpoint"
    files = write_vtk_frame(out, 0, float(progress["time"]), positions=state.positions,
                            orientations=state.orientations, shape_ids=state.shape_ids,
                            library=library, contacts=contacts,
                            walls=_walls(box), velocities=state.velocities,
                            angular_velocities=state.angular_velocities)
    return sorted(files.values())


def _run_folder(folder: str | Path) -> Path:
    """``folder`` as a :class:`Path` if it holds a run (its config.toml), else an
    :class:`InputError` that says how to start one there."""
    folder = Path(folder)
    if not (folder / CONFIG).exists():
        raise InputError("run folder", str(folder), (
            f"a run folder, with its {CONFIG}: this folder holds no run; start one there with "
            f"e.g. `grainlab triaxial --out {folder}` (the tests: `grainlab --help`)"))
    return folder
