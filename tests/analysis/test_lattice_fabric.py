"""Hand-built periodic lattices: exact stress, coordination and fabric (issue tests)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from grainlab.analysis import ContactNetwork, SnapshotAnalysis

R = 1e-3


def lattice_network(basis: np.ndarray, cell: float, n: int, directions: np.ndarray,
                    force_of_direction) -> ContactNetwork:
    """Periodic spheres of radius R: ``basis`` (fractional, in a cubic cell of side ``cell``)
    repeated n x n x n; every particle is paired with its neighbour at +2R d for each of the
    given ``directions`` (one of each +/- pair), carrying force_of_direction(d) d."""
    positions = np.array([(np.array(c) + b) * cell for c in itertools.product(range(n), repeat=3)
                          for b in basis])
    side = n * cell
    index = {tuple(np.round((p % side) / (cell / 4)).astype(int) % (4 * n)): k
             for k, p in enumerate(positions)}
    pairs, branches, forces, normals, points = [], [], [], [], []
    for k, p in enumerate(positions):
        for d in directions:
            q = (p + 2 * R * d) % side
            j = index[tuple(np.round(q / (cell / 4)).astype(int) % (4 * n))]
            pairs.append((k, j))
            branches.append(2 * R * d)
            normals.append(d)
            forces.append(force_of_direction(d) * d)
            points.append(p + R * d)
    m = len(pairs)
    return ContactNetwork(
        positions=positions, volumes=np.full(len(positions), 4 / 3 * np.pi * R**3),
        volume=side**3, pair_particles=pairs, pair_branches=branches,
        point_pairs=np.arange(m), point_positions=points, point_normals=normals,
        point_forces=forces, friction_coefficient=0.5,
    )


def test_simple_cubic_under_a_known_load():
    forces = {0: 1.0, 1: 1.5, 2: 4.0}  # N along x, y, z
    net = lattice_network(np.zeros((1, 3)), 2 * R, 3, np.eye(3),
                          lambda d: forces[int(np.argmax(np.abs(d)))])
    analysis = SnapshotAnalysis().compute(net)
    sigma = analysis.stress.tensor
    # One particle and three contacts (one per axis) per cell of volume (2R)^3.
    np.testing.assert_allclose(np.diag(sigma), [forces[k] * 2 * R / (2 * R) ** 3 for k in range(3)],
                               rtol=1e-12)
    d = analysis.descriptors
    assert d["coordination_number"] == pytest.approx(6.0)
    assert d["connectivity_number"] == pytest.approx(6.0)
    assert d["packing_fraction"] == pytest.approx(np.pi / 6)
    np.testing.assert_allclose(analysis.fabric.tensors["F"], np.eye(3) / 3, atol=1e-12)
    assert d["a_c"] == pytest.approx(0.0, abs=1e-12)
    # Major axis z, minor x: a_fn = 5/2 (f_z - f_x) / (f_x + f_y + f_z).
    assert d["a_fn"] == pytest.approx(2.5 * (4.0 - 1.0) / 6.5, rel=1e-12)
    # q/p = (s1 - s3)/tr(s) = (f_z - f_x)/(sum f) = 2/5 a_fn: eq. 27a exact here.
    assert d["q_over_trace"] == pytest.approx(3.0 / 6.5, rel=1e-12)
    assert d["q_over_trace_27a"] == pytest.approx(d["q_over_trace"], rel=1e-10)


def test_fcc_under_isotropic_forces():
    fcc = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    half = np.array([[1, 1, 0], [1, -1, 0], [1, 0, 1], [1, 0, -1], [0, 1, 1], [0, 1, -1]])
    directions = half / np.sqrt(2.0)
    f = 2.0
    net = lattice_network(fcc, 2 * np.sqrt(2) * R, 2, directions, lambda d: f)
    analysis = SnapshotAnalysis().compute(net)
    # Six pairs per particle, sum of n n over them = 2 I; V per particle = a^3/4 = 4 sqrt2 R^3.
    np.testing.assert_allclose(analysis.stress.tensor, f / (np.sqrt(2) * R**2) * np.eye(3),
                               rtol=1e-12, atol=1e-9)
    d = analysis.descriptors
    assert d["coordination_number"] == pytest.approx(12.0)
    assert d["packing_fraction"] == pytest.approx(np.pi / (3 * np.sqrt(2)))
    np.testing.assert_allclose(analysis.fabric.tensors["F"], np.eye(3) / 3, atol=1e-12)
    for key in ("a_c", "a_fn", "a_ft", "a_c_branch", "q_over_trace"):
        assert d[key] == pytest.approx(0.0, abs=1e-12)
    assert d["rattler_fraction"] == 0.0
