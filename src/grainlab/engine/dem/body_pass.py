"""The bodies' side of the explicit soft-contact (DEM) sub-steps (Numba; STYLE.md 2, 8): the
net force and moment on each body gathered from the rows of the contact list, velocity-Verlet
half kicks and drifts with quaternion rotations, and the bodies taking up a change of the
periodic cell's velocity gradient (:mod:`grainlab.engine.dem.soft_contact_kernels`, the module
docstring: the gather, the blocks and the threads).

The bodies' pass of a sub-step is body by body, in blocks of :data:`BODY_BLOCK` bodies (as vector
code for bodies of isotropic inertia: :mod:`grainlab.engine.dem.sphere_bodies`), so the same
sub-steps run on one thread (:func:`bodies_kernel`) or on several (:func:`bodies_parallel`) with
the same results, bit for bit, whatever the number of threads.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainlab.engine.boundaries.periodic_cell_face import carry_body
from grainlab.engine.dem.sphere_bodies import large_turns, sphere_bodies_kernel
from grainlab.engine.quaternion import half_turn, turned


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
        carry_body(b, gradient, carried, cx, cy, cz, positions, velocities)
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
                  gradient, carried, centre, positions, orientations, velocities, spins,
                  body_force, body_torque, travel, plain):
    """The bodies of block ``blk``: through the vector kernel (after the gather, then
    :func:`~grainlab.engine.dem.sphere_bodies.large_turns`) if they are all of isotropic inertia
    (``plain[blk]``) and there is no local damping, else body by body; the same bits."""
    cx, cy, cz = centre  # x_c [m], the centre of mass the take-up of L is about
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
    half kick that end a sub-step (:func:`gather_kernel`; the kick v += (h/2) F / m,
    omega += (h/2) I_w^-1 T, ``half`` = h/2 [s], F and T reduced by the local damping
    alpha |F| sign(v) per component), with ``carry`` the change of the cell's velocity
    gradient taken up (v += (L - L_carried) (x - x_c), x_c = (``cx``, ``cy``, ``cz``) [m]:
    :func:`~grainlab.engine.boundaries.periodic_cell_face.carry_gradient_kernel`), with
    ``open_`` the half kick and the drift that start the next (x += h v;
    q <- exp(h omega / 2) q in the world frame, a body of anisotropic inertia keeping its
    angular momentum I_w omega through the turn; ``travel`` (N,) [m] grows by
    |dx| + |omega| h ``arm``, the largest displacement of a point its contacts are computed
    from), in that order. In blocks of :data:`BODY_BLOCK` bodies, those
    flagged in ``plain`` (:func:`isotropic_blocks`) as vector code (:func:`_bodies_block`)."""
    for blk in range(plain.shape[0]):
        _bodies_block(blk, close, carry, open_, half, dt, adj_start, adj_entry, force,
                      torque_i, torque_j, masses, gravity, inv_mass, principal, isotropic,
                      local_damping, arm, gradient, carried, (cx, cy, cz), positions,
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
                      isotropic, local_damping, arm, gradient, carried, (cx, cy, cz),
                      positions, orientations, velocities, spins, body_force, body_torque,
                      travel, plain)


@njit(_nrt=False)
def _body_side(parallel, close, carry, open_, half, dt, rows, bodies, gravity, local_damping,
               cell, cx, cy, cz):
    """The bodies' pass (:func:`bodies_kernel`, on the threads if ``parallel``:
    :func:`bodies_parallel`) on the rows' loads (``rows``: :class:`~grainlab.engine.dem.
    substep_arrays.SphereRowArrays`), the ``bodies`` (:class:`~grainlab.engine.dem.
    substep_arrays.BodyArrays`) and the cell's velocity gradient (``cell``: :class:`~grainlab.
    engine.boundaries.periodic_cell_face.CellFace`)."""
    if parallel:
        bodies_parallel(close, carry, open_, half, dt, rows.adj_start, rows.adj_entry,
                        rows.force, rows.torque_i, rows.torque_j, bodies.masses, gravity,
                        bodies.inv_mass, bodies.principal, bodies.isotropic, local_damping,
                        bodies.arm, cell.gradient, cell.carried, cx, cy, cz, bodies.positions,
                        bodies.orientations, bodies.velocities, bodies.spins, bodies.force,
                        bodies.torque, bodies.travel, bodies.plain_bodies)
    else:
        bodies_kernel(close, carry, open_, half, dt, rows.adj_start, rows.adj_entry,
                      rows.force, rows.torque_i, rows.torque_j, bodies.masses, gravity,
                      bodies.inv_mass, bodies.principal, bodies.isotropic, local_damping,
                      bodies.arm, cell.gradient, cell.carried, cx, cy, cz, bodies.positions,
                      bodies.orientations, bodies.velocities, bodies.spins, bodies.force,
                      bodies.torque, bodies.travel, bodies.plain_bodies)
