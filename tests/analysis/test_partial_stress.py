"""Partial stresses by contact type (seed 002 eq. 29, seed 003 eq. 26): they sum to the total
stress, their q_gamma/p sum to q/p, a hand-computed lattice split, invariance.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.contact_stress import StressState
from grainlab.analysis.partial_stress import PartialStresses, partial_stress_tensors
from grainlab.errors import InputError

R = 1.0e-3


def typed_simple_cubic(forces_xyz, n=2) -> ContactNetwork:
    """Periodic simple cubic lattice; pairs along x, y, z are of types "a", "b", "c" and carry
    the compressive forces f_x, f_y, f_z along their branches."""
    a = 2.0 * R
    cells = np.array(list(itertools.product(range(n), repeat=3)))
    index = {tuple(c): k for k, c in enumerate(cells)}
    pairs, branches, types, forces = [], [], [], []
    for k, c in enumerate(cells):
        for axis in range(3):
            e = np.eye(3)[axis]
            pairs.append((k, index[tuple((c + np.eye(3, dtype=int)[axis]) % n)]))
            branches.append(a * e)
            types.append(axis)
            forces.append(forces_xyz[axis] * e)
    m = len(pairs)
    normals = np.array(branches) / a
    return ContactNetwork.from_arrays(
        positions=a * cells, volumes=np.full(len(cells), 4 / 3 * np.pi * R**3),
        volume=(n * a) ** 3, pair_particles=pairs, pair_branches=branches,
        point_pairs=np.arange(m), point_positions=a * cells[np.array(pairs)[:, 0]] + R * normals,
        point_normals=normals, point_forces=forces, pair_types=types,
        type_names=("a", "b", "c"))


def random_typed_network(rng, d=3, n=20, n_pairs=80) -> ContactNetwork:
    positions = rng.uniform(0, 1, (n, d))
    i = rng.integers(0, n, n_pairs)
    j = (i + rng.integers(1, n, n_pairs)) % n
    branches = positions[j] - positions[i] + rng.integers(-1, 2, (n_pairs, d))
    counts = rng.integers(1, 4, n_pairs)
    point_pairs = np.repeat(np.arange(n_pairs), counts)
    c = point_pairs.size
    normals = rng.normal(size=(c, d))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    # mostly compressive forces roughly along the branches, with an anisotropic bias
    bias = np.array([2.0, 1.0, 0.5][:d])
    forces = (branches[point_pairs] * bias * rng.uniform(0.5, 1.5, (c, 1))
              + 0.2 * rng.normal(size=(c, d)))
    return ContactNetwork.from_arrays(
        positions=positions, volumes=np.full(n, 1e-3), volume=1.0,
        pair_particles=np.column_stack([i, j]), pair_branches=branches,
        point_pairs=point_pairs, point_positions=np.zeros((c, d)), point_normals=normals,
        point_forces=forces, pair_types=rng.integers(0, 4, n_pairs),
        type_names=("fv", "ee", "fe", "ff"))


def test_lattice_split_by_axis():
    # sigma_a = diag(3c, 0, 0), sigma_b = diag(0, 2c, 0), sigma_c = diag(0, 0, c),
    # c = 2R/(2R)^3; p = 2c, e_1 = e_x, e_3 = e_z:
    # q_a/p = 3c/3/2c = 1/2, q_b/p = 0, q_c/p = -c/3/2c = -1/6; sum 1/3 = q/p.
    net = typed_simple_cubic([3.0, 2.0, 1.0])
    c = 2 * R / (2 * R) ** 3
    part = PartialStresses().compute(net)
    np.testing.assert_allclose(part.tensors["a"], np.diag([3 * c, 0, 0]), rtol=1e-12)
    np.testing.assert_allclose(part.tensors["b"], np.diag([0, 2 * c, 0]), rtol=1e-12)
    np.testing.assert_allclose(part.tensors["c"], np.diag([0, 0, c]), rtol=1e-12)
    assert part.p == pytest.approx(2 * c)
    assert part.q_over_trace == pytest.approx({"a": 0.5, "b": 0.0, "c": -1.0 / 6.0}, abs=1e-12)
    assert part.descriptors() == pytest.approx(
        {"q_over_trace_a": 0.5, "q_over_trace_b": 0.0, "q_over_trace_c": -1.0 / 6.0}, abs=1e-12)


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("seed", [0, 1])
def test_partial_stresses_sum_to_the_total(d, seed):
    rng = np.random.default_rng(seed)
    net = random_typed_network(rng, d=d)
    part = PartialStresses().compute(net)
    state = StressState().compute(net)
    total = sum(part.tensors.values())
    np.testing.assert_allclose(total, state.tensor_full, rtol=1e-12, atol=1e-14)
    # slow twin: restrict the dyad sum by hand
    for code, name in enumerate(net.type_names):
        slow = np.zeros((d, d))
        for c in range(net.n_points):
            if net.pair_types[net.point_pairs[c]] == code:
                slow += np.outer(net.point_forces[c], net.point_branches[c])
        np.testing.assert_allclose(part.tensors[name], slow / net.volume, rtol=1e-12,
                                   atol=1e-14)
    assert sum(part.q_over_trace.values()) == pytest.approx(state.q_over_trace, rel=1e-10)
    assert part.p == pytest.approx(state.p, rel=1e-12)
    assert state.q_over_trace > 0.05


def test_rotation_and_relabelling_leave_q_over_trace_unchanged():
    rng = np.random.default_rng(5)
    net = random_typed_network(rng)
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    before = PartialStresses().compute(net)
    rotated = PartialStresses().compute(net.transformed(q))
    for name, tensor in before.tensors.items():
        np.testing.assert_allclose(rotated.tensors[name], q @ tensor @ q.T, atol=1e-12)
    relabelled = PartialStresses().compute(
        net.relabelled(rng.permutation(net.n_particles), rng.permutation(net.n_pairs),
                       rng.permutation(net.n_points)))
    for other in (rotated, relabelled):
        assert other.q_over_trace == pytest.approx(before.q_over_trace, rel=1e-9, abs=1e-12)


def test_errors():
    rng = np.random.default_rng(6)
    net = random_typed_network(rng)
    values = {k: getattr(net, k) for k in net.__dataclass_fields__}
    values.update(pair_types=None, type_names=())
    with pytest.raises(InputError, match="pair_types"):
        PartialStresses().compute(ContactNetwork(**values))
    with pytest.raises(InputError, match="pair_types"):
        partial_stress_tensors(ContactNetwork(**values))
    with pytest.raises(NotComputedError):
        PartialStresses().q_over_trace  # noqa: B018
