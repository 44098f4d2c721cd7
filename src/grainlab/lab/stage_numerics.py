"""How one kind of stage of a discrete test is solved: friction, loading speed, time step and
NLGS settings (:class:`StageNumerics`), with the defaults of the two kinds.

A discrete test (:mod:`grainlab.lab.discrete_test`) runs two kinds of stages, each with its
own numerics (:func:`stage_kind` decides which a stage is):

* ``compaction`` (:data:`COMPACTION`): no strain-controlled axis; the sample settles under
  stress-controlled walls and only its end state matters (seed 002: frictionless, so that it
  packs densely; the solver may be looser, and no overlap recovery, which keeps a settling
  packing moving: 4270 instead of 850 steps on 200 spheres);
* ``shear`` (:data:`SHEAR`): at least one strain-controlled axis (triaxial shear, oedometer
  loading and unloading); the path is the result, so the loading is slower (I <= 1e-3,
  quasi-static), the step shorter and the solver tighter.

Their values are the lab tests' settings, measured on 200 to 1000 spheres
(docs/explanations/walls-and-box-tests.md, "Solver settings of the lab tests").

>>> SHEAR.friction, COMPACTION.friction
(0.4, 0.0)
>>> from dataclasses import replace
>>> replace(SHEAR, tolerance=1e-5).tolerance
1e-05
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np

from grainlab._validate import at_least, in_range
from grainlab.errors import InputError

StageKind = Literal["compaction", "shear"]

STAGE_KINDS: tuple[StageKind, ...] = ("compaction", "shear")
"""The kinds of stage, each with its :class:`StageNumerics`."""


def stage_kind(strain_controlled: bool) -> StageKind:
    """The kind of a stage: ``"shear"`` when one of its axes is strain-controlled (the walls
    deform the sample at a prescribed rate), ``"compaction"`` when every axis is
    stress-controlled or fixed (the sample settles under its stresses).

    >>> stage_kind(True), stage_kind(False)
    ('shear', 'compaction')
    """
    return "shear" if strain_controlled else "compaction"


@dataclass(frozen=True)
class StageNumerics:
    """The numerics of one kind of stage (module docstring); frozen, validated.

    Attributes
    ----------
    friction:
        Interparticle Coulomb coefficient mu [-], >= 0.
    inertia_number:
        Bound on the inertia number I = eps_dot <d> sqrt(rho / p) [-], in (0, 1]: it sets
        the strain rate eps_dot [1/s] of the strain-controlled walls and the speed limit of
        the stress-controlled ones (:mod:`grainlab.lab.wall_stages`).
    time_step_factor:
        v h / d_min [-], in (0, 0.5]: the time step h [s] is this fraction of the smallest
        length d_min [m] over the stage's wall speed v [m/s] (unless the test's ``dt`` is
        given). The shortest step of a stage in a box of walls solved by contact dynamics
        (it grows from it while the overlaps stay small: ``time_step_growth``).
    time_step_growth:
        Largest multiple [-] (>= 1; 1: a fixed step) of the ``time_step_factor`` step the
        step may grow to, in a box of walls solved by contact dynamics: it grows while the
        largest overlap is below half ``overlap_bound`` and is halved (never below the
        ``time_step_factor`` step) once it exceeds it (:mod:`grainlab.lab.step_control`).
        The periodic cell and soft-contact DEM keep the ``time_step_factor`` step.
    overlap_bound:
        Largest overlap / mean diameter [-] in (0, 0.1) the growing step keeps to (above it
        the step shortens; 0.1 is the runaway limit of
        :class:`~grainlab.engine.simulation.Simulation`).
    tolerance:
        NLGS tolerance [-], in (0, 1): relative change of the contact impulses between two
        sweeps and relative residual (:class:`~grainlab.engine.nscd.contact_dynamics.
        ContactDynamicsStep`).
    max_iterations:
        Most NLGS sweeps per step, an integer >= 1.
    overlap_recovery:
        beta [-] in [0, 1]: the fraction of an overlap the solver asks to open per step
        (0: overlaps are never pushed back).
    capped_share_limit:
        Largest share [-] in [0, 1] of a stage's steps that may end at the sweep cap
        unconverged: above it the stage is not as asked (:mod:`grainlab.lab.run_outcome`;
        the command line exits with status 3). 1 (the compaction's default): any share is
        accepted, and reported; the loading's default is 0.5 (:data:`SHEAR`).
    """

    friction: float
    inertia_number: float
    time_step_factor: float
    tolerance: float
    max_iterations: int
    overlap_recovery: float
    capped_share_limit: float = 1.0
    time_step_growth: float = 1.0
    overlap_bound: float = 5e-3

    def __post_init__(self) -> None:
        at_least("friction", self.friction, strict=False)
        for name, high, closed in (("inertia_number", 1.0, "]"),
                                   ("time_step_factor", 0.5, "]"), ("tolerance", 1.0, ")")):
            value = at_least(name, getattr(self, name))
            if value > high or (closed == ")" and value == high):
                raise InputError(name, getattr(self, name),
                                 f"a finite number in (0, {high:g}{closed}")
        value = self.max_iterations
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise InputError("max_iterations", value, "an integer >= 1")
        if not 0.0 <= self.overlap_recovery <= 1.0:
            raise InputError("overlap_recovery", self.overlap_recovery, "a number in [0, 1]")
        if not 0.0 <= self.capped_share_limit <= 1.0:
            raise InputError("capped_share_limit", self.capped_share_limit, "a number in [0, 1]")
        growth = at_least("time_step_growth", self.time_step_growth, 1.0, strict=False)
        if growth * self.time_step_factor > 0.5:
            raise InputError("time_step_growth", self.time_step_growth,
                             f"a number >= 1 with time_step_growth x time_step_factor "
                             f"({self.time_step_factor:g}) <= 0.5")
        in_range("overlap_bound", self.overlap_bound, 0.0, 0.1)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (the keys of a ``[solver.compaction]`` or ``[solver.shear]`` table)."""
        return asdict(self)


COMPACTION = StageNumerics(friction=0.0, inertia_number=1e-2, time_step_factor=0.01,
                           tolerance=1e-4, max_iterations=1000, overlap_recovery=0.0,
                           time_step_growth=2.0)
"""Default numerics of compaction stages: frictionless (seed 002), I <= 1e-2, h = 0.01 d_min
/ v, tolerance 1e-4 (a looser one slows the settling: 2020 instead of 1040 steps on 1000
spheres at 1.666e-4), 1000 sweeps (1000 spheres: 450 a step on average, 0.2 % of the steps
at the cap), no overlap recovery; the step grows to 2 h while the largest overlap stays below
0.5 % of <d> (:mod:`grainlab.lab.step_control`; at most 3 the compaction of 1000 spheres
capped 3.5 % of its steps)."""

SHEAR = StageNumerics(friction=0.4, inertia_number=1e-3, time_step_factor=0.003,
                      tolerance=1.666e-4, max_iterations=2000, overlap_recovery=0.5,
                      time_step_growth=2.0, capped_share_limit=0.5)
"""Default numerics of shearing stages: mu = 0.4, I <= 1e-3 (quasi-static), h = 0.003 d_min
/ v (with 0.01 the overlaps grew to 6-9 % of <d> at eps_q = 0.1 on 200 spheres, below 1 %
with 0.003), growing to 2 h while the largest overlap stays below 0.5 % of <d>
(:mod:`grainlab.lab.step_control`), tolerance 1.666e-4, 2000 sweeps (1000 spheres to
eps_q = 0.5: ~600 a step on average, 0.1 % at the cap), overlap recovery beta = 0.5 (it holds
the overlaps the longer steps leave: at v h / d_min = 0.01, beta = 0.05 / 0.5 left 3.6 / 0.6 %
of <d>; 0.05 with fixed steps before); at most half the loading's steps may end at the sweep cap
unconverged (measured 0.1-1.4 % on 200-10 000 spheres, 0.3-2.9 % on polyhedra, 24 % on 150
spheres sheared in a periodic cell; a 100-sphere triaxial test on walls with momentum of 1e-6
the particles' mass capped 57 % and let the lateral stresses swing between 4.3 and 13.7 kPa
around 10 kPa)"""
