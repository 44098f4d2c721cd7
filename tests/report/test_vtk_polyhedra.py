"""Polyhedra in ParaView files, read back with meshio: true faceted shapes (hull vertices in
the world frame, one polygon per planar face, faces matching the convex hull), mixed with
spheres, as points, and polyhedron contact points merged into one line per pair."""

from __future__ import annotations

import math

import meshio
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from grainlab.engine.state import ShapeLibrary
from grainlab.geometry.polyhedron import from_vertices, random_polyhedron
from grainlab.report.vtk_export import ContactLines, write_vtk_frame

CUBE = from_vertices([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])


def rotation(axis, angle):
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    q = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * k])
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return q, np.eye(3) + math.sin(angle) * skew + (1 - math.cos(angle)) * skew @ skew


def polygons_of(mesh) -> list[np.ndarray]:
    return [cell for block in mesh.cells if block.type in ("triangle", "quad", "polygon")
            for cell in block.data]


def test_polyhedra_are_written_as_their_faces_in_the_world_frame(tmp_path):
    shape = random_polyhedron(20, np.random.default_rng(1), circumscribed_diameter=0.8)
    library = ShapeLibrary.from_polyhedra([CUBE, shape]).concatenate(
        ShapeLibrary.from_spheres([0.3]))
    q1, r1 = rotation([1, 2, 3], 0.7)
    q2, r2 = rotation([0, 1, -1], 2.1)
    positions = np.array([[0.0, 0, 0], [3.0, 1, 0], [-2.0, 0, 1]])
    files = write_vtk_frame(tmp_path, 0, 0.0, positions=positions,
                            orientations=[q1, q2, [1, 0, 0, 0]], shape_ids=[0, 1, 2],
                            library=library)
    mesh = meshio.read(files["particles"])
    owner = mesh.point_data["particle_id"]
    assert len(mesh.points) == 8 + shape.n_vertices + 42
    types = {block.type: len(block) for block in mesh.cells}
    assert types["quad"] == 6  # the cube's faces are merged squares
    assert types["triangle"] == 20 + 80  # the random hull's triangles + the icosphere
    for body, (rot, poly) in enumerate(((r1, CUBE), (r2, shape))):
        mine = owner == body
        np.testing.assert_allclose(mesh.points[mine], positions[body] + poly.vertices @ rot.T,
                                   atol=1e-12)
        np.testing.assert_allclose(mesh.point_data["radius"][mine], poly.circumscribed_radius)
        hull = ConvexHull(mesh.points[mine])
        faces = [f for f in polygons_of(mesh) if np.all(owner[f] == body)]
        assert len(faces) == poly.n_polygons
        # the polygons close the hull: same area, same volume (divergence theorem), and
        # every polygon is planar and wound counter-clockwise seen from outside
        area, volume = 0.0, 0.0
        centre = mesh.points[mine].mean(axis=0)
        for face in faces:
            p = mesh.points[face]
            vector = 0.5 * sum(np.cross(p[k], p[(k + 1) % len(p)]) for k in range(len(p)))
            normal = vector / np.linalg.norm(vector)
            assert np.ptp((p - p[0]) @ normal) < 1e-12
            assert (p[0] - centre) @ normal > 0.0
            area += np.linalg.norm(vector)
            volume += (p[0] @ vector) / 3.0
        assert area == pytest.approx(hull.area, rel=1e-12)
        assert volume == pytest.approx(hull.volume, rel=1e-12)
    assert mesh.point_data["particle_id"][-42:].tolist() == [2] * 42


def test_polyhedra_as_points_carry_the_circumscribed_radius(tmp_path):
    library = ShapeLibrary.from_polyhedra([CUBE, CUBE])
    files = write_vtk_frame(tmp_path, 0, 0.0, positions=[[0, 0, 0], [2, 0, 0]],
                            orientations=[[1, 0, 0, 0]] * 2, shape_ids=[0, 1],
                            library=library, as_points=True)
    mesh = meshio.read(files["particles"])
    np.testing.assert_array_equal(mesh.points, [[0, 0, 0], [2, 0, 0]])
    np.testing.assert_allclose(mesh.point_data["radius"], math.sqrt(3) / 2)


def test_contact_points_of_a_polyhedron_pair_become_one_line():
    """Three points of a face-face pair (type 4) and one wall point (type 1) with a sphere
    pair left alone: the pair's line carries the resultant, the wall line starts at the
    force-weighted centre of its points."""
    normal = np.array([0.0, 0.0, 1.0])
    points = np.array([[0.0, 0, 1], [1.0, 0, 1], [0.0, 1, 1], [0.5, 0.5, 0], [0.2, 0.3, 0],
                       [5.0, 5, 5]])
    forces = np.array([[0.0, 0, 1], [0.1, 0, 2], [0.0, 0, 3], [0, 0, 4.0], [0, 0, 12.0],
                       [0, 0, 7.0]])
    lines = ContactLines(
        start=np.zeros((6, 3)), end=np.ones((6, 3)), force=forces,
        normal=np.tile(normal, (6, 1)), type=[0, 0, 0, 1, 1, 0],
        contact_type=[4, 4, 4, 1, 1, 0], sliding=[False] * 6)
    merged = lines.polyhedron_pairs_merged(body_i=np.array([0, 0, 0, -5, -5, 2]),
                                           body_j=np.array([1, 1, 1, 0, 0, 3]),
                                           points=points, mu=np.full(6, 0.5))
    assert merged.n_contacts == 3
    np.testing.assert_array_equal(merged.contact_type, [0, 1, 4])
    np.testing.assert_allclose(merged.force[0], [0, 0, 7.0])
    np.testing.assert_allclose(merged.force[2], [0.1, 0, 6.0])
    np.testing.assert_allclose(merged.force[1], [0, 0, 16.0])
    np.testing.assert_allclose(merged.start[1], (4 * points[3] + 12 * points[4]) / 16)
    np.testing.assert_array_equal(merged.type, [0, 1, 0])
