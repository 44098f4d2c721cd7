"""Convex polyhedra and seed 002's random polyhedra (Sec. II.A, Table I).

Closed forms for a cube, a box and a regular tetrahedron; a quasi-Monte-Carlo twin for a
random hull; invariance under rigid motions; angularity of Platonic solids; Table I's mean
angularity; topology and the axis-ratio criterion; bad input.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import qmc

from grainlab.errors import InputError
from grainlab.geometry.polyhedron import (
    TABLE_I,
    ConvexPolyhedron,
    from_vertices,
    random_polyhedron,
)

BOX = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
TETRA = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
PHI = (1.0 + math.sqrt(5.0)) / 2.0
ICOSA = np.array(
    [p for s1 in (-1, 1) for s2 in (-1, 1) for p in ([0, s1, s2 * PHI], [s1, s2 * PHI, 0],
                                                     [s2 * PHI, 0, s1])],
    dtype=float,
)


def test_box_closed_form():
    sides = np.array([3.0, 1.0, 2.0])
    shape = from_vertices(BOX * sides + [5.0, -1.0, 2.0])
    volume = float(np.prod(sides))
    assert shape.volume == pytest.approx(volume, rel=1e-13)
    a, b, c = sides
    expected = np.sort(volume / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b]))
    np.testing.assert_allclose(shape.principal_moments, expected, rtol=1e-12)
    np.testing.assert_allclose(shape.centre_of_mass, [6.5, -0.5, 3.0], atol=1e-13)
    np.testing.assert_allclose(shape.axis_lengths, [3.0, 2.0, 1.0], atol=1e-12)
    assert shape.surface_area == pytest.approx(2 * (a * b + b * c + a * c), rel=1e-13)
    assert shape.angularity == pytest.approx(math.pi / 2, abs=1e-12)
    assert shape.vertices.mean(axis=0) == pytest.approx(np.zeros(3), abs=1e-13)


def test_cube_closed_form():
    shape = from_vertices(2.0 * BOX)
    assert shape.volume == pytest.approx(8.0, rel=1e-13)
    np.testing.assert_allclose(shape.principal_moments, np.full(3, 8.0 * 8.0 / 12.0), rtol=1e-12)
    assert shape.angularity == pytest.approx(math.pi / 2, abs=1e-12)
    assert shape.n_faces == 12 and shape.n_edges == 18  # qhull splits each square
    assert np.sum(shape.edge_angles > 1e-7) == 12
    assert shape.sphericity == pytest.approx(math.pi ** (1 / 3) * 6 ** (2 / 3) / 6, rel=1e-12)
    assert shape.circumscribed_radius == pytest.approx(math.sqrt(3.0), rel=1e-13)
    assert "angularity" in shape.describe()


def test_regular_tetrahedron_closed_form():
    shape = from_vertices(TETRA)
    edge = 2.0 * math.sqrt(2.0)
    volume = edge**3 / (6.0 * math.sqrt(2.0))
    assert shape.volume == pytest.approx(volume, rel=1e-13)
    np.testing.assert_allclose(shape.principal_moments, np.full(3, volume * edge**2 / 20.0),
                               rtol=1e-12)
    assert shape.angularity == pytest.approx(math.pi - math.acos(1.0 / 3.0), abs=1e-12)
    assert shape.n_faces == 4 and shape.n_edges == 6


def test_icosahedron_angularity():
    shape = from_vertices(ICOSA)
    assert shape.n_vertices == 12 and shape.n_faces == 20 and shape.n_edges == 30
    dihedral = math.acos(-math.sqrt(5.0) / 3.0)
    assert shape.angularity == pytest.approx(math.pi - dihedral, abs=1e-12)  # 0.7297 rad


def test_monte_carlo_twin():
    shape = random_polyhedron(20, np.random.default_rng(7), circumscribed_diameter=2.0)
    normals = shape.face_normals
    offsets = np.einsum("ij,ij->i", normals, shape.vertices[shape.faces[:, 0]])
    low, high = shape.vertices.min(axis=0), shape.vertices.max(axis=0)
    box_volume = float(np.prod(high - low))
    points = qmc.scale(qmc.Sobol(3, seed=3).random_base2(20), low, high)
    count, first, second = 0, np.zeros(3), np.zeros((3, 3))
    for chunk in np.array_split(points, 8):
        inside = chunk[np.all(chunk @ normals.T <= offsets, axis=1)]
        count += len(inside)
        first += inside.sum(axis=0)
        second += inside.T @ inside
    weight = box_volume / len(points)
    volume = count * weight
    assert volume == pytest.approx(shape.volume, rel=5e-3)
    assert np.linalg.norm(first * weight / volume) < 5e-3
    second *= weight
    inertia = np.trace(second) * np.eye(3) - second
    np.testing.assert_allclose(np.diag(inertia), shape.principal_moments, rtol=5e-3)
    off = inertia - np.diag(np.diag(inertia))
    assert np.max(np.abs(off)) < 5e-3 * shape.principal_moments.max()


def test_invariance_under_rigid_motion():
    rng = np.random.default_rng(11)
    points = rng.normal(size=(30, 3))
    base = from_vertices(points)
    rotation = Rotation.random(random_state=5).as_matrix()
    moved = from_vertices(points @ rotation.T + [3.0, -7.0, 0.5])
    assert moved.volume == pytest.approx(base.volume, rel=1e-12)
    np.testing.assert_allclose(moved.principal_moments, base.principal_moments, rtol=1e-11)
    np.testing.assert_allclose(moved.axis_lengths, base.axis_lengths, rtol=1e-10)
    assert moved.angularity == pytest.approx(base.angularity, rel=1e-12)
    assert moved.sphericity == pytest.approx(base.sphericity, rel=1e-12)
    np.testing.assert_allclose(moved.centre_of_mass,
                               rotation @ base.centre_of_mass + [3.0, -7.0, 0.5], atol=1e-12)
    # the body frames agree up to the sign of each axis
    body = np.sort(np.abs(base.vertices), axis=0)
    np.testing.assert_allclose(np.sort(np.abs(moved.vertices), axis=0), body, atol=1e-11)
    # the input frame is recovered from the body frame: every vertex is an input point
    back = moved.centre_of_mass + moved.vertices @ moved.rotation.T
    moved_points = points @ rotation.T + [3.0, -7.0, 0.5]
    distance = np.linalg.norm(back[:, None, :] - moved_points[None, :, :], axis=2)
    assert np.max(np.min(distance, axis=1)) < 1e-11


def test_faces_outward_and_closed():
    shape = random_polyhedron(46, np.random.default_rng(3))
    centres = shape.vertices[shape.faces].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", shape.face_normals, centres) > 0.0)
    assert shape.n_edges == 3 * shape.n_vertices - 6
    assert np.all(shape.edge_faces[:, 0] != shape.edge_faces[:, 1])


@pytest.mark.parametrize("n_faces", [596, 176, 96, 46, 30, 20, 8])
def test_topology_and_axis_criterion(n_faces):
    rng = np.random.default_rng(n_faces)
    for _ in range(3):
        shape = random_polyhedron(n_faces, rng, circumscribed_diameter=0.2)
        assert shape.n_faces == n_faces == 2 * shape.n_vertices - 4
        assert min(shape.axis_ratios) >= 0.9
        big, mid, small = shape.axis_lengths
        assert big >= mid >= small
        # every vertex on the generating sphere of diameter d
        points = shape.centre_of_mass + shape.vertices @ shape.rotation.T
        np.testing.assert_allclose(np.linalg.norm(points, axis=1), 0.1, rtol=1e-12)
        assert shape.circumscribed_radius >= 0.1 - 1e-12


SAMPLES = {596: 100, 176: 100, 96: 100, 46: 100, 30: 100, 20: 100}


@pytest.mark.parametrize("n_faces", list(SAMPLES))
def test_table_one_mean_angularity(n_faces):
    """Mean angularity over a fixed-seed sample within 5 % of seed 002's Table I."""
    rng = np.random.default_rng(2002 + n_faces)
    alphas = [random_polyhedron(n_faces, rng).angularity for _ in range(SAMPLES[n_faces])]
    assert np.mean(alphas) == pytest.approx(TABLE_I[n_faces], rel=0.05)


@pytest.mark.long
def test_table_one_octahedra_deviate():
    """n_f = 8: random 6-vertex hulls that pass the criterion have a mean exterior angle of
    ~1.27 rad, above the regular octahedron's pi - arccos(-1/3) = 1.231 rad, whereas Table I
    gives 1.181 (7 % lower). The seed's value is not reproduced by this reading; the test pins
    our value so that a change is noticed."""
    rng = np.random.default_rng(2010)
    alphas = [random_polyhedron(8, rng).angularity for _ in range(30)]
    octahedron = math.pi - math.acos(-1.0 / 3.0)
    assert np.mean(alphas) > octahedron
    assert np.mean(alphas) == pytest.approx(1.27, rel=0.03)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"n_faces": 7}, "n_faces"),
        ({"n_faces": 2}, "n_faces"),
        ({"n_faces": 8.0}, "n_faces"),
        ({"n_faces": 8, "circumscribed_diameter": -1.0}, "circumscribed_diameter"),
        ({"n_faces": 8, "min_axis_ratio": 1.5}, "min_axis_ratio"),
        ({"n_faces": 8, "max_tries": 0}, "max_tries"),
        ({"n_faces": 8, "rng": 3}, "rng"),
    ],
)
def test_random_polyhedron_bad_input(kwargs, field):
    kwargs = {"rng": np.random.default_rng(0), **kwargs}
    with pytest.raises(InputError) as info:
        random_polyhedron(**kwargs)
    assert info.value.field == field
    assert field in str(info.value)


@pytest.mark.parametrize(
    ("points", "field"),
    [
        (np.zeros((3, 3)), "points"),
        (np.zeros((5, 2)), "points"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], "points"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, np.nan]], "points[3]"),
    ],
)
def test_from_vertices_bad_input(points, field):
    with pytest.raises(InputError) as info:
        from_vertices(points)
    assert info.value.field == field


def test_frozen_and_read_only():
    shape = from_vertices(TETRA)
    assert isinstance(shape, ConvexPolyhedron)
    with pytest.raises(AttributeError):
        shape.volume = 2.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        shape.vertices[0, 0] = 1.0


@pytest.mark.parametrize("lift", [2e-8, 5e-8])
def test_a_face_merged_from_nearly_coplanar_triangles_is_a_supporting_plane(lift):
    # one corner of the cube's top lifted by `lift`: its two triangles meet at an exterior
    # angle below COPLANAR_ANGLE and are merged into one quad that is not quite planar; the
    # quad's plane must still leave every vertex on its inner side, as ShapeLibrary checks
    from grainlab.engine.state import ShapeLibrary

    points = BOX.copy()
    points[7, 2] += lift  # the corner (1, 1, 1)
    body = from_vertices(points)
    start, _ = body.polygon_csr
    assert body.n_polygons == 6 and np.diff(start).max() == 4
    heights = body.vertices @ body.polygon_normals.T - body.polygon_offsets[None, :]
    assert heights.max() <= 1e-15
    # the merged top: the face whose own vertices spread about its plane (the others are flat)
    spread = [np.ptp(heights[ids, k]) for k, ids in enumerate(body.polygon_faces)]
    top = int(np.argmax(spread))
    ids = body.polygon_faces[top]
    assert spread[top] > 0.2 * lift and sorted(spread)[-2] < 1e-15
    assert np.isclose(heights[ids, top].max(), 0.0, atol=1e-15)  # it touches its highest vertex
    ShapeLibrary.from_polyhedra([body])  # accepted: a convex shape with supporting planes
