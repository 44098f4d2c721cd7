"""Kinematics of a contact point: the velocity of a point carried by a rigid body, from which
every solver forms the relative velocity U = u_j - u_i of its contacts, and the gap of a
sphere to a plane wall (the soft passes of :mod:`grainlab.engine.dem.soft_contact_kernels`,
:mod:`grainlab.engine.dem.sphere_rows`, :mod:`grainlab.engine.dem.soft_polyhedra_kernels`, the
dashpots' bound of :mod:`grainlab.engine.dem.soft_stability` and contact dynamics' sweeps).
Scalar functions compiled inline, without branches."""

from __future__ import annotations

from numba import njit


@njit(inline="always")
def point_velocity(vx, vy, vz, wx, wy, wz, rx, ry, rz):
    """u = v + omega x r [m/s]: the velocity of the point at arm r [m] from the centre of a
    rigid body of velocity v [m/s] and spin omega [rad/s], as three floats (each component
    summed as v_a + (omega x r)_a's first product - its second, in that order)."""
    return vx + wy * rz - wz * ry, vy + wz * rx - wx * rz, vz + wx * ry - wy * rx


@njit(inline="always")
def less_body_i(i, ux, uy, uz, px, py, pz, positions, velocities, spins, wall_n, wall_speed):
    """The velocity U = u_j - u_i [m/s] of body j relative to side i at the point p [m], from
    j's velocity there (ux, uy, uz) [m/s]: side i a rigid body (i >= 0, centre
    ``positions[i]``, ``velocities[i]``, ``spins[i]``) or the wall w = -1 - i, which moves
    with ``wall_speed[w]`` [m/s] along its unit normal ``wall_n[w]``. Returns (U, r_i,
    omega_i): also the arm r_i = p - x_i [m] and the spin omega_i [rad/s], zero for a wall."""
    rix, riy, riz = 0.0, 0.0, 0.0
    wix, wiy, wiz = 0.0, 0.0, 0.0
    if i >= 0:
        rix, riy, riz = px - positions[i, 0], py - positions[i, 1], pz - positions[i, 2]
        wix, wiy, wiz = spins[i, 0], spins[i, 1], spins[i, 2]
        qx, qy, qz = point_velocity(velocities[i, 0], velocities[i, 1], velocities[i, 2],
                                    wix, wiy, wiz, rix, riy, riz)
        ux, uy, uz = ux - qx, uy - qy, uz - qz
    else:
        w = -1 - i
        s = wall_speed[w]
        ux, uy, uz = ux - s * wall_n[w, 0], uy - s * wall_n[w, 1], uz - s * wall_n[w, 2]
    return ux, uy, uz, rix, riy, riz, wix, wiy, wiz


@njit(inline="always")
def sphere_wall_gap(bx, by, bz, rb, w, wall_n, wall_p0, wall_disp):
    """The gap g [m] of the sphere of centre b [m] and radius rb [m] to the plane wall w, of
    unit normal ``wall_n[w]`` (towards the sample) through ``wall_p0[w]`` [m] moved by
    ``wall_disp[w]`` [m] along it: g = (b - p0 - d n) . n - rb (negative: overlap). Returns
    (g, n_x, n_y, n_z)."""
    nx, ny, nz = wall_n[w, 0], wall_n[w, 1], wall_n[w, 2]
    d = wall_disp[w]
    g = ((bx - wall_p0[w, 0] - d * nx) * nx + (by - wall_p0[w, 1] - d * ny) * ny
         + (bz - wall_p0[w, 2] - d * nz) * nz - rb)
    return g, nx, ny, nz
