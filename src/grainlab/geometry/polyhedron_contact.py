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
is perpendicular to n within that angle, else a VERTEX. The pair's type follows: face-face ff,
face-edge (or two parallel edges) fe, edge-edge ee, any vertex fv (the rare vertex-edge and
vertex-vertex counted with fv). Since only the direction of n enters, a pair whose normal does
not turn keeps its type from step to step.

The manifold is the "shadow overlap" of the near-plane parts of both bodies
(research/engine_tech.md 3.1-3.2): the candidates are

- the vertices of B's cap (n . b within the alert distance of B's lowest point) whose line
  along -n enters A, at the entry point of A's upper surface;
- the vertices of A's cap whose line along +n enters B;
- the crossings, seen along n, of A's and B's cap edges that face each other (an edge of A
  bordering a face with n_f . n > 0, of B with n_f . n < 0),

each with its own gap (distance along n between the two surfaces there), written at the
mid-point, and kept if the gap is within the alert distance. They are reduced to the deepest,
the one farthest from it, the one giving the largest triangle (seed 002: a flat contact is
"replaced by three points", an edge-face contact by two; the engine's default) or, with
``max_points`` = 4 (LMGC90 keeps up to 4), also the one adding the largest area outside that
triangle. A vertex-face or edge-edge contact alone gives 1 point, an edge on a face 2, two
faces 3; more points appear only when other features lie within the alert distance, so that
the solver also holds them (one point per ee/fv pair let bodies rotate into each other about
it). Measured trade-off: with 3 points a cube tipping onto the floor drove the corner left
out 0.43 mm (0.9 % of its inradius) into it in one step; with 4 the four coplanar corners
of a cube at rest on the floor (hyperstatic, mu 0.5) kept NLGS from converging to 1e-6 in
1000 sweeps.

Feature ids (stable warm-start keys): vertex k -> k, edge e -> n_v + e, face f -> n_v + n_e + f
(local to the shape). A manifold point made by a vertex of B inside a face of A has ids (face
of A, vertex of B); a crossing of two edges (edge, edge); a vertex of A inside a face of B
(vertex, face).

Walls and spheres
-----------------
A wall is a plane (p_w, n_w) with the bodies on the side of n_w: the vertices with gap
n_w . (v - p_w) within the alert distance, reduced to three as above; the type is that of the
polyhedron's feature supporting it along -n_w (vertex fv, edge fe, face ff).
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

MAX_POINTS = 4
"""Largest number of points of one manifold (the ``max_points`` argument: 3 or 4)."""

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
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit(inline="always")
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


@njit(inline="always")
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


@njit(inline="always")
def _inradius(normals, offsets, c):
    """Distance [m] from c to the nearest face plane, min_f (O_f - n_f . c) (> 0 when c is
    inside); every unit n then has min_x n . x <= n . c - r over the body."""
    r = _HUGE
    for f in range(normals.shape[0]):
        r = min(r, offsets[f] - (normals[f, 0] * c[0] + normals[f, 1] * c[1]
                                 + normals[f, 2] * c[2]))
    return r


@njit(inline="always")
def _best_bound_face(normals, offsets, c, r):
    """Face f of largest bound n_f . c - O_f - r on its axis value s (the face most likely
    to give the largest s) and that bound."""
    best_f, best_b = 0, -_HUGE
    for f in range(normals.shape[0]):
        b = normals[f, 0] * c[0] + normals[f, 1] * c[1] + normals[f, 2] * c[2] - offsets[f] - r
        if b > best_b:
            best_b, best_f = b, f
    return best_f


@njit(inline="always")
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


@njit(inline="always")
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
    return _signed_distance(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                            vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out, True)


@njit(cache=True)
def signed_distance_exhaustive(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                               vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out):
    """:func:`signed_distance` without the pruning (every face axis evaluated, every face in
    the exact distance): the slow twin it must agree with (same g, normal, found)."""
    return _signed_distance(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                            vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out, False)


@njit(cache=True)
def _signed_distance(va, na, oa, fsa, fva, ea, efa, nsa, nba, ca,
                     vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb, cb, alert, normal_out, prune):
    """:func:`signed_distance`; ``prune`` skips the face axes whose bound on s is below a
    value already reached and, apart, the faces out of the slab (same result)."""
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
    best_kind, best_f, best_g = -1, -1, -1  # 0 face of A, 1 face of B, 2 edge pair
    bx, by, bz = 0.0, 0.0, 1.0
    # pruning of the face axes: s(f) <= n_f . c_B - O_f - r_B (face of A), n_g . c_A - O_g - r_A
    # (face of B), r the inradius about the centre; a face whose bound is below a value s
    # already reached can be neither the best axis nor the first one beyond the alert
    # distance. The faces of largest bound give the first value (most often the best one).
    r_a, r_b = _inradius(na, oa, ca), _inradius(nb, ob, cb)
    if not prune or r_a <= 0.0 or r_b <= 0.0:
        r_a = r_b = -_HUGE  # (a centre outside its body: no bound)
    tol = 1e-9 * (max(r_a, 0.0) + max(r_b, 0.0) + length) + 1e-12 * (
        abs(ca[0]) + abs(ca[1]) + abs(ca[2]) + abs(cb[0]) + abs(cb[1]) + abs(cb[2]))
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
    # face axes of A: s = min_b n.b - O_a
    start = 0
    for f in range(na.shape[0]):
        if na[f, 0] * cb[0] + na[f, 1] * cb[1] + na[f, 2] * cb[2] - oa[f] - r_b + tol \
                < max(floor, best):
            continue
        start, neg = _support(vb, nsb, nbb, -na[f, 0], -na[f, 1], -na[f, 2], start)
        s = -neg - oa[f]
        if s > best:
            best, bx, by, bz = s, na[f, 0], na[f, 1], na[f, 2]
            best_kind, best_f = 0, f
            if s > alert:
                return s, False
    # face axes of B: the axis from A to B is -n_b; s = min_a n_b.a - O_b
    start = 0
    for f in range(nb.shape[0]):
        if nb[f, 0] * ca[0] + nb[f, 1] * ca[1] + nb[f, 2] * ca[2] - ob[f] - r_a + tol \
                < max(floor, best):
            continue
        start, neg = _support(va, nsa, nba, -nb[f, 0], -nb[f, 1], -nb[f, 2], start)
        s = -neg - ob[f]
        if s > best:
            best, bx, by, bz = s, -nb[f, 0], -nb[f, 1], -nb[f, 2]
            best_kind, best_f = 1, f
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
    # Gauss-map arcs of B's kept edges (the normals of their faces, negated), by component,
    # for a branch-free first test of the arc crossings
    arcs = np.empty((6, n_b))
    for j in range(n_b):
        g0, g1 = efb[keep_b[j], 0], efb[keep_b[j], 1]
        for c in range(3):
            arcs[c, j] = -nb[g0, c]
            arcs[3 + c, j] = -nb[g1, c]
    crossing = np.arange(n_b)
    # edge-edge axes on faces of the Minkowski difference (scalar code)
    for i in range(n_a):
        e = keep_a[i]
        f0, f1 = efa[e, 0], efa[e, 1]
        ax_, ay_, az_ = na[f0, 0], na[f0, 1], na[f0, 2]
        bx_, by_, bz_ = na[f1, 0], na[f1, 1], na[f1, 2]
        u0, u1 = ea[e, 0], ea[e, 1]
        a0x, a0y, a0z = va[u0, 0], va[u0, 1], va[u0, 2]
        tax, tay, taz = va[u1, 0] - a0x, va[u1, 1] - a0y, va[u1, 2] - a0z
        bxa_x, bxa_y, bxa_z = _cross(bx_, by_, bz_, ax_, ay_, az_)
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
            if cba * dba >= 0.0:
                continue
            dxc_x, dxc_y, dxc_z = _cross(dx_, dy_, dz_, cx_, cy_, cz_)
            adc = ax_ * dxc_x + ay_ * dxc_y + az_ * dxc_z
            bdc = bx_ * dxc_x + by_ * dxc_y + bz_ * dxc_z
            if not (adc * bdc < 0.0 and cba * bdc > 0.0):
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
            if s > best:
                best, bx, by, bz = s, sx_, sy_, sz_
                best_kind, best_f, best_g = 2, e, k
    if best > alert:
        return best, False
    normal_out[0], normal_out[1], normal_out[2] = bx, by, bz
    if best <= 0.0:
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
        if math.sqrt(lx * lx + ly * ly + lz * lz) <= best * (1.0 + 1e-12) + 1e-300:
            return best, True
    # otherwise (vertex-vertex, vertex-edge): exact distance over the features near the slab
    exact = _HUGE
    nx, ny, nz = bx, by, bz
    for v in range(va.shape[0]):
        a = va[v]
        if a[0] * sx + a[1] * sy + a[2] * sz < lo - margin:
            continue
        for f in range(nb.shape[0]):
            d = nb[f, 0] * a[0] + nb[f, 1] * a[1] + nb[f, 2] * a[2] - ob[f]
            if d < 0.0 or d >= exact:
                continue
            if _inside_face(a, vb, fsb, fvb, f, nb[f]):
                exact, nx, ny, nz = d, -nb[f, 0], -nb[f, 1], -nb[f, 2]
    for v in range(vb.shape[0]):
        b = vb[v]
        if b[0] * sx + b[1] * sy + b[2] * sz > hi + margin:
            continue
        for f in range(na.shape[0]):
            d = na[f, 0] * b[0] + na[f, 1] * b[1] + na[f, 2] * b[2] - oa[f]
            if d < 0.0 or d >= exact:
                continue
            if _inside_face(b, va, fsa, fva, f, na[f]):
                exact, nx, ny, nz = d, na[f, 0], na[f, 1], na[f, 2]
    for i in range(n_a):
        e = keep_a[i]
        for j in range(n_b):
            k = keep_b[j]
            lx, ly, lz = _seg_seg(va, ea[e, 0], ea[e, 1], vb, eb[k, 0], eb[k, 1])
            d = math.sqrt(lx * lx + ly * ly + lz * lz)
            if d < exact and d > 0.0:
                exact = d
                nx, ny, nz = lx / d, ly / d, lz / d
    if exact < _HUGE and exact > best * (1.0 + 1e-9) + 1e-15:
        normal_out[0], normal_out[1], normal_out[2] = nx, ny, nz
        return exact, exact <= alert
    return best, True


# --------------------------------------------------------------------------------------------
# Manifold
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def _reduce(points, gaps, count, tol, max_points):
    """Indices (4,) of at most ``max_points`` (3 or 4) of ``count`` points: the deepest
    (lowest index within ``tol``), the farthest from it, the one giving the largest triangle,
    then the one adding the largest area outside that triangle; returns (idx, n) (scalar
    code: no allocation per point)."""
    idx = np.empty(4, dtype=np.int64)
    first = 0
    for k in range(1, count):
        if gaps[k] < gaps[first] - tol:
            first = k
    idx[0] = first
    if count == 1:
        return idx, 1
    ox, oy, oz = points[first, 0], points[first, 1], points[first, 2]
    far, far_d = -1, -1.0
    for k in range(count):
        dx, dy, dz = points[k, 0] - ox, points[k, 1] - oy, points[k, 2] - oz
        dd = dx * dx + dy * dy + dz * dz
        if dd > far_d + tol * tol:
            far, far_d = k, dd
    if far_d <= tol * tol:
        return idx, 1
    idx[1] = far
    if count == 2:
        return idx, 2
    third, area = -1, 0.0
    bx, by, bz = points[far, 0] - ox, points[far, 1] - oy, points[far, 2] - oz
    for k in range(count):
        cx, cy, cz = _cross(bx, by, bz, points[k, 0] - ox, points[k, 1] - oy, points[k, 2] - oz)
        a = math.sqrt(cx * cx + cy * cy + cz * cz)
        if a > area + tol * math.sqrt(far_d):
            third, area = k, a
    if third < 0:
        return idx, 2
    idx[2] = third
    if count == 3 or max_points < 4:
        return idx, 3
    ax, ay, az = _cross(bx, by, bz, points[third, 0] - ox, points[third, 1] - oy,
                        points[third, 2] - oz)
    size = math.sqrt(ax * ax + ay * ay + az * az)
    ax, ay, az = ax / size, ay / size, az / size
    fourth, gain = -1, tol * math.sqrt(far_d)
    for k in range(count):
        added = 0.0
        for e in range(3):
            i, j = idx[e], idx[(e + 1) % 3]
            # outward side of edge (p_i, p_j) of the counter-clockwise triangle about the axis
            cx, cy, cz = _cross(points[j, 0] - points[i, 0], points[j, 1] - points[i, 1],
                                points[j, 2] - points[i, 2], points[k, 0] - points[i, 0],
                                points[k, 1] - points[i, 1], points[k, 2] - points[i, 2])
            c = cx * ax + cy * ay + cz * az
            if c < 0.0:
                added += -c
        if added > gain:
            fourth, gain = k, added
    if fourth < 0:
        return idx, 3
    idx[3] = fourth
    return idx, 4


@njit(inline="always")
def _line_entry(x, dx, dy, dz, normals, offsets, faces, n_faces):
    """Entry parameter t >= -inf of the line x + t d into the polyhedron (half-spaces
    n . y <= O of the faces ``faces[:n_faces]``) and the face it enters through;
    (t_in, face, hit)."""
    t_in, t_out, face = -_HUGE, _HUGE, -1
    for i in range(n_faces):
        f = faces[i]
        c = normals[f, 0] * dx + normals[f, 1] * dy + normals[f, 2] * dz
        r = offsets[f] - (normals[f, 0] * x[0] + normals[f, 1] * x[1] + normals[f, 2] * x[2])
        if c < -1e-15:
            t = r / c
            if t > t_in:
                t_in, face = t, f
        elif c > 1e-15:
            t_out = min(t_out, r / c)
        elif r < 0.0:
            return 0.0, -1, False
    return t_in, face, face >= 0 and t_in <= t_out + 1e-12 * (abs(t_in) + 1.0)


@njit(inline="always")
def _edge_boxes(vertices, edges, kept, n_kept, proj, nx, ny, nz, upper, grow, boxes):
    """Columns (min, max) along t1, (min, max) along t2 (t1, t2, n orthonormal), widened by
    ``grow``, and the highest (``upper``) or lowest end along n of the edges
    ``kept[:n_kept]``, written in the rows of ``boxes`` (5, n_kept)."""
    if abs(nx) < 0.6:
        t1x, t1y, t1z = _cross(nx, ny, nz, 1.0, 0.0, 0.0)
    else:
        t1x, t1y, t1z = _cross(nx, ny, nz, 0.0, 1.0, 0.0)
    size = math.sqrt(t1x * t1x + t1y * t1y + t1z * t1z)
    t1x, t1y, t1z = t1x / size, t1y / size, t1z / size
    t2x, t2y, t2z = _cross(nx, ny, nz, t1x, t1y, t1z)
    for i in range(n_kept):
        p, q = edges[kept[i], 0], edges[kept[i], 1]
        a1 = vertices[p, 0] * t1x + vertices[p, 1] * t1y + vertices[p, 2] * t1z
        b1 = vertices[q, 0] * t1x + vertices[q, 1] * t1y + vertices[q, 2] * t1z
        a2 = vertices[p, 0] * t2x + vertices[p, 1] * t2y + vertices[p, 2] * t2z
        b2 = vertices[q, 0] * t2x + vertices[q, 1] * t2y + vertices[q, 2] * t2z
        boxes[0, i], boxes[1, i] = min(a1, b1) - grow, max(a1, b1) + grow
        boxes[2, i], boxes[3, i] = min(a2, b2) - grow, max(a2, b2) + grow
        boxes[4, i] = max(proj[p], proj[q]) if upper else min(proj[p], proj[q])


@njit(inline="always")
def _near_edges(box_a, i, box_b, n_b, reach, out):
    """Writes into ``out`` the edges j of B (increasing) whose box (``box_b``, widened)
    overlaps that of edge i of A and whose lowest end is within ``reach`` above the highest
    end of edge i along n (the others cannot give a kept crossing); returns their number
    (branch-free loop)."""
    lo1, hi1, lo2, hi2 = box_a[0, i], box_a[1, i], box_a[2, i], box_a[3, i]
    top = box_a[4, i] + reach
    m = 0
    for j in range(n_b):
        out[m] = j
        m += (lo1 <= box_b[1, j]) & (box_b[0, j] <= hi1) & (lo2 <= box_b[3, j]) \
            & (box_b[2, j] <= hi2) & (box_b[4, j] <= top)
    return m


@njit(inline="always")
def _upper_edge(normals, edge_faces, e, dx, dy, dz):
    """Whether edge e borders a face whose normal has a positive component along d."""
    for k in range(2):
        f = edge_faces[e, k]
        if normals[f, 0] * dx + normals[f, 1] * dy + normals[f, 2] * dz > 0.0:
            return True
    return False


@njit(cache=True)
def pair_manifold(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                  vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                  g, normal, alert, cos_tol, sin_tol, max_points, points, gaps, ids_a, ids_b):
    """Contact manifold of polyhedra A and B at signed distance ``g`` [m] along ``normal``
    (3,) from A to B (module docstring): writes ``points`` (4, 3) [m] (mid-points), ``gaps``
    (4,) [m] and feature ids ``ids_a``, ``ids_b`` (4,); returns (count, type code)."""
    return _pair_manifold(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                          vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                          g, normal, alert, cos_tol, sin_tol, max_points, points, gaps, ids_a,
                          ids_b, True)


@njit(cache=True)
def pair_manifold_exhaustive(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                             vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                             g, normal, alert, cos_tol, sin_tol, max_points, points, gaps, ids_a,
                             ids_b):
    """:func:`pair_manifold` with every face of the other body in the line entries: the slow
    twin it must agree with (same points, gaps, ids and type)."""
    return _pair_manifold(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                          vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                          g, normal, alert, cos_tol, sin_tol, max_points, points, gaps, ids_a,
                          ids_b, False)


@njit(cache=True)
def _pair_manifold(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                   vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                   g, normal, alert, cos_tol, sin_tol, max_points, points, gaps, ids_a, ids_b,
                   prune):
    """Contact manifold of polyhedra A and B at signed distance ``g`` [m] along ``normal``
    (3,) from A to B (module docstring): writes ``points`` (4, 3) [m] (mid-points), ``gaps``
    (4,) [m] and feature ids ``ids_a``, ``ids_b`` (4,); returns (count, type code).

    Candidates, each with its own gap along n: the vertices of B's cap (n . b within alert of
    B's lowest) over A's upper surface, the vertices of A's cap under B's lower surface, and
    the crossings, seen along n, of the cap edges of A and B that face each other; those with
    gap <= max(alert, g) are reduced to ``max_points`` (3 or 4)."""
    nx, ny, nz = normal[0], normal[1], normal[2]
    nva, nea = va.shape[0], ea.shape[0]
    nvb, neb = vb.shape[0], eb.shape[0]
    kind_a, fa, _ = supporting_feature(va, na, nsa, nba, ea, nx, ny, nz, cos_tol, sin_tol)
    kind_b, fb, top_b = supporting_feature(vb, nb, nsb, nbb, eb, -nx, -ny, -nz, cos_tol,
                                           sin_tol)
    _, hi = _support(va, nsa, nba, nx, ny, nz, 0)
    _, neg = _support(vb, nsb, nbb, -nx, -ny, -nz, top_b)
    lo = -neg
    band = max(alert, g, 0.0)
    limit = band + 1e-12 * (abs(hi) + abs(lo))
    proj_a = _project(va, nx, ny, nz)
    proj_b = _project(vb, nx, ny, nz)
    cap_a = np.empty(nva, dtype=np.int64)
    n_ca = 0
    for v in range(nva):
        if proj_a[v] >= hi - band - limit:
            cap_a[n_ca] = v
            n_ca += 1
    cap_b = np.empty(nvb, dtype=np.int64)
    n_cb = 0
    for v in range(nvb):
        if proj_b[v] <= lo + band + limit:
            cap_b[n_cb] = v
            n_cb += 1
    edge_a = np.empty(nea, dtype=np.int64)
    n_ea = 0
    for e in range(nea):
        if max(proj_a[ea[e, 0]], proj_a[ea[e, 1]]) >= hi - band - limit and \
                _upper_edge(na, efa, e, nx, ny, nz):
            edge_a[n_ea] = e
            n_ea += 1
    edge_b = np.empty(neb, dtype=np.int64)
    n_eb = 0
    for e in range(neb):
        if min(proj_b[eb[e, 0]], proj_b[eb[e, 1]]) <= lo + band + limit and \
                _upper_edge(nb, efb, e, -nx, -ny, -nz):
            edge_b[n_eb] = e
            n_eb += 1
    # faces the line entries need: a kept entry point lies at n . x >= lo - limit on A (a line
    # from B's cap going down at most limit), n . x <= hi + limit on B; A's part above
    # lo - limit is cut out by the faces of A reaching that level alone (convexity), B's
    # below hi + limit likewise; a pad of 1e-6 of the extent covers round-off
    faces_a = np.empty(na.shape[0], dtype=np.int64)
    faces_b = np.empty(nb.shape[0], dtype=np.int64)
    pad = 1e-6 * (hi - proj_a.min() + proj_b.max() - lo)
    if prune:
        n_fa = _faces_reaching(proj_a, fsa, fva, lo - limit - pad, True, faces_a)
        n_fb = _faces_reaching(proj_b, fsb, fvb, hi + limit + pad, False, faces_b)
    else:
        n_fa, n_fb = na.shape[0], nb.shape[0]
        faces_a[:] = np.arange(n_fa)
        faces_b[:] = np.arange(n_fb)
    # the cap edges seen along n: boxes in a plane normal to n, and the reach along n (highest
    # end on A, lowest on B); a pair of edges whose boxes are apart cannot cross, one whose
    # ends are farther than limit along n gives no kept crossing (pad: round-off)
    box_a = np.empty((5, n_ea))
    box_b = np.empty((5, n_eb))
    _edge_boxes(va, ea, edge_a, n_ea, proj_a, nx, ny, nz, True, 0.0, box_a)
    _edge_boxes(vb, eb, edge_b, n_eb, proj_b, nx, ny, nz, False, pad, box_b)
    near = np.empty(n_ea * n_eb, dtype=np.int64)  # edges of B near edge i of A, CSR
    near_start = np.zeros(n_ea + 1, dtype=np.int64)
    for i in range(n_ea):
        out = near[near_start[i]:]
        if prune:
            near_start[i + 1] = near_start[i] + _near_edges(box_a, i, box_b, n_eb,
                                                            limit + pad, out)
        else:
            out[:n_eb] = np.arange(n_eb)
            near_start[i + 1] = near_start[i] + n_eb
    size = n_ca + n_cb + near_start[n_ea]
    cand = np.empty((size, 3))
    local = np.empty(size)
    cid_a = np.empty(size, dtype=np.int64)
    cid_b = np.empty(size, dtype=np.int64)
    count = 0
    for k in range(n_cb):  # vertices of B over A's upper surface (line going down)
        b = vb[cap_b[k]]
        t, f, hit = _line_entry(b, -nx, -ny, -nz, na, oa, faces_a, n_fa)
        if hit and t <= limit:
            cand[count] = b - 0.5 * t * normal
            local[count] = t
            cid_a[count] = nva + nea + f
            cid_b[count] = cap_b[k]
            count += 1
    for k in range(n_ca):  # vertices of A under B's lower surface (line going up)
        a = va[cap_a[k]]
        t, f, hit = _line_entry(a, nx, ny, nz, nb, ob, faces_b, n_fb)
        if hit and t <= limit:
            cand[count] = a + 0.5 * t * normal
            local[count] = t
            cid_a[count] = cap_a[k]
            cid_b[count] = nvb + neb + f
            count += 1
    for i in range(n_ea):  # crossings of facing cap edges seen along n (scalar code)
        e = edge_a[i]
        u0, u1 = ea[e, 0], ea[e, 1]
        p0x, p0y, p0z = va[u0, 0], va[u0, 1], va[u0, 2]
        dax, day, daz = va[u1, 0] - p0x, va[u1, 1] - p0y, va[u1, 2] - p0z
        la = dax * dax + day * day + daz * daz
        for jj in range(near_start[i], near_start[i + 1]):
            k = edge_b[near[jj]]
            w0, w1 = eb[k, 0], eb[k, 1]
            q0x, q0y, q0z = vb[w0, 0], vb[w0, 1], vb[w0, 2]
            dbx, dby, dbz = vb[w1, 0] - q0x, vb[w1, 1] - q0y, vb[w1, 2] - q0z
            # (u x v) . n is the same for u, v and their parts normal to n
            cx, cy, cz = _cross(dax, day, daz, dbx, dby, dbz)
            cross = cx * nx + cy * ny + cz * nz
            if abs(cross) <= 1e-12 * math.sqrt(la * (dbx * dbx + dby * dby + dbz * dbz)):
                continue
            wx, wy, wz = q0x - p0x, q0y - p0y, q0z - p0z
            cx, cy, cz = _cross(wx, wy, wz, dbx, dby, dbz)
            s = (cx * nx + cy * ny + cz * nz) / cross
            if s < 0.0 or s > 1.0:
                continue
            cx, cy, cz = _cross(wx, wy, wz, dax, day, daz)
            t = (cx * nx + cy * ny + cz * nz) / cross
            if t < 0.0 or t > 1.0:
                continue
            pax, pay, paz = p0x + s * dax, p0y + s * day, p0z + s * daz
            pbx, pby, pbz = q0x + t * dbx, q0y + t * dby, q0z + t * dbz
            gap_k = (pbx - pax) * nx + (pby - pay) * ny + (pbz - paz) * nz
            if gap_k <= limit:
                cand[count, 0] = 0.5 * (pax + pbx)
                cand[count, 1] = 0.5 * (pay + pby)
                cand[count, 2] = 0.5 * (paz + pbz)
                local[count] = gap_k
                cid_a[count] = nva + e
                cid_b[count] = nvb + k
                count += 1
    kind = _type_of(kind_a, kind_b, ea, eb, fa, fb, va, vb, sin_tol)
    if count == 0:  # numerically empty: one point at the deepest vertex of B
        gaps[0] = g
        points[0] = vb[top_b] - 0.5 * g * normal
        ids_a[0] = _code(kind_a, fa, nva, nea)
        ids_b[0] = top_b
        return 1, kind
    extent = 0.0
    for k in range(count):
        extent = max(extent, abs(cand[k, 0] - cand[0, 0]) + abs(cand[k, 1] - cand[0, 1])
                     + abs(cand[k, 2] - cand[0, 2]))
    scale = 0.0
    for v in range(nva):
        scale = max(scale, abs(va[v, 0] - va[0, 0]) + abs(va[v, 1] - va[0, 1])
                    + abs(va[v, 2] - va[0, 2]))
    idx, kept = _reduce(cand, local, count, 1e-9 * scale, max_points)
    for r in range(kept):
        points[r] = cand[idx[r]]
        gaps[r] = local[idx[r]]
        ids_a[r] = cid_a[idx[r]]
        ids_b[r] = cid_b[idx[r]]
    return kept, kind


@njit(inline="always")
def _code(kind, index, n_vertices, n_edges):
    if kind == _VERTEX:
        return index
    if kind == _EDGE:
        return n_vertices + index
    return n_vertices + n_edges + index


@njit(inline="always")
def _type_of(kind_a, kind_b, ea, eb, fa, fb, va, vb, sin_tol):
    """Pair type from the supporting features: ff, fe (face-edge or parallel edges), ee, fv."""
    if kind_a == _FACE and kind_b == _FACE:
        return TYPE_FF
    if (kind_a == _FACE and kind_b == _EDGE) or (kind_a == _EDGE and kind_b == _FACE):
        return TYPE_FE
    if kind_a == _EDGE and kind_b == _EDGE:
        ta = va[ea[fa, 1]] - va[ea[fa, 0]]
        tb = vb[eb[fb, 1]] - vb[eb[fb, 0]]
        cross = np.cross(ta, tb)
        if cross @ cross <= (sin_tol * sin_tol) * (ta @ ta) * (tb @ tb):
            return TYPE_FE
        return TYPE_EE
    return TYPE_FV


# --------------------------------------------------------------------------------------------
# Walls and spheres
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def wall_manifold(vertices, normals, fstart, fverts, edges, nstart, nbrs, wall_point,
                  wall_normal, alert, cos_tol, sin_tol, max_points, points, gaps, ids):
    """Contact of a polyhedron with the plane wall (``wall_point`` (3,) [m], unit
    ``wall_normal`` (3,) towards the polyhedron): the vertices with gap n_w . (v - p_w) <=
    alert reduced to ``max_points`` (3 or 4) as :func:`pair_manifold`: points (4, 3) [m]
    (mid-points), gaps (4,) [m], vertex ids (4,); the type is that of the feature supporting
    the polyhedron along -n_w (vertex fv, edge fe, face ff). Returns (count, type), count 0
    when no vertex is within ``alert``."""
    mx, my, mz = wall_normal[0], wall_normal[1], wall_normal[2]
    kind, _, top = supporting_feature(vertices, normals, nstart, nbrs, edges, -mx, -my,
                                          -mz, cos_tol, sin_tol)
    g_top = (vertices[top] - wall_point) @ wall_normal
    if g_top > alert:
        return 0, TYPE_NONE
    n_v = vertices.shape[0]
    cand = np.empty((n_v, 3))
    local = np.empty(n_v)
    which = np.empty(n_v, dtype=np.int64)
    count = 0
    scale = 0.0
    for v in range(n_v):
        scale = max(scale, abs(vertices[v, 0] - vertices[0, 0])
                    + abs(vertices[v, 1] - vertices[0, 1]) + abs(vertices[v, 2] - vertices[0, 2]))
        gap = (vertices[v] - wall_point) @ wall_normal
        if gap <= alert:
            cand[count] = vertices[v] - 0.5 * gap * wall_normal
            local[count] = gap
            which[count] = v
            count += 1
    idx, kept = _reduce(cand, local, count, 1e-9 * scale, max_points)
    for r in range(kept):
        gaps[r] = local[idx[r]]
        points[r] = cand[idx[r]]
        ids[r] = which[idx[r]]
    if kind == _VERTEX:
        return kept, TYPE_FV
    if kind == _EDGE:
        return kept, TYPE_FE
    return kept, TYPE_FF


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
