"""A load path run on a discrete sample in a box of walls (contact dynamics; seeds 002/003).

:class:`DiscreteTest` turns the stages of a lab :class:`~grainlab.lab.load_path.LoadPath`
into wall controls (:mod:`grainlab.lab.wall_stages`) and runs them on a
:class:`~grainlab.engine.simulation.Simulation` through two operations: the stage control
(walls driven, stage ends decided) and the recorder (one results row every ``record_every``
steps, a contact-network snapshot every ``snapshot_every`` and of the state each stage ends
in, so that a short run has its compaction and its end to analyse). Everything it needs to go on
is plain data (:meth:`DiscreteTest.progress_arrays`), so a run can checkpoint and resume.

Per stage, with the numerics of its kind (:class:`~grainlab.lab.stage_numerics.StageNumerics`:
``settings.compaction`` in stages without a strain-controlled axis, ``settings.shear``
otherwise; :meth:`DiscreteTestSettings.numerics_for`):

* interparticle friction (default 0 in compaction, seed 002; 0.4 in shear);
* strain rate from the bound on the inertia number (:mod:`grainlab.lab.wall_stages`); the
  stress-controlled walls are speed-limited to the same rate (their inward free speed at most
  eps_dot L);
* time step h = ``time_step_factor`` x d_min / v (defaults 0.003 in shear, 0.01 in
  compaction), v the largest wall speed of the stage, d_min the smallest member-sphere
  diameter or, for polyhedra, the smallest inscribed diameter (twice the smallest distance from
  a centre of mass to a face plane; :func:`time_step_length`) (research/cd_engines.md pitfall
  6: v h <= 0.01-0.05 d_min), unless ``dt`` is given. In triaxial shear the solver ends each
  step with small velocity violations (the NLGS residual stalls near the tolerance however
  many sweeps: docs/discrete_engine.md, "The contact problem on its own") and contact
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
* stress-controlled walls are overdamped servos (``wall_servo``, default): no speed carried
  from step to step, mass c h with the damping c = F / v_max (F = sigma A its driving force,
  v_max its speed limit), so that the wall moves at v_max when nothing holds it and at
  (F - R) / c against the reaction R. With momentum (``wall_servo = False``) the mass is
  max(``wall_mass_factor`` x the particles' mass, h F / v_max), so that one step of driving
  cannot push it past the limit (a lighter wall leaves the solver trading the driving
  impulse between the speed limit and the contacts, and it stalls: penetrations of several
  % of a diameter in shear were traced to this); but in shear a lateral wall held above
  sigma for a few steps gained many times v_max outwards, flew on after the particles
  stopped pushing, and a rigid sample of 100-200 polyhedra unloaded completely (p from
  ~10^4 to ~50 Pa, I up to 0.06) in 30 % of the records.

Strains are logarithmic, compression positive, from the reference box: the box at the end of
the last stage without a strain-controlled axis (the consolidated sample), or the initial box
before any. A stage without a strain-controlled axis ends when quasi-static
(:class:`~grainlab.lab.wall_stages.QuasiStaticCriteria`). A stage that reaches
``max_stage_steps`` first did not reach its end: the test stops there (``halted``; the stage
goes on when resumed with a larger cap), or with ``at_max_stage_steps = "next_stage"`` the
next stage starts all the same; either way :meth:`DiscreteTest.run_outcome` says the stage was
not reached (:mod:`grainlab.lab.run_outcome`).

A box thinner than a few particles cannot hold a granular sample
(:mod:`grainlab.lab.box_thickness`): a stage whose target would take the box below
:func:`~grainlab.lab.box_thickness.box_limits` does not start, and a stage whose box gets there
stops (``halted``), both with the diagnosis; :meth:`DiscreteTest.predicted_flattening` checks
a whole path before a run.

Stage ends do not wait for a record. After every step the walls alone decide (cheap: the box
lengths give the strains): the strain target of each strain-controlled axis, stop criteria on
strain columns (:data:`STRAIN_COLUMNS`: ``eps_q`` of the triaxial test) and
``max_stage_steps``. The step that would carry a stage past a target is cut short, and one
that would leave less than :data:`SHORTEST_CUT` of a step to go is stretched by that much
instead (no sliver of a step: its forces, impulses over its length, would mean nothing):

* a strain-controlled axis moves at a prescribed wall speed, so its last step is cut to end
  on the target exactly (to round-off: :data:`TARGET_MARGIN` past it); an axis that reached
  its target holds still while the others go on;
* a stop criterion on a strain is crossed where the walls' speeds of the step before predict
  (linear in the step length); the stress-controlled walls may move a little otherwise, so it
  ends within a small fraction of a step's increment of its limit, at worst one more step of
  at least :data:`SHORTEST_CUT` of a step.

The state a stage ends in is always a results row (the last of the stage), whatever
``record_every``; stop criteria on other columns, and quasi-static ends, are checked at the
records. The cut step length is the solver's step, saved in checkpoints like the rest, so a
resumed run takes the same steps.

Columns besides :mod:`grainlab.engine.sample_measures`: ``stage``, ``step``, ``time`` [s],
``dt`` [s], ``unbalanced_force_ratio``, ``kinetic_energy_ratio``, ``velocity_zigzag`` (the
soft-contact solver's :attr:`~grainlab.engine.soft_contact.SoftContactStep.velocity_zigzag`,
NaN for contact dynamics: the run's outcome reads it, :mod:`grainlab.lab.run_outcome`),
``friction``, and in tests
with a one-dimensional stage (:attr:`~grainlab.lab.wall_stages.WallStage.oedometric`)
``K0`` = (sigma_xx + sigma_yy) / (2 sigma_zz) [-] of the contact stresses.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from grainlab._validate import at_least
from grainlab.engine.contact_dynamics import WARM_START_EXTRAPOLATION
from grainlab.engine.sample_measures import box_strains, log_strains, sample_measures
from grainlab.engine.shape_kinds import kinds_present, library_time_step_length
from grainlab.engine.simulation import Periodic, Simulation
from grainlab.engine.state import ShapeLibrary
from grainlab.engine.wall_box import WALL_NAMES
from grainlab.errors import InputError
from grainlab.lab.box_thickness import (
    Flattening,
    box_limits,
    predicted_flattening,
    stage_flattening,
)
from grainlab.lab.load_path import LoadPath, StopCriterion
from grainlab.lab.run_outcome import (
    BOX_TOO_THIN,
    MAX_STAGE_STEPS,
    REACHED,
    UNFINISHED,
    RunOutcome,
    stage_outcome,
)
from grainlab.lab.soft_contact_settings import SoftContactSettings
from grainlab.lab.solver_registry import DEFAULT_SOLVER, solver_record
from grainlab.lab.stage_numerics import (
    COMPACTION,
    SHEAR,
    STAGE_KINDS,
    StageNumerics,
    stage_kind,
)
from grainlab.lab.step_control import OverlapStepControl
from grainlab.lab.wall_stages import AXES, QuasiStaticCriteria, WallStage, wall_stages
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


TARGET_MARGIN = 1e-12
"""Strain [-] by which the cut last step of a stage aims past its target, so that round-off
cannot leave the target a hair short (and add a step of a few femtoseconds)."""

SHORTEST_CUT = 0.25
"""Shortest fraction of a step that a last step may take; a target less than this fraction of
a step beyond a full step is reached by stretching that step instead (by at most this
fraction). The forces of a step are its impulses over its length, and contacts that still
approach at a small speed carry impulses that do not shrink with the step: a last step cut
to 1.3 % of the others made p of the final row 6 times that of the row before (1000
spheres). A stop criterion's crossing is predicted from the walls' speeds of the step before;
where the stress-controlled walls then move less than predicted, the criterion is met one
step later, and this bounds how short that step is (its overshoot is below this fraction of
a step's increment)."""

STRAIN_COLUMNS = tuple(box_strains(np.ones(3), np.ones(3)))
"""The columns known from the walls alone (:func:`~grainlab.engine.sample_measures.box_strains`):
stop criteria on them are checked after every step, the others at the records."""

RECOVERY_SPEED_FRACTION = 0.25
"""Cap of the overlap recovery's separation speed, as a fraction of the stage's wall speed [-].
On 200 polyhedra (n_f = 30, 7.5 % overlaps left by the compaction) a cap at the full wall speed
let p swing between 115 Pa and 170 kPa (sigma0 = 10 kPa) early in shear, with I up to 0.21;
at 0.25 the largest I was 4e-3. Spheres never reach it (beta |g| / h <= 0.08 of the wall speed
at 0.5 % overlaps)."""


@dataclass(frozen=True)
class DiscreteTestSettings:
    """Numerical settings of a discrete test (module docstring for their roles): the
    numerics of each kind of stage, and those of the whole run.

    Attributes
    ----------
    compaction, shear:
        :class:`~grainlab.lab.stage_numerics.StageNumerics` (friction, bound on the inertia
        number, time step factor, NLGS tolerance and sweep cap, overlap recovery) of the
        stages without and with a strain-controlled axis (:meth:`numerics_for`); defaults
        :data:`~grainlab.lab.stage_numerics.COMPACTION` and
        :data:`~grainlab.lab.stage_numerics.SHEAR`. The overlap recovery's separation speed
        is capped at :data:`RECOVERY_SPEED_FRACTION` of the stage's wall speed
        (``overlap_recovery_speed`` of the solver).
    dt:
        Time step [s]; None: from the stage's ``time_step_factor``.
    theta, sweep, warm_start_extrapolation:
        Solver settings (:class:`~grainlab.engine.contact_dynamics.ContactDynamicsStep`;
        ``warm_start_extrapolation`` lambda in [0, 1], default
        :data:`~grainlab.engine.contact_dynamics.WARM_START_EXTRAPOLATION`).
    record_every, snapshot_every:
        Steps between results rows and between contact-network snapshots (0: none; with
        snapshots on, the state each stage ends in is one too).
    max_stage_steps:
        Cap on the steps of one stage (>= 1); reaching it, the stage did not reach its end.
    at_max_stage_steps:
        What a stage that reaches ``max_stage_steps`` does: ``"stop"`` the test there
        (default; resumable with a larger cap) or start the ``"next_stage"`` all the same.
    wall_mass_factor:
        Mass of a stress-controlled wall / mass of the particles (> 0), when ``wall_servo``
        is False.
    wall_servo:
        Stress-controlled walls as overdamped servos (default): no speed carried over from
        one step to the next, damping c = sigma A / v_max (speed v_max when nothing holds
        them, at rest when the particles push back sigma A;
        :class:`~grainlab.engine.wall_box.WallBox`). False: walls with the mass above.
    quasi_static:
        End criteria of stages without a strain-controlled axis.
    seed:
        Seed of the solver's visiting order.
    method:
        The solver, a name of :data:`~grainlab.lab.solver_registry.SOLVERS`: contact
        dynamics (rigid grains; default) or soft-contact DEM
        (:class:`~grainlab.engine.soft_contact.SoftContactStep`); the NLGS settings
        (``tolerance``, ``max_iterations``, ``overlap_recovery``, ``theta``, ``sweep``)
        serve an iterative solver only (:attr:`~grainlab.lab.solver_registry.SolverRecord.
        iterative`).
    dem:
        The soft-contact law (:class:`~grainlab.lab.soft_contact_settings.
        SoftContactSettings`), its stiffness number taken at the first stage's confining
        stress.
    """

    compaction: StageNumerics = COMPACTION
    shear: StageNumerics = SHEAR
    dt: float | None = None
    theta: float = 0.5
    sweep: str = "coloured"
    warm_start_extrapolation: float = WARM_START_EXTRAPOLATION
    record_every: int = 10
    snapshot_every: int = 0
    max_stage_steps: int = 200_000
    at_max_stage_steps: str = "stop"
    wall_mass_factor: float = 1.0
    wall_servo: bool = True
    quasi_static: QuasiStaticCriteria = field(default_factory=QuasiStaticCriteria)
    seed: int = 0
    method: str = DEFAULT_SOLVER
    dem: SoftContactSettings = field(default_factory=SoftContactSettings)

    def __post_init__(self) -> None:
        for kind in STAGE_KINDS:
            if not isinstance(getattr(self, kind), StageNumerics):
                raise InputError(kind, getattr(self, kind), "a StageNumerics")
        solver_record(self.method)  # a registered solver
        if not isinstance(self.dem, SoftContactSettings):
            raise InputError("dem", self.dem, "a SoftContactSettings")
        at_least("wall_mass_factor", self.wall_mass_factor)
        if self.dt is not None:
            at_least("dt", self.dt)
        if self.at_max_stage_steps not in ("stop", "next_stage"):
            raise InputError("at_max_stage_steps", self.at_max_stage_steps,
                             '"stop" or "next_stage"')
        for name, low in (("record_every", 1), ("snapshot_every", 0), ("max_stage_steps", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) \
                    or value < low:
                raise InputError(name, value, f"an integer >= {low}")

    def numerics_for(self, strain_controlled: bool) -> StageNumerics:
        """The numerics of a stage with (True) or without a strain-controlled axis
        (:func:`~grainlab.lab.stage_numerics.stage_kind`)."""
        return getattr(self, stage_kind(strain_controlled))

    def to_dict(self) -> dict[str, Any]:
        """Plain data (each kind of stage's numerics a nested dict)."""
        data = asdict(self)
        data["quasi_static"] = self.quasi_static.to_dict()
        return data


class DiscreteTest:
    """A load path on a discrete sample (module docstring).

    Parameters
    ----------
    sample:
        The sample (its box's controls are set by the stages).
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
        self.stages: list[WallStage] = self.load_stages(path)
        self.reports_k0 = any(stage.oedometric for stage in self.stages)
        self.on_record = on_record
        self.on_snapshot = on_snapshot
        self.on_stage_end = None
        self.rows: list[dict[str, Any]] = []
        self.stage_index = 0
        self.stage_started = False
        self.stage_start_step = 0
        self.stage_start_lengths = sample.box.lengths.copy()
        self.reference_lengths = sample.box.lengths.copy()
        self.strain_rate = 0.0
        self.n_snapshots = 0
        self._unsnapped: tuple[Any, dict[str, Any]] | None = None
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
            s, sample, lambda: self._confining(self.stages[0]), self.adaptive_step)
        self.simulation = Simulation(sample, self.solver)
        self.simulation.add(_StageControl(self))
        self.simulation.add(_Recorder(self, Periodic(s.record_every)))

    def load_stages(self, path: LoadPath) -> list[WallStage]:
        """The path's stages as this test's boundary runs them (walls here)."""
        return wall_stages(path)

    # -- stage logic --------------------------------------------------------------------------
    @property
    def stage(self) -> WallStage | None:
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

    def _confining(self, stage: WallStage) -> float:
        values = [stage.targets[a] for a in stage.stress_axes
                  if math.isfinite(stage.targets[a])]
        if values:
            return max(values)
        return self._confining_from_rows(stage)

    def _confining_from_rows(self, stage) -> float:
        """The mean stress of the last record [Pa] (a stage without a stress target)."""
        p = self.rows[-1]["p"] if self.rows else math.nan
        if not (math.isfinite(p) and p > 0.0):
            raise InputError(f"stage {stage.name!r}", "no stress reference",
                             "a stress-controlled axis, or a previous stage that loaded the "
                             "sample (the strain rate follows from the inertia number at p)")
        return p

    def start_stage(self) -> None:
        """Set the walls, friction, strain rate and time step of the current stage; a stage
        whose target would flatten the box does not start (the test halts, module
        docstring)."""
        stage = self.stage
        assert stage is not None
        box = self.sample.box
        if stage.moving_axes:
            flat = self._stage_flattening(stage, box.lengths, self.reference_lengths)
            if flat:
                self.halt(BOX_TOO_THIN, flat[0].words() + "; " + flat[0].advice())
                return
        p_ref = self._confining(stage)
        self.strain_rate = self.stage_numerics.inertia_number * \
            math.sqrt(p_ref / self.sample.state.density) / self.sample.mean_diameter
        for a in range(3):
            mode, target = stage.modes[a], stage.targets[a]
            lower, upper = WALL_NAMES[2 * a], WALL_NAMES[2 * a + 1]
            if mode == "fixed":
                box.set_control(lower, "fixed")
                box.set_control(upper, "fixed")
            elif mode == "strain":
                box.set_control(lower, "fixed")
                box.set_control(upper, "velocity", math.copysign(1.0, target)
                                * self.strain_rate * box.lengths[a])
            else:
                sigma = target if math.isfinite(target) else self._held_stress(a)
                box.set_control(lower, "fixed")
                box.set_control(upper, "stress", sigma)
        self.stage_wall_speed = self.strain_rate * float(box.lengths.max())  # [m/s]
        self.stage_start_step = self.simulation.step_index
        self.stage_start_unconverged = self.simulation.unconverged_steps
        self.stage_start_lengths = box.lengths.copy()
        self.step_control.scale = 1.0  # every stage starts at its shortest step
        self._stage_numerics()
        self.stage_started = True

    def _stage_numerics(self) -> None:
        """The solver settings, wall speed limits, time step and wall masses of the current
        stage, from the settings and the stage's wall speed ``stage_wall_speed``."""
        s, box, numerics = self.settings, self.sample.box, self.stage_numerics
        v_max = self.stage_wall_speed
        # overlap recovery slower than the walls: beta |g| / h alone grows without bound as
        # the step shortens (spinning polyhedra), and then blows the sample apart
        self.solver_record.set_stage(self.solver, numerics, RECOVERY_SPEED_FRACTION * v_max)
        box.set_max_speeds(v_max)
        if s.dt is None:
            self.stage_dt = self.automatic_step()
        else:  # the last step of the previous stage may have been cut short
            self.stage_dt = s.dt
        self.step_control = self._step_control(self.step_control.scale)
        self.solver.dt = self._last_step(self.stage_dt * self.step_control.scale)
        # stress walls: heavy enough that one step of driving force cannot take them past the
        # speed limit (h F / m_w <= v_max): otherwise the solver spends its sweeps trading the
        # driving impulse between the brake and the contacts
        box.servo = s.wall_servo
        if box.servo:
            box.set_masses(box.servo_masses(self.solver.dt))
        else:
            force = box.driving_forces()
            masses = np.maximum(float(np.sum(self.sample.state.masses)) * s.wall_mass_factor,
                                self.solver.dt * force / v_max)
            box.set_masses(masses)

    def _step_control(self, scale: float) -> OverlapStepControl:
        """The step control of the current stage (:mod:`grainlab.lab.step_control`) at
        ``scale`` (at most its growth): the stage's ``time_step_growth`` with contact dynamics
        and an automatic step, else a fixed step (growth 1)."""
        s, numerics = self.settings, self.stage_numerics
        grows = s.dt is None and self.solver_record.grows_step
        growth = numerics.time_step_growth if grows else 1.0
        return OverlapStepControl(growth, numerics.overlap_bound * self.sample.mean_diameter,
                                  scale=min(scale, growth))

    def automatic_step(self) -> float:
        """The step h [s] the current stage takes when the test's ``dt`` is not given: its
        ``time_step_factor`` x d_min [m] (:func:`time_step_length`) / the stage's wall speed
        [m/s] (the shortest: the step may grow from it by ``time_step_growth``), in whole
        sub-steps for the soft-contact solver."""
        numerics = self.stage_numerics
        return self._whole_substeps(numerics.time_step_factor
                                    * time_step_length(self.sample.library)
                                    / self.stage_wall_speed)

    def _whole_substeps(self, dt: float) -> float:
        """The stage's step [s] from the time step factor's ``dt``: for the soft-contact
        solver, rounded down to whole stable sub-steps
        (:meth:`~grainlab.engine.soft_contact.SoftContactStep.whole_substeps`)."""
        return self.solver_record.step_length(self.solver, dt, self.sample.state,
                                              self.sample.library)

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

    # -- the box against its particles (lab.box_thickness) -----------------------------------
    def box_limits(self, reference: np.ndarray) -> np.ndarray:
        """(3,) smallest edges [m] allowed for a consolidated box of edges ``reference``."""
        return box_limits(self.largest_diameter, reference)

    def _stage_flattening(self, stage: WallStage, start: np.ndarray,
                          reference: np.ndarray) -> list[Flattening]:
        return stage_flattening(stage, start, reference, self.largest_diameter,
                                self.sample.state.n_bodies)

    def predicted_flattening(self) -> list[Flattening]:
        """The stages from the current one whose targets would flatten the box
        (:func:`~grainlab.lab.box_thickness.predicted_flattening`), from the box now (the
        stage under way: from its start)."""
        started = self.stage_started and self.stage is not None and self.stage.moving_axes
        lengths = self.stage_start_lengths if started else self.sample.box.lengths
        library, state = self.sample.library, self.sample.state
        return predicted_flattening(self.stages[self.stage_index:], lengths,
                                    self.reference_lengths,
                                    float(np.sum(library.volume[state.shape_ids])),
                                    self.largest_diameter, state.n_bodies)

    def _held_stress(self, axis: int) -> float:
        if not self.rows:
            raise InputError(f"stage {self.stage.name!r}: sigma_{AXES[axis] * 2}", "held",
                             "a stress target: no earlier stage set this stress")
        return float(self.rows[-1][f"wall_sigma_{AXES[axis] * 2}"])

    def drive(self) -> None:
        """Keep the strain-controlled walls at a constant logarithmic strain rate (at rest
        once their axis reached its target); grow or shorten the step by the overlaps
        (:mod:`grainlab.lab.step_control`); with polyhedra, shorten it to the particles' own
        speeds; cut the last step of the stage (module docstring)."""
        stage, box = self.stage, self.sample.box
        if stage is None:
            return
        strained = self._stage_strains()
        for a in stage.moving_axes:
            sign = math.copysign(1.0, stage.targets[a])
            speed = 0.0 if abs(strained[a]) >= abs(stage.targets[a]) else \
                sign * self.strain_rate * box.lengths[a]
            box.set_control(WALL_NAMES[2 * a + 1], "velocity", speed)
        scale = self._step_scale()
        dt = self.stage_dt * scale
        if self.adaptive_step and self.settings.dt is None:
            dt = min(dt, self._particle_speed_step(scale))
        self.solver.dt = self._last_step(dt)
        if box.servo:  # damping fixed, mass c h follows the step (and the face areas)
            box.set_masses(box.servo_masses(self.solver.dt))

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
    def wall_strains(self, lengths: np.ndarray | None = None) -> dict[str, float]:
        """The strain columns (:data:`STRAIN_COLUMNS`) of the box now, or of a box of
        ``lengths`` (3,) [m], from the reference box."""
        return box_strains(self.reference_lengths,
                           self.sample.box.lengths if lengths is None else lengths)

    def _stage_strains(self) -> np.ndarray:
        """(3,) logarithmic strains [-] since the stage began."""
        return log_strains(self.stage_start_lengths, self.sample.box.lengths)

    def wall_end(self) -> tuple[bool, str]:
        """Whether the walls end the current stage now, and why (checked after every step):
        a stop criterion on a strain column, every strain-controlled axis at its target, a box
        too thin for its particles (:data:`THIN_BOX`), ``max_stage_steps``
        (:data:`MAX_STEPS_REASON`)."""
        stage = self.stage
        assert stage is not None
        strains = self.wall_strains()
        for criterion in stage.stop:
            if criterion.quantity in strains and criterion.met(strains):
                return True, _stop_reason(criterion)
        if stage.moving_axes:
            strained = self._stage_strains()
            if all(abs(strained[a]) >= abs(stage.targets[a]) for a in stage.moving_axes):
                return True, "strain reached"
            lengths = self.sample.box.lengths
            limits = self.box_limits(self.reference_lengths)
            thin = np.flatnonzero(lengths < limits)
            if thin.size:
                a = int(thin[0])
                return True, (
                    f"{THIN_BOX}: its {AXES[a]} edge is {lengths[a] * 1e3:.4g} mm, "
                    f"{lengths[a] / self.largest_diameter:.2f} largest particle diameters "
                    f"(d_max = {self.largest_diameter * 1e3:.4g} mm; smallest allowed "
                    f"{limits[a] * 1e3:.4g} mm), at {strains['eps_q']:.4g} of eps_q: the "
                    "particles are squeezed into one or two layers, where no time step or "
                    "tolerance helps; ask a smaller strain or use more particles")
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
        :meth:`wall_end`, quasi-static (stages without a strain-controlled axis)."""
        stage = self.stage
        assert stage is not None
        for criterion in stage.stop:
            if criterion.met(row):
                return True, _stop_reason(criterion)
        done, reason = self.wall_end()
        if done:
            return done, reason
        if self.settled(row):
            return True, "quasi-static"
        return False, ""

    def settled(self, row: dict[str, Any]) -> bool:
        """Whether a stage without a strain-controlled axis is quasi-static at ``row``
        (:class:`~grainlab.lab.wall_stages.QuasiStaticCriteria` on the walls' stresses)."""
        stage = self.stage
        if stage.moving_axes:
            return False
        targets = {a: self.sample.box.controls[2 * a + 1].value for a in stage.stress_axes}
        return self.settings.quasi_static.met(row, targets)

    def _last_step(self, dt: float) -> float:
        """``dt`` [s], or the step that ends the stage where a step of at most
        (1 + :data:`SHORTEST_CUT`) ``dt`` reaches a target (module docstring): the step that
        ends a strain-controlled axis on its target, the predicted crossing of a stop criterion
        on a strain column (at least :data:`SHORTEST_CUT` of ``dt``). Wall speeds as the
        coming step will have them."""
        stage, box = self.stage, self.sample.box
        lengths = box.lengths
        closing = box.speeds[0::2] + box.speeds[1::2]  # [m/s], > 0 shortens the axis
        reach = dt * (1.0 + SHORTEST_CUT)  # a step may stretch this far to end the stage
        cut = math.inf
        for a in stage.moving_axes:
            if closing[a] == 0.0:
                continue
            target = stage.targets[a] + math.copysign(TARGET_MARGIN, stage.targets[a])
            travel = lengths[a] - self.stage_start_lengths[a] * math.exp(-target)
            if 0.0 < travel / closing[a] <= reach:
                cut = min(cut, travel / closing[a])  # cut short, or stretched: no sliver left
        criteria = [c for c in stage.stop if c.quantity in STRAIN_COLUMNS]
        if criteria:
            now, after = self.wall_strains(), self.wall_strains(lengths - reach * closing)
            for criterion in criteria:
                if criterion.met(now) or not criterion.met(after):
                    continue
                start, end = _value(criterion, now), _value(criterion, after)
                goal = criterion.limit + math.copysign(
                    TARGET_MARGIN, 1.0 if criterion.when == "above" else -1.0)
                cut = min(cut, max(SHORTEST_CUT * dt, (goal - start) / (end - start) * reach))
        return dt if cut == math.inf else cut

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
        if not stage.moving_axes:
            self.reference_lengths = self.sample.box.lengths.copy()
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
            targets = self.outcome_stress_targets(stage) if stage is not None else {}
            stages.append(stage_outcome(record, rows, self.settings, targets))
        return RunOutcome(stages=tuple(stages), finished=self.finished,
                          steps=self.simulation.step_index,
                          stopped=self.halted["reason"] if self.halted else "")

    def outcome_stress_targets(self, stage) -> dict[str, float]:
        """The stress targets [Pa] of a stage's stress-controlled axes, by ``"xx"``... (the
        outcome judges the walls' stresses against them)."""
        return {AXES[a] * 2: stage.targets[a] for a in stage.stress_axes
                if math.isfinite(stage.targets[a])}

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
        if every and sim.step_index % every == 0:
            self._snapshot(network, full)
        elif every:
            self._unsnapped = (network, full)  # snapshotted if the stage ends on this row
        if self.on_record is not None:
            self.on_record(self, full)
        return full

    def measures(self):
        """The results row and contact network of the sample now
        (:func:`~grainlab.engine.sample_measures.sample_measures`)."""
        return sample_measures(self.simulation.last_report, self.sample.state,
                               self.sample.library, self.sample.box, self.reference_lengths,
                               self.simulation.last_dt, self.solver.friction)

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
        self.simulation.run(max_steps)
        return self.finished

    # -- persistence --------------------------------------------------------------------------
    def progress_arrays(self) -> dict[str, Any]:
        """What a checkpoint needs besides the sample and the solver's memory."""
        return {
            "stage_index": self.stage_index, "stage_started": self.stage_started,
            "stage_start_step": self.stage_start_step,
            "stage_start_lengths": self.stage_start_lengths.copy(),
            "reference_lengths": self.reference_lengths.copy(),
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
        self.stage_start_lengths = np.asarray(data["stage_start_lengths"], dtype=float)
        self.reference_lengths = np.asarray(data["reference_lengths"], dtype=float)
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
    """Drives the walls every step; starts the next stage when one ended."""

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
            done, reason = test.wall_end()
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



MAX_STEPS_REASON = "max_stage_steps reached"
THIN_BOX = "box too thin for its particles"


def _stop_reason(criterion: StopCriterion) -> str:
    return f"stop criterion {criterion.quantity} {criterion.when} {criterion.limit:g}"


def _value(criterion: StopCriterion, row: dict[str, float]) -> float:
    """The value ``criterion`` compares with its limit."""
    value = float(row[criterion.quantity])
    return abs(value) if criterion.absolute else value


def _k0(row: dict[str, float]) -> float:
    """K0 = (sigma_xx + sigma_yy) / (2 sigma_zz) [-] of a row's contact stresses (NaN unless
    sigma_zz > 0)."""
    vertical = row["sigma_zz"]
    return 0.5 * (row["sigma_xx"] + row["sigma_yy"]) / vertical if vertical > 0.0 \
        else math.nan
