"""The update of one contact in the nonlinear Gauss-Seidel sweep of contact dynamics (Numba,
inlined into every sweep: serial, coloured, slab): the relative velocity at the contact, the local
solve on the Coulomb cone (:mod:`grainlab.contact.coulomb_cone`), the impulse applied to both
bodies,
the walls or the cell, the skip of open contacts and the convergence checks spaced through the
sweeps (:mod:`~grainlab.engine.nscd.contact_dynamics`, module docstring).
"""

from __future__ import annotations

import math

from llvmlite import ir
from numba import njit, types
from numba.core.extending import intrinsic

from grainlab.contact.contact_kinematics import point_velocity
from grainlab.contact.coulomb_cone import local_solve, natural_map

_TINY = 1e-300


SKIP_OPEN = 2
"""A contact found open (P = 0) at this many visits in a row is skipped by the sweeps
(LMGC90's iskip idea, research/cd_engines.md 1.3) ..."""


SKIP_REVISIT = 10


CHECK_FACTOR = 2.0


CHECK_SPACING = 10
"""... except in every SKIP_REVISIT-th sweep, the first, and the one after a failed
convergence check, which visit every contact; the check pass always covers every contact."""



# --------------------------------------------------------------------------------------------
# Scalar laws
# --------------------------------------------------------------------------------------------


@intrinsic
def _fma(typingctx, a, b, c):
    """a b + c with a single rounding (LLVM's ``fma`` on float64)."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, sig, args):
        double = ir.DoubleType()
        fma = builder.module.declare_intrinsic("llvm.fma", [double],
                                               ir.FunctionType(double, [double] * 3))
        return builder.call(fma, args)

    return signature, codegen


@njit(inline="always")
def _dot3(a0, a1, a2, b0, b1, b2):
    """a . b of two 3-vectors as a chain of fused multiply-adds over k = 0, 1, 2 from 0 (one
    rounding each): the same bits on every processor, and those of one entry of a 3 x 3
    product by the OpenBLAS dgemm that Numba's ``@`` called here before."""
    return _fma(a2, b2, _fma(a1, b1, _fma(a0, b0, 0.0)))


@njit(inline="always")
def _relative_velocity(k, contacts, wall_normals, motion):
    """Local (n, t, s) velocity of body j relative to body i at contact k [m/s] in the motion
    ``motion`` (:class:`~grainlab.engine.nscd.sweep_arrays.Motion`); a wall (body_i = -1 - w)
    moves with the speed ``motion.wall_speeds[w]`` along its normal ``wall_normals[w]``; in
    a periodic cell body j may be its image translated by h m_k (``contacts.images[k]`` =
    m_k), which moves with the cell: its velocity is v_j + hdot m_k, hdot =
    ``motion.cell_rate`` (3, 3) [m/s]."""
    velocities, spins, cell_rate = motion.velocities, motion.spins, motion.cell_rate
    frame, images = contacts.frame, contacts.images
    ux, uy, uz = 0.0, 0.0, 0.0
    j = contacts.body_j[k]
    if j >= 0:
        wx, wy, wz = spins[j, 0], spins[j, 1], spins[j, 2]
        arm_j = contacts.arm_j
        px, py, pz = point_velocity(velocities[j, 0], velocities[j, 1], velocities[j, 2],
                                    wx, wy, wz, arm_j[k, 0], arm_j[k, 1], arm_j[k, 2])
        ux, uy, uz = ux + px, uy + py, uz + pz
        mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
        if mx != 0.0 or my != 0.0 or mz != 0.0:
            ux += cell_rate[0, 0] * mx + cell_rate[0, 1] * my + cell_rate[0, 2] * mz
            uy += cell_rate[1, 0] * mx + cell_rate[1, 1] * my + cell_rate[1, 2] * mz
            uz += cell_rate[2, 0] * mx + cell_rate[2, 1] * my + cell_rate[2, 2] * mz
    i = contacts.body_i[k]
    if i >= 0:
        wx, wy, wz = spins[i, 0], spins[i, 1], spins[i, 2]
        arm_i = contacts.arm_i
        px, py, pz = point_velocity(velocities[i, 0], velocities[i, 1], velocities[i, 2],
                                    wx, wy, wz, arm_i[k, 0], arm_i[k, 1], arm_i[k, 2])
        ux, uy, uz = ux - px, uy - py, uz - pz
    else:
        w = -1 - i
        wall_speeds = motion.wall_speeds
        ux -= wall_speeds[w] * wall_normals[w, 0]
        uy -= wall_speeds[w] * wall_normals[w, 1]
        uz -= wall_speeds[w] * wall_normals[w, 2]
    return (frame[k, 0, 0] * ux + frame[k, 0, 1] * uy + frame[k, 0, 2] * uz,
            frame[k, 1, 0] * ux + frame[k, 1, 1] * uy + frame[k, 1, 2] * uz,
            frame[k, 2, 0] * ux + frame[k, 2, 1] * uy + frame[k, 2, 2] * uz)


@njit(cache=True)
def closing_velocities_kernel(contacts, wall_normals, motion, out):
    """Write into ``out`` (C, 3) the local (n, t, s) velocities [m/s] of every contact in
    ``motion``, by the sweeps' own law (:func:`_relative_velocity`): the closing velocities a
    correction between sweeps and the step's report read."""
    for k in range(out.shape[0]):
        un, ut, us = _relative_velocity(k, contacts, wall_normals, motion)
        out[k, 0] = un
        out[k, 1] = ut
        out[k, 2] = us


@njit(inline="always")
def _apply(k, dn, dt_, ds, contacts, bodies, walls, cell, motion):
    """Add the local impulse change (dn, dt_, ds) of contact k to its two bodies' ``motion``
    (a wall moves only along its normal, with inverse mass ``walls.inv_mass[w]``, 0 if
    driven); a contact with an image (``contacts.images[k]`` = m_k != 0) also drives the
    periodic cell's free degrees of freedom e_d (:func:`_apply_to_cell`)."""
    frame = contacts.frame
    px = frame[k, 0, 0] * dn + frame[k, 1, 0] * dt_ + frame[k, 2, 0] * ds
    py = frame[k, 0, 1] * dn + frame[k, 1, 1] * dt_ + frame[k, 2, 1] * ds
    pz = frame[k, 0, 2] * dn + frame[k, 1, 2] * dt_ + frame[k, 2, 2] * ds
    if cell.inv_mass.shape[0] > 0:
        _apply_to_cell(k, px, py, pz, contacts.images, cell, motion)
    wall_inv_mass, wall_normals = walls.inv_mass, walls.normals
    inv_mass, inv_inertia = bodies.inv_mass, bodies.inv_inertia
    velocities, spins = motion.velocities, motion.spins
    for side in range(2):
        b = contacts.body_j[k] if side == 0 else contacts.body_i[k]
        if b < 0:
            w = -1 - b
            if wall_inv_mass[w] > 0.0:
                motion.wall_speeds[w] -= wall_inv_mass[w] * (
                    px * wall_normals[w, 0] + py * wall_normals[w, 1] + pz * wall_normals[w, 2])
            continue
        sign = 1.0 if side == 0 else -1.0
        if side == 0:
            rx, ry, rz = contacts.arm_j[k, 0], contacts.arm_j[k, 1], contacts.arm_j[k, 2]
        else:
            rx, ry, rz = contacts.arm_i[k, 0], contacts.arm_i[k, 1], contacts.arm_i[k, 2]
        fx, fy, fz = sign * px, sign * py, sign * pz
        velocities[b, 0] += inv_mass[b] * fx
        velocities[b, 1] += inv_mass[b] * fy
        velocities[b, 2] += inv_mass[b] * fz
        tx, ty, tz = ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx
        for d in range(3):
            spins[b, d] += (inv_inertia[b, d, 0] * tx + inv_inertia[b, d, 1] * ty
                            + inv_inertia[b, d, 2] * tz)


@njit(inline="always")
def _apply_to_cell(k, px, py, pz, images, cell, motion):
    """The cell's share of a world impulse change (px, py, pz) [N s] on the image of body j
    at contact k: each free degree of freedom e_d (hdot = hdot_fixed + sum_d e_d H_d, H_d =
    ``cell.basis[d]`` (3, 3) [m]) changes by kappa_d (H_d m_k) . P, kappa_d =
    ``cell.inv_mass[d]`` [1/(N s^2)] (:mod:`grainlab.engine.boundaries.periodic_boundary`),
    and hdot (``motion.cell_rate``) with it."""
    mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
    if mx == 0.0 and my == 0.0 and mz == 0.0:
        return
    cell_inv_mass, cell_dofs, cell_rate = cell.inv_mass, motion.cell_dofs, motion.cell_rate
    for d in range(cell_inv_mass.shape[0]):
        if cell_inv_mass[d] > 0.0:
            h = cell.basis[d]
            gx = h[0, 0] * mx + h[0, 1] * my + h[0, 2] * mz
            gy = h[1, 0] * mx + h[1, 1] * my + h[1, 2] * mz
            gz = h[2, 0] * mx + h[2, 1] * my + h[2, 2] * mz
            delta = cell_inv_mass[d] * (px * gx + py * gy + pz * gz)
            cell_dofs[d] += delta
            for a in range(3):
                for b in range(3):
                    cell_rate[a, b] += delta * h[a, b]


@njit(inline="always")
def update_contact(k, contacts, bodies, walls, cell, motion, impulses, delassus, work):
    """One Gauss-Seidel update (every sweep): local solve of contact k against the current
    ``motion``; applies the impulse change to its bodies and returns its squared norm
    [N^2 s^2]. Before the update it writes the contact's share of the running residual into
    ``work.running[k]``: (||natural map||^2, ||w P||^2, ||U'||^2) [m^2/s^2] at the current
    iterate (module docstring); not with an empty ``work.running`` (0, 3), when the change
    decides."""
    w = delassus[k]
    mu = contacts.mu
    running = work.running
    un, ut, us = _relative_velocity(k, contacts, walls.normals, motion)
    p0, p1, p2 = impulses[k, 0], impulses[k, 1], impulses[k, 2]
    vn = un + work.shift[k]
    if running.shape[0] > 0:  # only when the running residual decides (no change tolerance)
        running[k, 0], running[k, 1], running[k, 2] = natural_map(mu[k], w[0, 0], p0, p1, p2,
                                                                  vn, ut, us)
    # free (P_k = 0) corrected velocity
    fn = vn - (w[0, 0] * p0 + w[0, 1] * p1 + w[0, 2] * p2)
    ft = ut - (w[1, 0] * p0 + w[1, 1] * p1 + w[1, 2] * p2)
    fs = us - (w[2, 0] * p0 + w[2, 1] * p1 + w[2, 2] * p2)
    q0, q1, q2 = local_solve(w, fn, ft, fs, mu[k], p0, p1, p2)
    d0, d1, d2 = q0 - p0, q1 - p1, q2 - p2
    impulses[k, 0], impulses[k, 1], impulses[k, 2] = q0, q1, q2
    _apply(k, d0, d1, d2, contacts, bodies, walls, cell, motion)
    return d0 * d0 + d1 * d1 + d2 * d2


@njit(inline="always")
def skipped_update(k, skip, contacts, bodies, walls, cell, motion, impulses, delassus, work):
    """:func:`update_contact` unless contact k has been open (P = 0) at its last ``skip``
    visits (then it is left alone, its running-residual share zero, and 0 returned);
    ``work.open_sweeps[k]`` counts those visits."""
    open_sweeps, running = work.open_sweeps, work.running
    if open_sweeps[k] >= skip:
        if running.shape[0] > 0:
            running[k, 0] = 0.0
            running[k, 1] = 0.0
            running[k, 2] = 0.0
        return 0.0
    change = update_contact(k, contacts, bodies, walls, cell, motion, impulses, delassus,
                            work)
    if impulses[k, 0] == 0.0:
        open_sweeps[k] += 1
    else:
        open_sweeps[k] = 0
    return change




@njit(inline="always")
def running_residual(run_res2, run_wp2, run_u2, free_norm2):
    """The running residual of a sweep: the natural map summed over the sweep with each
    contact at its visit (``run_res2``), over max(||U'_free||, ||w P||, ||U'||) (squares
    ``free_norm2``, ``run_wp2``, ``run_u2``): the residual of the check pass, one sweep
    late, at no extra pass."""
    scale = max(math.sqrt(free_norm2), math.sqrt(run_wp2), math.sqrt(run_u2), _TINY)
    return math.sqrt(run_res2) / scale


@njit(inline="always")
def check_spaced(iterations, last_check):
    """Whether the check pass may follow the sweep ``iterations``: at least max(1,
    ``iterations`` / CHECK_SPACING) sweeps after the last check (``last_check``), so that the
    checks cost at most ~1 / CHECK_SPACING of the sweeps (a check costs about half a sweep;
    in sheared packings the change stays below the tolerance while the residual does not, and
    a check after every sweep made the steps up to 70 % longer) and delay convergence by as
    much."""
    return iterations - last_check >= max(1, iterations // CHECK_SPACING)


@njit(inline="always")
def check_due(running, tolerance, iterations, last_check):
    """Whether a sweep without a change tolerance is followed by the check pass: once the
    running residual is below CHECK_FACTOR x ``tolerance`` (it runs a sweep late and above
    the check's), spaced as :func:`check_spaced`."""
    return running <= CHECK_FACTOR * tolerance and check_spaced(iterations, last_check)




