"""Compiled kernels of the soft-contact DEM step for convex polyhedra (Numba; STYLE.md 2, 8):
the contact force of every listed pair from its manifold recomputed at each sub-step,
registered as the list's force pass of the one sub-step loop (:func:`polyhedron_force_pass`,
:mod:`grainlab.engine.dem.substep_loop`; :mod:`grainlab.engine.dem.soft_polyhedra`, the
physics).

List (:class:`~grainlab.engine.dem.substep_arrays.PolyhedronPairArrays`). Row p is a body pair
found within the skin at the last detection: ``body_i`` (body i, or -1 - w for wall w),
``body_j`` (a polyhedron), the image vector ``images`` (P, 3) of body
j (x_j + h m_p), Coulomb coefficient ``mu`` (P,) and equivalent radius ``r_eff`` (P,) [m].
Each evaluation moves every polyhedron to the world frame (serial:
:func:`~grainlab.engine.detect.polyhedron_narrow_phase.world_polyhedron` per body, no thread
launch per sub-step), then recomputes the pair's gap and normal
(:func:`~grainlab.geometry.polyhedron_contact.signed_distance`) and its manifold
(:func:`~grainlab.geometry.polyhedron_manifold.pair_manifold`,
:func:`~grainlab.geometry.polyhedron_manifold.wall_manifold`) with a zero alert distance:
the exact narrow phase of contact dynamics, keeping the points that penetrate.

Outputs per pair: the force on j (P, 3) [N] (minus on i), the moments on i and j (P, 3)
[N m], the mean normal and point, the normal stiffness, the relative velocity at the mean
point; per closed manifold point (slot r < ``n_points[p]`` of (P, K) arrays, K the most
points kept): gap [m], normal, position [m], world force on j [N] (its normal force plus
its share of the pair's tangential force), relative velocity [m/s], feature ids and the
pair's type code. The loop gathers the pairs' loads on the bodies, kicks and drifts them and
moves the boundary as for the sphere rows; the pass also sums the walls' loads
(:func:`~grainlab.engine.dem.soft_contact_kernels.wall_loads_kernel`) and the stress of the
pairs' forces the periodic cell's servo reads
(:func:`~grainlab.engine.dem.soft_contact_kernels.virial_kernel`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainlab.contact.contact_kinematics import less_body_i, point_velocity
from grainlab.contact.soft_contact_law import contact_law
from grainlab.contact.tangential_spring import mindlin_coulomb
from grainlab.engine.dem.soft_contact_kernels import virial_kernel, wall_loads_kernel
from grainlab.engine.dem.substep_arrays import PolyhedronPairArrays
from grainlab.engine.dem.substep_loop import register_force_pass
from grainlab.engine.detect.polyhedron_narrow_phase import _body_features, world_polyhedron
from grainlab.geometry.polyhedron_contact import MAX_POINTS, signed_distance
from grainlab.geometry.polyhedron_manifold import pair_manifold, wall_manifold


# no reference counts on the arrays in the loop (inline helper): compiled without the Numba
# runtime (_nrt=False), as it allocates nothing
@njit(cache=True, _nrt=False)
def world_boundaries_kernel(positions, orientations, bodies, world):
    """Every polyhedron body moved to the world frame, one after the other (``bodies``:
    (shape_ids, vertex_start, vertices, face_start, face_normals, face_offsets); ``world``:
    (body_vertex_start, world_vertices, body_face_start, world_normals, world_offsets), the
    last three written)."""
    shape_ids, vertex_start, vertices, face_start, face_normals, face_offsets = bodies
    body_vertex_start, world_vertices, body_face_start, world_normals, world_offsets = world
    for n in range(positions.shape[0]):
        world_polyhedron(n, positions, orientations, shape_ids, vertex_start, vertices,
                         face_start, face_normals, face_offsets, body_vertex_start,
                         body_face_start, world_vertices, world_normals, world_offsets)


@njit(inline="always")
def _velocity_at(i, j, px, py, pz, cj, rate, positions, velocities, spins, wall_n, wall_speed):
    """Velocity (3 floats) [m/s] of body j's image (centre ``cj`` (3,), image speed ``rate``
    (3,)) relative to body i (or wall -1 - i) at the point p."""
    ux, uy, uz = point_velocity(velocities[j, 0], velocities[j, 1], velocities[j, 2],
                                spins[j, 0], spins[j, 1], spins[j, 2], px - cj[0], py - cj[1],
                                pz - cj[2])
    ux, uy, uz, _, _, _, _, _, _ = less_body_i(i, ux + rate[0], uy + rate[1], uz + rate[2],
                                               px, py, pz, positions, velocities, spins,
                                               wall_n, wall_speed)
    return ux, uy, uz


@njit(inline="always")
def _add_moment(torque, p, rx, ry, rz, fx, fy, fz, sign):
    torque[p, 0] += sign * (ry * fz - rz * fy)
    torque[p, 1] += sign * (rz * fx - rx * fz)
    torque[p, 2] += sign * (rx * fy - ry * fx)


@njit(cache=True)
def polyhedron_forces_kernel(step, code, params, library, world, pairs, tolerances, xi,
                             outputs, bodies, walls, cell, stats):
    """Manifold and force of every pair p of the list (module docstring; the law of
    :mod:`grainlab.engine.dem.soft_polyhedra`); ``step`` [s] is the time since the last
    evaluation (0: the force of the current springs). ``library``: (shape_ids, face_start,
    face_count, face_vertex_start, face_vertices, edge_start, edge_count, edges, edge_faces,
    vertex_start, vertex_count, vertex_neighbour_start, vertex_neighbours); ``world`` as
    :func:`world_boundaries_kernel`'s, filled. The tangential springs ``xi`` (P, 3) [N] are
    updated; ``stats[0]`` grows to the deepest penetration [m] met. ``pairs``: (pair_i,
    pair_j, images, mu, r_eff), ``tolerances``: (cos, sin of the angle tolerance, most points
    kept), ``outputs``: the per-pair and per-point outputs (module docstring: force,
    torque_i, torque_j, normal, point, stiffness, rel_vel, n_points, point_gap, point_normal,
    point_position, point_force, point_velocity, feature_i, feature_j, pair_type); the
    ``bodies`` (:class:`~grainlab.engine.dem.substep_arrays.BodyArrays`), the walls
    (:class:`~grainlab.engine.boundaries.wall_box_face.WallFace`) and the cell
    (:class:`~grainlab.engine.boundaries.periodic_cell_face.CellFace`) as they are now."""
    pair_i, pair_j, images, mu, r_eff = pairs
    cos_tol, sin_tol, max_points = tolerances
    (force, torque_i, torque_j, normal, point, stiffness, rel_vel, n_points, point_gap,
     point_normal, point_position, point_force, point_velocity, feature_i, feature_j,
     pair_type) = outputs
    inv_mass, positions, velocities, spins = bodies.inv_mass, bodies.positions, \
        bodies.velocities, bodies.spins
    wall_p0, wall_n, wall_disp, wall_speed = walls.points, walls.normals, walls.disp, \
        walls.speed
    cell_h, cell_rate = cell.h, cell.rate
    (shape_ids, face_start, face_count, face_vertex_start, face_vertices, edge_start,
     edge_count, edges, edge_faces, vertex_start, vertex_count, vertex_neighbour_start,
     vertex_neighbours) = library
    body_vertex_start, world_vertices, body_face_start, world_normals, world_offsets = world
    pts = np.empty((MAX_POINTS, 3))
    gps = np.empty(MAX_POINTS)
    nrm = np.empty((MAX_POINTS, 3))
    ida = np.empty(MAX_POINTS, dtype=np.int64)
    idb = np.empty(MAX_POINTS, dtype=np.int64)
    n_out = np.empty(3)
    cj = np.empty(3)
    rate = np.empty(3)
    wall_point = np.empty(3)
    shifted_v = np.empty((max(1, int(vertex_count.max())), 3))
    shifted_o = np.empty(max(1, int(face_count.max())))
    for p in range(pair_j.shape[0]):
        i, j = pair_i[p], pair_j[p]
        mx, my, mz = images[p, 0], images[p, 1], images[p, 2]
        imaged = mx != 0.0 or my != 0.0 or mz != 0.0
        for a in range(3):
            cj[a] = positions[j, a] + cell_h[a, 0] * mx + cell_h[a, 1] * my + cell_h[a, 2] * mz
            rate[a] = cell_rate[a, 0] * mx + cell_rate[a, 1] * my + cell_rate[a, 2] * mz
        vb, nb, ob, fsb, eb, efb, nsb = _body_features(
            j, shape_ids[j], body_vertex_start, world_vertices, body_face_start, world_normals,
            world_offsets, face_start, face_count, face_vertex_start, edge_start, edge_count,
            edges, edge_faces, vertex_start, vertex_count, vertex_neighbour_start)
        if imaged:  # body j's image
            _shift_image(vb, nb, ob, cj[0] - positions[j, 0], cj[1] - positions[j, 1],
                         cj[2] - positions[j, 2], shifted_v, shifted_o)
            vb = shifted_v[:vb.shape[0]]
            ob = shifted_o[:ob.shape[0]]
        count, kind = 0, 0
        if i >= 0:
            va, na, oa, fsa, ea, efa, nsa = _body_features(
                i, shape_ids[i], body_vertex_start, world_vertices, body_face_start,
                world_normals, world_offsets, face_start, face_count, face_vertex_start,
                edge_start, edge_count, edges, edge_faces, vertex_start, vertex_count,
                vertex_neighbour_start)
            g, found = signed_distance(
                va, na, oa, fsa, face_vertices, ea, efa, nsa, vertex_neighbours, positions[i],
                vb, nb, ob, fsb, face_vertices, eb, efb, nsb, vertex_neighbours, cj, 0.0, n_out)
            if found:
                count, kind = pair_manifold(
                    va, na, oa, fsa, face_vertices, ea, efa, nsa, vertex_neighbours,
                    vb, nb, ob, fsb, face_vertices, eb, efb, nsb, vertex_neighbours,
                    g, n_out, 0.0, cos_tol, sin_tol, max_points, pts, gps, nrm, ida, idb)
        else:
            w = -1 - i
            for a in range(3):
                wall_point[a] = wall_p0[w, a] + wall_disp[w] * wall_n[w, a]
            count, kind = wall_manifold(vb, nb, fsb, face_vertices, eb, nsb, vertex_neighbours,
                                        wall_point, wall_n[w], 0.0, cos_tol, sin_tol,
                                        max_points, pts, gps, idb)
            for r in range(count):
                nrm[r, 0], nrm[r, 1], nrm[r, 2] = wall_n[w, 0], wall_n[w, 1], wall_n[w, 2]
                ida[r] = -1
        closed, total, squares = _closed_points(
            p, count, pts, gps, nrm, ida, idb, point_gap, point_normal, point_position,
            feature_i, feature_j, stats)
        n_points[p] = closed
        pair_type[p] = kind
        if closed == 0:  # open: the spring is released
            _release(p, xi, stiffness, force, torque_i, torque_j, normal, point, rel_vel)
            continue
        row = 0 if i >= 0 else 1
        m_eff = 1.0 / (inv_mass[i] + inv_mass[j]) if i >= 0 else 1.0 / inv_mass[j]
        normal_sum = _normal_forces(
            p, i, j, closed, total, code, params[row], r_eff[p], m_eff, cj, rate, positions,
            velocities, spins, wall_n, wall_speed, point_gap, point_normal, point_position,
            point_velocity, point_force, force, torque_i, torque_j, normal, point)
        _tangential_force(p, i, j, step, closed, total, squares, code, params[row], r_eff[p],
                          m_eff, mu[p] * normal_sum, cj, rate, positions, velocities, spins,
                          wall_n, wall_speed, xi, point_gap, point_force, force, torque_i,
                          torque_j, normal, point, rel_vel, stiffness)


# The per-pair stages of the force kernel after its geometry: compiled functions without
# Numba's runtime (they allocate nothing), so that a call costs no reference counts on the
# arrays it is handed (the kernel itself allocates through the geometry and keeps the runtime)
@njit(inline="always")
def _shift_image(vb, nb, ob, sx, sy, sz, shifted_v, shifted_o):
    """A polyhedron's image shifted by (sx, sy, sz) = h m [m]: its vertices ``vb`` plus the
    shift into ``shifted_v``, its face offsets ``ob`` plus n . h m into ``shifted_o``."""
    for v in range(vb.shape[0]):
        shifted_v[v, 0] = vb[v, 0] + sx
        shifted_v[v, 1] = vb[v, 1] + sy
        shifted_v[v, 2] = vb[v, 2] + sz
    for f in range(ob.shape[0]):
        shifted_o[f] = ob[f] + nb[f, 0] * sx + nb[f, 1] * sy + nb[f, 2] * sz


@njit(inline="always")
def _closed_points(p, count, pts, gps, nrm, ida, idb, point_gap, point_normal, point_position,
                   feature_i, feature_j, stats):
    """The penetrating points of pair p's manifold (``count`` points of gap ``gps`` [m],
    position ``pts``, normal ``nrm``, features ``ida``, ``idb``) compacted into its slots;
    ``stats[0]`` grows to the deepest penetration [m]. Returns (closed points, the sum of
    their depths [m], the sum of their squares [m^2])."""
    closed, total, squares = 0, 0.0, 0.0
    for r in range(count):
        depth = -gps[r]
        if depth > 0.0:
            point_gap[p, closed] = gps[r]
            feature_i[p, closed], feature_j[p, closed] = ida[r], idb[r]
            for a in range(3):
                point_normal[p, closed, a] = nrm[r, a]
                point_position[p, closed, a] = pts[r, a]
            total += depth
            squares += depth * depth
            stats[0] = max(stats[0], depth)
            closed += 1
    return closed, total, squares


@njit(inline="always")
def _release(p, xi, stiffness, force, torque_i, torque_j, normal, point, rel_vel):
    """An open pair p: no force, no moment, its spring released."""
    xi[p, 0], xi[p, 1], xi[p, 2] = 0.0, 0.0, 0.0
    stiffness[p] = 0.0
    for a in range(3):
        force[p, a] = 0.0
        torque_i[p, a] = 0.0
        torque_j[p, a] = 0.0
        normal[p, a] = 0.0
        point[p, a] = 0.0
        rel_vel[p, a] = 0.0


@njit(inline="always")
def _normal_forces(p, i, j, closed, total, code, params, r_eff, m_eff, cj, rate, positions,
                   velocities, spins, wall_n, wall_speed, point_gap, point_normal,
                   point_position, point_velocity, point_force, force, torque_i, torque_j,
                   normal, point):
    """The normal force of each of pair p's ``closed`` points, its share depth / ``total``
    of the law's elastic force at the point's depth less the dashpot on the point's normal
    velocity (never pulling); the pair's force and moments start from their sum. The pair's
    normal and point are the shares' means. Returns the sum of the normal forces [N]."""
    for a in range(3):
        force[p, a] = 0.0
        torque_i[p, a] = 0.0
        torque_j[p, a] = 0.0
    normal_sum = 0.0
    bx, by, bz, nx, ny, nz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for r in range(closed):
        depth = -point_gap[p, r]
        share = depth / total
        qx, qy, qz = point_position[p, r, 0], point_position[p, r, 1], point_position[p, r, 2]
        ex, ey, ez = point_normal[p, r, 0], point_normal[p, r, 1], point_normal[p, r, 2]
        ux, uy, uz = _velocity_at(i, j, qx, qy, qz, cj, rate, positions, velocities, spins,
                                  wall_n, wall_speed)
        point_velocity[p, r, 0], point_velocity[p, r, 1], point_velocity[p, r, 2] = \
            ux, uy, uz
        fne, _, _, c_n, _ = contact_law(code, params, depth, r_eff, m_eff)
        f = max(0.0, share * (fne - c_n * (ux * ex + uy * ey + uz * ez)))
        normal_sum += f
        fx, fy, fz = f * ex, f * ey, f * ez
        point_force[p, r, 0], point_force[p, r, 1], point_force[p, r, 2] = fx, fy, fz
        force[p, 0] += fx
        force[p, 1] += fy
        force[p, 2] += fz
        _add_moment(torque_j, p, qx - cj[0], qy - cj[1], qz - cj[2], fx, fy, fz, 1.0)
        if i >= 0:
            _add_moment(torque_i, p, qx - positions[i, 0], qy - positions[i, 1],
                        qz - positions[i, 2], fx, fy, fz, -1.0)
        bx, by, bz = bx + share * qx, by + share * qy, bz + share * qz
        nx, ny, nz = nx + share * ex, ny + share * ey, nz + share * ez
    length = math.sqrt(nx * nx + ny * ny + nz * nz)
    normal[p, 0], normal[p, 1], normal[p, 2] = nx / length, ny / length, nz / length
    point[p, 0], point[p, 1], point[p, 2] = bx, by, bz
    return normal_sum


@njit(inline="always")
def _tangential_force(p, i, j, step, closed, total, squares, code, params, r_eff, m_eff,
                      limit, cj, rate, positions, velocities, spins, wall_n, wall_speed, xi,
                      point_gap, point_force, force, torque_i, torque_j, normal, point,
                      rel_vel, stiffness):
    """Pair p's one tangential spring at its mean point about its mean normal (the
    Mindlin-Coulomb spring of :func:`~grainlab.contact.tangential_spring.mindlin_coulomb`,
    capped at ``limit`` = mu times the normal force [N], stiffness at the root mean square
    depth), added to the pair's force and moments and shared over its ``closed`` points as
    their depths (report); the pair's normal stiffness S_n [N/m] written."""
    nx, ny, nz = normal[p, 0], normal[p, 1], normal[p, 2]
    bx, by, bz = point[p, 0], point[p, 1], point[p, 2]
    ux, uy, uz = _velocity_at(i, j, bx, by, bz, cj, rate, positions, velocities, spins,
                              wall_n, wall_speed)
    rel_vel[p, 0], rel_vel[p, 1], rel_vel[p, 2] = ux, uy, uz
    un = ux * nx + uy * ny + uz * nz
    utx, uty, utz = ux - un * nx, uy - un * ny, uz - un * nz
    _, s_n, k_t, _, c_t = contact_law(code, params, squares / total, r_eff, m_eff)
    stiffness[p] = s_n
    spin_n = spins[j, 0] * nx + spins[j, 1] * ny + spins[j, 2] * nz
    if i >= 0:
        spin_n += spins[i, 0] * nx + spins[i, 1] * ny + spins[i, 2] * nz
    ftx, fty, ftz, hx, hy, hz = mindlin_coulomb(step > 0.0, step, xi[p, 0], xi[p, 1],
                                                xi[p, 2], nx, ny, nz, 0.5 * spin_n, utx,
                                                uty, utz, k_t, c_t, limit)
    xi[p, 0], xi[p, 1], xi[p, 2] = hx, hy, hz
    force[p, 0] += ftx
    force[p, 1] += fty
    force[p, 2] += ftz
    _add_moment(torque_j, p, bx - cj[0], by - cj[1], bz - cj[2], ftx, fty, ftz, 1.0)
    if i >= 0:
        _add_moment(torque_i, p, bx - positions[i, 0], by - positions[i, 1],
                    bz - positions[i, 2], ftx, fty, ftz, -1.0)
    for r in range(closed):  # each point's share of the tangential force (report)
        share = -point_gap[p, r] / total
        point_force[p, r, 0] += share * ftx
        point_force[p, r, 1] += share * fty
        point_force[p, r, 2] += share * ftz


@register_force_pass(PolyhedronPairArrays, allocates=True)
@njit(cache=True)
def polyhedron_force_pass(parallel, step, record, law, pairs, bodies, walls, cell, virial,
                          stats):
    """The force pass of the polyhedron pairs in the sub-step loop
    (:func:`~grainlab.engine.dem.substep_loop.substeps_kernel`; serial, whatever
    ``parallel``; every evaluation recorded): the bodies moved to the world frame, the pairs'
    forces, the walls' loads and the pairs' virial (their whole forces: a pair's spring and
    dashpot are not kept apart, so the cell's servo reads both); ``law``: (code,
    parameters, rolling coefficient, 0 with polyhedra)."""
    code, params, _ = law
    world_boundaries_kernel(bodies.positions, bodies.orientations, pairs.shapes, pairs.world)
    outputs = (pairs.force, pairs.torque_i, pairs.torque_j, pairs.normal, pairs.point,
               pairs.stiffness, pairs.rel_vel, pairs.n_points, pairs.point_gap,
               pairs.point_normal, pairs.point_position, pairs.point_force,
               pairs.point_velocity, pairs.feature_i, pairs.feature_j, pairs.pair_type)
    polyhedron_forces_kernel(step, code, params, pairs.library, pairs.world,
                             (pairs.body_i, pairs.body_j, pairs.images, pairs.mu, pairs.r_eff),
                             pairs.tolerances, pairs.xi, outputs, bodies, walls, cell, stats)
    wall_loads_kernel(pairs.wall_rows, pairs.body_i, walls.normals, pairs.force,
                      pairs.stiffness, walls.force, walls.stiffness)
    virial_kernel(pairs.body_i, pairs.body_j, pairs.images, pairs.force, bodies.positions,
                  cell.h, virial)
