"""Angular distributions about the major stress direction (seed 002 eqs. 21–26, Fig. 14).

Networks are sampled from the harmonic model about a tilted axis; expected bin counts and bin
means come from integrating the model over each bin, independently of the code under test.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.angular_distributions import AngularDistributions
from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.errors import InputError

N = 200_000
L, F0 = 2e-3, 10.0
A_C, A_FN, A_FT = 0.3, 0.4, 0.2
AXIS = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
Z_MAX = 4.5  # largest allowed standardised deviation of a bin count


def sample(n, a_c, a_fn, a_ft, *, dimension=3, seed=0):
    """Spheres, one pair per point: normals from P = (1 + a_c Y)/(4 pi) (2D: (1 + a_c cos 2t)/2pi)
    about AXIS (2D: x), f = f0(1 + a_fn Y) n + f0 a_ft sin 2theta m, m = -dn/dtheta, l = L n."""
    rng = np.random.default_rng(seed)
    theta = np.empty(0)
    while theta.size < n:
        if dimension == 3:
            t = np.arccos(rng.uniform(-1, 1, 2 * n))
            weight, bound = 1 + a_c * (3 * np.cos(t) ** 2 - 1), max(1 + 2 * a_c, 1 - a_c)
        else:
            t = rng.uniform(0, 2 * np.pi, 2 * n)
            weight, bound = 1 + a_c * np.cos(2 * t), 1 + abs(a_c)
        theta = np.concatenate([theta, t[rng.uniform(0, bound, 2 * n) < weight]])
    theta = theta[:n]
    if dimension == 3:
        b1 = np.cross(AXIS, [1.0, 0, 0])
        b1 /= np.linalg.norm(b1)
        phi = rng.uniform(0, 2 * np.pi, n)
        radial = np.cos(phi)[:, None] * b1 + np.sin(phi)[:, None] * np.cross(AXIS, b1)
        axis, shape = AXIS, 3 * np.cos(theta) ** 2 - 1
    else:
        radial = np.tile([0.0, 1.0], (n, 1))
        axis, shape = np.array([1.0, 0.0]), np.cos(2 * theta)
    normal = np.cos(theta)[:, None] * axis + np.sin(theta)[:, None] * radial
    towards_axis = np.sin(theta)[:, None] * axis - np.cos(theta)[:, None] * radial
    force = (F0 * (1 + a_fn * shape))[:, None] * normal \
        + (F0 * a_ft * np.sin(2 * theta))[:, None] * towards_axis
    branch = L * normal
    first = rng.uniform(0, 1, (n, dimension))
    positions = np.empty((2 * n, dimension))
    positions[0::2], positions[1::2] = first, first + branch
    return ContactNetwork(
        positions=positions, volumes=np.full(2 * n, L**dimension), volume=4 * n * L**dimension,
        pair_particles=np.arange(2 * n).reshape(n, 2), pair_branches=branch,
        point_pairs=np.arange(n), point_positions=first + branch / 2, point_normals=normal,
        point_forces=force)


def bin_model_3d(edges_deg, a_c, values):
    """Per bin: probability (both hemispheres) and P-weighted mean of values(u), u = cos theta,
    integrating over u in the bin (uniform measure in u is uniform in solid angle)."""
    prob, means = [], []
    for lo, hi in zip(np.radians(edges_deg[:-1]), np.radians(edges_deg[1:]), strict=True):
        x, w = np.polynomial.legendre.leggauss(16)
        u = np.cos(hi) + (np.cos(lo) - np.cos(hi)) * (x + 1) / 2
        w = w * (np.cos(lo) - np.cos(hi)) / 2
        density = w * (1 + a_c * (3 * u**2 - 1))
        prob.append(density.sum())
        means.append(np.sum(density * values(u)) / density.sum())
    return np.array(prob), np.array(means)


@pytest.fixture(scope="module")
def tilted():
    return AngularDistributions(n_bins=18).compute(sample(N, A_C, A_FN, A_FT, seed=21))


def test_binned_density_matches_the_sampled_model(tilted):
    table = tilted.contact_frame
    assert len(table) == 18
    assert abs(tilted.fabric.stress_directions[:, 0] @ AXIS) > 0.999
    edges = np.append(table["theta_lo_deg"].to_numpy(), table["theta_hi_deg"].iloc[-1])
    np.testing.assert_allclose(edges, np.linspace(0, 90, 19))
    prob, _ = bin_model_3d(edges, A_C, lambda u: 1.0)
    z = (table["count"] - N * prob) / np.sqrt(N * prob * (1 - prob))
    assert np.max(np.abs(z)) < Z_MAX
    # P is per steradian and integrates to 1 over the sphere
    np.testing.assert_allclose(table["solid_angle"].sum(), 4 * np.pi, rtol=1e-12)
    assert np.sum(table["P"] * table["solid_angle"]) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(table["P"], prob / table["solid_angle"], rtol=Z_MAX / 20)
    # the harmonic curve of eq. 26a, with the fitted a_c, at the bin centres
    a_c = tilted.fabric.anisotropies["a_c"]
    theta = np.radians(table["theta_deg"])
    np.testing.assert_allclose(table["P_harmonic"],
                               (1 + a_c * (3 * np.cos(theta) ** 2 - 1)) / (4 * np.pi))
    sigma = np.sqrt(N * prob) / (N * table["solid_angle"])
    assert np.max(np.abs(table["P"] - table["P_harmonic"]) / sigma) < Z_MAX + 1


def test_binned_forces_and_lengths(tilted):
    table = tilted.contact_frame
    edges = np.append(table["theta_lo_deg"].to_numpy(), table["theta_hi_deg"].iloc[-1])
    _, f_n = bin_model_3d(edges, A_C, lambda u: F0 * (1 + A_FN * (3 * u**2 - 1)))
    _, f_t = bin_model_3d(edges, A_C, lambda u: F0 * A_FT * 2 * u * np.sqrt(1 - u**2))
    np.testing.assert_allclose(table["f_n"], f_n, rtol=2e-3)
    np.testing.assert_allclose(table["f_t"], f_t, rtol=5e-3, atol=1e-3)
    np.testing.assert_allclose(table["f_t_meridional"], f_t, rtol=5e-3, atol=1e-3)
    np.testing.assert_allclose(table["l_n"], L, rtol=1e-12)
    np.testing.assert_allclose(table["l_t"], 0.0, atol=1e-15)
    np.testing.assert_allclose(table["l_t_meridional"], 0.0, atol=1e-15)
    fab = tilted.fabric
    a = fab.anisotropies
    theta = np.radians(table["theta_deg"].to_numpy())
    # eq. 26d-e with the prefactor that makes the model's mean the measured <f_n>
    f_bar = fab.mean_normal_force / (1 + 4 / 5 * a["a_c"] * a["a_fn"])
    np.testing.assert_allclose(table["f_n_harmonic"],
                               f_bar * (1 + a["a_fn"] * (3 * np.cos(theta) ** 2 - 1)))
    np.testing.assert_allclose(table["f_t_harmonic"], f_bar * a["a_ft"] * np.sin(2 * theta))
    # the harmonic curves follow the sampled data (bin width and sampling only)
    np.testing.assert_allclose(table["f_n_harmonic"], table["f_n"], rtol=0.01)
    # (not in the first bin, where the solid-angle mean of theta is 2/3 of the bin, not 1/2)
    np.testing.assert_allclose(table["f_t_harmonic"][1:], table["f_t"][1:],
                               atol=0.02 * F0 * A_FT)


def test_branch_frame_equals_contact_frame_for_spheres(tilted):
    contact, branch = tilted.contact_frame, tilted.branch_frame
    assert "l_t" not in branch.columns
    for column in ("count", "P", "P_harmonic", "f_n", "f_n_harmonic", "f_t", "f_t_meridional",
                   "f_t_harmonic", "l_n", "l_n_harmonic"):
        np.testing.assert_allclose(branch[column], contact[column], rtol=1e-9, atol=1e-12,
                                   err_msg=column)


def test_isotropic_density_is_flat():
    table = AngularDistributions(n_bins=9).compute(sample(N, 0.0, 0.0, 0.0, seed=22)).contact_frame
    sigma = np.sqrt(N * table["solid_angle"] / (4 * np.pi)) / (N * table["solid_angle"])
    assert np.max(np.abs(table["P"] - 1 / (4 * np.pi)) / sigma) < Z_MAX
    # the fitted a_c is only sampling noise (< 0.012), |Y| <= 2
    np.testing.assert_allclose(table["P_harmonic"], 1 / (4 * np.pi), atol=0.024 / (4 * np.pi))


def test_two_dimensional_distributions():
    a_c, a_fn, a_ft = 0.4, 0.3, 0.2
    result = AngularDistributions(n_bins=12).compute(
        sample(N, a_c, a_fn, a_ft, dimension=2, seed=23))
    table = result.contact_frame
    lo, hi = np.radians(table["theta_lo_deg"]), np.radians(table["theta_hi_deg"])
    np.testing.assert_allclose(hi.iloc[-1], np.pi)
    prob = ((hi - lo) + a_c * (np.sin(2 * hi) - np.sin(2 * lo)) / 2) / np.pi
    z = (table["count"] - N * prob) / np.sqrt(N * prob * (1 - prob))
    assert np.max(np.abs(z)) < Z_MAX
    assert np.sum(table["P"] * table["solid_angle"]) == pytest.approx(1.0, abs=1e-12)
    theta = np.radians(table["theta_deg"])
    np.testing.assert_allclose(
        table["P_harmonic"],
        (1 + result.fabric.anisotropies["a_c"] * np.cos(2 * theta)) / (2 * np.pi))
    # the signed meridional tangential force follows sin 2 theta through both quadrants,
    # the magnitude cannot
    expected_ft = F0 * a_ft * (np.cos(2 * lo) - np.cos(2 * hi)) / (2 * (hi - lo))
    np.testing.assert_allclose(table["f_t_meridional"], expected_ft, atol=0.02 * F0 * a_ft)
    np.testing.assert_allclose(table["f_t"], np.abs(expected_ft), atol=0.02 * F0 * a_ft)
    assert np.all(table["f_t_meridional"].iloc[7:] < 0)
    isotropic = AngularDistributions(n_bins=12).compute(
        sample(N, 0.0, 0.0, 0.0, dimension=2, seed=24)).contact_frame
    sigma = np.sqrt(N / 12) / (N * isotropic["solid_angle"])
    assert np.max(np.abs(isotropic["P"] - 1 / (2 * np.pi)) / sigma) < Z_MAX


def test_results_before_compute_raise():
    result = AngularDistributions()
    for name in ("contact_frame", "branch_frame", "fabric"):
        with pytest.raises(NotComputedError):
            getattr(result, name)
    with pytest.raises(InputError):
        AngularDistributions(n_bins=0)
    with pytest.raises(InputError):
        AngularDistributions(frame_level="atoms")
