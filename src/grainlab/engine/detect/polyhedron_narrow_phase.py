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
from typing import NamedTuple

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


class WorldPolyhedra(NamedTuple):
    """The boundaries of the polyhedron bodies in the world frame (:func:`world_polyhedra`):
    ``is_poly`` (N,) bool, body n's vertices ``world_vertices`` (V_w, 3) [m] at rows
    ``body_vertex_start[n] .. body_vertex_start[n + 1] - 1``, its face normals
    ``world_normals`` (F_w, 3) and offsets ``world_offsets`` (F_w,) [m] at rows
    ``body_face_start[n] ..``."""

    is_poly: np.ndarray
    body_vertex_start: np.ndarray
    world_vertices: np.ndarray
    body_face_start: np.ndarray
    world_normals: np.ndarray
    world_offsets: np.ndarray


class ShapeTopology(NamedTuple):
    """The polyhedra's topology in local ids, per shape s of the
    :class:`~grainlab.engine.state.ShapeLibrary`: faces (``face_start``, ``face_count``,
    CSR ``face_vertex_start`` into ``face_vertices``), edges (``edge_start``, ``edge_count``,
    ``edges`` (E, 2), ``edge_faces`` (E, 2)) and vertex neighbours (``vertex_start``,
    ``vertex_count``, CSR ``vertex_neighbour_start`` into ``vertex_neighbours``)."""

    face_start: np.ndarray
    face_count: np.ndarray
    face_vertex_start: np.ndarray
    face_vertices: np.ndarray
    edge_start: np.ndarray
    edge_count: np.ndarray
    edges: np.ndarray
    edge_faces: np.ndarray
    vertex_start: np.ndarray
    vertex_count: np.ndarray
    vertex_neighbour_start: np.ndarray
    vertex_neighbours: np.ndarray

    @classmethod
    def of(cls, library) -> ShapeTopology:
        """The topology arrays of ``library`` as the kernels take them (read-only,
        C-contiguous)."""
        lib = ReadOnlyArrays(library)
        return cls(*(getattr(lib, name) for name in cls._fields))


class MemberSpheres(NamedTuple):
    """The member spheres in the world frame: body n's at rows ``body_start[n] ..
    body_start[n + 1] - 1`` of ``centres`` (S, 3) [m] and ``radii`` (S,) [m]."""

    body_start: np.ndarray
    centres: np.ndarray
    radii: np.ndarray


class ManifoldSettings(NamedTuple):
    """Alert distance ``alert`` [m], (cos, sin) of the classification angle ``cos_tol``,
    ``sin_tol``, and the most points of a manifold ``max_points``."""

    alert: float
    cos_tol: float
    sin_tol: float
    max_points: int


class ContactBuffers(NamedTuple):
    """The rows the narrow phase writes: ``body_i``, ``body_j``, ``member_i``, ``member_j``
    (R,) int64, ``point`` (R, 3) [m], ``normal`` (R, 3), ``gap`` (R,) [m], ``contact_type``
    (R,) (module docstring)."""

    body_i: np.ndarray
    body_j: np.ndarray
    member_i: np.ndarray
    member_j: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    contact_type: np.ndarray


@njit(inline="always")
def _store(row, bi, bj, mi, mj, g, n, p, code, rows):
    if row < rows.gap.shape[0]:
        rows.body_i[row] = bi
        rows.body_j[row] = bj
        rows.member_i[row] = mi
        rows.member_j[row] = mj
        rows.gap[row] = g
        for c in range(3):
            rows.normal[row, c] = n[c]
            rows.point[row, c] = p[c]
        rows.contact_type[row] = code


@njit(inline="always")
def _sphere_row(row, poly, other, a, poly_first, wv, wn, wo, fs, fv, ed, centre, radius,
                alert, rows):
    """One polyhedron-member-sphere row; ``poly_first`` says whether the polyhedron is
    body i. Returns the next row."""
    n = np.empty(3)
    p = np.empty(3)
    g, code, kind = sphere_contact(wv, wn, wo, fs, fv, ed, centre, radius, n, p)
    if g > alert:
        return row
    if poly_first:
        _store(row, poly, other, code, a, g, n, p, kind, rows)
    else:
        _store(row, other, poly, a, code, g, -n, p, kind, rows)
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


@njit(inline="always")
def _features(b, s, polyhedra, topology):
    """:func:`_body_features` of body b (shape s) from the :class:`WorldPolyhedra` and the
    :class:`ShapeTopology`."""
    t = topology
    return _body_features(b, s, polyhedra.body_vertex_start, polyhedra.world_vertices,
                          polyhedra.body_face_start, polyhedra.world_normals,
                          polyhedra.world_offsets, t.face_start, t.face_count,
                          t.face_vertex_start, t.edge_start, t.edge_count, t.edges,
                          t.edge_faces, t.vertex_start, t.vertex_count,
                          t.vertex_neighbour_start)


PARALLEL_PAIRS = 256
"""Fewest candidate pairs whose tests :func:`polyhedron_pairs_kernel` runs on the threads;
fewer run on the calling thread (a parallel region's start costs more than their tests, and
waits on every thread where the cores are shared)."""


@njit(inline="always")
def _pair_into_slots(p, pairs, shape_ids, positions, polyhedra, topology, settings, counts,
                     codes, pts, gps, ida, idb, nrm, n_out):
    """The test of candidate pair p when both bodies are polyhedra: its points into slots p
    of the scratch arrays and their count into ``counts[p]``, its type into ``codes[p]``."""
    i, j = pairs[p, 0], pairs[p, 1]
    if not (polyhedra.is_poly[i] and polyhedra.is_poly[j]):
        return
    fv, nbrs = topology.face_vertices, topology.vertex_neighbours
    va, na, oa, fsa, ea, efa, nsa = _features(i, shape_ids[i], polyhedra, topology)
    vb, nb, ob, fsb, eb, efb, nsb = _features(j, shape_ids[j], polyhedra, topology)
    g, found = signed_distance(
        va, na, oa, fsa, fv, ea, efa, nsa, nbrs, positions[i],
        vb, nb, ob, fsb, fv, eb, efb, nsb, nbrs, positions[j], settings.alert, n_out[p])
    if found:
        counts[p], codes[p] = pair_manifold(
            va, na, oa, fsa, fv, ea, efa, nsa, nbrs, vb, nb, ob, fsb, fv, eb, efb, nsb, nbrs,
            g, n_out[p], settings.alert, settings.cos_tol, settings.sin_tol,
            settings.max_points, pts[p], gps[p], nrm[p], ida[p], idb[p])


@njit(cache=True, parallel=True)
def polyhedron_pairs_kernel(pairs, shape_ids, positions, polyhedra, topology, spheres,
                            settings, start, rows, parallel_from=PARALLEL_PAIRS):
    """Contacts (gap <= ``settings.alert``) of the candidate pairs (P, 2) with at least one
    polyhedron (``polyhedra``: :class:`WorldPolyhedra`; ``topology``:
    :class:`ShapeTopology`; ``spheres``: :class:`MemberSpheres`; ``settings``:
    :class:`ManifoldSettings`) into ``rows`` (:class:`ContactBuffers`), written from row
    ``start``; returns start + rows needed.

    Two passes: the polyhedron-polyhedron pairs are tested, each into its own slots (at
    most ``MAX_POINTS`` points), on the threads from ``parallel_from`` pairs on
    (:data:`PARALLEL_PAIRS`); then every pair's rows are written in the pairs' order (a
    polyhedron-sphere pair's rows then, in that serial pass). Each pair's test is
    independent of the others, so the rows, their order and every bit of them do not depend
    on the number of threads."""
    is_poly, fv = polyhedra.is_poly, topology.face_vertices
    alert = settings.alert
    n_pairs = pairs.shape[0]
    counts = np.zeros(n_pairs, dtype=np.int64)
    codes = np.zeros(n_pairs, dtype=np.int64)
    pts = np.empty((n_pairs, MAX_POINTS, 3))
    gps = np.empty((n_pairs, MAX_POINTS))
    ida = np.empty((n_pairs, MAX_POINTS), dtype=np.int64)
    idb = np.empty((n_pairs, MAX_POINTS), dtype=np.int64)
    nrm = np.empty((n_pairs, MAX_POINTS, 3))
    n_out = np.empty((n_pairs, 3))
    if n_pairs >= parallel_from:
        for p in prange(n_pairs):
            _pair_into_slots(p, pairs, shape_ids, positions, polyhedra, topology, settings,
                             counts, codes, pts, gps, ida, idb, nrm, n_out)
    else:
        for p in range(n_pairs):
            _pair_into_slots(p, pairs, shape_ids, positions, polyhedra, topology, settings,
                             counts, codes, pts, gps, ida, idb, nrm, n_out)
    row = start
    for p in range(n_pairs):
        i, j = pairs[p, 0], pairs[p, 1]
        if is_poly[i] and is_poly[j]:
            for r in range(counts[p]):
                _store(row, i, j, ida[p, r], idb[p, r], gps[p, r], nrm[p, r], pts[p, r],
                       codes[p], rows)
                row += 1
        elif is_poly[i] or is_poly[j]:
            poly, other = (i, j) if is_poly[i] else (j, i)
            wv, wn, wo, fs, ed, _, _ = _features(poly, shape_ids[poly], polyhedra, topology)
            first = spheres.body_start[other]
            for a in range(first, spheres.body_start[other + 1]):
                row = _sphere_row(row, poly, other, a - first, poly == i, wv, wn, wo, fs, fv,
                                  ed, spheres.centres[a], spheres.radii[a], alert, rows)
    return row


@njit(cache=True)
def polyhedron_walls_kernel(wall_points, wall_normals, positions, bounding_radii, shape_ids,
                            polyhedra, topology, settings, start, rows):
    """Contacts (gap <= ``settings.alert``) of the polyhedron bodies (``polyhedra``,
    ``topology``: as :func:`polyhedron_pairs_kernel`) with plane walls (points (W, 3) [m],
    unit normals (W, 3)) into ``rows``; wall w is body_i = -1 - w, member_i = -1; member_j
    is a vertex id. Written from row ``start``; returns start + rows needed."""
    row = start
    t, bvs, bfs = topology, polyhedra.body_vertex_start, polyhedra.body_face_start
    pts = np.empty((MAX_POINTS, 3))
    gps = np.empty(MAX_POINTS)
    ids = np.empty(MAX_POINTS, dtype=np.int64)
    for w in range(wall_points.shape[0]):
        for n in range(positions.shape[0]):
            if not polyhedra.is_poly[n]:
                continue
            h = (positions[n] - wall_points[w]) @ wall_normals[w]
            if h - bounding_radii[n] > settings.alert:
                continue
            s = shape_ids[n]
            count, code = wall_manifold(
                polyhedra.world_vertices[bvs[n]:bvs[n + 1]],
                polyhedra.world_normals[bfs[n]:bfs[n + 1]],
                t.face_vertex_start[t.face_start[s]:t.face_start[s] + t.face_count[s] + 1],
                t.face_vertices, t.edges[t.edge_start[s]:t.edge_start[s] + t.edge_count[s]],
                t.vertex_neighbour_start[t.vertex_start[s]:t.vertex_start[s]
                                         + t.vertex_count[s] + 1],
                t.vertex_neighbours, wall_points[w], wall_normals[w], settings.alert,
                settings.cos_tol, settings.sin_tol, settings.max_points, pts, gps, ids)
            for r in range(count):
                _store(row, -1 - w, n, -1, ids[r], gps[r], wall_normals[w], pts[r], code, rows)
                row += 1
    return row


def world_polyhedra(state, library) -> WorldPolyhedra:
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
    return WorldPolyhedra(is_poly, body_vertex_start, world_vertices, body_face_start,
                          world_normals, world_offsets)


def angle_tolerances(angle: float) -> tuple[float, float]:
    """(cos, sin) of the classification angle [rad]."""
    return math.cos(angle), math.sin(angle)
