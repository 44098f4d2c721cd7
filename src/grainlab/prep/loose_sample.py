"""Loose random samples for the discrete engine: sizes, shapes and a random placement without
overlap in a box of walls (seeds 002/003 §II.B; the seeds' geometric deposition is a later
step).

Sizes (seed 002: "diameters uniform by volume fraction in [d_min, 2 d_min]"; seed 003: R
uniform by volume in [R_min, 3 R_min]). Equal volume in every size class means a number
density p(d) proportional to d^-3 on [d_min, d_max]; with u uniform in [0, 1) the inverse of
its distribution function is

    d = (d_min^-2 - u (d_min^-2 - d_max^-2))^(-1/2)                        [m]

Placement: random sequential addition of the particles' bounding spheres, largest first, in a
cube sized so that the bounding spheres fill ``packing_fraction`` of it (a loose gas, 0.2 by
default; random sequential addition jams near 0.38), with a cell grid so that each trial
costs O(1). Aggregates and polyhedra get uniformly random orientations (unit quaternions
from normalised 4-D Gaussians).

Polyhedra (seed 002 §II.A): every particle its own random convex polyhedron of ``n_faces``
faces (:func:`grainlab.geometry.polyhedron.random_polyhedron`, as the paper), or, with
``templates = K > 0``, K random polyhedra drawn once and reused (each particle picks one at
random; the random orientation makes them distinct in the box) -- much faster to build for
few faces (n_f = 8 keeps about one hull in 900, ~0.25 s per shape). Each shape is scaled so
that its circumscribed sphere about the centre of mass has the drawn diameter d: vertices
v d / (2 R_c), volume V (d / 2 R_c)^3, inertia ~ (d / 2 R_c)^5 (recomputed exactly).

The result is an engine :class:`~grainlab.engine.discrete_sample.DiscreteSample` (also
importable from here).

>>> sample = loose_sample(n_particles=20, seed=3)
>>> sample.state.n_bodies, bool(sample.box.volume > 0)
(20, True)
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from grainlab._validate import at_least
from grainlab._validate import seed as check_seed
from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.periodic_boundary import PeriodicCell
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.wall_box import WallBox
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import ConvexPolyhedron, from_vertices, random_polyhedron
from grainlab.geometry.sphere_aggregate import tetrahedral_aggregate

SHAPES = ("sphere", "aggregate", "polyhedron")
"""Particle shapes a loose sample can be made of."""

MAX_FACES = 1000
"""Most faces a sample's polyhedra may have: above seed 002's largest (596, Table I), below
where contact detection would cost seconds per pair and hull draws dominate the run."""


def diameters_uniform_by_volume(n: int, d_min: float, d_max: float,
                                rng: np.random.Generator) -> np.ndarray:
    """``n`` diameters [m] with equal volume in every size class of [d_min, d_max] (module
    docstring); d_max = d_min gives a monodisperse set."""
    u = rng.random(n)
    return (d_min**-2 - u * (d_min**-2 - d_max**-2)) ** -0.5


def random_orientations(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 4) unit quaternions uniformly distributed on SO(3)."""
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    q[q[:, 0] < 0.0] *= -1.0
    return q


def random_sequential_placement(radii: np.ndarray, side: np.ndarray,
                                rng: np.random.Generator, max_trials: int = 20000
                                ) -> np.ndarray:
    """Centres (n, 3) [m] of spheres of ``radii`` (n,) [m] placed one by one, largest first,
    at uniformly random positions inside the box [0, side] (3,) without overlapping the box or
    each other; raises :class:`InputError` when one cannot be placed in ``max_trials``."""
    n = radii.shape[0]
    order = np.argsort(-radii, kind="stable")
    cell = 2.0 * float(radii.max())
    shape = np.maximum(1, np.floor(side / cell).astype(int))
    cell_size = side / shape
    grid: dict[tuple[int, int, int], list[int]] = {}
    centres = np.zeros((n, 3))
    for k in order:
        r = radii[k]
        lo, hi = np.full(3, r), side - r
        if np.any(hi < lo):
            raise InputError("box", side.tolist(), f"room for a particle of radius {r:g} m")
        for _ in range(max_trials):
            x = lo + rng.random(3) * (hi - lo)
            c = np.minimum((x / cell_size).astype(int), shape - 1)
            free = True
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for dz in (-1, 0, 1):
                        for other in grid.get((c[0] + dx, c[1] + dy, c[2] + dz), ()):
                            d = centres[other] - x
                            if d @ d < (r + radii[other]) ** 2:
                                free = False
                                break
                        if not free:
                            break
                    if not free:
                        break
                if not free:
                    break
            if free:
                centres[k] = x
                grid.setdefault((int(c[0]), int(c[1]), int(c[2])), []).append(int(k))
                break
        else:
            raise InputError("packing_fraction", "too high",
                             f"a looser initial packing: particle {int(k)} found no room in "
                             f"{max_trials} trials")
    return centres


@lru_cache(maxsize=16)
def _unit_aggregate(eta: float):
    """Tetrahedral aggregate of circumscribed radius 1 m (mass properties scale with size)."""
    return tetrahedral_aggregate(circumscribed_radius=1.0, eta=eta)


def aggregate_library(bounding_radii: np.ndarray, eta: float) -> ShapeLibrary:
    """One tetrahedral aggregate shape of non-convexity ``eta`` per circumscribed radius [m]
    (volume ~ R^3, inertia ~ R^5 from one exact unit aggregate)."""
    unit = _unit_aggregate(float(eta))
    s = np.asarray(bounding_radii, dtype=np.float64)
    n, k = s.shape[0], unit.n_spheres
    return ShapeLibrary(
        kind=np.full(n, 1), sphere_start=np.arange(n) * k, sphere_count=np.full(n, k),
        sphere_offsets=(s[:, None, None] * unit.centres[None]).reshape(-1, 3),
        sphere_radii=(s[:, None] * unit.radii[None]).reshape(-1),
        volume=unit.volume * s**3, principal_inertia=unit.principal_moments[None] * s[:, None]**5,
        bounding_radius=unit.bounding_radius * s,
    )


def check_n_faces(n_faces, field: str = "n_faces") -> int:
    """``n_faces`` as the face count of a seed 002 random polyhedron: an even integer in
    [8, :data:`MAX_FACES`] (Table I: 8, 20, 30, 46, 96, 176, 596; n_f = 2 n_v - 4), else
    InputError naming ``field``."""
    if isinstance(n_faces, bool) or not isinstance(n_faces, int | np.integer) \
            or not 8 <= n_faces <= MAX_FACES or n_faces % 2:
        raise InputError(field, n_faces, f"an even number of faces in [8, {MAX_FACES}] "
                                         "(n_f = 2 n_v - 4; Table I of Azéma, Radjaï & "
                                         "Dubois 2013: 8, 20, 30, 46, 96, 176, 596)")
    return int(n_faces)


def scaled_polyhedron(shape: ConvexPolyhedron, diameter: float) -> ConvexPolyhedron:
    """``shape`` scaled so that its circumscribed sphere about the centre of mass has the
    ``diameter`` [m] (mass properties recomputed exactly from the scaled vertices)."""
    factor = 0.5 * diameter / shape.circumscribed_radius
    return from_vertices(shape.vertices * factor, name=shape.name)


def random_polyhedra(diameters: np.ndarray, n_faces: int, rng: np.random.Generator,
                     templates: int = 0) -> list[ConvexPolyhedron]:
    """One seed 002 random polyhedron of ``n_faces`` faces per circumscribed diameter (n,)
    [m]: each its own (``templates`` = 0) or one of ``templates`` shapes drawn once and
    picked at random for each particle (module docstring)."""
    n_faces = check_n_faces(n_faces)
    if isinstance(templates, bool) or not isinstance(templates, int | np.integer) \
            or templates < 0:
        raise InputError("templates", templates,
                         "an integer >= 0 (0: every particle its own polyhedron)")
    d = np.asarray(diameters, dtype=np.float64)
    if templates:
        unit = [random_polyhedron(n_faces, rng) for _ in range(int(templates))]
        pick = rng.integers(0, int(templates), d.shape[0])
        return [scaled_polyhedron(unit[k], float(dk)) for k, dk in zip(pick, d, strict=True)]
    return [scaled_polyhedron(random_polyhedron(n_faces, rng), float(dk)) for dk in d]


def loose_sample(
    *, shape: str = "sphere", n_particles: int = 1000, d_min: float = 1e-3,
    size_ratio: float = 2.0, eta: float = 0.4, n_faces: int = 30, templates: int = 0,
    density: float = 2600.0,
    packing_fraction: float = 0.2, aspect: tuple[float, float, float] = (1.0, 1.0, 1.0),
    wall_friction: float = 0.0, seed: int = 0, boundary: str = "walls",
) -> DiscreteSample:
    """A loose random sample in a box of fixed walls or in a periodic cell (module
    docstring).

    Parameters
    ----------
    shape:
        ``"sphere"``, ``"aggregate"`` (seed 003's tetrahedral aggregates of 4 spheres) or
        ``"polyhedron"`` (seed 002's random convex polyhedra).
    n_particles:
        Number of particles (>= 1).
    d_min, size_ratio:
        Smallest diameter [m] of the particles' bounding (circumscribed) spheres and
        d_max / d_min (>= 1);
        sizes uniform by volume (seed 002: 2; seed 003: 3).
    eta:
        Non-convexity (R - R')/R of the aggregates, in [0, 0.828] (aggregates only).
    n_faces:
        Faces of the polyhedra, even, >= 8 (seed 002 Table I; polyhedra only).
    templates:
        0: every polyhedron its own; K > 0: K shapes reused in random orientations.
    density:
        Particle density [kg/m^3].
    packing_fraction:
        Fraction of the box filled by the bounding spheres, in (0, 0.35].
    aspect:
        Box side ratios (x, y, z).
    boundary:
        ``"walls"`` (a box of six fixed walls, :class:`~grainlab.engine.wall_box.WallBox`)
        or ``"periodic"`` (a periodic cell of the same box,
        :class:`~grainlab.engine.periodic_boundary.PeriodicCell`).
    wall_friction:
        Coulomb coefficient of the walls (seed 002: 0).
    seed:
        Seed of the sizes, positions and orientations.
    """
    if shape not in SHAPES:
        raise InputError("shape", shape, "one of " + ", ".join(SHAPES))
    if isinstance(n_particles, bool) or not isinstance(n_particles, int | np.integer) \
            or n_particles < 1:
        raise InputError("n_particles", n_particles, "an integer >= 1")
    d_min = at_least("d_min", d_min)
    ratio = at_least("size_ratio", size_ratio)
    if ratio < 1.0:
        raise InputError("size_ratio", size_ratio, "d_max / d_min >= 1")
    density = at_least("density", density)
    phi = at_least("packing_fraction", packing_fraction)
    if phi > 0.35:
        raise InputError("packing_fraction", packing_fraction,
                         "a loose initial packing fraction in (0, 0.35]")
    shape_ratio = np.asarray(aspect, dtype=np.float64)
    if shape_ratio.shape != (3,) or not np.all(np.isfinite(shape_ratio)) \
            or np.any(shape_ratio <= 0.0):
        raise InputError("aspect", aspect, "three positive box side ratios")
    rng = np.random.default_rng(check_seed("seed", seed))
    radii = 0.5 * diameters_uniform_by_volume(int(n_particles), d_min, ratio * d_min, rng)
    if shape == "sphere":
        library = ShapeLibrary.from_spheres(radii)
        description = {"shape": "sphere"}
    elif shape == "aggregate":
        eta_value = at_least("eta", eta, strict=False)
        if eta_value > 2.0 * math.sqrt(2.0) - 2.0:
            raise InputError("eta", eta, "a non-convexity in [0, 0.828]")
        library = aggregate_library(radii, eta_value)
        description = {"shape": "aggregate", "eta": eta_value}
    else:
        shapes = random_polyhedra(2.0 * radii, n_faces, rng, templates)
        library = ShapeLibrary.from_polyhedra(shapes)
        description = {"shape": "polyhedron", "n_faces": int(n_faces),
                       "templates": int(templates),
                       "mean_angularity": float(np.mean([p.angularity for p in shapes]))}
    bounding = library.bounding_radius
    volume = float(np.sum(4.0 / 3.0 * np.pi * bounding**3)) / phi
    side = shape_ratio * (volume / float(np.prod(shape_ratio))) ** (1.0 / 3.0)
    side = np.maximum(side, 2.0 * bounding.max() * 1.01)
    try:
        positions = random_sequential_placement(bounding, side, rng)
    except InputError:
        # few particles: the box is barely wider than the largest, the walls leave no room
        raise InputError("n_particles", n_particles,
                         f"more particles, a looser start (packing_fraction, now {phi:g}) or "
                         f"another size ratio (now {ratio:g}): random placement found no "
                         f"room for all {int(n_particles)} in so small a box") from None
    orientations = random_orientations(int(n_particles), rng) if shape != "sphere" else None
    state = BodyState.from_library(library, np.arange(int(n_particles)), positions, density,
                                   orientations)
    box = WallBox(np.zeros(3), side, friction=at_least("wall_friction", wall_friction,
                                                         strict=False))
    box.set_masses(float(np.sum(state.masses)))
    if boundary == "periodic":
        # the centres lie at least a radius inside every face: no overlap across the faces
        box = PeriodicCell(np.diag(side))
    elif boundary != "walls":
        raise InputError("boundary", boundary, '"walls" or "periodic"')
    if boundary == "periodic":
        description["boundary"] = boundary
    description.update({"n_particles": int(n_particles), "d_min": d_min,
                        "d_max": ratio * d_min, "density": density,
                        "initial_packing_fraction": phi, "seed": int(seed)})
    return DiscreteSample(library, state, box, description)
