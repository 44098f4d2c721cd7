"""Samples of one series: every shape inscribed in the spheres of one skeleton (seeds 002
and 003, §II: "the same sphere packing is then used with each sphere serving as the
circumscribing sphere of a polyhedral particle ... inscribed with ... a random orientation").

Inscription. Particle i has its centre of mass at the centre c_i of sphere i and its
circumscribed radius about the centre of mass equal to the sphere's radius R_i: the shape
makers of :mod:`grainlab.prep.sample_shapes` scale each shape about its centre of mass so
that max |v| = R_i over the vertices v of a polyhedron (body frame, origin at the centre of
mass) and max(|c_k| + r_k) = R_i over the member spheres of an aggregate (the tetrahedral
aggregate's centre of mass is its centre). Every point of particle i is thus within R_i of
c_i, whatever the orientation: particles inscribed in non-overlapping spheres do not
overlap. (For a seed 002 polyhedron this sphere about the centre of mass is somewhat larger
than the sphere its vertices were drawn on, whose centre is off the centre of mass by up to
~10 % of the radius for n_f = 8, so the polyhedron is that much smaller than one inscribed
with its generating sphere on the skeleton's sphere; the centre of mass is what the engine
places.) Orientations are uniform on SO(3)
(:func:`~grainlab.prep.loose_sample.random_orientations`); spheres keep the identity.

Shared skeleton. The random numbers of a sample come from two independent streams spawned
from its seed (:func:`sample_streams`): the first makes the skeleton (sizes and drops of the
deposition), the second the shapes and orientations. Samples of every shape with one seed
thus share the skeleton bit for bit; only the shape changes.

>>> sample = deposited_sample(shape="aggregate", n_particles=20, eta=0.3, seed=2)
>>> sample.state.n_bodies, sample.description["preparation"]
(20, 'deposition')
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainlab._validate import at_least
from grainlab._validate import seed as check_seed
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.shape_kinds import SPHERE
from grainlab.engine.state import BodyState
from grainlab.prep.deposition import deposited_packing
from grainlab.prep.loose_sample import random_orientations
from grainlab.prep.sample_shapes import sample_shape
from grainlab.prep.sphere_skeleton import SphereSkeleton


def sample_streams(seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    """(skeleton, shapes): two independent generators spawned from ``seed`` (module
    docstring)."""
    skeleton, shapes = np.random.SeedSequence(check_seed("seed", seed)).spawn(2)
    return np.random.default_rng(skeleton), np.random.default_rng(shapes)


def inscribed_sample(
    skeleton: SphereSkeleton, *, shape: str = SPHERE.name, eta: float = 0.4,
    n_faces: int = 30, templates: int = 0, density: float = 2600.0,
    wall_friction: float = 0.0, seed: int = 0, rng: np.random.Generator | None = None,
) -> DiscreteSample:
    """A sample of ``shape`` particles inscribed in the spheres of ``skeleton`` (module
    docstring), in a box of walls at the skeleton's box.

    Parameters
    ----------
    skeleton:
        The spheres: each particle's centre of mass at a centre, its circumscribed radius a
        radius [m].
    shape, eta, n_faces, templates:
        The shape kind and its parameters, as
        :func:`~grainlab.prep.loose_sample.loose_sample`.
    density:
        Particle density [kg/m^3].
    wall_friction:
        Coulomb coefficient of the walls.
    seed, rng:
        The shapes and orientations come from ``rng`` when given, else from the second
        stream of ``seed`` (:func:`sample_streams`).
    """
    maker = sample_shape(shape)
    density = at_least("density", density)
    if rng is None:
        _, rng = sample_streams(seed)
    radii = skeleton.radii
    n = skeleton.n_spheres
    parameters = {"eta": eta, "n_faces": n_faces, "templates": templates}
    library, description = maker.make_library(
        radii.copy(), rng, **{key: parameters[key] for key in maker.parameters})
    orientations = random_orientations(n, rng) if maker.oriented else None
    state = BodyState.from_library(library, np.arange(n), skeleton.centres.copy(), density,
                                   orientations)
    box = WallBox(skeleton.lower, skeleton.upper,
                  friction=at_least("wall_friction", wall_friction, strict=False))
    box.set_masses(float(np.sum(state.masses)))
    description.update({"n_particles": n, "d_min": float(2.0 * radii.min()),
                        "d_max": float(2.0 * radii.max()), "density": density,
                        "skeleton_packing_fraction": skeleton.packing_fraction,
                        "seed": int(seed)})
    return DiscreteSample(library, state, box, description)


def deposited_sample(
    *, shape: str = SPHERE.name, n_particles: int = 1000, d_min: float = 1e-3,
    size_ratio: float = 2.0, height_ratio: float = 1.0, eta: float = 0.4,
    n_faces: int = 30, templates: int = 0, density: float = 2600.0,
    wall_friction: float = 0.0, seed: int = 0,
) -> DiscreteSample:
    """A sample of ``shape`` particles inscribed in a deposited sphere packing
    (:func:`~grainlab.prep.deposition.deposited_packing` of ``n_particles`` spheres of
    diameters uniform by volume in [d_min, size_ratio d_min] [m], box height about
    ``height_ratio`` times its width), both from ``seed`` (:func:`sample_streams`); the other
    keywords as :func:`inscribed_sample`."""
    skeleton_rng, shapes_rng = sample_streams(seed)
    packing = deposited_packing(n_particles=n_particles, d_min=d_min, size_ratio=size_ratio,
                                height_ratio=height_ratio, seed=skeleton_rng)
    sample = inscribed_sample(packing.skeleton, shape=shape, eta=eta, n_faces=n_faces,
                              templates=templates, density=density,
                              wall_friction=wall_friction, seed=seed, rng=shapes_rng)
    extra: dict[str, Any] = {"preparation": "deposition", "size_ratio": float(size_ratio)}
    sample.description.update(extra)
    return sample
