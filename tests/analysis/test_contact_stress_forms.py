"""The two forms of the contact stress (seed 002 eq. 3) and the invariants of StressState
(seed 002 eqs. 4, 5, 11): exact lattice stresses, a loop-based twin of the internal moments,
agreement of the forms on random periodic multi-point networks, frame invariance.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.contact_stress import (
    StressState,
    internal_moments,
    particle_stresses,
    principal_stresses,
    stress_from_internal_moments,
    stress_from_network,
)

R = 1.0e-3  # sphere radius [m]


def simple_cubic(n: int, radius: float, forces_xyz) -> ContactNetwork:
    """Periodic simple cubic lattice (n^3 spheres, spacing 2R), each sphere's +x, +y, +z
    neighbour paired with it; the pair along axis k carries the compressive force f_k e_k."""
    a = 2.0 * radius
    cells = np.array(list(itertools.product(range(n), repeat=3)))
    index = {tuple(c): k for k, c in enumerate(cells)}
    pairs, branches, points, normals, forces = [], [], [], [], []
    for k, c in enumerate(cells):
        for axis in range(3):
            e = np.eye(3)[axis]
            other = tuple((c + np.eye(3, dtype=int)[axis]) % n)
            pairs.append((k, index[other]))
            branches.append(a * e)
            points.append(a * c + radius * e)
            normals.append(e)
            forces.append(forces_xyz[axis] * e)
    return ContactNetwork.from_arrays(
        positions=a * cells, volumes=np.full(len(cells), 4.0 / 3.0 * np.pi * radius**3),
        volume=(n * a) ** 3, pair_particles=pairs, pair_branches=branches,
        point_pairs=np.arange(len(pairs)), point_positions=points, point_normals=normals,
        point_forces=forces)


def fcc(n: int, radius: float, force: float) -> ContactNetwork:
    """Periodic FCC lattice, n^3 cubic cells of side a = 2 sqrt(2) R (4 spheres each), every
    touching pair (distance 2R) carrying the compressive force ``force`` along its branch."""
    a = 2.0 * np.sqrt(2.0) * radius
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    positions = np.array([a * (np.array(c) + b) for c in itertools.product(range(n), repeat=3)
                          for b in basis])
    box = n * a
    delta = positions[None, :, :] - positions[:, None, :]
    delta -= box * np.round(delta / box)
    distance = np.linalg.norm(delta, axis=2)
    i, j = np.nonzero(np.triu(np.isclose(distance, 2.0 * radius), k=1))
    branches = delta[i, j]
    normals = branches / np.linalg.norm(branches, axis=1)[:, None]
    return ContactNetwork.from_arrays(
        positions=positions, volumes=np.full(len(positions), 4.0 / 3.0 * np.pi * radius**3),
        volume=box**3, pair_particles=np.column_stack([i, j]), pair_branches=branches,
        point_pairs=np.arange(len(i)), point_positions=positions[i] + radius * normals,
        point_normals=normals, point_forces=force * normals)


def random_unit(rng, m: int, d: int) -> np.ndarray:
    v = rng.normal(size=(m, d))
    return v / np.linalg.norm(v, axis=1)[:, None]


def random_network(rng, d: int = 3, n: int = 25, n_pairs: int = 60, box: float = 1.0,
                   max_points: int = 3) -> ContactNetwork:
    """Random periodic network: branch vectors x_j - x_i + (lattice shift), so that the second
    particle's image differs from its stored position; 1..max_points points per pair with
    arbitrary (not balanced) forces, some tensile."""
    positions = rng.uniform(0.0, box, (n, d))
    i = rng.integers(0, n, n_pairs)
    j = (i + rng.integers(1, n, n_pairs)) % n
    shifts = box * rng.integers(-1, 2, (n_pairs, d))
    branches = positions[j] - positions[i] + shifts
    counts = rng.integers(1, max_points + 1, n_pairs)
    point_pairs = np.repeat(np.arange(n_pairs), counts)
    c = point_pairs.size
    point_positions = (positions[i[point_pairs]] + rng.uniform(0.2, 0.8, (c, 1))
                       * branches[point_pairs] + 0.05 * rng.normal(size=(c, d)))
    return ContactNetwork.from_arrays(
        positions=positions, volumes=rng.uniform(0.001, 0.002, n), volume=box**d,
        pair_particles=np.column_stack([i, j]), pair_branches=branches,
        point_pairs=point_pairs, point_positions=point_positions,
        point_normals=random_unit(rng, c, d), point_forces=rng.normal(0.3, 1.0, (c, d)),
        pair_types=rng.integers(0, 2, n_pairs), type_names=("a", "b"))


def random_rotation(rng, d: int) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(d, d)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def slow_internal_moments(network) -> np.ndarray:
    """Loop-based twin of internal_moments: for each point, -f (x) (x_c - x_i) on the first
    particle, +f (x) (x_c - (x_i + l)) on the second."""
    d = network.dimension
    moments = np.zeros((network.n_particles, d, d))
    for c in range(network.n_points):
        pair = network.point_pairs[c]
        i, j = network.pair_particles[pair]
        x_i = network.positions[i]
        x_j_image = x_i + network.pair_branches[pair]
        f = network.point_forces[c]
        x_c = network.point_positions[c]
        moments[i] -= np.outer(f, x_c - x_i)
        moments[j] += np.outer(f, x_c - x_j_image)
    return moments


# -- exact lattices ---------------------------------------------------------------------------
def test_simple_cubic_stress_is_f_times_2R_over_cell_volume():
    # One sphere per cell of volume (2R)^3 and three contacts per cell (one per axis), each
    # contributing f_k (2R) to sigma_kk: sigma_kk = f_k 2R / (2R)^3.
    f = np.array([3.0, 2.0, 1.0])
    net = simple_cubic(3, R, f)
    expected = np.diag(f * 2 * R / (2 * R) ** 3)
    np.testing.assert_allclose(stress_from_network(net), expected, rtol=1e-12, atol=0)
    np.testing.assert_allclose(stress_from_internal_moments(net), expected, rtol=1e-12,
                               atol=1e-9 * expected.max())


def test_simple_cubic_particle_stress():
    # Each sphere: two contacts per axis at +-R e_k, each pushing inwards with f_k:
    # M_kk = -2 f_k R, sigma^i = -M / v = 2 f_k R / (4/3 pi R^3).
    f = np.array([3.0, 2.0, 1.0])
    net = simple_cubic(3, R, f)
    expected = np.diag(2 * f * R / (4.0 / 3.0 * np.pi * R**3))
    stresses = particle_stresses(net)
    assert stresses.shape == (27, 3, 3)
    np.testing.assert_allclose(stresses, np.broadcast_to(expected, stresses.shape),
                               rtol=1e-12, atol=1e-9 * expected.max())


def test_simple_cubic_invariants():
    # sigma = c diag(3, 2, 1): p = 2c, q = 2c, q/p (papers) = (2c/3)/(2c) = 1/3,
    # sin phi = 2c/4c = 1/2, b = (2 - 1)/(3 - 1) = 1/2.
    net = simple_cubic(2, R, [1.0, 3.0, 2.0])  # major axis along y
    c = 2 * R / (2 * R) ** 3
    state = StressState().compute(net)
    np.testing.assert_allclose(state.principal_values, [3 * c, 2 * c, c], rtol=1e-12)
    np.testing.assert_allclose(np.abs(state.principal_directions), np.eye(3)[:, [1, 2, 0]],
                               atol=1e-12)
    assert state.p == pytest.approx(2 * c, rel=1e-12)
    assert state.q == pytest.approx(2 * c, rel=1e-12)
    assert state.q_over_3 == pytest.approx(2 * c / 3, rel=1e-12)
    assert state.q_over_trace == pytest.approx(1.0 / 3.0, rel=1e-12)
    assert state.sin_phi == pytest.approx(0.5, rel=1e-12)
    assert state.b == pytest.approx(0.5, rel=1e-12)
    assert state.asymmetry == pytest.approx(0.0, abs=1e-14)


def test_sin_phi_matches_seed_eq_11_for_axisymmetric_stress():
    net = simple_cubic(2, R, [5.0, 2.0, 2.0])
    state = StressState().compute(net)
    qp = state.q_over_trace
    assert state.sin_phi == pytest.approx(3 * qp / (2 + qp), rel=1e-12)
    assert state.b == pytest.approx(0.0, abs=1e-12)


def test_fcc_isotropic_stress():
    # sigma = (1/V) sum_pairs f 2R n n; each sphere has 6 pairs (half its 12 neighbours) and
    # sum over the 6 directions of n n = 2 I, so sigma = (N/V) 4 f R I; with N/V = 4/a^3 and
    # a^3 = 16 sqrt(2) R^3: p = f / (sqrt(2) R^2), q = 0.
    force = 2.5
    net = fcc(2, R, force)
    assert net.n_pairs == 6 * net.n_particles
    p_expected = force / (np.sqrt(2.0) * R**2)
    state = StressState().compute(net)
    np.testing.assert_allclose(state.tensor, p_expected * np.eye(3), rtol=1e-12,
                               atol=1e-12 * p_expected)
    np.testing.assert_allclose(state.tensor_internal_moments, p_expected * np.eye(3),
                               rtol=1e-9, atol=1e-9 * p_expected)
    assert state.p == pytest.approx(p_expected, rel=1e-12)
    assert state.q_over_trace == pytest.approx(0.0, abs=1e-12)


# -- the two forms agree ------------------------------------------------------------------------
@pytest.mark.parametrize("d", [2, 3])
def test_internal_moments_match_loop_twin(d):
    net = random_network(np.random.default_rng(d), d=d)
    np.testing.assert_allclose(internal_moments(net), slow_internal_moments(net),
                               rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("d", [2, 3])
def test_forms_agree_on_random_periodic_multipoint_networks(seed, d):
    rng = np.random.default_rng(100 + seed)
    net = random_network(rng, d=d)
    # some second particles are periodic images: x_j != x_i + l
    second = net.positions[net.pair_particles[:, 1]]
    assert np.any(np.abs(net.positions[net.pair_particles[:, 0]] + net.pair_branches - second)
                  > 0.5)
    assert net.pair_point_counts.max() > 1
    contact = stress_from_network(net)
    particle = stress_from_internal_moments(net)
    np.testing.assert_allclose(particle, contact, rtol=1e-10, atol=1e-12 * np.abs(contact).max())
    # slow twin of the contact form
    slow = sum(np.outer(net.point_forces[c], net.point_branches[c])
               for c in range(net.n_points)) / net.volume
    np.testing.assert_allclose(contact, slow, rtol=1e-12, atol=1e-14)
    # the volume-weighted particle stresses sum to the sample stress
    weighted = np.einsum("i,iab->ab", net.volumes, particle_stresses(net)) / net.volume
    np.testing.assert_allclose(weighted, contact, rtol=1e-10, atol=1e-12)


def test_unbalanced_network_is_asymmetric():
    # a single contact whose force is not along its branch: the full tensor has a skew part
    net = ContactNetwork.from_arrays(
        positions=[[0, 0, 0], [2, 0, 0]], volumes=[1.0, 1.0], volume=10.0,
        pair_particles=[[0, 1]], pair_branches=[[2, 0, 0]], point_pairs=[0],
        point_positions=[[1, 0, 0]], point_normals=[[1, 0, 0]], point_forces=[[1, 1, 0]])
    state = StressState().compute(net)
    # full = [[2, 0], [2, 0]]/10 in the xy block: skew norm sqrt(2), full norm sqrt(8)
    assert state.asymmetry == pytest.approx(0.5, rel=1e-12)
    np.testing.assert_allclose(state.tensor, state.tensor.T)
    np.testing.assert_allclose(state.tensor_full[1, 0], 0.2)


def test_two_dimensional_invariants():
    # sigma = diag(3, 1) (see the StressState doctest geometry): p = 2, q = 2,
    # q/p = (3 - 1)/2 / 2 = 0.5, sin phi = 2/4.
    net = ContactNetwork.from_arrays(
        positions=[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], volumes=[1.0] * 3, volume=8.0,
        pair_particles=[[0, 1], [0, 2]], pair_branches=[[2.0, 0.0], [0.0, 2.0]],
        point_pairs=[0, 1], point_positions=[[1.0, 0.0], [0.0, 1.0]],
        point_normals=[[1.0, 0.0], [0.0, 1.0]], point_forces=[[12.0, 0.0], [0.0, 4.0]])
    state = StressState().compute(net)
    assert (state.p, state.q, state.q_over_trace, state.sin_phi) == \
        pytest.approx((2, 2, 0.5, 0.5))
    assert np.isnan(state.b)
    out = state.descriptors()
    assert set(out) == {"sigma_xx", "sigma_yy", "sigma_xy", "sigma_1", "sigma_3", "p", "q",
                        "q_over_3", "q_over_trace", "sin_phi", "stress_ratio",
                        "stress_asymmetry", "wall_share_of_p"}  # 2D: the minor one is sigma_3
    assert out["wall_share_of_p"] == 0.0  # no walls
    assert (out["sigma_1"], out["sigma_3"], out["stress_ratio"]) == (3.0, 1.0, 3.0)


def test_descriptors_3d():
    state = StressState().compute(simple_cubic(2, R, [3.0, 2.0, 1.0]))
    out = state.descriptors()
    for key in ("sigma_xx", "sigma_yy", "sigma_zz", "sigma_xy", "sigma_xz", "sigma_yz", "p",
                "q", "q_over_3", "q_over_trace", "sin_phi", "b", "stress_asymmetry"):
        assert key in out
    c = 2 * R / (2 * R) ** 3
    assert out["sigma_xx"] == pytest.approx(3 * c)
    assert out["sigma_zz"] == pytest.approx(c)
    assert out["sigma_xy"] == 0.0


def test_principal_stresses_sorted_and_orthonormal():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(3, 3))
    values, vectors = principal_stresses(a)
    assert np.all(np.diff(values) <= 0)
    np.testing.assert_allclose(vectors.T @ vectors, np.eye(3), atol=1e-12)
    sym = 0.5 * (a + a.T)
    np.testing.assert_allclose(sym @ vectors, vectors * values, atol=1e-12)


# -- invariance ---------------------------------------------------------------------------------
@pytest.mark.parametrize("d", [2, 3])
def test_rotation_rotates_the_stress_and_keeps_invariants(d):
    rng = np.random.default_rng(7 + d)
    net = random_network(rng, d=d)
    rotation = random_rotation(rng, d)
    before = StressState().compute(net)
    after = StressState().compute(net.transformed(rotation, shift=rng.normal(size=d)))
    np.testing.assert_allclose(after.tensor, rotation @ before.tensor @ rotation.T,
                               atol=1e-12 * np.abs(before.tensor).max())
    np.testing.assert_allclose(after.tensor_internal_moments,
                               rotation @ before.tensor_internal_moments @ rotation.T,
                               atol=1e-10 * np.abs(before.tensor).max())
    for name in ("p", "q", "q_over_3", "q_over_trace", "sin_phi", "asymmetry"):
        assert getattr(after, name) == pytest.approx(getattr(before, name), rel=1e-9, abs=1e-12)
    np.testing.assert_allclose(np.abs(rotation @ before.principal_directions),
                               np.abs(after.principal_directions), atol=1e-8)


def test_relabelling_changes_nothing():
    rng = np.random.default_rng(11)
    net = random_network(rng)
    relabelled = net.relabelled(rng.permutation(net.n_particles), rng.permutation(net.n_pairs),
                                rng.permutation(net.n_points))
    before = StressState().compute(net)
    after = StressState().compute(relabelled)
    np.testing.assert_allclose(after.tensor, before.tensor, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(after.tensor_internal_moments, before.tensor_internal_moments,
                               rtol=1e-10, atol=1e-12)
    assert after.descriptors() == pytest.approx(before.descriptors(), rel=1e-10, abs=1e-12,
                                                nan_ok=True)


def test_properties_before_compute_raise():
    state = StressState()
    for name in ("tensor", "p", "q_over_trace", "principal_values", "asymmetry"):
        with pytest.raises(NotComputedError):
            getattr(state, name)
    with pytest.raises(NotComputedError):
        state.descriptors()
