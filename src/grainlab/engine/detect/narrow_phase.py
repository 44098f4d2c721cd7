"""Narrow phase: contact points of candidate pairs and of walls, for sphere-based bodies here
and for convex polyhedra through :mod:`grainlab.engine.detect.polyhedron_narrow_phase` (Numba;
STYLE.md 2, 3, 8; research/cd_engines.md 6.4). The kernels a body goes through are those of
its shape kind's narrow-phase family (:attr:`~grainlab.engine.shape_kinds.ShapeKind.narrow_phase`:
member spheres here, polyhedron features there; a pair with a polyhedron goes through the
polyhedron kernels).

Spheres and aggregates are both lists of member spheres (:class:`~grainlab.engine.state.
ShapeLibrary`), so one geometry serves all sphere-based shape pairs (sphere-sphere,
aggregate-sphere, aggregate-aggregate): the member spheres of every body are first placed in
the world frame, c = x + R(q) c_body, then each candidate body pair (i, j) tests every member
pair (a of i, b of j). With d = c_b - c_a, the

    gap       g = |d| - r_a - r_b                          [m]
    normal    n = d / |d|          (from i to j; n = e_z when |d| = 0)
    point     p = c_a + (r_a + g/2) n                      [m]

(the midpoint between the two surfaces along n), and the member pair is a contact when
g <= alert. Swapping i and j flips n and keeps p. Each touching member pair gives one contact
point: an aggregate pair can carry several (classified by :func:`classify_aggregate_pairs`).
Member spheres of one body are never tested against each other.

Walls are planes through a point p_w with a unit normal n_w pointing out of the wall into the
region of the bodies. A member sphere (c, r) of body j has the gap g = (c - p_w) . n_w - r; the
wall is side i of the contact, written body_i = -1 - w, member_i = -1, so the contact normal
(from i to j) is n_w itself and p = c - (r + g/2) n_w. A body is tested against a wall only if
its bounding sphere is within the alert distance.

Output, rows 0 .. C-1 of arrays allocated by the launcher (C, ...): ``body_i``, ``body_j``,
``member_i``, ``member_j`` (member index inside its shape, 0 .. count-1), ``point`` (C, 3) [m],
``normal`` (C, 3), ``gap`` (C,) [m]. Body-pair contacts come first, in the order of the
candidate pairs and then of the members (a, b) lexicographically; then the rows of the pairs
with a polyhedron (polyhedron-polyhedron: 1 to ``max_points`` points of the pair's manifold,
each with its own normal; polyhedron-member sphere: 1 point per member), in the order of the
candidate pairs; wall contacts follow, by wall then body then member, then the
polyhedron-wall rows by wall then body. ``contact_type`` (C,)
int8 is 0 on sphere-based rows and the pair's type code (1 fv, 2 ee, 3 fe, 4 ff; names
:data:`POLYHEDRON_CONTACT_TYPE_NAMES`) on every row of a pair with a polyhedron; member ids of a
polyhedron are feature ids (vertex k -> k, edge e -> V + e, face f -> V + E + f), stable while
the same features touch (warm-start keys). The kernels return the number of rows they needed
and write only the rows that fit; the launcher grows the buffers (to 1.25 x the need) and runs
again, never truncating (STYLE.md 8). The pair loop is serial so that the order above is
deterministic.

>>> import numpy as np
>>> from grainlab.engine.state import BodyState, ShapeLibrary
>>> library = ShapeLibrary.from_spheres([0.5])
>>> state = BodyState.from_library(library, [0, 0], [[0, 0, 0], [0.99, 0, 0]], 1000.0)
>>> contacts = NarrowPhase(alert=0.0).detect(state, library, np.array([[0, 1]]))
>>> contacts.n_contacts, round(float(contacts.gap[0]), 12), contacts.normal[0].tolist()
(1, -0.01, [1.0, 0.0, 0.0])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from grainlab.engine.detect import polyhedron_narrow_phase
from grainlab.engine.detect.polyhedron_narrow_phase import (
    ContactBuffers,
    ManifoldSettings,
    MemberSpheres,
    ShapeTopology,
    angle_tolerances,
    polyhedron_pairs_kernel,
    polyhedron_walls_kernel,
    world_polyhedra,
)
from grainlab.engine.quaternion import rotate
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron_contact import ANGLE_TOLERANCE, DEFAULT_MAX_POINTS, MAX_POINTS

_GROWTH = 1.25

POLYHEDRON_CONTACT_TYPE_NAMES = ("", "fv", "ee", "fe", "ff")
"""Names of the ``contact_type`` codes of pairs with a polyhedron (0: sphere-based rows)."""

CONTACT_CLASS_NAMES = ("s", "ds", "d", "t", "q", "m")
"""Names of the codes of :func:`classify_aggregate_pairs`: simple, double-simple, double,
triple, quadruple, and "m" for five or more contacts (seed 003: below 1 %)."""


# --------------------------------------------------------------------------------------------
# Scalar law
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def sphere_sphere(ax, ay, az, ra, bx, by, bz, rb):
    """Gap g [m], normal (nx, ny, nz) from a to b and midpoint (px, py, pz) [m] of spheres
    a = (centre, radius) and b (module docstring)."""
    dx, dy, dz = bx - ax, by - ay, bz - az
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    if dist > 0.0:
        nx, ny, nz = dx / dist, dy / dist, dz / dist
    else:
        nx, ny, nz = 0.0, 0.0, 1.0
    g = dist - ra - rb
    s = ra + 0.5 * g
    return g, nx, ny, nz, ax + s * nx, ay + s * ny, az + s * nz


# --------------------------------------------------------------------------------------------
# Array kernels (outputs last)
# --------------------------------------------------------------------------------------------


@njit(cache=True, parallel=True)
def world_spheres_kernel(
    positions, orientations, shape_ids, sphere_start, sphere_offsets, sphere_radii, body_start,
    world_centres, world_radii,
):
    """Member spheres of N bodies in the world frame: body n owns rows body_start[n] ..
    body_start[n + 1] - 1 of ``world_centres`` (M, 3) [m] and ``world_radii`` (M,) [m]."""
    for n in prange(positions.shape[0]):
        w, x, y, z = orientations[n, 0], orientations[n, 1], orientations[n, 2], \
            orientations[n, 3]
        first = sphere_start[shape_ids[n]]
        for row in range(body_start[n], body_start[n + 1]):
            k = first + row - body_start[n]
            rx, ry, rz = rotate(w, x, y, z, sphere_offsets[k, 0], sphere_offsets[k, 1],
                                sphere_offsets[k, 2])
            world_centres[row, 0] = positions[n, 0] + rx
            world_centres[row, 1] = positions[n, 1] + ry
            world_centres[row, 2] = positions[n, 2] + rz
            world_radii[row] = sphere_radii[k]


@njit(inline="always")
def _store(row, bi, bj, mi, mj, g, nx, ny, nz, px, py, pz,
           body_i, body_j, member_i, member_j, point, normal, gap):
    if row < gap.shape[0]:
        body_i[row] = bi
        body_j[row] = bj
        member_i[row] = mi
        member_j[row] = mj
        gap[row] = g
        normal[row, 0] = nx
        normal[row, 1] = ny
        normal[row, 2] = nz
        point[row, 0] = px
        point[row, 1] = py
        point[row, 2] = pz


# no reference counts on the arrays in the loops (inline helpers): compiled without the Numba
# runtime (_nrt=False), as they allocate nothing
@njit(cache=True, _nrt=False)
def pair_contacts_kernel(
    pairs, body_start, world_centres, world_radii, alert, start,
    body_i, body_j, member_i, member_j, point, normal, gap,
):
    """Member-sphere contacts (g <= alert) of candidate body pairs ``pairs`` (P, 2), written
    from row ``start`` on; returns ``start`` + the number of contacts (rows that do not fit the
    output arrays are counted, not written)."""
    row = start
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        for a in range(body_start[i], body_start[i + 1]):
            ax, ay, az = world_centres[a, 0], world_centres[a, 1], world_centres[a, 2]
            ra = world_radii[a]
            for b in range(body_start[j], body_start[j + 1]):
                g, nx, ny, nz, px, py, pz = sphere_sphere(
                    ax, ay, az, ra, world_centres[b, 0], world_centres[b, 1],
                    world_centres[b, 2], world_radii[b],
                )
                if g <= alert:
                    _store(row, i, j, a - body_start[i], b - body_start[j], g, nx, ny, nz,
                           px, py, pz, body_i, body_j, member_i, member_j, point, normal, gap)
                    row += 1
    return row


@njit(cache=True, _nrt=False)
def wall_contacts_kernel(
    wall_points, wall_normals, positions, bounding_radii, body_start, world_centres,
    world_radii, alert, start,
    body_i, body_j, member_i, member_j, point, normal, gap,
):
    """Member-sphere contacts (g <= alert) with plane walls (points (W, 3) [m], unit normals
    (W, 3)) of bodies whose bounding sphere (``bounding_radii`` (N,) [m]) is within ``alert``;
    written from row ``start`` on, returns ``start`` + the number of contacts."""
    row = start
    for w in range(wall_points.shape[0]):
        qx, qy, qz = wall_points[w, 0], wall_points[w, 1], wall_points[w, 2]
        nx, ny, nz = wall_normals[w, 0], wall_normals[w, 1], wall_normals[w, 2]
        for n in range(positions.shape[0]):
            h = (positions[n, 0] - qx) * nx + (positions[n, 1] - qy) * ny \
                + (positions[n, 2] - qz) * nz
            if h - bounding_radii[n] > alert:
                continue
            for a in range(body_start[n], body_start[n + 1]):
                cx, cy, cz = world_centres[a, 0], world_centres[a, 1], world_centres[a, 2]
                r = world_radii[a]
                g = (cx - qx) * nx + (cy - qy) * ny + (cz - qz) * nz - r
                if g <= alert:
                    s = r + 0.5 * g
                    _store(row, -1 - w, n, -1, a - body_start[n], g, nx, ny, nz,
                           cx - s * nx, cy - s * ny, cz - s * nz,
                           body_i, body_j, member_i, member_j, point, normal, gap)
                    row += 1
    return row


# --------------------------------------------------------------------------------------------
# Python launcher
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Contacts:
    """Contact points of one detection (module docstring for the meaning of each array).

    ``body_i``, ``body_j``, ``member_i``, ``member_j`` (C,) int64; ``point`` (C, 3) [m];
    ``normal`` (C, 3) unit, from i to j; ``gap`` (C,) [m], negative when overlapping. A wall
    w appears as body_i = -1 - w with member_i = -1. ``contact_type`` (C,) int8: 0 for
    sphere-based rows, else the polyhedron pair's type (:data:`POLYHEDRON_CONTACT_TYPE_NAMES`);
    zeros when not given.
    """

    body_i: np.ndarray
    body_j: np.ndarray
    member_i: np.ndarray
    member_j: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    contact_type: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.contact_type is None:
            object.__setattr__(self, "contact_type",
                               np.zeros(np.asarray(self.gap).shape[0], dtype=np.int8))

    @property
    def n_contacts(self) -> int:
        """Number of contact points C."""
        return int(self.gap.shape[0])


def _validated_walls(wall_points, wall_normals) -> tuple[np.ndarray, np.ndarray]:
    if wall_points is None and wall_normals is None:
        return np.zeros((0, 3)), np.zeros((0, 3))
    points = np.ascontiguousarray(wall_points, dtype=np.float64)
    normals = np.array(wall_normals, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or not np.isfinite(points).all():
        raise InputError("wall_points", points.tolist(), "a finite (W, 3) array in m")
    if normals.shape != points.shape or not np.isfinite(normals).all():
        raise InputError("wall_normals", normals.tolist(),
                         f"a finite array of shape {points.shape}, one normal per wall point")
    lengths = np.linalg.norm(normals, axis=1)
    for w in range(lengths.shape[0]):
        if not lengths[w] > 0.0:
            raise InputError(f"wall_normals[{w}]", normals[w].tolist(), "a non-zero vector")
    return points, np.ascontiguousarray(normals / lengths[:, None])


def _validated_pairs(pairs, n_bodies: int) -> np.ndarray:
    arr = np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2) if len(pairs) else \
        np.zeros((0, 2), dtype=np.int64)
    bad = (arr < 0).any(axis=1) | (arr >= n_bodies).any(axis=1) | (arr[:, 0] == arr[:, 1])
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"pairs[{k}]", arr[k].tolist(),
                         f"two different body indices in 0 .. {n_bodies - 1}")
    return arr


class NarrowPhase:
    """Contact points of sphere-based bodies (module docstring).

    Parameters
    ----------
    alert:
        Alert distance [m] >= 0: member pairs with gap <= alert are contacts.
    capacity:
        Initial rows of the output buffers (>= 1); they grow when a call needs more.
    angle_tolerance:
        Angle [rad] classifying the supporting features of polyhedra (face parallel / edge
        perpendicular to the normal within it; :mod:`grainlab.geometry.polyhedron_contact`).
    max_points:
        Most points kept per polyhedron manifold, 3 to :data:`MAX_POINTS`: the deepest, the
        3-4 spanning the largest area, then the deepest of the rest
        (:mod:`grainlab.geometry.polyhedron_manifold`; default
        :data:`~grainlab.geometry.polyhedron_contact.DEFAULT_MAX_POINTS`).
    """

    def __init__(self, alert: float, capacity: int = 1024,
                 angle_tolerance: float = ANGLE_TOLERANCE,
                 max_points: int = DEFAULT_MAX_POINTS) -> None:
        try:
            value = float(alert)
        except (TypeError, ValueError):
            value = math.nan
        if not (math.isfinite(value) and value >= 0.0):
            raise InputError("alert", alert, "a finite distance >= 0 in m")
        if isinstance(capacity, bool) or not isinstance(capacity, int | np.integer) \
                or capacity < 1:
            raise InputError("capacity", capacity, "an integer >= 1 (rows)")
        try:
            angle = float(angle_tolerance)
        except (TypeError, ValueError):
            angle = math.nan
        if not (math.isfinite(angle) and 0.0 <= angle < 0.5 * math.pi):
            raise InputError("angle_tolerance", angle_tolerance, "an angle in [0, pi/2) in rad")
        self.angle_tolerance = angle
        if max_points not in range(3, MAX_POINTS + 1) or isinstance(max_points, bool):
            raise InputError("max_points", max_points, f"an integer from 3 to {MAX_POINTS}")
        self.max_points = int(max_points)
        self.alert = value
        self.n_regrowths = 0
        self._allocate(int(capacity))

    def _allocate(self, rows: int) -> None:
        self._buffers = (
            np.empty(rows, dtype=np.int64), np.empty(rows, dtype=np.int64),
            np.empty(rows, dtype=np.int64), np.empty(rows, dtype=np.int64),
            np.empty((rows, 3)), np.empty((rows, 3)), np.empty(rows),
            np.zeros(rows, dtype=np.int8),
        )

    @property
    def capacity(self) -> int:
        """Rows of the output buffers now."""
        return int(self._buffers[-2].shape[0])

    def world_spheres(self, state: BodyState, library: ShapeLibrary):
        """Member spheres in the world frame: (body_start (N + 1,), centres (M, 3) [m],
        radii (M,) [m])."""
        ids = state.shape_ids
        counts = library.sphere_count[ids]
        body_start = np.zeros(state.n_bodies + 1, dtype=np.int64)
        np.cumsum(counts, out=body_start[1:])
        centres = np.empty((int(body_start[-1]), 3))
        radii = np.empty(int(body_start[-1]))
        world_spheres_kernel(
            np.ascontiguousarray(state.positions), np.ascontiguousarray(state.orientations),
            ids, library.sphere_start, library.sphere_offsets, library.sphere_radii,
            body_start, centres, radii,
        )
        return body_start, centres, radii

    def detect(
        self, state: BodyState, library: ShapeLibrary, pairs, wall_points=None,
        wall_normals=None,
    ) -> Contacts:
        """Contacts of the candidate body ``pairs`` (P, 2) (e.g. from the broad phase) and of
        every body with the walls (``wall_points`` (W, 3) [m], ``wall_normals`` (W, 3), pointing
        into the bodies' region; normalised here)."""
        pairs = _validated_pairs(pairs, state.n_bodies)
        points, normals = _validated_walls(wall_points, wall_normals)
        body_start, centres, radii = self.world_spheres(state, library)
        bounding = np.ascontiguousarray(library.bounding_radius[state.shape_ids])
        positions = np.ascontiguousarray(state.positions)
        polyhedra = world_polyhedra(state, library)
        is_poly = polyhedra.is_poly
        any_poly = bool(is_poly.any())
        if any_poly:
            poly_pairs = np.ascontiguousarray(pairs[is_poly[pairs[:, 0]] | is_poly[pairs[:, 1]]])
        settings = ManifoldSettings(float(self.alert), *angle_tolerances(self.angle_tolerance),
                                    int(self.max_points))
        shape_ids = np.ascontiguousarray(state.shape_ids, dtype=np.int64)
        topology = ShapeTopology.of(library)
        spheres = MemberSpheres(body_start, centres, radii)
        while True:
            self._buffers[-1][:] = 0
            sphere_rows = self._buffers[:-1]
            rows = ContactBuffers(*self._buffers)
            n_pair = pair_contacts_kernel(
                pairs, body_start, centres, radii, self.alert, 0, *sphere_rows)
            if any_poly:
                n_pair = polyhedron_pairs_kernel(
                    poly_pairs, shape_ids, positions, polyhedra, topology, spheres, settings,
                    n_pair, rows, polyhedron_narrow_phase.PARALLEL_PAIRS)
            n_all = wall_contacts_kernel(
                points, normals, positions, bounding, body_start, centres, radii, self.alert,
                n_pair, *sphere_rows)
            if any_poly:
                n_all = polyhedron_walls_kernel(points, normals, positions, bounding, shape_ids,
                                                polyhedra, topology, settings, n_all, rows)
            if n_all <= self.capacity:
                break
            self._allocate(max(math.ceil(_GROWTH * n_all), self.capacity + 1))
            self.n_regrowths += 1
        return Contacts(*(buffer[:n_all].copy() for buffer in self._buffers))


def classify_aggregate_pairs(body_i, body_j, member_i, member_j):
    """Seed 003 Fig. 8 class of every body pair that carries contacts.

    Contacts are grouped by (body_i, body_j); with n contacts in a group the code is

    - n = 1: 0 "s" (simple);
    - n = 2: 2 "d" (double) when the two contacts share a member sphere on one side (one
      sphere of one aggregate touches two of the other), else 1 "ds" (double-simple: two
      different pairs of spheres);
    - n = 3: 3 "t" (triple), whatever its make-up (Fig. 8 3a: a double plus a simple; 3b: one
      sphere touching three; 3c: three simple contacts);
    - n = 4: 4 "q" (quadruple); the seed names two doubles, here every four-contact pair;
    - n >= 5: 5 "m" (five or six contacts, below 1 % in the seed).

    A wall counts as one member sphere (member_i = -1), so a body touching a wall with two
    members is "d". Names: :data:`CONTACT_CLASS_NAMES`.

    Returns ``(pairs, codes, counts)``: the distinct body pairs (K, 2) sorted
    lexicographically, their codes (K,) int64 and contact counts (K,).

    >>> pairs, codes, counts = classify_aggregate_pairs([0, 0, 1], [1, 1, 2], [0, 1, 2],
    ...                                                  [3, 3, 0])
    >>> [CONTACT_CLASS_NAMES[c] for c in codes], counts.tolist()
    (['d', 's'], [2, 1])
    """
    bi, bj = np.asarray(body_i, np.int64), np.asarray(body_j, np.int64)
    mi, mj = np.asarray(member_i, np.int64), np.asarray(member_j, np.int64)
    if not (bi.shape == bj.shape == mi.shape == mj.shape) or bi.ndim != 1:
        raise InputError("body_i/body_j/member_i/member_j",
                         (bi.shape, bj.shape, mi.shape, mj.shape),
                         "four 1-D arrays of equal length")
    order = np.lexsort((mj, mi, bj, bi))
    bi, bj, mi, mj = bi[order], bj[order], mi[order], mj[order]
    keys = np.stack([bi, bj], axis=1)
    if keys.shape[0] == 0:
        return np.zeros((0, 2), np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    new = np.ones(keys.shape[0], dtype=bool)
    new[1:] = (keys[1:] != keys[:-1]).any(axis=1)
    starts = np.flatnonzero(new)
    counts = np.diff(np.append(starts, keys.shape[0]))
    codes = np.select([counts == 1, counts == 2, counts == 3, counts == 4], [0, 1, 3, 4], 5)
    two = np.flatnonzero(counts == 2)
    first = starts[two]
    shared = (mi[first] == mi[first + 1]) | (mj[first] == mj[first + 1])
    codes[two[shared]] = 2
    return keys[starts], codes.astype(np.int64), counts.astype(np.int64)
