"""The frictional contact problem of one contact-dynamics step, as a plain problem
(research/cd_engines.md 6.2-6.3; Acary, Brémond & Huber 2018; the FCLib local problem).

With C contacts, each with a local frame (n, t, s), the step's unknowns are the local
impulses r = (r_n, r_t, r_s) per contact [N s] and the end-of-step relative velocities
u = (u_n, u_t, u_s) [m/s] (the normal one corrected by the gap, U_n + g*/h), linked by

    u = W r + q          W (3C, 3C) [1/kg] the Delassus operator H M^-1 H^T, q [m/s] the
                         free (r = 0) corrected relative velocity

and Coulomb's law at every contact a (the frictional contact problem, "FC3D" of Siconos)::

    r_a in K_a = {|r_T| <= mu_a r_n},   u'_a = u_a + mu_a |u_T| e_n in K_a*,   r_a . u'_a = 0

which holds exactly when the natural map vanishes:

    F_a(r) = r_a - proj_{K_a}(r_a - (u_a + mu_a |u_T,a| e_n)).

:func:`natural_map_error` is the error measure of Acary, Brémond & Huber (2018) and FCLib:
||F(r)|| / ||q|| (||F(r)|| alone when ||q|| is below machine epsilon). The contact-dynamics
step measures the same map with each block scaled by W_nn,a so that it has units of velocity
(:mod:`~grainlab.engine.nscd.contact_dynamics`); both vanish together.

:func:`assemble_problem` builds (W, q, mu) from the arrays of a step: bodies (translation and
rotation, world inverse inertia), mobile walls (one degree of freedom along their normal) and
the free degrees of freedom of a periodic cell, so that any step can be stored and any solver
compared on it (:mod:`~grainlab.engine.nscd.plain_problem_methods`). The wall and cell speed limits
(brakes) of the step are not part of this problem: a step whose brakes held is not the
stored problem's solution.

:func:`write_fclib` and :func:`read_fclib` store problems in FCLib's HDF5 layout (a
``/fclib_local`` group: ``spacedim``, the matrix ``W`` as ``nzmax, m, n, nz, p, i, x`` with
nz = -2 for compressed rows, -1 compressed columns, >= 0 triplets; ``vectors/q``,
``vectors/mu``; ``info/title, description, math_info``; an optional ``/solution`` with ``r``
and ``u``), so grainlab's problems can be solved elsewhere and FCLib's collection here.

>>> import numpy as np, scipy.sparse as sp
>>> problem = FrictionalContactProblem(sp.identity(3, format="csr"), [-1.0, 0.5, 0.0], [0.5])
>>> float(natural_map_error(problem, [1.0, -0.5, 0.0]))      # r = -q: sticking, u = 0
0.0
>>> round(float(natural_map_error(problem, [0.0, 0.0, 0.0])), 6)   # r = 0 but u_n < 0
0.8
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from grainlab.errors import InputError

_EPSILON = np.finfo(np.float64).eps


@dataclass(frozen=True, eq=False)
class FrictionalContactProblem:
    """u = W r + q with Coulomb's law at each contact (module docstring).

    Parameters
    ----------
    delassus:
        W (3C, 3C) [1/kg], symmetric positive semi-definite, any SciPy sparse or dense
        matrix (stored as CSR); rows and columns 3a, 3a + 1, 3a + 2 are contact a's
        (n, t, s).
    free_velocity:
        q (3C,) [m/s], the local relative velocities with r = 0 (normal: corrected by the gap).
    friction:
        mu (C,) >= 0, Coulomb's coefficient of each contact.
    """

    delassus: sp.csr_matrix
    free_velocity: np.ndarray
    friction: np.ndarray

    def __init__(self, delassus, free_velocity, friction) -> None:
        q = np.asarray(free_velocity, dtype=np.float64).ravel()
        mu = np.asarray(friction, dtype=np.float64).ravel()
        if q.size % 3:
            raise InputError("free_velocity", f"{q.size} entries",
                             "3 entries (n, t, s) per contact")
        n = q.size // 3
        if mu.size != n:
            raise InputError("friction", f"{mu.size} entries", f"one per contact ({n})")
        if not np.all(np.isfinite(q)):
            raise InputError("free_velocity", "a non-finite entry", "finite velocities in m/s")
        if not np.all(np.isfinite(mu)) or np.any(mu < 0.0):
            raise InputError("friction", float(mu[~(np.isfinite(mu) & (mu >= 0.0))][0]),
                             "finite coefficients >= 0")
        w = sp.csr_matrix(delassus, dtype=np.float64)
        if w.shape != (3 * n, 3 * n):
            raise InputError("delassus", f"shape {w.shape}",
                             f"a square matrix of shape ({3 * n}, {3 * n})")
        w.sum_duplicates()
        w.sort_indices()
        if not np.all(np.isfinite(w.data)):
            raise InputError("delassus", "a non-finite entry", "a finite matrix in 1/kg")
        diagonal = w.diagonal()
        if n and not np.all(diagonal[0::3] > 0.0):
            raise InputError("delassus", f"W_nn = {float(diagonal[0::3].min()):g}",
                             "a positive normal diagonal entry at every contact")
        object.__setattr__(self, "delassus", w)
        object.__setattr__(self, "free_velocity", q)
        object.__setattr__(self, "friction", mu)

    @property
    def n_contacts(self) -> int:
        """Number of contacts C."""
        return self.friction.size

    def velocity(self, reactions) -> np.ndarray:
        """u = W r + q (3C,) [m/s] for impulses r (3C,) [N s]."""
        return self.delassus @ _flat(reactions, self.n_contacts) + self.free_velocity


def natural_map_error(problem: FrictionalContactProblem, reactions,
                      velocities=None) -> float:
    """||F(r)|| / ||q|| (module docstring; Acary, Brémond & Huber 2018), the natural map F
    of Coulomb's law at r (3C,) [N s] with u = W r + q unless ``velocities`` (3C,) [m/s]
    are given; ||F(r)|| alone when ||q|| is below machine epsilon."""
    r = _flat(reactions, problem.n_contacts).reshape(-1, 3)
    u = (problem.velocity(r.ravel()) if velocities is None
         else _flat(velocities, problem.n_contacts)).reshape(-1, 3)
    mu = problem.friction
    slip = np.hypot(u[:, 1], u[:, 2])
    z = r - u
    z[:, 0] -= mu * slip
    projected = project_on_cones(z, mu)
    error = float(np.linalg.norm(r - projected))
    norm_q = float(np.linalg.norm(problem.free_velocity))
    return error / norm_q if norm_q > _EPSILON else error


def project_on_cones(z: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Projections (C, 3) of the local vectors z (C, 3) (n, t, s) on the Coulomb cones
    {|z_T| <= mu z_n} (NumPy twin of :func:`~grainlab.contact.coulomb_cone.project_cone`,
    STYLE.md 12)."""
    z = np.asarray(z, dtype=np.float64).reshape(-1, 3)
    mu = np.asarray(mu, dtype=np.float64)
    norm_t = np.hypot(z[:, 1], z[:, 2])
    out = np.zeros_like(z)
    inside = (z[:, 0] >= 0.0) & (norm_t <= mu * z[:, 0])
    out[inside] = z[inside]
    polar = ~inside & (mu * norm_t <= -z[:, 0])
    side = ~inside & ~polar
    a = (z[side, 0] + mu[side] * norm_t[side]) / (1.0 + mu[side] ** 2)
    out[side, 0] = a
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(norm_t[side] > 0.0, mu[side] * a / norm_t[side], 0.0)
    out[side, 1] = f * z[side, 1]
    out[side, 2] = f * z[side, 2]
    return out


@dataclass(frozen=True, eq=False)
class ConstraintSystem:
    """The parts of a step's plain problem before the Delassus product: ``constraints`` H
    (3C, n_dofs) (rows 3a .. 3a + 2: contact a's (n, t, s)), ``inverse_mass`` M^-1
    (n_dofs, n_dofs) [1/kg, 1/(kg m^2)] and ``free_velocity`` q (3C,) [m/s]
    (:func:`constraint_system`); W = H M^-1 H^T. ``centres`` (N, 3) [m]: the bodies'
    centres H's arms start from (the step's detection configuration), where given; the
    rigid motions of groups of bodies need them
    (:mod:`~grainlab.engine.nscd.rigid_clusters`)."""

    constraints: sp.csr_matrix
    inverse_mass: sp.csr_matrix
    free_velocity: np.ndarray
    centres: np.ndarray | None = None

    def problem(self, friction) -> FrictionalContactProblem:
        """The plain problem (W = H M^-1 H^T, q, ``friction`` mu (C,))."""
        h_matrix = self.constraints
        return FrictionalContactProblem((h_matrix @ self.inverse_mass @ h_matrix.T).tocsr(),
                                        self.free_velocity, friction)


def assemble_problem(contacts, bodies, walls, cell, dt) -> FrictionalContactProblem:
    """The plain problem (W, q, mu) of a contact-dynamics step (:func:`constraint_system`,
    then W = H M^-1 H^T)."""
    return constraint_system(contacts, bodies, walls, cell, dt).problem(contacts.mu)


def constraint_system(contacts, bodies, walls, cell, dt, centres=None) -> ConstraintSystem:
    """H, M^-1 and q of a contact-dynamics step, from the arrays its kernels
    take (:func:`~grainlab.engine.nscd.serial_sweep.nlgs_kernel`: the named tuples of
    :mod:`~grainlab.engine.nscd.sweep_arrays`, same names, units and conventions):
    ``contacts`` (:class:`ContactRows`, its ``gap`` the g* [m] of the law), ``bodies``
    (:class:`BodyRows`), ``walls`` (:class:`WallRows`, speed limits unused), ``cell``
    (:class:`CellRows`, bounds unused; None: no periodic cell), ``dt`` [s]; array-likes are
    accepted.

    W = H M^-1 H^T over the degrees of freedom: per body its velocity and angular velocity
    (M^-1: 1/m and the world inverse inertia), per mobile wall (``walls.inv_mass`` > 0) its
    normal speed, per free degree of freedom d of a periodic cell its value e_d
    (``cell.inv_mass[d]`` > 0). Rows of H for contact k (body j, minus body i): F_k (v -
    [r] w) for a body, -F_k n_w for a wall w on side i, F_k H_d m_k for cell dof d when body
    j is the image m_k. q = H v_free + F_k (hdot_fixed m_k) + g*_k / h e_n, with the free
    values of every degree of freedom. ``centres`` (N, 3) [m]: the bodies' centres the arms
    start from, kept in the result (:attr:`ConstraintSystem.centres`)."""
    body_i = np.asarray(contacts.body_i, dtype=np.int64)
    frame = np.asarray(contacts.frame, dtype=np.float64).reshape(-1, 3, 3)
    n_contacts = body_i.size
    n_bodies = np.asarray(bodies.inv_mass).size
    wall_inv_mass = np.asarray(walls.inv_mass, dtype=np.float64).reshape(-1)
    n_walls = wall_inv_mass.size
    wall_normals = np.asarray(walls.normals, dtype=np.float64).reshape(n_walls, 3)
    wall_free = np.asarray(walls.free_speeds, dtype=np.float64).reshape(n_walls)
    images = np.asarray(contacts.images, dtype=np.float64).reshape(n_contacts, 3)
    if cell is None:
        cell_fixed, cell_basis, cell_inv_mass = np.zeros((3, 3)), np.zeros((0, 3, 3)), \
            np.zeros(0)
        cell_free = np.zeros(0)
    else:
        cell_fixed = np.asarray(cell.fixed, dtype=np.float64).reshape(3, 3)
        cell_basis = np.asarray(cell.basis, dtype=np.float64).reshape(-1, 3, 3)
        n_cell = cell_basis.shape[0]
        cell_inv_mass = np.asarray(cell.inv_mass, dtype=np.float64).reshape(n_cell)
        cell_free = np.asarray(cell.free, dtype=np.float64).reshape(n_cell)
    mobile_walls = np.flatnonzero(wall_inv_mass > 0.0)
    free_cell = np.flatnonzero(cell_inv_mass > 0.0)
    wall_column = np.full(n_walls, -1, dtype=np.int64)
    wall_column[mobile_walls] = 6 * n_bodies + np.arange(mobile_walls.size)
    h_matrix = _constraint_matrix(
        contacts, frame, wall_normals, wall_column, images, cell_basis[free_cell],
        6 * n_bodies + mobile_walls.size + np.arange(free_cell.size),
        6 * n_bodies + mobile_walls.size + free_cell.size)

    inverse_mass = _inverse_mass(
        np.asarray(bodies.inv_mass, dtype=np.float64).reshape(n_bodies),
        np.asarray(bodies.inv_inertia, dtype=np.float64).reshape(n_bodies, 3, 3),
        np.concatenate([wall_inv_mass[mobile_walls], cell_inv_mass[free_cell]]))
    free = np.concatenate([
        np.concatenate([np.asarray(bodies.free_velocities, dtype=np.float64).reshape(n_bodies, 3),
                        np.asarray(bodies.free_spins, dtype=np.float64).reshape(n_bodies, 3)],
                       axis=1).ravel(),
        wall_free[mobile_walls], cell_free[free_cell]])
    q = (h_matrix @ free).reshape(n_contacts, 3)
    on_wall = np.flatnonzero(body_i < 0)  # none in a periodic cell (no walls at all)
    fixed_walls = on_wall[wall_column[-1 - body_i[on_wall]] < 0]
    if fixed_walls.size:  # a driven wall moves at its prescribed speed
        wall = -1 - body_i[fixed_walls]
        q[fixed_walls] -= wall_free[wall][:, None] * np.einsum(
            "cij,cj->ci", frame[fixed_walls], wall_normals[wall])
    crossing = np.flatnonzero(np.any(images != 0.0, axis=1))
    if crossing.size:  # images move with the cell's prescribed rate and its fixed dofs
        rate = cell_fixed.copy()
        for d in range(cell_basis.shape[0]):
            if cell_inv_mass[d] <= 0.0:
                rate += cell_free[d] * cell_basis[d]
        q[crossing] += np.einsum("cij,cj->ci", frame[crossing], images[crossing] @ rate.T)
    q[:, 0] += np.asarray(contacts.gap, dtype=np.float64).reshape(n_contacts) / float(dt)
    return ConstraintSystem(h_matrix, inverse_mass, q.ravel(),
                            None if centres is None else
                            np.array(centres, dtype=np.float64).reshape(n_bodies, 3))


def _inverse_mass(inv_mass: np.ndarray, inv_inertia: np.ndarray,
                  extra: np.ndarray) -> sp.csr_matrix:
    """M^-1 over the degrees of freedom: per body 1/m three times, then its world inverse
    inertia (3 x 3); then the ``extra`` (walls', cell's) inverse masses on the diagonal."""
    n_bodies = inv_mass.size
    base = 6 * np.arange(n_bodies)
    rows = [base[:, None] + np.arange(3)[None, :],
            np.broadcast_to((base[:, None] + 3 + np.arange(3)[None, :])[:, :, None],
                            (n_bodies, 3, 3))]
    cols = [rows[0], np.broadcast_to((base[:, None] + 3 + np.arange(3)[None, :])[:, None, :],
                                     (n_bodies, 3, 3))]
    vals = [np.repeat(inv_mass[:, None], 3, axis=1), inv_inertia]
    n_dofs = 6 * n_bodies + extra.size
    rows.append(6 * n_bodies + np.arange(extra.size))
    cols.append(rows[-1])
    vals.append(extra)
    return sp.csr_matrix((np.concatenate([v.ravel() for v in vals]),
                          (np.concatenate([r.ravel() for r in rows]),
                           np.concatenate([c.ravel() for c in cols]))),
                         shape=(n_dofs, n_dofs))


def _constraint_matrix(contacts, frame, wall_normals, wall_column, images, free_basis,
                       cell_column, n_dofs) -> sp.csr_matrix:
    """H (3C, n_dofs) of :func:`assemble_problem`: per contact, its bodies' columns (6 per
    body), its mobile wall's column (``wall_column[w]`` >= 0) and, for an image, the columns
    ``cell_column`` of the cell's free degrees of freedom (directions ``free_basis``)."""
    body_i = np.asarray(contacts.body_i, dtype=np.int64)
    body_j = np.asarray(contacts.body_j, dtype=np.int64)
    n_contacts = body_i.size
    rows, cols, vals = [], [], []
    local_rows = 3 * np.arange(n_contacts)[:, None] + np.arange(3)[None, :]  # (C, 3)

    def add(mask, columns, blocks):
        """blocks (c, 3, m) of H at contacts ``mask`` and columns (c, m)."""
        r = np.broadcast_to(local_rows[mask][:, :, None], blocks.shape)
        c = np.broadcast_to(columns[:, None, :], blocks.shape)
        rows.append(r.ravel())
        cols.append(c.ravel())
        vals.append(blocks.ravel())

    for body, arm, sign in ((body_j, np.asarray(contacts.arm_j, dtype=np.float64), 1.0),
                            (body_i, np.asarray(contacts.arm_i, dtype=np.float64), -1.0)):
        inner = body >= 0
        if np.any(inner):
            f = frame[inner]
            r = arm.reshape(-1, 3)[inner]
            skew = np.zeros((r.shape[0], 3, 3))
            skew[:, 0, 1], skew[:, 0, 2] = -r[:, 2], r[:, 1]
            skew[:, 1, 0], skew[:, 1, 2] = r[:, 2], -r[:, 0]
            skew[:, 2, 0], skew[:, 2, 1] = -r[:, 1], r[:, 0]
            block = sign * np.concatenate([f, -f @ skew], axis=2)  # (c, 3, 6)
            columns = 6 * body[inner][:, None] + np.arange(6)[None, :]
            add(inner, columns, block)
        on_wall = body < 0
        if np.any(on_wall):
            wall = -1 - body[on_wall]
            mobile = wall_column[wall] >= 0
            if np.any(mobile):
                mask = np.flatnonzero(on_wall)[mobile]
                block = sign * np.einsum("cij,cj->ci", frame[mask],
                                         wall_normals[wall[mobile]])[:, :, None]
                add(mask, wall_column[wall[mobile]][:, None], block)
    crossing = np.flatnonzero(np.any(images != 0.0, axis=1))
    if crossing.size and free_basis.shape[0]:
        g = np.einsum("dab,cb->cda", free_basis, images[crossing])  # (c, D, 3)
        block = np.einsum("cij,cdj->cid", frame[crossing], g)
        add(crossing, np.broadcast_to(cell_column, (crossing.size, free_basis.shape[0])), block)
    return sp.csr_matrix(
        (np.concatenate(vals) if vals else np.zeros(0),
         (np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64),
          np.concatenate(cols) if cols else np.zeros(0, dtype=np.int64))),
        shape=(3 * n_contacts, n_dofs))


# --------------------------------------------------------------------------------------------
# FCLib files
# --------------------------------------------------------------------------------------------


def write_fclib(problem: FrictionalContactProblem, path: str | Path, *, title: str = "",
                description: str = "", reactions=None, velocities=None) -> Path:
    """Store ``problem`` (and a solution r, u (3C,) when given) as an FCLib local problem
    (module docstring; W in compressed rows, nz = -2)."""
    import h5py

    path = Path(path)
    w = problem.delassus
    with h5py.File(path, "w") as f:
        group = f.create_group("fclib_local")
        group.create_dataset("spacedim", data=np.array([3], dtype=np.int32))
        matrix = group.create_group("W")
        for name, value in (("nzmax", w.nnz), ("m", w.shape[0]), ("n", w.shape[1]),
                            ("nz", -2)):
            matrix.create_dataset(name, data=np.array([value], dtype=np.int32))
        matrix.create_dataset("p", data=w.indptr.astype(np.int32))
        matrix.create_dataset("i", data=w.indices.astype(np.int32))
        matrix.create_dataset("x", data=w.data)
        vectors = group.create_group("vectors")
        vectors.create_dataset("q", data=problem.free_velocity)
        vectors.create_dataset("mu", data=problem.friction)
        info = group.create_group("info")
        info.create_dataset("title", data=title or "grainlab contact-dynamics step")
        info.create_dataset("description", data=description or
                            "local frictional contact problem u = W r + q, frames (n, t, s)")
        info.create_dataset("math_info", data="FC3D, natural-map error / ||q||")
        if reactions is not None:
            solution = f.create_group("solution")
            r = _flat(reactions, problem.n_contacts)
            solution.create_dataset("r", data=r)
            solution.create_dataset(
                "u", data=problem.velocity(r) if velocities is None
                else _flat(velocities, problem.n_contacts))
    return path


@dataclass(frozen=True, eq=False)
class StoredProblem:
    """A problem read by :func:`read_fclib`, with its stored solution (r, u) (None if the
    file has none) and its title."""

    problem: FrictionalContactProblem
    reactions: np.ndarray | None
    velocities: np.ndarray | None
    title: str


def read_fclib(path: str | Path) -> StoredProblem:
    """Read an FCLib local problem (module docstring: triplet, CSC or CSR W; 3D only)."""
    import h5py

    path = Path(path)
    if not path.is_file():
        raise InputError("fclib file", str(path), "an existing FCLib HDF5 file")
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise InputError("fclib file", str(path), f"an HDF5 file ({err})") from None
    with f:
        if "fclib_local" not in f:
            raise InputError("fclib file", str(path),
                             "a file with a /fclib_local group (FCLib's global problems "
                             "are not read)")
        group = f["fclib_local"]
        spacedim = int(np.asarray(group["spacedim"]).ravel()[0])
        if spacedim != 3:
            raise InputError("fclib_local/spacedim", spacedim, "3 (three-dimensional contacts)")
        w = _read_matrix(group["W"])
        q = np.asarray(group["vectors/q"], dtype=np.float64)
        mu = np.asarray(group["vectors/mu"], dtype=np.float64)
        title = ""
        if "info" in group and "title" in group["info"]:
            raw = group["info/title"][()]
            title = raw.decode() if isinstance(raw, bytes) else str(raw)
        reactions = velocities = None
        if "solution" in f and "r" in f["solution"]:
            reactions = np.asarray(f["solution/r"], dtype=np.float64)
            if "u" in f["solution"]:
                velocities = np.asarray(f["solution/u"], dtype=np.float64)
    return StoredProblem(FrictionalContactProblem(w, q, mu), reactions, velocities, title)


def _read_matrix(group) -> sp.csr_matrix:
    """An FCLib sparse matrix (triplet nz >= 0, CSC nz = -1, CSR nz = -2)."""

    def scalar(name):
        return int(np.asarray(group[name]).ravel()[0])

    m, n, nz = scalar("m"), scalar("n"), scalar("nz")
    p = np.asarray(group["p"], dtype=np.int64)
    i = np.asarray(group["i"], dtype=np.int64)
    x = np.asarray(group["x"], dtype=np.float64)
    if nz >= 0:  # triplets: row i, column p
        return sp.csr_matrix((x[:nz], (i[:nz], p[:nz])), shape=(m, n))
    if nz == -1:
        return sp.csc_matrix((x[:p[-1]], i[:p[-1]], p), shape=(m, n)).tocsr()
    if nz == -2:
        return sp.csr_matrix((x[:p[-1]], i[:p[-1]], p), shape=(m, n))
    raise InputError("fclib_local/W/nz", nz, "-2 (CSR), -1 (CSC) or >= 0 (triplets)")


def _flat(values, n_contacts: int) -> np.ndarray:
    """values as a flat (3C,) float array, checked."""
    flat = np.asarray(values, dtype=np.float64).ravel()
    if flat.size != 3 * n_contacts:
        raise InputError("reactions", f"{flat.size} entries", f"3 per contact ({3 * n_contacts})")
    return flat


def problem_scale(problem: FrictionalContactProblem) -> float:
    """||q|| [m/s], the scale of :func:`natural_map_error` (1 when below machine epsilon)."""
    norm = float(np.linalg.norm(problem.free_velocity))
    return norm if norm > _EPSILON else 1.0


__all__ = ["ConstraintSystem", "FrictionalContactProblem", "StoredProblem", "assemble_problem",
           "constraint_system",
           "natural_map_error", "problem_scale", "project_on_cones", "read_fclib",
           "write_fclib"]
