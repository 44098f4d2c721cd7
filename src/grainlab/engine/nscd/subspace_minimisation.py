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

Measured on five frictionless compaction steps of the 1000-sphere triaxial test (5979-6086
contacts; ``benchmarks/benchmark_plain_problem_methods.py``, one thread, medians): to a
natural-map error of 1e-5 ||q||, NLGS alone in 1348 sweeps (1.97 s), with the correction in
113 sweeps (0.17 s, corrections included); to 1e-6 in 355 sweeps, where NLGS alone stops at
6.0e-6 after 2000. A conjugate-gradient product costs about half a sweep (60 us on 2750
loaded contacts), so a correction of 20 costs about ten sweeps. With friction the same
correction (sticking contacts' three components, sliding contacts' normal one) never lowered
the error on the shear steps of the same test: the contact-dynamics step uses it only where
every contact is frictionless.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

SWEEPS_BETWEEN = 10
"""Gauss-Seidel sweeps between two corrections."""
CG_ITERATIONS = 20
"""Conjugate-gradient iterations of a correction's linear solve."""
SMALLEST_STEP = 1.0 / 1024.0
"""The shortest step of the line search; below it the correction is dropped."""


@dataclass(frozen=True, eq=False)
class NormalCoupling:
    """The normal rows of H of a step, per contact a (C contacts, N bodies, E extra degrees
    of freedom: the mobile walls, then the free degrees of freedom of a periodic cell):
    ``body_i``, ``body_j`` (C,) int64 (body_i < 0: a wall), ``g_i``, ``g_j`` (C, 6) body i's
    and body j's rows (n, arm x n; minus for i; zero for a wall), ``extra_col`` (C, K) int64
    the extra degrees of freedom contact a moves (-1: none) and ``extra_coef`` (C, K) their
    coefficients; the inverse masses ``inv_mass`` (N,) [1/kg], ``inv_inertia`` (N, 3, 3)
    [1/(kg m^2)] and ``extra_inv_mass`` (E,). W_nn = H_n M^-1 H_n^T is applied from them by
    a compiled kernel (:meth:`product`), never formed."""

    body_i: np.ndarray
    body_j: np.ndarray
    g_i: np.ndarray
    g_j: np.ndarray
    extra_col: np.ndarray
    extra_coef: np.ndarray
    inv_mass: np.ndarray
    inv_inertia: np.ndarray
    extra_inv_mass: np.ndarray

    @classmethod
    def of(cls, contacts, bodies, walls, cell) -> NormalCoupling:
        """From the arrays of a step's kernels (:mod:`~grainlab.engine.nscd.sweep_arrays`:
        ``contacts`` ContactRows, ``bodies`` BodyRows, ``walls`` WallRows, ``cell`` CellRows
        or None), the normal rows of the H of
        :func:`~grainlab.engine.nscd.contact_problem.constraint_system`."""
        body_i = np.ascontiguousarray(contacts.body_i, dtype=np.int64)
        body_j = np.ascontiguousarray(contacts.body_j, dtype=np.int64)
        normal = np.asarray(contacts.frame, dtype=np.float64).reshape(-1, 3, 3)[:, 0]
        arm_i = np.asarray(contacts.arm_i, dtype=np.float64).reshape(-1, 3)
        arm_j = np.asarray(contacts.arm_j, dtype=np.float64).reshape(-1, 3)
        g_j = np.concatenate([normal, np.cross(arm_j, normal)], axis=1)
        g_i = -np.concatenate([normal, np.cross(arm_i, normal)], axis=1)
        g_i[body_i < 0] = 0.0
        wall_inv_mass = np.asarray(walls.inv_mass, dtype=np.float64).reshape(-1)
        mobile = np.flatnonzero(wall_inv_mass > 0.0)
        wall_column = np.full(wall_inv_mass.size, -1, dtype=np.int64)
        wall_column[mobile] = np.arange(mobile.size)
        if cell is None:
            basis, cell_inv_mass = np.zeros((0, 3, 3)), np.zeros(0)
        else:
            basis = np.asarray(cell.basis, dtype=np.float64).reshape(-1, 3, 3)
            cell_inv_mass = np.asarray(cell.inv_mass, dtype=np.float64).reshape(-1)
        free = np.flatnonzero(cell_inv_mass > 0.0)
        n_contacts = body_i.size
        extra_col = np.full((n_contacts, 1 + free.size), -1, dtype=np.int64)
        extra_coef = np.zeros((n_contacts, 1 + free.size))
        on_wall = np.flatnonzero(body_i < 0)
        if on_wall.size:
            wall = -1 - body_i[on_wall]
            extra_col[on_wall, 0] = wall_column[wall]
            wall_normals = np.asarray(walls.normals, dtype=np.float64).reshape(-1, 3)
            extra_coef[on_wall, 0] = -np.einsum("ci,ci->c", normal[on_wall],
                                                wall_normals[wall])
        images = np.asarray(contacts.images, dtype=np.float64).reshape(n_contacts, 3)
        crossing = np.flatnonzero(np.any(images != 0.0, axis=1))
        if crossing.size and free.size:  # an image moves with the cell's free dofs
            moved = np.einsum("dab,cb->cda", basis[free], images[crossing])
            extra_col[crossing, 1:] = mobile.size + np.arange(free.size)
            extra_coef[crossing, 1:] = np.einsum("ca,cda->cd", normal[crossing], moved)
        return cls(body_i, body_j, np.ascontiguousarray(g_i), np.ascontiguousarray(g_j),
                   extra_col, extra_coef,
                   np.ascontiguousarray(bodies.inv_mass, dtype=np.float64).reshape(-1),
                   np.ascontiguousarray(bodies.inv_inertia, dtype=np.float64)
                   .reshape(-1, 3, 3),
                   np.concatenate([wall_inv_mass[mobile], cell_inv_mass[free]]))

    def product(self, loaded: np.ndarray, x: np.ndarray) -> np.ndarray:
        """(W_nn x)_A for impulses x (|A|,) [N s] on the contacts ``loaded`` (A), zero on
        the others."""
        out = np.empty(loaded.size)
        _normal_product(loaded, x, self.body_i, self.body_j, self.g_i, self.g_j,
                        self.extra_col, self.extra_coef, self.inv_mass, self.inv_inertia,
                        self.extra_inv_mass, np.empty((self.inv_mass.size, 6)),
                        np.empty(self.extra_inv_mass.size), out)
        return out

    def diagonal(self, loaded: np.ndarray) -> np.ndarray:
        """W_nn,aa [1/kg] of the contacts ``loaded``."""
        out = np.empty(loaded.size)
        _normal_diagonal(loaded, self.body_i, self.body_j, self.g_i, self.g_j,
                         self.extra_col, self.extra_coef, self.inv_mass, self.inv_inertia,
                         self.extra_inv_mass, out)
        return out


def subspace_correction(coupling: NormalCoupling, normal: np.ndarray, velocity: np.ndarray,
                        iterations: int = CG_ITERATIONS) -> tuple[np.ndarray, float]:
    """The normal impulses ``normal`` (C,) [N s] of a step after one correction (module
    docstring), given their normal velocities ``velocity`` = W r + q (C,) [m/s] and the
    step's ``coupling``; and the change of J it made [J] (0, with ``normal`` returned
    unchanged, when no step lowered J). Every product is on the loaded contacts, where r
    and its change live."""
    loaded = np.flatnonzero(normal > 0.0)
    if loaded.size == 0:
        return normal, 0.0

    def delassus(change):
        out = np.zeros_like(change)
        out[loaded] = coupling.product(loaded, change[loaded])
        return out

    def restricted(subset):
        return (lambda x: coupling.product(subset, x)), coupling.diagonal(subset)

    return minimise_on_loaded(normal, velocity, delassus, restricted, iterations)


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
        energy = _dot(change, velocity) + 0.5 * _dot(change, delassus(change))
        if energy < 0.0:
            return normal + change, energy  # = max(0, r + t x)
        step *= 0.5
    return normal, 0.0


@njit(cache=True)
def _normal_product(loaded, x, body_i, body_j, g_i, g_j, extra_col, extra_coef, inv_mass,
                    inv_inertia, extra_inv_mass, acc, acc_extra, out):
    """out = (H_n M^-1 H_n^T x)_A: the impulses x on the contacts ``loaded`` gathered on the
    bodies and extra degrees of freedom, times M^-1, read back at the same contacts."""
    acc[:, :] = 0.0
    acc_extra[:] = 0.0
    for k in range(loaded.shape[0]):
        a = loaded[k]
        xa = x[k]
        j = body_j[a]
        for c in range(6):
            acc[j, c] += xa * g_j[a, c]
        i = body_i[a]
        if i >= 0:
            for c in range(6):
                acc[i, c] += xa * g_i[a, c]
        for e in range(extra_col.shape[1]):
            if extra_col[a, e] >= 0:
                acc_extra[extra_col[a, e]] += xa * extra_coef[a, e]
    for b in range(acc.shape[0]):
        m = inv_mass[b]
        t0, t1, t2 = acc[b, 3], acc[b, 4], acc[b, 5]
        acc[b, 0] *= m
        acc[b, 1] *= m
        acc[b, 2] *= m
        for r in range(3):
            acc[b, 3 + r] = inv_inertia[b, r, 0] * t0 + inv_inertia[b, r, 1] * t1 \
                + inv_inertia[b, r, 2] * t2
    for e in range(acc_extra.shape[0]):
        acc_extra[e] *= extra_inv_mass[e]
    for k in range(loaded.shape[0]):
        a = loaded[k]
        j = body_j[a]
        total = 0.0
        for c in range(6):
            total += g_j[a, c] * acc[j, c]
        i = body_i[a]
        if i >= 0:
            for c in range(6):
                total += g_i[a, c] * acc[i, c]
        for e in range(extra_col.shape[1]):
            if extra_col[a, e] >= 0:
                total += extra_coef[a, e] * acc_extra[extra_col[a, e]]
        out[k] = total


@njit(cache=True)
def _body_quadratic(g, b, inv_mass, inv_inertia):
    """g . M_b^-1 g for a row g (6,) of body b."""
    total = inv_mass[b] * (g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
    for r in range(3):
        for c in range(3):
            total += g[3 + r] * inv_inertia[b, r, c] * g[3 + c]
    return total


@njit(cache=True)
def _normal_diagonal(loaded, body_i, body_j, g_i, g_j, extra_col, extra_coef, inv_mass,
                     inv_inertia, extra_inv_mass, out):
    """out = W_nn,aa of the contacts ``loaded``."""
    for k in range(loaded.shape[0]):
        a = loaded[k]
        total = _body_quadratic(g_j[a], body_j[a], inv_mass, inv_inertia)
        if body_i[a] >= 0:
            total += _body_quadratic(g_i[a], body_i[a], inv_mass, inv_inertia)
        for e in range(extra_col.shape[1]):
            if extra_col[a, e] >= 0:
                total += extra_coef[a, e] ** 2 * extra_inv_mass[extra_col[a, e]]
        out[k] = total


@njit(cache=True)
def _dot(a, b):
    """a . b summed in order (not BLAS's ddot, whose sums differ between processors)."""
    total = 0.0
    for k in range(a.shape[0]):
        total += a[k] * b[k]
    return total


def _conjugate_gradients(product, inverse_diagonal: np.ndarray, rhs: np.ndarray,
                         iterations: int) -> np.ndarray:
    """x after ``iterations`` of conjugate gradients on product(x) = rhs from x = 0,
    preconditioned by ``inverse_diagonal``, its sums in order (:func:`_dot`); stops early
    when a search direction has no curvature left (the residual is zero, or the operator is
    singular along it)."""
    x = np.zeros_like(rhs)
    residual = rhs.copy()
    z = inverse_diagonal * residual
    direction = z.copy()
    rz = _dot(residual, z)
    for _ in range(iterations):
        image = product(direction)
        curvature = _dot(direction, image)
        if not curvature > 0.0 or not rz > 0.0:
            break
        alpha = rz / curvature
        x += alpha * direction
        residual -= alpha * image
        z = inverse_diagonal * residual
        rz_new = _dot(residual, z)
        direction = z + (rz_new / rz) * direction
        rz = rz_new
    return x


__all__ = ["CG_ITERATIONS", "SMALLEST_STEP", "SWEEPS_BETWEEN", "NormalCoupling",
           "minimise_on_loaded", "subspace_correction"]
