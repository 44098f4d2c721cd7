"""What a solver is to a simulation (STYLE.md 4): the seam between the pipeline of
:class:`~grainlab.engine.simulation.Simulation` and the way contacts are solved.

A solver advances a sample by one time step through its boundary
(:mod:`grainlab.engine.boundaries.boundary`): it asks the boundary for the step's constraints,
predicts
the configuration, has the boundary detect the contacts, solves them with its own law, moves
the bodies and hands the boundary its motion (:meth:`~grainlab.engine.boundaries.boundary.Boundary.
finish_step`). It returns a :class:`~grainlab.engine.step_report.StepReport` (contacts,
local frames, impulses over the step, relative velocities, images, the solve's convergence
figures): everything the recorders, the analysis and the health check read.

What every solver has is :class:`Solver`: a step length, gravity, friction, the step and its
warm start. An iterative solve (contact dynamics' NLGS) is also an :class:`IterativeSolver`:
a tolerance and a sweep cap, and its reports carry a :class:`Convergence` record (sweeps,
converged, change, residual) that the health check reads; an explicit solver's reports have
none (``convergence`` None): it has no iterations to count, no tolerance to miss.

The implementations are contact dynamics
(:class:`~grainlab.engine.nscd.contact_dynamics.ContactDynamicsStep`) and soft-contact DEM
(:class:`~grainlab.engine.dem.soft_contact.SoftContactStep`, explicit: each step is cut into
sub-steps; its reports have no convergence record). A new solver implements
:class:`Solver` and every boundary, recorder, checkpoint and lab test runs with it; what it
keeps from step to step (contact memory, random state) goes into checkpoints through
:meth:`Solver.warm_start_arrays` / :meth:`Solver.restore_warm_start` and ``rng_state``.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from grainlab.engine.boundaries.boundary import Boundary
from grainlab.engine.convergence import Convergence
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import StepReport

__all__ = ["Convergence", "IterativeSolver", "Solver"]


class Solver(Protocol):
    """A time-stepping solver of a discrete sample (module docstring).

    Attributes read by the simulation and the lab: ``dt`` [s] (the next step's length; the
    lab may change it between steps), ``gravity`` (3,) [m/s^2], ``friction`` (interparticle
    Coulomb coefficient), ``alert`` and ``alert_growths`` (its detection's alert distance),
    ``rng_state`` (plain data, checkpoints). Its step's report has ``convergence``: a
    :class:`Convergence` for an :class:`IterativeSolver`, None for an explicit step.
    """

    dt: float
    gravity: np.ndarray
    friction: float

    def step(self, state: BodyState, library: ShapeLibrary, walls: Boundary | None = None
             ) -> StepReport:
        """Advance ``state`` (and the boundary) by one step of ``dt``."""

    def warm_start_arrays(self) -> dict[str, np.ndarray]:
        """What the solver carries from step to step, as arrays (checkpoints)."""

    def restore_warm_start(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`warm_start_arrays`."""


class IterativeSolver(Solver, Protocol):
    """A solver whose step solves its contacts iteratively (contact dynamics): besides
    :class:`Solver`, a ``tolerance`` [-] on the change and the residual and a sweep cap
    ``max_iterations``; the health check names them when steps end unconverged
    (:class:`~grainlab.engine.simulation.Simulation`)."""

    tolerance: float
    max_iterations: int
