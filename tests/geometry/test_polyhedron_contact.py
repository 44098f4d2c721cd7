"""Contact geometry of convex polyhedra (geometry/polyhedron_contact.py, polyhedron_manifold.py)
through the narrow phase: gap and normal against python-fcl (apart) and a brute-force
separating-axis twin (overlap), swap symmetry, rigid-motion invariance, canonical contact types,
walls, spheres, the pruned kernels against their exhaustive twins."""

import numpy as np
import pytest
from polyhedron_arrays import body_arrays
from scipy.optimize import nnls

from grainlab.engine.detect.narrow_phase import POLYHEDRON_CONTACT_TYPE_NAMES, NarrowPhase
from grainlab.engine.quaternion import quat_multiply, quat_to_matrices
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.geometry.polyhedron import from_vertices, random_polyhedron
from grainlab.geometry.polyhedron_contact import (
    MAX_POINTS,
    signed_distance,
    signed_distance_exhaustive,
)
from grainlab.geometry.polyhedron_manifold import pair_manifold, pair_manifold_exhaustive

fcl = pytest.importorskip("fcl")

CUBE = from_vertices([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], name="cube")
TETRA = from_vertices([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], name="tetrahedron")


def _quat(axis, angle):
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def _random_quats(rng, n):
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1)[:, None]


def _signed_distance(lib, state, i, j, alert):
    """The kernel's signed distance and normal of bodies i, j (all polyhedra)."""
    arrays = body_arrays(lib, state)
    out = np.zeros(3)
    g, found = signed_distance(*arrays(i), *arrays(j), alert, out)
    return g, found, out


def _fcl_object(shape, position, quaternion):
    faces = np.hstack([np.full((shape.n_faces, 1), 3), shape.faces]).ravel()
    geometry = fcl.Convex(shape.vertices, shape.n_faces, faces)
    return fcl.CollisionObject(geometry, fcl.Transform(quat_to_matrices(quaternion[None])[0],
                                                       position))


def _sat_brute(va, vb, shape_a, shape_b, ra, rb):
    """Exact signed distance of OVERLAPPING polytopes: max over every triangle normal and every
    edge-pair cross product (both signs) of min_B n.b - max_A n.a (slow twin)."""
    axes = [shape_a.face_normals @ ra.T, -(shape_b.face_normals @ rb.T)]
    ta = (shape_a.vertices[shape_a.edges[:, 1]] - shape_a.vertices[shape_a.edges[:, 0]]) @ ra.T
    tb = (shape_b.vertices[shape_b.edges[:, 1]] - shape_b.vertices[shape_b.edges[:, 0]]) @ rb.T
    cross = np.cross(ta[:, None, :], tb[None, :, :]).reshape(-1, 3)
    size = np.linalg.norm(cross, axis=1)
    cross = cross[size > 1e-9] / size[size > 1e-9, None]
    axes += [cross, -cross]
    axes = np.concatenate(axes)
    sep = (vb @ axes.T).min(axis=0) - (va @ axes.T).max(axis=0)
    k = int(np.argmax(sep))
    return sep[k], axes[k]


_POOLS = {}


def _pool(n_faces):
    """Four random polyhedra of n_faces (circumscribed diameter 1) in one library."""
    if n_faces not in _POOLS:
        rng = np.random.default_rng(100 + n_faces)
        shapes = [random_polyhedron(n_faces, rng) for _ in range(4)]
        _POOLS[n_faces] = shapes, ShapeLibrary.from_polyhedra(shapes)
    return _POOLS[n_faces]


def _random_pair(rng, n_faces, distance_range):
    """Two polyhedra of the pool in random orientations, B along a random direction at a
    centre distance drawn from ``distance_range`` (near contact)."""
    pool, lib = _pool(n_faces)
    ids = rng.choice(len(pool), size=2)
    quats = _random_quats(rng, 2)
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    distance = rng.uniform(*distance_range)
    state = BodyState.from_library(lib, ids, [[0, 0, 0], distance * u], 1000.0,
                                   orientations=quats)
    return [pool[k] for k in ids], lib, state


@pytest.mark.parametrize("n_faces, n_poses, distances", [
    (8, 1000, (0.55, 1.0)), (30, 1000, (0.75, 1.0)), (96, 300, (0.88, 1.0))])
def test_gap_and_normal_against_fcl_and_brute_force(n_faces, n_poses, distances):
    rng = np.random.default_rng(n_faces)
    n_apart = n_overlap = 0
    for _ in range(n_poses):
        shapes, lib, state = _random_pair(rng, n_faces, distances)
        g, found, normal = _signed_distance(lib, state, 0, 1, alert=0.2)
        a = _fcl_object(shapes[0], state.positions[0], state.orientations[0])
        b = _fcl_object(shapes[1], state.positions[1], state.orientations[1])
        result = fcl.DistanceResult()
        d = fcl.distance(a, b, fcl.DistanceRequest(enable_nearest_points=True), result)
        rot = quat_to_matrices(state.orientations)
        va = shapes[0].vertices @ rot[0].T + state.positions[0]
        vb = shapes[1].vertices @ rot[1].T + state.positions[1]
        assert found == (d <= 0.2)
        if d > 0.2:
            assert g <= d + 1e-12  # a lower bound when not found
            continue
        if d > 1e-6:
            n_apart += 1
            assert g == pytest.approx(d, abs=1e-7)
            link = result.nearest_points[1] - result.nearest_points[0]
            np.testing.assert_allclose(normal, link / np.linalg.norm(link), atol=1e-4)
        elif d <= 0.0 or not np.isfinite(d):
            sep, axis = _sat_brute(va, vb, *shapes, rot[0], rot[1])
            if sep > -1e-9:
                continue
            n_overlap += 1
            assert g == pytest.approx(sep, abs=1e-12)
            np.testing.assert_allclose(normal, axis, atol=1e-8)
        np.testing.assert_allclose(np.linalg.norm(normal), 1.0, atol=1e-12)
    assert n_apart > n_poses / 5 and n_overlap > n_poses / 5


@pytest.mark.long
@pytest.mark.parametrize("n_faces, n_poses, distances", [
    (8, 400, (0.5, 1.0)), (30, 400, (0.7, 1.0)), (96, 300, (0.85, 1.0)),
    (596, 100, (0.93, 1.0))])
def test_pruned_kernels_agree_with_their_exhaustive_twins(n_faces, n_poses, distances):
    """The pruned face axes, arc pre-test, line-entry faces and crossing boxes change nothing:
    same g, normal and found, same manifold (points, gaps, ids, type) as with every face, edge
    pair and crossing evaluated, over touching, overlapping and near poses and two alerts."""
    rng = np.random.default_rng(1000 + n_faces)
    cos_tol, sin_tol = np.cos(0.01), np.sin(0.01)
    counts = np.zeros(5, dtype=int)
    for pose in range(n_poses):
        _, lib, state = _random_pair(rng, n_faces, distances)
        arrays = body_arrays(lib, state)
        a, b = arrays(0), arrays(1)
        alert = (0.02, 0.2)[pose % 2]
        fast, slow = np.zeros(3), np.zeros(3)
        g, found = signed_distance(*a, *b, alert, fast)
        g_slow, found_slow = signed_distance_exhaustive(*a, *b, alert, slow)
        assert found == found_slow
        if not found:
            continue
        assert g == pytest.approx(g_slow, rel=1e-12, abs=1e-15)
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
        max_points = 3 + pose // 2 % 2
        results = []
        for kernel in (pair_manifold, pair_manifold_exhaustive):
            out = (np.zeros((MAX_POINTS, 3)), np.zeros(MAX_POINTS), np.zeros((MAX_POINTS, 3)),
                   np.zeros(MAX_POINTS, np.int64), np.zeros(MAX_POINTS, np.int64))
            count, kind = kernel(*a[:-1], *b[:-1], g, fast, alert, cos_tol, sin_tol,
                                 max_points, *out)
            results.append((count, kind, *(x[:count] for x in out)))
        (count, kind, points, gaps, normals, ids_a, ids_b), slow_result = results
        assert (count, kind) == slow_result[:2]
        np.testing.assert_allclose(points, slow_result[2], rtol=0, atol=1e-12)
        np.testing.assert_allclose(gaps, slow_result[3], rtol=0, atol=1e-15)
        np.testing.assert_allclose(normals, slow_result[4], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(ids_a, slow_result[5])
        np.testing.assert_array_equal(ids_b, slow_result[6])
        counts[kind] += 1
    # touching pairs of several types were compared
    assert counts.sum() > n_poses / 3 and (counts[1:4] > 0).sum() >= 2


def _detect(lib, state, alert=0.05, **kwargs):
    return NarrowPhase(alert=alert, **kwargs).detect(state, lib, np.array([[0, 1]]))


def test_swap_flips_the_normal_and_keeps_the_points():
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(300):
        _, lib, state = _random_pair(rng, 30, (0.7, 0.95))
        forward = _detect(lib, state)
        swapped = BodyState.from_library(lib, state.shape_ids[::-1], state.positions[::-1],
                                         1000.0, orientations=state.orientations[::-1])
        backward = _detect(lib, swapped)
        assert forward.n_contacts == backward.n_contacts
        if forward.n_contacts == 0:
            continue
        checked += 1
        np.testing.assert_allclose(forward.normal, -backward.normal[::1], atol=1e-9)
        order_f = np.lexsort(forward.point.T)
        order_b = np.lexsort(backward.point.T)
        np.testing.assert_allclose(forward.point[order_f], backward.point[order_b], atol=1e-9)
        np.testing.assert_allclose(np.sort(forward.gap), np.sort(backward.gap), atol=1e-12)
        assert (forward.contact_type == backward.contact_type).all()
        np.testing.assert_array_equal(np.sort(forward.member_i), np.sort(backward.member_j))
    assert checked > 100


def test_rigid_motion_of_both_bodies_moves_the_contacts_with_them():
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(200):
        _, lib, state = _random_pair(rng, 30, (0.7, 0.95))
        before = _detect(lib, state)
        if before.n_contacts == 0:
            continue
        q = _random_quats(rng, 1)[0]
        rot = quat_to_matrices(q[None])[0]
        shift = rng.normal(size=3)
        # the orientations turned by the exact product with q (a rotation vector taken back
        # from the matrix through arccos loses ~1e-8 at small angles: no rigid motion then)
        turned = np.array([quat_multiply(q, o) for o in state.orientations])
        moved = BodyState.from_library(lib, state.shape_ids, state.positions @ rot.T + shift,
                                       1000.0, orientations=turned)
        after = _detect(lib, moved)
        assert after.n_contacts == before.n_contacts
        np.testing.assert_allclose(after.gap, before.gap, atol=1e-12)
        np.testing.assert_allclose(after.normal, before.normal @ rot.T, atol=1e-9)
        np.testing.assert_allclose(after.point, before.point @ rot.T + shift, atol=1e-9)
        np.testing.assert_array_equal(after.member_i, before.member_i)
        np.testing.assert_array_equal(after.member_j, before.member_j)
        checked += 1
    assert checked > 50


def _moved(lib, state, rng):
    """The pair under a random rigid motion (exact quaternion product); (state, rot, shift)."""
    q = _random_quats(rng, 1)[0]
    rot = quat_to_matrices(q[None])[0]
    shift = 3.0 * rng.normal(size=3)
    turned = np.array([quat_multiply(q, o) for o in state.orientations])
    return (BodyState.from_library(lib, state.shape_ids, state.positions @ rot.T + shift,
                                   1000.0, orientations=turned), rot, shift)


def _assert_same_manifold(before, after, rot, shift):
    """Same points (moved), gaps, normals (turned) and feature ids, in the same order."""
    assert after.n_contacts == before.n_contacts
    np.testing.assert_array_equal(after.member_i, before.member_i)
    np.testing.assert_array_equal(after.member_j, before.member_j)
    np.testing.assert_allclose(after.gap, before.gap, rtol=0, atol=1e-12)
    np.testing.assert_allclose(after.normal, before.normal @ rot.T, rtol=0, atol=1e-9)
    np.testing.assert_allclose(after.point, before.point @ rot.T + shift, rtol=0, atol=1e-9)


@pytest.mark.parametrize("n_faces", [8, 30])
def test_separated_pair_holds_a_point_at_its_distance_along_its_normal(n_faces):
    """Bodies apart by g (0 < g <= alert): the manifold holds the constraint of the two
    closest features, gap g along the pair normal n. When those are a vertex and an edge (or
    two vertices) the line from the vertex along n meets the edge exactly, where two faces
    of the other body tie: the vertex-edge constraint (gap g, normal n) must be taken, not
    either face's plane distance (smaller than g, tilted normal), which round-off chose."""
    rng = np.random.default_rng(40 + n_faces)
    cos_tol, sin_tol = np.cos(0.01), np.sin(0.01)
    vertex_edge = 0
    checked = 0
    for _ in range(400):
        _, lib, state = _random_pair(rng, n_faces, (0.75, 1.0) if n_faces == 30 else (0.6, 1.0))
        arrays = body_arrays(lib, state)
        a, b = arrays(0), arrays(1)
        alert = 0.1
        normal = np.zeros(3)
        g, found = signed_distance(*a, *b, alert, normal)
        if not found or g <= 1e-6:
            continue
        out = (np.zeros((MAX_POINTS, 3)), np.zeros(MAX_POINTS), np.zeros((MAX_POINTS, 3)),
               np.zeros(MAX_POINTS, np.int64), np.zeros(MAX_POINTS, np.int64))
        count, _ = pair_manifold(*a[:-1], *b[:-1], g, normal, alert, cos_tol, sin_tol,
                                 MAX_POINTS, *out)
        _, gaps, normals, ids_a, ids_b = (x[:count] for x in out)
        at_distance = np.flatnonzero(np.abs(gaps - g) <= 1e-12)
        assert at_distance.size > 0
        assert np.abs(normals[at_distance] @ normal - 1.0).min() <= 1e-12
        n_va, n_vb = a[0].shape[0], b[0].shape[0]
        n_ea, n_eb = a[5].shape[0], b[5].shape[0]
        k = at_distance[0]
        vertex_edge += (ids_a[k] < n_va and ids_b[k] < n_vb + n_eb) or \
            (ids_b[k] < n_vb and ids_a[k] < n_va + n_ea)
        checked += 1
    assert checked > 60 and vertex_edge >= 5, (checked, vertex_edge)


@pytest.mark.parametrize("n_faces", [8, 30, 96])
def test_manifold_is_the_same_in_every_frame_and_under_swap(n_faces):
    """Five rigid motions per pose (points moved, gaps kept, normals turned, same feature ids
    in the same order) and the swap of A and B (same points as a set, normals flipped), over
    apart, touching and overlapping pairs. Near-ties (a vertex over an edge, crossings at an
    edge end, equal depths) are decided by tolerances and feature ids, not by round-off, so
    this holds on any processor."""
    rng = np.random.default_rng(70 + n_faces)
    distances = {8: (0.5, 1.0), 30: (0.7, 1.0), 96: (0.85, 1.0)}[n_faces]
    checked = 0
    for _ in range(60):
        _, lib, state = _random_pair(rng, n_faces, distances)
        before = _detect(lib, state, alert=0.1)
        if before.n_contacts == 0:
            continue
        for _ in range(5):
            moved, rot, shift = _moved(lib, state, rng)
            _assert_same_manifold(before, _detect(lib, moved, alert=0.1), rot, shift)
        swapped = BodyState.from_library(lib, state.shape_ids[::-1], state.positions[::-1],
                                         1000.0, orientations=state.orientations[::-1])
        back = _detect(lib, swapped, alert=0.1)
        assert back.n_contacts == before.n_contacts
        order_f, order_b = np.lexsort(before.point.T), np.lexsort(back.point.T)
        np.testing.assert_allclose(back.point[order_b], before.point[order_f], atol=1e-9)
        np.testing.assert_allclose(back.gap[order_b], before.gap[order_f], atol=1e-12)
        np.testing.assert_allclose(back.normal[order_b], -before.normal[order_f], atol=1e-9)
        checked += 1
    assert checked > 30


@pytest.mark.parametrize("max_points", [3, 5, 6, 7])
def test_equal_depths_are_reduced_the_same_way_in_every_frame(max_points):
    """A square turned by 0.4 rad on a square overlaps in an octagon whose 8 corners lie at
    one depth (up to round-off): keeping fewer than 8 is a choice among exact ties, which must
    follow the feature ids, not the round-off of the frame."""
    rng = np.random.default_rng(5)
    lib, state = _two(CUBE, CUBE, [0.01, 0.0, 0.999], quat_b=_quat([0, 0, 1], 0.4))
    before = _detect(lib, state, max_points=max_points)
    assert before.n_contacts == max_points
    np.testing.assert_allclose(before.gap, -0.001, atol=1e-12)
    for _ in range(20):
        moved, rot, shift = _moved(lib, state, rng)
        _assert_same_manifold(before, _detect(lib, moved, max_points=max_points), rot, shift)


def _two(shape_a, shape_b, position_b, quat_a=(1, 0, 0, 0), quat_b=(1, 0, 0, 0)):
    lib = ShapeLibrary.from_polyhedra([shape_a, shape_b])
    state = BodyState.from_library(lib, [0, 1], [[0, 0, 0], position_b], 1000.0,
                                   orientations=[quat_a, quat_b])
    return lib, state


def _names(contacts):
    return {POLYHEDRON_CONTACT_TYPE_NAMES[c] for c in contacts.contact_type}


@pytest.mark.parametrize("max_points", [3, 4])
def test_cube_on_cube_face_to_face_is_ff_with_three_points(max_points):
    lib, state = _two(CUBE, CUBE, [0.2, 0.1, 0.999], quat_b=_quat([0, 0, 1], 0.3))
    c = _detect(lib, state, max_points=max_points)
    assert c.n_contacts == max_points and _names(c) == {"ff"}
    np.testing.assert_allclose(c.gap, -0.001, atol=1e-12)
    np.testing.assert_allclose(c.normal, [[0, 0, 1]] * max_points, atol=1e-12)
    np.testing.assert_allclose(c.point[:, 2], 0.4995, atol=1e-12)
    # the points span a large part of the overlap of the two squares and lie inside both
    area = 0.5 * np.linalg.norm(np.cross(c.point[1] - c.point[0], c.point[2] - c.point[0]))
    assert area > 0.2
    assert np.all(np.abs(c.point[:, :2]) <= 0.5 + 1e-12)
    rot = quat_to_matrices(state.orientations)[1]
    local = (c.point - state.positions[1]) @ rot
    assert np.all(np.abs(local[:, :2]) <= 0.5 + 1e-12)
    keys = {(int(a), int(b)) for a, b in zip(c.member_i, c.member_j, strict=True)}
    assert len(keys) == max_points


def test_cube_edge_on_face_is_fe_with_two_points():
    lift = 0.5 + np.sqrt(0.5) - 0.002
    lib, state = _two(CUBE, CUBE, [0.0, 0.1, lift], quat_b=_quat([1, 0, 0], np.pi / 4))
    c = _detect(lib, state)
    assert c.n_contacts == 2 and _names(c) == {"fe"}
    np.testing.assert_allclose(c.gap, -0.002, atol=1e-12)
    np.testing.assert_allclose(np.sort(c.point[:, 0]), [-0.5, 0.5], atol=1e-12)


def test_tetrahedron_vertex_on_face_is_fv():
    # a vertex of the tetrahedron (body frame) pointing down onto the top face of a cube
    vertex = TETRA.vertices[0]
    tip = np.linalg.norm(vertex)  # sqrt(3): distance of a vertex from the centre
    down = _quat(np.cross(vertex, [0, 0, -1]), np.arccos(-vertex[2] / tip))
    lib, state = _two(CUBE, TETRA, [0.1, -0.2, 0.5 + tip - 0.003], quat_b=down)
    c = _detect(lib, state)
    assert c.n_contacts == 1 and _names(c) == {"fv"}
    assert c.gap[0] == pytest.approx(-0.003, abs=1e-12)
    np.testing.assert_allclose(c.point[0], [0.1, -0.2, 0.4985], atol=1e-12)


def test_crossed_edges_are_ee():
    h = np.sqrt(0.5)
    lib, state = _two(CUBE, CUBE, [0.1, 0.05, 2 * h - 0.001], quat_a=_quat([1, 0, 0], np.pi / 4),
                      quat_b=_quat([0, 1, 0], np.pi / 4))
    c = _detect(lib, state)
    assert c.n_contacts == 1 and _names(c) == {"ee"}
    assert c.gap[0] == pytest.approx(-0.001, abs=1e-12)
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(c.point[0], [0.1, 0.0, h - 0.0005], atol=1e-12)


def test_a_tilt_beyond_the_angle_tolerance_changes_the_type():
    lift = 0.999
    for angle, name in ((0.005, "ff"), (0.03, "fe")):
        lib, state = _two(CUBE, CUBE, [0, 0, lift], quat_b=_quat([1, 0, 0], angle))
        c = _detect(lib, state, angle_tolerance=0.01)
        assert _names(c) == {name}


def test_walls_give_one_two_or_four_points():
    lib = ShapeLibrary.from_polyhedra([CUBE])
    floor = (np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
    cases = [
        ([1, 0, 0, 0], 0.499, "ff", 4),
        (_quat([1, 0, 0], np.pi / 4), np.sqrt(0.5) - 0.001, "fe", 2),
    ]
    for quat, height, name, count in cases:
        state = BodyState.from_library(lib, [0], [[0.3, 0.2, height]], 1000.0,
                                       orientations=[quat])
        c = NarrowPhase(alert=0.01).detect(state, lib, np.zeros((0, 2), np.int64), *floor)
        assert c.n_contacts == count and _names(c) == {name}
        np.testing.assert_allclose(c.gap, -0.001, atol=1e-12)
        assert (c.body_i == -1).all() and (c.member_i == -1).all()
        np.testing.assert_allclose(c.point[:, 2], -0.0005, atol=1e-12)
    state = BodyState.from_library(lib, [0], [[0, 0, 0.6]], 1000.0)
    assert NarrowPhase(alert=0.05).detect(state, lib, np.zeros((0, 2), np.int64),
                                          *floor).n_contacts == 0


def test_sphere_against_polyhedron_matches_a_least_squares_oracle():
    rng = np.random.default_rng(5)
    shape = random_polyhedron(30, rng)
    lib = ShapeLibrary.from_polyhedra([shape]).concatenate(ShapeLibrary.from_spheres([0.2]))
    checked = 0
    for _ in range(300):
        quat = _random_quats(rng, 1)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        centre = rng.uniform(0.35, 0.75) * u
        state = BodyState.from_library(lib, [0, 1], [[0, 0, 0], centre], 1000.0,
                                       orientations=np.vstack([quat, [[1, 0, 0, 0]]]))
        c = NarrowPhase(alert=1.0).detect(state, lib, np.array([[0, 1]]))
        assert c.n_contacts == 1
        # oracle: nearest point of the hull as a convex combination of its vertices
        # (non-negative least squares with a heavily weighted sum-to-one row); python-fcl's
        # sphere GJK is off by up to 3e-6 m here, this by < 1e-9 m
        world = shape.vertices @ quat_to_matrices(quat)[0].T
        weight = 1e4
        lam, _ = nnls(np.vstack([world.T, weight * np.ones(len(world))]),
                      np.concatenate([centre, [weight]]), maxiter=10_000)
        link = centre - world.T @ lam
        d = np.linalg.norm(link)
        if d > 1e-3:
            assert c.gap[0] == pytest.approx(d - 0.2, abs=1e-8)
            np.testing.assert_allclose(c.normal[0], link / d, atol=1e-6)
            checked += 1
        # the swapped pair flips the normal
        lib2 = ShapeLibrary.from_spheres([0.2]).concatenate(ShapeLibrary.from_polyhedra([shape]))
        state2 = BodyState.from_library(lib2, [0, 1], [centre, [0, 0, 0]], 1000.0,
                                        orientations=np.vstack([[[1, 0, 0, 0]], quat]))
        c2 = NarrowPhase(alert=1.0).detect(state2, lib2, np.array([[0, 1]]))
        np.testing.assert_allclose(c2.normal, -c.normal, atol=1e-12)
        np.testing.assert_allclose(c2.point, c.point, atol=1e-12)
        assert c2.member_j[0] == c.member_i[0] and c.contact_type[0] in (1, 2)
    assert checked > 100


def _inside(vertices, normals, offsets):
    """Mask of the ``vertices`` strictly inside the polyhedron of face planes (normals,
    offsets)."""
    return np.all(vertices @ normals.T - offsets < -1e-9, axis=1)


def test_every_buried_vertex_is_a_manifold_point_however_deep():
    """Overlaps deeper than the alert distance: every vertex of one body inside the other is a
    point of the manifold (with room for all), with the gap and normal of the face plane it
    lies under; a crossing's normal is normal to both edges. (The caps once reached only
    twice the alert distance below the deepest point: deeper buried vertices were left out
    and sank further.)"""
    rng = np.random.default_rng(11)
    cos_tol, sin_tol = np.cos(0.01), np.sin(0.01)
    checked = 0
    for _ in range(400):
        _, lib, state = _random_pair(rng, 8, (0.45, 0.75))
        arrays = body_arrays(lib, state)
        a, b = arrays(0), arrays(1)
        alert = 0.01
        normal = np.zeros(3)
        g, found = signed_distance(*a, *b, alert, normal)
        if not found or g > -4 * alert:
            continue
        out = (np.zeros((MAX_POINTS, 3)), np.zeros(MAX_POINTS), np.zeros((MAX_POINTS, 3)),
               np.zeros(MAX_POINTS, np.int64), np.zeros(MAX_POINTS, np.int64))
        count, _ = pair_manifold(*a[:-1], *b[:-1], g, normal, alert, cos_tol, sin_tol,
                                 MAX_POINTS, *out)
        points, gaps, normals, ids_a, ids_b = (x[:count] for x in out)
        if count == MAX_POINTS:
            continue  # truncated: no room for all
        (va, na, oa, *_), (vb, nb, ob, *_) = a, b
        n_va, n_ea = va.shape[0], a[5].shape[0]
        n_vb, n_eb = vb.shape[0], b[5].shape[0]
        pairs = set(zip(ids_a.tolist(), ids_b.tolist(), strict=True))
        for v in np.flatnonzero(_inside(vb, na, oa)):
            assert any(j == v and i >= n_va + n_ea for i, j in pairs)
        for v in np.flatnonzero(_inside(va, nb, ob)):
            assert any(i == v and j >= n_vb + n_eb for i, j in pairs)
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
        assert np.all(normals @ normal > 0.0)
        for k in range(count):
            if ids_a[k] >= n_va + n_ea:  # vertex of B under face f of A
                f = ids_a[k] - n_va - n_ea
                np.testing.assert_allclose(normals[k], na[f], atol=1e-12)
                assert gaps[k] == pytest.approx(na[f] @ vb[ids_b[k]] - oa[f], abs=1e-12)
            elif ids_b[k] >= n_vb + n_eb:  # vertex of A under face f of B
                f = ids_b[k] - n_vb - n_eb
                np.testing.assert_allclose(normals[k], -nb[f], atol=1e-12)
                assert gaps[k] == pytest.approx(nb[f] @ va[ids_a[k]] - ob[f], abs=1e-12)
            else:  # crossing of edge ids_a - V_a of A and edge ids_b - V_b of B
                ea = np.diff(va[a[5][ids_a[k] - n_va]], axis=0)[0]
                eb = np.diff(vb[b[5][ids_b[k] - n_vb]], axis=0)[0]
                cross = np.cross(ea, eb)
                size = np.linalg.norm(cross)
                if abs(normals[k] @ ea) > 1e-9 or abs(normals[k] @ eb) > 1e-9:
                    # the pair's normal kept: nearly parallel edges, or a common normal far
                    # from the pair's
                    np.testing.assert_allclose(normals[k], normal, atol=1e-12)
                    assert size <= 0.05 * np.linalg.norm(ea) * np.linalg.norm(eb) \
                        or abs(cross @ normal) < 0.5 * size
                else:
                    # the mid-point is half the gap above edge a along the common normal
                    start = va[a[5][ids_a[k] - n_va][0]]
                    assert gaps[k] == pytest.approx(2.0 * (points[k] - start) @ normals[k],
                                                    abs=1e-12)
        checked += 1
    assert checked > 50
