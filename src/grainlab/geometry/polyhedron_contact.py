"""Contact geometry of convex polyhedra (seed 002): gap, normal, contact type and manifold
(Numba; no Python objects in the kernels).

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
   contact.
3. Edge axes, pruned to the slab of the best face axis n*: an edge of A enters only if one of
   its ends lies above min_B n* . b - alert, an edge of B only if one end lies below
   max_A n* . a + alert (the witness points of any axis better than n* lie there), and only
   pairs forming a face of the Minkowski difference (Gauss-map arc test) are evaluated, each
   in O(1): s = n . (b0 - a0).
4. If the best s is <= 0 it is the exact signed distance (overlap) with its axis as normal. If
   0 < s <= alert, the SAT value is a lower bound (vertex-vertex and vertex-edge closest
   pairs have no SAT axis), so the exact distance is taken as the smallest vertex-face
   (projection inside the face) or segment-segment distance over the features within the
   slab, and n = (p_B - p_A)/|p_B - p_A| unless the SAT axis already gives it.

Contact type and manifold
-------------------------
The supporting feature of A along n (of B along -n) is a FACE when a face normal lies within
the angle :data:`ANGLE_TOLERANCE` of n (of -n), else an EDGE when an edge at the support vertex
is perpendicular to n within that angle, else a VERTEX. Since only the direction of n enters,
a pair whose normal does not turn keeps its type from step to step. The manifold:

- face-face: the incident face clipped by the side planes of the reference face along n
  (Sutherland-Hodgman); reduced to 3 points (deepest point, the point farthest from it, then
  the point giving the largest triangle: research/engine_tech.md 3.2 step 6, the seed's "flat
  contact replaced by three points");
- face-edge (or two parallel edges): the edge clipped by the face's side planes -> 2 points;
- edge-edge: the closest points of the two segments -> 1 point;
- a vertex on either side (vertex-face; the rare vertex-edge and vertex-vertex counted with
  it) -> 1 point.

Each point x gets its own gap, the distance between the two features along n, and is written
at the mid-point between them; the pair's type code follows the number of points: 1 "fv",
2 "ee" (one point, both features edges), 3 "fe" (two points), 4 "ff" (three points). A clipped
manifold that degenerates (fewer points than the features suggest) takes the type of its point
count.

Feature ids (stable warm-start keys): vertex k -> k, edge e -> n_v + e, face f -> n_v + n_e + f
(local to the shape). A manifold point made by a vertex of B inside a face of A has ids (face
of A, vertex of B); a crossing of two edges (edge, edge); a vertex of A inside a face of B
(vertex, face).

Walls and spheres
-----------------
A wall is a plane (p_w, n_w) with the bodies on the side of n_w; the polyhedron's feature
supporting along -n_w gives 1 (vertex), 2 (edge) or 3 (face, reduced) points, each a vertex
with gap n_w . (v - p_w). A sphere (centre, radius r) against a polyhedron: the closest point
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

MAX_POINTS = 3
"""Largest number of points of one manifold."""

_VERTEX, _EDGE, _FACE = 0, 1, 2
_HUGE = 1e300


# --------------------------------------------------------------------------------------------
# Small scalar helpers
# --------------------------------------------------------------------------------------------


@njit(inline="always")
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


@njit(inline="always")
def _seg_seg(p0, p1, q0, q1):
    """Closest points of segments [p0, p1] and [q0, q1] (each (3,)): (s, t) parameters."""
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = d1 @ d1
    e = d2 @ d2
    f = d2 @ r
    c = d1 @ r
    b = d1 @ d2
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
    return s, t


@njit(inline="always")
def _inside_face(x, vertices, fstart, fverts, f, normal):
    """Whether the projection of x along ``normal`` falls inside face f (CCW about normal)."""
    k0, k1 = fstart[f], fstart[f + 1]
    for k in range(k0, k1):
        p = vertices[fverts[k]]
        q = vertices[fverts[k0 + (k - k0 + 1) % (k1 - k0)]]
        if np.dot(np.cross(q - p, x - p), normal) < 0.0:
            return False
    return True


@njit(inline="always")
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


@njit(cache=True)
def signed_distance(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                    vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out):
    """Signed distance g [m] of polyhedra A and B (module docstring, steps 1-4) and the unit
    normal from A to B written in ``normal_out`` (3,); returns (g, found) with found False
    when g > alert (then g is only a lower bound and the normal is not set)."""
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
    best = -_HUGE
    bx, by, bz = 0.0, 0.0, 1.0
    # face axes of A: s = min_b n.b - O_a
    start = 0
    for f in range(na.shape[0]):
        start, neg = _support(vb, nsb, nbb, -na[f, 0], -na[f, 1], -na[f, 2], start)
        s = -neg - oa[f]
        if s > best:
            best, bx, by, bz = s, na[f, 0], na[f, 1], na[f, 2]
            if s > alert:
                return s, False
    # face axes of B: the axis from A to B is -n_b; s = min_a n_b.a - O_b
    start = 0
    for f in range(nb.shape[0]):
        start, neg = _support(va, nsa, nba, -nb[f, 0], -nb[f, 1], -nb[f, 2], start)
        s = -neg - ob[f]
        if s > best:
            best, bx, by, bz = s, -nb[f, 0], -nb[f, 1], -nb[f, 2]
            if s > alert:
                return s, False
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
    # edge-edge axes on faces of the Minkowski difference
    for i in range(n_a):
        e = keep_a[i]
        a_n = na[efa[e, 0]]
        b_n = na[efa[e, 1]]
        a0 = va[ea[e, 0]]
        ta = va[ea[e, 1]] - a0
        bxa = np.cross(b_n, a_n)
        for j in range(n_b):
            k = keep_b[j]
            c_n = -nb[efb[k, 0]]
            d_n = -nb[efb[k, 1]]
            dxc = np.cross(d_n, c_n)
            cba = c_n @ bxa
            dba = d_n @ bxa
            adc = a_n @ dxc
            bdc = b_n @ dxc
            if not (cba * dba < 0.0 and adc * bdc < 0.0 and cba * bdc > 0.0):
                continue
            b0 = vb[eb[k, 0]]
            tb = vb[eb[k, 1]] - b0
            axis = np.cross(ta, tb)
            size = math.sqrt(axis @ axis)
            if size <= 1e-12 * math.sqrt((ta @ ta) * (tb @ tb)):
                continue
            axis = axis / size
            if axis @ (a0 - ca) < 0.0:
                axis = -axis
            s = axis @ (b0 - a0)
            if s > best:
                best, bx, by, bz = s, axis[0], axis[1], axis[2]
    if best > alert:
        return best, False
    normal_out[0], normal_out[1], normal_out[2] = bx, by, bz
    if best <= 0.0:
        return best, True
    # apart: exact distance over the features near the slab
    exact = _HUGE
    nx, ny, nz = bx, by, bz
    for v in range(va.shape[0]):
        a = va[v]
        if a[0] * sx + a[1] * sy + a[2] * sz < lo - margin:
            continue
        for f in range(nb.shape[0]):
            d = nb[f] @ a - ob[f]
            if d < 0.0 or d >= exact:
                continue
            if _inside_face(a, vb, fsb, fvb, f, nb[f]):
                exact, nx, ny, nz = d, -nb[f, 0], -nb[f, 1], -nb[f, 2]
    for v in range(vb.shape[0]):
        b = vb[v]
        if b[0] * sx + b[1] * sy + b[2] * sz > hi + margin:
            continue
        for f in range(na.shape[0]):
            d = na[f] @ b - oa[f]
            if d < 0.0 or d >= exact:
                continue
            if _inside_face(b, va, fsa, fva, f, na[f]):
                exact, nx, ny, nz = d, na[f, 0], na[f, 1], na[f, 2]
    for i in range(n_a):
        e = keep_a[i]
        p0, p1 = va[ea[e, 0]], va[ea[e, 1]]
        for j in range(n_b):
            k = keep_b[j]
            q0, q1 = vb[eb[k, 0]], vb[eb[k, 1]]
            s, t = _seg_seg(p0, p1, q0, q1)
            link = (q0 + t * (q1 - q0)) - (p0 + s * (p1 - p0))
            d = math.sqrt(link @ link)
            if d < exact and d > 0.0:
                exact = d
                nx, ny, nz = link[0] / d, link[1] / d, link[2] / d
    if exact < _HUGE and exact > best * (1.0 + 1e-9) + 1e-15:
        normal_out[0], normal_out[1], normal_out[2] = nx, ny, nz
        return exact, exact <= alert
    return best, True


# --------------------------------------------------------------------------------------------
# Manifold
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def _reduce_to_three(points, gaps, count, tol):
    """Indices (3,) of at most three of ``count`` points: the deepest (lowest index within
    ``tol``), the farthest from it, the one giving the largest triangle; returns (idx, n)."""
    idx = np.empty(3, dtype=np.int64)
    first = 0
    for k in range(1, count):
        if gaps[k] < gaps[first] - tol:
            first = k
    idx[0] = first
    if count == 1:
        return idx, 1
    far, far_d = -1, -1.0
    for k in range(count):
        d = points[k] - points[first]
        dd = d @ d
        if dd > far_d + tol * tol:
            far, far_d = k, dd
    if far_d <= tol * tol:
        return idx, 1
    idx[1] = far
    if count == 2:
        return idx, 2
    third, area = -1, 0.0
    base = points[far] - points[first]
    for k in range(count):
        c = np.cross(base, points[k] - points[first])
        a = math.sqrt(c @ c)
        if a > area + tol * math.sqrt(far_d):
            third, area = k, a
    if third < 0:
        return idx, 2
    idx[2] = third
    return idx, 3


@njit(inline="always")
def _clip_polygon(poly, count, vertices, fstart, fverts, f, normal, scratch):
    """Clip ``poly`` rows 0 .. count-1 by the side planes of face f (containing ``normal``);
    the result is in ``poly`` (scratch of the same size); returns the new count."""
    k0, k1 = fstart[f], fstart[f + 1]
    m = k1 - k0
    for k in range(m):
        p = vertices[fverts[k0 + k]]
        q = vertices[fverts[k0 + (k + 1) % m]]
        side = np.cross(q - p, normal)
        n_out = 0
        for i in range(count):
            x = poly[i]
            y = poly[(i + 1) % count]
            dx = side @ (x - p)
            dy = side @ (y - p)
            if dx <= 0.0:
                scratch[n_out] = x
                n_out += 1
            if (dx <= 0.0) != (dy <= 0.0):
                scratch[n_out] = x + (dx / (dx - dy)) * (y - x)
                n_out += 1
        for i in range(n_out):
            poly[i] = scratch[i]
        count = n_out
        if count == 0:
            return 0
    return count


@njit(inline="always")
def _tag_point(x, n, va, fsa, fva, fa, ea, nva, nea, vb, fsb, fvb, fb, eb, nvb, neb, tol):
    """Feature ids (A, B) of a face-face manifold point x (module docstring)."""
    best_i, best_di = -1, _HUGE
    k0, k1 = fsb[fb], fsb[fb + 1]
    for k in range(k0, k1):
        d = x - vb[fvb[k]]
        d = d - (d @ n) * n
        dd = d @ d
        if dd < best_di:
            best_di, best_i = dd, fvb[k]
    if best_di <= tol * tol:
        return nva + nea + fa, best_i
    j0, j1 = fsa[fa], fsa[fa + 1]
    best_j, best_dj = -1, _HUGE
    for k in range(j0, j1):
        d = x - va[fva[k]]
        d = d - (d @ n) * n
        dd = d @ d
        if dd < best_dj:
            best_dj, best_j = dd, fva[k]
    if best_dj <= tol * tol:
        return best_j, nvb + neb + fb
    return nva + _nearest_side(x, n, va, fsa, fva, fa, ea), \
        nvb + _nearest_side(x, n, vb, fsb, fvb, fb, eb)


@njit(inline="always")
def _nearest_side(x, n, vertices, fstart, fverts, f, edges):
    """Edge id of the side of face f nearest to x (distance in the plane normal to n)."""
    k0, k1 = fstart[f], fstart[f + 1]
    m = k1 - k0
    best, best_d = 0, _HUGE
    for k in range(m):
        u, v = fverts[k0 + k], fverts[k0 + (k + 1) % m]
        side = np.cross(vertices[v] - vertices[u], n)
        d = abs(side @ (x - vertices[u])) / math.sqrt(side @ side)
        if d < best_d:
            best_d, best = d, _find_edge(edges, u, v)
    return best


@njit(cache=True)
def pair_manifold(va, na, oa, fsa, fva, ea, nsa, nba,
                  vb, nb, ob, fsb, fvb, eb, nsb, nbb,
                  g, normal, cos_tol, sin_tol, points, gaps, ids_a, ids_b):
    """Contact manifold of polyhedra A and B at signed distance ``g`` [m] along ``normal``
    (3,) from A to B (module docstring): writes ``points`` (3, 3) [m] (mid-points), ``gaps``
    (3,) [m] and feature ids ``ids_a``, ``ids_b`` (3,); returns (count, type code)."""
    nx, ny, nz = normal[0], normal[1], normal[2]
    nva, nea = va.shape[0], ea.shape[0]
    nvb, neb = vb.shape[0], eb.shape[0]
    kind_a, fa, _ = supporting_feature(va, na, nsa, nba, ea, nx, ny, nz, cos_tol, sin_tol)
    kind_b, fb, top_b = supporting_feature(vb, nb, nsb, nbb, eb, -nx, -ny, -nz, cos_tol,
                                           sin_tol)
    size = 0.0
    for v in range(nva):
        size = max(size, abs(va[v, 0] - va[0, 0]) + abs(va[v, 1] - va[0, 1])
                   + abs(va[v, 2] - va[0, 2]))
    tol = 1e-9 * size
    if kind_a == _FACE and (kind_b == _FACE or kind_b == _EDGE):
        if kind_b == _FACE:
            m = fsb[fb + 1] - fsb[fb]
            cap = m + (fsa[fa + 1] - fsa[fa]) + 2
            poly = np.empty((cap, 3))
            scratch = np.empty((cap, 3))
            for k in range(m):
                poly[k] = vb[fvb[fsb[fb] + k]]
            count = _clip_polygon(poly, m, va, fsa, fva, fa, na[fa], scratch)
        else:
            poly = np.empty((2, 3))
            poly[0] = vb[eb[fb, 0]]
            poly[1] = vb[eb[fb, 1]]
            count = _clip_segment(poly, va, fsa, fva, fa, na[fa])
        if count > 0:
            cos_n = na[fa] @ normal
            local = np.empty(count)
            for k in range(count):
                local[k] = (na[fa] @ poly[k] - oa[fa]) / cos_n
            idx, kept = _reduce_to_three(poly, local, count, tol)
            for r in range(kept):
                x = poly[idx[r]]
                gaps[r] = local[idx[r]]
                points[r] = x - 0.5 * gaps[r] * normal
                if kind_b == _FACE:
                    ids_a[r], ids_b[r] = _tag_point(x, normal, va, fsa, fva, fa, ea, nva, nea,
                                                    vb, fsb, fvb, fb, eb, nvb, neb,
                                                    max(tol, 1e-7 * size))
                else:
                    ids_a[r], ids_b[r] = _tag_segment_end(x, vb, eb, fb, nvb, va, fsa, fva,
                                                          fa, ea, normal, nva, nea,
                                                          max(tol, 1e-7 * size))
            return kept, _type_of(kept, kind_a, kind_b)
    elif kind_b == _FACE and kind_a == _EDGE:
        poly = np.empty((2, 3))
        poly[0] = va[ea[fa, 0]]
        poly[1] = va[ea[fa, 1]]
        count = _clip_segment(poly, vb, fsb, fvb, fb, nb[fb])
        if count > 0:
            cos_n = -(nb[fb] @ normal)
            local = np.empty(count)
            for k in range(count):
                local[k] = (nb[fb] @ poly[k] - ob[fb]) / cos_n
            idx, kept = _reduce_to_three(poly, local, count, tol)
            for r in range(kept):
                x = poly[idx[r]]
                gaps[r] = local[idx[r]]
                points[r] = x + 0.5 * gaps[r] * normal
                ids_b[r], ids_a[r] = _tag_segment_end(x, va, ea, fa, nva, vb, fsb, fvb, fb,
                                                      eb, normal, nvb, neb,
                                                      max(tol, 1e-7 * size))
            return kept, _type_of(kept, kind_a, kind_b)
    elif kind_a == _EDGE and kind_b == _EDGE:
        p0, p1 = va[ea[fa, 0]], va[ea[fa, 1]]
        q0, q1 = vb[eb[fb, 0]], vb[eb[fb, 1]]
        ta, tb = p1 - p0, q1 - q0
        cross = np.cross(ta, tb)
        if cross @ cross > (sin_tol * sin_tol) * (ta @ ta) * (tb @ tb):
            s, t = _seg_seg(p0, p1, q0, q1)
            pa = p0 + s * ta
            pb = q0 + t * tb
            points[0] = 0.5 * (pa + pb)
            gaps[0] = g
            ids_a[0], ids_b[0] = nva + fa, nvb + fb
            return 1, TYPE_EE
        # parallel edges: the overlap of their extents along the edge, two points
        length2 = ta @ ta
        s0 = (q0 - p0) @ ta / length2
        s1 = (q1 - p0) @ ta / length2
        lo_s, hi_s = max(0.0, min(s0, s1)), min(1.0, max(s0, s1))
        if hi_s > lo_s:
            for r in range(2):
                s = lo_s if r == 0 else hi_s
                x = p0 + s * ta
                points[r] = x + 0.5 * g * normal
                gaps[r] = g
                if s == 0.0 or s == 1.0:
                    ids_a[r] = ea[fa, 0] if s == 0.0 else ea[fa, 1]
                    ids_b[r] = nvb + fb
                else:
                    ids_a[r] = nva + fa
                    ids_b[r] = eb[fb, 0] if s == s0 else eb[fb, 1]
            return 2, TYPE_FE
    # one point: a vertex on one side (or a degenerate manifold)
    gaps[0] = g
    if kind_a == _VERTEX:
        points[0] = va[fa] + 0.5 * g * normal
        ids_a[0] = fa
        ids_b[0] = _code(kind_b, fb, nvb, neb)
    elif kind_b == _VERTEX:
        points[0] = vb[fb] - 0.5 * g * normal
        ids_a[0] = _code(kind_a, fa, nva, nea)
        ids_b[0] = fb
    else:
        points[0] = vb[top_b] - 0.5 * g * normal
        ids_a[0] = _code(kind_a, fa, nva, nea)
        ids_b[0] = top_b
    return 1, TYPE_FV


@njit(inline="always")
def _code(kind, index, n_vertices, n_edges):
    if kind == _VERTEX:
        return index
    if kind == _EDGE:
        return n_vertices + index
    return n_vertices + n_edges + index


@njit(inline="always")
def _type_of(count, kind_a, kind_b):
    if count >= 3:
        return TYPE_FF
    if count == 2:
        return TYPE_FE
    if kind_a == _EDGE and kind_b == _EDGE:
        return TYPE_EE
    return TYPE_FV


@njit(inline="always")
def _clip_segment(seg, vertices, fstart, fverts, f, normal):
    """Clip the segment seg[0] - seg[1] by the side planes of face f; returns 0 or 2."""
    k0, k1 = fstart[f], fstart[f + 1]
    m = k1 - k0
    lo, hi = 0.0, 1.0
    x0 = seg[0].copy()
    d = seg[1] - seg[0]
    for k in range(m):
        p = vertices[fverts[k0 + k]]
        q = vertices[fverts[k0 + (k + 1) % m]]
        side = np.cross(q - p, normal)
        a = side @ (x0 - p)
        b = side @ d
        if abs(b) < 1e-300:
            if a > 0.0:
                return 0
            continue
        t = -a / b
        if b > 0.0:
            hi = min(hi, t)
        else:
            lo = max(lo, t)
        if lo > hi:
            return 0
    seg[0] = x0 + lo * d
    seg[1] = x0 + hi * d
    if hi - lo <= 1e-12:
        return 1
    return 2


@njit(inline="always")
def _tag_segment_end(x, v_edge, e_edge, edge, nv_edge, v_face, fs_face, fv_face, face,
                     e_face, normal, nv_face, ne_face, tol):
    """Feature ids (face side, edge side) of an end x of a clipped edge: an end of the edge
    itself -> (face, vertex); a cut by a side -> (side edge, edge)."""
    for end in range(2):
        d = x - v_edge[e_edge[edge, end]]
        if d @ d <= tol * tol:
            return nv_face + ne_face + face, e_edge[edge, end]
    return nv_face + _nearest_side(x, normal, v_face, fs_face, fv_face, face, e_face), \
        nv_edge + edge


# --------------------------------------------------------------------------------------------
# Walls and spheres
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def wall_manifold(vertices, normals, fstart, fverts, edges, nstart, nbrs, wall_point,
                  wall_normal, alert, cos_tol, sin_tol, points, gaps, ids):
    """Contact of a polyhedron with the plane wall (``wall_point`` (3,) [m], unit
    ``wall_normal`` (3,) towards the polyhedron): points (3, 3) [m], gaps (3,) [m] and vertex
    ids (3,) of the supporting feature along -n_w (module docstring); returns (count, type),
    count 0 when the nearest vertex is farther than ``alert``."""
    mx, my, mz = wall_normal[0], wall_normal[1], wall_normal[2]
    kind, index, top = supporting_feature(vertices, normals, nstart, nbrs, edges, -mx, -my,
                                          -mz, cos_tol, sin_tol)
    g_top = (vertices[top] - wall_point) @ wall_normal
    if g_top > alert:
        return 0, TYPE_NONE
    if kind == _VERTEX:
        gaps[0] = g_top
        points[0] = vertices[top] - 0.5 * g_top * wall_normal
        ids[0] = top
        return 1, TYPE_FV
    if kind == _EDGE:
        count = 2
        cand = np.empty((2, 3))
        local = np.empty(2)
        which = np.empty(2, dtype=np.int64)
        for r in range(2):
            which[r] = edges[index, r]
    else:
        count = fstart[index + 1] - fstart[index]
        cand = np.empty((count, 3))
        local = np.empty(count)
        which = np.empty(count, dtype=np.int64)
        for r in range(count):
            which[r] = fverts[fstart[index] + r]
    size = 0.0
    for r in range(count):
        cand[r] = vertices[which[r]]
        local[r] = (cand[r] - wall_point) @ wall_normal
        size = max(size, abs(cand[r, 0] - cand[0, 0]) + abs(cand[r, 1] - cand[0, 1])
                   + abs(cand[r, 2] - cand[0, 2]))
    idx, kept = _reduce_to_three(cand, local, count, 1e-9 * size)
    for r in range(kept):
        gaps[r] = local[idx[r]]
        points[r] = cand[idx[r]] - 0.5 * gaps[r] * wall_normal
        ids[r] = which[idx[r]]
    return kept, _type_of(kept, kind, _FACE)


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
