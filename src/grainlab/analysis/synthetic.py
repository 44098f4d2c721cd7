"""Synthetic contact networks with prescribed harmonic anisotropies (seed 002 eq. 26).

For validation and benchmarks: contact normals are drawn from
P(theta) = (1 + a_c (3 cos^2 theta - 1)) / (4 pi) about a loading axis (2D:
(1 + a_c cos 2 theta) / (2 pi)), normal forces follow <f_n>(1 + a_fn (3 cos^2 theta - 1)) with
exponential fluctuations, tangential forces <f_n> a_ft sin 2 theta pointing towards the loading
axis, which makes a_ft > 0 raise q (capped by Coulomb), branch vectors l = 2 R n (spheres of
radius R). Particles are placed at random and pairs drawn at random; this is not a
mechanically balanced packing, only a network whose statistics are known.

:func:`cubic_lattice` is the other way round: a balanced packing in a box of walls whose
every descriptor is known in closed form (core packing fraction pi/6, z = 6 inside, the stress
of particle and wall contacts equal to the wall reactions over the faces).
"""

from __future__ import annotations

import numpy as np

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.errors import InputError


def _sample_theta(rng, n: int, a_c: float, dimension: int) -> np.ndarray:
    """Angles from the axis with the harmonic density (rejection sampling)."""
    out = np.empty(0)
    while out.size < n:
        m = 2 * (n - out.size) + 16
        if dimension == 3:
            cos = rng.uniform(-1.0, 1.0, m)  # uniform on the sphere
            weight = 1.0 + a_c * (3.0 * cos**2 - 1.0)
            bound = 1.0 + 2.0 * abs(a_c)
            theta = np.arccos(cos)
        else:
            theta = rng.uniform(0.0, 2 * np.pi, m)
            weight = 1.0 + a_c * np.cos(2 * theta)
            bound = 1.0 + abs(a_c)
        keep = rng.uniform(0.0, bound, m) < weight
        out = np.concatenate([out, theta[keep]])
    return out[:n]


def synthetic_network(
    n_points: int,
    *,
    dimension: int = 3,
    a_c: float = 0.0,
    a_fn: float = 0.0,
    a_ft: float = 0.0,
    axis: np.ndarray | None = None,
    mean_force: float = 1.0,
    radius: float = 1e-3,
    coordination: float = 6.0,
    friction_coefficient: float = 0.4,
    seed: int = 0,
) -> ContactNetwork:
    """A random network of ``n_points`` single-point interactions with known anisotropies.

    Anisotropies must keep the densities positive: |a_c|, |a_fn| < 0.5 in 3D (< 1 in 2D).
    """
    limit = 0.5 if dimension == 3 else 1.0
    for name, value in (("a_c", a_c), ("a_fn", a_fn)):
        if not abs(value) < limit:
            raise InputError(name, value, f"an anisotropy of magnitude below {limit}")
    rng = np.random.default_rng(seed)
    axis = np.eye(dimension)[-1] if axis is None else np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    theta = _sample_theta(rng, n_points, a_c, dimension)
    # Build unit normals at angle theta from the axis, random azimuth.
    if dimension == 3:
        helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = np.cross(axis, helper)
        u /= np.linalg.norm(u)
        v = np.cross(axis, u)
        phi = rng.uniform(0.0, 2 * np.pi, n_points)
        radial = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v
    else:
        radial = np.tile([axis[1], -axis[0]], (n_points, 1))
    normal = np.cos(theta)[:, None] * axis + np.sin(theta)[:, None] * radial
    # Direction of increasing theta (towards the equator), perpendicular to n.
    towards_equator = -np.sin(theta)[:, None] * axis + np.cos(theta)[:, None] * radial
    if dimension == 3:
        shape = 3.0 * np.cos(theta) ** 2 - 1.0
    else:
        shape = np.cos(2 * theta)
    f_n = mean_force * (1.0 + a_fn * shape) * rng.exponential(1.0, n_points)
    f_t = mean_force * a_ft * np.sin(2 * theta)
    f_t = np.clip(f_t, -friction_coefficient * f_n, friction_coefficient * f_n)
    forces = f_n[:, None] * normal - f_t[:, None] * towards_equator
    n_particles = max(2, round(2 * n_points / coordination))
    volume_particle = (4 / 3 * np.pi * radius**3) if dimension == 3 else np.pi * radius**2
    solid_fraction = 0.6 if dimension == 3 else 0.8
    volume = n_particles * volume_particle / solid_fraction
    side = volume ** (1.0 / dimension)
    positions = rng.uniform(0.0, side, (n_particles, dimension))
    first = rng.integers(0, n_particles, n_points)
    second = (first + rng.integers(1, n_particles, n_points)) % n_particles
    branch = 2.0 * radius * normal
    return ContactNetwork(
        positions=positions,
        volumes=np.full(n_particles, volume_particle),
        volume=volume,
        pair_particles=np.column_stack([first, second]),
        pair_branches=branch,
        point_pairs=np.arange(n_points),
        point_positions=positions[first] + radius * normal,
        point_normals=normal,
        point_forces=forces,
        friction_coefficient=friction_coefficient,
        state={"synthetic": True, "imposed_a_c": a_c, "imposed_a_fn": a_fn,
               "imposed_a_ft": a_ft},
    )


def cubic_lattice(n: int = 5, radius: float = 1.0, forces=(1.0, 1.0, 1.0),
                  friction_coefficient: float = 0.4) -> ContactNetwork:
    """n^3 spheres of radius R [m] on a simple cubic lattice of spacing 2R in the box
    [0, 2Rn]^3, every neighbour pair and every sphere of the outer layers against its wall
    pressed by the normal force forces[a] [N] along axis a: each sphere is in equilibrium, and
    sigma = diag(forces) / (4 R^2). Pairs typed "s" (one type)."""
    spacing = 2.0 * radius
    index = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    positions = (index + 0.5) * spacing
    number = {tuple(k): i for i, k in enumerate(index.tolist())}
    pairs, branches, normals, f, points = [], [], [], [], []
    wall_particles, wall_points, wall_normals, wall_forces = [], [], [], []
    for i, k in enumerate(index.tolist()):
        for a in range(3):
            e = np.eye(3)[a]
            up = list(k)
            up[a] += 1
            if tuple(up) in number:
                pairs.append((i, number[tuple(up)]))
                branches.append(spacing * e)
                normals.append(e)
                f.append(forces[a] * e)
                points.append(positions[i] + radius * e)
            if k[a] in (0, n - 1):  # against the wall below (normal +e) or above (-e)
                sign = 1.0 if k[a] == 0 else -1.0
                wall_particles.append(i)
                wall_points.append(positions[i] - sign * radius * e)
                wall_normals.append(sign * e)
                wall_forces.append(sign * forces[a] * e)
    return ContactNetwork.from_arrays(
        positions=positions, volumes=np.full(n**3, 4.0 / 3.0 * np.pi * radius**3),
        volume=(spacing * n) ** 3, pair_particles=pairs, pair_branches=branches,
        point_pairs=np.arange(len(pairs)), point_positions=points, point_normals=normals,
        point_forces=f, pair_types=np.zeros(len(pairs), dtype=int), type_names=("s",),
        friction_coefficient=friction_coefficient, wall_particles=wall_particles,
        wall_points=wall_points,
        wall_normals=wall_normals, wall_forces=wall_forces, box_lower=np.zeros(3),
        box_upper=np.full(3, spacing * n))
