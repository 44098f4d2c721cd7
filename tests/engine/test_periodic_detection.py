"""Contact detection in a periodic triclinic cell: the cell by hand, contacts across a face, an
edge and a corner against the same pair inside the cell, the fast detection against its
all-pairs, all-images twin, and invariances (lattice translations, origin, labels, rotation,
re-map of a sheared cell) for spheres, aggregates and polyhedra (STYLE.md 11, 12)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from grainlab.engine.detect import polyhedron_narrow_phase
from grainlab.engine.detect.narrow_phase import NarrowPhase
from grainlab.engine.detect.periodic_detection import (
    PeriodicContacts,
    PeriodicDetection,
    periodic_contacts_slow,
)
from grainlab.engine.detect.polyhedron_narrow_phase import world_polyhedra
from grainlab.engine.quaternion import quat_multiply, quat_to_matrices
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import random_polyhedron
from grainlab.geometry.triclinic_cell import TriclinicCell
from grainlab.prep.loose_sample import random_orientations
from grainlab.prep.sample_shapes import aggregate_library, scaled_polyhedron

ALERT = 0.15
KINDS = ("sphere", "aggregate", "polyhedron")
SHEARED = np.array([[1.0, 0.3, -0.2], [0.1, 1.05, 0.25], [0.0, 0.0, 0.95]])
"""A triclinic cell shape (columns the cell vectors), scaled per sample."""
TOL = 1e-9


# --------------------------------------------------------------------------------------------
# Samples
# --------------------------------------------------------------------------------------------


def _library(kind: str, radii: np.ndarray, rng: np.random.Generator) -> ShapeLibrary:
    """One shape per radius [m] (bounding radius = radius)."""
    if kind == "sphere":
        return ShapeLibrary.from_spheres(radii)
    if kind == "aggregate":
        return aggregate_library(radii, 0.4)
    if kind == "polyhedron":
        templates = [random_polyhedron(20, rng) for _ in range(3)]
        return ShapeLibrary.from_polyhedra([scaled_polyhedron(templates[k % 3], 2.0 * r)
                                            for k, r in enumerate(radii)])
    third = radii.shape[0] // 3  # mixed: spheres, aggregates and polyhedra in one library
    return _library("sphere", radii[:third], rng).concatenate(
        _library("aggregate", radii[third:2 * third], rng)).concatenate(
        _library("polyhedron", radii[2 * third:], rng))


def _scaled_cell(base: np.ndarray, cutoff: float, factor: float = 3.3) -> TriclinicCell:
    """``base`` scaled so that its thinnest width is ``factor`` x ``cutoff`` [m]."""
    return TriclinicCell(base * factor * cutoff / TriclinicCell(base).widths.min())


def _too_close(cell: TriclinicCell, centres: np.ndarray, x: np.ndarray,
               reach: np.ndarray) -> bool:
    """Whether the point ``x`` [m] is within ``reach`` (per centre) [m] of a ``centres`` row
    (minimum image)."""
    if centres.shape[0] == 0:
        return False
    d = cell.fractional(centres - x)
    d = (d - np.rint(d)) @ cell.matrix.T
    return bool((np.linalg.norm(d, axis=1) < reach).any())


def _placed(cell: TriclinicCell, bounding: np.ndarray, rng: np.random.Generator,
            ratio: float = 0.6) -> np.ndarray:
    """Random centres in the cell whose bounding spheres overlap by less than 1 - ``ratio``
    of the sum of radii (minimum image)."""
    centres = np.zeros((0, 3))
    for k in range(bounding.shape[0]):
        for _ in range(10000):
            x = cell.matrix @ rng.random(3)
            if not _too_close(cell, centres, x, ratio * (bounding[k] + bounding[:k])):
                centres = np.vstack([centres, x])
                break
        else:
            raise AssertionError("sample too dense")
    return centres


def random_sample(kind: str, n: int = 45, seed: int = 0, base: np.ndarray = SHEARED,
                  far: bool = True):
    """(library, state, cell): ``n`` bodies of ``kind`` with bounding radii in [0.4, 0.6] m in
    a triclinic cell 3.3 R_cut thin, each moved by a random lattice vector of up to 3 cells
    per axis when ``far`` (unwrapped positions)."""
    rng = np.random.default_rng(seed)
    radii = rng.uniform(0.4, 0.6, n)
    library = _library(kind, radii, rng)
    cell = _scaled_cell(base, 2.0 * library.bounding_radius.max() + ALERT)
    x = _placed(cell, library.bounding_radius, rng)
    if far:
        x = x + rng.integers(-3, 4, (n, 3)) @ cell.matrix.T
    state = BodyState.from_library(library, np.arange(n), x, 1000.0,
                                   orientations=random_orientations(n, rng))
    return library, state, cell


def keyed(found: PeriodicContacts, labels=None, h=None) -> dict:
    """Rows by (body_i, body_j, member_i, member_j, image) -> (gap, normal, point, type), in
    the bodies' ``labels`` (identity when None); a row whose relabelled body_i > body_j is
    written from the other side (members swapped, image and normal negated, point moved
    by -h image next to the other body)."""
    c = found.contacts
    out = {}
    for k in range(found.n_contacts):
        i, j = int(c.body_i[k]), int(c.body_j[k])
        if labels is not None:
            i, j = int(labels[i]), int(labels[j])
        mi, mj, n = int(c.member_i[k]), int(c.member_j[k]), found.images[k]
        normal, point = c.normal[k], c.point[k]
        if i > j:
            i, j, mi, mj, n = j, i, mj, mi, -n
            normal, point = -normal, point + h @ n
        key = (i, j, mi, mj, *(int(v) for v in n))
        assert key not in out, f"row {key} twice"
        out[key] = (float(c.gap[k]), normal, point, int(c.contact_type[k]))
    return out


def assert_same(found: dict, expected: dict, scale: float = 1.0, rotation=None,
                shift=None) -> None:
    """The same keys; equal gaps, normals (rotated by ``rotation``) and points (rotated, then
    moved by ``shift``) to TOL x ``scale``; equal contact types."""
    assert found.keys() == expected.keys(), (sorted(found.keys() - expected.keys())[:4],
                                             sorted(expected.keys() - found.keys())[:4])
    rotation = np.eye(3) if rotation is None else rotation
    shift = np.zeros(3) if shift is None else shift
    for key, (gap, normal, point, kind) in expected.items():
        g, n, p, t = found[key]
        assert abs(g - gap) <= TOL * scale, key
        np.testing.assert_allclose(n, rotation @ normal, atol=TOL, err_msg=str(key))
        np.testing.assert_allclose(p, rotation @ point + shift, atol=TOL * scale,
                                   err_msg=str(key))
        assert t == kind, key


# --------------------------------------------------------------------------------------------
# The cell
# --------------------------------------------------------------------------------------------


def test_volume_and_widths_of_a_sheared_cell_by_hand():
    a, b, c, gamma = 2.0, 3.0, 1.5, 0.6
    cell = TriclinicCell(np.array([[a, gamma * a, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]]))
    assert cell.volume == pytest.approx(a * b * c, rel=1e-14)
    # c2 x c3 = (b c, -gamma a c, 0); c3 x c1 = (0, a c, 0); c1 x c2 = (0, 0, a b)
    expected = [a * b / np.hypot(b, gamma * a), b, c]
    np.testing.assert_allclose(cell.widths, expected, rtol=1e-14)


@pytest.mark.parametrize("gamma", [0.8, 2.7, -1.6])
def test_reduced_cell_keeps_the_lattice_and_removes_the_skew(gamma):
    rng = np.random.default_rng(4)
    h = np.array([[1.0, gamma, 0.3], [0.0, 1.2, -2.1], [0.0, 0.0, 0.9]]) \
        + 0.05 * rng.standard_normal((3, 3))
    cell = TriclinicCell(h)
    reduced, m = cell.reduced()
    assert m.dtype == np.int64 and round(np.linalg.det(m)) == 1
    np.testing.assert_allclose(cell.inverse @ reduced.matrix, m, atol=1e-12)
    np.testing.assert_allclose(reduced.matrix, h @ m, atol=1e-12)
    assert reduced.volume == pytest.approx(cell.volume, rel=1e-12)
    columns = reduced.matrix.T
    for a in range(3):
        for b in range(3):
            if a != b:
                assert abs(columns[b] @ columns[a]) <= 0.5 * (columns[a] @ columns[a]) + 1e-12
    assert reduced.widths.min() > cell.widths.min()
    again, identity = reduced.reduced()
    np.testing.assert_array_equal(identity, np.eye(3, dtype=np.int64))
    np.testing.assert_array_equal(again.matrix, reduced.matrix)


def test_fractional_wrap_round_trips_and_checkpoint_arrays():
    rng = np.random.default_rng(5)
    cell = TriclinicCell(2.0 * SHEARED)
    x = rng.uniform(-20.0, 20.0, (200, 3))
    s = cell.fractional(x)
    np.testing.assert_allclose(s @ cell.matrix.T, x, atol=1e-12)
    counts = cell.wrap_counts(x)
    assert counts.dtype == np.int64 and np.abs(counts).max() >= 3
    wrapped = cell.wrapped(x)
    np.testing.assert_allclose(wrapped + counts @ cell.matrix.T, x, atol=1e-12)
    inside = cell.fractional(wrapped)
    assert (inside >= -1e-12).all() and (inside < 1.0 + 1e-12).all()
    k = np.array([2, -1, 5])
    np.testing.assert_array_equal(cell.wrap_counts(x + k @ cell.matrix.T), counts + k)
    restored = TriclinicCell.from_arrays(cell.to_arrays())
    np.testing.assert_array_equal(restored.matrix, cell.matrix)


@pytest.mark.parametrize("matrix", [
    np.eye(2), np.diag([1.0, np.nan, 1.0]), np.diag([1.0, 1.0, -1.0]),
    np.array([[1.0, 2.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]]), "cube",
], ids=["2x2", "nan", "left-handed", "singular", "text"])
def test_bad_cell_matrices_are_refused_naming_the_field(matrix):
    with pytest.raises(InputError) as error:
        TriclinicCell(matrix)
    assert error.value.field == "cell matrix"


def test_reduction_below_half_skew_is_refused():
    with pytest.raises(InputError) as error:
        TriclinicCell.cube(1.0).reduced(max_skew=0.4)
    assert error.value.field == "max_skew"


# --------------------------------------------------------------------------------------------
# Across a face, an edge, a corner
# --------------------------------------------------------------------------------------------


def _support(library: ShapeLibrary, state: BodyState, n: int, u: np.ndarray) -> float:
    """max over body n of (y - x_n) . u [m]: its extent along the unit vector u."""
    s = state.shape_ids[n]
    rotation = quat_to_matrices(state.orientations[n:n + 1])[0]
    if library.sphere_count[s]:
        rows = slice(library.sphere_start[s], library.sphere_start[s] + library.sphere_count[s])
        return float(np.max(library.sphere_offsets[rows] @ rotation.T @ u
                            + library.sphere_radii[rows]))
    rows = slice(library.vertex_start[s], library.vertex_start[s] + library.vertex_count[s])
    return float(np.max(library.vertices[rows] @ rotation.T @ u))


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("crossed", [(1, 0, 0), (0, 1, 1), (1, 1, 1)],
                         ids=["face", "edge", "corner"])
def test_contact_across_the_boundary_equals_the_pair_inside_the_cell(kind, crossed):
    rng = np.random.default_rng(11)
    library = _library(kind, np.array([0.5, 0.42]), rng)
    cell = _scaled_cell(SHEARED, 2.0 * library.bounding_radius.max() + ALERT)
    h = cell.matrix
    crossed = np.array(crossed)
    # body 0 near the faces to cross; body 1 just beyond them, touching it
    s0 = np.where(crossed == 1, 0.03, 0.5)
    u = h @ (-crossed.astype(float))
    u /= np.linalg.norm(u)
    state = BodyState.from_library(library, [0, 1], np.zeros((2, 3)), 1000.0,
                                   orientations=random_orientations(2, rng))
    distance = _support(library, state, 0, u) + _support(library, state, 1, -u) - 0.02
    x0 = h @ s0
    x1 = x0 + distance * u
    assert (cell.wrap_counts(x1) == -crossed).all()  # beyond every crossed face, no other
    # the same pair moved inside the cell, without periodicity
    shift = h @ (0.5 * crossed)
    state.positions[:] = [x0 + shift, x1 + shift]
    expected = NarrowPhase(ALERT).detect(state, library, np.array([[0, 1]]))
    assert expected.n_contacts >= 1
    # the periodic pair, body 1 given by its image inside the cell
    state.positions[:] = [x0, cell.wrapped(x1)]
    found = PeriodicDetection(ALERT).detect(state, library, cell)
    assert found.n_contacts == expected.n_contacts
    np.testing.assert_array_equal(found.images, np.tile(-crossed, (found.n_contacts, 1)))
    c = found.contacts
    np.testing.assert_array_equal(c.body_i, expected.body_i)
    np.testing.assert_array_equal(c.body_j, expected.body_j)
    np.testing.assert_array_equal(c.member_i, expected.member_i)
    np.testing.assert_array_equal(c.member_j, expected.member_j)
    np.testing.assert_array_equal(c.contact_type, expected.contact_type)
    np.testing.assert_allclose(c.gap, expected.gap, atol=TOL)
    np.testing.assert_allclose(c.normal, expected.normal, atol=TOL)
    np.testing.assert_allclose(c.point, expected.point - shift, atol=TOL)


# --------------------------------------------------------------------------------------------
# Against the slow twin
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", [*KINDS, "mixed"])
def test_detection_matches_all_pairs_all_images(kind):
    library, state, cell = random_sample(kind, seed=1)
    found = PeriodicDetection(ALERT).detect(state, library, cell)
    expected = periodic_contacts_slow(state, library, cell, ALERT)
    pairs = {(int(i), int(j)) for i, j in zip(found.contacts.body_i, found.contacts.body_j,
                                              strict=True)}
    assert len(pairs) >= 15  # a sample worth the name
    assert (np.abs(found.images).sum(axis=1) > 0).any()
    assert (found.contacts.body_i < found.contacts.body_j).all()
    assert_same(keyed(found), keyed(expected))


@pytest.mark.parametrize("sphere_rows", [False, True])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_pair_at_the_full_reach_across_a_face_is_found(axis, sphere_rows):
    # two spheres of the largest radius, as far apart as a contact can be, across a face of
    # a cell as thin as allowed, along the face's normal: the ghost layer must be that deep
    r = 0.5
    library = ShapeLibrary.from_spheres([r])
    cutoff = 2 * r + ALERT
    cell = _scaled_cell(SHEARED, cutoff, factor=3.0 + 1e-9)
    normal = cell.inverse[axis] / np.linalg.norm(cell.inverse[axis])
    s0 = np.full(3, 0.5)
    s0[axis] = 1e-12
    x0 = cell.matrix @ s0
    x1 = x0 - (cutoff - 1e-9) * normal
    state = BodyState.from_library(library, [0, 0], [x0, x1], 1000.0)
    found = PeriodicDetection(ALERT).detect(state, library, cell, sphere_rows=sphere_rows)
    assert found.n_contacts == 1
    assert found.contacts.gap[0] == pytest.approx(ALERT - 1e-9, abs=1e-12)
    np.testing.assert_array_equal(found.images[0], 0)  # unwrapped x1 is the touching image
    state.positions[1] = cell.wrapped(x1)
    found = PeriodicDetection(ALERT).detect(state, library, cell, sphere_rows=sphere_rows)
    np.testing.assert_array_equal(found.images[0], -np.eye(3, dtype=np.int64)[axis])


@pytest.mark.parametrize("kind", KINDS)
def test_bodies_on_faces_edges_and_corners_match_the_slow_twin(kind):
    library, state, cell = random_sample(kind, seed=8)
    rng = np.random.default_rng(9)
    bounding = library.bounding_radius[state.shape_ids]
    snapped = 0
    for body in rng.permutation(state.n_bodies):  # 1 to 3 axes on a face, as long as no
        s = cell.fractional(state.positions[body])  # two bodies come to overlap deeply
        axes = rng.choice(3, rng.integers(1, 4), replace=False)
        s[axes] = np.floor(s[axes]) + rng.choice([0.0, 1.0, -1e-17, 1.0 - 1e-16], axes.size)
        x = cell.matrix @ s
        others = np.delete(np.arange(state.n_bodies), body)
        if not _too_close(cell, state.positions[others], x,
                          0.6 * (bounding[body] + bounding[others])):
            state.positions[body] = x
            snapped += 1
    assert snapped >= 10
    found = PeriodicDetection(ALERT).detect(state, library, cell)
    expected = periodic_contacts_slow(state, library, cell, ALERT)
    assert (found.contacts.body_i < found.contacts.body_j).all()
    assert_same(keyed(found), keyed(expected), scale=10.0)


@pytest.mark.parametrize("seed", [1, 8])
@pytest.mark.parametrize("snap", [False, True])
def test_the_cell_list_of_plain_spheres_matches_the_slow_twin(seed, snap):
    # the compiled cell list (sphere_rows) finds the same rows as all pairs and all images,
    # bodies far outside the cell, on its faces, edges and corners; rows by body_i, body_j
    library, state, cell = random_sample("sphere", seed=seed)
    if snap:
        rng = np.random.default_rng(seed)
        s = cell.fractional(state.positions)
        faces = rng.random(s.shape) < 0.3
        s[faces] = np.floor(s[faces]) + rng.choice([0.0, 1.0, -1e-17, 1.0 - 1e-16],
                                                   int(faces.sum()))
        state.positions[:] = s @ cell.matrix.T
    found = PeriodicDetection(ALERT).detect(state, library, cell, sphere_rows=True)
    expected = periodic_contacts_slow(state, library, cell, ALERT)
    assert found.n_contacts >= 15
    c = found.contacts
    order = np.lexsort((c.body_j, c.body_i))
    np.testing.assert_array_equal(order, np.arange(found.n_contacts))
    assert (c.body_i < c.body_j).all()
    assert_same(keyed(found), keyed(expected), scale=10.0)


def polydisperse_spheres(seed: int):
    """600 spheres of radii in [0.25, 0.5] at random in a sheared cell nine cut-offs wide
    (alert ALERT), many bins per axis, positions up to two cells away: library, state, cell."""
    rng = np.random.default_rng(seed)
    radii = rng.uniform(0.25, 0.5, 600)
    library = ShapeLibrary.from_spheres(radii)
    cell = _scaled_cell(SHEARED, 2 * radii.max() + ALERT, factor=9.0)
    x = _placed(cell, radii, rng, ratio=0.9) + rng.integers(-2, 3, (600, 3)) @ cell.matrix.T
    return library, BodyState.from_library(library, np.arange(600), x, 1000.0), cell


def test_the_cell_list_keeps_the_general_detections_contacts_in_a_large_sample():
    # 600 polydisperse spheres, many bins per axis, a sheared cell: the same rows as the
    # ghost layer and broad phase
    library, state, cell = polydisperse_spheres(seed=4)
    detection = PeriodicDetection(ALERT)
    fast = detection.detect(state, library, cell, sphere_rows=True)
    general = detection.detect(state, library, cell)
    assert fast.n_contacts >= 200
    assert_same(keyed(fast), keyed(general))


@pytest.mark.parametrize("alert", [ALERT, 2.0])
def test_the_cell_lists_chunks_on_the_threads_give_the_serial_rows(monkeypatch, alert):
    # 600 polydisperse spheres in a sheared cell by chunks of bodies (the threads' road) and
    # one after the other: the same rows in the same order, bit for bit; with an alert of
    # 2.7 diameters the chunks overflow their share of the scratch and are run again
    from grainlab.engine.detect import periodic_spheres

    library, state, cell = polydisperse_spheres(seed=5)
    runs = []
    for threshold in (10**9, 0):
        monkeypatch.setattr(periodic_spheres, "PARALLEL_SPHERES", threshold)
        monkeypatch.setattr(numba, "get_num_threads", lambda: 2)  # the chunks, any machine
        runs.append(PeriodicDetection(alert).detect(state, library, cell, sphere_rows=True))
    serial, chunked = runs
    assert serial.n_contacts > (8 * 600 if alert == 2.0 else 200)
    for name in ("body_i", "body_j", "point", "normal", "gap"):
        np.testing.assert_array_equal(getattr(serial.contacts, name),
                                      getattr(chunked.contacts, name))
    np.testing.assert_array_equal(serial.images, chunked.images)


CONTACT_FIELDS = ("body_i", "body_j", "member_i", "member_j", "point", "normal", "gap",
                  "contact_type")
"""The arrays of a contact table compared bit for bit."""


def _on_one_thread(call):
    """``call()`` run with Numba on one thread (its thread count put back after)."""
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        return call()
    finally:
        numba.set_num_threads(threads)


def test_detection_does_not_depend_on_the_number_of_threads():
    library, state, cell = random_sample("mixed", seed=2)
    detection = PeriodicDetection(ALERT)
    one = _on_one_thread(lambda: detection.detect(state, library, cell))
    many = detection.detect(state, library, cell)
    for name in CONTACT_FIELDS:
        np.testing.assert_array_equal(getattr(one.contacts, name), getattr(many.contacts, name))
    np.testing.assert_array_equal(one.images, many.images)


@pytest.mark.parametrize("parallel_from", [0, 10**9])
def test_the_polyhedra_pairs_tested_at_once_give_each_pair_s_own_rows_in_order(
        monkeypatch, parallel_from):
    """The narrow phase tests the polyhedra's pairs on the threads (from
    ``PARALLEL_PAIRS`` pairs on; here from none, or never), then writes them in the pairs'
    order: the rows of all the pairs at once are those of each pair detected alone, one after
    the other, bit for bit, on one thread or on all of them (polyhedra with polyhedra, with
    aggregates and with spheres in one library)."""
    monkeypatch.setattr(polyhedron_narrow_phase, "PARALLEL_PAIRS", parallel_from)
    library, state, _ = random_sample("mixed", n=90, seed=4, far=False)
    reach = library.bounding_radius[state.shape_ids]
    gaps = np.linalg.norm(state.positions[:, None] - state.positions[None], axis=2) \
        - reach[:, None] - reach[None]
    pairs = np.argwhere(np.triu(gaps <= ALERT, 1))
    is_poly = world_polyhedra(state, library).is_poly
    with_polyhedron = is_poly[pairs[:, 0]] | is_poly[pairs[:, 1]]
    # the sphere-based pairs' rows come first, then those of the pairs with a polyhedron
    pairs = np.concatenate([pairs[~with_polyhedron], pairs[with_polyhedron]])
    detection = NarrowPhase(ALERT)
    alone = [detection.detect(state, library, pair[None]) for pair in pairs]
    one = _on_one_thread(lambda: detection.detect(state, library, pairs))
    many = detection.detect(state, library, pairs)
    kinds = set(np.unique(many.contact_type).tolist())
    assert {1, 2, 3, 4} & kinds and 0 in kinds  # polyhedron pairs and sphere-based rows
    assert (is_poly[pairs[:, 0]] & is_poly[pairs[:, 1]]).sum() >= 10
    assert (is_poly[pairs[:, 0]] != is_poly[pairs[:, 1]]).sum() >= 10
    for name in CONTACT_FIELDS:
        expected = np.concatenate([getattr(c, name) for c in alone])
        np.testing.assert_array_equal(getattr(one, name), expected, err_msg=name)
        np.testing.assert_array_equal(getattr(many, name), expected, err_msg=name)


# --------------------------------------------------------------------------------------------
# Invariances
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", KINDS)
def test_lattice_translations_of_bodies_change_only_the_images(kind):
    library, state, cell = random_sample(kind, seed=3)
    h = cell.matrix
    expected = PeriodicDetection(ALERT).detect(state, library, cell)
    k = np.random.default_rng(6).integers(-4, 5, (state.n_bodies, 3))
    state.positions += k @ h.T
    found = PeriodicDetection(ALERT).detect(state, library, cell)
    # contact (i, j, n) becomes (i, j, n + k_i - k_j), its point moves by h k_i
    c = expected.contacts
    moved = PeriodicContacts(
        type(c)(c.body_i, c.body_j, c.member_i, c.member_j, c.point + k[c.body_i] @ h.T,
                c.normal, c.gap, c.contact_type),
        expected.images + k[c.body_i] - k[c.body_j])
    assert_same(keyed(found), keyed(moved), scale=10.0)


@pytest.mark.parametrize("kind", KINDS)
def test_moving_the_origin_keeps_the_contacts(kind):
    library, state, cell = random_sample(kind, seed=4)
    expected = PeriodicDetection(ALERT).detect(state, library, cell)
    t = np.array([0.37, -1.91, 2.64])
    state.positions += t
    found = PeriodicDetection(ALERT).detect(state, library, cell)
    assert_same(keyed(found), keyed(expected), scale=10.0, shift=t)


@pytest.mark.parametrize("kind", KINDS)
def test_relabelling_the_bodies_keeps_the_physical_contacts(kind):
    library, state, cell = random_sample(kind, seed=5)
    expected = PeriodicDetection(ALERT).detect(state, library, cell)
    perm = np.random.default_rng(7).permutation(state.n_bodies)  # new body k is old perm[k]
    relabelled = BodyState.from_library(library, state.shape_ids[perm], state.positions[perm],
                                        1000.0, orientations=state.orientations[perm])
    found = PeriodicDetection(ALERT).detect(relabelled, library, cell)
    assert_same(keyed(found, labels=perm, h=cell.matrix), keyed(expected), scale=10.0)


@pytest.mark.parametrize("kind", KINDS)
def test_rotating_the_whole_problem_rotates_the_normals(kind):
    library, state, cell = random_sample(kind, seed=6)
    expected = PeriodicDetection(ALERT).detect(state, library, cell)
    q_r = random_orientations(1, np.random.default_rng(8))[0]
    rotation = quat_to_matrices(q_r[None])[0]
    rotated_cell = TriclinicCell(rotation @ cell.matrix)
    rotated = BodyState.from_library(
        library, state.shape_ids, state.positions @ rotation.T, 1000.0,
        orientations=[quat_multiply(q_r, q) for q in state.orientations])
    found = PeriodicDetection(ALERT).detect(rotated, library, rotated_cell)
    assert_same(keyed(found), keyed(expected), scale=10.0, rotation=rotation)


@pytest.mark.parametrize("kind", KINDS)
def test_re_mapping_a_sheared_cell_keeps_the_contacts(kind):
    base = np.array([[1.0, 0.8, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # gamma = 0.8
    library, state, cell = random_sample(kind, seed=7, base=base)
    reduced, m = cell.reduced()
    assert not np.array_equal(m, np.eye(3))
    expected = PeriodicDetection(ALERT).detect(state, library, cell)
    found = PeriodicDetection(ALERT).detect(state, library, reduced)
    # h n = h' M^-1 n: the image vectors of the re-mapped cell are M^-1 n
    m_inverse = np.rint(np.linalg.inv(m)).astype(np.int64)
    c = expected.contacts
    remapped = PeriodicContacts(c, expected.images @ m_inverse.T)
    assert (remapped.images != expected.images).any()
    assert_same(keyed(found), keyed(remapped), scale=10.0)


# --------------------------------------------------------------------------------------------
# Refusals
# --------------------------------------------------------------------------------------------


def test_a_cell_thinner_than_three_cut_offs_is_refused():
    library = ShapeLibrary.from_spheres([0.5])
    state = BodyState.from_library(library, [0, 0], [[0.5, 0.5, 0.5], [2.0, 2.0, 2.0]], 1000.0)
    cutoff = 2 * 0.5 + ALERT
    thin = TriclinicCell(np.diag([4.0, 2.9 * cutoff, 4.0]))
    with pytest.raises(InputError) as error:
        PeriodicDetection(ALERT).detect(state, library, thin)
    assert error.value.field == "periodic cell width"
    assert error.value.value == pytest.approx(2.9 * cutoff)
    assert f"{3 * cutoff:g} m" in str(error.value)
    found = PeriodicDetection(ALERT).detect(state, library, TriclinicCell.cube(3 * cutoff))
    assert found.n_contacts == 0
