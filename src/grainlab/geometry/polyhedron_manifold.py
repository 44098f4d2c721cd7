"""Contact manifold of convex polyhedra (seed 002): contact type, points of a polyhedron pair
and of a polyhedron on a plane wall (Numba; no Python objects in the kernels). Arrays as in
:mod:`grainlab.geometry.polyhedron_contact` (world frame); the gap g and the normal n from A to
B come from its :func:`~grainlab.geometry.polyhedron_contact.signed_distance`.

Contact type and manifold
-------------------------
The supporting feature of A along n (of B along -n) is a FACE when a face normal lies within
the angle :data:`~grainlab.geometry.polyhedron_contact.ANGLE_TOLERANCE` of n (of -n), else an
EDGE when an edge at the support vertex is perpendicular to n within that angle, else a
VERTEX. The pair's type follows: face-face ff,
face-edge (or two parallel edges) fe, edge-edge ee, any vertex fv (the rare vertex-edge and
vertex-vertex counted with fv). Since only the direction of n enters, a pair whose normal does
not turn keeps its type from step to step.

The manifold is the "shadow overlap" of the near-plane parts of both bodies
(research/engine_tech.md 3.1-3.2): the candidates are

- the vertices of B's cap (n . b within the alert distance of B's lowest point, and in any
  case every vertex below A's highest point: the whole overlap) whose line along -n enters
  A, at the entry point of A's upper surface;
- the vertices of A's cap (likewise) whose line along +n enters B;
- the crossings, seen along n, of A's and B's cap edges that face each other (an edge of A
  bordering a face with n_f . n > 0, of B with n_f . n < 0),

kept if their distance along n between the two surfaces is within the alert distance. The
pruned kernel cuts the caps to the levels a kept candidate needs: n . a >= lo - limit on A,
n . b <= hi + limit on B (lo: B's lowest point along n, hi: A's highest; limit: the band, the
larger of the alert distance and the gap), half the depth of the caps above for a shallow
contact, the same candidates. A line
from B's cap is cut only by the faces of A reaching above lo - limit (the kept entry points
lie there, and by convexity those faces alone bound A's part above that level), a line from
A's cap by the faces of B reaching below hi + limit; two cap edges are crossed only if their
boxes seen along n overlap and their ends are within the alert distance along n.
:func:`signed_distance_exhaustive` and :func:`pair_manifold_exhaustive` evaluate everything
(the slow twins of the tests).

Each point carries the gap and normal of its own constraint, not the pair's: a vertex of B
under face f of A has g = n_f . b - O_f and normal n_f (a vertex of A under face f of B:
g = n_f . a - O_f, normal -n_f), a crossing of edges d_a, d_b the common normal
m = d_a x d_b towards B and g = (gap along n) (m . n), unless the edges are nearly parallel
(:data:`EDGE_NORMAL_SIN`) or m lies more than 60 degrees from n (:data:`EDGE_NORMAL_COS`),
where the pair's n and the gap along n are kept. A vertex whose line along n meets the other
body on an edge (two face planes through the entry point, within a tie length of 1e-9 of the
body's size) has the vertex-edge constraint: normal the part of n normal to the edge, gap t
times its length (t: the distance along n), feature id the edge's; on a vertex (three or
more planes), the vertex-vertex constraint along n, gap t. This is the common case of bodies
apart whose closest features are a vertex and an edge: the line from the vertex along the
link n meets the edge exactly, and choosing one of the two faces there (as round-off would)
gives a gap smaller than the bodies' distance and a tilted normal, different on another
processor or in another frame. A crossing at an end of either edge (within the tie length) is
that end vertex over the other edge: the vertex candidate carries it (the two edges at the
vertex would each bring their own gap and normal). These are the gap functions whose first
order is exact under any small rigid motion: the gap along the pair's n of a vertex over a
face tilted from n changes with tangential sliding, so a frictionless point that the solver
held at zero normal velocity still sank (measured: 1e-4 to 3e-4 <d> per step in a jammed
packing). Points are written at the mid-point between the two surfaces along their normal.

Reduction to ``max_points`` (3 to :data:`~grainlab.geometry.polyhedron_contact.MAX_POINTS`,
default :data:`~grainlab.geometry.polyhedron_contact.DEFAULT_MAX_POINTS`): the deepest,
the one farthest from it, the one giving the largest triangle (seed 002: a flat contact is
"replaced by three points"), with 4 or more the one adding the largest area outside that
triangle, then the deepest of the rest (coincident points skipped); values within round-off
tie and go to the lower feature-ordered index, so the choice is the same in every frame. A
vertex-face or edge-edge contact alone gives 1 point, an edge on a face 2, two triangles up
to 6. Why more than seed 002's three: a point left out is not held, and when it lies outside
the kept triangle (a triangle-triangle overlap is a hexagon, a twisted square-square one an octagon)
the body turns into the other about the kept ones; in a frictionless compaction of 60
polyhedra (n_f = 30) the left-out points sank in turn (the deepest point of a wall contact
alternated between two vertices as it went from 4 % to 9 % of <d>) and the largest overlap
ran away to 10 % of <d> with 3 or 4 points; with 6 it settled at 2 %, with 8 at 0.3 %
(docs/benchmarks/polyhedra.md). Coplanar points are hyperstatic: NLGS still converges (the
velocities are unique), the split of the normal force among them is one of many.

Feature ids (stable warm-start keys): vertex k -> k, edge e -> n_v + e, face f -> n_v + n_e + f
(local to the shape). A manifold point made by a vertex of B inside a face of A has ids (face
of A, vertex of B); a crossing of two edges (edge, edge); a vertex of A inside a face of B
(vertex, face).

Walls
-----
A wall is a plane (p_w, n_w) with the bodies on the side of n_w: the vertices with gap
n_w . (v - p_w) within the alert distance (normal n_w), reduced as above; the type is that of the
polyhedron's feature supporting it along -n_w (vertex fv, edge fe, face ff).

Units: lengths in m, angles in rad.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainlab.geometry.polyhedron_contact import (
    _EDGE,
    _FACE,
    _HUGE,
    _VERTEX,
    MAX_POINTS,
    TYPE_EE,
    TYPE_FE,
    TYPE_FF,
    TYPE_FV,
    TYPE_NONE,
    _cross,
    _faces_reaching,
    _project,
    _support,
    supporting_feature,
)

# --------------------------------------------------------------------------------------------
# Manifold
# --------------------------------------------------------------------------------------------

EDGE_NORMAL_SIN = 0.05
"""A crossing of two edges takes their common normal d_a x d_b when the edges make an angle
whose sine exceeds this ..."""
EDGE_NORMAL_COS = 0.5
"""... and that normal lies within 60 degrees of the pair's normal; else the pair's normal."""


@njit
def _reduce(points, gaps, count, tol, max_points):
    """Indices (MAX_POINTS,) of at most ``max_points`` (3 to MAX_POINTS) of ``count``
    points: the deepest, the farthest from it, the one giving the largest triangle, the one
    adding the largest area outside that triangle, then the deepest of the rest not within
    ``tol`` [m] of a kept one; returns (idx, n) (scalar code). Every comparison asks for a
    margin of ``tol`` (a length, or tol times a length for areas), so that values equal up to
    round-off tie, and a tie goes to the lower index: the candidates come in the order of the
    shapes' own feature ids, so the choice does not depend on the frame (a symmetric contact,
    a square on a square, has exact ties that round-off would otherwise settle)."""
    idx = np.empty(MAX_POINTS, dtype=np.int64)
    first = 0
    for k in range(1, count):
        if gaps[k] < gaps[first] - tol:
            first = k
    idx[0] = first
    if count == 1:
        return idx, 1
    ox, oy, oz = points[first, 0], points[first, 1], points[first, 2]
    far, far_r = first, 0.0
    for k in range(count):
        dx, dy, dz = points[k, 0] - ox, points[k, 1] - oy, points[k, 2] - oz
        r = math.sqrt(dx * dx + dy * dy + dz * dz)
        if r > far_r + tol:  # distances, not their squares (tol^2 is below round-off)
            far, far_r = k, r
    if far_r <= tol:
        return idx, 1
    far_d = far_r * far_r
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
    kept = 3
    if fourth >= 0:
        idx[3] = fourth
        kept = 4
    # the rest by depth, skipping points that coincide with a kept one
    while kept < max_points:
        best = -1
        for k in range(count):
            fresh = True
            for r in range(kept):
                j = idx[r]
                dx, dy, dz = points[k, 0] - points[j, 0], points[k, 1] - points[j, 1], \
                    points[k, 2] - points[j, 2]
                if dx * dx + dy * dy + dz * dz <= tol * tol:
                    fresh = False
                    break
            if fresh and (best < 0 or gaps[k] < gaps[best] - tol):
                best = k
        if best < 0:
            break
        idx[kept] = best
        kept += 1
    return idx, kept


@njit
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


@njit
def _vertex_constraint(x, t, f, sign, nx, ny, nz, vertices, normals, offsets, edges,
                       edge_faces, faces, n_faces, tie):
    """Gap [m], unit normal (from A to B) and feature id (module docstring) of the other
    body's feature in the constraint of vertex ``x`` whose line x + sign t n (sign -1: a
    vertex of B going down into A, +1: a vertex of A going up into B) enters the other body
    (``vertices``, ``normals``, ``offsets``, ``edges``, ``edge_faces``) at parameter ``t`` [m]
    through face ``f`` (faces[:n_faces] are those the entry was searched among):
    (gap, mx, my, mz, feature).

    The entry point lies on the planes of the faces through it, within ``tie`` [m]: one face
    gives the vertex-face constraint (distance to the plane of f along its normal); two, an
    edge of the other body (e = n_f x n_g): the vertex-edge constraint, normal the part of n
    normal to e, gap t |n - (n . e) e|; three or more, a vertex: the vertex-vertex constraint
    along n, gap t. The line from the vertex nearest to an edge or a vertex of the other body
    hits that feature exactly (its direction n is the link of the two features), so this is
    the common case of separated bodies, not a rare one: choosing one of the faces there would
    let round-off decide between two different gaps and normals."""
    ex_x, ex_y, ex_z = x[0] + sign * t * nx, x[1] + sign * t * ny, x[2] + sign * t * nz
    through, first, second = 0, -1, -1
    for i in range(n_faces):
        g = faces[i]
        d = normals[g, 0] * ex_x + normals[g, 1] * ex_y + normals[g, 2] * ex_z - offsets[g]
        if abs(d) <= tie:
            through += 1
            if first < 0:
                first = g
            elif second < 0:
                second = g
    n_v, n_e = vertices.shape[0], edges.shape[0]
    if through >= 3:
        near, near_d = 0, _HUGE
        for v in range(n_v):
            d = abs(vertices[v, 0] - ex_x) + abs(vertices[v, 1] - ex_y) \
                + abs(vertices[v, 2] - ex_z)
            if d < near_d:
                near, near_d = v, d
        return t, nx, ny, nz, near
    if through == 2:
        ex, ey, ez = _cross(normals[first, 0], normals[first, 1], normals[first, 2],
                            normals[second, 0], normals[second, 1], normals[second, 2])
        size = math.sqrt(ex * ex + ey * ey + ez * ez)
        if size > 1e-9:
            ex, ey, ez = ex / size, ey / size, ez / size
            along = nx * ex + ny * ey + nz * ez
            px, py, pz = nx - along * ex, ny - along * ey, nz - along * ez
            size = math.sqrt(px * px + py * py + pz * pz)
            if size > 1e-9:
                edge = 0
                for e in range(n_e):
                    if (edge_faces[e, 0] == first and edge_faces[e, 1] == second) or \
                            (edge_faces[e, 0] == second and edge_faces[e, 1] == first):
                        edge = e
                        break
                return t * size, px / size, py / size, pz / size, n_v + edge
    gap = normals[f, 0] * x[0] + normals[f, 1] * x[1] + normals[f, 2] * x[2] - offsets[f]
    return gap, -sign * normals[f, 0], -sign * normals[f, 1], -sign * normals[f, 2], \
        n_v + n_e + f


@njit
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


@njit
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


@njit
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
                  g, normal, alert, cos_tol, sin_tol, max_points, points, gaps, point_normals,
                  ids_a, ids_b):
    """Contact manifold of polyhedra A and B at signed distance ``g`` [m] along ``normal``
    (3,) from A to B (module docstring): writes ``points`` (MAX_POINTS, 3) [m] (mid-points),
    ``gaps`` (MAX_POINTS,) [m], their unit ``point_normals`` (MAX_POINTS, 3) from A to B and
    feature ids ``ids_a``, ``ids_b`` (MAX_POINTS,); returns (count, type code)."""
    prune = va.shape[0] >= 0  # True as a typed flag, not a literal: one compiled body
    return _pair_manifold(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                          vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                          g, normal, alert, cos_tol, sin_tol, max_points, points, gaps,
                          point_normals, ids_a, ids_b, prune)


@njit(cache=True)
def pair_manifold_exhaustive(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                             vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                             g, normal, alert, cos_tol, sin_tol, max_points, points, gaps,
                             point_normals, ids_a, ids_b):
    """:func:`pair_manifold` with every face of the other body in the line entries and every
    pair of cap edges crossed: the slow twin it must agree with (same points, gaps, ids and
    type)."""
    prune = va.shape[0] < 0  # False as a typed flag: the same compiled body as the pruned
    return _pair_manifold(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                          vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                          g, normal, alert, cos_tol, sin_tol, max_points, points, gaps,
                          point_normals, ids_a, ids_b, prune)


@njit(cache=True)
def _pair_manifold(va, na, oa, fsa, fva, ea, efa, nsa, nba,
                   vb, nb, ob, fsb, fvb, eb, efb, nsb, nbb,
                   g, normal, alert, cos_tol, sin_tol, max_points, points, gaps, point_normals,
                   ids_a, ids_b, prune):
    """Contact manifold of polyhedra A and B at signed distance ``g`` [m] along ``normal``
    (3,) from A to B (module docstring): writes ``points``, ``gaps``, ``point_normals``,
    ``ids_a``, ``ids_b`` as :func:`pair_manifold`; returns (count, type code).

    Candidates, each with its own gap along n: the vertices of B's cap (n . b within alert of
    B's lowest) over A's upper surface, the vertices of A's cap under B's lower surface, and
    the crossings, seen along n, of the cap edges of A and B that face each other; those with
    gap <= max(alert, g) are reduced to ``max_points``. ``prune``: line entries
    only through the faces reaching the other cap, crossings only of edges whose boxes seen
    along n overlap, caps cut to the levels a kept candidate needs (lo - limit on A, hi +
    limit on B, where the band's caps reach a band deeper: the caps hold half the vertices
    and edges of a shallow contact); module docstring; same result."""
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
    scale = 0.0
    for v in range(nva):
        scale = max(scale, abs(va[v, 0] - va[0, 0]) + abs(va[v, 1] - va[0, 1])
                    + abs(va[v, 2] - va[0, 2]))
    # lengths within tie [m] are equal (round-off of the coordinates, far below any contact
    # length): entry points on a face plane, crossings at an edge end
    tie = 1e-9 * scale + 1e-12 * (abs(hi) + abs(lo))
    proj_a = _project(va, nx, ny, nz)
    proj_b = _project(vb, nx, ny, nz)
    # a pad of 1e-6 of the extent along n covers the round-off of the levels below
    pad = 1e-6 * (hi - proj_a.min() + proj_b.max() - lo)
    if prune:
        # the levels a kept candidate needs: B's surface lies at n . x >= lo, so a vertex of
        # A whose line up enters B within limit, or the point of an edge of A crossing an
        # edge of B with a gap within limit, lies at n . x >= lo - limit; A's surface at
        # n . x <= hi, so those of B at n . x <= hi + limit
        floor_a = lo - limit - pad
        ceiling_b = hi + limit + pad
    else:
        # the caps of the module docstring: within the band of each body's extreme point,
        # and at least through the whole overlap (an overlap deeper than the band must not
        # leave features of the overlapping region out of the candidates)
        floor_a = min(hi - band, lo) - limit
        ceiling_b = max(lo + band, hi) + limit
    cap_a = np.empty(nva, dtype=np.int64)
    n_ca = 0
    for v in range(nva):
        if proj_a[v] >= floor_a:
            cap_a[n_ca] = v
            n_ca += 1
    cap_b = np.empty(nvb, dtype=np.int64)
    n_cb = 0
    for v in range(nvb):
        if proj_b[v] <= ceiling_b:
            cap_b[n_cb] = v
            n_cb += 1
    edge_a = np.empty(nea, dtype=np.int64)
    n_ea = 0
    for e in range(nea):
        if max(proj_a[ea[e, 0]], proj_a[ea[e, 1]]) >= floor_a and \
                _upper_edge(na, efa, e, nx, ny, nz):
            edge_a[n_ea] = e
            n_ea += 1
    edge_b = np.empty(neb, dtype=np.int64)
    n_eb = 0
    for e in range(neb):
        if min(proj_b[eb[e, 0]], proj_b[eb[e, 1]]) <= ceiling_b and \
                _upper_edge(nb, efb, e, -nx, -ny, -nz):
            edge_b[n_eb] = e
            n_eb += 1
    # faces the line entries need: a kept entry point lies at n . x >= lo - limit on A (a line
    # from B's cap going down at most limit), n . x <= hi + limit on B; A's part above
    # lo - limit is cut out by the faces of A reaching that level alone (convexity), B's
    # below hi + limit likewise; a pad of 1e-6 of the extent covers round-off
    faces_a = np.empty(na.shape[0], dtype=np.int64)
    faces_b = np.empty(nb.shape[0], dtype=np.int64)
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
    cnormal = np.empty((size, 3))
    local = np.empty(size)
    cid_a = np.empty(size, dtype=np.int64)
    cid_b = np.empty(size, dtype=np.int64)
    count = 0
    for k in range(n_cb):  # vertices of B over A's upper surface (line going down)
        b = vb[cap_b[k]]
        t, f, hit = _line_entry(b, -nx, -ny, -nz, na, oa, faces_a, n_fa)
        if hit and t <= limit:
            # gap and normal of the vertex-face constraint: distance to the plane of f along
            # its own normal (first-order exact under sliding, unlike the gap along n); of
            # the vertex-edge or vertex-vertex one where the line enters on an edge or vertex
            gap_f, mx, my, mz, feature = _vertex_constraint(b, t, f, -1.0, nx, ny, nz, va, na,
                                                            oa, ea, efa, faces_a, n_fa, tie)
            cnormal[count, 0], cnormal[count, 1], cnormal[count, 2] = mx, my, mz
            cand[count, 0] = b[0] - 0.5 * gap_f * mx
            cand[count, 1] = b[1] - 0.5 * gap_f * my
            cand[count, 2] = b[2] - 0.5 * gap_f * mz
            local[count] = gap_f
            cid_a[count] = feature
            cid_b[count] = cap_b[k]
            count += 1
    for k in range(n_ca):  # vertices of A under B's lower surface (line going up)
        a = va[cap_a[k]]
        t, f, hit = _line_entry(a, nx, ny, nz, nb, ob, faces_b, n_fb)
        if hit and t <= limit:
            gap_f, mx, my, mz, feature = _vertex_constraint(a, t, f, 1.0, nx, ny, nz, vb, nb,
                                                            ob, eb, efb, faces_b, n_fb, tie)
            cnormal[count, 0], cnormal[count, 1], cnormal[count, 2] = mx, my, mz
            cand[count, 0] = a[0] + 0.5 * gap_f * mx
            cand[count, 1] = a[1] + 0.5 * gap_f * my
            cand[count, 2] = a[2] + 0.5 * gap_f * mz
            local[count] = gap_f
            cid_a[count] = cap_a[k]
            cid_b[count] = feature
            count += 1
    for i in range(n_ea):  # crossings of facing cap edges seen along n (scalar code)
        e = edge_a[i]
        u0, u1 = ea[e, 0], ea[e, 1]
        p0x, p0y, p0z = va[u0, 0], va[u0, 1], va[u0, 2]
        dax, day, daz = va[u1, 0] - p0x, va[u1, 1] - p0y, va[u1, 2] - p0z
        la = dax * dax + day * day + daz * daz
        sqrt_la = math.sqrt(la)
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
            # a crossing at an end of either edge (within tie) is that end vertex over an
            # edge of the other body: the vertex candidate carries it, with the vertex-edge
            # constraint (two edges at a vertex would each give their own gap and normal)
            s = (cx * nx + cy * ny + cz * nz) / cross
            if s * sqrt_la <= tie or (1.0 - s) * sqrt_la <= tie:
                continue
            cx, cy, cz = _cross(wx, wy, wz, dax, day, daz)
            t = (cx * nx + cy * ny + cz * nz) / cross
            sqrt_lb = math.sqrt(dbx * dbx + dby * dby + dbz * dbz)
            if t * sqrt_lb <= tie or (1.0 - t) * sqrt_lb <= tie:
                continue
            pax, pay, paz = p0x + s * dax, p0y + s * day, p0z + s * daz
            pbx, pby, pbz = q0x + t * dbx, q0y + t * dby, q0z + t * dbz
            gap_k = (pbx - pax) * nx + (pby - pay) * ny + (pbz - paz) * nz
            if gap_k <= limit:
                cand[count, 0] = 0.5 * (pax + pbx)
                cand[count, 1] = 0.5 * (pay + pby)
                cand[count, 2] = 0.5 * (paz + pbz)
                # edge-edge constraint: normal da x db towards B (pb - pa is along n, so
                # its gap is gap_k m . n); nearly parallel edges keep n
                cx, cy, cz = _cross(dax, day, daz, dbx, dby, dbz)
                size_m = math.sqrt(cx * cx + cy * cy + cz * cz)
                along = (cx * nx + cy * ny + cz * nz) / max(size_m, 1e-300)
                if size_m > EDGE_NORMAL_SIN * math.sqrt(la * (dbx * dbx + dby * dby
                                                              + dbz * dbz)) \
                        and abs(along) >= EDGE_NORMAL_COS:
                    sign = 1.0 if along > 0.0 else -1.0
                    cnormal[count, 0] = sign * cx / size_m
                    cnormal[count, 1] = sign * cy / size_m
                    cnormal[count, 2] = sign * cz / size_m
                    local[count] = gap_k * abs(along)
                else:
                    cnormal[count, 0], cnormal[count, 1], cnormal[count, 2] = nx, ny, nz
                    local[count] = gap_k
                cid_a[count] = nva + e
                cid_b[count] = nvb + k
                count += 1
    kind = _type_of(kind_a, kind_b, ea, eb, fa, fb, va, vb, sin_tol)
    if count == 0:  # numerically empty: one point at the deepest vertex of B
        gaps[0] = g
        points[0] = vb[top_b] - 0.5 * g * normal
        point_normals[0] = normal
        ids_a[0] = _code(kind_a, fa, nva, nea)
        ids_b[0] = top_b
        return 1, kind
    idx, kept = _reduce(cand, local, count, 1e-9 * scale, max_points)
    for r in range(kept):
        points[r] = cand[idx[r]]
        gaps[r] = local[idx[r]]
        point_normals[r] = cnormal[idx[r]]
        ids_a[r] = cid_a[idx[r]]
        ids_b[r] = cid_b[idx[r]]
    return kept, kind


@njit
def _code(kind, index, n_vertices, n_edges):
    if kind == _VERTEX:
        return index
    if kind == _EDGE:
        return n_vertices + index
    return n_vertices + n_edges + index


@njit
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
# Walls
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def wall_manifold(vertices, normals, fstart, fverts, edges, nstart, nbrs, wall_point,
                  wall_normal, alert, cos_tol, sin_tol, max_points, points, gaps, ids):
    """Contact of a polyhedron with the plane wall (``wall_point`` (3,) [m], unit
    ``wall_normal`` (3,) towards the polyhedron): the vertices with gap n_w . (v - p_w) <=
    alert reduced to ``max_points`` as :func:`pair_manifold`: points (MAX_POINTS, 3) [m]
    (mid-points), gaps (MAX_POINTS,) [m], vertex ids (MAX_POINTS,); the type is that of the
    feature supporting the polyhedron along -n_w (vertex fv, edge fe, face ff). Returns
    (count, type), count 0 when no vertex is within ``alert``."""
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
