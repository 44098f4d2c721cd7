"""Body state, quaternions and the sphere-based narrow phase against closed forms and an
all-pairs NumPy twin (STYLE.md 11, 12)."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.detect.narrow_phase import (
    CONTACT_CLASS_NAMES,
    NarrowPhase,
    classify_aggregate_pairs,
)
from grainlab.engine.quaternion import quat_multiply, quat_normalise, quat_to_matrix
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.sphere_aggregate import tetrahedral_aggregate

RNG_SEED = 20240611


def random_quaternions(rng, n):
    return np.array([quat_normalise(q) for q in rng.normal(size=(n, 4))])


def quat_between(u, v):
    """Unit quaternion rotating unit vector u onto unit vector v (not antiparallel)."""
    u = np.asarray(u, float) / np.linalg.norm(u)
    v = np.asarray(v, float) / np.linalg.norm(v)
    return quat_normalise(np.concatenate([[1.0 + u @ v], np.cross(u, v)]))


# ------------------------------------------------------------------------------ quaternions
def test_rotation_matrix_is_orthonormal_and_proper():
    rng = np.random.default_rng(RNG_SEED)
    for q in random_quaternions(rng, 20):
        m = quat_to_matrix(q)
        np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-14)
        assert np.linalg.det(m) == pytest.approx(1.0, abs=1e-14)


def test_quaternion_product_composes_rotations():
    rng = np.random.default_rng(RNG_SEED + 1)
    p, q = random_quaternions(rng, 2)
    np.testing.assert_allclose(
        quat_to_matrix(quat_multiply(p, q)), quat_to_matrix(p) @ quat_to_matrix(q), atol=1e-14
    )


def test_quaternion_about_z_rotates_x_to_y():
    half = np.pi / 4.0
    m = quat_to_matrix(np.array([np.cos(half), 0.0, 0.0, np.sin(half)]))
    np.testing.assert_allclose(m @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)


# ------------------------------------------------------------------------------ body state
def test_momentum_and_energy_of_known_motions():
    library = ShapeLibrary.from_spheres([0.5, 1.0])
    state = BodyState.from_library(library, [0, 1], [[0, 0, 0], [3, 0, 0]], density=2.0)
    m0, m1 = state.masses
    assert m0 == pytest.approx(2.0 * 4 / 3 * np.pi * 0.125)
    i1 = 0.4 * m1 * 1.0
    np.testing.assert_allclose(state.inertias[1], [i1] * 3)
    state.velocities[0] = [1.0, 2.0, 0.0]
    state.angular_velocities[1] = [0.0, 0.0, 3.0]
    state.velocities[1] = [0.0, -1.0, 0.0]
    assert state.kinetic_energy() == pytest.approx(0.5 * m0 * 5.0 + 0.5 * m1 + 0.5 * i1 * 9.0)
    np.testing.assert_allclose(state.momentum(), [m0, 2 * m0 - m1, 0.0])
    # orbital of body 1: (3, 0, 0) x (0, -m1, 0) = (0, 0, -3 m1); spin i1 * 3 about z
    np.testing.assert_allclose(state.angular_momentum(), [0.0, 0.0, -3 * m1 + 3 * i1])


def test_spin_of_rotated_aggregate_uses_world_inertia():
    agg = tetrahedral_aggregate(radius=1.0, lam=0.5)
    library = ShapeLibrary.from_aggregates([agg])
    rng = np.random.default_rng(RNG_SEED + 2)
    q = random_quaternions(rng, 1)
    state = BodyState.from_library(library, [0], [[1.0, 2.0, 3.0]], 1500.0, orientations=q)
    omega = np.array([0.3, -0.2, 0.7])
    state.angular_velocities[0] = omega
    r = quat_to_matrix(q[0])
    world = r @ np.diag(state.inertias[0]) @ r.T
    assert state.kinetic_energy() == pytest.approx(0.5 * omega @ world @ omega, rel=1e-13)
    np.testing.assert_allclose(state.angular_momentum(), world @ omega, rtol=1e-13)
    assert state.masses[0] == pytest.approx(1500.0 * agg.volume)


def test_state_validation_names_field_and_row():
    library = ShapeLibrary.from_spheres([0.5])
    with pytest.raises(InputError, match=r"orientations\[1\]"):
        BodyState.from_library(library, [0, 0], np.zeros((2, 3)), 1.0,
                               orientations=[[1, 0, 0, 0], [1, 1, 0, 0]])
    with pytest.raises(InputError, match=r"positions\[0\]"):
        BodyState.from_library(library, [0], [[np.nan, 0, 0]], 1.0)
    with pytest.raises(InputError, match=r"shape_ids\[1\]"):
        BodyState.from_library(library, [0, 3], np.zeros((2, 3)), 1.0)
    with pytest.raises(InputError, match="density"):
        BodyState.from_library(library, [0], np.zeros((1, 3)), -1.0)
    with pytest.raises(InputError, match=r"radii\[1\]"):
        ShapeLibrary.from_spheres([1.0, 0.0])


# ------------------------------------------------------------------------------ sphere-sphere
def two_spheres(ra, rb, xa, xb, alert=0.0):
    library = ShapeLibrary.from_spheres([ra, rb])
    state = BodyState.from_library(library, [0, 1], [xa, xb], 1000.0)
    return NarrowPhase(alert=alert).detect(state, library, [[0, 1]]), state, library


def test_sphere_sphere_gap_normal_point_closed_form():
    xa, xb = np.array([0.1, -0.2, 0.3]), np.array([0.7, 0.3, 0.2])
    contacts, _, _ = two_spheres(0.4, 0.5, xa, xb)
    d = xb - xa
    dist = np.linalg.norm(d)
    gap = dist - 0.9
    assert contacts.n_contacts == 1
    assert contacts.gap[0] == pytest.approx(gap, abs=1e-15)
    np.testing.assert_allclose(contacts.normal[0], d / dist, atol=1e-15)
    np.testing.assert_allclose(contacts.point[0], xa + (0.4 + gap / 2) * d / dist, atol=1e-15)
    far, _, _ = two_spheres(0.4, 0.5, xa, xa + np.array([0.0, 0.0, 0.95]))
    assert far.n_contacts == 0
    near, _, _ = two_spheres(0.4, 0.5, xa, xa + np.array([0.0, 0.0, 0.95]), alert=0.06)
    assert near.n_contacts == 1 and near.gap[0] == pytest.approx(0.05)


def test_swapping_bodies_flips_normal_keeps_point():
    contacts, state, library = two_spheres(0.4, 0.5, [0, 0, 0], [0.5, 0.6, 0.2])
    swapped = NarrowPhase(alert=0.0).detect(state, library, [[1, 0]])
    np.testing.assert_allclose(swapped.normal[0], -contacts.normal[0], atol=1e-15)
    np.testing.assert_allclose(swapped.point[0], contacts.point[0], atol=1e-15)
    assert swapped.gap[0] == pytest.approx(contacts.gap[0], abs=1e-15)


# ------------------------------------------------------------------------------ mixed sets
def mixed_set(seed, n=60, box=3.0):
    """Tetrahedral aggregates (two shapes) and spheres at random positions and orientations."""
    rng = np.random.default_rng(seed)
    library = ShapeLibrary.from_aggregates(
        [tetrahedral_aggregate(radius=0.25, lam=0.5), tetrahedral_aggregate(radius=0.2, lam=0.8)]
    ).concatenate(ShapeLibrary.from_spheres([0.3, 0.2]))
    ids = rng.integers(0, library.n_shapes, n)
    positions = rng.random((n, 3)) * box
    state = BodyState.from_library(library, ids, positions, 1000.0,
                                   orientations=random_quaternions(rng, n))
    return state, library


def all_pairs(n):
    i, j = np.triu_indices(n, k=1)
    return np.stack([i, j], axis=1)


def twin_contacts(state, library, alert):
    """All-pairs NumPy twin: every member pair of every body pair, rotation by matrices."""
    rows = []
    rotations = [quat_to_matrix(q) for q in state.orientations]
    spheres = []
    for n, s in enumerate(state.shape_ids):
        start, count = library.sphere_start[s], library.sphere_count[s]
        offsets = library.sphere_offsets[start:start + count]
        spheres.append((state.positions[n] + offsets @ rotations[n].T,
                        library.sphere_radii[start:start + count]))
    for i in range(state.n_bodies):
        for j in range(i + 1, state.n_bodies):
            ci, ri = spheres[i]
            cj, rj = spheres[j]
            d = cj[None, :, :] - ci[:, None, :]
            gap = np.linalg.norm(d, axis=2) - ri[:, None] - rj[None, :]
            for a, b in zip(*np.nonzero(gap <= alert), strict=True):
                rows.append((i, j, a, b, gap[a, b]))
    return rows


def test_kernel_equals_all_pairs_twin():
    state, library = mixed_set(RNG_SEED + 3)
    alert = 0.02
    contacts = NarrowPhase(alert=alert, capacity=4).detect(
        state, library, all_pairs(state.n_bodies))
    twin = twin_contacts(state, library, alert)
    assert contacts.n_contacts == len(twin) > 20
    got = list(zip(contacts.body_i, contacts.body_j, contacts.member_i, contacts.member_j,
                   strict=True))
    assert got == [row[:4] for row in twin]
    np.testing.assert_allclose(contacts.gap, [row[4] for row in twin], atol=1e-13)
    np.testing.assert_allclose(np.linalg.norm(contacts.normal, axis=1), 1.0, atol=1e-14)


def test_buffer_regrows_instead_of_truncating():
    state, library = mixed_set(RNG_SEED + 4)
    narrow = NarrowPhase(alert=0.0, capacity=1)
    contacts = narrow.detect(state, library, all_pairs(state.n_bodies))
    big = NarrowPhase(alert=0.0, capacity=10_000).detect(state, library,
                                                         all_pairs(state.n_bodies))
    assert narrow.n_regrowths >= 1
    assert contacts.n_contacts == big.n_contacts > 1
    np.testing.assert_array_equal(contacts.gap, big.gap)


def test_rigid_motion_keeps_contact_count_and_gaps():
    state, library = mixed_set(RNG_SEED + 5)
    pairs = all_pairs(state.n_bodies)
    before = NarrowPhase(alert=0.01).detect(state, library, pairs)
    rng = np.random.default_rng(RNG_SEED + 6)
    q = random_quaternions(rng, 1)[0]
    r = quat_to_matrix(q)
    shift = np.array([10.0, -4.0, 2.5])
    moved = BodyState.from_library(
        library, state.shape_ids, state.positions @ r.T + shift, state.density,
        orientations=np.array([quat_multiply(q, p) for p in state.orientations]),
    )
    after = NarrowPhase(alert=0.01).detect(moved, library, pairs)
    assert after.n_contacts == before.n_contacts > 10
    np.testing.assert_allclose(after.gap, before.gap, atol=1e-12)
    np.testing.assert_allclose(after.normal, before.normal @ r.T, atol=1e-12)
    np.testing.assert_allclose(after.point, before.point @ r.T + shift, atol=1e-12)


# ------------------------------------------------------------------------------ aggregates
R_SPHERE = 1.0
DELTA = 1e-3  # overlap of each touching member pair [m]


def tetra_pair(q_a, x_b, q_b):
    """Two tetrahedral aggregates (r = 1, lambda = 0.5): A at the origin, B at x_b."""
    agg = tetrahedral_aggregate(radius=R_SPHERE, lam=0.5)
    library = ShapeLibrary.from_aggregates([agg])
    state = BodyState.from_library(library, [0, 0], [[0, 0, 0], x_b], 1000.0,
                                   orientations=[q_a, q_b])
    contacts = NarrowPhase(alert=0.0).detect(state, library, [[0, 1]])
    _, codes, counts = classify_aggregate_pairs(contacts.body_i, contacts.body_j,
                                                contacts.member_i, contacts.member_j)
    return contacts, [CONTACT_CLASS_NAMES[c] for c in codes], counts


IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
A_VERTEX = 0.5 * R_SPHERE / np.sqrt(2.0)  # a = lambda r / sqrt 2: centres at a (+-1, +-1, +-1)
# rotation by pi about (1, -1, 0)/sqrt 2: (x, y, z) -> (-y, -x, -z)
HALF_TURN = np.array([0.0, 1.0, -1.0, 0.0]) / np.sqrt(2.0)


def test_simple_contact_vertex_to_vertex():
    u = np.ones(3) / np.sqrt(3.0)
    x_b = 2.0 * A_VERTEX * np.ones(3) + (2.0 * R_SPHERE - DELTA) * u
    contacts, names, counts = tetra_pair(IDENTITY, x_b, HALF_TURN)
    assert names == ["s"] and counts.tolist() == [1]
    assert contacts.gap[0] == pytest.approx(-DELTA, abs=1e-12)
    np.testing.assert_allclose(contacts.normal[0], u, atol=1e-12)


def test_double_simple_contact_parallel_edges():
    # B's top edge (members 1, 2 at z = +a) faces A's bottom edge (members 1, 2 at z = -a)
    x_b = np.array([0.0, 0.0, -(2.0 * A_VERTEX + 2.0 * R_SPHERE - DELTA)])
    contacts, names, counts = tetra_pair(IDENTITY, x_b, HALF_TURN)
    assert names == ["ds"] and counts.tolist() == [2]
    assert contacts.member_i.tolist() == [1, 2] and contacts.member_j.tolist() == [1, 2]


def test_double_contact_vertex_into_edge():
    # A's member 0 (direction (1, 1, 1)) turned to point along +z into B's bottom edge
    # (B identity: members 1, 2 at a (1, -1, -1), a (-1, 1, -1))
    t = np.sqrt((2.0 * R_SPHERE - DELTA) ** 2 - 2.0 * A_VERTEX**2)
    x_b = np.array([0.0, 0.0, 30.0])
    tip = x_b + np.array([0.0, 0.0, -A_VERTEX - t])
    q_a = quat_between(np.ones(3), [0.0, 0.0, 1.0])
    x_a = tip - quat_to_matrix(q_a) @ (A_VERTEX * np.ones(3))
    contacts, names, counts = tetra_pair(q_a, x_b - x_a, IDENTITY)
    assert names == ["d"] and counts.tolist() == [2]
    assert contacts.member_i.tolist() == [0, 0]
    assert sorted(contacts.member_j.tolist()) == [1, 2]
    np.testing.assert_allclose(contacts.gap, -DELTA, atol=1e-12)


def test_quadruple_contact_crossed_edges():
    # B turned by pi about x: its top edge runs along (1, 1, 0), across A's bottom edge
    dz = np.sqrt((2.0 * R_SPHERE - DELTA) ** 2 - 4.0 * A_VERTEX**2)
    x_b = np.array([0.0, 0.0, -(2.0 * A_VERTEX + dz)])
    _, names, counts = tetra_pair(IDENTITY, x_b, np.array([0.0, 1.0, 0.0, 0.0]))
    assert names == ["q"] and counts.tolist() == [4]


def test_classification_rules():
    bi = [0, 0, 0, 2, 2, 3, 3, 3, 5, 5, 5, 5, 5]
    bj = [1, 1, 1, 4, 4, 4, 4, 4, 6, 6, 6, 6, 6]
    mi = [0, 1, 2, 0, 0, 0, 1, 2, 0, 0, 1, 1, 2]
    mj = [0, 1, 2, 1, 2, 0, 0, 0, 0, 1, 0, 1, 0]
    pairs, codes, counts = classify_aggregate_pairs(bi, bj, mi, mj)
    assert pairs.tolist() == [[0, 1], [2, 4], [3, 4], [5, 6]]
    assert [CONTACT_CLASS_NAMES[c] for c in codes] == ["t", "d", "t", "m"]
    assert counts.tolist() == [3, 2, 3, 5]


# ------------------------------------------------------------------------------ walls
def test_sphere_on_wall_gives_one_contact_with_wall_normal():
    library = ShapeLibrary.from_spheres([0.5])
    normal = np.array([0.0, 0.6, 0.8])
    wall_point = np.array([1.0, 2.0, 3.0])
    centre = wall_point + (0.5 - 1e-6) * normal
    state = BodyState.from_library(library, [0], [centre], 1000.0)
    contacts = NarrowPhase(alert=0.0).detect(state, library, np.zeros((0, 2), int),
                                             wall_points=[wall_point], wall_normals=[normal])
    assert contacts.n_contacts == 1
    assert contacts.body_i[0] == -1 and contacts.body_j[0] == 0
    assert contacts.gap[0] == pytest.approx(-1e-6, abs=1e-14)
    np.testing.assert_allclose(contacts.normal[0], normal, atol=1e-15)
    np.testing.assert_allclose(contacts.point[0], centre - (0.5 - 0.5e-6) * normal, atol=1e-14)


def test_aggregate_on_wall_touches_with_its_lowest_members():
    agg = tetrahedral_aggregate(radius=1.0, lam=0.5)
    library = ShapeLibrary.from_aggregates([agg])
    lowest = float(np.min(agg.centres[:, 2] - agg.radii))
    state = BodyState.from_library(library, [0], [[0.0, 0.0, -lowest - 1e-6]], 1000.0)
    contacts = NarrowPhase(alert=0.0).detect(state, library, np.zeros((0, 2), int),
                                             wall_points=[[0, 0, 0], [0, 0, 50.0]],
                                             wall_normals=[[0, 0, 1.0], [0, 0, -1.0]])
    expected = np.flatnonzero(np.isclose(agg.centres[:, 2], agg.centres[:, 2].min()))
    assert sorted(contacts.member_j.tolist()) == expected.tolist()
    assert (contacts.body_i == -1).all()
    np.testing.assert_allclose(contacts.gap, -1e-6, atol=1e-12)
