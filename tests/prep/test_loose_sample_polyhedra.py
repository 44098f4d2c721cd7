"""Loose samples of seed 002 random polyhedra: one shape per particle or K templates,
circumscribed diameters from the size distribution, exact scaling of mass properties,
placement without overlap of the circumscribed spheres, named bad input."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.shape_kinds import POLYHEDRON
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import random_polyhedron
from grainlab.prep.loose_sample import loose_sample
from grainlab.prep.sample_shapes import scaled_polyhedron


def shape_signatures(library) -> np.ndarray:
    """Rotation- and scale-free fingerprint of each shape: its sorted vertex distances from
    the centre of mass over the circumscribed radius."""
    out = []
    for s in range(library.n_shapes):
        v = library.vertices[library.vertex_start[s]:library.vertex_start[s]
                             + library.vertex_count[s]]
        r = np.linalg.norm(v, axis=1)
        out.append(np.round(np.sort(r / r.max()), 9))
    return np.array(out)


@pytest.mark.parametrize("n_faces", [20, 46])
def test_every_particle_its_own_polyhedron(n_faces):
    sample = loose_sample(shape="polyhedron", n_particles=24, n_faces=n_faces, d_min=1e-3,
                          seed=5)
    library, state = sample.library, sample.state
    assert np.all(library.kind == POLYHEDRON.code)
    assert np.all(library.vertex_count == (n_faces + 4) // 2)
    assert np.all(library.face_count == n_faces)  # points in general position: triangles
    assert len(np.unique(shape_signatures(library), axis=0)) == 24
    # circumscribed diameters (about the centre of mass) in [d_min, 2 d_min]
    d = 2.0 * library.bounding_radius
    assert d.min() >= 1e-3 * (1 - 1e-12) and d.max() <= 2e-3 * (1 + 1e-12)
    for s in range(library.n_shapes):
        v = library.vertices[library.vertex_start[s]:library.vertex_start[s]
                             + library.vertex_count[s]]
        assert np.max(np.linalg.norm(v, axis=1)) == pytest.approx(library.bounding_radius[s])
    # random orientations, masses from the exact volumes
    assert not np.allclose(state.orientations, [1, 0, 0, 0])
    np.testing.assert_allclose(state.masses, 2600.0 * library.volume)
    assert sample.description["n_faces"] == n_faces


def test_templates_are_reused_in_random_orientations():
    sample = loose_sample(shape="polyhedron", n_particles=40, n_faces=8, templates=2, seed=2)
    signatures = shape_signatures(sample.library)
    assert len(np.unique(signatures, axis=0)) == 2
    assert np.all(sample.library.vertex_count == 6)
    assert sample.description["templates"] == 2
    q = sample.state.orientations
    assert len(np.unique(np.round(q, 9), axis=0)) == 40


def test_circumscribed_spheres_do_not_overlap_and_stay_in_the_box():
    sample = loose_sample(shape="polyhedron", n_particles=80, n_faces=30, templates=4, seed=9)
    x, r = sample.state.positions, sample.library.bounding_radius[sample.state.shape_ids]
    gaps = np.linalg.norm(x[:, None] - x[None], axis=2) - (r[:, None] + r[None])
    np.fill_diagonal(gaps, np.inf)
    assert gaps.min() > 0.0
    assert np.all(x - r[:, None] >= sample.box.lower)
    assert np.all(x + r[:, None] <= sample.box.upper)


def test_scaling_is_exact():
    shape = random_polyhedron(30, np.random.default_rng(3))
    scaled = scaled_polyhedron(shape, 3e-3)
    k = 1.5e-3 / shape.circumscribed_radius
    assert scaled.circumscribed_radius == pytest.approx(1.5e-3, rel=1e-12)
    assert scaled.volume == pytest.approx(shape.volume * k**3, rel=1e-10)
    np.testing.assert_allclose(scaled.principal_moments, shape.principal_moments * k**5,
                               rtol=1e-9)
    assert scaled.angularity == pytest.approx(shape.angularity, rel=1e-9)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"n_faces": 7}, "n_faces"), ({"n_faces": 6}, "n_faces"), ({"n_faces": 30.0}, "n_faces"),
    ({"templates": -1}, "templates"), ({"shape": "cube"}, "shape"),
])
def test_bad_input_names_the_field(kwargs, field):
    arguments = {"shape": "polyhedron", "n_particles": 5, **kwargs}
    with pytest.raises(InputError) as error:
        loose_sample(**arguments)
    assert error.value.field == field
