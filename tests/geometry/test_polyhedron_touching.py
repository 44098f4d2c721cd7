"""Flat contacts of convex polyhedra that touch exactly (geometry/polyhedron_contact.py through
the narrow phase): a face on a face or an edge on a face at a gap of round-off only, after a
random rigid motion of the pair and with A and B in either order.

Each scene is built in a canonical frame where A's touching face lies in the plane z = 0 with
outward normal +z and B rests on it from above; the pair is then moved by a random rotation
and translation (up to ~20 body sizes from the origin) and B is shifted along the normal so
that its lowest point lies on A's face plane in the world frame, so that |g| is of the order of
the round-off of the coordinates (1e-16 to 1e-14 of the size). Expected at alert 0.05 and 1.0
body sizes: a contact, gap 0 within 1e-12 of the size, the face normal on every touching point
(from A to B), the touching points (|g| <= 1e-12 size) on the face plane inside the touching
region (the overlap polygon of the two faces for ff, at least 3 points covering most of its
area; the edge clipped to A's face for fe, exactly its two ends), the type ff or fe, and the
pruned signed distance equal to its exhaustive twin."""

import numpy as np
import pytest
from polyhedron_arrays import body_arrays
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from grainlab.engine.detect.narrow_phase import NarrowPhase
from grainlab.engine.quaternion import quat_to_matrices
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.geometry.polyhedron import from_vertices, random_polyhedron
from grainlab.geometry.polyhedron_contact import (
    TYPE_FE,
    TYPE_FF,
    signed_distance,
    signed_distance_exhaustive,
)

ALERTS = (0.05, 1.0)
"""Alert distances in body sizes."""


def _box(a, b, c, scale=1.0):
    return from_vertices([[x, y, z] for x in (0, a * scale) for y in (0, b * scale)
                          for z in (0, c * scale)], name=f"box {a} x {b} x {c}")


def _quaternion(rot):
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    x, y, z, w = Rotation.from_matrix(rot).as_quat()
    return np.array([w, x, y, z])


def _turn_to(u, v):
    """A rotation matrix taking the unit vector u to the unit vector v."""
    axis = np.cross(u, v)
    s, c = np.linalg.norm(axis), float(u @ v)
    if s < 1e-12:
        if c > 0.0:
            return np.eye(3)
        other = np.eye(3)[np.argmin(np.abs(u))]
        axis = np.cross(u, other)
        return Rotation.from_rotvec(np.pi * axis / np.linalg.norm(axis)).as_matrix()
    return Rotation.from_rotvec(np.arctan2(s, c) * axis / s).as_matrix()


def _twist(angle):
    return Rotation.from_rotvec([0.0, 0.0, angle]).as_matrix()


def _polygon(shape, f):
    """Vertices (k, 3) of planar face f of a shape (body frame), counter-clockwise."""
    return shape.vertices[shape.polygon_faces[f]]


def _solid_edges(shape):
    """(edge (2,), normals of its two faces (2, 3)) for every edge of the solid."""
    out = []
    faces = shape.polygon_faces
    for edge in shape.polygon_edges:
        owners = [f for f, ids in enumerate(faces) if edge[0] in ids and edge[1] in ids]
        out.append((edge, shape.polygon_normals[owners]))
    return out


def _place_face(shape, f, up, twist, centre_xy):
    """Rotation and position putting face f of ``shape`` in the plane z = 0 with outward
    normal +z (``up``) or -z, its centroid at ``centre_xy``, turned by ``twist`` about z."""
    normal = shape.polygon_normals[f]
    rot = _twist(twist) @ _turn_to(normal, np.array([0.0, 0.0, 1.0 if up else -1.0]))
    centroid = _polygon(shape, f).mean(axis=0)
    return rot, np.array([*centre_xy, 0.0]) - rot @ centroid


def _place_edge(shape, edge, normals, fraction, twist, centre_xy):
    """Rotation and position putting the edge (two vertex ids) of ``shape`` lowest, along the
    plane z = 0, its mid-point at ``centre_xy``: the body's down direction is the normalised
    blend (1 - fraction) n_1 + fraction n_2 of its two face normals (strictly between them:
    the edge alone supports the body)."""
    down = (1.0 - fraction) * normals[0] + fraction * normals[1]
    down /= np.linalg.norm(down)
    rot = _twist(twist) @ _turn_to(down, np.array([0.0, 0.0, -1.0]))
    middle = 0.5 * (shape.vertices[edge[0]] + shape.vertices[edge[1]])
    return rot, np.array([*centre_xy, 0.0]) - rot @ middle


def _clip(polygon, window):
    """Intersection of two convex counter-clockwise polygons (k, 2), (m, 2)
    (Sutherland-Hodgman)."""
    out = list(polygon)
    for k in range(len(window)):
        p, q = window[k], window[(k + 1) % len(window)]
        edge = q - p
        inside = [edge[0] * (x[1] - p[1]) - edge[1] * (x[0] - p[0]) >= 0.0 for x in out]
        clipped = []
        for i in range(len(out)):
            a, b = out[i], out[(i + 1) % len(out)]
            if inside[i]:
                clipped.append(a)
            if inside[i] != inside[(i + 1) % len(out)]:
                da = edge[0] * (a[1] - p[1]) - edge[1] * (a[0] - p[0])
                db = edge[0] * (b[1] - p[1]) - edge[1] * (b[0] - p[0])
                clipped.append(a + da / (da - db) * (b - a))
        out = clipped
        if not out:
            break
    return np.array(out)


def _clip_segment(a, b, window):
    """The part of segment [a, b] (2,) inside the convex counter-clockwise polygon."""
    t0, t1 = 0.0, 1.0
    for k in range(len(window)):
        p, q = window[k], window[(k + 1) % len(window)]
        edge = q - p
        fa = edge[0] * (a[1] - p[1]) - edge[1] * (a[0] - p[0])
        fb = edge[0] * (b[1] - p[1]) - edge[1] * (b[0] - p[0])
        if fa < 0.0 and fb < 0.0:
            return None
        if fa < 0.0:
            t0 = max(t0, fa / (fa - fb))
        elif fb < 0.0:
            t1 = min(t1, fa / (fa - fb))
    return np.array([a + t0 * (b - a), a + t1 * (b - a)])


def _ccw(points):
    return points[ConvexHull(points).vertices]


def _area(polygon):
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(x @ np.roll(y, -1) - y @ np.roll(x, -1))


# --------------------------------------------------------------------------------------------
# Scenes in the canonical frame: (shape A, rotation A, position A, shape B, rotation B,
# position B, "ff" or "fe", touching region in the plane z = 0: overlap polygon or segment)
# --------------------------------------------------------------------------------------------


def _face_on_face(shape_a, f, shape_b, g, twist_a, twist_b, offset_xy):
    rot_a, x_a = _place_face(shape_a, f, True, twist_a, (0.0, 0.0))
    rot_b, x_b = _place_face(shape_b, g, False, twist_b, offset_xy)
    top = _ccw((_polygon(shape_a, f) @ rot_a.T + x_a)[:, :2])
    bottom = _ccw((_polygon(shape_b, g) @ rot_b.T + x_b)[:, :2])
    return shape_a, rot_a, x_a, shape_b, rot_b, x_b, "ff", _clip(bottom, top)


def _edge_on_face(shape_a, f, shape_b, edge, normals, fraction, twist_a, twist_b, offset_xy):
    rot_a, x_a = _place_face(shape_a, f, True, twist_a, (0.0, 0.0))
    rot_b, x_b = _place_edge(shape_b, edge, normals, fraction, twist_b, offset_xy)
    top = _ccw((_polygon(shape_a, f) @ rot_a.T + x_a)[:, :2])
    ends = (shape_b.vertices[edge] @ rot_b.T + x_b)[:, :2]
    return shape_a, rot_a, x_a, shape_b, rot_b, x_b, "fe", _clip_segment(*ends, top)


def _cube_on_slab(rng, scale):
    slab, cube = _box(2, 2, 1, scale), _box(0.5, 0.5, 0.5, scale)
    return _face_on_face(slab, rng.integers(slab.n_polygons), cube, rng.integers(cube.n_polygons),
                         rng.uniform(0, 2 * np.pi), rng.uniform(0, 2 * np.pi),
                         rng.uniform(-0.6, 0.6, 2) * scale)


def _cube_edge_on_slab(rng, scale):
    slab, cube = _box(2, 2, 1, scale), _box(0.5, 0.5, 0.5, scale)
    edges = _solid_edges(cube)
    edge, normals = edges[rng.integers(len(edges))]
    return _edge_on_face(slab, rng.integers(slab.n_polygons), cube, edge, normals,
                         rng.uniform(0.15, 0.85), rng.uniform(0, 2 * np.pi),
                         rng.uniform(0, 2 * np.pi), rng.uniform(-0.6, 0.6, 2) * scale)


def _slab_on_slab(rng, scale):
    slab = _box(2, 2, 1, scale)
    # the two largest (2 x 2) faces, partly overlapping: centres 0.4 to 2.3 sizes apart
    square = [k for k in range(slab.n_polygons)
              if np.isclose(_polygon_area(slab, k), 4.0 * scale**2)]
    while True:  # an overlap of at least a tenth of a face
        shift = rng.uniform(0.3, 1.6, 2) * rng.choice([-1.0, 1.0], 2) * scale
        scene = _face_on_face(slab, rng.choice(square), slab, rng.choice(square),
                              rng.uniform(0, 2 * np.pi), rng.uniform(0, 2 * np.pi), shift)
        if len(scene[7]) >= 3 and _area(_ccw(scene[7])) >= 0.4 * scale**2:
            return scene


def _polygon_area(shape, f):
    polygon = _polygon(shape, f)
    centre = polygon.mean(axis=0)
    return 0.5 * np.linalg.norm(np.cross(polygon - centre, np.roll(polygon, -1, axis=0) - centre)
                                .sum(axis=0))


def _cube_on_cube(rng, scale):
    cube = _box(1, 1, 1, scale)
    return _face_on_face(cube, rng.integers(6), cube, rng.integers(6), rng.uniform(0, 2 * np.pi),
                         rng.uniform(0, 2 * np.pi), rng.uniform(-0.2, 0.2, 2) * scale)


_RANDOM = {}


def _random_shapes(scale):
    if scale not in _RANDOM:
        rng = np.random.default_rng(14)
        _RANDOM[scale] = [random_polyhedron(n, rng, circumscribed_diameter=scale)
                          for n in (8, 8, 30, 30)]
    return _RANDOM[scale]


def _random_face_on_face(rng, scale):
    shapes = _random_shapes(scale)
    a, b = shapes[rng.integers(4)], shapes[rng.integers(4)]
    return _face_on_face(a, rng.integers(a.n_polygons), b, rng.integers(b.n_polygons),
                         rng.uniform(0, 2 * np.pi), rng.uniform(0, 2 * np.pi), (0.0, 0.0))


def _random_edge_on_face(rng, scale):
    shapes = _random_shapes(scale)
    a, b = shapes[rng.integers(4)], shapes[rng.integers(4)]
    # an edge whose faces make an exterior angle > 0.3 rad (a blend of their normals is then
    # more than the angle tolerance away from both: the type is fe, not ff)
    edges = [(e, n) for e, n in _solid_edges(b) if np.arccos(np.clip(n[0] @ n[1], -1, 1)) > 0.3]
    edge, normals = edges[rng.integers(len(edges))]
    return _edge_on_face(a, rng.integers(a.n_polygons), b, edge, normals,
                         rng.uniform(0.3, 0.7), rng.uniform(0, 2 * np.pi),
                         rng.uniform(0, 2 * np.pi), (0.0, 0.0))


SCENES = {
    "cube on slab, ff": _cube_on_slab,
    "cube edge on slab, fe": _cube_edge_on_slab,
    "slab on slab, partial ff": _slab_on_slab,
    "cube on twisted cube, ff": _cube_on_cube,
    "random polyhedra, ff": _random_face_on_face,
    "random polyhedra, fe": _random_edge_on_face,
}


# --------------------------------------------------------------------------------------------
# The moved pair and its checks
# --------------------------------------------------------------------------------------------


def _moved_state(scene, rng, scale, swap):
    """Library and state of the scene after a random rigid motion (rotation G, translation t)
    with B shifted along the normal G e_z onto A's face plane in the world frame; returns
    (library, state, G, t)."""
    shape_a, rot_a, x_a, shape_b, rot_b, x_b = scene[:6]
    turn = Rotation.random(random_state=rng.integers(2**31)).as_matrix()
    shift = rng.normal(size=3) * rng.uniform(0.0, 20.0) * scale
    quats = [_quaternion(turn @ rot_a), _quaternion(turn @ rot_b)]
    positions = [turn @ x_a + shift, turn @ x_b + shift]
    normal = turn[:, 2]
    rots = quat_to_matrices(np.array(quats))
    top = np.max((shape_a.vertices @ rots[0].T + positions[0]) @ normal)
    low = np.min((shape_b.vertices @ rots[1].T + positions[1]) @ normal)
    positions[1] = positions[1] + (top - low) * normal
    shapes = [shape_a, shape_b]
    order = [1, 0] if swap else [0, 1]
    lib = ShapeLibrary.from_polyhedra([shapes[k] for k in order])
    state = BodyState.from_library(lib, [0, 1], [positions[k] for k in order], 1000.0,
                                   orientations=[quats[k] for k in order])
    return lib, state, turn, shift


def _check_touching(scene, lib, state, turn, shift, swap, alert, scale):
    """The contact of the moved scene at ``alert`` [m] (module docstring); returns the number
    of touching points."""
    kind, region = scene[6], scene[7]
    tol = 1e-12 * scale
    normal = turn[:, 2] * (-1.0 if swap else 1.0)
    arrays = body_arrays(lib, state)
    fast, slow = np.zeros(3), np.zeros(3)
    g, found = signed_distance(*arrays(0), *arrays(1), alert, fast)
    g_slow, found_slow = signed_distance_exhaustive(*arrays(0), *arrays(1), alert, slow)
    assert found and found_slow
    assert abs(g) <= tol and g == pytest.approx(g_slow, abs=tol)
    np.testing.assert_allclose(fast, normal, atol=1e-12)
    np.testing.assert_allclose(slow, normal, atol=1e-12)

    c = NarrowPhase(alert=alert).detect(state, lib, np.array([[0, 1]]))
    assert c.n_contacts >= 1
    assert set(c.contact_type.tolist()) == {TYPE_FF if kind == "ff" else TYPE_FE}
    assert abs(c.gap.min()) <= tol and c.gap.min() >= -tol
    touching = np.abs(c.gap) <= tol
    np.testing.assert_allclose(c.normal[touching], np.tile(normal, (touching.sum(), 1)),
                               atol=1e-12)
    local = (c.point[touching] - shift) @ turn  # back to the canonical frame
    np.testing.assert_allclose(local[:, 2], 0.0, atol=tol)
    xy = local[:, :2]
    if kind == "ff":
        assert touching.sum() >= 3
        polygon = _ccw(region)
        edge = np.roll(polygon, -1, axis=0) - polygon
        for p in xy:  # inside the overlap polygon of the two faces
            side = edge[:, 0] * (p[1] - polygon[:, 1]) - edge[:, 1] * (p[0] - polygon[:, 0])
            assert side.min() >= -1e-9 * scale**2
        # the touching points span the overlap polygon; at an alert of a body size the
        # reduction also keeps points of the cap above the contact, so less of it
        coverage = 0.5 if alert <= 0.05 * scale else 0.1
        assert _area(_ccw(xy)) >= coverage * _area(polygon)
    else:  # the two ends of the edge clipped to A's face
        assert touching.sum() == 2
        for end in region:
            assert np.linalg.norm(xy - end, axis=1).min() <= 1e-9 * scale
        for p in xy:
            assert np.linalg.norm(region - p, axis=1).min() <= 1e-9 * scale
    return int(touching.sum())


SCALES = (1e-3, 1.0, 1e3)
"""Body sizes [m] (the tolerances follow them)."""


@pytest.mark.parametrize("name", list(SCENES))
@pytest.mark.parametrize("scale", SCALES)
def test_exactly_touching_flat_contacts(name, scale):
    """Every moved pose, both orders and both alerts: found, gap 0, face normal, touching
    points in the touching region, fast = exhaustive (module docstring)."""
    rng = np.random.default_rng([list(SCENES).index(name), SCALES.index(scale)])
    for _ in range(40):
        scene = SCENES[name](rng, scale)
        if scene[6] == "fe" and scene[7] is None:
            continue
        for swap in (False, True):
            lib, state, turn, shift = _moved_state(scene, rng, scale, swap)
            for alert in ALERTS:
                _check_touching(scene, lib, state, turn, shift, swap, alert * scale, scale)


def test_cube_resting_on_a_slab_reproduction():
    """A cube resting on a slab (gap 0, cube face inside the slab face) in a pose where the
    face axes gave s = -1e-16 and an edge pair in the contact plane s = +2e-16: the pair was
    missed at alert 0.05 and given gaps of -1.76 m at alert 1.0."""
    box = _box
    lib = ShapeLibrary.from_polyhedra([box(2.0, 2.0, 1.0), box(0.5, 0.5, 0.5)])
    q = [-0.7146373309078363, 0.513548335594488, 0.4282164831346684, 0.20540748733391115]
    pb = [0.16017009135826438, 0.9040567790486419, -0.07920844002603966]
    state = BodyState.from_library(lib, [0, 1], [[0.0, 0.0, 0.0], pb], 1000.0, [q, q])
    rot = quat_to_matrices(np.array([q]))[0]
    face = lib.face_normals[:6] @ rot.T
    for alert in ALERTS:
        c = NarrowPhase(alert=alert).detect(state, lib, np.array([[0, 1]]))
        assert c.n_contacts >= 4 and set(c.contact_type.tolist()) == {TYPE_FF}
        assert abs(c.gap.min()) <= 1e-12
        touching = np.abs(c.gap) <= 1e-12
        assert touching.sum() == 4  # the four corners of the cube's face
        # the normal is that of the slab face the cube rests on
        k = np.argmax(face @ c.normal[0])
        np.testing.assert_allclose(c.normal[touching], np.tile(face[k], (4, 1)), atol=1e-12)
