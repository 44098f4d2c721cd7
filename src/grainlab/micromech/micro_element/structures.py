"""Generators of seed 001's micro-element structures (representative units).

Each function returns a :class:`~grainlab.micromech.micro_element.structure.MicroElementStructure`
(or, for the chapter 3 packing, the :class:`~grainlab.geometry.DiscPacking2D` it is made from).
All lengths are in metres, volumes in m^3 (areas in m^2 in 2D); every random generator is
reproducible from an integer ``seed``.

=============================  =================================================================
generator                      structure
=============================  =================================================================
:func:`binary_units`           §4.1: isotropic set of binary units (one contact each)
:func:`idealized_material`     §4.2: 5 random 8-sphere micro-elements x 6 axis permutations = 30
:func:`from_contact_network`   one micro-element per particle of a contact network (2D or 3D)
:func:`from_disc_packing`      one micro-element per disc of a periodic packing, V^n = power cell
:func:`chang_periodic_discs`   §3: random jammed periodic packing of 12 + 13 discs (a DiscPacking2D)
=============================  =================================================================

Volume bookkeeping. The micro-element stress is sigma^n = (1 / 2V^n) sum_m L^nm f^nm (seed 001
eq. 2.16) and the overall stress its volume average (eq. 2.20), so
sigma = (1/V) sum_n (1/2) sum_m L f. Every physical contact appears in the micro-elements of both
its particles (branch vectors +L and -L, forces +f and -f), so the sum is over contacts counted
twice and the factor 1/2 makes it the usual sigma = (1/V) sum_contacts L f — provided
V = sum_n V^n is the volume of the whole sample. Every generator below therefore makes the V^n
add up to the sample volume.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from scipy.optimize import minimize
from scipy.spatial import ConvexHull, QhullError

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.errors import ConvergenceError, InputError
from grainlab.geometry.disc_contacts import DEFAULT_CONTACT_TOLERANCE, find_disc_contacts
from grainlab.geometry.disc_packing import DiscPacking2D
from grainlab.geometry.periodic_cell import PeriodicCell2D
from grainlab.geometry.power_tessellation import power_tessellation
from grainlab.micromech.micro_element.structure import MicroElementStructure

GOLDEN = (1.0 + np.sqrt(5.0)) / 2.0
"""The golden ratio phi [-]."""

NON_OVERLAP_ANGLE = np.pi / 3.0
"""Smallest angle between the branch vectors of two equal neighbours of an equal centre
sphere: the neighbours (centres 2r from the centre, radius r) touch at 60 degrees [rad]."""


# -- small validators ------------------------------------------------------------------------
def _positive(name: str, value: Any, what: str = "a positive number") -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(name, value, what) from None
    if not (np.isfinite(number) and number > 0.0):
        raise InputError(name, value, what)
    return number


def _integer(name: str, value: Any, low: int, high: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InputError(name, value, f"an integer >= {low}")
    if value < low or (high is not None and value > high):
        allowed = f"an integer in [{low}, {high}]" if high is not None else f"an integer >= {low}"
        raise InputError(name, value, allowed)
    return int(value)


def _seed(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise InputError("seed", value, "a non-negative integer seed")
    return int(value)


def sphere_volume(radius: float | np.ndarray, dimension: int = 3) -> float | np.ndarray:
    """Volume 4/3 pi r^3 of a sphere [m^3] (area pi r^2 of a disc [m^2] when dimension = 2)."""
    radius = np.asarray(radius, dtype=float)
    return 4.0 / 3.0 * np.pi * radius**3 if dimension == 3 else np.pi * radius**2


def radius_from_volume(volume: float | np.ndarray, dimension: int = 3) -> np.ndarray:
    """Radius [m] of the sphere (disc in 2D) of the given volume [m^3] (area [m^2])."""
    volume = np.asarray(volume, dtype=float)
    if dimension == 3:
        return np.cbrt(3.0 * volume / (4.0 * np.pi))
    return np.sqrt(volume / np.pi)


# -- (a) binary units -------------------------------------------------------------------------
def icosahedron_axes() -> np.ndarray:
    """(6, 3) unit vectors along the six axes through opposite vertices of a regular
    icosahedron (one vertex of each opposite pair: (0, 1, phi), (1, phi, 0), (phi, 0, 1), ...).

    The 12 vertices +/-n form a spherical 5-design: sum n_i n_j = 4 delta_ij and
    sum n_i n_j n_k n_l = (4/5) (delta_ij delta_kl + delta_ik delta_jl + delta_il delta_jk)
    exactly; odd moments vanish.

    >>> axes = icosahedron_axes()
    >>> np.allclose(np.linalg.norm(axes, axis=1), 1.0), axes.shape
    (True, (6, 3))
    """
    g = GOLDEN
    axes = np.array([[0.0, 1.0, g], [0.0, 1.0, -g], [1.0, g, 0.0], [-1.0, g, 0.0],
                     [g, 0.0, 1.0], [g, 0.0, -1.0]])
    return axes / np.linalg.norm(axes, axis=1, keepdims=True)


def fibonacci_axes(n: int) -> np.ndarray:
    """(n, 3) unit vectors spread evenly over the upper hemisphere (a Fibonacci lattice:
    z_k = (k + 1/2)/n, azimuth k times the golden angle); used both ways (+/-) they cover the
    sphere evenly and their moments are isotropic to O(1/n)."""
    k = np.arange(n) + 0.5
    z = k / n
    azimuth = np.pi * (3.0 - np.sqrt(5.0)) * np.arange(n)
    rho = np.sqrt(1.0 - z**2)
    return np.column_stack([rho * np.cos(azimuth), rho * np.sin(azimuth), z])


def half_circle_axes(n: int) -> np.ndarray:
    """(n, 2) unit vectors at angles k pi / n, k = 0..n-1; used both ways they are 2n equally
    spaced directions, whose 2nd and 4th moments are exactly isotropic when n >= 3."""
    theta = np.pi * np.arange(n) / n
    return np.column_stack([np.cos(theta), np.sin(theta)])


def contact_density_parameter(coordination_number: float, void_ratio: float) -> float:
    """Seed 001 eq. 4.4: z = (M / 3V) r^3 = n_bar / (4 pi (1 + e)) [-].

    M / V is the number of contacts per unit volume counted twice (once from each particle):
    N n_bar contacts in V = N (4/3 pi r^3)(1 + e) for N equal spheres of radius r, whence the
    right-hand side.

    >>> round(contact_density_parameter(6.0, 0.6), 6)
    0.298416
    """
    n_bar = _positive("coordination_number", coordination_number,
                      "a positive mean number of contacts per particle")
    e = _positive("void_ratio", void_ratio, "a positive void ratio")
    return n_bar / (4.0 * np.pi * (1.0 + e))


def binary_units(
    directions: str | int = "icosahedron",
    *,
    radius: float,
    void_ratio: float,
    coordination_number: float | None = None,
    dimension: int = 3,
) -> MicroElementStructure:
    """Seed 001 §4.1: an isotropic packing of equal spheres as a set of binary units.

    A binary unit is two equal spheres (radius r) in contact: a micro-element with one contact,
    branch vector L = 2r n. The contact directions n are

    * ``"icosahedron"`` (3D): the 6 axes of a regular icosahedron, both ways — 12 units, a
      spherical 5-design, so sum n_i n_j n_k n_l = (12/15)(d_ij d_kl + d_ik d_jl + d_il d_jk)
      exactly (the 4th-order fabric of an isotropic packing);
    * an integer N (3D): N Fibonacci axes on the hemisphere, both ways — 2N units,
      approximately isotropic;
    * an integer N (2D): N axes equally spaced on the half circle, both ways — 2N units,
      exactly isotropic to 4th order for N >= 3.

    Volume bookkeeping (see the module docstring): a packing of N particles with coordination
    number n_bar (contacts per particle) and void ratio e has N n_bar contacts counted twice in
    V = N V_p (1 + e), V_p = 4/3 pi r^3 (pi r^2 in 2D). Each binary unit stands for one
    contact seen from one of its two particles, so it gets the volume

        V^n = V / (N n_bar) = V_p (1 + e) / n_bar,

    and with eq. 2.16's factor 1/2 the volume average of the unit stresses is the packing's
    stress (1/V) sum_contacts L f. (Counting each contact once, V^n = 2 V_p (1 + e) / n_bar,
    would halve every stress and stiffness.) With this choice, M / V = 1 / V^n and
    (M / 3V) r^3 = n_bar / (4 pi (1 + e)) is eq. 4.4's z (``description["z_eq_4_4"]``, 3D).

    The structure's own :meth:`~MicroElementStructure.void_ratio` and
    :attr:`~MicroElementStructure.coordination_number` count each unit as a particle and do not
    apply here: ``description`` carries the packing's ``void_ratio`` and
    ``coordination_number``.

    Parameters
    ----------
    directions:
        ``"icosahedron"`` (3D only) or a positive number of axes N.
    radius:
        Sphere (disc) radius r [m].
    void_ratio:
        Void ratio e of the packing [-].
    coordination_number:
        Mean contacts per particle n_bar [-]; default 6 in 3D, 4 in 2D.
    dimension:
        3 (spheres) or 2 (discs).

    >>> units = binary_units(radius=1e-3, void_ratio=0.6)
    >>> units.n_elements, units.max_contacts, round(units.description["z_eq_4_4"], 6)
    (12, 1, 0.298416)
    """
    if isinstance(dimension, bool) or dimension not in (2, 3):
        raise InputError("dimension", dimension, "2 (discs) or 3 (spheres)")
    r = _positive("radius", radius, "a positive radius in metres")
    e = _positive("void_ratio", void_ratio, "a positive void ratio")
    default_z = 6.0 if dimension == 3 else 4.0
    n_bar = _positive("coordination_number",
                      default_z if coordination_number is None else coordination_number,
                      "a positive mean number of contacts per particle")
    if isinstance(directions, str):
        if directions.strip().lower() != "icosahedron" or dimension != 3:
            raise InputError("directions", directions, "'icosahedron' (3D only) or a positive "
                             "integer number of axes")
        axes, kind = icosahedron_axes(), "icosahedron"
    else:
        count = _integer("directions", directions, 1)
        axes = fibonacci_axes(count) if dimension == 3 else half_circle_axes(count)
        kind = "fibonacci hemisphere" if dimension == 3 else "equally spaced half circle"
    normals = np.concatenate([axes, -axes])
    n_units = normals.shape[0]
    volume = float(sphere_volume(r, dimension)) * (1.0 + e) / n_bar
    description: dict[str, Any] = {
        "generator": "binary_units", "source": "seed 001 §4.1", "directions": kind,
        "n_axes": int(axes.shape[0]), "radius": r, "void_ratio": e,
        "coordination_number": n_bar, "volume_per_unit": volume,
    }
    if dimension == 3:
        description["z_eq_4_4"] = n_bar / (4.0 * np.pi * (1.0 + e))
    return MicroElementStructure(
        branches=(2.0 * r * normals)[:, None, :],
        mask=np.ones((n_units, 1), dtype=bool),
        volumes=np.full(n_units, volume),
        centre_radii=np.full(n_units, r),
        neighbour_radii=np.full((n_units, 1), r),
        name=f"binary units ({kind}, {n_units})",
        description=description,
    )


# -- (b) the idealized material of §4.2 -------------------------------------------------------
def axis_permutation_rotations() -> np.ndarray:
    """(6, 3, 3) the six permutations of the axes (x, y, z) as proper rotations.

    R_ij = sign(p) delta_{p(i) j}: an odd permutation (a swap of two axes, det -1) is composed
    with the inversion -I, giving a half-turn about a face diagonal such as (1, -1, 0). The six
    matrices form a group (the identity first), isomorphic to the permutations of three axes.
    Micro-element stiffness (eq. 2.18) is even in the branch vectors, so a structure invariant
    under these rotations has the material symmetry of the pure axis exchanges too.

    >>> rotations = axis_permutation_rotations()
    >>> np.allclose(np.linalg.det(rotations), 1.0), rotations.shape
    (True, (6, 3, 3))
    """
    rotations = []
    for perm in itertools.permutations(range(3)):
        matrix = np.zeros((3, 3))
        matrix[np.arange(3), perm] = 1.0
        rotations.append(np.sign(np.linalg.det(matrix)) * matrix)
    return np.array(rotations)


def _positively_spanning(directions: np.ndarray, margin: float = 1e-9) -> bool:
    """True when the origin lies strictly inside the convex hull of the unit vectors, i.e. no
    closed hemisphere holds them all (a centre particle pressed by its neighbours can be in
    equilibrium with compressive forces only)."""
    try:
        hull = ConvexHull(directions)
    except QhullError:  # coplanar directions: no full-dimensional hull
        return False
    return bool(np.all(hull.equations[:, -1] < -margin))


def random_neighbour_directions(
    rng: np.random.Generator, n_neighbours: int, min_angle: float = NON_OVERLAP_ANGLE,
    max_tries: int = 10_000,
) -> np.ndarray:
    """(n, 3) random unit vectors, uniform on the sphere, pairwise at least ``min_angle``
    [rad] apart and not all in one closed hemisphere.

    Random sequential addition with rejection: each candidate is drawn uniformly on the sphere
    and kept if it is at least ``min_angle`` from every kept direction; a set that cannot be
    completed (after 200 candidates) or lies in one hemisphere is discarded and drawn afresh.

    Raises
    ------
    ConvergenceError
        No acceptable set in ``max_tries`` sets (too many neighbours for the angle).
    """
    cos_min = np.cos(min_angle)
    for _ in range(max_tries):
        kept: list[np.ndarray] = []
        for _candidate in range(200):
            v = rng.normal(size=3)
            v /= np.linalg.norm(v)
            if all(float(v @ u) <= cos_min + 1e-12 for u in kept):
                kept.append(v)
                if len(kept) == n_neighbours:
                    break
        if len(kept) == n_neighbours and _positively_spanning(np.array(kept)):
            return np.array(kept)
    raise ConvergenceError(
        f"Could not place {n_neighbours} neighbours at least {np.degrees(min_angle):.1f} deg "
        f"apart around a centre in equilibrium in {max_tries} tries; use fewer neighbours."
    )


def idealized_material(
    seed: int = 1,
    n_random: int = 5,
    n_neighbours: int = 7,
    radius: float = 0.2e-3,
    void_ratio: float = 0.7,
) -> MicroElementStructure:
    """Seed 001 §4.2's idealized material: n_random random micro-elements in 6 orientations.

    Each random micro-element is a centre sphere of radius r touching ``n_neighbours`` equal
    spheres (8 spheres in all by default): branch vectors L = 2r n with the directions n uniform
    on the sphere, subject to (i) non-overlapping neighbours, every pair of directions at least
    60 deg apart, and (ii) a centre that can be in equilibrium under compressive contact forces,
    the directions not all in one closed hemisphere (the origin strictly inside their convex
    hull) — see :func:`random_neighbour_directions`. Each is then taken in the 6 orientations of
    :func:`axis_permutation_rotations` (element 6k + p is random element k under rotation p),
    so the 30 micro-elements map onto themselves under every exchange of the axes: "material
    symmetry along the directions of three axes". Every V^n = (4/3 pi r^3)(1 + e), so the
    structure's void ratio is e (0.7) and its coordination number ``n_neighbours`` (7).

    Parameters
    ----------
    seed:
        Seed of the random directions (numpy ``default_rng``).
    n_random:
        Number of random micro-elements (5).
    n_neighbours:
        Neighbours of each centre sphere, 4 to 12 (7). Above about 9 the random addition
        rarely succeeds and a ConvergenceError is raised.
    radius:
        Radius r of every sphere [m] (0.2 mm).
    void_ratio:
        Void ratio e [-] (0.7).

    >>> material = idealized_material(seed=1)
    >>> material.n_elements, material.coordination_number, round(material.void_ratio(), 12)
    (30, 7.0, 0.7)
    """
    seed = _seed(seed)
    n_random = _integer("n_random", n_random, 1)
    n_neighbours = _integer("n_neighbours", n_neighbours, 4, 12)
    r = _positive("radius", radius, "a positive radius in metres")
    e = _positive("void_ratio", void_ratio, "a positive void ratio")
    rng = np.random.default_rng(seed)
    base = np.array([random_neighbour_directions(rng, n_neighbours) for _ in range(n_random)])
    rotations = axis_permutation_rotations()
    # normals[k, p, m, :] = R_p n_km
    normals = np.einsum("pij,kmj->kpmi", rotations, base).reshape(-1, n_neighbours, 3)
    n_elements = normals.shape[0]
    return MicroElementStructure(
        branches=2.0 * r * normals,
        mask=np.ones((n_elements, n_neighbours), dtype=bool),
        volumes=np.full(n_elements, float(sphere_volume(r)) * (1.0 + e)),
        centre_radii=np.full(n_elements, r),
        neighbour_radii=np.full((n_elements, n_neighbours), r),
        name=f"idealized material (seed {seed})",
        description={
            "generator": "idealized_material", "source": "seed 001 §4.2", "seed": seed,
            "n_random": n_random, "n_neighbours": n_neighbours, "radius": r, "void_ratio": e,
            "orientations": "6 axis permutations as proper rotations (element 6k + p)",
        },
    )


# -- (c) from a contact network or a disc packing ---------------------------------------------
def _assemble(
    owners: np.ndarray, branches: np.ndarray, neighbour_radii: np.ndarray,
    centre_radii_all: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Group contacts (owner particle, branch, neighbour radius) into padded per-particle
    arrays. Returns the particle indices that own contacts, branches (E, M, d), mask,
    centre radii (E,) and neighbour radii (E, M)."""
    order = np.argsort(owners, kind="stable")
    owners, branches, neighbour_radii = owners[order], branches[order], neighbour_radii[order]
    particles, first, counts = np.unique(owners, return_index=True, return_counts=True)
    n_elements, width, d = particles.size, int(counts.max()), branches.shape[1]
    slot = np.arange(owners.size) - np.repeat(first, counts)
    row = np.repeat(np.arange(n_elements), counts)
    padded = np.zeros((n_elements, width, d))
    mask = np.zeros((n_elements, width), dtype=bool)
    radii = np.ones((n_elements, width))
    padded[row, slot] = branches
    mask[row, slot] = True
    radii[row, slot] = neighbour_radii
    return particles, padded, mask, centre_radii_all[particles], radii


def from_contact_network(
    network: ContactNetwork,
    volumes: str = "uniform",
    active_only: bool = True,
    threshold: float = 0.0,
) -> MicroElementStructure:
    """One micro-element per particle of a contact network that has a contact.

    The micro-element of particle i holds the branch vectors to all its neighbours: for each
    interaction (i, j) with branch l (from i to j, periodic images resolved), +l for particle i
    and -l for particle j (a particle touching its own periodic image gets both). Radii are
    estimated from the particle volumes as those of spheres (discs in 2D). Particles without
    a (selected) contact — rattlers — form no micro-element.

    Parameters
    ----------
    network:
        The contact network (2D or 3D).
    volumes:
        ``"uniform"``: V^n = V / E for the E micro-elements; ``"particle"``: V^n proportional
        to the particle volume, scaled so that sum V^n = V. Either way the V^n add up to the
        sample volume ``network.volume`` (see the module docstring).
    active_only:
        Keep only interactions with a contact point carrying a normal force above
        ``threshold`` [N]; False keeps every geometric interaction.
    threshold:
        Normal-force threshold for ``active_only`` [N].

    Raises
    ------
    InputError
        No interaction selected, or an unknown ``volumes`` option.

    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0, 0], [2, 0]], volumes=[np.pi, np.pi], volume=8.0,
    ...     pair_particles=[[0, 1]], pair_branches=[[2, 0]], point_pairs=[0],
    ...     point_positions=[[1, 0]], point_normals=[[1, 0]], point_forces=[[5, 0]])
    >>> from_contact_network(net).branches[:, 0, 0].tolist()  # +l for particle 0, -l for 1
    [2.0, -2.0]
    """
    if not isinstance(network, ContactNetwork):
        raise InputError("network", type(network).__name__, "a ContactNetwork")
    if volumes not in ("uniform", "particle"):
        raise InputError("volumes", volumes, "'uniform' or 'particle'")
    if not isinstance(active_only, bool | np.bool_):
        raise InputError("active_only", active_only, "True or False")
    if not (np.isfinite(threshold) and threshold >= 0.0):
        raise InputError("threshold", threshold, "a normal-force threshold >= 0 in newtons")
    selected = network.active_pairs(threshold) if active_only else np.ones(network.n_pairs, bool)
    if not np.any(selected):
        which = "active " if active_only else ""
        raise InputError("network", f"{network.n_pairs} interactions, none {which}selected",
                         f"a network with at least one {which}interaction")
    d = network.dimension
    pairs, branch = network.pair_particles[selected], network.pair_branches[selected]
    radii_all = radius_from_volume(network.volumes, d)
    owners = np.concatenate([pairs[:, 0], pairs[:, 1]])
    others = np.concatenate([pairs[:, 1], pairs[:, 0]])
    particles, branches, mask, centre, neighbour = _assemble(
        owners, np.concatenate([branch, -branch]), radii_all[others], radii_all)
    if volumes == "uniform":
        element_volumes = np.full(particles.size, network.volume / particles.size)
    else:
        share = network.volumes[particles]
        element_volumes = share * network.volume / share.sum()
    return MicroElementStructure(
        branches, mask, element_volumes, centre, neighbour,
        name="micro-elements of a contact network",
        description={
            "generator": "from_contact_network", "volumes": volumes,
            "active_only": bool(active_only), "threshold": float(threshold),
            "particles": particles.tolist(),
            "n_rattlers": int(network.n_particles - particles.size),
        },
    )


def from_disc_packing(
    packing: DiscPacking2D, tolerance: float = DEFAULT_CONTACT_TOLERANCE,
) -> MicroElementStructure:
    """One micro-element per disc of a periodic packing; V^n its power (radical) cell area.

    Contacts come from :func:`grainlab.geometry.find_disc_contacts` (relative gap tolerance
    ``tolerance``); each contact (i, j) with branch l gives +l to disc i and -l to disc j. The
    power cells tile the periodic cell, so sum V^n is the cell area exactly. Discs without a
    contact (rattlers, warned about) form no micro-element; the areas of the others are then
    scaled by cell area / (their summed area) so that V = sum V^n is still the cell area.

    >>> from grainlab.prep.regular_packings import named_packing
    >>> hexagonal = from_disc_packing(named_packing("hexagonal"))
    >>> hexagonal.n_elements, int(hexagonal.contact_counts[0])
    (1, 6)
    """
    if not isinstance(packing, DiscPacking2D):
        raise InputError("packing", type(packing).__name__, "a DiscPacking2D")
    contacts = find_disc_contacts(packing, tolerance)
    if contacts.n_contacts == 0:
        raise InputError("packing", packing.name, "a packing with at least one contact")
    areas = power_tessellation(packing).areas
    owners = np.concatenate([contacts.particle_i, contacts.particle_j])
    neighbour_radii = np.concatenate([contacts.radius_j, contacts.radius_i])
    particles, branches, mask, centre, neighbour = _assemble(
        owners, np.concatenate([contacts.branch, -contacts.branch]), neighbour_radii,
        packing.radii)
    element_areas = areas[particles] * packing.cell.area / areas[particles].sum()
    return MicroElementStructure(
        branches, mask, element_areas, centre, neighbour,
        name=f"micro-elements of {packing.name}",
        description={
            "generator": "from_disc_packing", "packing": packing.name,
            "tolerance": float(tolerance), "particles": particles.tolist(),
            "rattlers": sorted(set(range(packing.n_particles)) - set(particles.tolist())),
            "volumes": "power cell areas",
        },
    )


# -- (d) the random periodic packing of chapter 3 ---------------------------------------------
PRESSURE_SCHEDULE = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
"""Dimensionless pressures P of the successive enthalpy minimisations of
:func:`chang_periodic_discs` (mean relative overlap about 2P)."""


def _enthalpy(x: np.ndarray, sigma: np.ndarray, i: np.ndarray, j: np.ndarray,
              pressure: float) -> tuple[float, np.ndarray]:
    """H = sum_pairs (h / sigma)^2 / 2 + P L^2 and its gradient, for fractional coordinates s
    (x[:-1]) in a square cell of side L = exp(x[-1]); h = max(sigma - d, 0) is the overlap."""
    n = (x.size - 1) // 2
    s, side = x[:-1].reshape(n, 2), np.exp(x[-1])
    ds = s[j] - s[i]
    ds -= np.round(ds)
    distance = side * np.linalg.norm(ds, axis=1)
    overlap = np.maximum(sigma - distance, 0.0)
    dh = -overlap / sigma**2  # dU/dd
    touching = overlap > 0.0
    coefficient = np.zeros_like(distance)
    coefficient[touching] = dh[touching] * side**2 / distance[touching]  # dU/dd * dd/d(ds)
    force = coefficient[:, None] * ds
    grad = np.zeros((n, 2))
    for axis in range(2):
        grad[:, axis] = (np.bincount(j, force[:, axis], minlength=n)
                         - np.bincount(i, force[:, axis], minlength=n))
    grad_log_side = float(np.sum(dh * distance)) + 2.0 * pressure * side**2
    energy = 0.5 * float(np.sum((overlap / sigma) ** 2)) + pressure * side**2
    return energy, np.concatenate([grad.ravel(), [grad_log_side]])


def _rattlers(n: int, contact_i: np.ndarray, contact_j: np.ndarray) -> np.ndarray:
    """Indices of rattlers: repeatedly remove discs with fewer than 3 contacts (2D)."""
    alive = np.ones(n, dtype=bool)
    while True:
        keep = alive[contact_i] & alive[contact_j]
        count = np.bincount(contact_i[keep], minlength=n) + np.bincount(contact_j[keep],
                                                                         minlength=n)
        weak = alive & (count < 3)
        if not weak.any():
            return np.flatnonzero(~alive)
        alive &= ~weak


def _polish(s: np.ndarray, side: float, sigma: np.ndarray, i: np.ndarray, j: np.ndarray,
            image: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Gauss-Newton on |L (s_j + image - s_i)| = sigma for the listed contacts (fractional
    s, side L; least squares, translations left free). Returns s, L, max relative residual."""
    n = s.shape[0]
    residual = np.inf
    for _ in range(50):
        ds = s[j] + image - s[i]
        norm = np.linalg.norm(ds, axis=1)
        residual_vec = side * norm - sigma
        residual = float(np.max(np.abs(residual_vec) / sigma))
        if residual < 1e-14:
            break
        unit = side * ds / norm[:, None]
        jac = np.zeros((i.size, 2 * n + 1))
        rows = np.arange(i.size)
        for axis in range(2):
            jac[rows, 2 * j + axis] += unit[:, axis]
            jac[rows, 2 * i + axis] -= unit[:, axis]
        jac[:, -1] = norm
        step = np.linalg.lstsq(jac, -residual_vec, rcond=None)[0]
        s = s + step[:-1].reshape(n, 2)
        side += step[-1]
    return s, side, residual


def _jam_once(rng: np.random.Generator, radii: np.ndarray, max_rattlers: int,
              start_fraction: float = 0.5) -> tuple[np.ndarray, float] | None:
    """One jammed packing of discs of the given (dimensionless) radii in a square cell, as
    (centres, side), or None when it has too many rattlers or does not polish."""
    n = radii.size
    i, j = np.triu_indices(n, 1)
    sigma = radii[i] + radii[j]
    side0 = np.sqrt(np.pi * np.sum(radii**2) / start_fraction)
    x = np.concatenate([rng.random(2 * n), [np.log(side0)]])
    for pressure in PRESSURE_SCHEDULE:
        result = minimize(_enthalpy, x, args=(sigma, i, j, pressure), jac=True,
                          method="L-BFGS-B",
                          options={"maxiter": 20_000, "gtol": 1e-14, "ftol": 1e-16,
                                   "maxcor": 30})
        x = result.x
        if pressure == 1e-3 and len(_contacts_and_rattlers(x, sigma, i, j)[1]) > max_rattlers:
            return None  # rattlers at this pressure stay rattlers: skip the slow last stages
    (touch_i, touch_j, image), rattlers = _contacts_and_rattlers(x, sigma, i, j)
    if len(rattlers) > max_rattlers:
        return None
    s, side = x[:-1].reshape(n, 2), float(np.exp(x[-1]))
    pair = np.flatnonzero(np.isin(i * n + j, touch_i * n + touch_j))
    s, side, residual = _polish(s, side, sigma[pair], touch_i, touch_j, image)
    if residual > 1e-12 or side <= 2.0 * sigma.max() * 1.01:
        return None
    ds = s[j] - s[i]
    ds -= np.round(ds)
    gap = side * np.linalg.norm(ds, axis=1) - sigma
    others = np.ones(i.size, dtype=bool)
    others[pair] = False
    if np.any(gap[others] <= 1e-9 * sigma[others]):
        return None  # a non-contact closed up while polishing: reject rather than guess
    s -= np.floor(s)
    return s * side, side


def _contacts_and_rattlers(x: np.ndarray, sigma: np.ndarray, i: np.ndarray, j: np.ndarray):
    n = (x.size - 1) // 2
    s, side = x[:-1].reshape(n, 2), np.exp(x[-1])
    ds = s[j] - s[i]
    shift = -np.round(ds)
    touching = side * np.linalg.norm(ds + shift, axis=1) < sigma
    contacts = (i[touching], j[touching], shift[touching])
    return contacts, _rattlers(n, contacts[0], contacts[1])


def chang_periodic_discs(
    seed: int = 1,
    n_large: int = 12,
    r_large: float = 0.21e-3,
    n_small: int = 13,
    r_small: float = 0.105e-3,
    max_rattlers: int = 0,
    max_attempts: int = 200,
) -> DiscPacking2D:
    """Seed 001 ch. 3's random periodic packing of 12 + 13 discs (Fig. 3.1 is lost).

    A reconstruction: a frictionless jammed packing in a square periodic cell. Discs are put at
    random (solid fraction 0.5) and relaxed as soft discs (energy sum (h/sigma)^2 / 2 over
    overlaps h, sigma = r_i + r_j) while the cell side L is free under a dimensionless pressure
    P: minimising the enthalpy U + P L^2 (L-BFGS) at P = 1e-1 ... 1e-6 compresses the packing to
    jamming. The touching pairs are then made exact (Gauss-Newton on |l| = r_i + r_j, cell side
    free) and every other pair must keep a gap. A packing with more than ``max_rattlers``
    rattlers (discs with fewer than 3 contacts after repeatedly removing such discs) is rejected
    and the next random start tried, so by default every disc has at least 3 contacts and can
    be in equilibrium. Contacts are exact to about 1e-14 of the sum of radii; gaps of
    non-contacts exceed 1e-9 of it, so ``find_disc_contacts`` with its default tolerance finds
    exactly the jammed contact network. Discs 0..n_large-1 are the large ones.

    For the default arguments and ``seed=1`` the packing (found at the first start) has void
    ratio e = 0.2029 (solid fraction 0.831) and coordination number 3.92: 49 contacts, the
    isostatic 2N - 1 of a periodic frictionless packing, every disc touching 3 to 6 others.
    Seeds 0 to 7 give e = 0.176 to 0.203, always 49 contacts. Seed 001 gives neither number.

    Parameters
    ----------
    seed:
        Seed of the random starts (numpy ``default_rng``); attempts are drawn in sequence.
    n_large, r_large, n_small, r_small:
        Numbers and radii [m] of the two disc sizes (12 of 0.21 mm, 13 of 0.105 mm).
    max_rattlers:
        Rattlers allowed (they stay where jamming left them, touching at most 2 discs).
    max_attempts:
        Random starts tried before giving up.

    Raises
    ------
    ConvergenceError
        No acceptable packing in ``max_attempts`` starts.

    >>> packing = chang_periodic_discs(seed=1)
    >>> packing.n_particles, round(packing.void_ratio, 3)
    (25, 0.203)
    """
    seed = _seed(seed)
    n_large = _integer("n_large", n_large, 0)
    n_small = _integer("n_small", n_small, 0)
    r_large = _positive("r_large", r_large, "a positive radius in metres")
    r_small = _positive("r_small", r_small, "a positive radius in metres")
    max_rattlers = _integer("max_rattlers", max_rattlers, 0)
    max_attempts = _integer("max_attempts", max_attempts, 1)
    radii = np.concatenate([np.full(n_large, r_large), np.full(n_small, r_small)])
    if radii.size < 4:
        raise InputError("n_large + n_small", radii.size, "at least 4 discs")
    scale = radii.max()
    # The cell must be wider than two contact distances for minimum images to be exact.
    if np.sum(np.pi * (radii / scale) ** 2) / 0.9 <= (4.0 * 1.01) ** 2:
        raise InputError("n_large, n_small", (n_large, n_small),
                         "enough discs for a jammed cell wider than 4 largest radii")
    rng = np.random.default_rng(seed)
    for _ in range(max_attempts):
        found = _jam_once(rng, radii / scale, max_rattlers)
        if found is not None:
            centres, side = found
            return DiscPacking2D(
                PeriodicCell2D(np.eye(2) * side * scale), centres * scale, radii,
                name=f"seed 001 ch. 3 random periodic packing (seed {seed})",
            )
    raise ConvergenceError(
        f"No jammed packing with at most {max_rattlers} rattlers in {max_attempts} random "
        "starts; allow more rattlers or attempts."
    )
