"""Polyhedron storage in the shape library: merged planar faces, CSR arrays, concatenation,
validation (engine/state.py, geometry/polyhedron.py)."""

from dataclasses import replace

import numpy as np
import pytest

from grainlab.engine.shape_kinds import POLYHEDRON, SPHERE
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import from_vertices, random_polyhedron

CUBE = from_vertices([[x, y, z] for x in (0, 2) for y in (0, 2) for z in (0, 2)], name="cube")
TETRA = from_vertices([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], name="tetrahedron")


def _newell(points: np.ndarray) -> np.ndarray:
    """Twice the vector area of a polygon (Newell), independent of any triangulation."""
    nxt = np.roll(points, -1, axis=0)
    return np.cross(points, nxt).sum(axis=0)


@pytest.mark.parametrize("shape, n_poly, n_edges", [(CUBE, 6, 12), (TETRA, 4, 6)])
def test_merged_faces_of_cube_and_tetrahedron(shape, n_poly, n_edges):
    assert shape.n_polygons == n_poly
    assert shape.polygon_edges.shape == (n_edges, 2)
    for face, normal, offset in zip(shape.polygon_faces, shape.polygon_normals,
                                    shape.polygon_offsets, strict=True):
        points = shape.vertices[face]
        area = _newell(points)
        # counter-clockwise seen from outside: the Newell normal points along the normal
        assert np.dot(area, normal) > 0.0
        np.testing.assert_allclose(area / np.linalg.norm(area), normal, atol=1e-12)
        np.testing.assert_allclose(points @ normal, offset, atol=1e-12)
    if shape is CUBE:
        assert all(len(face) == 4 for face in shape.polygon_faces)
        np.testing.assert_allclose(np.abs(shape.polygon_offsets), 1.0, atol=1e-12)


def test_random_hull_polygons_cover_the_surface():
    shape = random_polyhedron(30, np.random.default_rng(4))
    total = sum(np.linalg.norm(_newell(shape.vertices[f])) / 2 for f in shape.polygon_faces)
    assert total == pytest.approx(shape.surface_area, rel=1e-12)
    # Euler: V - E + F = 2 with the solid's edges and faces
    assert shape.n_vertices - len(shape.polygon_edges) + shape.n_polygons == 2


def test_library_from_polyhedra_stores_the_boundary():
    shapes = [CUBE, TETRA, random_polyhedron(20, np.random.default_rng(0))]
    lib = ShapeLibrary.from_polyhedra(shapes)
    assert lib.kind.tolist() == [POLYHEDRON.code] * 3
    assert lib.sphere_count.tolist() == [0, 0, 0]
    for s, shape in enumerate(shapes):
        v0, f0, e0 = lib.vertex_start[s], lib.face_start[s], lib.edge_start[s]
        np.testing.assert_array_equal(lib.vertices[v0:v0 + lib.vertex_count[s]], shape.vertices)
        assert lib.face_count[s] == shape.n_polygons
        assert lib.edge_count[s] == len(shape.polygon_edges)
        for k, face in enumerate(shape.polygon_faces):
            a, b = lib.face_vertex_start[f0 + k], lib.face_vertex_start[f0 + k + 1]
            np.testing.assert_array_equal(lib.face_vertices[a:b], face)
        np.testing.assert_array_equal(lib.edges[e0:e0 + lib.edge_count[s]], shape.polygon_edges)
        radius = np.max(np.linalg.norm(shape.vertices, axis=1))
        assert lib.bounding_radius[s] == pytest.approx(radius)
        assert lib.volume[s] == shape.volume
        # each edge lies on the boundary of its two faces
        for (u, v), (f, g) in zip(lib.edges[e0:e0 + lib.edge_count[s]],
                                  lib.edge_faces[e0:e0 + lib.edge_count[s]], strict=True):
            for face in (shape.polygon_faces[f], shape.polygon_faces[g]):
                assert u in face and v in face
            assert f != g
        # neighbours: symmetric, one entry per edge end
        for v in range(lib.vertex_count[s]):
            row = lib.vertex_neighbours[lib.vertex_neighbour_start[v0 + v]:
                                        lib.vertex_neighbour_start[v0 + v + 1]]
            for w in row:
                edge = sorted((v, int(w)))
                assert any((shape.polygon_edges == edge).all(axis=1))
    assert lib.max_features == max(s.n_vertices + len(s.polygon_edges) + s.n_polygons
                                   for s in shapes)
    state = BodyState.from_library(lib, [0, 1], [[0, 0, 0], [5, 0, 0]], density=2.0)
    assert state.masses[0] == pytest.approx(16.0)


def test_mixed_library_concatenates():
    spheres = ShapeLibrary.from_spheres([0.5, 1.0])
    polys = ShapeLibrary.from_polyhedra([CUBE, TETRA])
    lib = spheres.concatenate(polys).concatenate(ShapeLibrary.from_spheres([2.0]))
    assert lib.kind.tolist() == [SPHERE.code, SPHERE.code, POLYHEDRON.code,
                                 POLYHEDRON.code, SPHERE.code]
    assert lib.vertex_count.tolist() == [0, 0, 8, 4, 0]
    assert lib.vertex_start[3] == 8 and lib.face_start[3] == 6 and lib.edge_start[3] == 12
    np.testing.assert_array_equal(lib.face_vertex_start, polys.face_vertex_start)
    np.testing.assert_array_equal(lib.vertex_neighbours, polys.vertex_neighbours)
    assert lib.sphere_radii.tolist() == [0.5, 1.0, 2.0]
    assert lib.sphere_start[4] == 2
    twice = polys.concatenate(polys)
    assert twice.face_vertex_start[-1] == 2 * polys.face_vertex_start[-1]
    assert twice.vertex_neighbour_start.shape == (2 * 12 + 1,)


def test_sphere_libraries_keep_empty_polyhedron_arrays():
    lib = ShapeLibrary.from_spheres([1.0])
    assert lib.vertices.shape == (0, 3) and lib.face_vertex_start.tolist() == [0]
    assert lib.max_features == 0


def test_bad_polyhedron_input_names_the_field():
    lib = ShapeLibrary.from_polyhedra([CUBE])
    with pytest.raises(InputError, match="face_offsets"):
        replace(lib, face_offsets=lib.face_offsets - 0.1)  # a vertex outside a face
    with pytest.raises(InputError, match="face_vertices"):
        replace(lib, face_vertices=lib.face_vertices + 3)
    with pytest.raises(InputError, match="face_normals"):
        replace(lib, face_normals=2.0 * lib.face_normals)
    with pytest.raises(InputError, match="sphere_count"):
        replace(lib, sphere_count=np.ones(1, dtype=np.int64))
    with pytest.raises(InputError, match="vertex_start"):
        replace(lib, vertex_count=np.array([3]))
    with pytest.raises(InputError, match="face_vertex_start"):
        replace(lib, face_vertex_start=lib.face_vertex_start[::-1])
    with pytest.raises(InputError, match="polyhedra"):
        ShapeLibrary.from_polyhedra([])
    with pytest.raises(InputError, match=r"polyhedra\[0\]"):
        ShapeLibrary.from_polyhedra(["cube"])
