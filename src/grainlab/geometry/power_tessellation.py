"""Radical-plane (power, Laguerre) tessellation of a periodic disc packing (seed 000, Fig. 2).

The cell of disc i is the set of points x whose power |x - x_i|^2 - r_i^2 is not larger than
their power with respect to any other disc or periodic image. The boundary between two discs
is their radical line: the line normal to the line of centres through the point from which the
tangents to both discs have equal length (seed 000, Fig. 2: OA = OB). For touching discs it
passes through the contact point. For equal discs it is the perpendicular bisector, so the
power cell is the ordinary Voronoi cell.

The cells are computed as half-plane intersections with :class:`scipy.spatial.HalfspaceIntersection`
(qhull), and the tessellation checks that they tile the periodic cell.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import HalfspaceIntersection

from grainlab.errors import GeometryError
from grainlab.geometry.disc_packing import DiscPacking2D

TILING_TOLERANCE = 1e-9
"""Relative mismatch allowed between the summed cell areas and the periodic cell area."""


def radical_point(
    centre_i: np.ndarray, radius_i: float, centre_j: np.ndarray, radius_j: float
) -> np.ndarray:
    """The point where the radical line of discs i and j crosses their line of centres [m].

    It lies at s = (d^2 + r_i^2 - r_j^2) / (2 d) from x_i towards x_j (d the centre distance);
    for touching discs s = r_i, the contact point.
    """
    centre_i = np.asarray(centre_i, dtype=float)
    d_vec = np.asarray(centre_j, dtype=float) - centre_i
    d = np.linalg.norm(d_vec)
    s = (d**2 + radius_i**2 - radius_j**2) / (2.0 * d)
    return centre_i + s * d_vec / d


@dataclass(frozen=True, eq=False)
class PowerTessellation:
    """The power cells of the discs of one periodic cell.

    Attributes
    ----------
    polygons:
        One (k, 2) array per disc: the cell's vertices [m], counter-clockwise, around the disc
        centre as given in the packing.
    neighbours:
        One (k, 3) integer array per disc: for edge e (from vertex e to vertex e+1), the
        neighbouring disc index and its lattice image (j, n1, n2).
    areas:
        (N,) cell areas [m^2].
    """

    polygons: tuple[np.ndarray, ...]
    neighbours: tuple[np.ndarray, ...]
    areas: np.ndarray

    @property
    def total_area(self) -> float:
        """Sum of the cell areas [m^2]; equals the periodic cell area."""
        return float(self.areas.sum())

    def local_void_ratios(self, radii: np.ndarray) -> np.ndarray:
        """(N,) void ratio of each power cell, (A_cell - pi r^2) / (pi r^2) [-]."""
        solid = np.pi * np.asarray(radii) ** 2
        return self.areas / solid - 1.0


def _polygon_area(vertices: np.ndarray) -> float:
    x, y = vertices[:, 0], vertices[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def power_tessellation(packing: DiscPacking2D) -> PowerTessellation:
    """Compute the radical-plane tessellation of a periodic disc packing.

    Raises
    ------
    GeometryError
        A disc centre lies outside its own power cell (discs overlapping deeply) or the cells
        fail to tile the periodic cell.

    >>> from grainlab.prep.regular_packings import named_packing
    >>> t = power_tessellation(named_packing("square"))
    >>> len(t.polygons[0])  # the Voronoi cell of the square packing is a square
    4
    """
    lattice = packing.cell.lattice
    reach = float(np.linalg.norm(lattice, axis=1).sum() + 2.0 * packing.radii.max())
    polygons, neighbours, areas = [], [], []
    n = packing.n_particles
    for i in range(n):
        others, deltas, radii_j = [], [], []
        for j in range(n):
            images, offsets = packing.cell.images_near(
                packing.centres[j] - packing.centres[i], reach
            )
            d = packing.centres[j] + offsets - packing.centres[i]
            keep = np.linalg.norm(d, axis=1) <= reach
            if j == i:
                keep &= np.any(images != 0, axis=1)
            for k in np.flatnonzero(keep):
                others.append((j, *images[k]))
                deltas.append(d[k])
                radii_j.append(packing.radii[j])
        delta = np.array(deltas)
        # 2 d.x - |d|^2 + r_j^2 - r_i^2 <= 0, with x relative to the centre of disc i.
        offset = -np.sum(delta**2, axis=1) + np.array(radii_j) ** 2 - packing.radii[i] ** 2
        if np.any(offset >= 0.0):
            bad = others[int(np.argmax(offset))]
            raise GeometryError(
                f"Disc {packing.labels[i]} lies outside its own power cell because of disc "
                f"{packing.labels[bad[0]]} (image {bad[1]}, {bad[2]}): the discs overlap."
            )
        halfspaces = np.column_stack([2.0 * delta, offset])
        hull = HalfspaceIntersection(halfspaces, np.zeros(2))
        vertices = hull.intersections
        order = np.argsort(
            np.arctan2(*(vertices - vertices.mean(axis=0)).T[::-1])
        )
        vertices = vertices[order]
        # Each edge lies on the half-plane that both of its end vertices make tight.
        slack = np.abs(halfspaces[:, :2] @ vertices.T + halfspaces[:, 2:3])
        scale = np.abs(halfspaces[:, 2:3]) + 1e-300
        tight = slack <= 1e-9 * scale
        edge_owner = []
        for e in range(len(vertices)):
            both = np.flatnonzero(tight[:, e] & tight[:, (e + 1) % len(vertices)])
            edge_owner.append(others[int(both[0])] if both.size else (-1, 0, 0))
        polygons.append(vertices + packing.centres[i])
        neighbours.append(np.array(edge_owner, dtype=int))
        areas.append(_polygon_area(vertices))
    areas_arr = np.array(areas)
    if abs(areas_arr.sum() - packing.cell.area) > TILING_TOLERANCE * packing.cell.area:
        raise GeometryError(
            f"The power cells cover {areas_arr.sum():.12g} m^2 but the periodic cell is "
            f"{packing.cell.area:.12g} m^2: the cell does not tile the packing."
        )
    return PowerTessellation(tuple(polygons), tuple(neighbours), areas_arr)
