"""Contact geometry of convex polyhedra (seed 002): gap and normal, supporting features,
sphere contacts (Numba; no Python objects in the kernels).

Every routine works on WORLD-frame arrays of one polyhedron: vertices V (n_v, 3) [m], polygon
face normals N (n_f, 3) (outward, unit) and offsets O (n_f,) [m] (n . x = O on the face), the
face CSR ``face_start`` (n_f + 1,) into ``face_vertices`` (local vertex ids, counter-clockwise
seen from outside), edges E (n_e, 2) (local ids) with their two faces ``edge_faces`` (n_e, 2),
the vertex-neighbour CSR and the centre c (3,) [m] (:class:`~grainlab.engine.state.ShapeLibrary`
layout, moved to the world frame).

Gap and normal (polyhedron A, polyhedron B; normal n from A to B)
-----------------------------------------------------------------
The signed distance is g = max over unit n of s(n), s(n) = min_B n . b - max_A n . a: the
distance when A and B are apart, minus the penetration depth when they overlap. For
polytopes the maximum over an overlap is reached on a face of the Minkowski difference A - B,
i.e. on a face normal of A, a face normal of B or the cross product of an edge of A and an edge
of B whose Gauss-map arcs cross (Gregorius, "The separating axis test between convex
polyhedra", GDC 2013): the separating-axis test (SAT) over those axes is exact for an overlap.

1. Early out along the centre line u = (c_B - c_A)/|c_B - c_A|: s(u) > alert -> no contact.
2. Face axes of A and of B: s = min over the other's vertices (support by hill climbing on the
   vertex-neighbour graph, O(sqrt n_v) per axis) minus the face offset; any s > alert -> no
   contact. A face f of A is skipped when its bound s(f) <= n_f . c_B - O_f - r_B (r_B: the
   distance from B's centre to its nearest face plane) is below a value of s already reached,
   first that of the faces of largest bound of A and of B (faces of B likewise): such a face
   can be neither the best axis nor the first beyond the alert distance. The face axis kept
   is the first (faces of A, then of B, in their order) whose s is within the round-off band
   eps (:data:`TOUCH_TOLERANCE`) of the largest: a face of A and the face of B lying on it
   give the same axis, and where two different axes tie (a vertex on a rim) the choice does
   not depend on the round-off of the frame.
3. Edge axes, pruned to the slab of the best face axis n*: an edge of A enters only if one of
   its ends lies above min_B n* . b - alert, an edge of B only if one end lies below
   max_A n* . a + alert (the witness points of any axis better than n* lie there), and only
   pairs forming a face of the Minkowski difference (Gauss-map arc test, its first half
   branch-free over all kept edges of B) are evaluated, each in O(1): s = n . (b0 - a0).
   The arc test is strict by :data:`ARC_TOLERANCE`: arcs that meet at (or within round-off
   of) an end meet at a face normal, already a face axis; in a flat contact the edges lying
   in the contact plane are such pairs (their s is that of the face, give or take round-off).
   An edge axis replaces the face axis only if its s exceeds the largest face value by more
   than eps.
4. If the best s is <= eps it is the exact signed distance (overlap, or touching within the
   round-off) with its axis as normal: when 0 < s <= eps the exact distance is at most
   s / cos(alpha/2), alpha the widest normal cone of a vertex of A or B (< pi), so within
   the band too. If eps < s <= alert, the SAT value is a lower bound (vertex-vertex and
   vertex-edge closest pairs have no SAT axis), so the exact distance is taken as the
   smallest vertex-face (projection inside the face; a distance within -eps of 0 counts as
   0) or segment-segment distance over the features within the slab, and
   n = (p_B - p_A)/|p_B - p_A| unless it exceeds s by no more than eps (the SAT axis then
   gives the distance and the normal).

Contact type, manifold and walls: :mod:`grainlab.geometry.polyhedron_manifold`.

Spheres
-------
A sphere (centre, radius r) against a polyhedron: the closest point
of the polyhedron to the centre (the face of largest signed distance if the centre projects
inside it, else the nearest edge), one point, type 1 ("fv") for a face or a vertex, 2 ("ee")
for an edge.

Units: lengths in m, angles in rad.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

ANGLE_TOLERANCE = 0.01
"""Angle [rad] within which a face normal counts as parallel to the contact normal (face) or
an edge as perpendicular to it (edge) when classifying the supporting features."""

TYPE_NONE, TYPE_FV, TYPE_EE, TYPE_FE, TYPE_FF = 0, 1, 2, 3, 4
"""Contact type codes: 0 none/sphere-based, 1 fv, 2 ee, 3 fe, 4 ff."""

MAX_POINTS = 16
"""Largest number of points of one manifold (the ``max_points`` argument: 3 to 16)."""
DEFAULT_MAX_POINTS = 8
"""Points kept per manifold by default. Measured on a frictionless compaction of 60
polyhedra (n_f = 30, docs/benchmarks/polyhedra.md): with 3 or 4 the largest overlap ran away
to 10 % of <d>, with 6 it settled at 2 %, with 8 at 0.3 %, with 16 at 0.27 % (13 % more
contacts)."""

TOUCH_TOLERANCE = 1e-12
"""Relative round-off band of the separations: two values of s within
TOUCH_TOLERANCE (R_A + R_B + |c_A|_1 + |c_B|_1) of each other are treated as equal, and a best
separation within that band of 0 as touching (R: circumscribed radius about the centre c [m];
the world coordinates carry errors of about 1e-16 of their magnitude, so the band is about
1e3 times the round-off and 1e-12 of the bodies' size)."""
ARC_TOLERANCE = 1e-12
"""Sine of the angle within which an end of one Gauss-map arc counts as lying on the great
circle of the other: such a pair of edges crosses (if at all) at a face normal, which is a face
axis, not an edge-edge face of the Minkowski difference."""

_VERTEX, _EDGE, _FACE = 0, 1, 2
_HUGE = 1e300


# --------------------------------------------------------------------------------------------
# Small scalar helpers
# --------------------------------------------------------------------------------------------


@njit
def _support(vertices, nstart, nbrs, dx, dy, dz, start):
    """Index of the vertex maximising d . v, by hill climbing from ``start`` on the
    vertex-neighbour graph (exact on a convex polyhedron)."""
    best = start
    value = vertices[best, 0] * dx + vertices[best, 1] * dy + vertices[best, 2] * dz
    moved = True
    while moved:
        moved = False
        for k in range(nstart[best], nstart[best + 1]):
            w = nbrs[k]
            x = vertices[w, 0] * dx + vertices[w, 1] * dy + vertices[w, 2] * dz
            if x > value:
                value, best, moved = x, w, True
    return best, value


@njit
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit
def _seg_seg(p, i0, i1, q, j0, j1):
    """Closest points of segments [p[i0], p[i1]] and [q[j0], q[j1]] (rows of (n, 3) arrays):
    the link vector from the first to the second (lx, ly, lz) (scalar code)."""
    d1x, d1y, d1z = p[i1, 0] - p[i0, 0], p[i1, 1] - p[i0, 1], p[i1, 2] - p[i0, 2]
    d2x, d2y, d2z = q[j1, 0] - q[j0, 0], q[j1, 1] - q[j0, 1], q[j1, 2] - q[j0, 2]
    rx, ry, rz = p[i0, 0] - q[j0, 0], p[i0, 1] - q[j0, 1], p[i0, 2] - q[j0, 2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    c = d1x * rx + d1y * ry + d1z * rz
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denom = a * e - b * b
    if denom > 1e-14 * a * e:
        s = min(1.0, max(0.0, (b * f - c * e) / denom))
    else:
        s = 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(1.0, max(0.0, -c / a))
    elif t > 1.0:
        t = 1.0
        s = min(1.0, max(0.0, (b - c) / a))
    return t * d2x - s * d1x - rx, t * d2y - s * d1y - ry, t * d2z - s * d1z - rz


@njit
def _inside_face(x, vertices, fstart, fverts, f, normal):
    """Whether the projection of x along ``normal`` falls inside face f (CCW about normal)."""
    k0, k1 = fstart[f], fstart[f + 1]
    nx, ny, nz = normal[0], normal[1], normal[2]
    for k in range(k0, k1):
        p = fverts[k]
        q = fverts[k0 + (k - k0 + 1) % (k1 - k0)]
        ex, ey, ez = vertices[q, 0] - vertices[p, 0], vertices[q, 1] - vertices[p, 1], \
            vertices[q, 2] - vertices[p, 2]
        rx, ry, rz = x[0] - vertices[p, 0], x[1] - vertices[p, 1], x[2] - vertices[p, 2]
        cx, cy, cz = _cross(ex, ey, ez, rx, ry, rz)
        if cx * nx + cy * ny + cz * nz < 0.0:
            return False
    return True


@njit
def _find_edge(edges, u, v):
    a, b = min(u, v), max(u, v)
    for e in range(edges.shape[0]):
        if edges[e, 0] == a and edges[e, 1] == b:
            return e
    return -1


@njit(cache=True)
def supporting_feature(vertices, normals, nstart, nbrs, edges, dx, dy, dz, cos_tol, sin_tol):
    """Feature of a polyhedron supporting it along (dx, dy, dz) (unit): returns (kind, index,
    support vertex) with kind 0 vertex, 1 edge, 2 face (module docstring, tolerance angle
    given by its cosine and sine)."""
    best_f, best_c = -1, -2.0
    for f in range(normals.shape[0]):
        c = normals[f, 0] * dx + normals[f, 1] * dy + normals[f, 2] * dz
        if c > best_c:
            best_c, best_f = c, f
    top, _ = _support(vertices, nstart, nbrs, dx, dy, dz, 0)
    if best_c >= cos_tol:
        return _FACE, best_f, top
    best_w, best_s = -1, sin_tol
    for k in range(nstart[top], nstart[top + 1]):
        w = nbrs[k]
        tx = vertices[w, 0] - vertices[top, 0]
        ty = vertices[w, 1] - vertices[top, 1]
        tz = vertices[w, 2] - vertices[top, 2]
        s = abs(tx * dx + ty * dy + tz * dz) / math.sqrt(tx * tx + ty * ty + tz * tz)
        if s <= best_s:
            best_s, best_w = s, w
    if best_w >= 0:
        return _EDGE, _find_edge(edges, top, best_w), top
    return _VERTEX, top, top


# --------------------------------------------------------------------------------------------
# Gap and normal
# --------------------------------------------------------------------------------------------


@njit
def _inradius(normals, offsets, c):
    """Distance [m] from c to the nearest face plane, min_f (O_f - n_f . c) (> 0 when c is
    inside); every unit n then has min_x n . x <= n . c - r over the body."""
    r = _HUGE
    for f in range(normals.shape[0]):
        r = min(r, offsets[f] - (normals[f, 0] * c[0] + normals[f, 1] * c[1]
                                 + normals[f, 2] * c[2]))
    return r


@njit
def _circumradius(vertices, c):
    """Largest distance [m] from c to a vertex."""
    r2 = 0.0
    for v in range(vertices.shape[0]):
        dx, dy, dz = vertices[v, 0] - c[0], vertices[v, 1] - c[1], vertices[v, 2] - c[2]
        r2 = max(r2, dx * dx + dy * dy + dz * dz)
    return math.sqrt(r2)


@njit
def _best_bound_face(normals, offsets, c, r):
    """Face f of largest bound n_f . c - O_f - r on its axis value s (c, r: centre and
    inradius of the other body): the face most likely to give the largest s."""
    best_f, best_b = 0, -_HUGE
    for f in range(normals.shape[0]):
        b = normals[f, 0] * c[0] + normals[f, 1] * c[1] + normals[f, 2] * c[2] - offsets[f] - r
        if b > best_b:
            best_b, best_f = b, f
    return best_f


@njit
def _faces_reaching(proj, fstart, fverts, level, above, out):
    """Writes into ``out`` the faces with a vertex projection ``proj`` (n_v,) >= ``level``
    (``above``) or <= ``level`` (not ``above``), in increasing order; returns their number."""
    count = 0
    for f in range(fstart.shape[0] - 1):
        for k in range(fstart[f], fstart[f + 1]):
            x = proj[fverts[k]]
            if (x >= level) if above else (x <= level):
                out[count] = f
                count += 1
                break
    return count


@njit
def _project(vertices, dx, dy, dz):
    """Projections (n_v,) of the vertices on (dx, dy, dz)."""
    proj = np.empty(vertices.shape[0])
    for v in range(vertices.shape[0]):
        proj[v] = vertices[v, 0] * dx + vertices[v, 1] * dy + vertices[v, 2] * dz
    return proj


@njit(cache=True)
def signed_distance(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                    vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out):
    """Signed distance g [m] of polyhedra A and B (module docstring, steps 1-4) and the unit
    normal from A to B written in ``normal_out`` (3,); returns (g, found) with found False
    when g > alert (then g is only a lower bound and the normal is not set)."""
    prune = va.shape[0] >= 0  # True as a typed flag, not a literal: one compiled body
    return _signed_distance(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                            vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out, prune)


@njit(cache=True)
def signed_distance_exhaustive(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                               vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out):
    """:func:`signed_distance` without the pruning (every face axis evaluated, every edge
    pair of the slab given the whole arc test): the slow twin it must agree with (same g,
    normal, found)."""
    prune = va.shape[0] < 0  # False as a typed flag: the same compiled body as the pruned
    return _signed_distance(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                            vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out, prune)


@njit(cache=True)
def _signed_distance(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                     vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out, prune):
    """:func:`signed_distance`; ``prune`` skips the face axes whose bound on s is below a
    value already reached and pre-tests the Gauss-map arcs branch-free (same result)."""
    ux, uy, uz = cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]
    length = math.sqrt(ux * ux + uy * uy + uz * uz)
    if length > 0.0:
        ux, uy, uz = ux / length, uy / length, uz / length
    else:
        ux, uy, uz = 0.0, 0.0, 1.0
    _, top_a = _support(va, nsa, nba, ux, uy, uz, 0)
    _, low_b = _support(vb, nsb, nbb, -ux, -uy, -uz, 0)
    if -low_b - top_a > alert:
        return -low_b - top_a, False
    # round-off band of the separations (TOUCH_TOLERANCE): values of s within eps are equal
    eps = TOUCH_TOLERANCE * (_circumradius(va, ca) + _circumradius(vb, cb) + abs(ca[0])
                             + abs(ca[1]) + abs(ca[2]) + abs(cb[0]) + abs(cb[1]) + abs(cb[2]))
    # pruning of the face axes: s(f) <= n_f . c_B - O_f - r_B (face of A), n_g . c_A - O_g - r_A
    # (face of B), r the inradius about the centre; a face whose bound is below a value s
    # already reached can be neither the best axis nor the first one beyond the alert
    # distance. The faces of largest bound give the first value (most often the best one).
    r_a, r_b = _inradius(na, oa, ca), _inradius(nb, ob, cb)
    if not prune or r_a <= 0.0 or r_b <= 0.0:
        r_a = r_b = -_HUGE  # (a centre outside its body: no bound)
    # (tol >= eps: a face skipped is below the largest value by more than eps, so it can be
    # no tie either)
    tol = 1e-9 * (max(r_a, 0.0) + max(r_b, 0.0) + length) + 1e-12 * (
        abs(ca[0]) + abs(ca[1]) + abs(ca[2]) + abs(cb[0]) + abs(cb[1]) + abs(cb[2])) + eps
    floor = -_HUGE
    if r_a > 0.0:
        f = _best_bound_face(na, oa, cb, r_b)
        _, neg = _support(vb, nsb, nbb, -na[f, 0], -na[f, 1], -na[f, 2], 0)
        floor = -neg - oa[f]
        f = _best_bound_face(nb, ob, ca, r_a)
        _, neg = _support(va, nsa, nba, -nb[f, 0], -nb[f, 1], -nb[f, 2], 0)
        floor = max(floor, -neg - ob[f])
        if floor > alert:
            return floor, False
    n_fa = na.shape[0]
    face_s = np.full(n_fa + nb.shape[0], -_HUGE)  # s of the face axes evaluated
    top = -_HUGE  # their largest s
    # face axes of A: s = min_b n.b - O_a
    start = 0
    for f in range(n_fa):
        if na[f, 0] * cb[0] + na[f, 1] * cb[1] + na[f, 2] * cb[2] - oa[f] - r_b + tol \
                < max(floor, top):
            continue
        start, neg = _support(vb, nsb, nbb, -na[f, 0], -na[f, 1], -na[f, 2], start)
        s = -neg - oa[f]
        if s > alert:
            return s, False
        face_s[f] = s
        top = max(top, s)
    # face axes of B: the axis from A to B is -n_b; s = min_a n_b.a - O_b
    start = 0
    for f in range(nb.shape[0]):
        if nb[f, 0] * ca[0] + nb[f, 1] * ca[1] + nb[f, 2] * ca[2] - ob[f] - r_a + tol \
                < max(floor, top):
            continue
        start, neg = _support(va, nsa, nba, -nb[f, 0], -nb[f, 1], -nb[f, 2], start)
        s = -neg - ob[f]
        if s > alert:
            return s, False
        face_s[n_fa + f] = s
        top = max(top, s)
    # the face axis kept: the first within eps of the largest (a tie-break independent of the
    # frame's round-off)
    best_kind, best_f, best_g = 0, 0, -1  # 0 face of A, 1 face of B, 2 edge pair
    for k in range(face_s.shape[0]):
        if face_s[k] >= top - eps:
            best_f = k
            break
    best = face_s[best_f]
    if best_f < n_fa:
        bx, by, bz = na[best_f, 0], na[best_f, 1], na[best_f, 2]
    else:
        best_kind, best_f = 1, best_f - n_fa
        bx, by, bz = -nb[best_f, 0], -nb[best_f, 1], -nb[best_f, 2]
    # slab of the best face axis
    sx, sy, sz = bx, by, bz
    _, hi = _support(va, nsa, nba, bx, by, bz, 0)
    _, neg = _support(vb, nsb, nbb, -bx, -by, -bz, 0)
    lo = -neg
    margin = max(alert, 0.0) + 1e-12 * (abs(hi) + abs(lo))
    keep_a = np.empty(ea.shape[0], dtype=np.int64)
    n_a = 0
    for e in range(ea.shape[0]):
        p, q = va[ea[e, 0]], va[ea[e, 1]]
        if max(p[0] * bx + p[1] * by + p[2] * bz, q[0] * bx + q[1] * by + q[2] * bz) \
                >= lo - margin:
            keep_a[n_a] = e
            n_a += 1
    keep_b = np.empty(eb.shape[0], dtype=np.int64)
    n_b = 0
    for e in range(eb.shape[0]):
        p, q = vb[eb[e, 0]], vb[eb[e, 1]]
        if min(p[0] * bx + p[1] * by + p[2] * bz, q[0] * bx + q[1] * by + q[2] * bz) \
                <= hi + margin:
            keep_b[n_b] = e
            n_b += 1
    # Gauss-map arcs of B's kept edges (the normals of their faces, negated), by component,
    # for a branch-free first test of the arc crossings
    arcs = np.empty((6, n_b))
    for j in range(n_b):
        g0, g1 = efb[keep_b[j], 0], efb[keep_b[j], 1]
        for c in range(3):
            arcs[c, j] = -nb[g0, c]
            arcs[3 + c, j] = -nb[g1, c]
    crossing = np.arange(n_b)
    # edge-edge axes on faces of the Minkowski difference (scalar code); the largest s with
    # its axis and edges
    edge_best, edge_e, edge_k = -_HUGE, -1, -1
    ex, ey, ez = 0.0, 0.0, 1.0
    for i in range(n_a):
        e = keep_a[i]
        f0, f1 = efa[e, 0], efa[e, 1]
        ax_, ay_, az_ = na[f0, 0], na[f0, 1], na[f0, 2]
        bx_, by_, bz_ = na[f1, 0], na[f1, 1], na[f1, 2]
        u0, u1 = ea[e, 0], ea[e, 1]
        a0x, a0y, a0z = va[u0, 0], va[u0, 1], va[u0, 2]
        tax, tay, taz = va[u1, 0] - a0x, va[u1, 1] - a0y, va[u1, 2] - a0z
        bxa_x, bxa_y, bxa_z = _cross(bx_, by_, bz_, ax_, ay_, az_)
        arc_a = ARC_TOLERANCE * math.sqrt(bxa_x * bxa_x + bxa_y * bxa_y + bxa_z * bxa_z)
        ta2 = tax * tax + tay * tay + taz * taz
        m = n_b
        if prune:  # the B arcs whose ends lie on both sides of the plane of A's arc
            m = 0
            for j in range(n_b):
                crossing[m] = j
                m += (arcs[0, j] * bxa_x + arcs[1, j] * bxa_y + arcs[2, j] * bxa_z) * (
                    arcs[3, j] * bxa_x + arcs[4, j] * bxa_y + arcs[5, j] * bxa_z) < 0.0
        for jj in range(m):
            j = crossing[jj]
            k = keep_b[j]
            g0, g1 = efb[k, 0], efb[k, 1]
            cx_, cy_, cz_ = -nb[g0, 0], -nb[g0, 1], -nb[g0, 2]
            dx_, dy_, dz_ = -nb[g1, 0], -nb[g1, 1], -nb[g1, 2]
            cba = cx_ * bxa_x + cy_ * bxa_y + cz_ * bxa_z
            dba = dx_ * bxa_x + dy_ * bxa_y + dz_ * bxa_z
            # (strict: an end of B's arc on A's great circle is a crossing at a face normal)
            if cba * dba >= 0.0 or abs(cba) <= arc_a or abs(dba) <= arc_a:
                continue
            dxc_x, dxc_y, dxc_z = _cross(dx_, dy_, dz_, cx_, cy_, cz_)
            adc = ax_ * dxc_x + ay_ * dxc_y + az_ * dxc_z
            bdc = bx_ * dxc_x + by_ * dxc_y + bz_ * dxc_z
            if not (adc * bdc < 0.0 and cba * bdc > 0.0):
                continue
            arc_b = ARC_TOLERANCE * math.sqrt(dxc_x * dxc_x + dxc_y * dxc_y + dxc_z * dxc_z)
            if abs(adc) <= arc_b or abs(bdc) <= arc_b:
                continue
            w0, w1 = eb[k, 0], eb[k, 1]
            b0x, b0y, b0z = vb[w0, 0], vb[w0, 1], vb[w0, 2]
            tbx, tby, tbz = vb[w1, 0] - b0x, vb[w1, 1] - b0y, vb[w1, 2] - b0z
            sx_, sy_, sz_ = _cross(tax, tay, taz, tbx, tby, tbz)
            size = math.sqrt(sx_ * sx_ + sy_ * sy_ + sz_ * sz_)
            if size <= 1e-12 * math.sqrt(ta2 * (tbx * tbx + tby * tby + tbz * tbz)):
                continue
            sx_, sy_, sz_ = sx_ / size, sy_ / size, sz_ / size
            if sx_ * (a0x - ca[0]) + sy_ * (a0y - ca[1]) + sz_ * (a0z - ca[2]) < 0.0:
                sx_, sy_, sz_ = -sx_, -sy_, -sz_
            s = sx_ * (b0x - a0x) + sy_ * (b0y - a0y) + sz_ * (b0z - a0z)
            if s > edge_best:
                edge_best, ex, ey, ez = s, sx_, sy_, sz_
                edge_e, edge_k = e, k
    # an edge axis replaces the face axis only beyond the round-off band
    if edge_best > top + eps:
        best, bx, by, bz = edge_best, ex, ey, ez
        best_kind, best_f, best_g = 2, edge_e, edge_k
    if best > alert:
        return best, False
    normal_out[0], normal_out[1], normal_out[2] = bx, by, bz
    if best <= eps:  # overlap, or touching within the round-off (module docstring, step 4)
        return best, True
    # apart: the SAT value is the distance when its witness features realise it (a vertex
    # over the face, or the closest points of the two edges inside both): O(1) check
    if best_kind == 0:
        w, _ = _support(vb, nsb, nbb, -bx, -by, -bz, 0)
        if _inside_face(vb[w], va, fsa, fva, best_f, na[best_f]):
            return best, True
    elif best_kind == 1:
        w, _ = _support(va, nsa, nba, bx, by, bz, 0)
        if _inside_face(va[w], vb, fsb, fvb, best_f, nb[best_f]):
            return best, True
    elif best_kind == 2:
        lx, ly, lz = _seg_seg(va, ea[best_f, 0], ea[best_f, 1], vb, eb[best_g, 0],
                              eb[best_g, 1])
        if math.sqrt(lx * lx + ly * ly + lz * lz) <= best * (1.0 + 1e-12) + eps:
            return best, True
    # otherwise (vertex-vertex, vertex-edge): exact distance over the features near the slab;
    # a vertex within -eps of a face plane touches it (distance 0, the SAT axis kept)
    exact = _HUGE
    nx, ny, nz = bx, by, bz
    for v in range(va.shape[0]):
        a = va[v]
        if a[0] * sx + a[1] * sy + a[2] * sz < lo - margin:
            continue
        for f in range(nb.shape[0]):
            d = nb[f, 0] * a[0] + nb[f, 1] * a[1] + nb[f, 2] * a[2] - ob[f]
            if d < -eps or d >= exact:
                continue
            if _inside_face(a, vb, fsb, fvb, f, nb[f]):
                exact, nx, ny, nz = max(d, 0.0), -nb[f, 0], -nb[f, 1], -nb[f, 2]
    for v in range(vb.shape[0]):
        b = vb[v]
        if b[0] * sx + b[1] * sy + b[2] * sz > hi + margin:
            continue
        for f in range(na.shape[0]):
            d = na[f, 0] * b[0] + na[f, 1] * b[1] + na[f, 2] * b[2] - oa[f]
            if d < -eps or d >= exact:
                continue
            if _inside_face(b, va, fsa, fva, f, na[f]):
                exact, nx, ny, nz = max(d, 0.0), na[f, 0], na[f, 1], na[f, 2]
    for i in range(n_a):
        e = keep_a[i]
        for j in range(n_b):
            k = keep_b[j]
            lx, ly, lz = _seg_seg(va, ea[e, 0], ea[e, 1], vb, eb[k, 0], eb[k, 1])
            d = math.sqrt(lx * lx + ly * ly + lz * lz)
            if d < exact:
                exact = d
                if d > eps:
                    nx, ny, nz = lx / d, ly / d, lz / d
    if exact < _HUGE and exact > best * (1.0 + 1e-9) + eps:
        normal_out[0], normal_out[1], normal_out[2] = nx, ny, nz
        return exact, exact <= alert
    return best, True


# --------------------------------------------------------------------------------------------
# Spheres
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def sphere_contact(vertices, normals, offsets, fstart, fverts, edges, centre, radius,
                   normal_out, point_out):
    """Gap [m] between a polyhedron and the sphere (``centre`` (3,) [m], ``radius`` [m]),
    the unit normal from the polyhedron to the sphere in ``normal_out`` (3,) and the
    mid-point between the two surfaces in ``point_out`` (3,) [m]; returns (gap, feature id,
    type): the face (type 1) of largest signed distance when the centre is inside or
    projects inside it, else the nearest edge (type 2) or vertex (type 1)."""
    n_v, n_e = vertices.shape[0], edges.shape[0]
    best_f, best_s = 0, -_HUGE
    for f in range(normals.shape[0]):
        s = normals[f] @ centre - offsets[f]
        if s > best_s:
            best_s, best_f = s, f
    if best_s <= 0.0 or _inside_face(centre, vertices, fstart, fverts, best_f, normals[best_f]):
        distance = best_s
        normal_out[:] = normals[best_f]
        code, kind = n_v + n_e + best_f, TYPE_FV
    else:
        distance = _HUGE
        code, kind = 0, TYPE_EE
        for e in range(n_e):
            p0, p1 = vertices[edges[e, 0]], vertices[edges[e, 1]]
            d = p1 - p0
            t = min(1.0, max(0.0, (centre - p0) @ d / (d @ d)))
            link = centre - (p0 + t * d)
            dist = math.sqrt(link @ link)
            if dist < distance:
                distance = dist
                normal_out[:] = link / dist
                if t == 0.0 or t == 1.0:
                    code, kind = edges[e, 0] if t == 0.0 else edges[e, 1], TYPE_FV
                else:
                    code, kind = n_v + e, TYPE_EE
    gap = distance - radius
    surface = centre - distance * normal_out
    point_out[:] = surface + 0.5 * gap * normal_out
    return gap, code, kind
