"""The arrays of the soft-contact (DEM) sub-steps grouped by what they describe, as NamedTuples
the compiled sub-step loop takes (Numba passes a NamedTuple of arrays as one argument): the
bodies (:class:`BodyArrays`) and the rows of a contact list, of member spheres
(:class:`SphereRowArrays`) or of polyhedra (:class:`PolyhedronPairArrays`);
the boundary's arrays are its face's
(:class:`~grainlab.engine.boundaries.wall_box_face.WallFace`,
:class:`~grainlab.engine.boundaries.periodic_cell_face.CellFace`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

ROW_BLOCK = 512
"""Rows per block of the force pass: the springs' virial is summed per block, then over the
blocks in order, whether the blocks run one after the other or on several threads (the same
sums, bit for bit, on any number of threads). Small, so that a few thousand rows still share
out evenly (8493 rows of 2000 spheres on 2 threads: blocks of 4096 gave 1.15x, of 512 1.7x)."""


class BodyArrays(NamedTuple):
    """The N bodies: constants, state (updated) and the loads of the last evaluation."""

    inv_mass: np.ndarray
    """(N,) [1/kg]."""
    masses: np.ndarray
    """(N,) [kg]."""
    principal: np.ndarray
    """(N, 3) [kg m^2] principal moments of inertia."""
    isotropic: np.ndarray
    """(N,) whether the three principal moments are equal."""
    arm: np.ndarray
    """(N,) [m] rotation arms (the farthest point contacts are computed from)."""
    plain_bodies: np.ndarray
    """Per block of bodies, whether all have isotropic inertia (the vector pass)."""
    positions: np.ndarray
    """(N, 3) [m]."""
    orientations: np.ndarray
    """(N, 4) unit quaternions."""
    velocities: np.ndarray
    """(N, 3) [m/s]."""
    spins: np.ndarray
    """(N, 3) [rad/s] angular velocities."""
    force: np.ndarray
    """(N, 3) [N] net force (contacts and weight)."""
    torque: np.ndarray
    """(N, 3) [N m] net moment."""
    travel: np.ndarray
    """(N,) [m] the largest displacement of a body's contact points since the list was
    built."""


class SphereRowArrays(NamedTuple):
    """The C rows of the sphere contact list (module docstring of
    :mod:`grainlab.engine.dem.soft_contact_kernels`): their description, histories, outputs and
    scratch."""

    body_i: np.ndarray
    body_j: np.ndarray
    off_i: np.ndarray
    off_j: np.ndarray
    rad_i: np.ndarray
    rad_j: np.ndarray
    images: np.ndarray
    mu: np.ndarray
    adj_start: np.ndarray
    adj_entry: np.ndarray
    wall_rows: np.ndarray
    xi: np.ndarray
    roll: np.ndarray
    force: np.ndarray
    torque_i: np.ndarray
    torque_j: np.ndarray
    gap: np.ndarray
    normal: np.ndarray
    point: np.ndarray
    stiffness: np.ndarray
    rel_vel: np.ndarray
    approach: np.ndarray
    partial: np.ndarray
    plain: np.ndarray
    springs: np.ndarray


class PolyhedronPairArrays(NamedTuple):
    """The P rows of a polyhedron contact list, one per body pair (module docstring of
    :mod:`grainlab.engine.dem.soft_polyhedra_kernels`): their description, springs, per-pair
    and per-point outputs (K the most points kept per pair), the shapes' geometry and
    scratch."""

    body_i: np.ndarray
    """(P,) body i, or -1 - w for wall w."""
    body_j: np.ndarray
    """(P,) body j, a polyhedron."""
    images: np.ndarray
    """(P, 3) image vector m of body j (x_j + h m)."""
    mu: np.ndarray
    """(P,) Coulomb coefficient."""
    r_eff: np.ndarray
    """(P,) [m] equivalent radius of the pair."""
    adj_start: np.ndarray
    adj_entry: np.ndarray
    wall_rows: np.ndarray
    xi: np.ndarray
    """(P, 3) [N] tangential springs (updated)."""
    force: np.ndarray
    torque_i: np.ndarray
    torque_j: np.ndarray
    normal: np.ndarray
    point: np.ndarray
    stiffness: np.ndarray
    rel_vel: np.ndarray
    approach: np.ndarray
    n_points: np.ndarray
    """(P,) the pair's penetrating points."""
    point_gap: np.ndarray
    point_normal: np.ndarray
    point_position: np.ndarray
    point_force: np.ndarray
    point_velocity: np.ndarray
    feature_i: np.ndarray
    feature_j: np.ndarray
    pair_type: np.ndarray
    shapes: tuple
    """(shape_ids, vertex_start, vertices, face_start, face_normals, face_offsets): the
    bodies' shapes in their own frames."""
    library: tuple
    """(shape_ids, face_start, face_count, face_vertex_start, face_vertices, edge_start,
    edge_count, edges, edge_faces, vertex_start, vertex_count, vertex_neighbour_start,
    vertex_neighbours): the shapes' topology."""
    world: tuple
    """(body_vertex_start, world_vertices, body_face_start, world_normals, world_offsets):
    the bodies in the world frame (written at each evaluation)."""
    tolerances: tuple
    """(cos, sin of the angle tolerance, most points kept) of the manifolds."""


def body_arrays(positions: np.ndarray, velocities: np.ndarray, spins: np.ndarray,
                inv_mass: np.ndarray, **given: np.ndarray) -> BodyArrays:
    """:class:`BodyArrays` of N bodies at ``positions`` (N, 3) [m] with ``velocities``,
    ``spins`` and ``inv_mass``; the other fields ``given`` by name or, if not, those of
    unturned spheres of unit moments of inertia, at rest (zero loads and travel), each block
    of bodies through the scalar pass."""
    from grainlab.engine.dem.body_pass import BODY_BLOCK

    n = positions.shape[0]
    arrays = {"inv_mass": inv_mass, "masses": 1.0 / inv_mass, "principal": np.ones((n, 3)),
              "isotropic": np.ones(n, dtype=np.bool_), "arm": np.zeros(n),
              "plain_bodies": np.zeros(-(-n // BODY_BLOCK), dtype=np.bool_),
              "positions": positions,
              "orientations": np.tile(np.array([1.0, 0.0, 0.0, 0.0]), (n, 1)),
              "velocities": velocities, "spins": spins, "force": np.zeros((n, 3)),
              "torque": np.zeros((n, 3)), "travel": np.zeros(n)} | given
    return BodyArrays(**{name: np.ascontiguousarray(arrays[name])
                         for name in BodyArrays._fields})


def sphere_row_arrays(body_i: np.ndarray, body_j: np.ndarray, rad_i: np.ndarray,
                      rad_j: np.ndarray, **given: np.ndarray) -> SphereRowArrays:
    """:class:`SphereRowArrays` of C rows between bodies ``body_i`` and ``body_j`` (C,) of
    member radii ``rad_i``, ``rad_j`` [m]; the other fields ``given`` by name or, if not, those
    of rows between the bodies' centres (no offsets, no images, mu 0), their springs unloaded,
    their outputs zero, every block through the general rows (the gather's list and the wall
    rows empty)."""
    c = body_j.shape[0]
    vectors = ("off_i", "off_j", "images", "xi", "roll", "force", "torque_i", "torque_j",
               "normal", "point", "rel_vel")
    arrays = {name: np.zeros((c, 3)) for name in vectors} | {
        "body_i": body_i, "body_j": body_j, "rad_i": rad_i, "rad_j": rad_j,
        "mu": np.zeros(c), "adj_start": np.zeros(1, dtype=np.int64),
        "adj_entry": np.zeros(0, dtype=np.int64), "wall_rows": np.zeros(0, dtype=np.int64),
        "gap": np.zeros(c), "stiffness": np.zeros(c), "approach": np.zeros(1),
        "partial": np.zeros((-(-c // ROW_BLOCK), 10)),
        "plain": np.zeros(-(-c // ROW_BLOCK), dtype=np.bool_), "springs": np.zeros((c, 6))} \
        | given
    return SphereRowArrays(**{name: np.ascontiguousarray(arrays[name])
                              for name in SphereRowArrays._fields})
