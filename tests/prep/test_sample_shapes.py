"""The makers of a loose sample's particles, one per shape kind: the keywords each takes, the
library of the right kind and size, how the particles are named in messages."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.shape_kinds import SHAPE_KINDS
from grainlab.errors import InputError
from grainlab.prep.loose_sample import loose_sample
from grainlab.prep.sample_shapes import SAMPLE_SHAPES, particles_text, sample_shape

PARAMETERS = {"sphere": {}, "aggregate": {"eta": 0.4},
              "polyhedron": {"n_faces": 8, "templates": 1}, "disc": {}}


@pytest.mark.parametrize("kind", SHAPE_KINDS, ids=lambda k: k.name)
def test_each_maker_makes_shapes_of_its_kind_of_the_bounding_radii(kind):
    radii = np.array([1e-3, 1.5e-3, 2e-3])
    library, description = sample_shape(kind.name).make_library(
        radii, np.random.default_rng(1), **PARAMETERS[kind.name])
    assert library.kind.tolist() == [kind.code] * 3
    np.testing.assert_allclose(library.bounding_radius, radii, rtol=1e-12)
    assert description["shape"] == kind.name
    assert set(PARAMETERS[kind.name]) <= set(description)


def test_a_maker_takes_exactly_its_keywords():
    maker = sample_shape("aggregate")
    with pytest.raises(InputError, match="exactly eta"):
        maker.make_library(np.ones(2), np.random.default_rng(0), eta=0.4, n_faces=8)
    with pytest.raises(InputError, match="exactly eta"):
        maker.make_library(np.ones(2), np.random.default_rng(0))


def test_only_spheres_are_placed_without_orientations():
    assert {name: s.oriented for name, s in SAMPLE_SHAPES.items()} == {
        "sphere": False, "aggregate": True, "polyhedron": True, "disc": False}
    assert loose_sample(n_particles=5, seed=1).state.orientations[:, 0].tolist() == [1.0] * 5


def test_unknown_shapes_are_refused_naming_the_makers():
    with pytest.raises(InputError) as error:
        loose_sample(shape="cube", n_particles=5)
    assert error.value.field == "shape"
    assert error.value.allowed == "one of 'sphere', 'aggregate', 'polyhedron', 'disc'"


@pytest.mark.parametrize(("specimen", "text"), [
    ({"shape": "sphere"}, "spheres"), ({"shape": "aggregate", "eta": 0.4}, "aggregates"),
    ({"shape": "polyhedron", "n_faces": 30}, "polyhedra of 30 faces"),
    ({"shape": "polyhedron"}, "polyhedra"), ({"shape": "ellipsoid"}, "ellipsoid"), ({}, ""),
])
def test_particles_named_in_messages(specimen, text):
    assert particles_text(specimen) == text
