"""Compiled kernels of the explicit soft-contact DEM step on member spheres (Numba; STYLE.md
2, 8): the contact forces of a neighbour list of sphere rows, registered as the list's force
pass of the sub-step loop (:func:`sphere_force_pass`;
:mod:`grainlab.engine.dem.substep_loop`, which moves the bodies and the boundary), and the
step report's copy of the closed rows (:mod:`grainlab.engine.dem.soft_contact`).

Contact list. Row k is a member pair (a of body i, b of body j) found within the skin at the
last detection: ``body_i`` (-1 - w for wall w), ``body_j``, member offsets in the body frames
``off_i``, ``off_j`` (C, 3) [m], radii ``rad_i``, ``rad_j`` (C,) [m] and image vector
``images`` (C, 3) (member b is at x_j + R_j off_j + h m_k). Each evaluation recomputes the
exact sphere-sphere or sphere-plane geometry of every row from the current configuration, so
the list stays valid while no two points have approached by more than the skin
(:func:`~grainlab.engine.dem.substep_loop.substeps_kernel` stops early when they might
have).

Gather. The forces of the rows are written per row and summed per body from a CSR list
(``adj_start`` (N + 1,), ``adj_entry``: 2 k for the j side of row k, 2 k + 1 for its i side),
always in the order of the list.

Threads. The rows are evaluated in blocks of :data:`ROW_BLOCK`, whose sums (the springs'
virial, the largest overlap) are added in block order; the bodies' side of a sub-step (gather,
kicks, drift, the cell's velocity gradient taken up) is body by body, in blocks of bodies
(:mod:`grainlab.engine.dem.body_pass`; as vector code for bodies of isotropic inertia:
:mod:`grainlab.engine.dem.sphere_bodies`). So the same sub-steps run on one thread
(:func:`contact_forces_kernel`, :func:`~grainlab.engine.dem.body_pass.bodies_kernel`) or on
several (:func:`contact_forces_parallel`, :func:`~grainlab.engine.dem.body_pass.
bodies_parallel`: ``parallel`` in :func:`~grainlab.engine.dem.substep_loop.substeps_kernel`)
with the same results, bit for bit, whatever the number of threads.
Each parallel loop costs ~0.02 ms to start with Numba's TBB layer on a
2-core machine, ~0.17 ms with workqueue (two per sub-step: the rows, then the bodies'
end of the sub-step and start of the next in one pass), so the threads pay from about
1000 bodies with TBB, 8000 with workqueue (:data:`~grainlab.engine.dem.soft_contact.
PARALLEL_BODIES`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainlab.contact.contact_kinematics import less_body_i, point_velocity, sphere_wall_gap
from grainlab.contact.rolling_resistance import rolling_spring
from grainlab.contact.soft_contact_law import contact_law
from grainlab.contact.tangential_spring import mindlin_coulomb
from grainlab.engine.boundaries.periodic_cell_face import branch
from grainlab.engine.dem.sphere_rows import sphere_rows_kernel
from grainlab.engine.dem.substep_arrays import ROW_BLOCK, SphereRowArrays
from grainlab.engine.dem.substep_loop import register_force_pass
from grainlab.engine.detect.narrow_phase import sphere_sphere
from grainlab.engine.quaternion import rotate


def body_rows(body_i: np.ndarray, body_j: np.ndarray, n_bodies: int
              ) -> tuple[np.ndarray, np.ndarray]:
    """The CSR list of the rows of each body that :func:`gather_kernel` reads: (adj_start
    (N + 1,), adj_entry) with entry 2 k for the j side of row k, 2 k + 1 for its i side (a row
    with a wall, body_i < 0, has only its j side), in the order of the rows."""
    adj_start = np.zeros(n_bodies + 1, dtype=np.int64)
    adj_entry = np.empty(body_j.shape[0] + int(np.count_nonzero(body_i >= 0)), dtype=np.int64)
    _body_rows_kernel(np.ascontiguousarray(body_i, dtype=np.int64),
                      np.ascontiguousarray(body_j, dtype=np.int64), adj_start, adj_entry)
    return adj_start, adj_entry


@njit(cache=True, _nrt=False)
def _body_rows_kernel(body_i, body_j, adj_start, adj_entry):
    """:func:`body_rows` by a counting sort: each body's entries in increasing order (rows
    in order, the j side 2 k before the i side 2 k + 1)."""
    n = adj_start.shape[0] - 1
    for k in range(body_j.shape[0]):
        adj_start[body_j[k] + 1] += 1
        if body_i[k] >= 0:
            adj_start[body_i[k] + 1] += 1
    for b in range(n):
        adj_start[b + 1] += adj_start[b]
    for k in range(body_j.shape[0]):  # adj_start[b] runs ahead as body b's entries fill
        j = body_j[k]
        adj_entry[adj_start[j]] = 2 * k
        adj_start[j] += 1
        i = body_i[k]
        if i >= 0:
            adj_entry[adj_start[i]] = 2 * k + 1
            adj_start[i] += 1
    for b in range(n, 0, -1):  # back to the starts
        adj_start[b] = adj_start[b - 1]
    adj_start[0] = 0


def plain_blocks(body_i: np.ndarray, off_i: np.ndarray, off_j: np.ndarray) -> np.ndarray:
    """Per block of :data:`ROW_BLOCK` rows, whether all its rows are plain: between two
    bodies (no wall), each member at its body's centre (no aggregate's member). Those blocks
    go through the vector force pass (:mod:`grainlab.engine.dem.sphere_rows`)."""
    plain = np.ones(-(-body_i.shape[0] // ROW_BLOCK), dtype=np.bool_)
    _plain_blocks_kernel(np.ascontiguousarray(body_i, dtype=np.int64),
                         np.ascontiguousarray(off_i, dtype=np.float64),
                         np.ascontiguousarray(off_j, dtype=np.float64), plain)
    return plain


@njit(cache=True, _nrt=False)
def _plain_blocks_kernel(body_i, off_i, off_j, plain):
    """:func:`plain_blocks` in one pass (``plain`` all true on entry)."""
    for k in range(body_i.shape[0]):
        if (body_i[k] < 0 or off_i[k, 0] != 0.0 or off_i[k, 1] != 0.0 or off_i[k, 2] != 0.0
                or off_j[k, 0] != 0.0 or off_j[k, 1] != 0.0 or off_j[k, 2] != 0.0):
            plain[k // ROW_BLOCK] = False


@njit(_nrt=False)
def _sphere_block(blk, step, record, code, params, body_i, body_j, rad_i, rad_j, images, mu,
                  inv_mass, positions, velocities, spins, cell_h, cell_rate, xi, force,
                  torque_i, torque_j, gap, normal, point, stiffness, rel_vel, springs,
                  partial):
    """The rows of block ``blk``, all plain, by the vector kernel
    (:func:`~grainlab.engine.dem.sphere_rows.sphere_rows_kernel`), then their springs' virial and
    largest overlap summed in row order into ``partial[blk]``: what :func:`_forces_block`
    writes, bit for bit."""
    lo, hi = blk * ROW_BLOCK, min((blk + 1) * ROW_BLOCK, body_j.shape[0])
    sphere_rows_kernel(lo, hi, step, record, code, params[0], body_i, body_j,
                       rad_i, rad_j, images.reshape(images.size), mu, inv_mass, positions,
                       velocities, spins, cell_h, cell_rate, xi.reshape(xi.size),
                       force.reshape(force.size), torque_i.reshape(torque_i.size),
                       torque_j.reshape(torque_j.size), gap, stiffness,
                       normal.reshape(normal.size), point.reshape(point.size),
                       rel_vel.reshape(rel_vel.size), springs.reshape(springs.size))
    v00 = v01 = v02 = v10 = v11 = v12 = v20 = v21 = v22 = worst = 0.0
    for k in range(lo, hi):
        if gap[k] >= 0.0:
            continue
        worst = max(worst, -gap[k])
        ex, ey, ez = springs[k, 0], springs[k, 1], springs[k, 2]
        lx, ly, lz = springs[k, 3], springs[k, 4], springs[k, 5]
        v00, v01, v02 = v00 + ex * lx, v01 + ex * ly, v02 + ex * lz
        v10, v11, v12 = v10 + ey * lx, v11 + ey * ly, v12 + ey * lz
        v20, v21, v22 = v20 + ez * lx, v21 + ez * ly, v22 + ez * lz
    partial[blk, 0], partial[blk, 1], partial[blk, 2] = v00, v01, v02
    partial[blk, 3], partial[blk, 4], partial[blk, 5] = v10, v11, v12
    partial[blk, 6], partial[blk, 7], partial[blk, 8] = v20, v21, v22
    partial[blk, 9] = worst


@njit(inline="always")
def _member_j(k, j, mx, my, mz, image, off_j, positions, orientations, cell_h):
    """Row k's body j through its image (x_j + h m, m = (mx, my, mz), if ``image``) and the
    centre of its member (the offset ``off_j[k]`` turned with the body) [m]: (jx, jy, jz, bx,
    by, bz)."""
    ox, oy, oz = off_j[k, 0], off_j[k, 1], off_j[k, 2]
    if ox != 0.0 or oy != 0.0 or oz != 0.0:  # a member off the centre (aggregates)
        qj = orientations[j]
        ox, oy, oz = rotate(qj[0], qj[1], qj[2], qj[3], ox, oy, oz)
    jx, jy, jz = positions[j, 0], positions[j, 1], positions[j, 2]
    if image:  # the image of body j: x_j + h m
        jx += cell_h[0, 0] * mx + cell_h[0, 1] * my + cell_h[0, 2] * mz
        jy += cell_h[1, 0] * mx + cell_h[1, 1] * my + cell_h[1, 2] * mz
        jz += cell_h[2, 0] * mx + cell_h[2, 1] * my + cell_h[2, 2] * mz
    return jx, jy, jz, jx + ox, jy + oy, jz + oz


@njit(inline="always")
def _release(k, rows):
    """Row k opened: its springs, force, moments and stiffness set to zero."""
    for a in range(3):
        rows.xi[k, a] = 0.0
        rows.roll[k, a] = 0.0
        rows.force[k, a] = 0.0
        rows.torque_i[k, a] = 0.0
        rows.torque_j[k, a] = 0.0
    rows.stiffness[k] = 0.0


@njit(inline="always")
def _moments(k, rows, turn, step, rolling, fx, fy, fz, rix, riy, riz, rjx, rjy, rjz, nx, ny,
             nz, spin_n, wx, wy, wz, s_n, r_eff, fn):
    """The moments [N m] of row k's force (fx, fy, fz) [N] on j at arm r_j and on i at arm
    r_i [m], with the rolling spring's moment (:func:`~grainlab.contact.rolling_resistance.
    rolling_spring`, the relative spin (wx, wy, wz) [rad/s] of j to i) if ``rolling`` > 0."""
    mjx, mjy, mjz = rjy * fz - rjz * fy, rjz * fx - rjx * fz, rjx * fy - rjy * fx
    mix, miy, miz = -(riy * fz - riz * fy), -(riz * fx - rix * fz), -(rix * fy - riy * fx)
    if rolling > 0.0:
        roll = rows.roll
        lx, ly, lz = rolling_spring(turn, step, roll[k, 0], roll[k, 1], roll[k, 2], nx, ny,
                                    nz, spin_n, wx, wy, wz, s_n, rolling, r_eff, fn)
        roll[k, 0], roll[k, 1], roll[k, 2] = lx, ly, lz
        mjx, mjy, mjz = mjx + lx, mjy + ly, mjz + lz
        mix, miy, miz = mix - lx, miy - ly, miz - lz
    rows.torque_j[k, 0], rows.torque_j[k, 1], rows.torque_j[k, 2] = mjx, mjy, mjz
    rows.torque_i[k, 0], rows.torque_i[k, 1], rows.torque_i[k, 2] = mix, miy, miz


@njit(_nrt=False)  # a call per block: more arguments than Python 3.11 lets Numba inline
def _forces_block(blk, step, record, code, params, rolling, rows, bodies, wall_p0, wall_n,
                  wall_disp, wall_speed, cell_h, cell_rate):
    """The rows of block ``blk`` (:func:`contact_forces_kernel`); their springs' virial into
    ``partial[blk, :9]`` (row-major), their largest overlap [m] into ``partial[blk, 9]``."""
    body_i, body_j, off_i, off_j = rows.body_i, rows.body_j, rows.off_i, rows.off_j
    rad_i, rad_j, images, mu = rows.rad_i, rows.rad_j, rows.images, rows.mu
    xi, force = rows.xi, rows.force
    gap, normal, point, stiffness, rel_vel = rows.gap, rows.normal, rows.point, \
        rows.stiffness, rows.rel_vel
    partial = rows.partial
    inv_mass, positions, orientations = bodies.inv_mass, bodies.positions, bodies.orientations
    velocities, spins = bodies.velocities, bodies.spins
    v00 = v01 = v02 = v10 = v11 = v12 = v20 = v21 = v22 = worst = 0.0
    for k in range(blk * ROW_BLOCK, min((blk + 1) * ROW_BLOCK, body_j.shape[0])):
        j = body_j[k]
        i = body_i[k]
        mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
        image = mx != 0.0 or my != 0.0 or mz != 0.0
        jx, jy, jz, bx, by, bz = _member_j(k, j, mx, my, mz, image, off_j, positions,
                                           orientations, cell_h)
        rb = rad_j[k]
        nx = ny = nz = cx = cy = cz = ra = 0.0
        if i >= 0:
            px_, py_, pz_ = off_i[k, 0], off_i[k, 1], off_i[k, 2]
            if px_ != 0.0 or py_ != 0.0 or pz_ != 0.0:
                qi = orientations[i]
                px_, py_, pz_ = rotate(qi[0], qi[1], qi[2], qi[3], px_, py_, pz_)
            ax, ay, az = positions[i, 0] + px_, positions[i, 1] + py_, positions[i, 2] + pz_
            ra = rad_i[k]
            dx, dy, dz = bx - ax, by - ay, bz - az
            reach = ra + rb
            d2 = dx * dx + dy * dy + dz * dz
            if d2 >= reach * reach:  # open (sphere_sphere's gap, without its normal)
                g = math.sqrt(d2) - reach
            else:
                g, nx, ny, nz, cx, cy, cz = sphere_sphere(ax, ay, az, ra, bx, by, bz, rb)
        else:
            w = -1 - i
            g, nx, ny, nz = sphere_wall_gap(bx, by, bz, rb, w, wall_n, wall_p0, wall_disp)
        gap[k] = g
        if g >= 0.0:  # open: the springs are released (once: an open row stays zero)
            if step == 0.0 or stiffness[k] != 0.0:
                _release(k, rows)
            continue
        if i >= 0:
            r_eff = ra * rb / (ra + rb)
            m_eff = 1.0 / (inv_mass[i] + inv_mass[j])
        else:
            s = rb + 0.5 * g
            cx, cy, cz = bx - s * nx, by - s * ny, bz - s * nz
            r_eff = rb
            m_eff = 1.0 / inv_mass[j]
        if record:
            normal[k, 0], normal[k, 1], normal[k, 2] = nx, ny, nz
            point[k, 0], point[k, 1], point[k, 2] = cx, cy, cz
        # relative velocity of j (image) with respect to i at the contact point
        rjx, rjy, rjz = cx - jx, cy - jy, cz - jz
        wjx, wjy, wjz = spins[j, 0], spins[j, 1], spins[j, 2]
        ux, uy, uz = point_velocity(velocities[j, 0], velocities[j, 1], velocities[j, 2],
                                    wjx, wjy, wjz, rjx, rjy, rjz)
        if image:
            ux += cell_rate[0, 0] * mx + cell_rate[0, 1] * my + cell_rate[0, 2] * mz
            uy += cell_rate[1, 0] * mx + cell_rate[1, 1] * my + cell_rate[1, 2] * mz
            uz += cell_rate[2, 0] * mx + cell_rate[2, 1] * my + cell_rate[2, 2] * mz
        ux, uy, uz, rix, riy, riz, wix, wiy, wiz = less_body_i(
            i, ux, uy, uz, cx, cy, cz, positions, velocities, spins, wall_n, wall_speed)
        if record:
            rel_vel[k, 0], rel_vel[k, 1], rel_vel[k, 2] = ux, uy, uz
        overlap = -g
        worst = max(worst, overlap)
        un = ux * nx + uy * ny + uz * nz
        utx, uty, utz = ux - un * nx, uy - un * ny, uz - un * nz
        fne, s_n, k_t, c_n, c_t = contact_law(code, params[0 if i >= 0 else 1], overlap, r_eff,
                                              m_eff)
        fn = max(0.0, fne - c_n * un)
        stiffness[k] = s_n
        turn = step > 0.0  # the springs carried with the contact frame and loaded
        spin_n = 0.5 * ((wix + wjx) * nx + (wiy + wjy) * ny + (wiz + wjz) * nz)
        ftx, fty, ftz, hx, hy, hz = mindlin_coulomb(turn, step, xi[k, 0], xi[k, 1], xi[k, 2],
                                                    nx, ny, nz, spin_n, utx, uty, utz, k_t,
                                                    c_t, mu[k] * fn)
        xi[k, 0], xi[k, 1], xi[k, 2] = hx, hy, hz
        fx, fy, fz = fn * nx + ftx, fn * ny + fty, fn * nz + ftz
        force[k, 0], force[k, 1], force[k, 2] = fx, fy, fz
        if i >= 0:
            lx, ly, lz = jx - positions[i, 0], jy - positions[i, 1], jz - positions[i, 2]
            ex, ey, ez = fne * nx + hx, fne * ny + hy, fne * nz + hz
            v00, v01, v02 = v00 + ex * lx, v01 + ex * ly, v02 + ex * lz
            v10, v11, v12 = v10 + ey * lx, v11 + ey * ly, v12 + ey * lz
            v20, v21, v22 = v20 + ez * lx, v21 + ez * ly, v22 + ez * lz
        _moments(k, rows, turn, step, rolling, fx, fy, fz, rix, riy, riz, rjx, rjy, rjz, nx,
                 ny, nz, spin_n, wjx - wix, wjy - wiy, wjz - wiz, s_n, r_eff, fn)
    partial[blk, 0], partial[blk, 1], partial[blk, 2] = v00, v01, v02
    partial[blk, 3], partial[blk, 4], partial[blk, 5] = v10, v11, v12
    partial[blk, 6], partial[blk, 7], partial[blk, 8] = v20, v21, v22
    partial[blk, 9] = worst


@njit(_nrt=False)
def _block(blk, step, record, code, params, rolling, rows, bodies, wall_p0, wall_n, wall_disp,
           wall_speed, cell_h, cell_rate):
    """Block ``blk`` of the rows: by the vector kernel if its rows are plain and there is no
    rolling resistance (:func:`_sphere_block`), else row by row (:func:`_forces_block`)."""
    if rows.plain[blk] and rolling == 0.0:
        _sphere_block(blk, step, record, code, params, rows.body_i, rows.body_j, rows.rad_i,
                      rows.rad_j, rows.images, rows.mu, bodies.inv_mass, bodies.positions,
                      bodies.velocities, bodies.spins, cell_h, cell_rate, rows.xi, rows.force,
                      rows.torque_i, rows.torque_j, rows.gap, rows.normal, rows.point,
                      rows.stiffness, rows.rel_vel, rows.springs, rows.partial)
    else:
        _forces_block(blk, step, record, code, params, rolling, rows, bodies, wall_p0, wall_n,
                      wall_disp, wall_speed, cell_h, cell_rate)


@njit(inline="always")
def _sum_blocks(partial, virial, stats):
    for blk in range(partial.shape[0]):
        stats[0] = max(stats[0], partial[blk, 9])
    for a in range(3):
        for b in range(3):
            total = 0.0
            for blk in range(partial.shape[0]):
                total += partial[blk, 3 * a + b]
            virial[a, b] = total


@njit(cache=True, _nrt=False)  # no reference counts on the array arguments (~5 %)
def contact_forces_kernel(step, record, code, params, rolling, rows, bodies, wall_p0, wall_n,
                          wall_disp, wall_speed, cell_h, cell_rate, virial, stats):
    """Geometry and force of every row k of the list ``rows``
    (:class:`~grainlab.engine.dem.substep_arrays.SphereRowArrays`) between the ``bodies``
    (:class:`~grainlab.engine.dem.substep_arrays.BodyArrays`) and with the walls (points
    ``wall_p0`` (W, 3) [m], normals ``wall_n``, displacements ``wall_disp`` (W,) [m], speeds
    ``wall_speed`` [m/s]) through the cell (``cell_h``, ``cell_rate`` (3, 3): h [m], hdot
    [m/s]) (module docstring of :mod:`grainlab.contact.soft_contact_law`); ``step`` [s] is
    the time since the last evaluation (0: the force of the current springs, nothing carried
    forward). Writes the rows' outputs (``gap`` of every row; normal, point and relative
    velocity of the closed ones (of every row in a plain block), and only if ``record``: the
    step report reads those of the step's last evaluation;
    an open row's force, moments, stiffness and springs are zero, written once when it opens, or
    at ``step`` 0); the histories ``xi`` (C, 3) [N] and ``roll`` (C, 3) [N m] are updated;
    ``virial`` (3, 3) [N m] becomes sum_k f_k (x) l_k over the rows between bodies, f_k the
    springs' force on j (the elastic normal force and the tangential spring, without the
    dashpots), l_k = x_j + h m_k - x_i the branch vector: V sigma of the springs, compression
    positive (summed by blocks of :data:`ROW_BLOCK` rows: ``partial`` (ceil(C / ROW_BLOCK), 10)
    scratch); ``stats[0]`` becomes the largest overlap [m] if larger. The blocks flagged in
    ``plain`` (ceil(C / ROW_BLOCK),) (:func:`plain_blocks`) go through the vector kernel of
    :mod:`grainlab.engine.dem.sphere_rows` when there is no rolling resistance (the same bits;
    ``springs`` (C, 6) scratch)."""
    for blk in range(rows.partial.shape[0]):
        _block(blk, step, record, code, params, rolling, rows, bodies, wall_p0, wall_n,
               wall_disp, wall_speed, cell_h, cell_rate)
    _sum_blocks(rows.partial, virial, stats)


@njit(cache=True, parallel=True, _nrt=False)
def contact_forces_parallel(step, record, code, params, rolling, rows, bodies, wall_p0, wall_n,
                            wall_disp, wall_speed, cell_h, cell_rate, virial, stats):
    """:func:`contact_forces_kernel` with its blocks on the threads (the same results)."""
    for blk in prange(rows.partial.shape[0]):  # prange's index is unsigned: cast
        _block(np.int64(blk), step, record, code, params, rolling, rows, bodies, wall_p0,
               wall_n, wall_disp, wall_speed, cell_h, cell_rate)
    _sum_blocks(rows.partial, virial, stats)


@njit(cache=True, _nrt=False)
def wall_loads_kernel(wall_rows, body_i, wall_n, force, stiffness, wall_force,
                      wall_stiffness):
    """Per wall w: the normal force R_w [N] of its rows (compression positive) and their
    normal stiffness K_w [N/m]."""
    wall_force[:] = 0.0
    wall_stiffness[:] = 0.0
    for e in range(wall_rows.shape[0]):
        k = wall_rows[e]
        w = -1 - body_i[k]
        wall_force[w] += (force[k, 0] * wall_n[w, 0] + force[k, 1] * wall_n[w, 1]
                          + force[k, 2] * wall_n[w, 2])
        wall_stiffness[w] += stiffness[k]


@njit(cache=True, _nrt=False)
def virial_kernel(body_i, body_j, images, force, positions, cell_h, virial):
    """``virial`` (3, 3) [N m] = sum_k f_k (x) l_k over the rows between bodies (f_k the
    force on j [N], l_k = x_j + h m_k - x_i the branch vector): V sigma, compression
    positive."""
    virial[:, :] = 0.0
    for k in range(body_j.shape[0]):
        i, j = body_i[k], body_j[k]
        if i < 0:
            continue
        lx, ly, lz = branch(k, i, j, images, positions, cell_h)
        for a in range(3):
            virial[a, 0] += force[k, a] * lx
            virial[a, 1] += force[k, a] * ly
            virial[a, 2] += force[k, a] * lz


@register_force_pass(SphereRowArrays)
@njit(cache=True, _nrt=False)
def sphere_force_pass(parallel, step, record, law, rows, bodies, walls, cell, virial, stats):
    """The force pass of the sphere rows in the sub-step loop
    (:func:`~grainlab.engine.dem.substep_loop.substeps_kernel`): the rows' forces (on the
    threads if ``parallel``: :func:`contact_forces_parallel`, else
    :func:`contact_forces_kernel`) and the walls' loads (:func:`wall_loads_kernel`); ``law``:
    (code, parameters, rolling coefficient)."""
    code, params, rolling = law
    if parallel:
        contact_forces_parallel(step, record, code, params, rolling, rows, bodies, walls.points,
                                walls.normals, walls.disp, walls.speed, cell.h, cell.rate,
                                virial, stats)
    else:
        contact_forces_kernel(step, record, code, params, rolling, rows, bodies, walls.points,
                              walls.normals, walls.disp, walls.speed, cell.h, cell.rate,
                              virial, stats)
    wall_loads_kernel(rows.wall_rows, rows.body_i, walls.normals, rows.force, rows.stiffness,
                      walls.force, walls.stiffness)


@njit(inline="always")
def _frame(nx, ny, nz):
    """The local frame (n, t, s) of a contact normal, as :func:`~grainlab.engine.
    contact_dynamics.contact_frames` builds it: t = n x e normalised (e the axis least
    aligned with n, the first of equals), s = n x t."""
    ax, ay, az = abs(nx), abs(ny), abs(nz)
    if ax <= ay and ax <= az:
        tx, ty, tz = 0.0, nz, -ny
    elif ay <= az:
        tx, ty, tz = -nz, 0.0, nx
    else:
        tx, ty, tz = ny, -nx, 0.0
    norm = math.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx / norm, ty / norm, tz / norm
    return tx, ty, tz, ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx


@njit(cache=True, _nrt=False)
def closed_rows_kernel(rows, body_i, body_j, member_i, member_j, contact_type, images, gap,
                       normal, point, force, rel_vel, dt, out_body_i, out_body_j,
                       out_member_i, out_member_j, out_type, out_images, out_gap, out_normal,
                       out_point, out_force, frames, impulses, relative):
    """For the rows ``rows`` of the list (the closed contacts), in one pass: their bodies,
    members, types, images, gaps, normals, points and forces (C, 3) [N] copied out, their
    local frames (C, 3, 3) (rows n, t, s), the impulses force x ``dt`` [N s] and relative
    velocities [m/s] in those frames (the step report of :mod:`grainlab.engine.
    soft_contact`)."""
    for c in range(rows.shape[0]):
        k = rows[c]
        out_body_i[c], out_body_j[c] = body_i[k], body_j[k]
        out_member_i[c], out_member_j[c] = member_i[k], member_j[k]
        out_type[c], out_gap[c] = contact_type[k], gap[k]
        nx, ny, nz = normal[k, 0], normal[k, 1], normal[k, 2]
        fx, fy, fz = force[k, 0], force[k, 1], force[k, 2]
        for a in range(3):
            out_images[c, a] = images[k, a]
            out_normal[c, a] = normal[k, a]
            out_point[c, a] = point[k, a]
            out_force[c, a] = force[k, a]
        tx, ty, tz, sx, sy, sz = _frame(nx, ny, nz)
        frames[c, 0, 0], frames[c, 0, 1], frames[c, 0, 2] = nx, ny, nz
        frames[c, 1, 0], frames[c, 1, 1], frames[c, 1, 2] = tx, ty, tz
        frames[c, 2, 0], frames[c, 2, 1], frames[c, 2, 2] = sx, sy, sz
        impulses[c, 0] = dt * (nx * fx + ny * fy + nz * fz)
        impulses[c, 1] = dt * (tx * fx + ty * fy + tz * fz)
        impulses[c, 2] = dt * (sx * fx + sy * fy + sz * fz)
        ux, uy, uz = rel_vel[k, 0], rel_vel[k, 1], rel_vel[k, 2]
        relative[c, 0] = nx * ux + ny * uy + nz * uz
        relative[c, 1] = tx * ux + ty * uy + tz * uz
        relative[c, 2] = sx * ux + sy * uy + sz * uz
