"""A simulation owns its sample and an ordered, visible list of operations (STYLE.md 4).

Each time step: the solver (:class:`~grainlab.engine.solver.Solver`; contact dynamics today)
advances the sample through its boundary (:mod:`grainlab.engine.boundaries.boundary`: the wall box
or
the periodic cell; detection, contact problem, integration, the boundary's motion), the step
counter and clock move on, the health check runs, then every operation
whose trigger fires on this step acts, in the order they were added. Operations are objects
with a ``name``, a ``trigger`` (a callable on the step index, e.g. :class:`Periodic`) and an
``act(simulation)`` method: boundary control, recorders, snapshot and checkpoint writers,
progress bars, or a user's own action, added without touching any kernel.

Health check (a run that blows up stops with a diagnosis, :class:`SimulationBlowUp`):

* non-finite positions, velocities or wall coordinates; a solver step that diverged
  (:class:`~grainlab.errors.SolverDivergence`: non-finite impulses, nothing applied);
* runaway overlap: the largest overlap at detection above ``max_overlap`` x the mean
  particle diameter (default 0.1);
* solver divergence: ``max_unconverged`` consecutive steps (default 200) whose NLGS hit its
  iteration cap still far from the solution (natural-map residual above
  ``divergence_factor`` x the tolerance, default 100); steps that end near it are counted
  (``unconverged_steps``) and reported, not fatal. The relative change of the impulses is
  not a distance to the solution where the impulses are not unique: the coplanar points of
  a polyhedron face contact share their normal force in many ways, and a loose frictionless
  compaction of 1000 polyhedra was stopped with the residual at 1.5e-4 (tolerance 1e-4)
  while the impulses still moved by 1.8 % per sweep along that freedom;
* opposite walls crossing.

>>> from grainlab.prep.loose_sample import loose_sample
>>> from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
>>> sim = Simulation(loose_sample(n_particles=5, seed=1), ContactDynamicsStep(dt=1e-5))
>>> class Count:
...     name, trigger, calls = "count", Periodic(2), 0
...     def act(self, simulation):
...         self.calls += 1
>>> counter = sim.add(Count())
>>> sim.run(6)
6
>>> counter.calls, sim.step_index
(3, 6)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.solver import Solver
from grainlab.engine.step_report import StepReport
from grainlab.errors import GrainlabError, InputError, SolverDivergence


class SimulationBlowUp(GrainlabError, RuntimeError):
    """The simulation left the physical regime; the message says how and where."""


@dataclass(frozen=True)
class Periodic:
    """Fires on steps k with k >= start and (k - start) divisible by ``period`` (>= 1)."""

    period: int
    start: int = 0

    def __post_init__(self) -> None:
        if isinstance(self.period, bool) or not isinstance(self.period, int | np.integer) \
                or self.period < 1:
            raise InputError("period", self.period, "an integer >= 1")

    def __call__(self, step: int) -> bool:
        return step >= self.start and (step - self.start) % self.period == 0


class Operation(Protocol):
    """Something a simulation does after the steps its trigger selects."""

    name: str
    trigger: Callable[[int], bool]

    def act(self, simulation: Simulation) -> None:
        """Act on the simulation (read or change its sample, write files...)."""


class Simulation:
    """A discrete sample advanced by a solver, with ordered operations (module docstring).

    Attributes
    ----------
    sample:
        The :class:`~grainlab.engine.discrete_sample.DiscreteSample` (library, state, box).
    solver:
        The :class:`~grainlab.engine.solver.Solver` (e.g.
        :class:`~grainlab.engine.nscd.contact_dynamics.ContactDynamicsStep`).
    step_index, time:
        Steps done and simulated time [s].
    last_report:
        The solver's :class:`StepReport` of the last step (None before the first).
    last_dt:
        The length [s] of the last step (the solver's ``dt`` may already be set for the next
        one when operations measure the last: forces are its impulses over ``last_dt``).
    unconverged_steps:
        Steps whose NLGS did not converge; ``unconverged_in_row``: consecutive ones far from
        convergence (module docstring).
    """

    def __init__(self, sample: DiscreteSample, solver: Solver, *,
                 max_overlap: float = 0.1, max_unconverged: int = 200,
                 divergence_factor: float = 100.0) -> None:
        self.sample = sample
        self.solver = solver
        self.step_index = 0
        self.time = 0.0
        self.last_report: StepReport | None = None
        self.unconverged_steps = 0
        self.unconverged_in_row = 0
        self.max_overlap = float(max_overlap)
        self.max_unconverged = int(max_unconverged)
        self.divergence_factor = float(divergence_factor)
        self.operations: list[Operation] = []
        self._stop = False
        self._previous_velocities = sample.state.velocities.copy()
        self.last_dt = solver.dt

    # -- operations ---------------------------------------------------------------------------
    def add(self, operation: Operation) -> Operation:
        """Append ``operation`` (names must be unique); returns it."""
        if any(op.name == operation.name for op in self.operations):
            raise InputError("operation.name", operation.name, "a name not used yet: "
                             + ", ".join(op.name for op in self.operations))
        self.operations.append(operation)
        return operation

    def operation(self, name: str) -> Operation:
        """The operation called ``name``."""
        for op in self.operations:
            if op.name == name:
                return op
        raise InputError("operation", name,
                         "one of " + ", ".join(op.name for op in self.operations))

    def remove(self, name: str) -> None:
        """Remove the operation called ``name``."""
        self.operations.remove(self.operation(name))

    def net_forces(self) -> np.ndarray:
        """(N, 3) net force [N] on each particle over the last step, contacts only:
        m (v_new - v_old) / h - m g (the unbalanced force)."""
        state = self.sample.state
        dv = state.velocities - self._previous_velocities
        return state.masses[:, None] * (dv / self.last_dt - self.solver.gravity[None, :])

    def request_stop(self) -> None:
        """Make :meth:`run` return after the current step's operations."""
        self._stop = True

    # -- stepping -----------------------------------------------------------------------------
    def step(self) -> StepReport:
        """One time step, the health check, then the triggered operations."""
        sample = self.sample
        self._check_finite()
        self._previous_velocities = sample.state.velocities.copy()
        self.last_dt = self.solver.dt
        try:
            report = self.solver.step(sample.state, sample.library, sample.boundary)
        except SolverDivergence as error:  # nothing of the step was applied
            raise SimulationBlowUp(
                f"{error} (step {self.step_index + 1}, t = {self.time:.6g} s)") from None
        self.step_index += 1
        self.time += self.last_dt
        self.last_report = report
        convergence = report.convergence  # None: an explicit step, nothing to converge
        if convergence is None or convergence.converged:
            self.unconverged_in_row = 0
        else:
            self.unconverged_steps += 1
            far = convergence.residual > self.divergence_factor * self.solver.tolerance
            self.unconverged_in_row = self.unconverged_in_row + 1 if far else 0
        self._check_health(report)
        for op in self.operations:
            if op.trigger(self.step_index):
                op.act(self)
        return report

    def run(self, n_steps: int | None = None) -> int:
        """Step ``n_steps`` times (None: until an operation calls :meth:`request_stop`);
        returns the steps done."""
        done = 0
        while (n_steps is None or done < n_steps) and not self._stop:
            self.step()
            done += 1
        self._stop = False  # a stop requested before the call still takes effect
        return done

    def _check_finite(self) -> None:
        state, boundary = self.sample.state, self.sample.boundary
        where = f"at step {self.step_index} (t = {self.time:.6g} s)"
        checked = [("positions", state.positions), ("velocities", state.velocities),
                   ("angular velocities", state.angular_velocities)]
        for name, array in boundary.health_arrays().items():
            checked.append((name, array))
        for name, array in checked:
            if not np.all(np.isfinite(array)):
                rows = np.flatnonzero(~np.all(np.isfinite(array.reshape(len(array), -1)),
                                              axis=1))
                raise SimulationBlowUp(
                    f"non-finite {name} {where} (rows {rows[:5].tolist()}); the time step "
                    f"{self.solver.dt:g} s may be too large for the speeds reached.")

    def _check_health(self, report: StepReport) -> None:
        self._check_finite()
        where = f"at step {self.step_index} (t = {self.time:.6g} s)"
        d_mean = self.sample.mean_diameter
        if report.max_overlap > self.max_overlap * d_mean:
            raise SimulationBlowUp(
                f"runaway overlap {where}: {report.max_overlap:.3g} m = "
                f"{report.max_overlap / d_mean:.3g} mean diameters (limit {self.max_overlap}); "
                "reduce the time step or the loading speed, or tighten the solver tolerance.")
        if self.unconverged_in_row >= self.max_unconverged:
            raise SimulationBlowUp(
                f"solver divergence {where}: {self.unconverged_in_row} steps in a row ended "
                f"far from convergence at the cap of {self.solver.max_iterations} sweeps (last "
                f"residual {report.convergence.residual:.3g}, change "
                f"{report.convergence.change:.3g}, tolerance "
                f"{self.solver.tolerance:g}); raise max_iterations or reduce the time step.")
