"""The bodies' side of a soft-contact sub-step for bodies of isotropic inertia (spheres) without
local damping, as vector code (:mod:`grainlab._vector_loops`): the half kicks, the take-up of
a change of the cell's velocity gradient and the drift with its quaternion turn, with the same
operations in the same order as the scalar
:func:`~grainlab.engine.dem.soft_contact_kernels._body_pass`, so the same bits, several bodies
at a time.

The turn of a body's orientation by exp(h omega / 2) uses the series of
:func:`~grainlab.engine.quaternion.half_turn_series`, which is what the scalar pass uses below
:data:`~grainlab.engine.quaternion.SMALL_TURN`; a body that does not turn (omega = 0) or turns
farther in one sub-step keeps its orientation here, and :func:`large_turns` turns the latter
afterwards as the scalar pass does (the C library's sine and cosine, never vectorised).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainlab._vector_loops import DistinctArrays, pick, root
from grainlab.engine.quaternion import SMALL_TURN, half_turn, half_turn_series, turned

ONE, TWO, THREE = np.uint64(1), np.uint64(2), np.uint64(3)
"""Unsigned index steps: no wrap-around of negative indices, so LLVM sees the strides."""


@njit(cache=True, _nrt=False, error_model="numpy", pipeline_class=DistinctArrays)
def sphere_bodies_kernel(lo, hi, close, carry, open_, half, dt, inv_mass, principal, arm,
                         gradient, carried, cx, cy, cz, body_force, body_torque, positions,
                         orientations, velocities, spins, travel):
    """Bodies ``lo`` .. ``hi`` - 1, each of isotropic inertia ``principal[3 b]`` [kg m^2]:
    with ``close`` the half kick that ends a sub-step (v += (h/2) F / m, omega += (h/2) T / I,
    ``half`` = h/2 [s], the net loads ``body_force``, ``body_torque`` already gathered), with
    ``carry`` the change of the cell's velocity gradient taken up (v += (L - L_carried)
    (x - x_c), ``gradient`` and ``carried`` (9,) row-major [1/s], x_c = (``cx``, ``cy``,
    ``cz``) [m]), with ``open_`` the half kick and the drift of ``dt`` [s] that start the next
    (x += h v, the turn of the orientation, ``travel`` += h |v| + h |omega| x ``arm``), in
    that order. The per-body arrays of three or four components are flat (3 N,) or (4 N,).
    Orientations of bodies that turn by half-angles of :data:`~grainlab.engine.quaternion.
    SMALL_TURN` or more are left for :func:`large_turns`; returns how many. No two array
    arguments may share memory (:class:`~grainlab._vector_loops.DistinctArrays`)."""
    d00, d01, d02 = gradient[0] - carried[0], gradient[1] - carried[1], gradient[2] - carried[2]
    d10, d11, d12 = gradient[3] - carried[3], gradient[4] - carried[4], gradient[5] - carried[5]
    d20, d21, d22 = gradient[6] - carried[6], gradient[7] - carried[7], gradient[8] - carried[8]
    left = 0
    for b in range(np.uint64(lo), np.uint64(hi)):
        b3, b4 = b * THREE, b * np.uint64(4)
        vx, vy, vz = velocities[b3], velocities[b3 + ONE], velocities[b3 + TWO]
        wx, wy, wz = spins[b3], spins[b3 + ONE], spins[b3 + TWO]
        fx, fy, fz = body_force[b3], body_force[b3 + ONE], body_force[b3 + TWO]
        tx, ty, tz = body_torque[b3], body_torque[b3 + ONE], body_torque[b3 + TWO]
        f = half * inv_mass[b]
        g = half / principal[b3]
        if close:
            vx, vy, vz = vx + f * fx, vy + f * fy, vz + f * fz
            wx, wy, wz = wx + g * tx, wy + g * ty, wz + g * tz
        if carry:
            rx, ry, rz = positions[b3] - cx, positions[b3 + ONE] - cy, positions[b3 + TWO] - cz
            vx += d00 * rx + d01 * ry + d02 * rz
            vy += d10 * rx + d11 * ry + d12 * rz
            vz += d20 * rx + d21 * ry + d22 * rz
        if open_:
            vx, vy, vz = vx + f * fx, vy + f * fy, vz + f * fz
            wx, wy, wz = wx + g * tx, wy + g * ty, wz + g * tz
            ex, ey, ez = dt * vx, dt * vy, dt * vz
            positions[b3] += ex
            positions[b3 + ONE] += ey
            positions[b3 + TWO] += ez
            spin = root(wx * wx + wy * wy + wz * wz)
            travel[b] += root(ex * ex + ey * ey + ez * ez) + spin * dt * arm[b]
            a = 0.5 * spin * dt
            cos, sinc = half_turn_series(a)
            w, x, y, z = orientations[b4], orientations[b4 + ONE], orientations[b4 + TWO], \
                orientations[b4 + THREE]
            nw, nx, ny, nz = turned(w, x, y, z, cos, sinc * 0.5 * dt, wx, wy, wz)
            large = a >= SMALL_TURN
            left += np.int64(large)
            keep = (spin == 0.0) | large  # no turn, or one for large_turns
            orientations[b4], orientations[b4 + ONE] = pick(keep, w, nw), pick(keep, x, nx)
            orientations[b4 + TWO] = pick(keep, y, ny)
            orientations[b4 + THREE] = pick(keep, z, nz)
        velocities[b3], velocities[b3 + ONE], velocities[b3 + TWO] = vx, vy, vz
        spins[b3], spins[b3 + ONE], spins[b3 + TWO] = wx, wy, wz
    return left


@njit(inline="always")
def large_turns(lo, hi, dt, orientations, spins):
    """The orientations of bodies ``lo`` .. ``hi`` - 1 that :func:`sphere_bodies_kernel` left
    for being turned by a half-angle of :data:`~grainlab.engine.quaternion.SMALL_TURN` or more
    in the sub-step of ``dt`` [s], turned with their spins as the drift left them (the
    library's sine and cosine: :func:`~grainlab.engine.quaternion.half_turn`)."""
    for b in range(lo, hi):
        wx, wy, wz = spins[b, 0], spins[b, 1], spins[b, 2]
        spin = math.sqrt(wx * wx + wy * wy + wz * wz)
        a = 0.5 * spin * dt
        if a >= SMALL_TURN:
            cos, sinc = half_turn(a)
            q = orientations[b]
            q[0], q[1], q[2], q[3] = turned(q[0], q[1], q[2], q[3], cos, sinc * 0.5 * dt,
                                            wx, wy, wz)
