"""Solvers of the plain frictional contact problem u = W r + q with Coulomb's law
(:mod:`~grainlab.engine.nscd.contact_problem`; research/cd_engines.md 6.3; Numba).

:func:`solve` takes a :class:`~grainlab.engine.nscd.contact_problem.FrictionalContactProblem`
and runs one of :data:`METHODS` until the natural-map error ||F(r)|| / ||q|| (Acary, Brémond &
Huber 2018) is at most ``tolerance`` or ``max_iterations`` iterations are done. Every method
measures that same error on its iterate after each iteration (the cost of one product W r),
so that methods are compared at equal accuracy, in time and in iterations; the history is
returned. The error that stopped the iterations is the one returned, and the convergence flag
is that same number against ``tolerance`` (one evaluation: the compiled twin of
:func:`~grainlab.engine.nscd.contact_problem.natural_map_error`, which may differ from it in the
last bits).

Divergence. A method whose error becomes non-finite, or exceeds :data:`DIVERGENCE_FACTOR` x
max(1, the error of the starting impulses), stops at once and raises
:class:`~grainlab.errors.SolverDivergence` naming the method and the setting that would help
(an error of 1 is that of r = 0, relative to ||q||). Projected Jacobi is stable only for
relaxations omega below about 2 / lambda_max(D W), D = diag(1 / W_nn,a)
(:func:`jacobi_relaxation_bound`); its default 0.5 diverges where lambda_max(D W) > 4, as in
dense clusters where every body carries many contacts.

W is held in 3 x 3 blocks (compressed block rows), so an iteration costs one pass over the
nonzero blocks, O(C) for a contact network.

Methods
-------
``"nlgs"``
    Nonlinear Gauss-Seidel (Jean & Moreau; Siconos' NSGS): contacts visited in order (by
    default 0 .. C-1), each solved exactly against the current others with the local solver
    of the contact-dynamics step (:func:`~grainlab.contact.coulomb_cone.local_solve`:
    open, sticking 3 x 3 solve, or projections), updated in place.
``"psor"``
    NLGS with over-relaxation: r_a <- proj_K(r_a + omega (local - r_a)), omega = 1.3 by
    default (Siconos' NSGS ``relaxation``).
``"apgd"``
    Accelerated projected gradient on Coulomb's variational inequality, r = proj_K(r -
    rho F(r)) with F(r) = W r + q + mu |u_T| e_n (the fixed-point projection of the VI
    form, Acary et al.), with Nesterov's momentum and adaptive restart (the momentum is
    dropped whenever it points uphill, O'Donoghue & Candès 2015), as Chrono's APGD
    (Mazhar et al. 2015) does on its convex relaxation. The step is per contact, rho_a =
    t / W_nn,a (a diagonal scaling: proj_K commutes with a positive scale per contact),
    t = 1 / lambda_max(D W), D = diag(1 / W_nn,a), by power iteration (x 1.05).
``"jacobi"``
    Projected Jacobi: every contact solved locally against the others' previous values,
    all at once, then r <- r + omega (local - r) with omega = 0.5 (undamped Jacobi
    oscillates on packings; stable below :func:`jacobi_relaxation_bound`).
``"nlgs-subspace"``
    NLGS with a subspace minimisation of the normal impulses after every
    :data:`~grainlab.engine.nscd.subspace_minimisation.SWEEPS_BETWEEN` sweeps
    (:mod:`~grainlab.engine.nscd.subspace_minimisation`: conjugate gradients on the loaded
    contacts' W_AA, a projected line search on the energy) where every contact is
    frictionless; with friction it is NLGS. Its iterations are the sweeps; each
    correction adds :data:`~grainlab.engine.nscd.subspace_minimisation.CG_ITERATIONS` + 2
    products with W_nn (``ContactSolution.products``).

>>> import numpy as np, scipy.sparse as sp
>>> from grainlab.engine.nscd.contact_problem import FrictionalContactProblem
>>> w = np.array([[2.0, 0, 0], [0, 2.0, 0], [0, 0, 2.0]])  # a sphere on the floor, m = 0.5
>>> problem = FrictionalContactProblem(w, [-1.0, 0.3, 0.0], [0.5])
>>> solution = solve(problem, "nlgs", tolerance=1e-12)
>>> solution.converged, solution.reactions.round(6).tolist()   # sticks: r = -W^-1 q
(True, [0.5, -0.15, 0.0])
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit

from grainlab._validate import at_least
from grainlab.contact.coulomb_cone import local_solve, project_cone
from grainlab.engine.nscd.contact_problem import (
    FrictionalContactProblem,
    problem_scale,
)
from grainlab.engine.nscd.subspace_minimisation import (
    CG_ITERATIONS,
    SWEEPS_BETWEEN,
    minimise_on_loaded,
)
from grainlab.errors import InputError, SolverDivergence

METHODS = ("nlgs", "psor", "apgd", "jacobi", "nlgs-subspace")
"""The methods of :func:`solve` (module docstring)."""

DIVERGENCE_FACTOR = 1e6
"""A solve stops as diverged once its error exceeds this many times max(1, the error of its
starting impulses), or is not finite (module docstring, "Divergence")."""

_TINY = 1e-300
_POWER_ITERATIONS = 30
_STEP_SAFETY = 1.05


@dataclass(frozen=True, eq=False)
class ContactSolution:
    """Outcome of :func:`solve`.

    ``reactions`` r (3C,) [N s] and ``velocities`` u = W r + q (3C,) [m/s] (contact a at
    3a .. 3a + 2, (n, t, s)); ``iterations`` done; ``error`` the natural-map error of r, the
    one the stop test measured (``errors[-1]``; 0 without contacts); ``converged`` that same
    number against the tolerance (error <= tolerance); ``errors`` (iterations,) the error
    after each iteration; ``seconds`` the wall time of the iterations (compilation excluded
    once the kernels are compiled); ``method``; ``products`` the products with W made
    besides the iterations (``"nlgs-subspace"``'s corrections; 0 for the others).
    """

    reactions: np.ndarray
    velocities: np.ndarray
    iterations: int
    error: float
    converged: bool
    errors: np.ndarray
    seconds: float
    method: str
    products: int = 0


@dataclass(frozen=True, eq=False)
class BlockDelassus:
    """W in compressed 3 x 3 block rows: ``indptr`` (C + 1,), ``indices`` (B,), ``blocks``
    (B, 3, 3), and ``diagonal`` (C,) the position of block (a, a) in row a."""

    indptr: np.ndarray
    indices: np.ndarray
    blocks: np.ndarray
    diagonal: np.ndarray

    @classmethod
    def of(cls, problem: FrictionalContactProblem) -> BlockDelassus:
        n = problem.n_contacts
        bsr = sp.bsr_matrix(problem.delassus, blocksize=(3, 3))
        bsr.sort_indices()
        indptr = bsr.indptr.astype(np.int64)
        indices = bsr.indices.astype(np.int64)
        diagonal = np.full(n, -1, dtype=np.int64)
        rows = np.repeat(np.arange(n), np.diff(indptr))
        on_diagonal = np.flatnonzero(indices == rows)
        diagonal[rows[on_diagonal]] = on_diagonal
        if np.any(diagonal < 0):
            raise InputError("delassus", "a contact without its diagonal block",
                             "a 3 x 3 block W_aa at every contact")
        return cls(indptr, indices, np.ascontiguousarray(bsr.data, dtype=np.float64), diagonal)


def solve(problem: FrictionalContactProblem, method: str = "nlgs", *,
          tolerance: float = 1e-6, max_iterations: int = 1000, reactions=None,
          order=None, relaxation: float | None = None) -> ContactSolution:
    """Solve ``problem`` by ``method`` (:data:`METHODS`, module docstring) to a natural-map
    error of at most ``tolerance``, in at most ``max_iterations`` iterations, from
    ``reactions`` (3C,) [N s] (a warm start; default zero). ``order`` (C,): the NLGS / PSOR
    visiting order (default 0 .. C-1); ``relaxation``: omega of PSOR (default 1.3) and
    Jacobi (default 0.5). A solve that diverges raises
    :class:`~grainlab.errors.SolverDivergence` (module docstring, "Divergence")."""
    if method not in METHODS:
        raise InputError("method", method, "one of " + ", ".join(map(repr, METHODS)))
    tolerance = at_least("tolerance", tolerance)
    if isinstance(max_iterations, bool) or not isinstance(max_iterations, int | np.integer) \
            or max_iterations < 1:
        raise InputError("max_iterations", max_iterations, "an integer >= 1")
    n = problem.n_contacts
    r = np.zeros(3 * n) if reactions is None else \
        np.array(reactions, dtype=np.float64).ravel()
    if r.size != 3 * n or not np.all(np.isfinite(r)):
        raise InputError("reactions", f"{r.size} entries", f"{3 * n} finite impulses in N s")
    r = r.reshape(n, 3)
    mu = problem.friction
    for a in range(n):  # start inside the cones
        r[a] = project_cone(mu[a], r[a, 0], r[a, 1], r[a, 2])
    if order is None:
        visit = np.arange(n, dtype=np.int64)
    else:
        visit = np.asarray(order, dtype=np.int64).ravel()
        if visit.size != n or not np.array_equal(np.sort(visit), np.arange(n)):
            raise InputError("order", f"{visit.size} indices", f"a permutation of 0 .. {n - 1}")
    default_omega = {"psor": 1.3, "jacobi": 0.5}.get(method, 1.0)
    omega = default_omega if relaxation is None else float(relaxation)
    if not 0.0 < omega < 2.0:
        raise InputError("relaxation", relaxation, "a number in (0, 2)")
    q = problem.free_velocity.reshape(n, 3)
    scale = problem_scale(problem)
    errors = np.zeros(max_iterations)
    if n == 0:
        return ContactSolution(r.ravel(), np.zeros(0), 0, 0.0, True, errors[:0], 0.0, method)
    w = BlockDelassus.of(problem)
    u = np.empty((n, 3))
    start_error = _error(w.indptr, w.indices, w.blocks, q, mu, r, u, scale)
    limit = DIVERGENCE_FACTOR * max(1.0, start_error)
    start = time.perf_counter()
    products = 0
    if method in ("nlgs", "psor"):
        done = _gauss_seidel(w.indptr, w.indices, w.blocks, w.diagonal, q, mu, visit, omega,
                             tolerance, limit, scale, r, u, errors)
    elif method == "nlgs-subspace":
        done, products = _subspace_sweeps(problem, w, visit, tolerance, limit, scale, r, u,
                                          errors)
    elif method == "jacobi":
        done = _jacobi(w.indptr, w.indices, w.blocks, w.diagonal, q, mu, omega, tolerance,
                       limit, scale, r, u, errors, np.empty((n, 3)))
    else:
        step = 1.0 / (_STEP_SAFETY * _largest_scaled_eigenvalue(w, n))
        done = _apgd(w.indptr, w.indices, w.blocks, w.diagonal, q, mu, step, tolerance,
                     limit, scale, r, u, errors, np.empty((n, 3)), np.empty((n, 3)),
                     np.empty((n, 3)))
    seconds = time.perf_counter() - start
    if done < 0:
        raise SolverDivergence(_divergence(problem, w, method, omega, relaxation is None,
                                           errors[:-done], start_error))
    error = float(errors[done - 1])  # the error the stop test measured, and no other
    return ContactSolution(r.ravel().copy(), u.ravel().copy(), int(done), error,
                           bool(error <= tolerance), errors[:done].copy(), seconds, method,
                           products)


def _subspace_sweeps(problem: FrictionalContactProblem, w: BlockDelassus, visit, tolerance,
                     limit, scale, r, u, errors) -> tuple[int, int]:
    """``"nlgs-subspace"``: NLGS in runs of SWEEPS_BETWEEN sweeps, a subspace minimisation
    of the normal impulses after each unconverged run of a frictionless problem; the sweeps
    done (negated on divergence, as :func:`_gauss_seidel`) and the correction's products."""
    q, mu = problem.free_velocity.reshape(-1, 3), problem.friction
    if np.any(mu > 0.0):
        return _gauss_seidel(w.indptr, w.indices, w.blocks, w.diagonal, q, mu, visit, 1.0,
                             tolerance, limit, scale, r, u, errors), 0
    normal_block = problem.delassus[0::3, 0::3].tocsr()

    def restricted(loaded):
        block = normal_block[loaded][:, loaded].tocsr()
        return (lambda x: block @ x), block.diagonal()

    done, products = 0, 0
    while done < errors.shape[0]:
        run = min(SWEEPS_BETWEEN, errors.shape[0] - done)
        ran = _gauss_seidel(w.indptr, w.indices, w.blocks, w.diagonal, q, mu, visit, 1.0,
                            tolerance, limit, scale, r, u, errors[done:done + run])
        if ran < 0:
            return ran - done, products
        done += ran
        if ran < run or errors[done - 1] <= tolerance or done == errors.shape[0]:
            break
        normal, gain = minimise_on_loaded(
            r[:, 0].copy(), normal_block @ r[:, 0] + q[:, 0], lambda x: normal_block @ x,
            restricted)
        products += CG_ITERATIONS + 2
        if gain < 0.0:
            r[:, 0] = normal
            errors[done - 1] = _error(w.indptr, w.indices, w.blocks, q, mu, r, u, scale)
            if _verdict(errors[done - 1], tolerance, limit) == 1:
                break
    return done, products


def jacobi_relaxation_bound(problem: FrictionalContactProblem) -> float:
    """2 / lambda_max(D W), D = diag(1 / W_nn,a) per contact (power iteration): about the
    largest relaxation omega for which projected Jacobi does not diverge on ``problem``
    (its linear iteration on sticking contacts amplifies by |1 - omega lambda| per
    iteration); inf without contacts."""
    if problem.n_contacts == 0:
        return math.inf
    return 2.0 / _largest_scaled_eigenvalue(BlockDelassus.of(problem), problem.n_contacts)


def _divergence(problem: FrictionalContactProblem, w: BlockDelassus, method: str,
                omega: float, default: bool, errors: np.ndarray, start_error: float) -> str:
    """The message of a diverged solve: the method, where its error went, and what to
    change."""
    n = problem.n_contacts
    last = float(errors[-1])
    went = (f"its natural-map error became {last:g} at iteration {errors.size}"
            if not math.isfinite(last) else
            f"its natural-map error grew from {start_error:.3g} to {last:.3g} in "
            f"{errors.size} iterations (limit {DIVERGENCE_FACTOR:g} x max(1, start))")
    head = f"method {method!r} diverged on this problem ({n} contacts): {went}; "
    setting = f"relaxation = {omega:g}{' (the default)' if default else ''}"
    if method == "jacobi":
        bound = 2.0 / _largest_scaled_eigenvalue(w, n)
        return head + (
            f"{setting} is above this problem's stable bound 2 / lambda_max(D W) = "
            f"{bound:.3g} (D = diag(1 / W_nn)); pass relaxation below it (e.g. "
            f"relaxation={_round_down(0.9 * bound)}) or use method 'nlgs'.")
    if method == "psor":
        return head + (f"{setting} over-relaxes it; pass a relaxation in (0, 1] "
                       "(1 is 'nlgs') or use method 'nlgs'.")
    if method == "apgd":
        return head + ("its step, 1 / (1.05 lambda_max(D W)) from 30 power iterations, was "
                       "too long for this problem; use method 'nlgs'.")
    return head + ("check that the problem's W is symmetric positive semi-definite and that "
                   "the problem has a solution, or try method 'apgd'.")


def _round_down(value: float) -> str:
    """``value`` > 0 rounded down to two significant digits, as text."""
    digits = 1 - math.floor(math.log10(value))
    return f"{math.floor(value * 10**digits) / 10**digits:g}"


def _largest_scaled_eigenvalue(w: BlockDelassus, n: int) -> float:
    """lambda_max of D W, D = diag(1 / W_nn,a) per contact (power iteration)."""
    vector = np.ones((n, 3))
    out = np.empty((n, 3))
    normal = w.blocks[w.diagonal, 0, 0][:, None]  # W_nn per contact
    value = 1.0
    for _ in range(_POWER_ITERATIONS):
        _product(w.indptr, w.indices, w.blocks, vector, out)
        out /= normal
        value = float(np.linalg.norm(out)) / max(float(np.linalg.norm(vector)), _TINY)
        vector = out / max(float(np.linalg.norm(out)), _TINY)
    return max(value, _TINY)


# --------------------------------------------------------------------------------------------
# Kernels
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def _row(a, indptr, indices, blocks, r, skip):
    """(W r)_a, the 3 x 3 blocks of row a times the impulses r (C, 3), leaving out column
    ``skip`` (-1: none)."""
    u0, u1, u2 = 0.0, 0.0, 0.0
    for p in range(indptr[a], indptr[a + 1]):
        b = indices[p]
        if b == skip:
            continue
        block = blocks[p]
        r0, r1, r2 = r[b, 0], r[b, 1], r[b, 2]
        u0 += block[0, 0] * r0 + block[0, 1] * r1 + block[0, 2] * r2
        u1 += block[1, 0] * r0 + block[1, 1] * r1 + block[1, 2] * r2
        u2 += block[2, 0] * r0 + block[2, 1] * r1 + block[2, 2] * r2
    return u0, u1, u2


@njit(cache=True)
def _product(indptr, indices, blocks, r, out):
    """out = W r over the 3 x 3 blocks (r, out (C, 3))."""
    for a in range(indptr.shape[0] - 1):
        out[a, 0], out[a, 1], out[a, 2] = _row(a, indptr, indices, blocks, r, -1)


@njit(cache=True)
def _error(indptr, indices, blocks, q, mu, r, u, scale):
    """Natural-map error of r (u = W r + q written to ``u``), divided by ``scale``."""
    _product(indptr, indices, blocks, r, u)
    total = 0.0
    for a in range(r.shape[0]):
        u0, u1, u2 = u[a, 0] + q[a, 0], u[a, 1] + q[a, 1], u[a, 2] + q[a, 2]
        u[a, 0], u[a, 1], u[a, 2] = u0, u1, u2
        slip = math.sqrt(u1 * u1 + u2 * u2)
        c0, c1, c2 = project_cone(mu[a], r[a, 0] - u0 - mu[a] * slip, r[a, 1] - u1,
                                  r[a, 2] - u2)
        total += (r[a, 0] - c0) ** 2 + (r[a, 1] - c1) ** 2 + (r[a, 2] - c2) ** 2
    return math.sqrt(total) / scale


@njit(inline="always")
def _verdict(error, tolerance, limit):
    """1 when ``error`` <= ``tolerance`` (converged), -1 when it is not finite or above
    ``limit`` (diverged), else 0."""
    if not math.isfinite(error) or error > limit:
        return -1
    return 1 if error <= tolerance else 0


@njit(inline="always")
def _local(a, indptr, indices, blocks, diagonal, q, mu, r):
    """Contact a solved exactly against the current impulses of the others."""
    u0, u1, u2 = _row(a, indptr, indices, blocks, r, a)
    return local_solve(blocks[diagonal[a]], q[a, 0] + u0, q[a, 1] + u1, q[a, 2] + u2, mu[a],
                       r[a, 0], r[a, 1], r[a, 2])


@njit(cache=True)
def _gauss_seidel(indptr, indices, blocks, diagonal, q, mu, order, omega, tolerance, limit,
                  scale, r, u, errors):
    """NLGS (omega = 1) or PSOR sweeps in ``order``; returns the iterations done (negated
    when the error went past ``limit`` or became non-finite: :func:`_verdict`)."""
    for iteration in range(errors.shape[0]):
        for m in range(order.shape[0]):
            a = order[m]
            x0, x1, x2 = _local(a, indptr, indices, blocks, diagonal, q, mu, r)
            if omega != 1.0:
                x0 = r[a, 0] + omega * (x0 - r[a, 0])
                x1 = r[a, 1] + omega * (x1 - r[a, 1])
                x2 = r[a, 2] + omega * (x2 - r[a, 2])
                x0, x1, x2 = project_cone(mu[a], x0, x1, x2)
            r[a, 0], r[a, 1], r[a, 2] = x0, x1, x2
        errors[iteration] = _error(indptr, indices, blocks, q, mu, r, u, scale)
        verdict = _verdict(errors[iteration], tolerance, limit)
        if verdict != 0:
            return verdict * (iteration + 1)
    return errors.shape[0]


@njit(cache=True)
def _jacobi(indptr, indices, blocks, diagonal, q, mu, omega, tolerance, limit, scale, r, u,
            errors, local):
    """Damped projected Jacobi; returns the iterations done (negated on divergence, as
    :func:`_gauss_seidel`)."""
    n = r.shape[0]
    for iteration in range(errors.shape[0]):
        for a in range(n):
            x0, x1, x2 = _local(a, indptr, indices, blocks, diagonal, q, mu, r)
            local[a, 0], local[a, 1], local[a, 2] = x0, x1, x2
        for a in range(n):
            x0 = r[a, 0] + omega * (local[a, 0] - r[a, 0])
            x1 = r[a, 1] + omega * (local[a, 1] - r[a, 1])
            x2 = r[a, 2] + omega * (local[a, 2] - r[a, 2])
            r[a, 0], r[a, 1], r[a, 2] = project_cone(mu[a], x0, x1, x2)
        errors[iteration] = _error(indptr, indices, blocks, q, mu, r, u, scale)
        verdict = _verdict(errors[iteration], tolerance, limit)
        if verdict != 0:
            return verdict * (iteration + 1)
    return errors.shape[0]


@njit(cache=True)
def _apgd(indptr, indices, blocks, diagonal, q, mu, step, tolerance, limit, scale, r, u,
          errors, y, previous, gradient):
    """Accelerated projected gradient with adaptive restart (module docstring); returns the
    iterations done (negated on divergence, as :func:`_gauss_seidel`)."""
    n = r.shape[0]
    for a in range(n):
        y[a, 0], y[a, 1], y[a, 2] = r[a, 0], r[a, 1], r[a, 2]
    theta = 1.0
    for iteration in range(errors.shape[0]):
        _product(indptr, indices, blocks, y, gradient)
        uphill = 0.0
        for a in range(n):
            g0 = gradient[a, 0] + q[a, 0]
            g1 = gradient[a, 1] + q[a, 1]
            g2 = gradient[a, 2] + q[a, 2]
            g0 += mu[a] * math.sqrt(g1 * g1 + g2 * g2)
            rho = step / blocks[diagonal[a], 0, 0]
            previous[a, 0], previous[a, 1], previous[a, 2] = r[a, 0], r[a, 1], r[a, 2]
            x0, x1, x2 = project_cone(mu[a], y[a, 0] - rho * g0, y[a, 1] - rho * g1,
                                      y[a, 2] - rho * g2)
            r[a, 0], r[a, 1], r[a, 2] = x0, x1, x2
            uphill += (g0 * (x0 - previous[a, 0]) + g1 * (x1 - previous[a, 1])
                       + g2 * (x2 - previous[a, 2]))
        if uphill > 0.0:  # restart: the momentum points uphill
            theta = 1.0
            for a in range(n):
                y[a, 0], y[a, 1], y[a, 2] = r[a, 0], r[a, 1], r[a, 2]
        else:
            following = 0.5 * (1.0 + math.sqrt(1.0 + 4.0 * theta * theta))
            beta = (theta - 1.0) / following
            theta = following
            for a in range(n):
                for d in range(3):
                    y[a, d] = r[a, d] + beta * (r[a, d] - previous[a, d])
        errors[iteration] = _error(indptr, indices, blocks, q, mu, r, u, scale)
        verdict = _verdict(errors[iteration], tolerance, limit)
        if verdict != 0:
            return verdict * (iteration + 1)
    return errors.shape[0]
