"""Sphere aggregates (clumps) and their exact mass properties (seed 003, Sec. II, eq. 1).

Closed forms for one and two spheres; a slow, obviously right twin (points in the bounding box
tested against every sphere) for the tetrahedral aggregates and a random clump; invariance
under rigid motions; the seed's lambda-eta relation; bad input.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import qmc

from grainlab.errors import InputError
from grainlab.geometry.sphere_aggregate import (
    ETA_MAX,
    LAM_MAX,
    SphereAggregate,
    eta_from_lam,
    from_spheres,
    lam_from_eta,
    principal_frame,
    tetrahedral_aggregate,
    union_mass_properties,
)

SEED_ETAS = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]  # the eight packings of seed 003


def ball_moments(radius: float) -> tuple[float, float]:
    """Volume and second moment int x^2 dV of a ball about its centre."""
    volume = 4.0 / 3.0 * math.pi * radius**3
    return volume, volume * radius**2 / 5.0


def cap_moments(radius: float, z0: float) -> tuple[float, float, float, float]:
    """The cap z >= z0 of the ball |x| <= radius: volume, int z, int z^2 and int x^2 dV."""

    def integral(power: int) -> float:  # int_{z0}^{r} z^p (r^2 - z^2) dz
        def antiderivative(z):
            return radius**2 * z ** (power + 1) / (power + 1) - z ** (power + 3) / (power + 3)

        return antiderivative(radius) - antiderivative(z0)

    def quartic(z):  # antiderivative of (r^2 - z^2)^2
        return radius**4 * z - 2.0 * radius**2 * z**3 / 3.0 + z**5 / 5.0

    return (
        math.pi * integral(0),
        math.pi * integral(1),
        math.pi * integral(2),
        math.pi / 4.0 * (quartic(radius) - quartic(z0)),
    )


def two_sphere_closed_form(r1: float, r2: float, distance: float):
    """Volume, centre z and inertia diag of the union of balls at z = 0 (r1) and z = D (r2),
    by hand: two balls minus the lens, the lens being two caps cut by the radical plane."""
    v1, xx1 = ball_moments(r1)
    v2, xx2 = ball_moments(r2)
    if distance >= r1 + r2:
        cap1 = cap2 = (0.0, 0.0, 0.0, 0.0)
    else:
        d = (distance**2 + r1**2 - r2**2) / (2.0 * distance)
        cap1 = cap_moments(r1, d)  # part of ball 1 beyond the plane z = d
        cap2 = cap_moments(r2, distance - d)  # part of ball 2 below it, mirrored
    volume = v1 + v2 - cap1[0] - cap2[0]
    # moments about z = 0; ball 2's cap sits at z = D - z' for its local z'
    first_z = -cap1[1] + v2 * distance - (distance * cap2[0] - cap2[1])
    zz = xx1 - cap1[2] + (xx2 + v2 * distance**2) - (
        cap2[2] - 2.0 * distance * cap2[1] + distance**2 * cap2[0]
    )
    xx = xx1 - cap1[3] + xx2 - cap2[3]
    com = first_z / volume
    zz_com = zz - volume * com**2
    return volume, com, np.array([xx + zz_com, xx + zz_com, 2.0 * xx])


def quasi_monte_carlo_twin(centres, radii, log2_points: int = 21, seed: int = 7):
    """Slow twin: 2^21 scrambled-Sobol points in the bounding box, kept if inside any sphere.

    Sobol rather than pseudo-random points: with ~2e6 plain random points the volume's
    standard error is ~0.09 %, too close to the 0.1 % tolerance; the Sobol error is ~0.01 %.
    """
    centres, radii = np.asarray(centres, float), np.asarray(radii, float)
    low = (centres - radii[:, None]).min(axis=0)
    high = (centres + radii[:, None]).max(axis=0)
    points = low + (high - low) * qmc.Sobol(3, scramble=True, seed=seed).random_base2(log2_points)
    inside = np.zeros(len(points), dtype=bool)
    for centre, radius in zip(centres, radii, strict=True):
        inside |= np.sum((points - centre) ** 2, axis=1) <= radius**2
    volume = float(np.prod(high - low) * inside.mean())
    kept = points[inside]
    com = kept.mean(axis=0)
    second = volume * (kept - com).T @ (kept - com) / len(kept)
    inertia = np.trace(second) * np.eye(3) - second
    return volume, com, inertia


def random_clump(seed: int = 3, k: int = 5):
    """Unequal, overlapping spheres with triple overlaps and no symmetry."""
    rng = np.random.default_rng(seed)
    return rng.normal(size=(k, 3)) * 0.5, rng.uniform(0.4, 0.9, size=k)


# --------------------------------------------------------------------------- closed forms
def test_single_sphere_closed_form():
    agg = from_spheres([[0.3, -1.0, 2.0]], [0.25])
    volume, xx = ball_moments(0.25)
    assert agg.volume == pytest.approx(volume, rel=1e-14)
    np.testing.assert_allclose(agg.centre_of_mass, [0.3, -1.0, 2.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(agg.principal_moments, 2.0 * xx, rtol=1e-14)
    np.testing.assert_allclose(agg.centres, [[0.0, 0.0, 0.0]], atol=1e-15)
    np.testing.assert_array_equal(agg.rotation, np.eye(3))
    assert agg.bounding_radius == pytest.approx(0.25)


@pytest.mark.parametrize("gap", [0.0, 0.4])  # touching and separate
def test_two_disjoint_spheres_by_parallel_axes(gap):
    r1, r2 = 1.0, 0.6
    distance = r1 + r2 + gap
    agg = from_spheres([[0.0, 0.0, 0.0], [0.0, 0.0, distance]], [r1, r2])
    volume, com, moments = two_sphere_closed_form(r1, r2, distance)
    assert agg.volume == pytest.approx(volume, rel=1e-13)
    np.testing.assert_allclose(agg.centre_of_mass, [0.0, 0.0, com], atol=1e-13)
    np.testing.assert_allclose(agg.principal_moments, np.sort(moments), rtol=1e-13)


@pytest.mark.parametrize(("r1", "r2", "distance"), [(1.0, 1.0, 1.0), (1.0, 1.0, 1.9),
                                                    (1.0, 0.7, 1.2), (1.0, 0.5, 0.6)])
def test_two_overlapping_spheres_closed_form(r1, r2, distance):
    agg = from_spheres([[0.0, 0.0, 0.0], [0.0, 0.0, distance]], [r1, r2])
    volume, com, moments = two_sphere_closed_form(r1, r2, distance)
    if r1 == r2:  # the textbook lens of two equal spheres
        lens = math.pi * (4.0 * r1 + distance) * (2.0 * r1 - distance) ** 2 / 12.0
        assert volume == pytest.approx(2 * ball_moments(r1)[0] - lens, rel=1e-14)
    assert agg.volume == pytest.approx(volume, rel=1e-12)
    np.testing.assert_allclose(agg.centre_of_mass, [0.0, 0.0, com], atol=1e-12)
    np.testing.assert_allclose(agg.principal_moments, np.sort(moments), rtol=1e-12)
    # the symmetry axis z is the unique (largest or smallest) principal axis
    unique = 2 if moments[2] > moments[0] else 0
    assert abs(agg.rotation[2, unique]) == pytest.approx(1.0, abs=1e-12)


def test_lam_zero_is_one_sphere():
    agg = tetrahedral_aggregate(radius=0.5, lam=0.0)
    volume, xx = ball_moments(0.5)
    assert agg.n_spheres == 1
    assert agg.volume == pytest.approx(volume, rel=1e-14)
    np.testing.assert_allclose(agg.principal_moments, 2.0 * xx, rtol=1e-14)


def test_contained_sphere_is_dropped():
    agg = from_spheres([[0.0, 0.0, 0.0], [0.2, 0.1, 0.0], [0.0, 0.0, 0.0]], [1.0, 0.5, 1.0])
    assert agg.n_spheres == 1
    assert agg.volume == pytest.approx(ball_moments(1.0)[0], rel=1e-14)


# --------------------------------------------------------------------------- slow twin
@pytest.mark.parametrize("lam", [0.2, 0.5, LAM_MAX])
def test_tetrahedral_aggregate_matches_quasi_monte_carlo(lam):
    agg = tetrahedral_aggregate(radius=1e-3, lam=lam)
    volume, com, inertia = quasi_monte_carlo_twin(agg.centres, agg.radii)
    assert agg.volume == pytest.approx(volume, rel=1e-3)
    assert np.linalg.norm(com) < 1e-3 * agg.bounding_radius  # body frame: com at the origin
    np.testing.assert_allclose(agg.principal_moments, np.linalg.eigvalsh(inertia), rtol=1e-3)


def test_random_clump_matches_quasi_monte_carlo():
    centres, radii = random_clump()
    agg = from_spheres(centres, radii)
    assert agg.n_spheres == len(radii)
    volume, com, inertia = quasi_monte_carlo_twin(centres, radii)
    assert agg.volume == pytest.approx(volume, rel=1e-3)
    assert np.linalg.norm(agg.centre_of_mass - com) < 1e-3 * agg.bounding_radius
    np.testing.assert_allclose(agg.principal_moments, np.linalg.eigvalsh(inertia), rtol=1e-3)


@pytest.mark.parametrize("lam", [0.05, 0.5, math.sqrt(2.0 / 3.0), LAM_MAX])
def test_quadrature_converged(lam):
    """Doubling the Gauss-Legendre order changes nothing beyond 1e-11."""
    agg = tetrahedral_aggregate(radius=1.0, lam=lam)
    coarse = union_mass_properties(agg.centres, agg.radii, order=32)
    fine = union_mass_properties(agg.centres, agg.radii, order=64)
    assert coarse[0] == pytest.approx(fine[0], rel=1e-11)
    np.testing.assert_allclose(coarse[2], fine[2], rtol=0, atol=1e-11 * fine[2][0, 0])


# --------------------------------------------------------------------------- seed 003 shape
@pytest.mark.parametrize("lam", [0.0, 0.3, 0.7, LAM_MAX])
def test_circumscribed_radius_by_construction(lam):
    r = 2e-3
    agg = tetrahedral_aggregate(radius=r, lam=lam)
    assert agg.bounding_radius == pytest.approx(r * (1.0 + lam * math.sqrt(1.5)), rel=1e-12)
    again = tetrahedral_aggregate(circumscribed_radius=agg.bounding_radius, lam=lam)
    np.testing.assert_allclose(again.radii, r, rtol=1e-12)
    if lam > 0:  # regular tetrahedron of edge l = 2 lambda r, isotropic inertia
        edges = np.linalg.norm(agg.centres[:, None] - agg.centres[None], axis=2)
        np.testing.assert_allclose(edges[np.triu_indices(4, 1)], 2.0 * lam * r, rtol=1e-12)
        np.testing.assert_allclose(agg.principal_moments, agg.principal_moments[0], rtol=1e-12)
        np.testing.assert_array_equal(agg.rotation, np.eye(3))


def test_eta_monotonic_from_zero_and_covers_the_seed_packings():
    lams = np.linspace(0.0, LAM_MAX, 2001)
    etas = np.array([eta_from_lam(lam) for lam in lams])
    assert etas[0] == 0.0
    assert np.all(np.diff(etas) > 0.0)
    # at lambda = sqrt(3)/2: R' = l/(2 sqrt 6) = r/(2 sqrt 2), R = r (1 + 3/(2 sqrt 2))
    assert etas[-1] == pytest.approx(ETA_MAX, abs=1e-15)
    assert ETA_MAX == pytest.approx(1.0 - 1.0 / (2.0 * math.sqrt(2.0) + 3.0), rel=1e-15)
    # the seed's largest packing (eta = 0.7) is inside the range, at lambda ~ 0.835 < sqrt(3)/2
    assert max(SEED_ETAS) < ETA_MAX
    assert 0.83 < lam_from_eta(0.7) < 0.84 < LAM_MAX
    for eta in [*SEED_ETAS, ETA_MAX]:
        assert eta_from_lam(lam_from_eta(eta)) == pytest.approx(eta, abs=1e-13)
        agg = tetrahedral_aggregate(circumscribed_radius=1.0, eta=eta)
        assert agg.bounding_radius == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("lam", [0.3, 0.6, 0.8, 0.85])
def test_inscribed_radius_is_the_concentric_inscribed_sphere(lam):
    """R' = r(lambda/sqrt 6 + sqrt(1 - 4 lambda^2/3)): the concentric sphere of radius R'
    lies in the aggregate and touches its outer surface where three spheres meet."""
    agg = tetrahedral_aggregate(radius=1.0, lam=lam)
    inscribed = agg.bounding_radius * (1.0 - eta_from_lam(lam))
    assert inscribed == pytest.approx(lam / math.sqrt(6) + math.sqrt(1 - 4 * lam**2 / 3))
    rng = np.random.default_rng(11)
    directions = rng.normal(size=(100_000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    distance = np.linalg.norm(directions[:, None, :] * inscribed - agg.centres, axis=2)
    if lam <= math.sqrt(2.0 / 3.0):  # no sealed cavity: the whole ball is covered
        assert np.all(distance.min(axis=1) <= 1.0 + 1e-12)
    # the touching point on a three-fold axis is at distance r from three centres
    touch = -agg.centres[0] / np.linalg.norm(agg.centres[0]) * inscribed
    gaps = np.linalg.norm(agg.centres - touch, axis=1)
    np.testing.assert_allclose(np.sort(gaps)[:3], 1.0, rtol=1e-12)
    assert gaps[0] > 1.0


# --------------------------------------------------------------------------- invariance
def test_rigid_motion_moves_the_result():
    centres, radii = random_clump(seed=5, k=6)
    rotation = Rotation.random(random_state=2).as_matrix()
    shift = np.array([3.0, -1.0, 0.5])
    base = from_spheres(centres, radii)
    moved = from_spheres(centres @ rotation.T + shift, radii)
    assert moved.volume == pytest.approx(base.volume, rel=1e-13)
    np.testing.assert_allclose(moved.principal_moments, base.principal_moments, rtol=1e-12)
    np.testing.assert_allclose(
        moved.centre_of_mass, rotation @ base.centre_of_mass + shift, atol=1e-12
    )
    # inertia tensor in the input frame rotates as R I R^T
    tensor = base.rotation @ base.inertia_tensor @ base.rotation.T
    moved_tensor = moved.rotation @ moved.inertia_tensor @ moved.rotation.T
    np.testing.assert_allclose(moved_tensor, rotation @ tensor @ rotation.T, atol=1e-12)
    # body frames agree up to the sign of each principal axis
    np.testing.assert_allclose(np.abs(moved.centres), np.abs(base.centres), atol=1e-12)
    np.testing.assert_allclose(moved.radii, base.radii)


def test_body_frame_is_principal_and_right_handed():
    centres, radii = random_clump(seed=9, k=4)
    agg = from_spheres(centres, radii)
    assert np.linalg.det(agg.rotation) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(agg.rotation.T @ agg.rotation, np.eye(3), atol=1e-12)
    assert np.all(np.diff(agg.principal_moments) > 0.0)
    # recomputing in the body frame gives a diagonal tensor about the origin
    _, com, inertia = union_mass_properties(agg.centres, agg.radii)
    np.testing.assert_allclose(com, 0.0, atol=1e-12)
    np.testing.assert_allclose(inertia, np.diag(agg.principal_moments), atol=1e-12)
    moments, axes = principal_frame(np.diag([2.0, 2.0, 1.0]))
    np.testing.assert_allclose(moments, [1.0, 2.0, 2.0])
    assert np.linalg.det(axes) == pytest.approx(1.0)


def test_value_object_and_report():
    agg = tetrahedral_aggregate(radius=1e-3, eta=0.4)
    assert isinstance(agg, SphereAggregate)
    with pytest.raises(ValueError):
        agg.centres[0, 0] = 1.0  # read-only arrays of a frozen dataclass
    assert agg.mass(2500.0) == pytest.approx(2500.0 * agg.volume)
    np.testing.assert_allclose(agg.moments_of_inertia(2.0), 2.0 * agg.principal_moments)
    text = agg.describe()
    assert "eta = 0.4" in text and "4 sphere(s)" in text


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"radius": 1.0, "lam": 0.2, "eta": 0.1}, "lam/eta"),
        ({"radius": 1.0}, "lam/eta"),
        ({"radius": 1.0, "lam": 0.9}, "lam"),
        ({"radius": 1.0, "lam": -0.1}, "lam"),
        ({"radius": 1.0, "lam": "big"}, "lam"),
        ({"radius": 1.0, "eta": 0.83}, "eta"),
        ({"radius": 1.0, "eta": float("nan")}, "eta"),
        ({"radius": -1.0, "lam": 0.2}, "radius"),
        ({"circumscribed_radius": 0.0, "lam": 0.2}, "circumscribed_radius"),
        ({"radius": 1.0, "circumscribed_radius": 2.0, "lam": 0.2}, "radius/circumscribed_radius"),
        ({"lam": 0.2}, "radius/circumscribed_radius"),
    ],
)
def test_bad_tetrahedral_input_names_the_field(kwargs, field):
    with pytest.raises(InputError) as info:
        tetrahedral_aggregate(**kwargs)
    assert info.value.field == field


@pytest.mark.parametrize(
    ("centres", "radii", "field"),
    [
        ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [1.0, -1.0], "radii[1]"),
        ([[0.0, 0.0, 0.0]], [1.0, 2.0], "radii"),
        ([[0.0, 0.0]], [1.0], "centres"),
        ([], [], "centres"),
        ([[0.0, np.nan, 0.0]], [1.0], "centres[0]"),
    ],
)
def test_bad_spheres_name_the_field(centres, radii, field):
    with pytest.raises(InputError) as info:
        from_spheres(centres, radii)
    assert info.value.field == field
