"""A two-level correction of a step's frictional contact problem on the rigid motions of
groups of bodies (a coarse space of rigid clusters), measured against NLGS alone
(docs/explanations/contact-problem.md, "Rigid clusters as a coarse level").

The bodies are split into groups (:func:`grid_clusters`: cubes of a given side;
:func:`sticking_clusters`: bodies joined along sticking contacts, up to a given count). A
group moving as one rigid body, v_i = V_g + Omega_g x (x_i - X_g), omega_i = Omega_g (the
prolongation P, :func:`rigid_prolongation`), leaves the relative velocity at every contact
inside the group unchanged (H_I P = 0); only the contacts between groups (and with the
walls), the external ones E, see it. The coarse problem is the step's problem on the groups
as rigid bodies::

    u_E' = u_E + W_c (r_E' - r_E),    W_c = H_E P (P^T M P)^-1 P^T H_E^T

with Coulomb's law at every external contact, solved by NLGS from the current impulses (a
coarse sweep costs W_c's 3 x 3 blocks over W's in sweeps). Its impulses are unique only up
to the coarse self-stresses (ker P^T H_E^T, far larger than the step's own: a group cannot
deform), so the change is replaced by the part of it that moves the groups
(``project``: its projection on the range of H_E P, least squares by LSQR), and the internal
impulses that would keep each group rigid under it are added (``internal``: least squares
H_I^T dr_I = M P dV - H_E^T dr_E, LSQR). NLGS sweeps on the whole problem then smooth.

The error is the natural-map error ||F(r)|| / ||q|| (Acary, Brémond & Huber 2018;
:func:`~grainlab.engine.nscd.contact_problem.natural_map_error`). On the shear steps of the
1000-sphere triaxial test the correction does not lower the error reached for the same
work (``benchmarks/benchmark_rigid_cluster_correction.py``): NLGS's slow mode is a drift of
the impulses along self-stresses of the sticking network (W d ~ 0), which no rigid motion
of a group represents. It stays an experiment; the engine's step does not use it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import lsqr

from grainlab.engine.nscd.contact_problem import (
    ConstraintSystem,
    FrictionalContactProblem,
    natural_map_error,
)
from grainlab.engine.nscd.plain_problem_methods import solve
from grainlab.errors import InputError

STICKING_MARGIN = 0.98
"""A closed contact sticks when |r_T| < STICKING_MARGIN mu r_n (:func:`sticking_clusters`)."""
LSQR_ITERATIONS = 300
"""LSQR iterations of the projection and of the internal impulses."""


def grid_clusters(centres: np.ndarray, side: float) -> np.ndarray:
    """Group label (N,) of each body: the cube of side ``side`` [m] its centre (N, 3) [m]
    falls in, labels 0 .. G - 1."""
    x = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
    if not side > 0.0:
        raise InputError("side", side, "a positive length in m")
    cell = np.floor((x - x.min(axis=0)) / side).astype(np.int64)
    return np.unique(cell, axis=0, return_inverse=True)[1].ravel()


def sticking_clusters(body_i, body_j, impulses, friction, n_bodies: int,
                      largest: int) -> np.ndarray:
    """Group label (N,) of each body: bodies joined along sticking contacts (r_n > 0,
    |r_T| < :data:`STICKING_MARGIN` mu r_n; impulses (C, 3) local [N s]), grown breadth
    first from the lowest unlabelled body, the most loaded contact first, up to ``largest``
    bodies per group. Labels depend on the numbering only through the order of growth."""
    bi = np.asarray(body_i, dtype=np.int64)
    bj = np.asarray(body_j, dtype=np.int64)
    r = np.asarray(impulses, dtype=np.float64).reshape(-1, 3)
    mu = np.asarray(friction, dtype=np.float64)
    tangential = np.hypot(r[:, 1], r[:, 2])
    stick = np.flatnonzero((bi >= 0) & (r[:, 0] > 0.0)
                           & (tangential < STICKING_MARGIN * mu * r[:, 0]))
    neighbours: list[list[int]] = [[] for _ in range(n_bodies)]
    for a in stick[np.argsort(-r[stick, 0], kind="stable")]:
        neighbours[bi[a]].append(bj[a])
        neighbours[bj[a]].append(bi[a])
    label = np.full(n_bodies, -1, dtype=np.int64)
    groups = 0
    for seed in range(n_bodies):
        if label[seed] >= 0:
            continue
        label[seed] = groups
        members, front = 1, [seed]
        while front and members < largest:
            body = front.pop(0)
            for other in neighbours[body]:
                if label[other] < 0 and members < largest:
                    label[other] = groups
                    members += 1
                    front.append(other)
        groups += 1
    return label


def rigid_prolongation(centres: np.ndarray, labels: np.ndarray, masses: np.ndarray,
                       n_dofs: int) -> sp.csr_matrix:
    """P (n_dofs, 6 G + E): group g's velocity and spin (V_g, Omega_g) about its centre of
    mass X_g to its bodies' v_i = V_g - [x_i - X_g]x Omega_g, omega_i = Omega_g; the E extra
    degrees of freedom (walls, cell) after the 6 N of the bodies map to themselves."""
    x = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
    n_bodies = x.shape[0]
    groups = int(labels.max()) + 1 if n_bodies else 0
    centre = np.zeros((groups, 3))
    np.add.at(centre, labels, masses[:, None] * x)
    centre /= np.bincount(labels, masses, groups)[:, None]
    arm = x - centre[labels]
    body_rows, group_cols = 6 * np.arange(n_bodies), 6 * labels
    rows, cols, vals = [], [], []
    for i in range(3):
        for offset in (0, 3):
            rows.append(body_rows + offset + i)
            cols.append(group_cols + offset + i)
            vals.append(np.ones(n_bodies))
    minus_skew = {(0, 1): arm[:, 2], (0, 2): -arm[:, 1], (1, 0): -arm[:, 2],
                  (1, 2): arm[:, 0], (2, 0): arm[:, 1], (2, 1): -arm[:, 0]}
    for (i, j), value in minus_skew.items():
        rows.append(body_rows + i)
        cols.append(group_cols + 3 + j)
        vals.append(value)
    extra = n_dofs - 6 * n_bodies
    rows.append(6 * n_bodies + np.arange(extra))
    cols.append(6 * groups + np.arange(extra))
    vals.append(np.ones(extra))
    p = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n_dofs, 6 * groups + extra))
    p.eliminate_zeros()  # a body at its group's centre (a group of one) has no arm
    return p


@dataclass(frozen=True, eq=False)
class ClusterSpace:
    """The coarse level of one grouping (module docstring): ``labels`` (N,), ``external`` and
    ``internal`` contact indices, P, M, (P^T M P)^-1, H_E P and W_c; ``work_ratio``: the
    3 x 3 blocks of W_c over those of W, a coarse sweep's cost in sweeps of the whole
    problem."""

    labels: np.ndarray
    external: np.ndarray
    internal: np.ndarray
    prolongation: sp.csr_matrix
    mass: sp.csr_matrix
    coarse_inverse_mass: sp.csr_matrix
    external_rigid: sp.csr_matrix
    coarse_delassus: sp.csr_matrix
    work_ratio: float

    @classmethod
    def of(cls, system: ConstraintSystem, problem: FrictionalContactProblem,
           labels) -> ClusterSpace:
        if system.centres is None:
            raise InputError("system.centres", None, "the bodies' centres (N, 3) in m")
        n_bodies = system.centres.shape[0]
        labels = np.asarray(labels, dtype=np.int64).ravel()
        if labels.size != n_bodies or (n_bodies and labels.min() < 0):
            raise InputError("labels", f"{labels.size} labels", f"{n_bodies} labels >= 0")
        inverse = system.inverse_mass.tocsr()
        blocks = [np.linalg.inv(inverse[6 * b:6 * b + 6, 6 * b:6 * b + 6].toarray())
                  for b in range(n_bodies)]
        extra = inverse.diagonal()[6 * n_bodies:]
        mass = sp.block_diag(blocks + ([sp.diags(1.0 / extra)] if extra.size else []),
                             format="csr")
        masses = 1.0 / inverse.diagonal()[0:6 * n_bodies:6]
        p = rigid_prolongation(system.centres, labels, masses, inverse.shape[0])
        coarse = (p.T @ mass @ p).tocsr()
        groups = int(labels.max()) + 1 if n_bodies else 0
        coarse_extra = coarse.diagonal()[6 * groups:]
        coarse_inverse = sp.block_diag(
            [np.linalg.inv(coarse[6 * g:6 * g + 6, 6 * g:6 * g + 6].toarray())
             for g in range(groups)] + ([sp.diags(1.0 / coarse_extra)] if coarse_extra.size
                                        else []), format="csr")
        h_matrix = system.constraints.tocsr()
        # internal: a contact between two bodies of one group, with no wall or cell column
        touched = h_matrix[0::3].tocsr()
        internal_mask = np.zeros(problem.n_contacts, dtype=bool)
        for a in range(problem.n_contacts):
            columns = touched.indices[touched.indptr[a]:touched.indptr[a + 1]]
            bodies = np.unique(columns // 6)
            internal_mask[a] = columns.max(initial=-1) < 6 * n_bodies and bodies.size == 2 \
                and labels[bodies[0]] == labels[bodies[1]]
        external = np.flatnonzero(~internal_mask)
        rows = (3 * external[:, None] + np.arange(3)).ravel()
        external_rigid = (h_matrix[rows] @ p).tocsr()
        coarse_delassus = (external_rigid @ coarse_inverse @ external_rigid.T).tocsr()
        coarse_delassus.eliminate_zeros()
        return cls(labels, external, np.flatnonzero(internal_mask), p, mass, coarse_inverse,
                   external_rigid, coarse_delassus,
                   _blocks(coarse_delassus) / max(1, _blocks(problem.delassus)))

    def correct(self, system: ConstraintSystem, problem: FrictionalContactProblem,
                reactions: np.ndarray, coarse_sweeps: int, *, project: bool = True,
                internal: bool = True) -> tuple[np.ndarray, float]:
        """One coarse correction of ``reactions`` (3C,) [N s] (module docstring): the new
        impulses and the work it took [sweep-equivalents]."""
        r = np.array(reactions, dtype=np.float64).ravel()
        rows = (3 * self.external[:, None] + np.arange(3)).ravel()
        u = problem.velocity(r)
        before = r[rows]
        coarse = FrictionalContactProblem(self.coarse_delassus,
                                          u[rows] - self.coarse_delassus @ before,
                                          problem.friction[self.external])
        solved = solve(coarse, "nlgs", tolerance=1e-12, max_iterations=coarse_sweeps,
                       reactions=before)
        change = solved.reactions - before
        if project:
            change = self.external_rigid @ lsqr(self.external_rigid, change, atol=1e-12,
                                                btol=1e-12, iter_lim=LSQR_ITERATIONS)[0]
        r[rows] = before + change
        if internal and self.internal.size:
            spins = self.coarse_inverse_mass @ (self.external_rigid.T @ change)
            full = np.zeros_like(r)
            full[rows] = change
            wanted = self.mass @ (self.prolongation @ spins) - system.constraints.T @ full
            inside = (3 * self.internal[:, None] + np.arange(3)).ravel()
            r[inside] += lsqr(system.constraints[inside].T, wanted, atol=1e-12, btol=1e-12,
                              iter_lim=LSQR_ITERATIONS)[0]
        return r, solved.iterations * self.work_ratio


def _blocks(matrix: sp.spmatrix) -> int:
    """The 3 x 3 blocks of a contact matrix with a stored entry (what a sweep reads)."""
    coo = matrix.tocoo()
    return int(np.unique((coo.row // 3) * (matrix.shape[1] // 3 + 1) + coo.col // 3).size)


@dataclass(frozen=True, eq=False)
class TwoLevelHistory:
    """Error ||F(r)|| / ||q|| after each cycle (``errors``) against the work done so far
    (``work``, sweep-equivalents: smoothing sweeps plus coarse sweeps times their ratio),
    the smoothing sweeps alone so far (``smoothing``); the final ``reactions`` (3C,) [N s]."""

    work: np.ndarray
    errors: np.ndarray
    smoothing: np.ndarray
    reactions: np.ndarray


def two_level_solve(system: ConstraintSystem, problem: FrictionalContactProblem, labels, *,
                    reactions=None, work_limit: float = 1000.0, coarse_sweeps: int = 20,
                    smoothing_sweeps: int = 20, project: bool = True,
                    internal: bool = True) -> TwoLevelHistory:
    """Cycles of one coarse correction and ``smoothing_sweeps`` NLGS sweeps from
    ``reactions`` (default zero) until ``work_limit`` sweep-equivalents are spent."""
    space = ClusterSpace.of(system, problem, labels)
    r = np.zeros(3 * problem.n_contacts) if reactions is None else \
        np.array(reactions, dtype=np.float64).ravel()
    work, errors, done, smoothing = [], [], 0.0, []
    while done < work_limit:
        r, spent = space.correct(system, problem, r, coarse_sweeps, project=project,
                                 internal=internal)
        r = solve(problem, "nlgs", tolerance=1e-14, max_iterations=smoothing_sweeps,
                  reactions=r).reactions
        done += spent + smoothing_sweeps
        work.append(done)
        smoothing.append(smoothing_sweeps * (len(smoothing) + 1))
        errors.append(natural_map_error(problem, r))
    return TwoLevelHistory(np.array(work), np.array(errors), np.array(smoothing), r)


__all__ = ["ClusterSpace", "TwoLevelHistory", "grid_clusters", "rigid_prolongation",
           "sticking_clusters", "two_level_solve"]
