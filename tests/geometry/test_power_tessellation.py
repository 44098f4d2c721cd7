"""Radical-plane (power) tessellation of periodic disc packings (seed 000, Fig. 2).

The fast half-plane construction is compared with an obviously right twin: random points
assigned to the disc (over periodic images) of least power |x - c|^2 - r^2.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial import ConvexHull, Voronoi

from grainlab.errors import GeometryError, RattlerWarning
from grainlab.geometry import (
    DiscPacking2D,
    PeriodicCell2D,
    find_disc_contacts,
    power_tessellation,
)
from grainlab.geometry.power_tessellation import radical_point
from grainlab.prep.regular_packings import named_packing

NAMES = ["square", "rhombic", "hexagonal", "A", "B", "C"]


def random_packing(seed: int, n: int = 6) -> DiscPacking2D:
    """Non-overlapping discs of unequal radii in an oblique periodic cell."""
    rng = np.random.default_rng(seed)
    lattice = np.array([[1.0, 0.0], [0.3, 0.9]])
    cell = PeriodicCell2D(lattice)
    centres, radii = [], []
    while len(radii) < n:
        x = rng.random(2) @ lattice
        r = rng.uniform(0.03, 0.15)
        ok = True
        for c, rc in zip(centres, radii, strict=True):
            for n1 in range(-2, 3):
                for n2 in range(-2, 3):
                    image = c + n1 * lattice[0] + n2 * lattice[1]
                    if np.linalg.norm(x - image) < (r + rc) * 1.01:
                        ok = False
        if ok and 2 * r < 0.85:
            centres.append(x)
            radii.append(r)
    return DiscPacking2D(cell, centres, radii, "random")


def least_power_owner(packing: DiscPacking2D, points: np.ndarray, reach: int = 3):
    """Slow twin: for each point, the disc index and lattice image of least power, and the
    gap between the least and second least powers."""
    lattice = packing.cell.lattice
    n1, n2 = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1))
    images = np.column_stack([n1.ravel(), n2.ravel()])
    sites = (packing.centres[:, None, :] + (images @ lattice)[None, :, :]).reshape(-1, 2)
    site_radius = np.repeat(packing.radii, len(images))
    site_disc = np.repeat(np.arange(packing.n_particles), len(images))
    site_image = np.tile(images, (packing.n_particles, 1))
    power = (
        np.sum(points**2, axis=1)[:, None]
        - 2.0 * points @ sites.T
        + np.sum(sites**2, axis=1)[None, :]
        - site_radius[None, :] ** 2
    )
    order = np.argsort(power, axis=1)
    best, second = order[:, 0], order[:, 1]
    rows = np.arange(len(points))
    margin = power[rows, second] - power[rows, best]
    return site_disc[best], site_image[best], margin


def inside_convex_polygon(vertices: np.ndarray, points: np.ndarray, tol: float) -> np.ndarray:
    """True for points inside a counter-clockwise convex polygon (within ``tol``)."""
    inside = np.ones(len(points), dtype=bool)
    for k in range(len(vertices)):
        a, b = vertices[k], vertices[(k + 1) % len(vertices)]
        edge = b - a
        rel = points - a
        cross = edge[0] * rel[:, 1] - edge[1] * rel[:, 0]
        inside &= cross >= -tol
    return inside


def tessellate(packing):
    return power_tessellation(packing)


@pytest.mark.parametrize("name", NAMES)
def test_cell_areas_sum_to_the_periodic_cell(name):
    packing = named_packing(name)
    t = tessellate(packing)
    assert t.total_area == pytest.approx(packing.cell.area, rel=1e-12)
    assert len(t.polygons) == packing.n_particles
    for polygon, area in zip(t.polygons, t.areas, strict=True):
        x, y = polygon[:, 0], polygon[:, 1]
        shoelace = 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
        assert shoelace > 0  # counter-clockwise
        assert shoelace == pytest.approx(area, rel=1e-12)
        assert ConvexHull(polygon).volume == pytest.approx(area, rel=1e-12)
    # void ratio from the cells is the packing's void ratio
    solid = np.pi * packing.radii**2
    local = t.local_void_ratios(packing.radii)
    np.testing.assert_allclose(local, t.areas / solid - 1.0, rtol=1e-14)
    assert np.sum(t.areas) / np.sum(solid) - 1.0 == pytest.approx(packing.void_ratio, rel=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_unequal_packing_tiles(seed):
    packing = random_packing(seed)
    t = tessellate(packing)
    assert t.total_area == pytest.approx(packing.cell.area, rel=1e-12)
    for centre, polygon in zip(packing.centres, t.polygons, strict=True):
        assert inside_convex_polygon(polygon, centre[None, :], 0.0)[0]


def test_hexagonal_cell_is_the_regular_hexagon():
    packing = named_packing("hexagonal")
    d = 2 * packing.radii[0]
    polygon = tessellate(packing).polygons[0]
    assert len(polygon) == 6
    # vertices of the Voronoi hexagon lie at the circumradius d / sqrt(3)
    np.testing.assert_allclose(
        np.linalg.norm(polygon - packing.centres[0], axis=1), d / np.sqrt(3), rtol=1e-12
    )
    sides = np.linalg.norm(np.roll(polygon, -1, axis=0) - polygon, axis=1)
    np.testing.assert_allclose(sides, d / np.sqrt(3), rtol=1e-12)
    assert tessellate(packing).areas[0] == pytest.approx(np.sqrt(3) / 2 * d**2, rel=1e-12)


def test_square_cell_is_the_square():
    packing = named_packing("square")
    d = 2 * packing.radii[0]
    polygon = tessellate(packing).polygons[0]
    assert len(polygon) == 4
    np.testing.assert_allclose(np.abs(polygon), d / 2, rtol=1e-12)


def periodic_voronoi_areas(packing: DiscPacking2D, reach: int = 2) -> np.ndarray:
    """Ordinary Voronoi cell areas of the discs (scipy, replicated images)."""
    lattice = packing.cell.lattice
    points, centre_rows = [], []
    for n1 in range(-reach, reach + 1):
        for n2 in range(-reach, reach + 1):
            for c in packing.centres:
                if n1 == 0 and n2 == 0:
                    centre_rows.append(len(points))
                points.append(c + n1 * lattice[0] + n2 * lattice[1])
    vor = Voronoi(np.array(points))
    areas = []
    for row in centre_rows:
        region = vor.regions[vor.point_region[row]]
        assert -1 not in region
        areas.append(ConvexHull(vor.vertices[region]).volume)
    return np.array(areas)


@pytest.mark.parametrize("name", ["square", "rhombic", "hexagonal", "A", "B"])
def test_equal_discs_give_ordinary_voronoi_cells(name):
    packing = named_packing(name)
    np.testing.assert_allclose(
        tessellate(packing).areas, periodic_voronoi_areas(packing), rtol=1e-9
    )


def test_equal_radii_power_cells_do_not_depend_on_the_common_radius():
    packing = named_packing("A")
    smaller = DiscPacking2D(packing.cell, packing.centres, 0.5 * packing.radii)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RattlerWarning)
        a, b = tessellate(packing), tessellate(smaller)
    for pa, pb in zip(a.polygons, b.polygons, strict=True):
        np.testing.assert_allclose(pa, pb, atol=1e-15)


def test_radical_point_of_touching_discs_is_the_contact_point():
    ci, ri = np.array([0.3, -0.2]), 0.7
    direction = np.array([np.cos(0.4), np.sin(0.4)])
    for rj in (0.7, 0.35, 2.0):
        cj = ci + (ri + rj) * direction
        point = radical_point(ci, ri, cj, rj)
        np.testing.assert_allclose(point, ci + ri * direction, atol=1e-14)
        # equal tangent lengths: power with respect to both discs is equal (zero here)
        assert np.sum((point - ci) ** 2) - ri**2 == pytest.approx(0.0, abs=1e-14)
        assert np.sum((point - cj) ** 2) - rj**2 == pytest.approx(0.0, abs=1e-14)
        if rj != ri:
            midpoint = 0.5 * (ci + cj)
            assert np.linalg.norm(point - midpoint) > 0.1 * abs(rj - ri)


def test_radical_point_has_equal_tangent_lengths_for_separated_discs():
    ci, ri, cj, rj = np.array([0.0, 0.0]), 1.0, np.array([5.0, 1.0]), 2.5
    point = radical_point(ci, ri, cj, rj)
    tangent_i = np.sum((point - ci) ** 2) - ri**2
    tangent_j = np.sum((point - cj) ** 2) - rj**2
    assert tangent_i == pytest.approx(tangent_j, rel=1e-12)
    # on the line of centres
    d = cj - ci
    rel = point - ci
    assert d[0] * rel[1] - d[1] * rel[0] == pytest.approx(0.0, abs=1e-12)
    # equal discs: the perpendicular bisector
    np.testing.assert_allclose(radical_point(ci, 1.0, cj, 1.0), 0.5 * (ci + cj), atol=1e-14)


@pytest.mark.parametrize("name", NAMES)
def test_shared_edge_contains_the_contact_point(name):
    packing = named_packing(name)
    t = tessellate(packing)
    c = find_disc_contacts(packing)
    lattice = packing.cell.lattice
    scale = packing.radii.max()
    for k in range(c.n_contacts):
        i, j, image = c.particle_i[k], c.particle_j[k], c.image[k]
        point = packing.centres[i] + c.radius_i[k] * c.normal[k]
        cj = packing.centres[j] + image @ lattice
        np.testing.assert_allclose(
            radical_point(packing.centres[i], c.radius_i[k], cj, c.radius_j[k]),
            point,
            atol=1e-12 * scale,
        )
        # the edge of i facing (j, image), and the edge of j facing (i, -image)
        for owner, other, shift, p in (
            (i, j, image, point),
            (j, i, -image, point - image @ lattice),
        ):
            rows = np.flatnonzero(
                (t.neighbours[owner][:, 0] == other)
                & np.all(t.neighbours[owner][:, 1:] == shift, axis=1)
            )
            assert rows.size == 1, (name, owner, other, shift)
            e = rows[0]
            polygon = t.polygons[owner]
            a, b = polygon[e], polygon[(e + 1) % len(polygon)]
            edge, rel = b - a, p - a
            cross = edge[0] * rel[1] - edge[1] * rel[0]
            assert abs(cross) <= 1e-10 * np.linalg.norm(edge) * scale
            along = np.dot(rel, edge) / np.dot(edge, edge)
            assert -1e-12 <= along <= 1 + 1e-12
            # the edge is normal to the branch vector
            assert abs(np.dot(edge, c.normal[k])) <= 1e-10 * np.linalg.norm(edge)


def test_unequal_touching_discs_edge_is_not_at_the_midpoint():
    packing = named_packing("C")
    c = find_disc_contacts(packing)
    unequal = np.flatnonzero(c.radius_i != c.radius_j)
    assert unequal.size == 4
    for k in unequal:
        ci = packing.centres[c.particle_i[k]]
        cj = ci + c.branch[k]
        point = radical_point(ci, c.radius_i[k], cj, c.radius_j[k])
        midpoint = 0.5 * (ci + cj)
        expected_offset = 0.5 * abs(c.radius_i[k] - c.radius_j[k])
        assert np.linalg.norm(point - midpoint) == pytest.approx(expected_offset, rel=1e-12)


def _monte_carlo_check(packing, n_points, seed):
    t = tessellate(packing)
    rng = np.random.default_rng(seed)
    points = rng.random((n_points, 2)) @ packing.cell.lattice
    owner, image, margin = least_power_owner(packing, points)
    fractions = np.bincount(owner, minlength=packing.n_particles) / n_points
    expected = t.areas / packing.cell.area
    sigma = np.sqrt(np.clip(expected * (1 - expected), 0.0, None) / n_points)
    assert np.all(np.abs(fractions - expected) <= 5 * sigma + 1e-12), (fractions, expected)
    # point by point: a point owned by (i, image) lies in cell i once shifted back
    scale = packing.radii.max() ** 2
    clear = margin > 1e-9 * scale
    length = np.linalg.norm(packing.cell.lattice, axis=1).max()
    for i in range(packing.n_particles):
        mine = clear & (owner == i)
        local = points[mine] - image[mine] @ packing.cell.lattice
        assert np.all(inside_convex_polygon(t.polygons[i], local, 1e-12 * length**2))
        others = clear & (owner != i)
        # a point of another cell is not strictly inside cell i (any image of it)
        for n1 in (-1, 0, 1):
            for n2 in (-1, 0, 1):
                shifted = points[others] - np.array([n1, n2]) @ packing.cell.lattice
                strictly = inside_convex_polygon(t.polygons[i], shifted, -1e-9 * length**2)
                assert not np.any(strictly)


@pytest.mark.parametrize("name", NAMES)
def test_tessellation_matches_least_power_oracle(name):
    _monte_carlo_check(named_packing(name), 20_000, seed=7)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_packing_matches_least_power_oracle(seed):
    _monte_carlo_check(random_packing(seed), 20_000, seed=seed + 100)


def test_deep_overlap_raises():
    cell = PeriodicCell2D([[10.0, 0.0], [0.0, 10.0]])
    # disc 1 lies inside disc 0: its centre has lower power with respect to disc 0
    packing = DiscPacking2D(cell, [[0.0, 0.0], [0.5, 0.0]], [3.0, 1.0], labels=("big", "in"))
    with pytest.raises(GeometryError, match="in"):
        tessellate(packing)


@pytest.mark.parametrize("name", ["A", "B", "C"])
@pytest.mark.parametrize("basis", [[[1, 0], [1, 1]], [[2, 1], [1, 1]], [[1, 0], [5, 1]]])
def test_cells_do_not_depend_on_how_the_periodic_cell_is_drawn(name, basis):
    packing = named_packing(name)
    redrawn = DiscPacking2D(
        PeriodicCell2D(np.array(basis, float) @ packing.cell.lattice),
        packing.centres,
        packing.radii,
    )
    a, b = tessellate(packing), tessellate(redrawn)
    np.testing.assert_allclose(b.areas, a.areas, rtol=1e-9)
    for pa, pb in zip(a.polygons, b.polygons, strict=True):
        assert len(pa) == len(pb)
        # same polygon up to the starting vertex
        start = np.argmin(np.linalg.norm(pb - pa[0], axis=1))
        np.testing.assert_allclose(np.roll(pb, -start, axis=0), pa, atol=1e-12)
