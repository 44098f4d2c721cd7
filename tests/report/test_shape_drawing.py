"""Body-frame drawings of shapes: the icosphere's counts, closure and winding, and the
member-sphere drawer of spheres and aggregates."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.shape_kinds import AGGREGATE
from grainlab.engine.state import ShapeLibrary
from grainlab.errors import InputError
from grainlab.report.shape_drawing import (
    check_subdivisions,
    concatenated_ranges,
    icosphere,
    library_meshes,
)


@pytest.mark.parametrize("level", [0, 1, 2, 3])
def test_icosphere_is_a_closed_outward_unit_sphere(level):
    vertices, triangles = icosphere(level)
    assert vertices.shape == (10 * 4**level + 2, 3)
    assert triangles.shape == (20 * 4**level, 3)
    np.testing.assert_allclose(np.linalg.norm(vertices, axis=1), 1.0, rtol=1e-14)
    # closed: every undirected edge is shared by exactly two triangles, once each way
    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    assert len({tuple(e) for e in directed.tolist()}) == len(directed)
    assert {tuple(e) for e in directed[:, ::-1].tolist()} == {tuple(e) for e in directed.tolist()}
    # outward winding: the enclosed volume (divergence theorem) is positive and near 4 pi / 3
    p = vertices[triangles]
    volume = np.einsum("ti,ti->", p[:, 0], np.cross(p[:, 1], p[:, 2])) / 6.0
    assert 0.6 * 4 / 3 * np.pi < volume < 4 / 3 * np.pi
    assert not vertices.flags.writeable


def test_member_spheres_of_an_aggregate_in_the_body_frame():
    offsets = np.array([[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]])
    radii = np.array([0.4, 0.2])
    aggregate = ShapeLibrary(
        kind=[AGGREGATE.code], sphere_start=[0], sphere_count=[2], sphere_offsets=offsets,
        sphere_radii=radii, volume=[0.3], principal_inertia=[[0.01, 0.02, 0.02]],
        bounding_radius=[0.9])
    library = aggregate.concatenate(ShapeLibrary.from_spheres([1.0]))
    meshes = library_meshes(library, subdivisions=0)
    assert meshes.vertex_start.tolist() == [0, 24, 36]
    assert meshes.triangle_start.tolist() == [0, 40, 60]
    for m in range(2):
        rows = np.flatnonzero(meshes.member[:24] == m)
        np.testing.assert_allclose(np.linalg.norm(meshes.vertices[rows] - offsets[m], axis=1),
                                   radii[m])
    # triangles are counted from the shape's own first vertex
    assert meshes.triangles[:40].max() == 23 and meshes.triangles[40:].max() == 11
    points = library_meshes(library, as_points=True)
    np.testing.assert_array_equal(points.vertices, [[0.5, 0, 0], [-0.5, 0, 0], [0, 0, 0]])
    np.testing.assert_array_equal(points.radius, [0.4, 0.2, 1.0])
    assert points.triangles.shape == (0, 3)


def test_helpers_and_bad_levels():
    assert concatenated_ranges(np.array([3, 0, 9]), np.array([0, 2, 1])).tolist() == [0, 1, 9]
    assert concatenated_ranges(np.zeros(0, dtype=int), np.zeros(0, dtype=int)).size == 0
    for bad in (-1, 5, 1.0, True):
        with pytest.raises(InputError, match="subdivisions"):
            check_subdivisions(bad)
