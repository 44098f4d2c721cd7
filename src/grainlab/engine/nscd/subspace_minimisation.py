"""Subspace minimisation between Gauss-Seidel sweeps for a frictionless step (projected
Gauss-Seidel with subspace minimisation: Silcowitz, Niebe & Erleben 2010; the truncated
nonsmooth Newton multigrid idea of Graeser & Kornhuber 2009 with an exact-enough linear
solve in place of the multigrid cycle).

Without friction the step's contact problem is a convex quadratic programme on the normal
impulses r [N s] (one per contact; :mod:`~grainlab.engine.nscd.contact_problem`)::

    minimise  J(r) = 1/2 r . W r + q . r     subject to  r >= 0,     W = H_n M^-1 H_n^T

whose optimality conditions are Signorini's: u = W r + q >= 0, r >= 0, u r = 0. Gauss-Seidel
sweeps (NLGS) find which contacts carry an impulse within a few sweeps, but then need
hundreds more to spread the impulses through a packing near its isostatic point: the error
left lies along the softest modes of W (Rayleigh quotient ~6e-4 of the mean W_nn on a
1000-sphere compaction step), which a sweep barely touches. The correction:

1. A = {a : r_a > 0}, the contacts the sweeps left loaded;
2. the linear system W_AA x = -u_A (u = W r + q at the current impulses) by
   :data:`CG_ITERATIONS` iterations of conjugate gradients on the products
   H_A M^-1 H_A^T (W is never formed), preconditioned by its diagonal;
3. a projected line search on J: r(t) = max(0, r + t x) with t = 1, 1/2, ... down to
   :data:`SMALLEST_STEP`, the first that lowers J taken (J(r(t)) - J(r) computed exactly,
   from u and one product), none if none lowers it.

J never rises, so sweeps and corrections together converge as the sweeps alone do
(each is a descent step on the same convex J); the engine's own stop test (change and
residual, :mod:`~grainlab.engine.nscd.contact_dynamics`) decides when the step is solved.

Measured on a frictionless compaction step of the 1000-sphere triaxial test (6086 contacts,
2753 loaded; ``benchmarks/benchmark_plain_problem_methods.py``): NLGS alone reaches the
engine's stopping error (1.4e-5 ||q||) in 679 sweeps; 10 sweeps then a correction of 20
conjugate-gradient products, repeated, in 70 sweeps and 120 products (22 ms of corrections).
With friction the same correction (sticking contacts' three components, sliding contacts'
normal one) never lowered the error on the shear steps of the same test: the contact
dynamics step uses it only where every contact is frictionless.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from grainlab.engine.nscd.contact_problem import ConstraintSystem

SWEEPS_BETWEEN = 10
"""Gauss-Seidel sweeps between two corrections."""
CG_ITERATIONS = 20
"""Conjugate-gradient iterations of a correction's linear solve."""
SMALLEST_STEP = 1.0 / 1024.0
"""The shortest step of the line search; below it the correction is dropped."""


def normal_rows(system: ConstraintSystem) -> tuple[sp.csr_matrix, sp.csr_matrix, np.ndarray]:
    """H_n (C, n_dofs), its transpose and q_n (C,) [m/s]: the normal rows of ``system``."""
    h_normal = system.constraints[0::3].tocsr()
    return h_normal, h_normal.T.tocsr(), np.ascontiguousarray(system.free_velocity[0::3])


def subspace_correction(system: ConstraintSystem, normal: np.ndarray,
                        iterations: int = CG_ITERATIONS) -> tuple[np.ndarray, float]:
    """The normal impulses ``normal`` (C,) [N s] of a step (``system``: its H, M^-1, q)
    after one correction (module docstring), and the change of J it made [J] (0, with
    ``normal`` returned unchanged, when no step lowered J). W is applied as
    H_n M^-1 H_n^T, never formed."""
    h_normal, h_transpose, q_normal = normal_rows(system)
    inverse_mass = system.inverse_mass

    def delassus(x):
        return h_normal @ (inverse_mass @ (h_transpose @ x))

    def restricted(loaded):
        h_loaded = h_normal[loaded]
        h_loaded_t = h_loaded.T.tocsr()
        diagonal = np.asarray(h_loaded.multiply(h_loaded @ inverse_mass).sum(axis=1)).ravel()
        return (lambda x: h_loaded @ (inverse_mass @ (h_loaded_t @ x))), diagonal

    return minimise_on_loaded(normal, delassus(normal) + q_normal, delassus, restricted,
                              iterations)


def minimise_on_loaded(normal: np.ndarray, velocity: np.ndarray, delassus, restricted,
                       iterations: int = CG_ITERATIONS) -> tuple[np.ndarray, float]:
    """One correction of the normal impulses ``normal`` (C,) [N s] whose normal velocities
    are ``velocity`` = W r + q (C,) [m/s], given ``delassus`` (x -> W_nn x over every
    contact) and ``restricted`` (loaded indices -> (x -> W_AA x, diag W_AA)): the conjugate
    gradients on the loaded contacts, then the projected line search on J (module
    docstring). Returns the new impulses and the change of J [J] (0: unchanged)."""
    loaded = np.flatnonzero(normal > 0.0)
    if loaded.size == 0:
        return normal, 0.0
    product, diagonal = restricted(loaded)
    solution = _conjugate_gradients(product, 1.0 / diagonal, -velocity[loaded], iterations)
    direction = np.zeros_like(normal)
    direction[loaded] = solution
    step = 1.0
    while step >= SMALLEST_STEP:
        change = np.maximum(normal + step * direction, 0.0) - normal
        energy = float(change @ velocity + 0.5 * change @ delassus(change))
        if energy < 0.0:
            return normal + change, energy  # = max(0, r + t x)
        step *= 0.5
    return normal, 0.0


def _conjugate_gradients(product, inverse_diagonal: np.ndarray, rhs: np.ndarray,
                         iterations: int) -> np.ndarray:
    """x after ``iterations`` of conjugate gradients on product(x) = rhs from x = 0,
    preconditioned by ``inverse_diagonal``; stops early when a search direction has no
    curvature left (the residual is zero, or the operator is singular along it)."""
    x = np.zeros_like(rhs)
    residual = rhs.copy()
    z = inverse_diagonal * residual
    direction = z.copy()
    rz = float(residual @ z)
    for _ in range(iterations):
        image = product(direction)
        curvature = float(direction @ image)
        if not curvature > 0.0 or not rz > 0.0:
            break
        alpha = rz / curvature
        x += alpha * direction
        residual -= alpha * image
        z = inverse_diagonal * residual
        rz_new = float(residual @ z)
        direction = z + (rz_new / rz) * direction
        rz = rz_new
    return x


__all__ = ["CG_ITERATIONS", "SMALLEST_STEP", "SWEEPS_BETWEEN", "minimise_on_loaded",
           "normal_rows", "subspace_correction"]
