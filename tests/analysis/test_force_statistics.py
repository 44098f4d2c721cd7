"""Force PDFs (seed 003 Figs. 14, 16) and the length–force correlation C_lf (seed 002 eq. B2,
centred): normalisation, an exponential sample against its density, radial forces of
multi-point pairs, correlation limits.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.force_statistics import (
    ForceStatistics,
    pearson_correlation,
    probability_density,
    radial_forces,
)
from grainlab.errors import InputError


def single_point_network(rng, normal_forces, lengths, d=3, tangential=0.0) -> ContactNetwork:
    """One point per pair, normal along a random branch direction, f = f_n n (+ a tangential
    part of relative size ``tangential``)."""
    m = len(normal_forces)
    n_particles = 500
    i = rng.integers(0, n_particles, m)
    j = (i + rng.integers(1, n_particles, m)) % n_particles
    normals = rng.normal(size=(m, d))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    side = rng.normal(size=(m, d))
    side -= np.einsum("ci,ci->c", side, normals)[:, None] * normals
    side /= np.linalg.norm(side, axis=1)[:, None]
    forces = normal_forces[:, None] * (normals + tangential * side)
    branches = lengths[:, None] * normals
    return ContactNetwork.from_arrays(
        positions=rng.uniform(0, 1, (n_particles, d)), volumes=np.full(n_particles, 1e-3),
        volume=1.0, pair_particles=np.column_stack([i, j]), pair_branches=branches,
        point_pairs=np.arange(m), point_positions=np.zeros((m, d)), point_normals=normals,
        point_forces=forces)


def integral(frame) -> float:
    return float(np.sum(frame["density"].to_numpy() * np.diff(frame.attrs["bin_edges"])))


@pytest.fixture(scope="module")
def exponential():
    rng = np.random.default_rng(1)
    m = 100_000
    forces = rng.exponential(2.0, m)
    lengths = rng.uniform(1.0, 3.0, m)  # independent of the forces
    return ForceStatistics(n_bins=40).compute(single_point_network(rng, forces, lengths))


def test_pdfs_integrate_to_one(exponential):
    for name in ("normal_pdf_linear", "normal_pdf_log", "radial_pdf_linear", "radial_pdf_log"):
        frame = getattr(exponential, name)
        assert list(frame.columns) == ["force_ratio", "density"]
        assert len(frame) == 40
        assert integral(frame) == pytest.approx(1.0, rel=1e-12)
        # the mean of f/<f> is 1 (to binning error)
        mean = np.sum(frame["force_ratio"] * frame["density"] * np.diff(frame.attrs["bin_edges"]))
        assert mean == pytest.approx(1.0, rel=0.05)


def test_exponential_sample_gives_exponential_density(exponential):
    # P(x) = exp(-x) for x = f/<f>; compare bin averages (exp(-a) - exp(-b))/(b - a) where a
    # bin holds >= 400 samples, within 5 standard errors sqrt(count)/count.
    m = 100_000
    for frame in (exponential.normal_pdf_linear, exponential.normal_pdf_log):
        edges = frame.attrs["bin_edges"]
        width = np.diff(edges)
        expected = (np.exp(-edges[:-1]) - np.exp(-edges[1:])) / width
        counts = frame["density"].to_numpy() * width * m
        ok = counts >= 400
        assert ok.sum() >= 10
        error = 5.0 / np.sqrt(counts[ok]) + 0.01  # + mean-normalisation error
        relative = np.abs(frame["density"].to_numpy()[ok] / expected[ok] - 1.0)
        assert np.all(relative < error), relative.max()
    # log bins are geometric: centres are geometric means of the edges
    edges = exponential.normal_pdf_log.attrs["bin_edges"]
    np.testing.assert_allclose(np.diff(np.log(edges)), np.log(edges[1] / edges[0]), rtol=1e-9)
    assert exponential.fraction_normal_above_mean == pytest.approx(np.exp(-1.0), abs=0.005)


def test_correlation_of_independent_samples_is_small(exponential):
    # the centred coefficient: 5 standard errors 5/sqrt(m); the raw-moment form of the OCR'd
    # eq. B2 would give <l f>/sqrt(<l^2><f^2>) = 4/sqrt(8 * 13/3) ~ 0.68 here
    assert abs(exponential.pearson_length_force) < 5.0 / np.sqrt(100_000)


def test_correlation_is_one_when_force_is_proportional_to_length():
    rng = np.random.default_rng(2)
    lengths = rng.uniform(1.0, 3.0, 1000)
    stats = ForceStatistics().compute(single_point_network(rng, 4.0 * lengths, lengths,
                                                           tangential=0.3))
    assert stats.pearson_length_force == pytest.approx(1.0, abs=1e-12)
    stats = ForceStatistics().compute(single_point_network(rng, 10.0 - lengths, lengths))
    assert stats.pearson_length_force == pytest.approx(-1.0, abs=1e-12)


def test_pearson_helper():
    x = np.array([1.0, 2.0, 3.0, 4.0])
    assert pearson_correlation(x, np.array([1.0, 0.0, 0.0, 1.0])) == pytest.approx(0.0)
    assert np.isnan(pearson_correlation(x, np.ones(4)))
    assert np.isnan(pearson_correlation(x[:1], x[:1]))


def test_radial_force_of_a_multipoint_pair_and_inactive_points():
    # pair 0: branch 2 e_x, three points each pushing (1, 0.5, 0) -> F = (3, 1.5, 0), f_n' = 3;
    # pair 1: branch along y, one point with f_n = 1; pair 2: tensile only (inactive).
    net = ContactNetwork.from_arrays(
        positions=[[0, 0, 0], [2, 0, 0], [0, 2, 0]], volumes=[1.0] * 3, volume=100.0,
        pair_particles=[[0, 1], [0, 2], [1, 2]],
        pair_branches=[[2, 0, 0], [0, 2, 0], [-2, 2, 0]], point_pairs=[0, 0, 0, 1, 2],
        point_positions=np.zeros((5, 3)),
        point_normals=[[1, 0, 0]] * 3 + [[0, 1, 0], [-np.sqrt(0.5), np.sqrt(0.5), 0]],
        point_forces=[[1, 0.5, 0]] * 3 + [[0, 1, 0], [np.sqrt(0.5), -np.sqrt(0.5), 0]])
    np.testing.assert_allclose(radial_forces(net), [3.0, 1.0, -1.0])
    stats = ForceStatistics(n_bins=5).compute(net)
    assert stats.mean_normal_force == pytest.approx(1.0)  # four active points of f_n = 1
    assert stats.mean_radial_force == pytest.approx(2.0)
    assert stats.fraction_radial_above_mean == pytest.approx(0.5)
    assert stats.max_radial_ratio == pytest.approx(1.5)
    # equal normal forces: a zero-width range still gives a normalised density
    assert integral(stats.normal_pdf_linear) == pytest.approx(1.0)
    assert integral(stats.normal_pdf_log) == pytest.approx(1.0)


def test_probability_density_helper():
    centres, density, edges = probability_density(np.array([-1.0, 1.0, 3.0]), 4)
    np.testing.assert_allclose(edges, [-1.0, 0.0, 1.0, 2.0, 3.0])
    np.testing.assert_allclose(density, [1 / 3, 0.0, 1 / 3, 1 / 3])
    centres, density, edges = probability_density(np.array([-1.0, 1.0, 100.0]), 2, "log")
    np.testing.assert_allclose(edges, [1.0, 10.0, 100.0])
    np.testing.assert_allclose(density, [0.5 / 9.0, 0.5 / 90.0])
    np.testing.assert_allclose(centres, [np.sqrt(10.0), np.sqrt(1000.0)])
    assert probability_density(np.empty(0), 3)[0].size == 0
    with pytest.raises(InputError, match="scale"):
        probability_density(np.ones(3), 3, "cubic")


def test_empty_network_gives_nan_without_warnings():
    net = ContactNetwork.from_arrays(
        positions=[[0, 0], [1, 0]], volumes=[0.5, 0.5], volume=4.0, pair_particles=[[0, 1]],
        pair_branches=[[1, 0]], point_pairs=[0], point_positions=[[0.5, 0]],
        point_normals=[[1, 0]], point_forces=[[-1.0, 0]])
    stats = ForceStatistics().compute(net)
    assert np.isnan(stats.mean_normal_force)
    assert stats.normal_pdf_linear.empty
    assert np.isnan(stats.pearson_length_force)


def test_rotation_and_relabelling_leave_statistics_unchanged():
    rng = np.random.default_rng(4)
    net = single_point_network(rng, rng.exponential(1.0, 500), rng.uniform(1, 2, 500),
                               tangential=0.2)
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    before = ForceStatistics(n_bins=10).compute(net)
    for other in (net.transformed(q * np.sign(np.diag(r))),
                  net.relabelled(rng.permutation(net.n_particles), rng.permutation(net.n_pairs),
                                 rng.permutation(net.n_points))):
        after = ForceStatistics(n_bins=10).compute(other)
        assert after.descriptors() == pytest.approx(before.descriptors(), rel=1e-9)
        np.testing.assert_allclose(after.radial_pdf_log["density"],
                                   before.radial_pdf_log["density"], rtol=1e-9)


def test_errors():
    with pytest.raises(NotComputedError):
        ForceStatistics().normal_pdf_linear  # noqa: B018
    with pytest.raises(InputError, match="n_bins"):
        ForceStatistics(n_bins=0)
