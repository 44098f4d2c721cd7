"""Loose random samples for the discrete engine: sizes, shapes and a random placement without
overlap in a box of walls (seeds 002/003 §II.B; the seeds' geometric deposition is a later
step).

Sizes (seed 002: "diameters uniform by volume fraction in [d_min, 2 d_min]"; seed 003: R
uniform by volume in [R_min, 3 R_min]). Equal volume in every size class means a number
density p(d) proportional to d^-3 on [d_min, d_max]; with u uniform in [0, 1) the inverse of
its distribution function is

    d = (d_min^-2 - u (d_min^-2 - d_max^-2))^(-1/2)                        [m]

Or two sizes (``sizes="binary"``): a number fraction ``fine_fraction`` of the particles (the
nearest whole number) of diameter d_min, the rest of d_max = size_ratio d_min, in random order
(seed 001 ch. 3: 13 discs of radius 0.105 mm and 12 of 0.21 mm, a fraction 0.52 of fine ones).

Placement: random sequential addition of the particles' bounding spheres, largest first, in a
cube sized so that the bounding spheres fill ``packing_fraction`` of it (a loose gas, 0.2 by
default; random sequential addition jams near 0.38), with a cell grid so that each trial
costs O(1). Aggregates and polyhedra get uniformly random orientations (unit quaternions
from normalised 4-D Gaussians).

The particles' shapes are made by the maker of the shape kind
(:mod:`grainlab.prep.sample_shapes`: spheres, seed 003's tetrahedral aggregates, seed 002's
random convex polyhedra), each from its circumscribed radius.

The result is an engine :class:`~grainlab.engine.discrete_sample.DiscreteSample` (also
importable from here).

>>> sample = loose_sample(n_particles=20, seed=3)
>>> sample.state.n_bodies, bool(sample.box.volume > 0)
(20, True)
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

from grainlab._validate import at_least
from grainlab._validate import seed as check_seed
from grainlab.engine.boundaries.boundary import Boundary
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.shape_kinds import SPHERE
from grainlab.engine.state import BodyState
from grainlab.errors import InputError
from grainlab.prep.sample_shapes import sample_shape


def checked_sizes(n_particles, d_min, size_ratio) -> tuple[int, float, float]:
    """(n_particles, d_min [m], size_ratio) checked: an integer >= 1, a positive diameter,
    d_max / d_min >= 1; else :class:`InputError` naming the keyword."""
    if isinstance(n_particles, bool) or not isinstance(n_particles, int | np.integer) \
            or n_particles < 1:
        raise InputError("n_particles", n_particles, "an integer >= 1")
    d_min = at_least("d_min", d_min)
    ratio = at_least("size_ratio", size_ratio)
    if ratio < 1.0:
        raise InputError("size_ratio", size_ratio, "d_max / d_min >= 1")
    return int(n_particles), d_min, ratio


def diameters_uniform_by_volume(n: int, d_min: float, d_max: float,
                                rng: np.random.Generator) -> np.ndarray:
    """``n`` diameters [m] with equal volume in every size class of [d_min, d_max] (module
    docstring); d_max = d_min gives a monodisperse set."""
    u = rng.random(n)
    return (d_min**-2 - u * (d_min**-2 - d_max**-2)) ** -0.5


SIZE_DISTRIBUTIONS = ("uniform_volume", "binary")
"""The sizes a loose sample can take (module docstring)."""


def binary_diameters(n: int, d_min: float, d_max: float, fine_fraction: float,
                     rng: np.random.Generator) -> np.ndarray:
    """``n`` diameters [m]: round(``fine_fraction`` n) of ``d_min``, the rest of ``d_max``,
    in random order (module docstring)."""
    if isinstance(fine_fraction, bool) or not isinstance(fine_fraction, int | float) \
            or not 0.0 < fine_fraction < 1.0:
        raise InputError("fine_fraction", fine_fraction, "a number fraction in (0, 1)")
    fine = round(fine_fraction * n)
    return rng.permutation(np.concatenate([np.full(fine, d_min), np.full(n - fine, d_max)]))


def random_orientations(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 4) unit quaternions uniformly distributed on SO(3)."""
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    q[q[:, 0] < 0.0] *= -1.0
    return q


def _overlaps(separation: np.ndarray, contact: float) -> bool:
    """Whether centres ``separation`` [m] apart are closer than ``contact`` [m]."""
    return float(separation @ separation) < contact * contact


def random_sequential_placement(radii: np.ndarray, side: np.ndarray,
                                rng: np.random.Generator, max_trials: int = 20000
                                ) -> np.ndarray:
    """Centres (n, D) [m] of spheres (discs) of ``radii`` (n,) [m] placed one by one, largest
    first, at uniformly random positions inside the box [0, side] ((D,), D = 3 or 2) without
    overlapping the box or each other; raises :class:`InputError` when one cannot be placed
    in ``max_trials``."""
    n, dimension = radii.shape[0], side.shape[0]
    order = np.argsort(-radii, kind="stable")
    cell = 2.0 * float(radii.max())
    shape = np.maximum(1, np.floor(side / cell).astype(int))
    cell_size = side / shape
    grid: dict[tuple[int, ...], list[int]] = {}
    around = [np.array(offset) for offset in itertools.product((-1, 0, 1), repeat=dimension)]
    centres = np.zeros((n, dimension))
    for k in order:
        r = radii[k]
        lo, hi = np.full(dimension, r), side - r
        if np.any(hi < lo):
            raise InputError("box", side.tolist(), f"room for a particle of radius {r:g} m")
        for _ in range(max_trials):
            x = lo + rng.random(dimension) * (hi - lo)
            c = np.minimum((x / cell_size).astype(int), shape - 1)
            free = not any(
                _overlaps(centres[other] - x, r + radii[other])
                for offset in around for other in grid.get(tuple(int(v) for v in c + offset), ()))
            if free:
                centres[k] = x
                grid.setdefault(tuple(int(v) for v in c), []).append(int(k))
                break
        else:
            raise InputError("packing_fraction", "too high",
                             f"a looser initial packing: particle {int(k)} found no room in "
                             f"{max_trials} trials")
    return centres


def _box_side(bounding: np.ndarray, phi: float, ratio: np.ndarray, thickness: float | None
              ) -> np.ndarray:
    """(3,) sides [m] of the box whose bounding spheres (discs of ``thickness`` [m]: their
    areas over the box's x-y area) fill ``phi``, at the side ratios ``ratio``; a 2D box is
    as deep as the discs are thick (:mod:`grainlab.engine.planar`)."""
    floor = 2.0 * bounding.max() * 1.01
    if thickness is not None:
        area = float(np.sum(np.pi * bounding**2)) / phi
        plane = ratio[:2] * (area / float(np.prod(ratio[:2]))) ** 0.5
        return np.append(np.maximum(plane, floor), thickness)
    volume = float(np.sum(4.0 / 3.0 * np.pi * bounding**3)) / phi
    side = ratio * (volume / float(np.prod(ratio))) ** (1.0 / 3.0)
    return np.maximum(side, floor)


def loose_sample(
    *, shape: str = SPHERE.name, n_particles: int = 1000, d_min: float = 1e-3,
    size_ratio: float = 2.0, eta: float = 0.4, n_faces: int = 30, templates: int = 0,
    density: float = 2600.0,
    packing_fraction: float = 0.2, aspect: tuple[float, float, float] = (1.0, 1.0, 1.0),
    wall_friction: float = 0.0, seed: int = 0, sizes: str = "uniform_volume",
    fine_fraction: float = 0.5,
    boundary: Callable[[np.ndarray, float, float], Boundary] = WallBox.around,
) -> DiscreteSample:
    """A loose random sample in a box of fixed walls or in a periodic cell (module
    docstring).

    Parameters
    ----------
    shape:
        A name of :data:`~grainlab.prep.sample_shapes.SAMPLE_SHAPES`, such as ``"sphere"``,
        ``"aggregate"`` (seed 003's tetrahedral aggregates of 4 spheres) or ``"polyhedron"``
        (seed 002's random convex polyhedra).
    n_particles:
        Number of particles (>= 1).
    d_min, size_ratio:
        Smallest diameter [m] of the particles' bounding (circumscribed) spheres and
        d_max / d_min (>= 1);
        sizes uniform by volume (seed 002: 2; seed 003: 3).
    sizes, fine_fraction:
        ``"uniform_volume"`` (the above), or ``"binary"``: a number fraction
        ``fine_fraction`` in (0, 1) of d_min, the rest of d_max (module docstring).
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
        What holds the sample: ``(side (3,) [m], wall_friction, particle mass [kg]) ->``
        a :class:`~grainlab.engine.boundaries.boundary.Boundary` around the box [0, side],
        the ``around`` of a boundary class: :meth:`WallBox.around
        <grainlab.engine.boundaries.wall_box.WallBox.around>` (a box of six fixed walls,
        the default) or :meth:`PeriodicCell.around
        <grainlab.engine.boundaries.periodic_boundary.PeriodicCell.around>` (a periodic
        cell of the same box). A run names it by ``sample.boundary``
        (:mod:`grainlab.lab.boundary_registry`).
    wall_friction:
        Coulomb coefficient of the walls (seed 002: 0).
    seed:
        Seed of the sizes, positions and orientations.
    """
    maker = sample_shape(shape)
    n_particles, d_min, ratio = checked_sizes(n_particles, d_min, size_ratio)
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
    if sizes not in SIZE_DISTRIBUTIONS:
        raise InputError("sizes", sizes, "one of " + ", ".join(SIZE_DISTRIBUTIONS))
    radii = 0.5 * (diameters_uniform_by_volume(int(n_particles), d_min, ratio * d_min, rng)
                   if sizes == "uniform_volume" else
                   binary_diameters(int(n_particles), d_min, ratio * d_min, fine_fraction, rng))
    shape_parameters = {"eta": eta, "n_faces": n_faces, "templates": templates}
    library, description = maker.make_library(
        radii, rng, **{key: shape_parameters[key] for key in maker.parameters})
    bounding = library.bounding_radius
    side = _box_side(bounding, phi, shape_ratio, library.thickness)
    try:
        positions = random_sequential_placement(bounding, side[:library.dimension], rng)
    except InputError:
        # few particles: the box is barely wider than the largest, the walls leave no room
        raise InputError("n_particles", n_particles,
                         f"more particles, a looser start (packing_fraction, now {phi:g}) or "
                         f"another size ratio (now {ratio:g}): random placement found no "
                         f"room for all {int(n_particles)} in so small a box") from None
    orientations = random_orientations(int(n_particles), rng) if maker.oriented else None
    if library.dimension == 2:  # discs in the box's mid-plane
        positions = np.column_stack([positions, np.full(positions.shape[0], 0.5 * side[2])])
    state = BodyState.from_library(library, np.arange(int(n_particles)), positions, density,
                                   orientations)
    friction = at_least("wall_friction", wall_friction, strict=False)
    if not callable(boundary):
        raise InputError("boundary", boundary, "the around() of a boundary class, "
                         "(side, wall_friction, particle mass) -> boundary (WallBox.around)")
    box = boundary(side, friction, float(np.sum(state.masses)), **(
        {"planar": True} if library.dimension == 2 else {}))
    description.update({"n_particles": int(n_particles), "d_min": d_min,
                        "d_max": ratio * d_min, "density": density,
                        **({"sizes": sizes, "fine_fraction": float(fine_fraction)}
                           if sizes == "binary" else {}),
                        "initial_packing_fraction": phi, "seed": int(seed)})
    return DiscreteSample(library, state, box, description)
