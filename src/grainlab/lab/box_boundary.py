"""The box of walls as the stage loop drives it (:class:`BoxBoundary`, a
:class:`~grainlab.lab.stage_boundary.StageBoundary`; stages from
:func:`~grainlab.lab.wall_stages.wall_stages`).

* A strain-controlled axis moves its upper wall at eps_dot L (L the box's edge along it) at
  the test's strain rate, so that the logarithmic strain rate is constant; an axis that
  reached its target holds still while the others go on. Stress-controlled walls are
  speed-limited to the stage's wall speed eps_dot max(L) (their inward free speed).
* Stress-controlled walls are overdamped servos (``wall_servo``, default): no speed carried
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
* Strains are logarithmic, compression positive, from the reference box: the box at the end
  of the last stage without a strain-controlled axis (the consolidated sample), or the
  initial box before any. A stage without a strain-controlled axis ends when quasi-static
  (:class:`~grainlab.lab.wall_stages.QuasiStaticCriteria` on the walls' stresses).
* The last step of a stage: a strain-controlled axis moves at a prescribed wall speed, so its
  last step is cut to end on the target exactly (to round-off:
  :data:`~grainlab.lab.stage_boundary.TARGET_MARGIN` past it); a stop criterion on a strain
  column (:data:`STRAIN_COLUMNS`) is crossed where the walls' speeds of the step before
  predict (linear in the step length); the stress-controlled walls may move a little
  otherwise, so it ends within a small fraction of a step's increment of its limit, at worst
  one more step of at least :data:`~grainlab.lab.stage_boundary.SHORTEST_CUT` of a step.
* A box thinner than a few particles cannot hold a granular sample
  (:mod:`grainlab.lab.box_thickness`): a stage whose target would take the box below
  :func:`~grainlab.lab.box_thickness.box_limits` does not start, and a stage whose box gets
  there stops, both with the diagnosis; :meth:`BoxBoundary.predicted_flattening` checks a
  whole path before a run.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grainlab.engine.boundaries.wall_box import WALL_NAMES
from grainlab.engine.sample_measures import box_strains, log_strains, sample_measures
from grainlab.errors import InputError
from grainlab.lab.box_thickness import box_limits, predicted_flattening, stage_flattening
from grainlab.lab.stage_boundary import (
    SHORTEST_CUT,
    TARGET_MARGIN,
    THIN_BOX,
    criterion_value,
)
from grainlab.lab.wall_stages import AXES, WallStage, wall_stages

STRAIN_COLUMNS = tuple(box_strains(np.ones(3), np.ones(3)))
"""The columns known from the walls alone (:func:`~grainlab.engine.sample_measures.box_strains`):
stop criteria on them are checked after every step, the others at the records."""


class BoxBoundary:
    """The walls of ``test``'s sample as its stages drive them (module docstring).

    Attributes
    ----------
    stage_start_lengths, reference_lengths:
        (3,) edges [m] of the box at the start of the stage and of the reference box.
    """

    steps_by_overlap = True

    def __init__(self, test) -> None:
        self.test = test
        self.box = test.sample.box
        self.stage_start_lengths = self.box.lengths.copy()
        self.reference_lengths = self.box.lengths.copy()

    def load_stages(self, path, deformable: bool) -> list[WallStage]:
        """The path's stages as wall controls (:func:`~grainlab.lab.wall_stages.
        wall_stages`; walls strain the sample in its axes whatever its grains)."""
        return wall_stages(path)

    # -- a stage's start ------------------------------------------------------------------
    def confining(self, stage: WallStage) -> float:
        """The largest finite stress target [Pa], else the mean stress of the last row."""
        values = [stage.targets[a] for a in stage.stress_axes
                  if math.isfinite(stage.targets[a])]
        return max(values) if values else self.test.mean_stress_reached(stage)

    def refuse_start(self, stage: WallStage) -> str:
        """The diagnosis when the stage's target would flatten the box, else ""."""
        if not stage.moving_axes:
            return ""
        flat = stage_flattening(stage, self.box.lengths, self.reference_lengths,
                                self.test.largest_diameter, self.test.sample.state.n_bodies)
        return flat[0].words() + "; " + flat[0].advice() if flat else ""

    def start(self, stage: WallStage, reference_stress: float) -> None:
        """Set each axis's walls: fixed, at the strain rate, or servo-held at its stress (a
        held stress: the walls' stress of the last row)."""
        box, rate = self.box, self.test.strain_rate
        for a in range(3):
            mode, target = stage.modes[a], stage.targets[a]
            lower, upper = WALL_NAMES[2 * a], WALL_NAMES[2 * a + 1]
            box.set_control(lower, "fixed")
            if mode == "fixed":
                box.set_control(upper, "fixed")
            elif mode == "strain":
                box.set_control(upper, "velocity",
                                math.copysign(1.0, target) * rate * box.lengths[a])
            else:
                sigma = target if math.isfinite(target) else self._held_stress(stage, a)
                box.set_control(upper, "stress", sigma)
        self.stage_start_lengths = box.lengths.copy()

    def _held_stress(self, stage: WallStage, axis: int) -> float:
        rows = self.test.rows
        if not rows:
            raise InputError(f"stage {stage.name!r}: sigma_{AXES[axis] * 2}", "held",
                             "a stress target: no earlier stage set this stress")
        return float(rows[-1][f"wall_sigma_{AXES[axis] * 2}"])

    def width(self) -> float:
        """The box's longest edge [m]."""
        return float(self.box.lengths.max())

    def stage_numerics(self, stage: WallStage) -> None:
        """Speed limits at the stage's wall speed v_max; the stress walls' masses: heavy
        enough that one step of driving force cannot take them past the speed limit
        (h F / m_w <= v_max; otherwise the solver spends its sweeps trading the driving
        impulse between the brake and the contacts), or servos (module docstring)."""
        test, box = self.test, self.box
        v_max, dt, settings = test.stage_wall_speed, test.solver.dt, test.settings
        box.set_max_speeds(v_max)
        box.servo = settings.wall_servo
        if box.servo:
            box.set_masses(box.servo_masses(dt))
        else:
            particles = float(np.sum(test.sample.state.masses))
            box.set_masses(np.maximum(particles * settings.wall_mass_factor,
                                      dt * box.driving_forces() / v_max))

    # -- every step -----------------------------------------------------------------------
    def _stage_strains(self) -> np.ndarray:
        """(3,) logarithmic strains [-] since the stage began."""
        return log_strains(self.stage_start_lengths, self.box.lengths)

    def advance(self, stage: WallStage) -> None:
        """Nothing: the walls' strains are their lengths'."""

    def before_step(self, stage: WallStage) -> None:
        """Keep the strain-controlled walls at a constant logarithmic strain rate (at rest
        once their axis reached its target)."""
        strained = self._stage_strains()
        for a in stage.moving_axes:
            sign = math.copysign(1.0, stage.targets[a])
            speed = 0.0 if abs(strained[a]) >= abs(stage.targets[a]) else \
                sign * self.test.strain_rate * self.box.lengths[a]
            self.box.set_control(WALL_NAMES[2 * a + 1], "velocity", speed)

    def after_step(self, stage: WallStage) -> None:
        """Servo walls: damping fixed, mass c h follows the step (and the face areas)."""
        if self.box.servo:
            self.box.set_masses(self.box.servo_masses(self.test.solver.dt))

    def last_step(self, stage: WallStage, dt: float) -> float:
        """``dt`` [s], or the step that ends the stage where a step of at most
        (1 + SHORTEST_CUT) ``dt`` reaches a target (module docstring): the step that ends a
        strain-controlled axis on its target, the predicted crossing of a stop criterion
        on a strain column (at least SHORTEST_CUT of ``dt``). Wall speeds as the coming
        step will have them."""
        box = self.box
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
            now, after = self.strains(), self.strains(lengths - reach * closing)
            for criterion in criteria:
                if criterion.met(now) or not criterion.met(after):
                    continue
                start, end = criterion_value(criterion, now), criterion_value(criterion, after)
                goal = criterion.limit + math.copysign(
                    TARGET_MARGIN, 1.0 if criterion.when == "above" else -1.0)
                cut = min(cut, max(SHORTEST_CUT * dt, (goal - start) / (end - start) * reach))
        return dt if cut == math.inf else cut

    # -- stage ends -----------------------------------------------------------------------
    def strains(self, lengths: np.ndarray | None = None) -> dict[str, float]:
        """The strain columns (:data:`STRAIN_COLUMNS`) of the box now, or of a box of
        ``lengths`` (3,) [m], from the reference box."""
        return box_strains(self.reference_lengths,
                           self.box.lengths if lengths is None else lengths,
                           self.test.sample.library.dimension)

    def box_limits(self, reference: np.ndarray) -> np.ndarray:
        """(3,) smallest edges [m] allowed for a consolidated box of edges ``reference``."""
        return box_limits(self.test.largest_diameter, reference)

    def target_end(self, stage: WallStage) -> str:
        """"strain reached" when every strain-controlled axis is at its target; the
        diagnosis (``THIN_BOX``...) when the box is too thin for its particles; else ""."""
        if not stage.moving_axes:
            return ""
        strained = self._stage_strains()
        if all(abs(strained[a]) >= abs(stage.targets[a]) for a in stage.moving_axes):
            return "strain reached"
        lengths, d_max = self.box.lengths, self.test.largest_diameter
        limits = self.box_limits(self.reference_lengths)
        thin = np.flatnonzero(lengths < limits)
        if not thin.size:
            return ""
        a = int(thin[0])
        return (f"{THIN_BOX}: its {AXES[a]} edge is {lengths[a] * 1e3:.4g} mm, "
                f"{lengths[a] / d_max:.2f} largest particle diameters "
                f"(d_max = {d_max * 1e3:.4g} mm; smallest allowed "
                f"{limits[a] * 1e3:.4g} mm), at {self.strains()['eps_q']:.4g} of eps_q: the "
                "particles are squeezed into one or two layers, where no time step or "
                "tolerance helps; ask a smaller strain or use more particles")

    def settled(self, stage: WallStage, row: dict[str, Any]) -> bool:
        """Whether a stage without a strain-controlled axis is quasi-static at ``row``
        (:class:`~grainlab.lab.wall_stages.QuasiStaticCriteria` on the walls' stresses)."""
        if stage.moving_axes:
            return False
        targets = {a: self.box.controls[2 * a + 1].value for a in stage.stress_axes}
        return self.test.settings.quasi_static.met(row, targets)

    def stage_ended(self, stage: WallStage) -> None:
        """A stage without a strain-controlled axis leaves the reference box."""
        if not stage.moving_axes:
            self.reference_lengths = self.box.lengths.copy()

    # -- records, outcome, checks before a run ----------------------------------------------
    def measures(self):
        """The results row and contact network of the sample now
        (:func:`~grainlab.engine.sample_measures.sample_measures`)."""
        test = self.test
        sim = test.simulation
        return sample_measures(sim.last_report, test.sample.state, test.sample.library,
                               self.box, self.reference_lengths, sim.last_dt,
                               test.solver.friction)

    def stress_targets(self, stage: WallStage) -> dict[str, float]:
        """The stress targets [Pa] of a stage's stress-controlled axes, by ``"xx"``... (the
        outcome judges the walls' stresses against them)."""
        return {AXES[a] * 2: stage.targets[a] for a in stage.stress_axes
                if math.isfinite(stage.targets[a])}

    def predicted_flattening(self, stages: list[WallStage], started: bool) -> list:
        """The ``stages`` (from the current one) whose targets would flatten the box
        (:func:`~grainlab.lab.box_thickness.predicted_flattening`), from the box now (the
        stage under way, ``started`` with a strain-controlled axis: from its start)."""
        lengths = self.stage_start_lengths if started else self.box.lengths
        library, state = self.test.sample.library, self.test.sample.state
        return predicted_flattening(stages, lengths, self.reference_lengths,
                                    float(np.sum(library.volume[state.shape_ids])),
                                    self.test.largest_diameter, state.n_bodies)

    def fraction_done(self, stage: WallStage) -> float:
        """The largest strain of a strain-controlled axis since the stage began over its
        target."""
        return max(abs(math.log(self.stage_start_lengths[a] / self.box.lengths[a]))
                   / abs(stage.targets[a]) for a in stage.moving_axes)

    def stress_goal(self, stage: WallStage) -> list[float]:
        """The finite stress targets [Pa] of the stage."""
        return [stage.targets[a] for a in stage.stress_axes if math.isfinite(stage.targets[a])]

    def checkpoint_arrays(self) -> dict[str, Any]:
        """The box at the stage's start and the reference box."""
        return {"stage_start_lengths": self.stage_start_lengths.copy(),
                "reference_lengths": self.reference_lengths.copy()}

    def restore(self, data: dict[str, Any]) -> None:
        """Inverse of :meth:`checkpoint_arrays`."""
        self.stage_start_lengths = np.asarray(data["stage_start_lengths"], dtype=float)
        self.reference_lengths = np.asarray(data["reference_lengths"], dtype=float)
