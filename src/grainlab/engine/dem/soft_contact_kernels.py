"""Compiled kernels of the explicit soft-contact DEM step (Numba; STYLE.md 2, 8):
contact forces on a neighbour list, their gather on the bodies, velocity-Verlet sub-steps with
quaternion rotations, servo walls and a servo cell (:mod:`grainlab.engine.dem.soft_contact`).

Contact list. Row k is a member pair (a of body i, b of body j) found within the skin at the
last detection: ``body_i`` (-1 - w for wall w), ``body_j``, member offsets in the body frames
``off_i``, ``off_j`` (C, 3) [m], radii ``rad_i``, ``rad_j`` (C,) [m] and image vector
``images`` (C, 3) (member b is at x_j + R_j off_j + h m_k). Each evaluation recomputes the
exact sphere-sphere or sphere-plane geometry of every row from the current configuration, so
the list stays valid while no two points have approached by more than the skin
(:func:`substeps_kernel` stops early when they might have).

Gather. The forces of the rows are written per row and summed per body from a CSR list
(``adj_start`` (N + 1,), ``adj_entry``: 2 k for the j side of row k, 2 k + 1 for its i side),
always in the order of the list.

Threads. The rows are evaluated in blocks of :data:`ROW_BLOCK`, whose sums (the springs'
virial, the largest overlap) are added in block order; the bodies' side of a sub-step (gather,
kicks, drift, the cell's velocity gradient taken up) is body by body, in blocks of
:data:`BODY_BLOCK` bodies (as vector code for bodies of isotropic inertia:
:mod:`grainlab.engine.dem.sphere_bodies`). So the same sub-steps run on one thread
(:func:`contact_forces_kernel`, :func:`bodies_kernel`) or on several
(:func:`contact_forces_parallel`, :func:`bodies_parallel`: ``parallel`` in
:func:`substeps_kernel`) with the same results, bit for bit, whatever the number of threads.
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
from grainlab.engine.dem.sphere_bodies import large_turns, sphere_bodies_kernel
from grainlab.engine.dem.sphere_rows import sphere_rows_kernel
from grainlab.engine.detect.narrow_phase import sphere_sphere
from grainlab.engine.quaternion import half_turn, rotate, turned

OUTWARD_FACTOR = 4.0
"""A servo wall or cell component moves out at most this many times its inward limit (as
contact dynamics' walls)."""


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


@njit(inline="always")
def _world_tensor(w, x, y, z, d0, d1, d2):
    """R diag(d0, d1, d2) R^T as its six entries (xx, yy, zz, yz, xz, xy): a body-frame
    diagonal tensor (principal moments of inertia [kg m^2] or their inverses) in the world
    frame, R the rotation of the unit quaternion (w, x, y, z)."""
    r00, r01, r02 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)
    r10, r11, r12 = 2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)
    r20, r21, r22 = 2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)
    return (r00 * r00 * d0 + r01 * r01 * d1 + r02 * r02 * d2,
            r10 * r10 * d0 + r11 * r11 * d1 + r12 * r12 * d2,
            r20 * r20 * d0 + r21 * r21 * d1 + r22 * r22 * d2,
            r10 * r20 * d0 + r11 * r21 * d1 + r12 * r22 * d2,
            r00 * r20 * d0 + r01 * r21 * d1 + r02 * r22 * d2,
            r00 * r10 * d0 + r01 * r11 * d1 + r02 * r12 * d2)


@njit(inline="always")
def _apply_tensor(t, vx, vy, vz):
    """The symmetric tensor t = (xx, yy, zz, yz, xz, xy) applied to (vx, vy, vz)."""
    return (t[0] * vx + t[5] * vy + t[4] * vz, t[5] * vx + t[1] * vy + t[3] * vz,
            t[4] * vx + t[3] * vy + t[2] * vz)


ROW_BLOCK = 512
"""Rows per block of the force pass: the springs' virial is summed per block, then over the
blocks in order, whether the blocks run one after the other or on several threads (the same
sums, bit for bit, on any number of threads). Small, so that a few thousand rows still share
out evenly (8493 rows of 2000 spheres on 2 threads: blocks of 4096 gave 1.15x, of 512 1.7x)."""


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


@njit(_nrt=False)  # a call per block: more arguments than Python 3.11 lets Numba inline
def _forces_block(blk, step, record, code, params, rolling, body_i, body_j, off_i, off_j,
                  rad_i, rad_j, images, mu, inv_mass, positions, orientations, velocities, spins,
                  wall_p0, wall_n, wall_disp, wall_speed, cell_h, cell_rate, xi, roll, force,
                  torque_i, torque_j, gap, normal, point, stiffness, rel_vel, partial):
    """The rows of block ``blk`` (:func:`contact_forces_kernel`); their springs' virial into
    ``partial[blk, :9]`` (row-major), their largest overlap [m] into ``partial[blk, 9]``."""
    v00 = v01 = v02 = v10 = v11 = v12 = v20 = v21 = v22 = worst = 0.0
    for k in range(blk * ROW_BLOCK, min((blk + 1) * ROW_BLOCK, body_j.shape[0])):
        j = body_j[k]
        i = body_i[k]
        mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
        ox, oy, oz = off_j[k, 0], off_j[k, 1], off_j[k, 2]
        if ox != 0.0 or oy != 0.0 or oz != 0.0:  # a member off the centre (aggregates)
            qj = orientations[j]
            ox, oy, oz = rotate(qj[0], qj[1], qj[2], qj[3], ox, oy, oz)
        jx, jy, jz = positions[j, 0], positions[j, 1], positions[j, 2]
        image = mx != 0.0 or my != 0.0 or mz != 0.0
        if image:  # the image of body j: x_j + h m
            jx += cell_h[0, 0] * mx + cell_h[0, 1] * my + cell_h[0, 2] * mz
            jy += cell_h[1, 0] * mx + cell_h[1, 1] * my + cell_h[1, 2] * mz
            jz += cell_h[2, 0] * mx + cell_h[2, 1] * my + cell_h[2, 2] * mz
        bx, by, bz = jx + ox, jy + oy, jz + oz
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
                xi[k, 0], xi[k, 1], xi[k, 2] = 0.0, 0.0, 0.0
                roll[k, 0], roll[k, 1], roll[k, 2] = 0.0, 0.0, 0.0
                force[k, 0], force[k, 1], force[k, 2] = 0.0, 0.0, 0.0
                torque_i[k, 0], torque_i[k, 1], torque_i[k, 2] = 0.0, 0.0, 0.0
                torque_j[k, 0], torque_j[k, 1], torque_j[k, 2] = 0.0, 0.0, 0.0
                stiffness[k] = 0.0
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
        mjx, mjy, mjz = rjy * fz - rjz * fy, rjz * fx - rjx * fz, rjx * fy - rjy * fx
        mix, miy, miz = -(riy * fz - riz * fy), -(riz * fx - rix * fz), -(rix * fy - riy * fx)
        if rolling > 0.0:
            lx, ly, lz = rolling_spring(turn, step, roll[k, 0], roll[k, 1], roll[k, 2], nx, ny,
                                        nz, spin_n, wjx - wix, wjy - wiy, wjz - wiz, s_n,
                                        rolling, r_eff, fn)
            roll[k, 0], roll[k, 1], roll[k, 2] = lx, ly, lz
            mjx, mjy, mjz = mjx + lx, mjy + ly, mjz + lz
            mix, miy, miz = mix - lx, miy - ly, miz - lz
        torque_j[k, 0], torque_j[k, 1], torque_j[k, 2] = mjx, mjy, mjz
        torque_i[k, 0], torque_i[k, 1], torque_i[k, 2] = mix, miy, miz
    partial[blk, 0], partial[blk, 1], partial[blk, 2] = v00, v01, v02
    partial[blk, 3], partial[blk, 4], partial[blk, 5] = v10, v11, v12
    partial[blk, 6], partial[blk, 7], partial[blk, 8] = v20, v21, v22
    partial[blk, 9] = worst


@njit(_nrt=False)
def _block(blk, step, record, code, params, rolling, body_i, body_j, off_i, off_j, rad_i, rad_j,
           images, mu, inv_mass, positions, orientations, velocities, spins, wall_p0, wall_n,
           wall_disp, wall_speed, cell_h, cell_rate, xi, roll, force, torque_i, torque_j, gap,
           normal, point, stiffness, rel_vel, partial, plain, springs):
    """Block ``blk`` of the rows: by the vector kernel if its rows are plain and there is no
    rolling resistance (:func:`_sphere_block`), else row by row (:func:`_forces_block`)."""
    if plain[blk] and rolling == 0.0:
        _sphere_block(blk, step, record, code, params, body_i, body_j, rad_i, rad_j, images,
                      mu, inv_mass, positions, velocities, spins, cell_h, cell_rate, xi, force,
                      torque_i, torque_j, gap, normal, point, stiffness, rel_vel, springs,
                      partial)
    else:
        _forces_block(blk, step, record, code, params, rolling, body_i, body_j, off_i, off_j,
                      rad_i, rad_j, images, mu, inv_mass, positions, orientations, velocities,
                      spins, wall_p0, wall_n, wall_disp, wall_speed, cell_h, cell_rate, xi,
                      roll, force, torque_i, torque_j, gap, normal, point, stiffness, rel_vel,
                      partial)


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
def contact_forces_kernel(step, record, code, params, rolling, body_i, body_j, off_i, off_j,
                          rad_i, rad_j, images, mu, inv_mass, positions, orientations, velocities,
                          spins, wall_p0, wall_n, wall_disp, wall_speed, cell_h, cell_rate,
                          xi, roll, force, torque_i, torque_j, gap, normal, point, stiffness,
                          rel_vel, virial, partial, stats, plain, springs):
    """Geometry and force of every row k of the list (module docstring of
    :mod:`grainlab.contact.soft_contact_law`); ``step`` [s] is the time since the last
    evaluation (0: the force of the current springs, nothing carried forward). Writes the rows'
    outputs (``gap`` of every row; normal, point and relative velocity of the closed ones (of
    every row in a plain block), and only if ``record``: the step report reads those of the
    step's last evaluation;
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
    for blk in range(partial.shape[0]):
        _block(blk, step, record, code, params, rolling, body_i, body_j, off_i, off_j, rad_i,
               rad_j, images, mu, inv_mass, positions, orientations, velocities, spins, wall_p0,
               wall_n, wall_disp, wall_speed, cell_h, cell_rate, xi, roll, force, torque_i,
               torque_j, gap, normal, point, stiffness, rel_vel, partial, plain, springs)
    _sum_blocks(partial, virial, stats)


@njit(cache=True, parallel=True, _nrt=False)
def contact_forces_parallel(step, record, code, params, rolling, body_i, body_j, off_i,
                            off_j, rad_i, rad_j, images, mu, inv_mass, positions, orientations,
                            velocities, spins, wall_p0, wall_n, wall_disp, wall_speed, cell_h,
                            cell_rate, xi, roll, force, torque_i, torque_j, gap, normal, point,
                            stiffness, rel_vel, virial, partial, stats, plain, springs):
    """:func:`contact_forces_kernel` with its blocks on the threads (the same results)."""
    for blk in prange(partial.shape[0]):  # prange's index is unsigned: cast, one signature
        _block(np.int64(blk), step, record, code, params, rolling, body_i, body_j, off_i,
               off_j, rad_i, rad_j, images, mu, inv_mass, positions, orientations, velocities,
               spins, wall_p0, wall_n, wall_disp, wall_speed, cell_h, cell_rate, xi, roll,
               force, torque_i, torque_j, gap, normal, point, stiffness, rel_vel, partial,
               plain, springs)
    _sum_blocks(partial, virial, stats)


@njit(inline="always")
def _gather_body(b, adj_start, adj_entry, force, torque_i, torque_j, masses, gravity,
                 body_force, body_torque):
    fx, fy, fz = masses[b] * gravity[0], masses[b] * gravity[1], masses[b] * gravity[2]
    tx, ty, tz = 0.0, 0.0, 0.0
    for e in range(adj_start[b], adj_start[b + 1]):
        entry = adj_entry[e]
        k = entry >> 1
        if entry & 1 == 0:
            fx, fy, fz = fx + force[k, 0], fy + force[k, 1], fz + force[k, 2]
            tx, ty, tz = tx + torque_j[k, 0], ty + torque_j[k, 1], tz + torque_j[k, 2]
        else:
            fx, fy, fz = fx - force[k, 0], fy - force[k, 1], fz - force[k, 2]
            tx, ty, tz = tx + torque_i[k, 0], ty + torque_i[k, 1], tz + torque_i[k, 2]
    body_force[b, 0], body_force[b, 1], body_force[b, 2] = fx, fy, fz
    body_torque[b, 0], body_torque[b, 1], body_torque[b, 2] = tx, ty, tz


@njit(cache=True, _nrt=False)
def gather_kernel(adj_start, adj_entry, force, torque_i, torque_j, masses, gravity,
                  body_force, body_torque):
    """Net force (N, 3) [N] (contacts and weight m g) and moment (N, 3) [N m] on each body,
    summed in list order (module docstring)."""
    for b in range(masses.shape[0]):
        _gather_body(b, adj_start, adj_entry, force, torque_i, torque_j, masses, gravity,
                     body_force, body_torque)


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


@njit(inline="always")
def _kick_body(b, half, inv_mass, principal, isotropic, local_damping, orientations,
               body_force, body_torque, velocities, spins):
    fx, fy, fz = body_force[b, 0], body_force[b, 1], body_force[b, 2]
    tx, ty, tz = body_torque[b, 0], body_torque[b, 1], body_torque[b, 2]
    if local_damping > 0.0:
        fx -= local_damping * abs(fx) * np.sign(velocities[b, 0])
        fy -= local_damping * abs(fy) * np.sign(velocities[b, 1])
        fz -= local_damping * abs(fz) * np.sign(velocities[b, 2])
        tx -= local_damping * abs(tx) * np.sign(spins[b, 0])
        ty -= local_damping * abs(ty) * np.sign(spins[b, 1])
        tz -= local_damping * abs(tz) * np.sign(spins[b, 2])
    f = half * inv_mass[b]
    velocities[b, 0] += f * fx
    velocities[b, 1] += f * fy
    velocities[b, 2] += f * fz
    if isotropic[b]:
        f = half / principal[b, 0]
        spins[b, 0] += f * tx
        spins[b, 1] += f * ty
        spins[b, 2] += f * tz
    else:
        q = orientations[b]
        inverse = _world_tensor(q[0], q[1], q[2], q[3], 1.0 / principal[b, 0],
                                1.0 / principal[b, 1], 1.0 / principal[b, 2])
        ax, ay, az = _apply_tensor(inverse, tx, ty, tz)
        spins[b, 0] += half * ax
        spins[b, 1] += half * ay
        spins[b, 2] += half * az


@njit(cache=True, _nrt=False)
def kick_kernel(half, inv_mass, principal, isotropic, local_damping, orientations,
                body_force, body_torque, velocities, spins):
    """Half kick of velocity Verlet: v += (h/2) F / m, omega += (h/2) I_w^-1 T (``half`` =
    h/2 [s]), F and T reduced by the local damping alpha |F| sign(v) per component."""
    for b in range(inv_mass.shape[0]):
        _kick_body(b, half, inv_mass, principal, isotropic, local_damping, orientations,
                   body_force, body_torque, velocities, spins)


@njit(inline="always")
def _drift_body(b, dt, principal, isotropic, arm, positions, orientations, velocities,
                spins, travel):
    ex, ey, ez = dt * velocities[b, 0], dt * velocities[b, 1], dt * velocities[b, 2]
    positions[b, 0] += ex
    positions[b, 1] += ey
    positions[b, 2] += ez
    wx, wy, wz = spins[b, 0], spins[b, 1], spins[b, 2]
    spin = math.sqrt(wx * wx + wy * wy + wz * wz)
    travel[b] += math.sqrt(ex * ex + ey * ey + ez * ez) + spin * dt * arm[b]
    if spin == 0.0:
        return
    w, x, y, z = orientations[b, 0], orientations[b, 1], orientations[b, 2], \
        orientations[b, 3]
    lx, ly, lz = wx, wy, wz
    if not isotropic[b]:  # L = I_w omega before the turn
        inertia = _world_tensor(w, x, y, z, principal[b, 0], principal[b, 1],
                                principal[b, 2])
        lx, ly, lz = _apply_tensor(inertia, wx, wy, wz)
    dw, sinc = half_turn(0.5 * spin * dt)
    # sin(h |omega| / 2) / |omega|
    nw, nx, ny, nz = turned(w, x, y, z, dw, sinc * 0.5 * dt, wx, wy, wz)
    orientations[b, 0], orientations[b, 1] = nw, nx
    orientations[b, 2], orientations[b, 3] = ny, nz
    if not isotropic[b]:
        inverse = _world_tensor(nw, nx, ny, nz, 1.0 / principal[b, 0],
                                1.0 / principal[b, 1], 1.0 / principal[b, 2])
        spins[b, 0], spins[b, 1], spins[b, 2] = _apply_tensor(inverse, lx, ly, lz)


@njit(cache=True, _nrt=False)
def drift_kernel(dt, principal, isotropic, arm, positions, orientations, velocities,
                 spins, travel):
    """Drift: x += h v; q <- exp(h omega / 2) q (world frame); a body with anisotropic
    inertia keeps its angular momentum L = I_w omega through the turn, so omega follows the
    new orientation (torque-free precession). ``travel`` (N,) [m] grows by the largest
    displacement of a point its contacts are computed from (|dx| + |omega| h ``arm``, the
    rotation arms of :func:`grainlab.engine.dem.soft_contact.rotation_arms`)."""
    for b in range(positions.shape[0]):
        _drift_body(b, dt, principal, isotropic, arm, positions, orientations,
                    velocities, spins, travel)


@njit(inline="always")
def _body_pass(b, close, carry, open_, half, dt, adj_start, adj_entry, force, torque_i,
               torque_j, masses, gravity, inv_mass, principal, isotropic, local_damping,
               arm, gradient, carried, cx, cy, cz, positions, orientations, velocities,
               spins, body_force, body_torque, travel):
    if close:  # the end of a sub-step: the rows' forces gathered, the half kick
        _gather_body(b, adj_start, adj_entry, force, torque_i, torque_j, masses, gravity,
                     body_force, body_torque)
        _kick_body(b, half, inv_mass, principal, isotropic, local_damping, orientations,
                   body_force, body_torque, velocities, spins)
    if carry:  # a change of the cell's velocity gradient taken up
        _carry_body(b, gradient, carried, cx, cy, cz, positions, velocities)
    if open_:  # the start of the next: the half kick, the drift
        _kick_body(b, half, inv_mass, principal, isotropic, local_damping, orientations,
                   body_force, body_torque, velocities, spins)
        _drift_body(b, dt, principal, isotropic, arm, positions, orientations,
                    velocities, spins, travel)


BODY_BLOCK = 512
"""Bodies per block of the bodies' pass of a sub-step: the threads' units of work, and the
runs of bodies that go through the vector kernel of :mod:`grainlab.engine.dem.sphere_bodies`
when they all have isotropic inertia (:func:`isotropic_blocks`)."""


def isotropic_blocks(isotropic: np.ndarray) -> np.ndarray:
    """Per block of :data:`BODY_BLOCK` bodies, whether all its bodies have isotropic inertia
    (spheres, and shapes whose principal moments are equal)."""
    n_blocks = -(-isotropic.shape[0] // BODY_BLOCK)
    padded = np.ones(n_blocks * BODY_BLOCK, dtype=np.bool_)
    padded[:isotropic.shape[0]] = isotropic
    return np.ascontiguousarray(padded.reshape(n_blocks, BODY_BLOCK).all(axis=1))


@njit(_nrt=False)
def _bodies_block(blk, close, carry, open_, half, dt, adj_start, adj_entry, force, torque_i,
                  torque_j, masses, gravity, inv_mass, principal, isotropic, local_damping, arm,
                  gradient, carried, cx, cy, cz, positions, orientations, velocities, spins,
                  body_force, body_torque, travel, plain):
    """The bodies of block ``blk``: through the vector kernel (after the gather, then
    :func:`~grainlab.engine.dem.sphere_bodies.large_turns`) if they are all of isotropic inertia
    (``plain[blk]``) and there is no local damping, else body by body; the same bits."""
    lo, hi = blk * BODY_BLOCK, min((blk + 1) * BODY_BLOCK, masses.shape[0])
    if plain[blk] and local_damping == 0.0:
        if close:
            for b in range(lo, hi):
                _gather_body(b, adj_start, adj_entry, force, torque_i, torque_j, masses,
                             gravity, body_force, body_torque)
        left = sphere_bodies_kernel(lo, hi, close, carry, open_, half, dt, inv_mass,
                                    principal.reshape(principal.size), arm,
                                    gradient.reshape(9), carried.reshape(9), cx, cy, cz,
                                    body_force.reshape(body_force.size),
                                    body_torque.reshape(body_torque.size),
                                    positions.reshape(positions.size),
                                    orientations.reshape(orientations.size),
                                    velocities.reshape(velocities.size),
                                    spins.reshape(spins.size), travel)
        if left > 0:
            large_turns(lo, hi, dt, orientations, spins)
    else:
        for b in range(lo, hi):
            _body_pass(b, close, carry, open_, half, dt, adj_start, adj_entry, force,
                       torque_i, torque_j, masses, gravity, inv_mass, principal, isotropic,
                       local_damping, arm, gradient, carried, cx, cy, cz, positions,
                       orientations, velocities, spins, body_force, body_torque, travel)


@njit(cache=True, _nrt=False)
def bodies_kernel(close, carry, open_, half, dt, adj_start, adj_entry, force, torque_i,
                  torque_j, masses, gravity, inv_mass, principal, isotropic, local_damping,
                  arm, gradient, carried, cx, cy, cz, positions, orientations,
                  velocities, spins, body_force, body_torque, travel, plain):
    """The bodies' side of the sub-steps, body by body: with ``close`` the gather and the
    half kick that end a sub-step (:func:`gather_kernel`, :func:`kick_kernel`), with
    ``carry`` the change of the cell's velocity gradient taken up (v += (L - L_carried)
    (x - x_c), x_c = (``cx``, ``cy``, ``cz``) [m]: :func:`carry_gradient_kernel`), with
    ``open_`` the half kick and the drift that start the next (:func:`kick_kernel`,
    :func:`drift_kernel`), in that order. Each body's operations are those of the separate
    kernels, in their order: the same bits. In blocks of :data:`BODY_BLOCK` bodies, those
    flagged in ``plain`` (:func:`isotropic_blocks`) as vector code (:func:`_bodies_block`)."""
    for blk in range(plain.shape[0]):
        _bodies_block(blk, close, carry, open_, half, dt, adj_start, adj_entry, force,
                      torque_i, torque_j, masses, gravity, inv_mass, principal, isotropic,
                      local_damping, arm, gradient, carried, cx, cy, cz, positions,
                      orientations, velocities, spins, body_force, body_torque, travel, plain)


@njit(cache=True, parallel=True, _nrt=False)
def bodies_parallel(close, carry, open_, half, dt, adj_start, adj_entry, force, torque_i,
                    torque_j, masses, gravity, inv_mass, principal, isotropic, local_damping,
                    arm, gradient, carried, cx, cy, cz, positions, orientations,
                    velocities, spins, body_force, body_torque, travel, plain):
    """:func:`bodies_kernel` with the blocks of bodies shared out over the threads (the same
    results: the bodies do not interact in it)."""
    for blk in prange(plain.shape[0]):
        _bodies_block(np.int64(blk), close, carry, open_, half, dt, adj_start, adj_entry,
                      force, torque_i, torque_j, masses, gravity, inv_mass, principal,
                      isotropic, local_damping, arm, gradient, carried, cx, cy, cz, positions,
                      orientations, velocities, spins, body_force, body_torque, travel, plain)


@njit(_nrt=False)  # a call: more arguments than Python 3.11 lets Numba inline
def _bodies(parallel, close, carry, open_, half, dt, adj_start, adj_entry, force, torque_i,
            torque_j, masses, gravity, inv_mass, principal, isotropic, local_damping, arm,
            gradient, carried, cx, cy, cz, positions, orientations, velocities, spins,
            body_force, body_torque, travel, plain):
    if parallel:
        bodies_parallel(close, carry, open_, half, dt, adj_start, adj_entry, force, torque_i,
                        torque_j, masses, gravity, inv_mass, principal, isotropic,
                        local_damping, arm, gradient, carried, cx, cy, cz, positions,
                        orientations, velocities, spins, body_force, body_torque, travel,
                        plain)
    else:
        bodies_kernel(close, carry, open_, half, dt, adj_start, adj_entry, force, torque_i,
                      torque_j, masses, gravity, inv_mass, principal, isotropic, local_damping,
                      arm, gradient, carried, cx, cy, cz, positions, orientations,
                      velocities, spins, body_force, body_torque, travel, plain)


SUBSTEP_SERVO_FRACTION = 0.1
"""Fraction of a stiff load's error a servo wall corrects per sub-step (:func:`servo_walls`;
as YADE's ``wallDamping`` of its triaxial stress controller). With 0.25 a compaction of 24
Hertz spheres and one of 60 linear ones stalled 2-4 % below sigma0 (likely the walls
chattering against their few contacts, a wall moving in no faster than its bound but out four
times faster); 0.1 settled every case tried (24-300 spheres, kappa 1e3-1e5)."""

SERVO_INTEGRAL = 0.3
"""Fraction of its proportional correction a servo adds to its memory each step (the integral
term), weighted by how much the contacts' stiffness dominates the correction; in steps where
another part of the boundary is driven (a strain-controlled wall or cell component), the only
ones where a servo must keep moving to hold its target. With no driven part (a compaction) it
would only carry the settling's overshoot into the packing (the cell then drifted out of
shape)."""


@njit(inline="always")
def _servo_rate(free, gain, load, stiffness, macro, low, high, memory, integral):
    """One servo's speed over a step of ``macro`` [s] and its updated memory (module docstring
    of :mod:`grainlab.engine.dem.soft_contact`): the proportional part is the overdamped servo
    of contact dynamics, s = free - gain load, taken backward in time with the load's
    stiffness K over the step, (free - gain load) / (1 + gain K h): stable at any contact
    stiffness, and it would cancel the load's error in one step if the grains behind the
    contacts did not move. They do, in a sample being deformed: the boundary must then keep
    moving, which the integral ``memory`` learns (+ :data:`SERVO_INTEGRAL` x the proportional
    part, weighted by gain K h / (1 + gain K h), so that a boundary still closing on a loose
    sample does not wind it up). Speed and memory within [low, high]."""
    damping = gain * stiffness * macro
    proportional = (free - gain * load) / (1.0 + damping)
    memory = min(max(memory + integral * proportional * damping / (1.0 + damping), low),
                 high)
    return min(max(proportional + memory, low), high), memory


@njit(cache=True, _nrt=False)
def servo_kernel(macro, integral, wall_inv_mass, wall_free, wall_max, wall_force,
                 wall_stiffness, wall_memory, wall_speed):
    """Speeds of the servo walls over a step of ``macro`` [s] (:func:`_servo_rate`) from the
    last step's mean loads ``wall_force`` (W,) [N] and their stiffnesses ``wall_stiffness``
    (W,) [N/m]; the servos' memories are updated (``integral``: :data:`SERVO_INTEGRAL` or 0).
    A driven wall keeps its speed ``wall_free``."""
    servo_walls(macro, macro, integral, 1.0, wall_inv_mass, wall_free, wall_max, wall_force,
                wall_stiffness, wall_memory, wall_speed, wall_stiffness)


@njit(inline="always")
def servo_walls(dt, macro, integral, servo_gain, wall_inv_mass, wall_free, wall_max,
                 wall_force, wall_stiffness, wall_memory, wall_speed, wall_floor):
    """The servo walls' speeds for the next ``dt`` [s] from their loads now ``wall_force``
    (W,) [N] (:func:`_servo_rate` over dt / ``servo_gain``: a fraction ``servo_gain`` of a
    stiff load's error corrected over dt, the servo's gain that of a step of ``macro`` [s],
    its memory learning ``integral`` per dt), with the largest stiffness of each wall's
    contacts met so far, ``wall_floor`` (W,) [N/m] (updated): a wall that loses its contacts
    for a sub-step keeps its stiff-load correction. A driven wall keeps its speed
    ``wall_free``."""
    for w in range(wall_speed.shape[0]):
        inv = wall_inv_mass[w]
        if inv > 0.0:
            high = wall_max[w]
            wall_floor[w] = max(wall_floor[w], wall_stiffness[w])
            wall_speed[w], wall_memory[w] = _servo_rate(
                wall_free[w], inv * macro, wall_force[w], wall_floor[w], dt / servo_gain,
                -OUTWARD_FACTOR * high, high, wall_memory[w], integral)
        else:
            wall_speed[w] = wall_free[w]


@njit(inline="always")
def _copy33(source, target):
    """target[:, :] = source for (3, 3) arrays, written out (no NRT in the kernels)."""
    for a in range(3):
        for b in range(3):
            target[a, b] = source[a, b]


@njit(inline="always")
def _det3(h):
    return (h[0, 0] * (h[1, 1] * h[2, 2] - h[1, 2] * h[2, 1])
            - h[0, 1] * (h[1, 0] * h[2, 2] - h[1, 2] * h[2, 0])
            + h[0, 2] * (h[1, 0] * h[2, 1] - h[1, 1] * h[2, 0]))


@njit(inline="always")
def _branch(k, i, j, images, positions, cell_h):
    """l_k = x_j + h m_k - x_i [m], the branch vector of row k through the cell."""
    mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
    return (positions[j, 0] - positions[i, 0] + cell_h[0, 0] * mx + cell_h[0, 1] * my
            + cell_h[0, 2] * mz,
            positions[j, 1] - positions[i, 1] + cell_h[1, 0] * mx + cell_h[1, 1] * my
            + cell_h[1, 2] * mz,
            positions[j, 2] - positions[i, 2] + cell_h[2, 0] * mx + cell_h[2, 1] * my
            + cell_h[2, 2] * mz)


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
        lx, ly, lz = _branch(k, i, j, images, positions, cell_h)
        for a in range(3):
            virial[a, 0] += force[k, a] * lx
            virial[a, 1] += force[k, a] * ly
            virial[a, 2] += force[k, a] * lz


@njit(cache=True, _nrt=False)
def cell_stiffness_kernel(body_i, body_j, images, stiffness, normal, positions, cell_h,
                          cell_directions, cell_stiffness):
    """K_d = (1/V) sum_k S_k (n_k . G_d l_k)^2 [Pa] (D,): how fast the springs' conjugate
    stress c_d grows per unit strain e_d of the cell when the bodies follow it affinely
    (S_k the rows' normal stiffness [N/m], l_k their branch vectors)."""
    volume = _det3(cell_h)
    cell_stiffness[:] = 0.0
    for k in range(body_j.shape[0]):
        i, j = body_i[k], body_j[k]
        if i < 0 or stiffness[k] == 0.0:
            continue
        lx, ly, lz = _branch(k, i, j, images, positions, cell_h)
        nx, ny, nz = normal[k, 0], normal[k, 1], normal[k, 2]
        for d in range(cell_directions.shape[0]):
            g = cell_directions[d]
            s = (nx * (g[0, 0] * lx + g[0, 1] * ly + g[0, 2] * lz)
                 + ny * (g[1, 0] * lx + g[1, 1] * ly + g[1, 2] * lz)
                 + nz * (g[2, 0] * lx + g[2, 1] * ly + g[2, 2] * lz))
            cell_stiffness[d] += stiffness[k] * s * s / volume


@njit(cache=True, _nrt=False)
def cell_servo_kernel(dt, virial, cell_h, cell_gradient, cell_directions, cell_scale,
                      cell_free, cell_bounds, cell_stiffness, filter_time, filtered,
                      cell_dofs, gradient):
    """The periodic cell's stress-controlled degrees of freedom, at every sub-step of ``dt``
    [s], from the stress of the contacts' springs (the servo of
    :mod:`grainlab.engine.boundaries.periodic_boundary` made fit for vibrating contacts):

        e_d = clip((free_d - scale_d c_d) / (1 + scale_d K_d 4 tau), bounds_d),

    c_d = -G_d : sym(sigma_f) [Pa], sigma_f the springs' stress ``virial`` / det h
    (compression positive) low-passed over ``filter_time`` tau [s] (``filtered`` (3, 3),
    updated here), free_d = scale_d (c*_d + J_d) (``cell_free`` (D,) [1/s], ``cell_scale``
    (D,) [1/(Pa s)], ``cell_directions`` G_d (D, 3, 3), ``cell_stiffness`` K_d (D,) [Pa] of
    :func:`cell_stiffness_kernel`). On a loose sample (K_d = 0) it is contact dynamics'
    servo; on a dense one the stress closes on its target in 4 tau, the critically damped
    response of a servo that reads through a filter of time tau. Why so: the instantaneous
    stress of a small packing shakes with every collision, and a servo that follows it
    shakes the bodies it carries; and the springs' stress, not the dashpots', because the
    dashpots answer at once to the velocity the servo gives the bodies, a loop that made the
    servo chatter from bound to bound. Writes ``cell_dofs`` (D,) [1/s] and the velocity
    gradient ``gradient`` = L_0 + sum_d e_d G_d (3, 3) [1/s] (``cell_gradient`` L_0 the
    prescribed part)."""
    volume = _det3(cell_h)
    blend = min(1.0, dt / filter_time)
    for a in range(3):
        for b in range(3):
            filtered[a, b] += blend * (virial[a, b] / volume - filtered[a, b])
    _copy33(cell_gradient, gradient)
    for d in range(cell_dofs.shape[0]):
        conjugate = 0.0
        for a in range(3):
            for b in range(3):
                conjugate -= cell_directions[d, a, b] * 0.5 * (filtered[a, b]
                                                               + filtered[b, a])
        e = (cell_free[d] - cell_scale[d] * conjugate) \
            / (1.0 + 4.0 * cell_scale[d] * cell_stiffness[d] * filter_time)
        e = min(max(e, cell_bounds[d, 0]), cell_bounds[d, 1])
        cell_dofs[d] = e
        for a in range(3):
            for b in range(3):
                gradient[a, b] += e * cell_directions[d, a, b]


@njit(inline="always")
def _gradient_changed(gradient, carried):
    """Whether the cell's velocity gradient L differs from the one the bodies carry."""
    change = False
    for a in range(3):
        for b in range(3):
            if gradient[a, b] != carried[a, b]:
                change = True
    return change


@njit(inline="always")
def _centre_of_mass(masses, positions):
    """x_c [m] of the bodies, summed in body order."""
    total, cx, cy, cz = 0.0, 0.0, 0.0, 0.0
    for n in range(masses.shape[0]):
        m = masses[n]
        total += m
        cx += m * positions[n, 0]
        cy += m * positions[n, 1]
        cz += m * positions[n, 2]
    return cx / total, cy / total, cz / total


@njit(inline="always")
def _carry_body(n, gradient, carried, cx, cy, cz, positions, velocities):
    """v_n += (L - L_carried) (x_n - x_c)."""
    d00, d01, d02 = gradient[0, 0] - carried[0, 0], gradient[0, 1] - carried[0, 1], \
        gradient[0, 2] - carried[0, 2]
    d10, d11, d12 = gradient[1, 0] - carried[1, 0], gradient[1, 1] - carried[1, 1], \
        gradient[1, 2] - carried[1, 2]
    d20, d21, d22 = gradient[2, 0] - carried[2, 0], gradient[2, 1] - carried[2, 1], \
        gradient[2, 2] - carried[2, 2]
    rx, ry, rz = positions[n, 0] - cx, positions[n, 1] - cy, positions[n, 2] - cz
    velocities[n, 0] += d00 * rx + d01 * ry + d02 * rz
    velocities[n, 1] += d10 * rx + d11 * ry + d12 * rz
    velocities[n, 2] += d20 * rx + d21 * ry + d22 * rz


@njit(inline="always")
def _take_up(change, gradient, carried, cell_h, cell_rate):
    """L_carried = L (if it changed) and the cell's rate hdot = L h."""
    if change:
        _copy33(gradient, carried)
    for a in range(3):
        for b in range(3):
            cell_rate[a, b] = (gradient[a, 0] * cell_h[0, b] + gradient[a, 1] * cell_h[1, b]
                               + gradient[a, 2] * cell_h[2, b])


@njit(cache=True, _nrt=False)
def carry_gradient_kernel(gradient, carried, masses, positions, velocities, cell_h, cell_rate):
    """The bodies take up a change of the cell's velocity gradient at once (YADE's
    homogeneous deformation): v_i += (L - L_carried) (x_i - x_c), x_c the centre of mass
    (momentum kept); then L_carried = L and the cell's rate hdot = L h (``cell_rate``
    (3, 3) [m/s])."""
    change = _gradient_changed(gradient, carried)
    if change:
        cx, cy, cz = _centre_of_mass(masses, positions)
        for n in range(masses.shape[0]):
            _carry_body(n, gradient, carried, cx, cy, cz, positions, velocities)
    _take_up(change, gradient, carried, cell_h, cell_rate)


@njit(cache=True, _nrt=False)
def _forces(parallel, step, record, code, params, rolling, body_i, body_j, off_i, off_j, rad_i,
            rad_j, images, mu, wall_rows, inv_mass, wall_p0, wall_n, positions, orientations,
            velocities, spins, wall_disp, wall_speed, cell_h, cell_rate, xi, roll, force,
            torque_i, torque_j, gap, normal, point, stiffness, rel_vel, virial, partial,
            stats, wall_force, wall_stiffness, plain, springs):
    """Contact forces of the list (on the threads if ``parallel``) and the walls' loads."""
    if parallel:
        contact_forces_parallel(step, record, code, params, rolling, body_i, body_j, off_i, off_j,
                                rad_i, rad_j, images, mu, inv_mass, positions, orientations,
                                velocities, spins, wall_p0, wall_n, wall_disp, wall_speed,
                                cell_h, cell_rate, xi, roll, force, torque_i, torque_j, gap,
                                normal, point, stiffness, rel_vel, virial, partial, stats,
                                plain, springs)
    else:
        contact_forces_kernel(step, record, code, params, rolling, body_i, body_j, off_i, off_j,
                              rad_i, rad_j, images, mu, inv_mass, positions, orientations,
                              velocities, spins, wall_p0, wall_n, wall_disp, wall_speed,
                              cell_h, cell_rate, xi, roll, force, torque_i, torque_j, gap,
                              normal, point, stiffness, rel_vel, virial, partial, stats, plain,
                              springs)
    wall_loads_kernel(wall_rows, body_i, wall_n, force, stiffness, wall_force,
                      wall_stiffness)


@njit(cache=True, _nrt=False)
def substeps_kernel(n_steps, dt, skin, code, params, rolling, local_damping, gravity,
                    body_i, body_j, off_i, off_j, rad_i, rad_j, images, mu, adj_start,
                    adj_entry, wall_rows, inv_mass, masses, principal, isotropic, arm,
                    wall_p0, wall_n, wall_speed, cell_gradient, cell_directions, cell_scale,
                    cell_free, cell_bounds, cell_stiffness, filter_time, filtered,
                    wall_disp_built, cell_h_built, positions, orientations, velocities,
                    spins, xi, roll, wall_disp, cell_h, cell_dofs, gradient, carried,
                    cell_rate, travel, force, torque_i, torque_j, gap,
                    normal, point, stiffness, rel_vel, virial, body_force, body_torque,
                    wall_force, wall_stiffness, wall_impulse, stress_impulse, stats,
                    approach, partial, parallel, wall_inv_mass, wall_free, wall_max,
                    wall_memory, macro, integral, servo_gain, wall_floor, plain, springs,
                    plain_bodies):
    """Up to ``n_steps`` velocity-Verlet sub-steps of ``dt`` [s] on the current list: half
    kick, drift (walls at their speeds ``wall_speed`` (W,) [m/s], the cell h at hdot = L h),
    forces, half kick; then the cell's servo (:func:`cell_servo_kernel`) sets L from the
    contacts' stress and the bodies take it up (:func:`carry_gradient_kernel`). The walls'
    loads are summed over time into ``wall_impulse`` (W,) [N s], in a periodic cell (no
    walls) the contacts' stress sigma into ``stress_impulse`` (3, 3) [Pa s]. Stops early,
    after a complete sub-step, when two points may have approached by more than ``skin`` [m]
    since the list was built (2 max travel + the walls' and the cell's own motion, with the
    next sub-step's increment taken as the last one's), so that no contact is missed;
    ``travel`` (N,) [m] and ``approach`` (1,) [m] (that bound after the last sub-step) carry
    over from call to call while the list lives. Returns the sub-steps done; ``stats[0]``
    becomes the largest overlap [m] met. ``partial`` (ceil(C / ROW_BLOCK), 10) and
    ``springs`` (C, 6) are scratch, ``plain`` the blocks of plain rows
    (:func:`contact_forces_kernel`), ``plain_bodies`` the blocks of bodies of isotropic
    inertia (:func:`isotropic_blocks`); with ``parallel`` the rows and the bodies are shared out
    over the threads (the same results: :func:`contact_forces_parallel`,
    :func:`bodies_parallel`)."""
    half = 0.5 * dt
    servo = cell_dofs.shape[0] > 0
    wall_servo = False
    for w in range(wall_inv_mass.shape[0]):
        wall_servo = wall_servo or wall_inv_mass[w] > 0.0
    periodic = wall_disp.shape[0] == 0
    met = stats[0]  # the overlaps met in the sub-steps, not those at the start
    # flags as typed booleans, not literals: a literal True or False at one call and a flag
    # at another would compile the callee twice (~17 s of a cold compilation)
    yes = n_steps >= 0  # True
    no = not yes
    _forces(parallel, 0.0, yes, code, params, rolling, body_i, body_j, off_i, off_j, rad_i,
            rad_j, images, mu, wall_rows, inv_mass, wall_p0, wall_n, positions, orientations,
            velocities, spins, wall_disp, wall_speed, cell_h, cell_rate, xi, roll, force,
            torque_i, torque_j, gap, normal, point, stiffness, rel_vel, virial, partial,
            stats, wall_force, wall_stiffness, plain, springs)
    stats[0] = met
    gather_kernel(adj_start, adj_entry, force, torque_i, torque_j, masses, gravity,
                  body_force, body_torque)
    if servo:
        cell_stiffness_kernel(body_i, body_j, images, stiffness, normal, positions, cell_h,
                              cell_directions, cell_stiffness)
    if servo:
        cell_servo_kernel(0.0, virial, cell_h, cell_gradient, cell_directions, cell_scale,
                          cell_free, cell_bounds, cell_stiffness, filter_time, filtered,
                          cell_dofs, gradient)
    else:
        _copy33(cell_gradient, gradient)
    carry_gradient_kernel(gradient, carried, masses, positions, velocities, cell_h, cell_rate)
    done = 0
    previous = approach[0]
    carrying = servo or periodic  # the bodies follow the cell's velocity gradient
    # the first sub-step's half kick and drift; each later one's come with the end of the
    # sub-step before, in one pass over the bodies (one parallel loop less per sub-step)
    if n_steps > 0:
        _bodies(parallel, no, no, yes, half, dt, adj_start, adj_entry, force, torque_i,
                torque_j, masses, gravity, inv_mass, principal, isotropic, local_damping,
                arm, gradient, carried, 0.0, 0.0, 0.0, positions, orientations,
                velocities, spins, body_force, body_torque, travel, plain_bodies)
    for _ in range(n_steps):
        for w in range(wall_disp.shape[0]):
            wall_disp[w] += dt * wall_speed[w]
        for a in range(3):
            for b in range(3):
                cell_h[a, b] += dt * cell_rate[a, b]
        last = _ == n_steps - 1  # the report reads its normals, points and velocities
        _forces(parallel, dt, last, code, params, rolling, body_i, body_j, off_i, off_j, rad_i,
                rad_j, images, mu, wall_rows, inv_mass, wall_p0, wall_n, positions, orientations,
                velocities, spins, wall_disp, wall_speed, cell_h, cell_rate, xi, roll, force,
                torque_i, torque_j, gap, normal, point, stiffness, rel_vel, virial, partial,
                stats, wall_force, wall_stiffness, plain, springs)
        if wall_servo:
            servo_walls(dt, macro, integral * dt / macro, servo_gain, wall_inv_mass,
                        wall_free, wall_max, wall_force, wall_stiffness, wall_memory,
                        wall_speed, wall_floor)
        if servo:
            cell_servo_kernel(dt, virial, cell_h, cell_gradient, cell_directions, cell_scale,
                              cell_free, cell_bounds, cell_stiffness, filter_time, filtered,
                              cell_dofs, gradient)
        for w in range(wall_impulse.shape[0]):
            wall_impulse[w] += dt * wall_force[w]
        if periodic:
            volume = _det3(cell_h)
            for a in range(3):
                for b in range(3):
                    stress_impulse[a, b] += dt * virial[a, b] / volume
        done += 1
        reach = 0.0
        for b in range(travel.shape[0]):
            reach = max(reach, travel[b])
        reach *= 2.0
        moved = 0.0
        for w in range(wall_disp.shape[0]):
            moved = max(moved, abs(wall_disp[w] - wall_disp_built[w]))
        shift = 0.0
        for a in range(3):
            for b in range(3):
                shift += (cell_h[a, b] - cell_h_built[a, b]) ** 2
        total = reach + moved + math.sqrt(3.0 * shift)
        approach[0] = total
        # the next sub-step might go past the skin: stop after this one
        stop = 2.0 * total - previous > skin or last
        previous = total
        change = carrying and _gradient_changed(gradient, carried)
        cx = cy = cz = 0.0
        if change:
            cx, cy, cz = _centre_of_mass(masses, positions)
        _bodies(parallel, yes, change, not stop, half, dt, adj_start, adj_entry, force,
                torque_i, torque_j, masses, gravity, inv_mass, principal, isotropic,
                local_damping, arm, gradient, carried, cx, cy, cz, positions,
                orientations, velocities, spins, body_force, body_torque, travel,
                plain_bodies)
        if carrying:  # hdot = L h follows the cell
            _take_up(change, gradient, carried, cell_h, cell_rate)
        if stop:
            break
    return done


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
