"""Polyhedron pairs in the sample measures (seed 002 §II.B, eqs. 13-14): the points of a pair
become one interaction carrying their resultant at the force-weighted centre, with the pair's
contact type; z counts pairs, z_c the nominal points of each type; spheres are unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.connectivity import Connectivity
from grainlab.analysis.snapshot_analysis import SnapshotAnalysis
from grainlab.analysis.snapshot_files import append_snapshot, read_snapshot
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.detect.narrow_phase import POLYHEDRON_CONTACT_TYPE_NAMES, Contacts
from grainlab.engine.sample_measures import (
    PAIR_TYPE_NAMES,
    contact_network,
    pair_resultants,
    sample_measures,
)
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import StepReport, contact_frames
from grainlab.geometry.polyhedron import from_vertices

DT = 1e-3
CUBE = from_vertices([[x, y, z] for x in (0, 1e-3) for y in (0, 1e-3) for z in (0, 1e-3)])


def report_of(body_i, body_j, points, normals, impulses, types) -> StepReport:
    n = len(body_i)
    normals = np.asarray(normals, dtype=float)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    contacts = Contacts(
        body_i=np.asarray(body_i), body_j=np.asarray(body_j),
        member_i=np.arange(n), member_j=np.arange(n), point=np.asarray(points, dtype=float),
        normal=normals, gap=np.zeros(n), contact_type=np.asarray(types, dtype=np.int8))
    return StepReport(n_contacts=n, iterations=1, converged=True, change=0.0, residual=0.0,
                      max_overlap=0.0, contacts=contacts, frames=contact_frames(normals),
                      impulses=np.asarray(impulses, dtype=float),
                      relative_velocity=np.zeros((n, 3)))


def four_cubes():
    library = ShapeLibrary.from_polyhedra([CUBE])
    positions = np.array([[0, 0, 0], [1e-3, 0, 0], [1e-3, 1e-3, 0], [0, 1e-3, 0]]) + 2e-3
    state = BodyState.from_library(library, [0, 0, 0, 0], positions, 2600.0)
    rng = np.random.default_rng(4)
    # pair (0, 1) ff: 3 points, one of them open; (1, 2) fe: 2 points; (2, 3) fv; (0, 3) ee;
    # wall 4 (z-) on body 0 ff: 3 points
    body_i = [0, 0, 0, 1, 1, 2, 0, -5, -5, -5]
    body_j = [1, 1, 1, 2, 2, 3, 3, 0, 0, 0]
    types = [4, 4, 4, 3, 3, 1, 2, 4, 4, 4]
    normals = [[1, 0.1, 0]] * 3 + [[0, 1, 0.2]] * 2 + [[-1, 0, 0], [0, 1, 0]] + [[0, 0, 1]] * 3
    points = positions[0] + 1e-3 * rng.random((10, 3))
    impulses = np.column_stack([[2e-3, 0.0, 1e-3, 3e-3, 5e-3, 1e-3, 4e-3, 1e-3, 1e-3, 2e-3],
                                1e-4 * rng.normal(size=(10, 2))])
    impulses[1, 1:] = 0.0  # the open point carries nothing
    return library, state, report_of(body_i, body_j, points, normals, impulses, types)


def test_pair_type_names_follow_the_narrow_phase_codes():
    assert PAIR_TYPE_NAMES[1:] == tuple(POLYHEDRON_CONTACT_TYPE_NAMES[1:])


def test_pair_resultant_against_a_loop():
    _, _, report = four_cubes()
    c = report.contacts
    loaded = np.flatnonzero((c.body_i >= 0) & (report.impulses[:, 0] > 0))
    forces = np.einsum("cji,cj->ci", report.frames, report.impulses)[loaded] / DT
    pairs, first, counts, force, centre, normal = pair_resultants(
        c.body_i[loaded], c.body_j[loaded], c.point[loaded], c.normal[loaded], forces, 4)
    assert pairs.tolist() == [[0, 1], [0, 3], [1, 2], [2, 3]]
    assert counts.tolist() == [2, 1, 2, 1]
    assert first.tolist() == [0, 5, 2, 4]  # loaded rows: (0,1) (0,1) (1,2) (1,2) (2,3) (0,3)
    for k, (i, j) in enumerate(pairs):
        rows = [r for r in range(len(loaded)) if (c.body_i[loaded][r], c.body_j[loaded][r])
                == (i, j)]
        f = forces[rows]
        fn = np.array([f[m] @ c.normal[loaded][r] for m, r in enumerate(rows)])
        np.testing.assert_allclose(force[k], f.sum(axis=0), rtol=1e-12)
        np.testing.assert_allclose(centre[k], (fn[:, None] * c.point[loaded][rows]).sum(0)
                                   / fn.sum(), rtol=1e-12)
        n = c.normal[loaded][rows].sum(axis=0)
        np.testing.assert_allclose(normal[k], n / np.linalg.norm(n), rtol=1e-12)


def test_network_has_one_interaction_per_polyhedron_pair(tmp_path):
    library, state, report = four_cubes()
    net = contact_network(report, state, library, 1e-6, DT, 0.4)
    assert net.n_pairs == 4 and net.n_points == 4
    assert net.type_names == PAIR_TYPE_NAMES
    names = [net.type_names[t] for t in net.pair_types]
    assert names == ["ff", "ee", "fe", "fv"]
    forces = np.einsum("cji,cj->ci", report.frames, report.impulses) / DT
    np.testing.assert_allclose(net.point_forces[0], forces[0] + forces[2], rtol=1e-12)
    np.testing.assert_allclose(net.pair_forces[2], forces[3] + forces[4], rtol=1e-12)
    # stress from the network = stress from the solver points (branch vectors per pair)
    inner = (report.contacts.body_i >= 0)
    branch = state.positions[report.contacts.body_j] - state.positions[
        np.maximum(report.contacts.body_i, 0)]
    expected = np.einsum("ci,cj->ij", branch[inner], forces[inner])
    got = np.einsum("ci,cj->ij", net.point_branches, net.point_forces)
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    c = Connectivity().compute(net)
    assert c.coordination_number == pytest.approx(2.0)
    assert c.type_proportions == {"point": 0.0, "fv": 0.25, "ee": 0.25, "fe": 0.25, "ff": 0.25}
    # the hand-off: through snapshots.h5 to the analysis (`grainlab analyse`)
    append_snapshot(tmp_path / "snapshots.h5", net)
    back = read_snapshot(tmp_path / "snapshots.h5", 0)
    descriptors = SnapshotAnalysis().compute(back).descriptors
    assert {k: descriptors[k] for k in ("k_fv", "k_ee", "k_fe", "k_ff")} == pytest.approx(
        {"k_fv": 0.25, "k_ee": 0.25, "k_fe": 0.25, "k_ff": 0.25})
    # eq. 14 in the analysis too: each resultant stands for its type's nominal points
    assert c.connectivity_number == pytest.approx(2.0 * (3 + 1 + 2 + 1) / 4)
    assert descriptors["connectivity_number"] == pytest.approx(c.connectivity_number)


def test_row_counts_pairs_and_nominal_points():
    library, state, report = four_cubes()
    box = WallBox(np.zeros(3), np.full(3, 5e-3))
    row, _ = sample_measures(report, state, library, box, box.lengths.copy(), DT, 0.4)
    assert row["z"] == pytest.approx(2.0)  # 4 pairs on 4 particles
    assert row["z_c"] == pytest.approx(2.0 * (3 + 1 + 2 + 1) / 4)  # seed 002 eq. 14
    assert row["z_c"] == pytest.approx(row["z"] * (1 + row["fraction_fe"]
                                                   + 2 * row["fraction_ff"]))
    assert row["z_c_points"] == pytest.approx(2.0 * 6 / 4)  # the open ff point not counted
    for name in ("fv", "ee", "fe", "ff"):
        assert row[f"fraction_{name}"] == pytest.approx(0.25)


def test_core_counts_the_contacts_of_particles_away_from_the_walls():
    """z_core, z_c_core: each core particle counts its own pairs and their nominal points,
    whatever its neighbour; particles near a wall are left out. Box 5 mm, <d> = 1.73 mm
    (twice the cube's circumradius): particles 1 and 2 (x = 3 mm) are core, 0 and 3
    (x = 1.5 mm) are not."""
    library, state, report = four_cubes()
    state.positions[:] = [[1.5e-3, 2e-3, 2.5e-3], [3e-3, 2e-3, 2.5e-3], [3e-3, 3e-3, 2.5e-3],
                          [1.5e-3, 3e-3, 2.5e-3]]
    box = WallBox(np.zeros(3), np.full(3, 5e-3))
    row, _ = sample_measures(report, state, library, box, box.lengths.copy(), DT, 0.4)
    # core 1: pairs (0,1) ff and (1,2) fe; core 2: (1,2) fe and (2,3) fv
    assert row["z_core"] == pytest.approx(4 / 2)
    assert row["z_c_core"] == pytest.approx((3 + 2 + 2 + 1) / 2)
    wide = WallBox(np.full(3, -5e-3), np.full(3, 10e-3))  # everyone core: z, z_c again
    row, _ = sample_measures(report, state, library, wide, wide.lengths.copy(), DT, 0.4)
    assert row["z_core"] == pytest.approx(row["z"])
    assert row["z_c_core"] == pytest.approx(row["z_c"])
    tight = WallBox(np.full(3, 1.5e-3), np.full(3, 3.5e-3))  # nobody core
    row, _ = sample_measures(report, state, library, tight, tight.lengths.copy(), DT, 0.4)
    assert np.isnan(row["z_core"]) and np.isnan(row["z_c_core"])


def test_spheres_keep_one_network_point_per_contact():
    library = ShapeLibrary.from_spheres([5e-4, 5e-4, 5e-4])
    positions = np.array([[1e-3, 1e-3, 1e-3], [2e-3, 1e-3, 1e-3], [1e-3, 2e-3, 1e-3]])
    state = BodyState.from_library(library, [0, 1, 2], positions, 2600.0)
    report = report_of([0, 0, -5], [1, 2, 0], [[1.5e-3, 1e-3, 1e-3], [1e-3, 1.5e-3, 1e-3],
                                               [1e-3, 1e-3, 5e-4]],
                       [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
                       [[1e-3, 0, 0], [2e-3, 0, 0], [3e-3, 0, 0]], [0, 0, 0])
    box = WallBox(np.zeros(3), np.full(3, 4e-3))
    row, net = sample_measures(report, state, library, box, box.lengths.copy(), DT, 0.4)
    assert net.pair_types is None and net.n_points == 2
    np.testing.assert_array_equal(net.point_positions, report.contacts.point[:2])
    assert row["z"] == row["z_c"] == pytest.approx(4 / 3)
    assert not any(k.startswith("fraction_") or k == "z_c_points" for k in row)
