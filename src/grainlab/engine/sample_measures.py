"""What a discrete sample in a wall box measures after a step (seed 002 eqs. 2-3, 5-11,
13-14; seed 003 eq. 13).

Stress from contacts: the volume average of the particles' stresses, every contact counted
on the particles it touches (walls included)::

    sigma = (1/V) [ sum_pairs l (x) f  +  sum_walls (x_j - p) (x) f ]        [Pa]

symmetrised, compression positive, with f the force [N] that side i (a particle or a wall)
exerts on particle j at the point p, l = x_j - x_i the branch vector and V the box volume.
In static equilibrium it equals the stress from the wall reactions exactly (the internal
contacts cancel pairwise, the rest is the walls' forces times their positions), so the two
agree only when the sample is quasi-static; both are recorded.

Invariants (:mod:`grainlab.result.invariants`, the columns of every specimen):
sigma_1 >= sigma_2 >= sigma_3 principal stresses, p = (sigma_1 + sigma_2 + sigma_3)/3,
q = sigma_1 - sigma_3, the seeds' q as q_over_3 = (sigma_1 - sigma_3)/3 (seed 002 eq. 5) and
their q/p as q_over_trace = q_over_3 / p, sin_phi = (sigma_1 - sigma_3)/(sigma_1 + sigma_3)
(seed 002 eq. 11 when sigma_2 = sigma_3); logarithmic strains eps_a = ln(L0_a / L_a)
(compression positive, eq. 8), eps_vol = sum eps_a (eq. 9), eps_q = eps_1 - eps_3 (eq. 10)
with eps_1 >= eps_3 the largest and smallest of the
three. Mechanical coordination z_m = 2 (C_pp + C_pw) / N_m: force-carrying contacts between
particles (C_pp) and with walls (C_pw), over the N_m particles left after removing rattlers
(fewer than d + 1 such contacts for frictionless particles, 4 in 3D and 3 in 2D; fewer than
2 with friction), repeatedly. A wall contact is one constraint on its particle like a particle
contact, so it counts twice, as the wall were a particle: the isostatic count of rigid
frictionless spheres (3 translations each) is C_pp + C_pw = 3 N_m (+ one per stress-controlled
wall), i.e. z_m = 6. Counting the wall contacts once, (2 C_pp + C_pw) / N_m, gives
6 - C_pw / N_m, ~5.3-5.5 in a box of 10 diameters.
Inertia number I = max_a |d eps_a/dt| <d> sqrt(rho / p) with the walls' strain rates.

A 2D sample (discs, :mod:`grainlab.engine.planar`) measures in its plane: the columns of the
in-plane stress and strain, sigma_xx, sigma_yy, sigma_xy, eps_xx, eps_yy (gamma_xy in a
cell), with the 2D invariants of :mod:`grainlab.result.invariants` (p = (sigma_1 +
sigma_3)/2; the stresses are those of discs of the sample's thickness), and its core is
the particles at least <d> from the four side walls.

The contact network (analysis layer) keeps the particle-particle contacts that carry a force
(P_n > 0; the solver also sees open contacts within the alert distance): pairs grouped
by particle pair, forces from the impulses (f = P / h) and sliding flags
(|f_t| >= mu f_n (1 - 1e-6)). Its pairs are typed by the pair typing of the shape kinds
present (:attr:`~grainlab.engine.shape_kinds.ShapeKind.pair_typing`): the polyhedron pair
types below, else the aggregate pair classes of seed 003 Fig. 8, else not at all (spheres).
In a wall box the network also carries the loaded wall contact points (particle, point,
normal from the wall into the particle, force of the wall on it) and the box's corners, which
the analysis of the stress, the rattlers and the core reads.

Polyhedra (seed 002 §II.B): the several points of a polyhedron pair are solved as
independent contacts, but "the net resultant of the calculated forces is attributed to the
contact with its application point located on the contact plane". In the network each pair
that involves a polyhedron is ONE interaction with ONE point (:func:`pair_resultants`):

    F = sum_k f_k,    c = sum_k f_n,k p_k / sum_k f_n,k,    n = (sum_k n_k) / |sum_k n_k|

over its loaded points k (f_n,k = f_k . n_k > 0), so c, a convex combination of points on
the contact plane, lies on it; its type is the pair's fv / ee / fe / ff
(``Contacts.contact_type``; :data:`PAIR_TYPE_NAMES`). Then z counts particle pairs and the
connectivity number is seed 002 eq. 14 (eq. 13 with k_fv + k_ee + k_fe + k_ff = 1),

    z_c = z (k_fv + k_ee + 2 k_fe + 3 k_ff) = z (1 + k_fe + 2 k_ff),

i.e. 2 sum_pairs m_type / N with the nominal points m = 1, 1, 2, 3 of each type (the same
over the pairs between non-rattlers for z_c_no_rattlers; ``z_core``, ``z_c_core`` over the
particles at least <d> from every wall, :func:`core_connectivity`). The row also holds
``fraction_fv`` ... ``fraction_ff`` (k_type among loaded pairs) and ``z_c_points`` =
2 (loaded solver points between particles) / N, the constraints the solver actually used.
Spheres and aggregates are unchanged (one network point per member contact).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grainlab.analysis.connectivity import Connectivity
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.convergence import convergence_columns
from grainlab.engine.detect.narrow_phase import (
    CONTACT_CLASS_NAMES,
    Contacts,
    classify_aggregate_pairs,
)
from grainlab.engine.shape_kinds import FEATURE_TYPES, MEMBER_CLASSES, kinds_present
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import StepReport
from grainlab.result.invariants import strain_invariants, stress_invariants

_SLIDING = 1e-6

PAIR_TYPE_NAMES = ("point", "fv", "ee", "fe", "ff")
"""Names of the pair types of a network with polyhedra, indexed by ``Contacts.contact_type``:
"point" (0, a pair of sphere-based bodies), "fv", "ee", "fe", "ff" (seed 002; the codes of
``grainlab.engine.detect.narrow_phase.POLYHEDRON_CONTACT_TYPE_NAMES``)."""
NOMINAL_POINTS = np.array([1, 1, 1, 2, 3], dtype=np.int64)
"""Points each pair type stands for in seed 002 eqs. 13-14 (point, fv, ee, fe, ff)."""
POLYHEDRON_TYPES = PAIR_TYPE_NAMES[1:]
"""The polyhedron contact types with a ``fraction_<type>`` column in the results."""


def world_forces(report: StepReport, dt: float) -> np.ndarray:
    """(C, 3) forces [N] side i exerts on body j over the step: frames^T P / h."""
    return np.einsum("cji,cj->ci", report.frames, report.impulses) / dt


def log_strains(initial_lengths, lengths) -> np.ndarray:
    """(3,) logarithmic strains ln(L0 / L) [-], compression positive, of lengths (3,) [m]
    from ``initial_lengths`` (3,) [m], with the C library's logarithm (NumPy's, vectorised
    by processor, differs in the last bits from one processor to the next: stage ends are
    decided on these strains)."""
    ratio = np.asarray(initial_lengths, dtype=np.float64) / np.asarray(lengths,
                                                                    dtype=np.float64)
    return np.array([math.log(value) for value in ratio.ravel()]).reshape(ratio.shape)


NORMAL_LABELS = ("xx", "yy", "zz")
"""The normal components' labels, by axis."""
COMPONENTS = {3: (("xx", (0, 0)), ("yy", (1, 1)), ("zz", (2, 2)), ("yz", (1, 2)),
                  ("xz", (0, 2)), ("xy", (0, 1))),
              2: (("xx", (0, 0)), ("yy", (1, 1)), ("xy", (0, 1)))}
"""The columns' labels and tensor indices of each dimension's components (Voigt order)."""


def box_strains(initial_lengths: np.ndarray, lengths: np.ndarray, dimension: int = 3
                ) -> dict[str, float]:
    """The strain columns of a box of ``lengths`` (3,) [m] from ``initial_lengths`` (3,) [m]
    (module docstring): logarithmic eps_xx, eps_yy, eps_zz (not in 2D), eps_vol and eps_q
    [-], known from the walls alone (stage ends are checked on them after every step)."""
    strains = log_strains(initial_lengths, lengths)[:dimension]
    row = {f"eps_{label}": float(value)
           for label, value in zip(NORMAL_LABELS, strains, strict=False)}
    row.update(strain_invariants(np.diag(strains)))
    return row


def contact_stress(report: StepReport, state: BodyState, volume: float,
                   dt: float) -> np.ndarray:
    """(3, 3) stress from contacts [Pa] (module docstring)."""
    contacts = report.contacts
    if contacts.n_contacts == 0:
        return np.zeros((3, 3))
    f = world_forces(report, dt)
    x = state.positions
    inner = contacts.body_i >= 0
    arm = np.empty_like(f)
    arm[inner] = x[contacts.body_j[inner]] - x[contacts.body_i[inner]]
    arm[~inner] = x[contacts.body_j[~inner]] - contacts.point[~inner]
    moment = np.einsum("ci,cj->ij", arm, f) / volume
    return 0.5 * (moment + moment.T)


def pair_resultants(body_i: np.ndarray, body_j: np.ndarray, points: np.ndarray,
                    normals: np.ndarray, forces: np.ndarray, n_bodies: int):
    """One interaction per body pair from its contact points (module docstring).

    Parameters: ``body_i``, ``body_j`` (C,) int body ids (i < j not required, each pair
    always in the same order), ``points`` (C, 3) [m], ``normals`` (C, 3) unit, from i to j,
    ``forces`` (C, 3) [N] on j from i; ``n_bodies`` N. Pairs whose points carry no normal
    force get the plain mean of their points as centre. A wall w (body_i = -1 - w) works
    too when ``body_i`` is shifted to be >= 0 by the caller.

    Returns ``pairs`` (P, 2) sorted by i N + j, ``first`` (P,) the first row of each pair,
    ``counts`` (P,) its number of points, and per pair the resultant ``force`` (P, 3) [N],
    the force-weighted ``centre`` (P, 3) [m] and the mean unit ``normal`` (P, 3).
    """
    key = body_i.astype(np.int64) * n_bodies + body_j
    pair_keys, first, inverse, counts = np.unique(key, return_index=True, return_inverse=True,
                                                  return_counts=True)
    inverse = inverse.reshape(-1)
    n_pairs = pair_keys.shape[0]
    pairs = np.stack([pair_keys // n_bodies, pair_keys % n_bodies], axis=1)
    fn = np.einsum("ci,ci->c", forces, normals)
    weight = np.bincount(inverse, fn, minlength=n_pairs)
    force, centre, normal = (np.empty((n_pairs, 3)) for _ in range(3))
    for axis in range(3):
        force[:, axis] = np.bincount(inverse, forces[:, axis], minlength=n_pairs)
        centre[:, axis] = np.bincount(inverse, fn * points[:, axis], minlength=n_pairs)
        normal[:, axis] = np.bincount(inverse, normals[:, axis], minlength=n_pairs)
    unloaded = weight <= 0.0  # open points only (VTK of all detected points): plain mean
    weight[unloaded] = counts[unloaded]
    for axis in range(3):
        centre[unloaded, axis] = np.bincount(inverse, points[:, axis],
                                             minlength=n_pairs)[unloaded]
    centre /= weight[:, None]
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return pairs, first, counts, force, centre, normal


def contact_types(contacts: Contacts) -> np.ndarray:
    """(C,) int64 ``contacts.contact_type`` (0 for every row of a narrow phase without
    polyhedra)."""
    types = getattr(contacts, "contact_type", None)
    if types is None:
        return np.zeros(contacts.n_contacts, dtype=np.int64)
    return np.asarray(types, dtype=np.int64)


def _network_points(contacts: Contacts, rows: np.ndarray, forces: np.ndarray, n: int):
    """Network points of the loaded particle-particle ``rows``: every row of a sphere-based
    pair, one resultant point per pair involving a polyhedron. Returns body_i, body_j,
    points, normals, forces (one per network point), type codes and solver points counts."""
    bi, bj = contacts.body_i[rows], contacts.body_j[rows]
    points, normals = contacts.point[rows], contacts.normal[rows]
    types = contact_types(contacts)[rows]
    poly = types > 0
    if not poly.any():
        return bi, bj, points, normals, forces, types, np.ones(rows.shape[0], np.int64)
    pairs, first, counts, force, centre, normal = pair_resultants(
        bi[poly], bj[poly], points[poly], normals[poly], forces[poly], n)
    single = ~poly
    return (np.concatenate([bi[single], pairs[:, 0]]),
            np.concatenate([bj[single], pairs[:, 1]]),
            np.concatenate([points[single], centre]),
            np.concatenate([normals[single], normal]),
            np.concatenate([forces[single], force]),
            np.concatenate([types[single], types[poly][first]]),
            np.concatenate([np.ones(int(single.sum()), np.int64), counts]))


def contact_network(report: StepReport, state: BodyState, library: ShapeLibrary,
                    volume: float, dt: float, friction: float,
                    extra_state: dict[str, Any] | None = None,
                    cell_matrix: np.ndarray | None = None,
                    box: tuple[np.ndarray, np.ndarray] | None = None) -> ContactNetwork:
    """The particle-particle contact network of the step (module docstring); in a periodic
    cell h = ``cell_matrix`` [m] the branch vectors reach through the images; in a wall box
    of corners ``box`` = (lower, upper) (3,) [m] it carries the loaded wall contacts."""
    network, _ = _contact_network(report, state, library, volume, dt, friction, extra_state,
                                  cell_matrix, box)
    return network


def wall_contacts(report: StepReport, dt: float) -> dict[str, np.ndarray]:
    """The loaded wall contact points of the step as the network's ``wall_*`` arrays:
    particle, point [m], normal (from the wall into the particle), force of the wall [N]."""
    contacts = report.contacts
    if not contacts.n_contacts:
        return {"wall_particles": np.zeros(0, np.int64), "wall_points": np.zeros((0, 3)),
                "wall_normals": np.zeros((0, 3)), "wall_forces": np.zeros((0, 3))}
    rows = np.flatnonzero((contacts.body_i < 0) & (report.impulses[:, 0] > 0.0))
    return {"wall_particles": contacts.body_j[rows].astype(np.int64),
            "wall_points": contacts.point[rows], "wall_normals": contacts.normal[rows],
            "wall_forces": world_forces(report, dt)[rows]}


def _contact_network(report: StepReport, state: BodyState, library: ShapeLibrary,
                     volume: float, dt: float, friction: float,
                     extra_state: dict[str, Any] | None = None,
                     cell_matrix: np.ndarray | None = None,
                     box: tuple[np.ndarray, np.ndarray] | None = None,
                     ) -> tuple[ContactNetwork, int]:
    """The network and the number of loaded solver points between particles."""
    contacts = report.contacts
    inner = np.flatnonzero((contacts.body_i >= 0) & (report.impulses[:, 0] > 0.0))
    forces = world_forces(report, dt)[inner] if contacts.n_contacts else np.zeros((0, 3))
    n = state.n_bodies
    bi, bj, points, normals, forces, codes, _ = _network_points(contacts, inner, forces, n)
    key = bi.astype(np.int64) * n + bj
    pair_keys, point_pairs = np.unique(key, return_inverse=True)
    pairs = np.stack([pair_keys // n, pair_keys % n], axis=1) if pair_keys.size \
        else np.zeros((0, 2), dtype=np.int64)
    branches = state.positions[pairs[:, 1]] - state.positions[pairs[:, 0]] if pairs.size \
        else np.zeros((0, 3))
    if cell_matrix is not None and pairs.size:  # through the image of j: + h m
        shifts = report.image_vectors[inner] @ np.asarray(cell_matrix).T
        row_keys = contacts.body_i[inner].astype(np.int64) * n + contacts.body_j[inner]
        order = np.argsort(row_keys, kind="stable")
        branches = branches + shifts[order[np.searchsorted(row_keys[order], pair_keys)]]
    fn = np.einsum("ci,ci->c", forces, normals)
    ft = np.linalg.norm(forces - fn[:, None] * normals, axis=1)
    sliding = (ft >= friction * fn * (1.0 - _SLIDING)) & (fn > 0.0) if friction > 0.0 \
        else fn > 0.0
    pair_types, type_names, type_points = None, (), ()
    typings = {kind.pair_typing for kind in kinds_present(library.kind[state.shape_ids])}
    if FEATURE_TYPES in typings:
        pair_types = np.zeros(pair_keys.shape[0], dtype=np.int64)
        pair_types[point_pairs.reshape(-1)] = codes
        type_names, type_points = PAIR_TYPE_NAMES, tuple(NOMINAL_POINTS.tolist())
    elif MEMBER_CLASSES in typings and pairs.size:
        classified, codes, _ = classify_aggregate_pairs(bi, bj, contacts.member_i[inner],
                                                        contacts.member_j[inner])
        ckey = classified[:, 0] * n + classified[:, 1]
        pair_types = codes[np.searchsorted(ckey, pair_keys)]
        type_names = CONTACT_CLASS_NAMES
    walls = {} if box is None else {**wall_contacts(report, dt), "box_lower": box[0],
                                    "box_upper": box[1]}
    arrays = {"positions": state.positions.copy(), "volumes": library.volume[state.shape_ids],
              "volume": volume, "pair_branches": branches, "point_positions": points,
              "point_normals": normals, "point_forces": forces, **walls}
    if library.dimension == 2:
        arrays = _in_plane(arrays, library.thickness)
    network = ContactNetwork(
        pair_particles=pairs, point_pairs=point_pairs.reshape(-1), pair_types=pair_types,
        type_names=type_names, type_points=type_points, friction_coefficient=friction,
        point_sliding=sliding, state=dict(extra_state or {}), **arrays)
    return network, int(inner.shape[0])


def _in_plane(arrays: dict[str, Any], thickness: float) -> dict[str, Any]:
    """A 2D sample's network arrays in its plane (:mod:`grainlab.engine.planar`): vectors
    by their x and y, the particles' areas and the box's (volumes / t [m^2]), the forces per
    unit thickness (/ t [N/m]), so that (1/A) sum f (x) l is the stress [Pa], as the
    micro-element model's 2D structures hold them."""
    out = {}
    for name, value in arrays.items():
        if name in ("volume", "volumes"):
            out[name] = value / thickness
        elif name in ("point_forces", "wall_forces"):
            out[name] = np.ascontiguousarray(value[:, :2]) / thickness
        elif name == "wall_particles":
            out[name] = value
        else:
            out[name] = np.ascontiguousarray(np.asarray(value)[..., :2])
    return out


def polyhedron_connectivity(network: ContactNetwork, connectivity: Connectivity,
                            solver_points: int) -> dict[str, float]:
    """z_c and z_c_no_rattlers of seed 002 eq. 14 (module docstring), the fractions
    k_fv ... k_ff of loaded pairs as ``fraction_<type>`` and ``z_c_points``, for a network
    of :func:`contact_network` with polyhedron pair types."""
    n = network.n_particles
    row = {  # the network's type_points make Connectivity's z_c that of eq. 14
        "z_c": float(connectivity.connectivity_number),
        "z_c_no_rattlers": float(connectivity.connectivity_number_no_rattlers),
        "z_c_points": float(2.0 * solver_points / n) if n else float("nan"),
    }
    for name in POLYHEDRON_TYPES:
        row[f"fraction_{name}"] = float(connectivity.type_proportions[name])
    return row


def core_connectivity(network: ContactNetwork, lower: np.ndarray, upper: np.ndarray,
                      margin: float) -> dict[str, float]:
    """z and z_c (seed 002 eq. 14; for spheres and aggregates every pair counts 1, or its
    type's points) of the core: the particles whose centre lies at least
    ``margin`` [m] inside every wall of the box (``lower``, ``upper`` (3,) [m]), each counting
    its own loaded pairs (z_core) and their nominal points (z_c_core) whoever the neighbour
    is. Walls take constraints that particles would otherwise share, so z and z_c over all
    the particles of a small box read low (seed 002's 40 000 particles are almost all core;
    docs/benchmarks/polyhedra.md gives both). NaN when the core is empty."""
    x = network.positions
    core = np.all((x >= lower + margin) & (x <= upper - margin), axis=1)
    n_core = int(np.count_nonzero(core))
    if n_core == 0:
        return {"z_core": float("nan"), "z_c_core": float("nan")}
    pairs = network.pair_particles
    points = np.ones(pairs.shape[0])
    if network.pair_types is not None and network.type_points:
        points = np.asarray(network.type_points, dtype=float)[network.pair_types]
    ends = core[pairs[:, 0]].astype(float) + core[pairs[:, 1]]
    return {"z_core": float(ends.sum() / n_core), "z_c_core": float(ends @ points / n_core)}


def mechanical_coordination(report: StepReport, n_bodies: int, min_contacts: int) -> float:
    """z_m of the module docstring: 2 (C_pp + C_pw) / N_m after removing, repeatedly, the
    particles with fewer than ``min_contacts`` force-carrying contacts (walls included)."""
    contacts = report.contacts
    loaded = report.impulses[:, 0] > 0.0 if contacts.n_contacts else np.zeros(0, bool)
    bi, bj = contacts.body_i[loaded], contacts.body_j[loaded]
    alive = np.ones(n_bodies, dtype=bool)
    while True:
        keep = alive[bj] & np.where(bi >= 0, alive[np.maximum(bi, 0)], True)
        counts = np.bincount(bj[keep], minlength=n_bodies)
        inner = keep & (bi >= 0)
        counts += np.bincount(bi[inner], minlength=n_bodies)
        weak = alive & (counts < min_contacts)
        if not weak.any():
            break
        alive &= ~weak
    n_alive = int(alive.sum())
    n_wall = int(np.count_nonzero(keep & (bi < 0)))  # each counted once in ``counts``
    return float((counts[alive].sum() + n_wall) / n_alive) if n_alive else float("nan")


def sample_measures(report: StepReport, state: BodyState, library: ShapeLibrary,
                    box: WallBox, initial_lengths: np.ndarray, dt: float, friction: float,
                    ) -> tuple[dict[str, float], ContactNetwork]:
    """One results row (stresses, strains, packing, coordination, inertia number, solver
    figures) and the contact network it was computed from."""
    volume, dimension = box.volume, library.dimension
    stress = contact_stress(report, state, volume, dt)
    extra = {f"wall_sigma_{label}": float(value)
             for label, value in zip(NORMAL_LABELS[:dimension], box.wall_stress, strict=False)}
    strains = box_strains(initial_lengths, box.lengths, dimension)
    rate = float(np.max(np.abs(box.speeds[0::2] + box.speeds[1::2]) / box.lengths))
    return _measures(report, state, library, volume, stress, extra, strains, rate, dt,
                     friction, core=(box.lower[:dimension], box.upper[:dimension]))


def cell_strains(strain: np.ndarray, dimension: int = 3) -> dict[str, float]:
    """The strain columns of a periodic cell from its natural strain (3, 3) [-]
    (:attr:`~grainlab.engine.boundaries.periodic_boundary.PeriodicCell.strain`, compression
    positive):
    normal components, engineering shears gamma = 2 eps_ab, eps_vol and eps_q [-] (for a
    box-shaped cell the same as :func:`box_strains`); in 2D those of the plane."""
    e = 0.5 * (np.asarray(strain, dtype=np.float64) + np.asarray(strain, dtype=np.float64).T)
    row = {}
    for label, (a, b) in COMPONENTS[dimension]:
        row[f"eps_{label}" if a == b else f"gamma_{label}"] = float(e[a, b] * (1 + (a != b)))
    row.update(strain_invariants(e[:dimension, :dimension]))
    return row


def cell_stress(report: StepReport, state: BodyState, matrix: np.ndarray, rate: np.ndarray,
                dt: float, image_matrix: np.ndarray | None = None) -> np.ndarray:
    """(3, 3) stress [Pa] of a sample in a periodic cell h = ``matrix`` [m] deforming at
    hdot = ``rate`` [m/s], compression positive: the contacts' (1/V) sum l (x) f with the
    branch vectors l = x_j + h m_k - x_i through the images, plus the kinetic term
    (1/V) sum m v' (x) v' of the velocities v' relative to the mean field hdot h^-1 (x - x_c)
    (x_c the centre of mass); symmetrised. The image vectors of the step are in the lattice
    basis ``image_matrix`` (the cell before a re-map at the end of the step; default
    ``matrix``)."""
    volume = float(np.linalg.det(matrix))
    contacts = report.contacts
    moment = np.zeros((3, 3))
    if contacts.n_contacts:
        f = world_forces(report, dt)
        x = state.positions
        lattice = np.asarray(matrix if image_matrix is None else image_matrix)
        branch = x[contacts.body_j] + report.image_vectors @ lattice.T - x[contacts.body_i]
        moment += np.einsum("ci,cj->ij", branch, f)
    centre = np.average(state.positions, axis=0, weights=state.masses)
    mean_field = (state.positions - centre) @ (np.asarray(rate) @ np.linalg.inv(matrix)).T
    fluctuation = state.velocities - mean_field
    moment += np.einsum("n,ni,nj->ij", state.masses, fluctuation, fluctuation)
    moment /= volume
    return 0.5 * (moment + moment.T)


def cell_measures(report: StepReport, state: BodyState, library: ShapeLibrary, cell,
                  dt: float, friction: float) -> tuple[dict[str, float], ContactNetwork]:
    """One results row of a sample in a periodic cell
    (:class:`~grainlab.engine.boundaries.periodic_boundary.PeriodicCell`): the columns of
    :func:`sample_measures` with the stress of :func:`cell_stress`, the strains of
    :func:`cell_strains` and the inertia number from the cell's largest strain rate (the
    largest eigenvalue magnitude of the symmetric velocity gradient); every particle is core
    (no walls)."""
    stress = cell_stress(report, state, cell.matrix, cell.rate, dt, cell.image_matrix)
    dimension = library.dimension
    strains = cell_strains(cell.strain, dimension)
    gradient = cell.gradient
    rate = float(np.max(np.abs(np.linalg.eigvalsh(0.5 * (gradient + gradient.T)))))
    extra = {f"cell_sigma_{label}": float(cell.boundary_stress[a, b])
             for label, (a, b) in COMPONENTS[dimension]}
    return _measures(report, state, library, cell.volume, stress, extra, strains, rate, dt,
                     friction, core=None, cell_matrix=cell.image_matrix)


def _measures(report, state, library, volume, stress, extra, strains, rate, dt, friction,
              core, cell_matrix=None) -> tuple[dict[str, float], ContactNetwork]:
    """The row shared by the wall box and the periodic cell."""
    row: dict[str, float] = {}
    dimension = library.dimension
    for label, (i, j) in COMPONENTS[dimension]:
        row[f"sigma_{label}"] = float(stress[i, j])
    row.update(extra)
    row.update(stress_invariants(stress[:dimension, :dimension]))
    row.update(strains)
    mean_d = float(2.0 * np.mean(library.bounding_radius[state.shape_ids]))
    p = row["p"]
    row["inertia_number"] = float(rate * mean_d * np.sqrt(state.density / p)) \
        if p > 0.0 else float("nan")
    network, solver_points = _contact_network(report, state, library, volume, dt, friction,
                                              cell_matrix=cell_matrix, box=core)
    connectivity = Connectivity(wall_supports=False).compute(network)  # the recorded rule
    row["packing_fraction"] = float(np.sum(library.volume[state.shape_ids]) / volume)
    row["z"] = float(connectivity.coordination_number)
    row["z_c"] = float(connectivity.connectivity_number)
    row["z_no_rattlers"] = float(connectivity.coordination_number_no_rattlers)
    row["z_c_no_rattlers"] = float(connectivity.connectivity_number_no_rattlers)
    row["rattler_fraction"] = float(connectivity.rattler_fraction)
    if network.pair_types is not None and network.type_names == PAIR_TYPE_NAMES:
        row.update(polyhedron_connectivity(network, connectivity, solver_points))
    if core is not None:
        row.update(core_connectivity(network, core[0], core[1], mean_d))
    else:
        row["z_core"], row["z_c_core"] = row["z"], row["z_c"]
    row["z_mechanical"] = mechanical_coordination(report, state.n_bodies,
                                                  dimension + 1 if friction == 0.0 else 2)
    row["n_contacts"] = float(report.n_contacts)
    row.update(convergence_columns(report.convergence))
    row["max_overlap_over_d"] = report.max_overlap / mean_d
    row["kinetic_energy"] = float(state.kinetic_energy())
    return row, network
