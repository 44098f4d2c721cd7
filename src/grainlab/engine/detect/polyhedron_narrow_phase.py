"""Narrow phase of convex polyhedra against polyhedra, spheres (and aggregate members) and
plane walls: array kernels over candidate pairs around the contact geometry of
:mod:`grainlab.geometry.polyhedron_contact` and
:mod:`grainlab.geometry.polyhedron_manifold` (Numba; STYLE.md 2, 3, 8).

The boundaries of the polyhedron bodies are first moved to the world frame (vertices
x + R(q) v, normals R(q) n, offsets O + n' . x), body n owning rows ``body_vertex_start[n] ..``
and ``body_face_start[n] ..``; edges, face CSR and vertex neighbours stay in local ids in the
:class:`~grainlab.engine.state.ShapeLibrary`. A polyhedron pair gives 1 to ``max_points``
rows (the pair's manifold, each point with the normal of its own vertex-face or edge-edge
constraint), a polyhedron and a member sphere 1 row, a polyhedron and a wall 1 to
``max_points`` rows; every row carries the pair's type code (1 fv, 2 ee, 3 fe, 4 ff).
member_i/member_j of a polyhedron are feature ids (vertex k -> k, edge e -> V + e,
face f -> V + E + f), those of a sphere its member index, of a wall -1. Rows are written from
``start`` on while they fit; the kernels return ``start`` + the rows they needed (the
launcher regrows and reruns).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainlab.engine.quaternion import rotate
from grainlab.engine.shape_kinds import POLYHEDRON_FEATURES, family_mask
from grainlab.engine.state import ReadOnlyArrays
from grainlab.geometry.polyhedron_contact import MAX_POINTS, signed_distance, sphere_contact
from grainlab.geometry.polyhedron_manifold import pair_manifold, wall_manifold


@njit(inline="always")
def world_polyhedron(n, positions, orientations, shape_ids, vertex_start, vertices, face_start,
                     face_normals, face_offsets, body_vertex_start, body_face_start,
                     world_vertices, world_normals, world_offsets):
    """Body n's rows of :func:`world_polyhedra_kernel` (the scalar law, also inlined in the
    serial sub-steps of :mod:`grainlab.engine.dem.soft_polyhedra_kernels`)."""
    w, x, y, z = orientations[n, 0], orientations[n, 1], orientations[n, 2], orientations[n, 3]
    s = shape_ids[n]
    px, py, pz = positions[n, 0], positions[n, 1], positions[n, 2]
    v0 = vertex_start[s]
    for row in range(body_vertex_start[n], body_vertex_start[n + 1]):
        k = v0 + row - body_vertex_start[n]
        rx, ry, rz = rotate(w, x, y, z, vertices[k, 0], vertices[k, 1], vertices[k, 2])
        world_vertices[row, 0] = px + rx
        world_vertices[row, 1] = py + ry
        world_vertices[row, 2] = pz + rz
    f0 = face_start[s]
    for row in range(body_face_start[n], body_face_start[n + 1]):
        k = f0 + row - body_face_start[n]
        rx, ry, rz = rotate(w, x, y, z, face_normals[k, 0], face_normals[k, 1],
                            face_normals[k, 2])
        world_normals[row, 0] = rx
        world_normals[row, 1] = ry
        world_normals[row, 2] = rz
        world_offsets[row] = face_offsets[k] + rx * px + ry * py + rz * pz


# no reference counts on the arrays in the loop (inline helper): compiled without the Numba
# runtime (_nrt=False), as it allocates nothing
@njit(cache=True, parallel=True, _nrt=False)
def world_polyhedra_kernel(
    positions, orientations, shape_ids, vertex_start, vertices, face_start, face_normals,
    face_offsets, body_vertex_start, body_face_start,
    world_vertices, world_normals, world_offsets,
):
    """Vertices (V_w, 3) [m], face normals (F_w, 3) and offsets (F_w,) [m] of the polyhedron
    bodies in the world frame (body n: rows body_*_start[n] .. body_*_start[n + 1] - 1)."""
    for n in prange(positions.shape[0]):
        world_polyhedron(n, positions, orientations, shape_ids, vertex_start, vertices,
                         face_start, face_normals, face_offsets, body_vertex_start,
                         body_face_start, world_vertices, world_normals, world_offsets)


@njit(inline="always")
def _store(row, bi, bj, mi, mj, g, n, p, code,
           body_i, body_j, member_i, member_j, point, normal, gap, contact_type):
    if row < gap.shape[0]:
        body_i[row] = bi
        body_j[row] = bj
        member_i[row] = mi
        member_j[row] = mj
        gap[row] = g
        for c in range(3):
            normal[row, c] = n[c]
            point[row, c] = p[c]
        contact_type[row] = code


@njit(inline="always")
def _sphere_row(row, poly, other, a, poly_first, wv, wn, wo, fs, fv, ed, centre, radius,
                alert, body_i, body_j, member_i, member_j, point, normal, gap, contact_type):
    """One polyhedron-member-sphere row; ``poly_first`` says whether the polyhedron is
    body i. Returns the next row."""
    n = np.empty(3)
    p = np.empty(3)
    g, code, kind = sphere_contact(wv, wn, wo, fs, fv, ed, centre, radius, n, p)
    if g > alert:
        return row
    if poly_first:
        _store(row, poly, other, code, a, g, n, p, kind,
               body_i, body_j, member_i, member_j, point, normal, gap, contact_type)
    else:
        _store(row, other, poly, a, code, g, -n, p, kind,
               body_i, body_j, member_i, member_j, point, normal, gap, contact_type)
    return row + 1


@njit(inline="always")
def _body_features(b, s, body_vertex_start, world_vertices, body_face_start, world_normals,
                   world_offsets, face_start, face_count, face_vertex_start, edge_start,
                   edge_count, edges, edge_faces, vertex_start, vertex_count,
                   vertex_neighbour_start):
    """Views of body b (shape s): world vertices, face normals and offsets, face CSR offsets,
    edges, edge faces and vertex-neighbour CSR offsets."""
    v = world_vertices[body_vertex_start[b]:body_vertex_start[b + 1]]
    n = world_normals[body_face_start[b]:body_face_start[b + 1]]
    o = world_offsets[body_face_start[b]:body_face_start[b + 1]]
    fs = face_vertex_start[face_start[s]:face_start[s] + face_count[s] + 1]
    e = edges[edge_start[s]:edge_start[s] + edge_count[s]]
    ef = edge_faces[edge_start[s]:edge_start[s] + edge_count[s]]
    ns = vertex_neighbour_start[vertex_start[s]:vertex_start[s] + vertex_count[s] + 1]
    return v, n, o, fs, e, ef, ns


@njit(cache=True)
def polyhedron_pairs_kernel(
    pairs, is_poly, shape_ids, positions, body_vertex_start, world_vertices, body_face_start,
    world_normals, world_offsets, face_start, face_count, face_vertex_start, face_vertices,
    edge_start, edge_count, edges, edge_faces, vertex_start, vertex_count,
    vertex_neighbour_start, vertex_neighbours, sphere_body_start, world_centres, world_radii,
    alert, cos_tol, sin_tol, max_points, start,
    body_i, body_j, member_i, member_j, point, normal, gap, contact_type,
):
    """Contacts (gap <= alert) of the candidate pairs (P, 2) with at least one polyhedron
    (``is_poly`` (N,) bool); written from row ``start``; returns start + rows needed."""
    row = start
    n_out = np.empty(3)
    pts = np.empty((MAX_POINTS, 3))
    gps = np.empty(MAX_POINTS)
    ida = np.empty(MAX_POINTS, dtype=np.int64)
    idb = np.empty(MAX_POINTS, dtype=np.int64)
    nrm = np.empty((MAX_POINTS, 3))
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        if not (is_poly[i] or is_poly[j]):
            continue
        si, sj = shape_ids[i], shape_ids[j]
        if is_poly[i] and is_poly[j]:
            va, na, oa, fsa, ea, efa, nsa = _body_features(
                i, si, body_vertex_start, world_vertices, body_face_start, world_normals,
                world_offsets, face_start, face_count, face_vertex_start, edge_start,
                edge_count, edges, edge_faces, vertex_start, vertex_count,
                vertex_neighbour_start)
            vb, nb, ob, fsb, eb, efb, nsb = _body_features(
                j, sj, body_vertex_start, world_vertices, body_face_start, world_normals,
                world_offsets, face_start, face_count, face_vertex_start, edge_start,
                edge_count, edges, edge_faces, vertex_start, vertex_count,
                vertex_neighbour_start)
            g, found = signed_distance(
                va, na, oa, fsa, face_vertices, ea, efa, nsa, vertex_neighbours, positions[i],
                vb, nb, ob, fsb, face_vertices, eb, efb, nsb, vertex_neighbours, positions[j],
                alert, n_out)
            if not found:
                continue
            count, code = pair_manifold(
                va, na, oa, fsa, face_vertices, ea, efa, nsa, vertex_neighbours,
                vb, nb, ob, fsb, face_vertices, eb, efb, nsb, vertex_neighbours,
                g, n_out, alert, cos_tol, sin_tol, max_points, pts, gps, nrm, ida, idb)
            for r in range(count):
                _store(row, i, j, ida[r], idb[r], gps[r], nrm[r], pts[r], code,
                       body_i, body_j, member_i, member_j, point, normal, gap, contact_type)
                row += 1
        else:
            poly, other = (i, j) if is_poly[i] else (j, i)
            sp = shape_ids[poly]
            wv, wn, wo, fs, ed, _, _ = _body_features(
                poly, sp, body_vertex_start, world_vertices, body_face_start, world_normals,
                world_offsets, face_start, face_count, face_vertex_start, edge_start,
                edge_count, edges, edge_faces, vertex_start, vertex_count,
                vertex_neighbour_start)
            for a in range(sphere_body_start[other], sphere_body_start[other + 1]):
                row = _sphere_row(row, poly, other, a - sphere_body_start[other], poly == i,
                                  wv, wn, wo, fs, face_vertices, ed, world_centres[a],
                                  world_radii[a], alert, body_i, body_j, member_i, member_j,
                                  point, normal, gap, contact_type)
    return row


@njit(cache=True)
def polyhedron_walls_kernel(
    wall_points, wall_normals, positions, bounding_radii, is_poly, shape_ids,
    body_vertex_start, world_vertices, body_face_start, world_normals, face_start,
    face_count, face_vertex_start, face_vertices, edge_start, edge_count, edges,
    vertex_start, vertex_count, vertex_neighbour_start, vertex_neighbours,
    alert, cos_tol, sin_tol, max_points, start,
    body_i, body_j, member_i, member_j, point, normal, gap, contact_type,
):
    """Contacts (gap <= alert) of the polyhedron bodies with plane walls (points (W, 3) [m],
    unit normals (W, 3)); wall w is body_i = -1 - w, member_i = -1; member_j is a vertex id.
    Written from row ``start``; returns start + rows needed."""
    row = start
    pts = np.empty((MAX_POINTS, 3))
    gps = np.empty(MAX_POINTS)
    ids = np.empty(MAX_POINTS, dtype=np.int64)
    for w in range(wall_points.shape[0]):
        for n in range(positions.shape[0]):
            if not is_poly[n]:
                continue
            h = (positions[n] - wall_points[w]) @ wall_normals[w]
            if h - bounding_radii[n] > alert:
                continue
            s = shape_ids[n]
            count, code = wall_manifold(
                world_vertices[body_vertex_start[n]:body_vertex_start[n + 1]],
                world_normals[body_face_start[n]:body_face_start[n + 1]],
                face_vertex_start[face_start[s]:face_start[s] + face_count[s] + 1],
                face_vertices, edges[edge_start[s]:edge_start[s] + edge_count[s]],
                vertex_neighbour_start[vertex_start[s]:vertex_start[s] + vertex_count[s] + 1],
                vertex_neighbours, wall_points[w], wall_normals[w], alert, cos_tol, sin_tol,
                max_points, pts, gps, ids)
            for r in range(count):
                _store(row, -1 - w, n, -1, ids[r], gps[r], wall_normals[w], pts[r], code,
                       body_i, body_j, member_i, member_j, point, normal, gap, contact_type)
                row += 1
    return row


def world_polyhedra(state, library):
    """The boundaries of the bodies of the narrow-phase family
    :data:`~grainlab.engine.shape_kinds.POLYHEDRON_FEATURES` in the world frame: (is_poly (N,)
    (the bodies of that family), body_vertex_start
    (N + 1,), world_vertices (V_w, 3) [m], body_face_start (N + 1,), world_normals (F_w, 3),
    world_offsets (F_w,) [m])."""
    ids = state.shape_ids
    is_poly = family_mask(library.kind[ids], POLYHEDRON_FEATURES)
    body_vertex_start = np.zeros(state.n_bodies + 1, dtype=np.int64)
    np.cumsum(np.where(is_poly, library.vertex_count[ids], 0), out=body_vertex_start[1:])
    body_face_start = np.zeros(state.n_bodies + 1, dtype=np.int64)
    np.cumsum(np.where(is_poly, library.face_count[ids], 0), out=body_face_start[1:])
    world_vertices = np.empty((int(body_vertex_start[-1]), 3))
    world_normals = np.empty((int(body_face_start[-1]), 3))
    world_offsets = np.empty(int(body_face_start[-1]))
    if body_vertex_start[-1]:
        lib = ReadOnlyArrays(library)
        world_polyhedra_kernel(
            np.ascontiguousarray(state.positions), np.ascontiguousarray(state.orientations),
            ids, lib.vertex_start, lib.vertices, lib.face_start, lib.face_normals,
            lib.face_offsets, body_vertex_start, body_face_start, world_vertices,
            world_normals, world_offsets)
    return is_poly, body_vertex_start, world_vertices, body_face_start, world_normals, \
        world_offsets


def angle_tolerances(angle: float) -> tuple[float, float]:
    """(cos, sin) of the classification angle [rad]."""
    return math.cos(angle), math.sin(angle)
