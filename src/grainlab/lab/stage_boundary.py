"""What a boundary does for a stage of a load path, as the one stage loop of
:class:`~grainlab.lab.discrete_test.DiscreteTest` asks it (:class:`StageBoundary`), and the
rules every boundary shares: how a stage's last step is cut, how a stop criterion names
itself, the words of a stage that ran out of steps or of room.

Two boundaries implement it: the box of walls (:class:`~grainlab.lab.box_boundary.
BoxBoundary`, stages from :func:`~grainlab.lab.wall_stages.wall_stages`) and the periodic
cell (:class:`~grainlab.lab.cell_boundary.CellBoundary`, stages from
:func:`~grainlab.lab.cell_stages.cell_stages`). As MercuryDPM's
``StressStrainControlBoundary``, YADE's ``PeriTriaxController`` or HOOMD's
``ConstantPressure``, the boundary owns the control of its stage: its strains and their
reference, the progress of the stage, when its targets are reached, when it is settled, when
it is too thin for its particles, and what of it a checkpoint keeps. The test owns what every
stage has: the solver and its numerics, the strain rate from the inertia number, the stage's
steps, records, snapshots and outcome.

Stage ends do not wait for a record: after every step the boundary alone decides (cheap: its
geometry gives the strains). The step that would carry a stage past a target is cut short,
and one that would leave less than :data:`SHORTEST_CUT` of a step to go is stretched by that
much instead (no sliver of a step: its forces, impulses over its length, would mean nothing).
"""

from __future__ import annotations

from typing import Any, Protocol

from grainlab.lab.load_path import StopCriterion

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

MAX_STEPS_REASON = "max_stage_steps reached"
THIN_BOX = "box too thin for its particles"


def stop_reason(criterion: StopCriterion) -> str:
    """The words of a stage ended by ``criterion``."""
    return f"stop criterion {criterion.quantity} {criterion.when} {criterion.limit:g}"


def criterion_value(criterion: StopCriterion, row: dict[str, float]) -> float:
    """The value ``criterion`` compares with its limit."""
    value = float(row[criterion.quantity])
    return abs(value) if criterion.absolute else value


class StageBoundary(Protocol):
    """The lab side of a boundary, for the stage loop (module docstring). ``stage`` is one of
    the boundary's own stages (:meth:`load_stages`); ``test`` the
    :class:`~grainlab.lab.discrete_test.DiscreteTest` it serves (its rows, strain rate,
    solver, settings and step count)."""

    steps_by_overlap: bool
    """Whether the stage's step grows and shrinks with the overlaps
    (:mod:`grainlab.lab.step_control`)."""

    def load_stages(self, path, deformable: bool) -> list:
        """The path's stages as this boundary runs them."""

    def confining(self, stage) -> float:
        """The stage's reference stress [Pa] (its strain rate follows from it)."""

    def refuse_start(self, stage) -> str:
        """Why the stage cannot start (its target would leave no room), else ""."""

    def start(self, stage, reference_stress: float) -> None:
        """Set the boundary's control for the stage (the test's strain rate set)."""

    def width(self) -> float:
        """The largest width [m] (the stage's boundary speed is the strain rate times it)."""

    def stage_numerics(self, stage) -> None:
        """The boundary's share of a stage's numerics (speed limits, masses), once the
        solver's step is set."""

    def advance(self, stage) -> None:
        """Follow the step just done in the stage's progress (once per step, whoever asks
        first: the stage end checks or the drive)."""

    def before_step(self, stage) -> None:
        """Follow the step just done (progress, strain-controlled speeds)."""

    def last_step(self, stage, dt: float) -> float:
        """``dt`` [s], or the step that ends the stage on its target (module docstring)."""

    def after_step(self, stage) -> None:
        """Set the control for the coming step, its length set."""

    def strains(self) -> dict[str, float]:
        """The strain columns of the boundary now."""

    def target_end(self, stage) -> str:
        """Why the boundary ends the stage now (target reached, too thin), else ""."""

    def settled(self, stage, row: dict[str, Any]) -> bool:
        """Whether a stage that ends when quasi-static is so at ``row``."""

    def stage_ended(self, stage) -> None:
        """Take the state a stage ended in as the reference where it should."""

    def measures(self):
        """The results row and contact network of the sample now."""

    def stress_targets(self, stage) -> dict[str, Any]:
        """The stress targets the outcome judges the boundary's stresses against."""

    def predicted_flattening(self, stages, started: bool) -> list:
        """The stages whose targets would leave the boundary too thin."""

    def fraction_done(self, stage) -> float:
        """Fraction [0, 1] of a strain-driven stage done (progress bars)."""

    def stress_goal(self, stage) -> list[float]:
        """The stresses [Pa] a stress-driven stage loads to (progress bars)."""

    def checkpoint_arrays(self) -> dict[str, Any]:
        """What a checkpoint keeps of the boundary's stage control."""

    def restore(self, data: dict[str, Any]) -> None:
        """Inverse of :meth:`checkpoint_arrays`."""
