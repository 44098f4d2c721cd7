"""The convergence record of an iterative step (:class:`Convergence`): what the health check
(:class:`~grainlab.engine.simulation.Simulation`), the results' ``solver_*`` columns
(:func:`~grainlab.engine.sample_measures.sample_measures`) and the run's outcome read of a
solve that sweeps to a tolerance. An explicit step has none (:mod:`grainlab.engine.solver`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Convergence:
    """How an iterative step's solve ended: ``iterations`` (sweeps done), ``converged`` (both
    the change and the residual within the tolerance), ``change`` and ``residual`` [-] after
    the last sweep (:mod:`grainlab.engine.nscd.contact_dynamics`, "Convergence")."""

    iterations: int
    converged: bool
    change: float
    residual: float


EXPLICIT_COLUMNS = {"solver_iterations": 1.0, "solver_converged": 1.0, "solver_change": 0.0,
                    "solver_residual": 0.0}
"""The results' ``solver_*`` columns of a step without a convergence record (an explicit
step): one evaluation, nothing left unsolved, as the results tables have always read them."""


def convergence_columns(convergence: Convergence | None) -> dict[str, float]:
    """The results' ``solver_iterations``, ``solver_converged``, ``solver_change`` and
    ``solver_residual`` of a step's convergence record (:data:`EXPLICIT_COLUMNS` for
    None)."""
    if convergence is None:
        return dict(EXPLICIT_COLUMNS)
    return {"solver_iterations": float(convergence.iterations),
            "solver_converged": float(convergence.converged),
            "solver_change": convergence.change, "solver_residual": convergence.residual}
