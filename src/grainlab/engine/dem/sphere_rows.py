"""The soft-contact force pass on the rows between two plain spheres, as vector code
(:mod:`grainlab._vector_loops`): the same law and the same bits as the general row of
:func:`grainlab.engine.dem.soft_contact_kernels._forces_block`, four to eight rows at a time.

A row is *plain* when both members are the centres of their bodies (no member offsets: not an
aggregate's member) and neither side is a wall; the rolling resistance is off. Those rows are
nearly all the rows of a sphere packing. Every row is computed without a branch: an open row
(gap g >= 0) goes through the same arithmetic with a zero overlap and a zero history, so its
force, moments, stiffness and history come out zero, as the general row writes them; the
Coulomb projection and the frame turn of the history are selects.

Measured (4000 spheres of the peers' test of ``benchmarks/benchmark_dem_peers.py`` in shear,
17 099 rows, one thread, AVX-512 Xeon): the general rows 60 ns per row, these 27 ns per row,
with the same results bit for bit (``tests/engine/test_sphere_rows.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from grainlab._vector_loops import DistinctArrays, pick, root
from grainlab.contact.contact_kinematics import point_velocity
from grainlab.contact.soft_contact_law import contact_law
from grainlab.contact.tangential_spring import mindlin_coulomb

ONE, TWO, THREE, SIX = np.uint64(1), np.uint64(2), np.uint64(3), np.uint64(6)
"""Unsigned index steps: no wrap-around of negative indices, so LLVM sees the row strides."""

@njit(cache=True, _nrt=False, error_model="numpy", pipeline_class=DistinctArrays)
def sphere_rows_kernel(lo, hi, step, record, code, params, body_i, body_j, rad_i, rad_j,
                       images, mu, inv_mass, positions, velocities, spins, cell_h, cell_rate,
                       xi, force, torque_i, torque_j, gap, stiffness, normal, point, rel_vel,
                       springs):
    """Rows ``lo`` .. ``hi`` - 1 of the list, all plain (module docstring), as
    :func:`~grainlab.engine.dem.soft_contact_kernels.contact_forces_kernel` evaluates them, with
    the law ``code`` and its ``params`` row (:func:`~grainlab.contact.soft_contact_law.
    contact_law`). The per-row arrays
    of three components are flat (3 C,): ``images``, ``xi``, ``force``, ``torque_i``,
    ``torque_j`` and, written only if ``record`` (for every row), ``normal``, ``point``,
    ``rel_vel``. ``springs`` (6 C,) receives per row the springs' force on j (elastic normal
    force and tangential spring, without the dashpots) [N] and the branch vector
    x_j + h m - x_i [m], from which the caller sums the virial in row order. No two array
    arguments may share memory (:class:`~grainlab._vector_loops.DistinctArrays`)."""
    h00, h01, h02 = cell_h[0, 0], cell_h[0, 1], cell_h[0, 2]
    h10, h11, h12 = cell_h[1, 0], cell_h[1, 1], cell_h[1, 2]
    h20, h21, h22 = cell_h[2, 0], cell_h[2, 1], cell_h[2, 2]
    r00, r01, r02 = cell_rate[0, 0], cell_rate[0, 1], cell_rate[0, 2]
    r10, r11, r12 = cell_rate[1, 0], cell_rate[1, 1], cell_rate[1, 2]
    r20, r21, r22 = cell_rate[2, 0], cell_rate[2, 1], cell_rate[2, 2]
    turn = step > 0.0
    for k in range(np.uint64(lo), np.uint64(hi)):
        k3, k6 = k * THREE, k * SIX
        j, i = np.uint64(body_j[k]), np.uint64(body_i[k])
        mx, my, mz = images[k3], images[k3 + ONE], images[k3 + TWO]
        # the image of body j, x_j + h m (+ 0.0: the general row adds the zero offset)
        jx = positions[j, 0] + (h00 * mx + h01 * my + h02 * mz)
        jy = positions[j, 1] + (h10 * mx + h11 * my + h12 * mz)
        jz = positions[j, 2] + (h20 * mx + h21 * my + h22 * mz)
        xa, ya, za = positions[i, 0], positions[i, 1], positions[i, 2]
        ax, ay, az = xa + 0.0, ya + 0.0, za + 0.0
        dx, dy, dz = (jx + 0.0) - ax, (jy + 0.0) - ay, (jz + 0.0) - az
        ra, rb = rad_i[k], rad_j[k]
        reach = ra + rb
        d2 = dx * dx + dy * dy + dz * dz
        dist = root(d2)
        g = pick(d2 >= reach * reach, dist - reach, (dist - ra) - rb)
        gap[k] = g
        closed = not g >= 0.0
        apart = dist > 0.0  # coincident centres: the normal (0, 0, 1) of sphere_sphere
        nx, ny, nz = pick(apart, dx / dist, 0.0), pick(apart, dy / dist, 0.0), \
            pick(apart, dz / dist, 1.0)
        s = ra + 0.5 * g
        cx, cy, cz = ax + s * nx, ay + s * ny, az + s * nz
        r_eff = ra * rb / (ra + rb)
        m_eff = 1.0 / (inv_mass[i] + inv_mass[j])
        # relative velocity of j (image) with respect to i at the contact point
        rjx, rjy, rjz = cx - jx, cy - jy, cz - jz
        wjx, wjy, wjz = spins[j, 0], spins[j, 1], spins[j, 2]
        ux, uy, uz = point_velocity(velocities[j, 0], velocities[j, 1], velocities[j, 2],
                                    wjx, wjy, wjz, rjx, rjy, rjz)
        ux += r00 * mx + r01 * my + r02 * mz
        uy += r10 * mx + r11 * my + r12 * mz
        uz += r20 * mx + r21 * my + r22 * mz
        rix, riy, riz = cx - xa, cy - ya, cz - za
        wix, wiy, wiz = spins[i, 0], spins[i, 1], spins[i, 2]
        qx, qy, qz = point_velocity(velocities[i, 0], velocities[i, 1], velocities[i, 2],
                                    wix, wiy, wiz, rix, riy, riz)
        ux, uy, uz = ux - qx, uy - qy, uz - qz
        if record:
            normal[k3], normal[k3 + ONE], normal[k3 + TWO] = nx, ny, nz
            point[k3], point[k3 + ONE], point[k3 + TWO] = cx, cy, cz
            rel_vel[k3], rel_vel[k3 + ONE], rel_vel[k3 + TWO] = ux, uy, uz
        overlap = pick(closed, -g, 0.0)  # an open row: no overlap, no force
        un = ux * nx + uy * ny + uz * nz
        utx, uty, utz = ux - un * nx, uy - un * ny, uz - un * nz
        fne, s_n, k_t, c_n, c_t = contact_law(code, params, overlap, r_eff, m_eff)
        # an open row: no stiffness, no damping (the linear law's are not zero at delta = 0)
        s_n, k_t = pick(closed, s_n, 0.0), pick(closed, k_t, 0.0)
        c_n, c_t = pick(closed, c_n, 0.0), pick(closed, c_t, 0.0)
        fn = max(0.0, fne - c_n * un)
        hx = pick(closed, xi[k3], 0.0)  # the tangential spring's force [N]
        hy = pick(closed, xi[k3 + ONE], 0.0)
        hz = pick(closed, xi[k3 + TWO], 0.0)
        # the spring carried with the contact frame, loaded, capped by Coulomb's law
        spin_n = 0.5 * ((wix + wjx) * nx + (wiy + wjy) * ny + (wiz + wjz) * nz)
        ftx, fty, ftz, hx, hy, hz = mindlin_coulomb(turn, step, hx, hy, hz, nx, ny, nz, spin_n,
                                                    utx, uty, utz, k_t, c_t, mu[k] * fn)
        fx, fy, fz = fn * nx + ftx, fn * ny + fty, fn * nz + ftz
        xi[k3], xi[k3 + ONE], xi[k3 + TWO] = hx, hy, hz
        stiffness[k] = s_n
        force[k3], force[k3 + ONE], force[k3 + TWO] = fx, fy, fz
        torque_j[k3] = rjy * fz - rjz * fy
        torque_j[k3 + ONE] = rjz * fx - rjx * fz
        torque_j[k3 + TWO] = rjx * fy - rjy * fx
        torque_i[k3] = -(riy * fz - riz * fy)
        torque_i[k3 + ONE] = -(riz * fx - rix * fz)
        torque_i[k3 + TWO] = -(rix * fy - riy * fx)
        springs[k6], springs[k6 + ONE] = fne * nx + hx, fne * ny + hy
        springs[k6 + TWO], springs[k6 + THREE] = fne * nz + hz, jx - xa
        springs[k6 + np.uint64(4)], springs[k6 + np.uint64(5)] = jy - ya, jz - za
