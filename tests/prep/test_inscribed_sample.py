"""Shapes inscribed in one skeleton: every particle inside its sphere, in its drawn
orientation; the skeleton shared bit for bit by every shape of a seed; skeleton files."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.errors import InputError
from grainlab.prep.deposition import deposited_packing
from grainlab.prep.inscribed_sample import deposited_sample, inscribed_sample, sample_streams
from grainlab.prep.sphere_skeleton import SphereSkeleton, read_skeleton, write_skeleton

SERIES = {"sphere": {}, "polyhedron": {"n_faces": 8, "templates": 3},
          "aggregate": {"eta": 0.7}}


def rotation(q):
    """Rotation matrix of the unit quaternion q = (w, x, y, z) (written out here, not the
    engine's)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def farthest_points(sample, i):
    """Distance from sphere i's centre of the farthest point of particle i [m], in the
    world frame (polyhedron vertices; aggregate member spheres: centre + radius)."""
    lib, state = sample.library, sample.state
    s = state.shape_ids[i]
    turn = rotation(state.orientations[i])
    if lib.vertex_count is not None and lib.vertex_count[s] > 0:
        v = lib.vertices[lib.vertex_start[s]:lib.vertex_start[s] + lib.vertex_count[s]]
        return np.linalg.norm(v @ turn.T, axis=1).max()
    rows = slice(lib.sphere_start[s], lib.sphere_start[s] + lib.sphere_count[s])
    world = lib.sphere_offsets[rows] @ turn.T
    return (np.linalg.norm(world, axis=1) + lib.sphere_radii[rows]).max()


@pytest.fixture(scope="module")
def series():
    return {name: deposited_sample(shape=name, n_particles=40, size_ratio=3.0, seed=11,
                                   **params) for name, params in SERIES.items()}


def test_every_shape_of_a_seed_shares_the_skeleton_bit_for_bit(series):
    skeleton_rng, _ = sample_streams(11)
    packing = deposited_packing(n_particles=40, d_min=1e-3, size_ratio=3.0, seed=skeleton_rng)
    for name, sample in series.items():
        assert np.array_equal(sample.state.positions, packing.centres), name
        assert np.array_equal(sample.box.coordinates, series["sphere"].box.coordinates)
    assert np.array_equal(series["sphere"].library.sphere_radii, packing.radii)
    other = deposited_sample(shape="sphere", n_particles=40, size_ratio=3.0, seed=12)
    assert not np.array_equal(other.state.positions, packing.centres)


def test_every_particle_lies_inside_its_sphere_in_its_orientation(series):
    radii = series["sphere"].library.sphere_radii
    for name in ("polyhedron", "aggregate"):
        sample = series[name]
        q = sample.state.orientations
        assert np.allclose(np.linalg.norm(q, axis=1), 1.0)
        assert np.unique(q.round(6), axis=0).shape[0] == len(q)  # random, not one
        far = np.array([farthest_points(sample, i) for i in range(len(radii))])
        assert np.all(far <= radii * (1 + 1e-12)), name
        # circumscribed: the farthest point is on the sphere
        assert np.allclose(far, radii, rtol=1e-9), name
        # the centre of mass at the sphere's centre: a polyhedron's vertex average near it
        assert np.allclose(sample.library.bounding_radius, radii, rtol=1e-9)


def test_a_particle_outside_its_sphere_is_found(series):
    """The check can fail: an aggregate of larger eta than its sphere allows."""
    sample = series["aggregate"]
    library = dataclasses.replace(sample.library,
                                  sphere_offsets=sample.library.sphere_offsets * 1.01)
    grown = DiscreteSample(library, sample.state, sample.boundary, {})
    assert farthest_points(grown, 0) > series["sphere"].library.sphere_radii[0]


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_a_skeleton_file_gives_the_same_sample(tmp_path, suffix, series):
    skeleton_rng, _ = sample_streams(11)
    skeleton = deposited_packing(n_particles=40, d_min=1e-3, size_ratio=3.0,
                                 seed=skeleton_rng).skeleton
    path = write_skeleton(skeleton, tmp_path / f"skeleton{suffix}")
    read = read_skeleton(path)
    assert np.array_equal(read.centres, skeleton.centres)
    assert np.array_equal(read.radii, skeleton.radii)
    if suffix == ".npz":  # the box kept; a CSV gives the spheres' extent
        assert np.array_equal(read.upper, skeleton.upper)
    else:
        assert np.all(read.upper <= skeleton.upper) and np.all(read.lower >= -1e-15)
    sample = inscribed_sample(read, shape="polyhedron", seed=11, **SERIES["polyhedron"])
    expected = series["polyhedron"]
    assert np.array_equal(sample.state.positions, expected.state.positions)
    assert np.array_equal(sample.state.orientations, expected.state.orientations)
    assert np.array_equal(sample.library.vertices, expected.library.vertices)


def test_bad_skeleton_files_name_the_field(tmp_path):
    with pytest.raises(InputError) as error:
        read_skeleton(tmp_path / "none.npz", field="skeleton_file")
    assert error.value.field == "skeleton_file"
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y,radius\n0,0,1\n")
    with pytest.raises(InputError, match="header"):
        read_skeleton(bad)
    bad.write_text("x,y,z,radius\n0,0,1,-1\n")
    with pytest.raises(InputError, match="radii"):
        read_skeleton(bad)
    with pytest.raises(InputError, match="inside the box"):
        SphereSkeleton(np.zeros((1, 3)), np.ones(1), np.zeros(3), np.ones(3))
