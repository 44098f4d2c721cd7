"""The particle shapes of a loose sample: for each shape kind of the engine's registry
(:mod:`grainlab.engine.shape_kinds`), how N particles of given bounding radii are made into a
:class:`~grainlab.engine.state.ShapeLibrary` (:data:`SAMPLE_SHAPES`, keyed by the kinds'
names; :func:`sample_shape`). The makers sit here, not in the engine's records, because the
engine does not know how samples are prepared (a lower layer never imports a higher one).

- ``sphere``: one sphere of each radius;
- ``aggregate`` (seed 003): tetrahedral aggregates of 4 overlapping spheres of non-convexity
  ``eta`` = (R - R')/R, each scaled from one exact unit aggregate to the circumscribed radius
  R (volume ~ R^3, inertia ~ R^5);
- ``polyhedron`` (seed 002 §II.A): every particle its own random convex polyhedron of
  ``n_faces`` faces (:func:`grainlab.geometry.polyhedron.random_polyhedron`, as the paper),
  or, with ``templates = K > 0``, K random polyhedra drawn once and reused (each particle
  picks one at random; the random orientation makes them distinct in the box) -- much faster
  to build for few faces (n_f = 8 keeps about one hull in 900, ~0.25 s per shape). Each shape
  is scaled so that its circumscribed sphere about the centre of mass has the drawn diameter
  d: vertices v d / (2 R_c), volume V (d / 2 R_c)^3, inertia ~ (d / 2 R_c)^5 (recomputed
  exactly).

A :class:`SampleShape` names the keywords its maker takes (``parameters``), whether the
particles are given random orientations (all but spheres) and how the particles are named in
a message (``"polyhedra of 30 faces"``).

>>> library, description = sample_shape("aggregate").make_library(
...     np.array([1e-3, 2e-3]), np.random.default_rng(0), eta=0.4)
>>> library.n_shapes, int(library.sphere_count.sum()), description["shape"]
(2, 8, 'aggregate')
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from grainlab._validate import at_least
from grainlab.engine.shape_kinds import AGGREGATE, DISC, POLYHEDRON, SPHERE, ShapeKind
from grainlab.engine.state import ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import ConvexPolyhedron, from_vertices, random_polyhedron
from grainlab.geometry.sphere_aggregate import tetrahedral_aggregate

MAX_FACES = 1000
"""Most faces a sample's polyhedra may have: above seed 002's largest (596, Table I), below
where contact detection would cost seconds per pair and hull draws dominate the run."""

MAX_ETA = 2.0 * math.sqrt(2.0) - 2.0
"""Largest non-convexity of a tetrahedral aggregate (0.828: the four spheres meet at the
centre)."""


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
        kind=np.full(n, AGGREGATE.code), sphere_start=np.arange(n) * k,
        sphere_count=np.full(n, k),
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


# --------------------------------------------------------------------------------------------
# Makers: bounding radii (N,) [m] and the sample's generator -> (library, description)
# --------------------------------------------------------------------------------------------


def sphere_sample(radii: np.ndarray, rng: np.random.Generator
                  ) -> tuple[ShapeLibrary, dict[str, Any]]:
    """One sphere per radius [m] (``rng`` unused)."""
    return ShapeLibrary.from_spheres(radii), {"shape": SPHERE.name}


def disc_sample(radii: np.ndarray, rng: np.random.Generator
                ) -> tuple[ShapeLibrary, dict[str, Any]]:
    """One disc per radius [m], all of the thickness t = their mean diameter [m] (a disc as
    thick as it is wide; :mod:`grainlab.engine.planar`); ``rng`` unused."""
    thickness = 2.0 * float(np.mean(radii))
    return ShapeLibrary.from_discs(radii, thickness), {"shape": DISC.name,
                                                       "thickness": thickness}


def aggregate_sample(radii: np.ndarray, rng: np.random.Generator, *, eta: float
                     ) -> tuple[ShapeLibrary, dict[str, Any]]:
    """One tetrahedral aggregate of non-convexity ``eta`` in [0, :data:`MAX_ETA`] per
    circumscribed radius [m] (``rng`` unused)."""
    eta_value = at_least("eta", eta, strict=False)
    if eta_value > MAX_ETA:
        raise InputError("eta", eta, "a non-convexity in [0, 0.828]")
    return aggregate_library(radii, eta_value), {"shape": AGGREGATE.name, "eta": eta_value}


def polyhedron_sample(radii: np.ndarray, rng: np.random.Generator, *, n_faces: int,
                      templates: int) -> tuple[ShapeLibrary, dict[str, Any]]:
    """One random convex polyhedron of ``n_faces`` faces per circumscribed radius [m], each
    its own or one of ``templates`` (module docstring); the description adds the mean
    angularity."""
    shapes = random_polyhedra(2.0 * radii, n_faces, rng, templates)
    library = ShapeLibrary.from_polyhedra(shapes)
    description = {"shape": POLYHEDRON.name, "n_faces": int(n_faces),
                   "templates": int(templates),
                   "mean_angularity": float(np.mean([p.angularity for p in shapes]))}
    return library, description


def _plural(kind: ShapeKind) -> Callable[[Mapping[str, Any]], str]:
    return lambda specimen: kind.plural


def _polyhedra_text(specimen: Mapping[str, Any]) -> str:
    n_faces = specimen.get("n_faces")
    return f"polyhedra of {n_faces} faces" if n_faces else POLYHEDRON.plural


@dataclass(frozen=True)
class SampleShape:
    """How the particles of a loose sample of one shape kind are made (module docstring).

    Attributes
    ----------
    kind:
        The engine's :class:`~grainlab.engine.shape_kinds.ShapeKind`.
    description:
        What the particles are, in a few words (the CLI's ``--shape`` help).
    parameters:
        Keywords of ``make`` besides the radii and the generator (``sample.<key>`` of a
        run's config, keywords of :func:`~grainlab.prep.loose_sample.loose_sample`).
    oriented:
        Whether the particles get uniformly random orientations (not spheres).
    make:
        ``make(radii (N,) [m], rng, **parameters) -> (library of N shapes, description)``;
        the description starts ``{"shape": name}`` and adds the parameters used.
    particles_text:
        The particles named in a message, from a sample description: ``"polyhedra of 30
        faces"``.
    """

    kind: ShapeKind
    description: str
    parameters: tuple[str, ...]
    oriented: bool
    make: Callable[..., tuple[ShapeLibrary, dict[str, Any]]]
    particles_text: Callable[[Mapping[str, Any]], str]

    def make_library(self, radii: np.ndarray, rng: np.random.Generator, **parameters: Any
                     ) -> tuple[ShapeLibrary, dict[str, Any]]:
        """``make`` with exactly the keywords of :attr:`parameters` (others: InputError)."""
        unknown = sorted(set(parameters) - set(self.parameters))
        missing = sorted(set(self.parameters) - set(parameters))
        if unknown or missing:
            raise InputError(f"parameters of a {self.kind.name} sample",
                             sorted(parameters), "exactly " + (", ".join(self.parameters)
                                                                 or "none"))
        return self.make(radii, rng, **parameters)


SAMPLE_SHAPES: dict[str, SampleShape] = {
    SPHERE.name: SampleShape(
        kind=SPHERE, description="one sphere per particle", parameters=(), oriented=False,
        make=sphere_sample, particles_text=_plural(SPHERE)),
    AGGREGATE.name: SampleShape(
        kind=AGGREGATE, description="4 overlapping spheres on a tetrahedron, Azéma et al. "
        "2013", parameters=("eta",), oriented=True, make=aggregate_sample,
        particles_text=_plural(AGGREGATE)),
    POLYHEDRON.name: SampleShape(
        kind=POLYHEDRON, description="random convex polyhedra, Azéma, Radjaï & Dubois 2013",
        parameters=("n_faces", "templates"), oriented=True, make=polyhedron_sample,
        particles_text=_polyhedra_text),
    DISC.name: SampleShape(
        kind=DISC, description="discs moving in a plane (2D), as thick as their mean "
        "diameter", parameters=(), oriented=False, make=disc_sample,
        particles_text=_plural(DISC)),
}
"""How a sample of each shape kind is made, keyed by the kind's name, in the registry's
order."""


def sample_shape(name: str, field: str = "shape") -> SampleShape:
    """The :class:`SampleShape` of a kind name; an InputError naming ``field`` and listing
    the names of :data:`SAMPLE_SHAPES` for any other value."""
    found = SAMPLE_SHAPES.get(name) if isinstance(name, str) else None
    if found is None:
        raise InputError(field, name, "one of " + ", ".join(repr(n) for n in SAMPLE_SHAPES))
    return found


VOLUME_FRACTION_DRAWS = 16
"""Particles drawn to estimate a shape's mean volume fraction in its circumscribed sphere
(:func:`circumscribed_volume_fraction`; polyhedra of 8 faces: 0.177 +- 0.025 over 16
draws, ~1.5 s)."""


@lru_cache(maxsize=64)
def circumscribed_volume_fraction(name: str, **parameters: Any) -> float:
    """Mean volume of a particle of shape ``name`` (and ``parameters``, as a run's
    ``sample.<key>``) over the volume of its circumscribed sphere [-]: 1 for spheres, the
    unit aggregate's for an aggregate, the mean over :data:`VOLUME_FRACTION_DRAWS` particles
    drawn with a fixed generator for random polyhedra (the same for every call).

    >>> round(circumscribed_volume_fraction("aggregate", eta=0.7), 3)
    0.456
    """
    shape = sample_shape(name)
    radii = np.ones(VOLUME_FRACTION_DRAWS)
    library, _ = shape.make_library(radii, np.random.default_rng(0), **parameters)
    return float(np.mean(library.volume / (4.0 / 3.0 * math.pi * library.bounding_radius**3)))


def particles_text(specimen: Mapping[str, Any]) -> str:
    """The particles of a sample description (``{"shape": "polyhedron", "n_faces": 30}``)
    named in a message: ``"polyhedra of 30 faces"``, ``"spheres"``; a shape no longer
    registered as it was written, ``""`` without one."""
    name = specimen.get("shape", "")
    if not name:
        return ""
    found = SAMPLE_SHAPES.get(name) if isinstance(name, str) else None
    return found.particles_text(specimen) if found is not None else str(name)

