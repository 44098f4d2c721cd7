"""A load path run on a discrete sample, in a box of walls or a periodic cell (contact
dynamics or soft-contact DEM; seeds 002/003).

:class:`DiscreteTest` is one stage loop whatever the boundary: its boundary
(:mod:`grainlab.lab.stage_boundary`: the box of walls, :class:`~grainlab.lab.box_boundary.
BoxBoundary`, or the periodic cell, :class:`~grainlab.lab.cell_boundary.CellBoundary`, as
the record of the sample's boundary in :mod:`grainlab.lab.boundary_registry` says) turns
the stages of a lab :class:`~grainlab.lab.load_path.LoadPath` into its controls and owns
their strains, progress, ends and thickness checks; its solver is a record of
:mod:`grainlab.lab.solver_registry`. The test runs them on a
:class:`~grainlab.engine.simulation.Simulation` through two operations: the stage control
(boundary driven, stage ends decided) and the recorder (one results row every
``record_every`` steps, a contact-network snapshot at the first record at or past each
multiple of ``snapshot_every`` steps, at the first
record past each strain of ``snapshot_eps_q`` in a strain-driven stage, and of the state
each stage ends in, so that a short run has its compaction and its end to analyse).
Everything it needs to go on is plain data (:meth:`DiscreteTest.progress_arrays`), so a run
can checkpoint and resume.

Per stage, with the numerics of its kind (:class:`~grainlab.lab.stage_numerics.StageNumerics`:
``settings.compaction`` in stages without a strain-controlled axis, ``settings.shear``
otherwise; :meth:`DiscreteTestSettings.numerics_for`):

* interparticle friction (default 0 in compaction, seed 002; 0.4 in shear);
* strain rate eps_dot from the bound on the inertia number at the stage's reference stress;
  the stage's wall speed eps_dot L, L the boundary's largest width;
* time step h = ``time_step_factor`` x d_min / v (defaults 0.003 in shear, 0.01 in
  compaction), v the largest wall speed of the stage, d_min the smallest member-sphere
  diameter or, for polyhedra, the smallest inscribed diameter (twice the smallest distance from
  a centre of mass to a face plane; :func:`time_step_length`) (research/cd_engines.md pitfall
  6: v h <= 0.01-0.05 d_min), unless ``dt`` is given. In triaxial shear the solver ends each
  step with small velocity violations (the NLGS residual stalls near the tolerance however
  many sweeps: docs/explanations/contact-problem.md, "The contact problem on its own") and contact
  dynamics never pushes an overlap back, so overlaps accumulate at a
  rate that falls faster than h: with 0.01 the largest overlap reached 6-9 % of <d> at
  eps_q = 0.1 on 200 spheres, with 0.003 below 1 %. That h is the stage's shortest step h_0:
  with contact dynamics the step grows from it to ``time_step_growth`` x h_0 (default 2)
  while the largest overlap stays below ``overlap_bound`` (0.5 % of <d>) and halves when it
  exceeds it (:mod:`grainlab.lab.step_control`; the scale is part of the checkpoint);
* NLGS tolerance, sweep cap and overlap recovery (0 in compaction by default);
* with polyhedra (shape kinds that spin fast, :func:`spins_fast`), the step is also
  shortened, before every step, to travel / max_i (|v_i| + |omega_i| R_i) (R_i the
  circumscribed radius), travel = max(factor x d_min, ALERT_TRAVEL x alert) (alert the
  detection's alert distance, 0.05 d_min by default: :data:`ALERT_TRAVEL`), times the step's
  growth (the overlaps decide both), whenever the particles' points move faster than that,
  and the solver adds the gyroscopic term. A
  polyhedron's contact rows are its close feature pairs: a corner turning towards a face has
  no row until a detection finds it within the alert distance, so no point may cover a
  large share of it in one step; a row's gap is then predicted to first order, with a
  second-order error R (omega h)^2 / 2 < 4e-5 d_min per step at the shear's travel.
  Particles squeezed by converging walls move 2-10 times faster than the walls and spin at
  up to ~1000 rad/s: a corner turning by 0.1 rad per step left
  overlaps that grew to 10 % of <d> in 40 steps (a 12-polyhedron compaction). In shear the
  fastest point is mostly a rattler's (a polyhedron sliding and spinning on a frictionless
  wall at 3-7 times the walls' speed): with travel = factor x d_min (0.003 d_min in shear)
  a polyhedra sample took 4-13 times the steps of a sphere sample to the same strain. With
  ALERT_TRAVEL x alert = 0.00625 d_min (100 polyhedra of 46 faces to eps_q = 0.3, three
  seeds) it takes half the shear steps and 1.25 times less wall time in all, with the largest
  overlap 0.30-0.55 % of <d> (0.12-0.19 % before; spheres ~0.5 % at their wall-based step)
  and the same strength within the seeds' spread (sin phi residual 0.541 against 0.551, peak
  0.692 against 0.715); at 0.25 of the alert distance the steps fell 4.4 times but the mean
  overlap rose from 0.03 % to 0.47 % of <d>.
  Spheres and aggregates keep the wall-based step (their results unchanged);
* the boundary's own controls (:mod:`grainlab.lab.box_boundary`: wall speeds, servo walls,
  logarithmic strains from the reference box; :mod:`grainlab.lab.cell_boundary`: the cell's
  velocity gradient and servo, natural strains from the reference cell).

A stage that reaches ``max_stage_steps`` first did not reach its end: the test stops there
(``halted``; the stage goes on when resumed with a larger cap), or with
``at_max_stage_steps = "next_stage"`` the next stage starts all the same; either way
:meth:`DiscreteTest.run_outcome` says the stage was not reached (:mod:`grainlab.lab.
run_outcome`). A stage whose target would leave the boundary too thin for its particles does
not start, and one whose boundary gets there stops (``halted``), both with the diagnosis;
:meth:`DiscreteTest.predicted_flattening` checks a whole path before a run.

Stage ends do not wait for a record. After every step the boundary alone decides
(:meth:`DiscreteTest.boundary_end`): stop criteria on its strain columns, its targets, its
thickness, and ``max_stage_steps``; the step that would carry a stage past a target is cut
(:data:`~grainlab.lab.stage_boundary.SHORTEST_CUT`, :data:`~grainlab.lab.stage_boundary.
TARGET_MARGIN`).

The state a stage ends in is always a results row (the last of the stage), whatever
``record_every``; stop criteria on other columns, and quasi-static ends, are checked at the
records. The cut step length is the solver's step, saved in checkpoints like the rest, so a
resumed run takes the same steps.

Columns besides :mod:`grainlab.engine.sample_measures`: ``stage``, ``step``, ``time`` [s],
``dt`` [s], ``unbalanced_force_ratio``, ``kinetic_energy_ratio``, ``velocity_zigzag`` (the
soft-contact solver's :attr:`~grainlab.engine.dem.soft_contact.SoftContactStep.velocity_zigzag`,
NaN without sub-steps: the run's outcome reads it, :mod:`grainlab.lab.run_outcome`),
``friction``, and in tests with a one-dimensional stage (:attr:`~grainlab.lab.wall_stages.
WallStage.oedometric`) ``K0`` = (sigma_xx + sigma_yy) / (2 sigma_zz) [-] (2D: sigma_xx /
sigma_yy) of the contact stresses.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from grainlab.engine.shape_kinds import kinds_present, library_time_step_length
from grainlab.engine.simulation import Periodic, Simulation
from grainlab.engine.state import ShapeLibrary
from grainlab.errors import CellTooThin, InputError
from grainlab.lab.boundary_registry import boundary_record_of
from grainlab.lab.box_thickness import Flattening
from grainlab.lab.discrete_test_settings import RECOVERY_SPEED_FRACTION, DiscreteTestSettings
from grainlab.lab.load_path import LoadPath
from grainlab.lab.run_outcome import (
    BOX_TOO_THIN,
    MAX_STAGE_STEPS,
    REACHED,
    UNFINISHED,
    RunOutcome,
    stage_outcome,
)
from grainlab.lab.solver_registry import solver_record
from grainlab.lab.stage_boundary import (
    MAX_STEPS_REASON,
    THIN_BOX,
    StageBoundary,
    stop_reason,
)
from grainlab.lab.stage_numerics import (
    StageNumerics,
    stage_kind,
)
from grainlab.lab.step_control import OverlapStepControl
from grainlab.lab.wall_stages import QuasiStaticCriteria
from grainlab.prep.loose_sample import DiscreteSample


def time_step_length(library: ShapeLibrary) -> float:
    """The length d_min [m] that scales the automatic time step (module docstring): the
    smallest over the library's shape kinds of each kind's length
    (:func:`~grainlab.engine.shape_kinds.library_time_step_length`): the smallest
    member-sphere diameter of the sphere-based shapes and the smallest inscribed diameter
    2 min_f (n_f . v_f) of the polyhedra (face planes about the centre of mass)."""
    return library_time_step_length(library)


def spins_fast(library: ShapeLibrary) -> bool:
    """Whether a kind of the library spins fast
    (:attr:`~grainlab.engine.shape_kinds.ShapeKind.spins_fast`: polyhedra): the step then
    follows the particles' own speeds too, and free rotation has its gyroscopic term."""
    return any(kind.spins_fast for kind in kinds_present(library.kind, "library.kind"))


ALERT_TRAVEL = 0.125
"""Largest travel per step of a point of a fast-spinning particle, as a fraction of the
contact detection's alert distance [-] (module docstring): two bodies closing in can then
cover at most half of it between two detections, so that every contact has its row (its gap
predicted over the step) before it closes."""


class DiscreteTest:
    """A load path on a discrete sample (module docstring): one stage loop, its boundary's
    (:attr:`boundary`) and its solver's (:attr:`solver_record`) parts read from them.

    Parameters
    ----------
    sample:
        The sample (in a box of walls or a periodic cell: its boundary's controls are set by
        the stages).
    path:
        A 3D lab load path (e.g. :func:`grainlab.lab.presets.triaxial_compression`).
    settings:
        :class:`DiscreteTestSettings`.
    on_record, on_snapshot:
        Optional callables ``(test, row)`` and ``(test, network)`` called after each results
        row and each snapshot (files, progress bars).
    """

    def __init__(self, sample: DiscreteSample, path: LoadPath,
                 settings: DiscreteTestSettings | None = None, *, on_record=None,
                 on_snapshot=None) -> None:
        self.sample = sample
        self.path = path
        self.settings = settings or DiscreteTestSettings()
        self.solver_record = solver_record(self.settings.method)
        self.boundary_record = boundary_record_of(sample.boundary)
        self.boundary: StageBoundary = self.boundary_record.stage_driver(self)
        self.stages = self.load_stages(path)
        self.reports_k0 = any(stage.oedometric for stage in self.stages)
        self.on_record = on_record
        self.on_snapshot = on_snapshot
        self.on_stage_end = None
        self.rows: list[dict[str, Any]] = []
        self.stage_index = 0
        self.stage_started = False
        self.stage_start_step = 0
        self.strain_rate = 0.0
        self.n_snapshots = 0
        self._unsnapped: tuple[Any, dict[str, Any]] | None = None
        self._eps_q_reached: tuple[int, float] | None = None  # stage index, largest eps_q
        self.finished = False
        self.halted: dict[str, str] | None = None
        """Why the test stopped before the end of its path (``stage``, ``ended`` of
        :data:`~grainlab.lab.run_outcome.ENDINGS`, ``reason``); None while it may go on."""
        self.outcome: dict[str, Any] = {"stages": []}
        self.stage_start_unconverged = 0
        self.stage_wall_speed = 0.0
        self.largest_diameter = float(2.0 * np.max(
            sample.library.bounding_radius[sample.state.shape_ids]))
        s = self.settings
        self.adaptive_step = spins_fast(sample.library)
        self.stage_dt = s.dt or 1.0
        self.step_control = OverlapStepControl(1.0, 1.0)
        self.solver, self.contact_law = self.solver_record.build(
            s, sample, lambda: self.boundary.confining(self.stages[0]), self.adaptive_step)
        self.simulation = Simulation(sample, self.solver)
        self.simulation.add(_StageControl(self))
        self.simulation.add(_Recorder(self, Periodic(s.record_every)))

    def load_stages(self, path: LoadPath) -> list:
        """The path's stages as this test's boundary runs them (its solver's grains
        deformable or not: :attr:`~grainlab.lab.solver_registry.SolverRecord.deformable`)."""
        return self.boundary.load_stages(path, self.solver_record.deformable)

    # -- stage logic --------------------------------------------------------------------------
    @property
    def stage(self):
        """The current stage (None when finished)."""
        return None if self.stage_index >= len(self.stages) else self.stages[self.stage_index]

    @property
    def stage_kind(self) -> str:
        """``"compaction"`` or ``"shear"``: the kind of the current stage
        (:func:`~grainlab.lab.stage_numerics.stage_kind`), which names its numerics."""
        return stage_kind(bool(self.stage.moving_axes))

    @property
    def stage_numerics(self) -> StageNumerics:
        """The numerics of the current stage (:meth:`DiscreteTestSettings.numerics_for`)."""
        return self.settings.numerics_for(bool(self.stage.moving_axes))

    def mean_stress_reached(self, stage) -> float:
        """The mean stress of the last record [Pa]: the reference of a stage without a stress
        target."""
        p = self.rows[-1]["p"] if self.rows else math.nan
        if not (math.isfinite(p) and p > 0.0):
            raise InputError(f"stage {stage.name!r}", "no stress reference",
                             "a stress-controlled axis, or a previous stage that loaded the "
                             "sample (the strain rate follows from the inertia number at p)")
        return p

    def start_stage(self) -> None:
        """Set the boundary's control, the friction, strain rate and time step of the
        current stage; a stage whose target would leave the boundary too thin does not
        start (the test halts, module docstring)."""
        stage = self.stage
        assert stage is not None
        refusal = self.boundary.refuse_start(stage)
        if refusal:
            self.halt(BOX_TOO_THIN, refusal)
            return
        p_ref = self.boundary.confining(stage)
        self.strain_rate = self.stage_numerics.inertia_number * \
            math.sqrt(p_ref / self.sample.state.density) / self.sample.mean_diameter
        self.boundary.start(stage, p_ref)
        self.stage_wall_speed = self.strain_rate * self.boundary.width()  # [m/s]
        self.stage_start_step = self.simulation.step_index
        self.stage_start_unconverged = self.simulation.unconverged_steps
        self.step_control.scale = 1.0  # every stage starts at its shortest step
        self._stage_numerics()
        self.boundary.after_step(stage)
        self.stage_started = True

    def _stage_numerics(self) -> None:
        """The solver settings, time step and the boundary's speed limits and masses of the
        current stage, from the settings and the stage's wall speed ``stage_wall_speed``."""
        s, numerics = self.settings, self.stage_numerics
        # overlap recovery slower than the walls: beta |g| / h alone grows without bound as
        # the step shortens (spinning polyhedra), and then blows the sample apart
        self.solver_record.set_stage(self.solver, numerics,
                                     RECOVERY_SPEED_FRACTION * self.stage_wall_speed)
        if s.dt is None:
            self.stage_dt = self.automatic_step()
        else:  # the last step of the previous stage may have been cut short
            self.stage_dt = s.dt
        self.step_control = self._step_control(self.step_control.scale)
        self.solver.dt = self.boundary.last_step(self.stage,
                                                 self.stage_dt * self.step_control.scale)
        self.boundary.stage_numerics(self.stage)

    def _step_control(self, scale: float) -> OverlapStepControl:
        """The step control of the current stage (:mod:`grainlab.lab.step_control`) at
        ``scale`` (at most its growth): the stage's ``time_step_growth`` with a solver that
        grows its step (:attr:`~grainlab.lab.solver_registry.SolverRecord.grows_step`) and
        an automatic step, else a fixed step (growth 1)."""
        s, numerics = self.settings, self.stage_numerics
        grows = s.dt is None and self.solver_record.grows_step
        growth = numerics.time_step_growth if grows else 1.0
        return OverlapStepControl(growth, numerics.overlap_bound * self.sample.mean_diameter,
                                  scale=min(scale, growth))

    def automatic_step(self) -> float:
        """The step h [s] the current stage takes when the test's ``dt`` is not given: its
        ``time_step_factor`` x d_min [m] (:func:`time_step_length`) / the stage's wall speed
        [m/s] (the shortest: the step may grow from it by ``time_step_growth``), in whole
        sub-steps for a solver of sub-steps."""
        numerics = self.stage_numerics
        return self.solver_record.step_length(
            self.solver, numerics.time_step_factor * time_step_length(self.sample.library)
            / self.stage_wall_speed, self.sample.state, self.sample.library)

    def apply_settings(self, previous: DiscreteTestSettings) -> None:
        """Take up the current ``settings`` in a stage under way (a resumed run whose
        settings changed from ``previous``): solver settings at once, a new bound on the
        inertia number scales the strain rate and the walls' speeds, the time step follows.
        Nothing changes when only the records and stage ends (the quasi-static criteria
        included) differ (a resumed run stays identical up to a changed end)."""
        same = {"record_every": 1, "snapshot_every": 0, "max_stage_steps": 1,
                "at_max_stage_steps": "stop", "quasi_static": QuasiStaticCriteria()}
        if not self.stage_started or self.finished or \
                replace(previous, **same) == replace(self.settings, **same):
            return
        moving = bool(self.stage.moving_axes)
        ratio = self.stage_numerics.inertia_number / \
            previous.numerics_for(moving).inertia_number
        self.strain_rate *= ratio
        self.stage_wall_speed *= ratio
        self._stage_numerics()

    def halt(self, ended: str, reason: str) -> None:
        """Stop the test in the current stage (not ended): ``ended`` of
        :data:`~grainlab.lab.run_outcome.ENDINGS`, ``reason`` in words."""
        self.halted = {"stage": self.stage.name, "ended": ended, "reason": reason}
        self.simulation.request_stop()

    def resumable(self) -> str:
        """Why a halted test cannot go on with its current settings ("" when it can, and
        then it is no longer halted)."""
        if self.halted is None:
            return ""
        steps = self.simulation.step_index - self.stage_start_step
        if self.halted["ended"] == MAX_STAGE_STEPS and steps < self.settings.max_stage_steps:
            self.halted = None
            return ""
        if self.halted["ended"] == BOX_TOO_THIN and not self.stage_started:
            self.halted = None  # the stage starts again and checks its (new) target
            return ""
        if self.halted["ended"] == MAX_STAGE_STEPS:
            return (f"stage {self.halted['stage']} stopped at max_stage_steps = {steps}: "
                    f"raise it to go on (--set solver.max_stage_steps={2 * steps})")
        return f"stage {self.halted['stage']} stopped: {self.halted['reason']}"

    # -- the boundary against its particles -------------------------------------------------
    def predicted_flattening(self) -> list[Flattening]:
        """The stages from the current one whose targets would leave the boundary too thin
        (:meth:`~grainlab.lab.box_boundary.BoxBoundary.predicted_flattening`; none in a
        periodic cell), from the boundary now (the stage under way: from its start)."""
        started = self.stage_started and self.stage is not None and self.stage.moving_axes
        return self.boundary.predicted_flattening(self.stages[self.stage_index:],
                                                  bool(started))

    def drive(self) -> None:
        """Follow the step just done and set the boundary for the next (strain-controlled
        walls at a constant logarithmic strain rate, the cell's progress and control); grow
        or shorten the step by the overlaps where the boundary's step follows them
        (:mod:`grainlab.lab.step_control`); with polyhedra, shorten it to the particles' own
        speeds; cut the last step of the stage (module docstring)."""
        stage = self.stage
        if stage is None:
            return
        self.boundary.before_step(stage)
        scale = self._step_scale() if self.boundary.steps_by_overlap else 1.0
        dt = self.stage_dt * scale
        if self.adaptive_step and self.settings.dt is None:
            dt = min(dt, self._particle_speed_step(scale))
        self.solver.dt = self.boundary.last_step(stage, dt)
        self.boundary.after_step(stage)

    def _step_scale(self) -> float:
        """The scale of the coming step (:mod:`grainlab.lab.step_control`), from the largest
        overlap of the step just done (none yet in this stage: as it is)."""
        report = self.simulation.last_report
        if report is None or self.simulation.step_index <= self.stage_start_step:
            return self.step_control.scale
        return self.step_control.after_step(report.max_overlap)

    def _particle_speed_step(self, scale: float = 1.0) -> float:
        """scale x travel / max_i (|v_i| + |omega_i| R_i): the step that moves no point of a
        particle by more than ``scale`` x ``travel`` [m] (inf when all are at rest); travel is
        the stage's fraction of d_min or, when larger, :data:`ALERT_TRAVEL` of the
        detection's alert distance (module docstring), and ``scale`` the step's growth
        (:mod:`grainlab.lab.step_control`): the overlaps decide how far it may go."""
        state, library = self.sample.state, self.sample.library
        reach = np.linalg.norm(state.velocities, axis=1) + np.linalg.norm(
            state.angular_velocities, axis=1) * library.bounding_radius[state.shape_ids]
        fastest = float(reach.max()) if reach.size else 0.0
        if fastest <= 0.0:
            return math.inf
        travel = self.stage_numerics.time_step_factor * time_step_length(library)
        alert = getattr(self.solver, "alert_distance", None)
        if alert is not None:
            travel = max(travel, ALERT_TRAVEL * alert(library))
        return scale * travel / fastest

    # -- stage ends (module docstring) --------------------------------------------------------
    def boundary_end(self) -> tuple[bool, str]:
        """Whether the boundary ends the current stage now, and why (checked after every
        step): a stop criterion on one of its strain columns, its targets reached or it too
        thin for its particles (:data:`~grainlab.lab.stage_boundary.THIN_BOX`),
        ``max_stage_steps`` (:data:`~grainlab.lab.stage_boundary.MAX_STEPS_REASON`)."""
        stage = self.stage
        assert stage is not None
        self.boundary.advance(stage)
        strains = self.boundary.strains()
        for criterion in stage.stop:
            if criterion.quantity in strains and criterion.met(strains):
                return True, stop_reason(criterion)
        reason = self.boundary.target_end(stage)
        if reason:
            return True, reason
        if self.simulation.step_index - self.stage_start_step >= self.settings.max_stage_steps:
            return True, MAX_STEPS_REASON
        return False, ""

    def close_stage(self, reason: str) -> None:
        """End the current stage for ``reason`` (of :meth:`stage_done`): move on, or halt the
        test where the stage did not reach its end (module docstring)."""
        if reason.startswith(THIN_BOX):
            self.halt(BOX_TOO_THIN, reason)
        elif reason == MAX_STEPS_REASON:
            what = "its target" if self.stage.moving_axes else "settling"
            words = f"max_stage_steps ({self.settings.max_stage_steps}) hit before {what}"
            if self.settings.at_max_stage_steps == "stop":
                self.halt(MAX_STAGE_STEPS, words)
            else:
                self.end_stage(words, ended=MAX_STAGE_STEPS)
        else:
            self.end_stage(reason)

    def stage_done(self, row: dict[str, Any]) -> tuple[bool, str]:
        """Whether the current stage ends at this record, and why: any stop criterion,
        :meth:`boundary_end`, quasi-static (the boundary's :meth:`~grainlab.lab.
        stage_boundary.StageBoundary.settled`)."""
        stage = self.stage
        assert stage is not None
        for criterion in stage.stop:
            if criterion.met(row):
                return True, stop_reason(criterion)
        done, reason = self.boundary_end()
        if done:
            return done, reason
        if self.boundary.settled(stage, row):
            return True, "quasi-static"
        return False, ""

    def end_stage(self, reason: str, ended: str = REACHED) -> None:
        """Close the current stage (``ended`` of :data:`~grainlab.lab.run_outcome.ENDINGS`)
        and move to the next."""
        stage = self.stage
        assert stage is not None
        unsnapped = self._unsnapped
        if unsnapped is not None and unsnapped[1]["step"] == self.simulation.step_index:
            self._snapshot(*unsnapped)  # every stage's end state is a snapshot
        self._unsnapped = None
        self.outcome["stages"].append(self._stage_record(reason, ended))
        self.boundary.stage_ended(stage)
        self.stage_index += 1
        self.stage_started = False
        ends_test = any(c.met(self.rows[-1]) and c.ends == "test" for c in stage.stop) \
            if self.rows else False
        if self.stage is None or ends_test:
            self.finished = True
            self.simulation.request_stop()
        else:
            self.start_stage()  # before the next step: no step runs on the old controls
            if self.on_stage_end is not None:
                self.on_stage_end(self)

    def _stage_record(self, reason: str, ended: str) -> dict[str, Any]:
        sim = self.simulation
        return {"name": self.stage.name, "reason": reason,
                "steps": sim.step_index - self.stage_start_step, "end_step": sim.step_index,
                "start_step": self.stage_start_step, "ended": ended,
                "capped_steps": sim.unconverged_steps - self.stage_start_unconverged,
                "strain_controlled": bool(self.stage.moving_axes)}

    def run_outcome(self) -> RunOutcome:
        """The test so far judged against what was asked (:mod:`grainlab.lab.run_outcome`):
        every ended stage, and the stage under way if the test stopped in it."""
        records = list(self.outcome["stages"])
        if not self.finished and self.stage is not None and self.stage_started:
            halted = self.halted or {}
            records.append(self._stage_record(
                halted.get("reason", f"stopped at step {self.simulation.step_index}"),
                halted.get("ended", UNFINISHED)))
        elif self.halted is not None:  # halted before its stage started
            records.append({"name": self.halted["stage"], "reason": self.halted["reason"],
                            "steps": 0, "ended": self.halted["ended"],
                            "strain_controlled": True})
        stages = []
        by_name = {stage.name: stage for stage in self.stages}
        for record in records:
            start = record.get("start_step", record.get("end_step", 0) - record["steps"])
            end = record.get("end_step", self.simulation.step_index)
            rows = [r for r in self.rows
                    if r["stage"] == record["name"] and start < r["step"] <= end]
            stage = by_name.get(record["name"])
            targets = self.boundary.stress_targets(stage) if stage is not None else {}
            stages.append(stage_outcome(record, rows, self.settings, targets))
        return RunOutcome(stages=tuple(stages), finished=self.finished,
                          steps=self.simulation.step_index,
                          stopped=self.halted["reason"] if self.halted else "")

    # -- records ------------------------------------------------------------------------------
    def record(self) -> dict[str, Any]:
        """Measure the sample now; append and return the results row."""
        sim = self.simulation
        report = sim.last_report
        assert report is not None
        row, network = self.measures()
        net = np.linalg.norm(sim.net_forces(), axis=1)
        normal_forces = report.impulses[:, 0] / sim.last_dt
        loaded = normal_forces[normal_forces > 0.0]
        mean_force = float(np.mean(loaded)) if loaded.size else math.nan
        row["unbalanced_force_ratio"] = float(np.mean(net) / mean_force) \
            if loaded.size else math.nan
        p = row["p"]
        d_mean = self.sample.mean_diameter
        n = self.sample.state.n_bodies
        # the quasi-static criterion leaves out the spin of bodies that bear no load: a
        # rattler spinning in its cage (frictionless, nothing slows it) exchanges no force
        # with the packing (QuasiStaticCriteria)
        contacts = report.contacts
        loaded_bodies = np.zeros(n, dtype=bool)
        for bodies in (contacts.body_i, contacts.body_j):
            touching = bodies[(normal_forces > 0.0) & (bodies >= 0)]
            loaded_bodies[touching] = True
        free_spin = float(np.sum(self.sample.state.rotational_energies()[~loaded_bodies]))
        row["kinetic_energy_ratio"] = (row["kinetic_energy"] - free_spin) \
            / (n * p * d_mean**3) if p > 0.0 else math.nan
        row.update(self.solver_record.row_fields(self.solver))
        stage = self.stage
        full = {"stage": stage.name if stage else "end", "step": sim.step_index,
                "time": sim.time, "dt": sim.last_dt, "friction": self.solver.friction}
        full.update(row)
        if self.reports_k0:
            full["K0"] = _k0(row)
        self.rows.append(full)
        every = self.settings.snapshot_every
        self._unsnapped = None
        if (every and self._passes_a_snapshot_step(every)) or self._passes_a_strain_mark(full):
            self._snapshot(network, full)
        elif every or self.settings.snapshot_eps_q:
            self._unsnapped = (network, full)  # snapshotted if the stage ends on this row
        if self.on_record is not None:
            self.on_record(self, full)
        return full

    def _passes_a_snapshot_step(self, every: int) -> bool:
        """Whether the row just recorded is the first at or past a multiple of ``every``
        steps: a multiple lies in (the previous row's step, this row's]. Snapshots are taken
        on records, so with ``record_every`` not dividing ``every`` a test asking for one
        every 53 steps, recording every 10, gets one about every 53 steps (at the records
        after 53, 106, ...), not every 530 where the two counts meet. Read from the rows, so
        a resumed test snapshots where the test run straight through did."""
        step = self.rows[-1]["step"]
        if len(self.rows) > 1:
            before = self.rows[-2]["step"]
        else:  # the first record: a multiple in (0, step], or step 0 itself
            before = -1 if step == 0 else 0
        return step // every > before // every

    def _passes_a_strain_mark(self, row: dict[str, Any]) -> bool:
        """Whether ``row`` (just recorded) is the first of its strain-driven stage whose eps_q
        has risen past a strain of ``settings.snapshot_eps_q``: past the largest eps_q of the
        stage's earlier rows. Read from the rows, so a resumed test snapshots where the test
        run straight through did."""
        marks = self.settings.snapshot_eps_q
        if not marks or self.stage is None or not self.stage.moving_axes \
                or not math.isfinite(row.get("eps_q", math.nan)):
            return False
        reached = self._eps_q_reached
        if reached is None or reached[0] != self.stage_index:
            earlier = [r["eps_q"] for r in self.rows[:-1] if r["stage"] == row["stage"]
                       and r["step"] > self.stage_start_step]
            reached = (self.stage_index, max(earlier, default=-math.inf))
        eps = row["eps_q"]
        self._eps_q_reached = (self.stage_index, max(reached[1], eps))
        return any(reached[1] < mark <= eps for mark in marks)

    def measures(self):
        """The results row and contact network of the sample now (the boundary's
        :meth:`~grainlab.lab.stage_boundary.StageBoundary.measures`)."""
        return self.boundary.measures()

    def _snapshot(self, network, full: dict[str, Any]) -> None:
        network.state.update({k: v for k, v in full.items() if k != "stage"})
        network.state["stage"] = full["stage"]
        self.n_snapshots += 1
        if self.on_snapshot is not None:
            self.on_snapshot(self, network)

    # -- running ------------------------------------------------------------------------------
    def run(self, max_steps: int | None = None) -> bool:
        """Run until the path is done, or halted (module docstring), or ``max_steps`` more
        steps; True when done."""
        if self.finished or self.halted:
            return self.finished
        if not self.stage_started:
            self.start_stage()
            if self.halted:
                return False
        try:
            self.simulation.run(max_steps)
        except CellTooThin as thin:  # the detection's own check, within a step
            self.halt(BOX_TOO_THIN, f"{THIN_BOX}: the detection refused the cell ({thin}); "
                      "use more particles, a cell longer along that axis (sample aspect) or "
                      "shorter steps (time_step_factor)")
        return self.finished

    # -- persistence --------------------------------------------------------------------------
    def progress_arrays(self) -> dict[str, Any]:
        """What a checkpoint needs besides the sample and the solver's memory."""
        return {
            "stage_index": self.stage_index, "stage_started": self.stage_started,
            "stage_start_step": self.stage_start_step,
            **self.boundary.checkpoint_arrays(),
            "strain_rate": self.strain_rate, "n_snapshots": self.n_snapshots,
            "finished": self.finished, "halted": self.halted,
            "stage_start_unconverged": self.stage_start_unconverged,
            "stage_wall_speed": self.stage_wall_speed,
            "dt": self.solver.dt, "stage_dt": self.stage_dt,
            "step_scale": self.step_control.scale,
            "alert": self.solver.alert,
            "alert_growths": self.solver.alert_growths,
            "friction": self.solver.friction,
            **self.solver_record.checkpoint_fields(self.solver),
            "step_index": self.simulation.step_index,
            "time": self.simulation.time,
            "unconverged_steps": self.simulation.unconverged_steps,
            "unconverged_in_row": self.simulation.unconverged_in_row,
        }

    def restore_progress(self, data: dict[str, Any]) -> None:
        """Inverse of :meth:`progress_arrays`."""
        self.stage_index = int(data["stage_index"])
        self.stage_started = bool(data["stage_started"])
        self.stage_start_step = int(data["stage_start_step"])
        self.boundary.restore(data)
        self.strain_rate = float(data["strain_rate"])
        self.n_snapshots = int(data["n_snapshots"])
        self.finished = bool(data["finished"])
        self.halted = data.get("halted")
        self.stage_start_unconverged = int(data.get("stage_start_unconverged", 0))
        self.solver.dt = float(data["dt"])
        self.stage_dt = float(data.get("stage_dt", data["dt"]))
        self.solver.alert = None if data["alert"] is None else float(data["alert"])
        self.solver.alert_growths = int(data["alert_growths"])
        self.solver.friction = float(data["friction"])
        self.solver_record.restore(self.solver, data)
        self.stage_wall_speed = float(data.get(
            "stage_wall_speed", data.get("overlap_recovery_speed", math.inf)
            / RECOVERY_SPEED_FRACTION))
        self.simulation.step_index = int(data["step_index"])
        self.simulation.time = float(data["time"])
        self.simulation.unconverged_steps = int(data["unconverged_steps"])
        self.simulation.unconverged_in_row = int(data["unconverged_in_row"])
        if self.stage_started and self.stage is not None:
            self.step_control = self._step_control(float(data.get("step_scale", 1.0)))


class _StageControl:
    """Drives the boundary every step; starts the next stage when one ended."""

    name = "stage_control"

    def __init__(self, test: DiscreteTest) -> None:
        self.test = test
        self.trigger = Periodic(1)

    def act(self, simulation: Simulation) -> None:
        test = self.test
        if test.finished or test.halted:
            return
        if not test.stage_started:
            test.start_stage()
            if test.halted:
                return
        else:
            done, reason = test.boundary_end()
            if done:
                test.record()  # the state the stage ends in is a row
                test.close_stage(reason)  # and the next stage's walls and step are set
                return
        test.drive()


class _Recorder:
    """Records a results row (unless the stage control recorded this step already); decides
    the end of the stage at each record."""

    name = "recorder"

    def __init__(self, test: DiscreteTest, trigger: Periodic) -> None:
        self.test = test
        self.trigger = trigger

    def act(self, simulation: Simulation) -> None:
        test = self.test
        if test.finished or test.halted or not test.stage_started:
            return
        if test.rows and test.rows[-1]["step"] == simulation.step_index:
            return
        row = test.record()
        done, reason = test.stage_done(row)
        if done:
            test.close_stage(reason)



def _k0(row: dict[str, float]) -> float:
    """K0 = (sigma_xx + sigma_yy) / (2 sigma_zz) [-] of a row's contact stresses; in 2D (no
    sigma_zz) sigma_xx / sigma_yy (NaN unless the vertical stress is > 0)."""
    if "sigma_zz" not in row:
        vertical, lateral = row["sigma_yy"], row["sigma_xx"]
    else:
        vertical, lateral = row["sigma_zz"], 0.5 * (row["sigma_xx"] + row["sigma_yy"])
    return lateral / vertical if vertical > 0.0 else math.nan
