"""Contact dynamics (Moreau-Jean / NSCD) time step for rigid sphere-based bodies
(Numba; research/cd_engines.md 6.1-6.3, 6.6; STYLE.md 2, 8, 10, 12).

Time step (theta-scheme, per body; translation and angular velocity in the world frame)::

    v_free = v_i + h M^-1 F_ext              F_ext = m g (constant over the step)
    w_free = w_i                             (gyroscopic term: see below)
    q_m    = q_i (+) (1 - theta) h (v_i, w_i) detection configuration
    detect contacts at q_m: point x_a, frame (n, t, s), gap g_a, arms r_ia, r_ja
    solve  U = U_free + W P,  law(U, P, g)   NLGS on the impulses P [N s]
    v_{i+1} = v_free + M^-1 H P
    q_{i+1} = q_m (+) theta h (v_{i+1}, w_{i+1})

h [s] is the time step, theta in [0.5, 1]. Rotations use the exponential map of the rotation
vector h w on the unit quaternion (world frame: q <- exp(h w / 2) q).

Gyroscopic term. Spheres have isotropic inertia, so w x I w = 0 and nothing is neglected.
For aggregates it is neglected by default, as LMGC90 does (6.1, pitfall 7). With
``gyroscopic=True`` it is added to w_free semi-implicitly (one linearised backward-Euler step
in the body frame, w_b' = w_b - h J^-1 (w_b x I w_b) with J = I + h ([w_b] I - [I w_b]), which
is stable where the explicit term is not; compiled in :mod:`~grainlab.engine.gyroscopic`).

Contact law (IQS_CLB, 6.2). The impulse P = P_n n + P_t t + P_s s acts on body j (and -P on
body i); U is the relative velocity of j with respect to i at the contact point at the END of
the step, in the local frame (U_n > 0: separating). With the gap g at q_m::

    U_n' = U_n + max(0, g) / h,   U_n' >= 0,  P_n >= 0,  U_n' P_n = 0
    |P_T| <= mu P_n;  |P_T| < mu P_n => U_T = 0;  else U_T = -lambda P_T, lambda >= 0

An open gap lets the bodies approach by at most g within the step; an existing overlap
(g < 0) is NOT pushed apart (no max(0, g) < 0 term): overlaps are never corrected violently,
and are reported as ``max_overlap`` (pitfall 4). Optionally (``overlap_recovery`` = beta in
(0, 1], default 0) the gap term is g* = max(0, g) + max(beta min(0, g), -v_r h): an overlap
must open by beta |g| within the step (U_n >= beta |g| / h, at most the cap
``overlap_recovery_speed`` v_r), so overlaps left by unconverged steps decay
geometrically instead of accumulating (a Baumgarte-type stabilisation; the separation speed
is energy put in, beta |g| / h per contact).

NLGS (6.3). Body accumulators: body velocities are kept up to date with every impulse
update, so the local right-hand side of contact a is its current relative velocity minus
W_aa P_a (O(1) per update, no W_ab stored). The exact 3 x 3 Delassus block
W_aa = F (K_i + K_j) F^T, K_b = m_b^-1 1 + [r_b]^T I_b^-1 [r_b] (world inverse inertia, walls:
K = 0) is built from the arms; W_tt is clamped to >= 1e-6 W_nn (pitfall 5). Local solution:
open (P = 0) if U'_free,n >= 0; else the sticking solution P = -W^-1 U'_free if det W is not
tiny and P lies in the cone; else (sliding, or a singular block) projections from the previous
P, normal first P_n = max(0, P_n - U'_n / W_nn), then tangential on the disc,
P_T = proj_{|P_T| <= mu P_n}(P_T - U_T / lambda_max(W_TT)), repeated (at most 100 times) until
the change is below 1e-12 relative. Contacts are visited in one seeded random permutation per
step.

Warm start. A contact starts from the force (impulse / h, world frame) of the same (body_i,
body_j, member_i, member_j) at the previous step, f_n, extrapolated when the contact was there
the step before too: f_n + lambda (f_n - f_(n-1)), projected on its Coulomb cone
(``warm_start_extrapolation`` = lambda; 0 by default: f_n, not projected; the lab tests use
:data:`WARM_START_EXTRAPOLATION` = 0.5); a new contact starts from zero. In quasi-static
shear the forces of the sticking network drift steadily from step to step
(docs/discrete_engine.md, "The contact problem on its own"), and the extrapolation starts
each step further along that drift.
Measured on 1000 spheres sheared from eps_q = 0.06 to 0.08 (tolerance 1.666e-4, every step
converged): 540 / 498 / 465 / 509 / 656 sweeps a step on average with lambda = 0 / 0.25 /
0.5 / 0.75 / 1.
Where the forces are indeterminate and at rest, it feeds their drift: a cube resting on a
cube (four coplanar points, tolerance 1e-5) no longer converged with lambda = 0.5.

Sweeps. ``sweep="serial"`` runs :func:`nlgs_kernel` in the seeded random order above.
``sweep="coloured"`` (the default) greedily colours the contacts so that no two of one colour
share a body (:mod:`~grainlab.engine.contact_colouring`, linear in C) and runs
:func:`~grainlab.engine.nlgs_parallel.nlgs_coloured_kernel`: the colours one after the other,
the contacts of a colour in parallel (``numba.prange``), the contacts of mobile
(stress-controlled) walls last in a serial loop, as they all share their wall. When every
colour is below :data:`~grainlab.engine.nlgs_parallel.MIN_COLOURS` contacts (too little work
per colour to wake the threads for: up to ~10^4 spheres) and there are at least
:data:`~grainlab.engine.nlgs_parallel.MIN_SLABS` contacts, the contacts are swept in slabs of
the packing instead (:func:`~grainlab.engine.contact_colouring.slab_contacts`, 2 to 16 of
them: :func:`~grainlab.engine.nlgs_parallel.slab_count`): each slab's inside by one thread,
then the contacts between neighbouring slabs, then the mobile walls' and those that span
more than one slab. The same
local solver and convergence measures, in a fixed order: the solution agrees with the serial
sweep within the tolerance and does not depend on the number of threads.

Skipping open contacts (LMGC90's iskip idea): a contact found open (P = 0) at
:data:`SKIP_OPEN` visits in a row is left out of the sweeps, except the first sweep, every
:data:`SKIP_REVISIT`-th and the one after a failed check, which visit every contact; the
check pass always covers every contact, so a skipped contact that closes fails the residual.

Convergence (both must be <= ``tolerance`` after a sweep; the change is measured in every
sweep, the residual, which costs a pass over the contacts, only after sweeps whose change is
below the tolerance and at the cap):

- change   = ||P^k - P^(k-1)|| / ||P^k||                          (0 when both vanish)
- residual = ||w P - proj_K(w P - (U' + mu |U_T| e_n))|| / max(||U_free||, ||w P||, ||U'||)

with w = W_nn per contact (so w P is a velocity [m/s] and the residual has no units; the
natural-map residual of Siconos, K the Coulomb cone). A step that hits ``max_iterations`` is
flagged (``converged=False``) with its residual in the :class:`StepReport`, never silently;
``strict=True`` raises :class:`~grainlab.errors.ConvergenceError` instead. The flag is the
kernel's own stop test on the change and residual it reports (one evaluation). A sweep whose
impulses, or whose measures, are not finite ends the sweeps at once, and the step raises
:class:`~grainlab.errors.SolverDivergence` before anything of it reaches the state: non-finite
impulses are never an answer. A state that is not finite at the start of a step is refused
(:class:`~grainlab.errors.InputError`).

>>> import numpy as np
>>> from grainlab.engine.state import BodyState, ShapeLibrary
>>> library = ShapeLibrary.from_spheres([0.5])
>>> state = BodyState.from_library(library, [0], [[0.0, 0.0, 0.5]], density=1000.0)
>>> step = ContactDynamicsStep(dt=1e-3, gravity=(0.0, 0.0, -9.81))
>>> report = step.step(state, library, walls=([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]]))
>>> report.n_contacts, report.converged, abs(float(state.velocities[0, 2])) < 1e-12
(1, True, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from llvmlite import ir
from numba import get_num_threads, njit, types
from numba.core.extending import intrinsic

from grainlab._validate import at_least, in_range
from grainlab.contact.contact_kinematics import point_velocity
from grainlab.contact.coulomb_cone import local_solve, natural_map
from grainlab.engine.boundary import (
    BoundaryMotion,
    ClosedContacts,
    DetectionPhases,
    as_boundary,
)
from grainlab.engine.contact_colouring import colour_contacts, slab_contacts, spatial_order
from grainlab.engine.contact_problem import (
    FrictionalContactProblem,
    assemble_problem,
    project_on_cones,
)
from grainlab.engine.convergence import Convergence
from grainlab.engine.gyroscopic import gyroscopic_spins
from grainlab.engine.narrow_phase import Contacts
from grainlab.engine.quaternion import quat_to_matrices, turn_quaternions_kernel
from grainlab.engine.shape_kinds import library_time_step_length
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import ConvergenceError, InputError, SolverDivergence

_TINY = 1e-300
_WTT_CLAMP = 1e-6  # W_tt >= 1e-6 W_nn (LMGC90, pitfall 5)
_SWEEPS = ("coloured", "serial")
SKIP_OPEN = 2
"""A contact found open (P = 0) at this many visits in a row is skipped by the sweeps
(LMGC90's iskip idea, research/cd_engines.md 1.3) ..."""
OUTWARD_SPEED_FACTOR = 4.0
"""A speed-limited wall moves out at most this many times its inward limit."""
SKIP_REVISIT = 10
WARM_START_EXTRAPOLATION = 0.5
"""lambda of the extrapolated warm start in the lab tests (module docstring, "Warm start";
the engine's default is 0)."""
CHECK_FACTOR = 2.0
SPATIAL_ORDER_BODIES = 4096
"""From this many bodies, the coloured sweep works on the bodies in Morton order
(:func:`~grainlab.engine.contact_colouring.spatial_order`: the same results, better use of the
caches)."""
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
def _relative_velocity(k, body_i, body_j, frame, arm_i, arm_j, velocities, spins,
                       wall_normals, wall_speeds, images, cell_rate):
    """Local (n, t, s) velocity of body j relative to body i at contact k [m/s]; a wall
    (body_i = -1 - w) moves with the speed ``wall_speeds[w]`` along its normal; in a periodic
    cell body j may be its image translated by h m_k (``images[k]`` = m_k), which moves with
    the cell: its velocity is v_j + hdot m_k, ``cell_rate`` = hdot (3, 3) [m/s]."""
    ux, uy, uz = 0.0, 0.0, 0.0
    j = body_j[k]
    if j >= 0:
        wx, wy, wz = spins[j, 0], spins[j, 1], spins[j, 2]
        px, py, pz = point_velocity(velocities[j, 0], velocities[j, 1], velocities[j, 2],
                                    wx, wy, wz, arm_j[k, 0], arm_j[k, 1], arm_j[k, 2])
        ux, uy, uz = ux + px, uy + py, uz + pz
        mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
        if mx != 0.0 or my != 0.0 or mz != 0.0:
            ux += cell_rate[0, 0] * mx + cell_rate[0, 1] * my + cell_rate[0, 2] * mz
            uy += cell_rate[1, 0] * mx + cell_rate[1, 1] * my + cell_rate[1, 2] * mz
            uz += cell_rate[2, 0] * mx + cell_rate[2, 1] * my + cell_rate[2, 2] * mz
    i = body_i[k]
    if i >= 0:
        wx, wy, wz = spins[i, 0], spins[i, 1], spins[i, 2]
        px, py, pz = point_velocity(velocities[i, 0], velocities[i, 1], velocities[i, 2],
                                    wx, wy, wz, arm_i[k, 0], arm_i[k, 1], arm_i[k, 2])
        ux, uy, uz = ux - px, uy - py, uz - pz
    else:
        w = -1 - i
        ux -= wall_speeds[w] * wall_normals[w, 0]
        uy -= wall_speeds[w] * wall_normals[w, 1]
        uz -= wall_speeds[w] * wall_normals[w, 2]
    return (frame[k, 0, 0] * ux + frame[k, 0, 1] * uy + frame[k, 0, 2] * uz,
            frame[k, 1, 0] * ux + frame[k, 1, 1] * uy + frame[k, 1, 2] * uz,
            frame[k, 2, 0] * ux + frame[k, 2, 1] * uy + frame[k, 2, 2] * uz)


@njit(inline="always")
def _apply(k, dn, dt_, ds, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
           velocities, spins, wall_normals, wall_inv_mass, wall_speeds, images, cell_basis,
           cell_inv_mass, cell_dofs, cell_rate):
    """Add the local impulse change (dn, dt_, ds) of contact k to its two bodies (a wall
    moves only along its normal, with inverse mass ``wall_inv_mass[w]``, 0 if driven); a
    contact with an image (``images[k]`` = m_k != 0) also drives the periodic cell's free
    degrees of freedom e_d (:func:`_apply_to_cell`)."""
    px = frame[k, 0, 0] * dn + frame[k, 1, 0] * dt_ + frame[k, 2, 0] * ds
    py = frame[k, 0, 1] * dn + frame[k, 1, 1] * dt_ + frame[k, 2, 1] * ds
    pz = frame[k, 0, 2] * dn + frame[k, 1, 2] * dt_ + frame[k, 2, 2] * ds
    if cell_inv_mass.shape[0] > 0:
        _apply_to_cell(k, px, py, pz, images, cell_basis, cell_inv_mass, cell_dofs, cell_rate)
    for side in range(2):
        b = body_j[k] if side == 0 else body_i[k]
        if b < 0:
            w = -1 - b
            if wall_inv_mass[w] > 0.0:
                wall_speeds[w] -= wall_inv_mass[w] * (
                    px * wall_normals[w, 0] + py * wall_normals[w, 1] + pz * wall_normals[w, 2])
            continue
        sign = 1.0 if side == 0 else -1.0
        if side == 0:
            rx, ry, rz = arm_j[k, 0], arm_j[k, 1], arm_j[k, 2]
        else:
            rx, ry, rz = arm_i[k, 0], arm_i[k, 1], arm_i[k, 2]
        fx, fy, fz = sign * px, sign * py, sign * pz
        velocities[b, 0] += inv_mass[b] * fx
        velocities[b, 1] += inv_mass[b] * fy
        velocities[b, 2] += inv_mass[b] * fz
        tx, ty, tz = ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx
        for d in range(3):
            spins[b, d] += (inv_inertia[b, d, 0] * tx + inv_inertia[b, d, 1] * ty
                            + inv_inertia[b, d, 2] * tz)


@njit(inline="always")
def _apply_to_cell(k, px, py, pz, images, cell_basis, cell_inv_mass, cell_dofs, cell_rate):
    """The cell's share of a world impulse change (px, py, pz) [N s] on the image of body j
    at contact k: each free degree of freedom e_d (hdot = hdot_fixed + sum_d e_d H_d, H_d =
    ``cell_basis[d]`` (3, 3) [m]) changes by kappa_d (H_d m_k) . P, kappa_d =
    ``cell_inv_mass[d]`` [1/(N s^2)] (:mod:`grainlab.engine.periodic_boundary`), and hdot
    with it."""
    mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
    if mx == 0.0 and my == 0.0 and mz == 0.0:
        return
    for d in range(cell_inv_mass.shape[0]):
        if cell_inv_mass[d] > 0.0:
            h = cell_basis[d]
            gx = h[0, 0] * mx + h[0, 1] * my + h[0, 2] * mz
            gy = h[1, 0] * mx + h[1, 1] * my + h[1, 2] * mz
            gz = h[2, 0] * mx + h[2, 1] * my + h[2, 2] * mz
            delta = cell_inv_mass[d] * (px * gx + py * gy + pz * gz)
            cell_dofs[d] += delta
            for a in range(3):
                for b in range(3):
                    cell_rate[a, b] += delta * h[a, b]


@njit(inline="always")
def brake_cell(cell_basis, cell_inv_mass, cell_bounds, brakes, cell_dofs, cell_rate):
    """Bounds lo_d <= e_d <= hi_d (``cell_bounds`` (D, 2)) on the cell's free degrees of
    freedom, solved in the sweep like :func:`brake_walls`: a brake impulse with the exact local
    solution, kept from sweep to sweep so that it lets go when the contacts hold the cell."""
    for d in range(cell_dofs.shape[0]):
        inv = cell_inv_mass[d]
        if inv > 0.0:
            free = cell_dofs[d] + brakes[d] * inv
            held = min(max(free, cell_bounds[d, 0]), cell_bounds[d, 1])
            brakes[d] = (free - held) / inv
            delta = held - cell_dofs[d]
            cell_dofs[d] = held
            if delta != 0.0:
                for a in range(3):
                    for b in range(3):
                        cell_rate[a, b] += delta * cell_basis[d, a, b]


@njit(inline="always")
def start_cell(cell_fixed, cell_basis, cell_free, cell_dofs, cell_rate):
    """hdot = hdot_fixed + sum_d e_d H_d with the free values e_d = ``cell_free[d]``."""
    cell_rate[:, :] = cell_fixed
    for d in range(cell_free.shape[0]):
        cell_dofs[d] = cell_free[d]
        for a in range(3):
            for b in range(3):
                cell_rate[a, b] += cell_free[d] * cell_basis[d, a, b]


@njit(inline="always")
def brake_walls(wall_inv_mass, wall_max_speeds, brakes, wall_speeds):
    """Speed limits of the mobile walls, -OUTWARD_SPEED_FACTOR s_max <= s_w <= s_max, solved
    in the Gauss-Seidel sweep: a brake impulse B_w [N s] (positive outward), the exact local
    solution B_w = m_w (s_free - clamp(s_free)) with s_free = s_w + B_w / m_w the speed
    without it. Inwards the limit bounds the inertia number; outwards (a looser bound) it
    keeps a wall shoved by a stress spike from jumping away from a rigid sample."""
    for w in range(wall_speeds.shape[0]):
        if wall_inv_mass[w] > 0.0 and wall_max_speeds[w] < np.inf:
            free = wall_speeds[w] + brakes[w] * wall_inv_mass[w]
            held = min(max(free, -OUTWARD_SPEED_FACTOR * wall_max_speeds[w]),
                       wall_max_speeds[w])
            brakes[w] = (free - held) / wall_inv_mass[w]
            wall_speeds[w] = held


@njit(inline="always")
def update_contact(k, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
                    wall_normals, wall_inv_mass, mu, shift, impulses, velocities, spins,
                    wall_speeds, delassus, images, cell_basis, cell_inv_mass, cell_dofs,
                    cell_rate, running):
    """One Gauss-Seidel update (serial and coloured sweeps): local solve of contact k
    against the current body velocities; applies the impulse change to its bodies and
    returns its squared norm [N^2 s^2]. Before the update it writes the contact's share of
    the running residual into ``running[k]``: (||natural map||^2, ||w P||^2, ||U'||^2)
    [m^2/s^2] at the current iterate (module docstring); not with an empty ``running``
    (0, 3), when the change decides."""
    w = delassus[k]
    un, ut, us = _relative_velocity(k, body_i, body_j, frame, arm_i, arm_j,
                                    velocities, spins, wall_normals, wall_speeds, images,
                                    cell_rate)
    p0, p1, p2 = impulses[k, 0], impulses[k, 1], impulses[k, 2]
    vn = un + shift[k]
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
    _apply(k, d0, d1, d2, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
           velocities, spins, wall_normals, wall_inv_mass, wall_speeds, images, cell_basis,
           cell_inv_mass, cell_dofs, cell_rate)
    return d0 * d0 + d1 * d1 + d2 * d2


@njit(inline="always")
def skipped_update(k, skip, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
                   wall_normals, wall_inv_mass, mu, shift, impulses, velocities, spins,
                   wall_speeds, delassus, open_sweeps, images, cell_basis, cell_inv_mass,
                   cell_dofs, cell_rate, running):
    """:func:`update_contact` unless contact k has been open (P = 0) at its last ``skip``
    visits (then it is left alone, its running-residual share zero, and 0 returned);
    ``open_sweeps[k]`` counts those visits."""
    if open_sweeps[k] >= skip:
        if running.shape[0] > 0:
            running[k, 0] = 0.0
            running[k, 1] = 0.0
            running[k, 2] = 0.0
        return 0.0
    change = update_contact(k, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
                            wall_normals, wall_inv_mass, mu, shift, impulses, velocities,
                            spins, wall_speeds, delassus, images, cell_basis, cell_inv_mass,
                            cell_dofs, cell_rate, running)
    if impulses[k, 0] == 0.0:
        open_sweeps[k] += 1
    else:
        open_sweeps[k] = 0
    return change


# --------------------------------------------------------------------------------------------
# Array kernels (outputs last)
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def delassus_kernel(body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                    wall_inv_mass, images, cell_basis, cell_inv_mass, out):
    """Local Delassus blocks W_aa (C, 3, 3) [1/kg] = F (K_i + K_j) F^T (module docstring);
    a wall w contributes K = wall_inv_mass[w] n_w n_w^T, and the free degrees of freedom of
    a periodic cell K = sum_d kappa_d g_d g_d^T at a contact with an image m_k (g_d =
    H_d m_k, :func:`_apply_to_cell`)."""
    _delassus_blocks(body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                     wall_inv_mass, images, cell_basis, cell_inv_mass, np.empty((3, 3, 3)), out)


# no reference counts on the arrays in the loops (inline helpers): compiled without the Numba
# runtime (_nrt=False), so it allocates nothing (scratch from the caller)
@njit(cache=True, _nrt=False)
def _delassus_blocks(body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                     wall_inv_mass, images, cell_basis, cell_inv_mass, scratch, out):
    """:func:`delassus_kernel` with a scratch array (3, 3, 3) for K, [r] and products."""
    k_world, skew, product = scratch[0], scratch[1], scratch[2]
    for k in range(body_i.shape[0]):
        for d in range(3):
            for e in range(3):
                k_world[d, e] = 0.0
        for side in range(2):
            b = body_j[k] if side == 0 else body_i[k]
            if b < 0:
                w = -1 - b
                for d in range(3):
                    for e in range(3):
                        k_world[d, e] += (wall_inv_mass[w] * wall_normals[w, d]
                                          * wall_normals[w, e])
                continue
            r = arm_j[k] if side == 0 else arm_i[k]
            skew[0, 0], skew[0, 1], skew[0, 2] = 0.0, -r[2], r[1]
            skew[1, 0], skew[1, 1], skew[1, 2] = r[2], 0.0, -r[0]
            skew[2, 0], skew[2, 1], skew[2, 2] = -r[1], r[0], 0.0
            # [r]^T I^-1 [r] = -[r] I^-1 [r]
            inv = inv_inertia[b]
            for d in range(3):
                for e in range(3):
                    product[d, e] = _dot3(skew[d, 0], skew[d, 1], skew[d, 2],
                                          inv[0, e], inv[1, e], inv[2, e])
            for d in range(3):
                for e in range(3):
                    k_world[d, e] -= _dot3(product[d, 0], product[d, 1], product[d, 2],
                                           skew[0, e], skew[1, e], skew[2, e])
            for d in range(3):
                k_world[d, d] += inv_mass[b]
        mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
        if mx != 0.0 or my != 0.0 or mz != 0.0:
            for c in range(cell_inv_mass.shape[0]):
                h = cell_basis[c]
                gx = h[0, 0] * mx + h[0, 1] * my + h[0, 2] * mz
                gy = h[1, 0] * mx + h[1, 1] * my + h[1, 2] * mz
                gz = h[2, 0] * mx + h[2, 1] * my + h[2, 2] * mz
                kappa = cell_inv_mass[c]
                k_world[0, 0] += kappa * gx * gx
                k_world[0, 1] += kappa * gx * gy
                k_world[0, 2] += kappa * gx * gz
                k_world[1, 0] += kappa * gy * gx
                k_world[1, 1] += kappa * gy * gy
                k_world[1, 2] += kappa * gy * gz
                k_world[2, 0] += kappa * gz * gx
                k_world[2, 1] += kappa * gz * gy
                k_world[2, 2] += kappa * gz * gz
        # W = F K F^T
        f = frame[k]
        for d in range(3):
            for e in range(3):
                product[d, e] = _dot3(f[d, 0], f[d, 1], f[d, 2],
                                      k_world[0, e], k_world[1, e], k_world[2, e])
        for d in range(3):
            for e in range(3):
                out[k, d, e] = _dot3(product[d, 0], product[d, 1], product[d, 2],
                                     f[e, 0], f[e, 1], f[e, 2])
        for d in range(1, 3):
            out[k, d, d] = max(out[k, d, d], _WTT_CLAMP * out[k, 0, 0])


@njit(cache=True)
def nlgs_kernel(
    body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, free_velocities, free_spins,
    wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
    mu, gap, dt, images, cell_fixed, cell_basis, cell_inv_mass, cell_free, cell_bounds,
    order, tolerance, change_tolerance, max_iterations,
    impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus, residuals,
):
    """Frictional unilateral contact problem on impulses by nonlinear Gauss-Seidel.

    Inputs: contact bodies ``body_i``, ``body_j`` (C,) (negative: a fixed wall, infinite
    mass); local frames ``frame`` (C, 3, 3), rows n (from i to j), t, s; arms (C, 3) [m] from
    each body's centre to the contact point; ``inv_mass`` (N,) [1/kg]; world inverse inertia
    tensors ``inv_inertia`` (N, 3, 3) [1/(kg m^2)]; free velocities (N, 3) [m/s] and angular
    velocities (N, 3) [rad/s]; walls: unit normals ``wall_normals`` (W, 3), inverse masses
    ``wall_inv_mass`` (W,) [1/kg] (0: driven), free normal speeds ``wall_free_speeds`` (W,)
    [m/s] and speed limits ``wall_max_speeds`` (W,) [m/s] (inf: none; :func:`brake_walls`);
    friction ``mu`` (C,); ``gap`` (C,) [m] at the detection
    configuration; time step ``dt`` [s]; periodic cell (D = 0 free degrees of freedom and
    zero images in a wall box): image vectors ``images`` (C, 3) (float; body j's image is
    translated by h m_k and moves with v_j + hdot m_k), the prescribed part of hdot
    ``cell_fixed`` (3, 3) [m/s], per free degree of freedom d its direction ``cell_basis``
    (D, 3, 3) [m], inverse mass ``cell_inv_mass`` (D,), free value ``cell_free`` (D,) and
    bounds ``cell_bounds`` (D, 2) (:mod:`grainlab.engine.periodic_boundary`); visiting
    ``order`` (C,) (a permutation); ``tolerance`` on the natural-map residual and
    ``change_tolerance`` on the relative change (inf: the change is measured, not required;
    module docstring, "Convergence").

    Outputs: ``impulses`` (C, 3) local (P_n, P_t, P_s) [N s] (in: warm start; out: solution);
    ``velocities``, ``spins`` (N, 3) end-of-step velocities; ``wall_speeds`` (W,) end-of-step
    wall normal speeds; ``cell_dofs`` (D,) end-of-step free degrees of freedom and
    ``cell_rate`` (3, 3) the cell's hdot [m/s]; ``delassus`` (C, 3, 3);
    ``residuals`` (2,) = (relative change, natural-map residual) of the last sweep.
    Returns the number of sweeps done (``max_iterations`` when not converged, fewer when
    a change or residual was not finite: ``residuals`` then holds it).
    """
    n_contacts = body_i.shape[0]
    velocities[:, :] = free_velocities
    spins[:, :] = free_spins
    wall_speeds[:] = wall_free_speeds
    brakes = np.zeros(wall_speeds.shape[0])
    cell_brakes = np.zeros(cell_dofs.shape[0])
    start_cell(cell_fixed, cell_basis, cell_free, cell_dofs, cell_rate)
    free_rate = cell_rate.copy()
    residuals[0] = 0.0
    residuals[1] = 0.0
    if n_contacts == 0:
        brake_walls(wall_inv_mass, wall_max_speeds, brakes, wall_speeds)
        brake_cell(cell_basis, cell_inv_mass, cell_bounds, cell_brakes, cell_dofs, cell_rate)
        return 0
    delassus_kernel(body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                    wall_inv_mass, images, cell_basis, cell_inv_mass, delassus)
    measured = n_contacts if change_tolerance == np.inf else 0  # running residual rows
    return _serial_sweeps(
        body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, free_velocities,
        free_spins, wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
        mu, gap, dt, images, cell_basis, cell_inv_mass, cell_bounds, free_rate,
        order, tolerance, change_tolerance, max_iterations,
        impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus, residuals,
        np.empty(n_contacts), brakes, cell_brakes, np.zeros(n_contacts, dtype=np.int64),
        np.zeros((measured, 3)))


@njit(cache=True, _nrt=False)
def _serial_sweeps(
    body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, free_velocities, free_spins,
    wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
    mu, gap, dt, images, cell_basis, cell_inv_mass, cell_bounds, free_rate,
    order, tolerance, change_tolerance, max_iterations,
    impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus, residuals,
    shift, brakes, cell_brakes, open_sweeps, running,
):
    """Warm start, sweeps and checks of :func:`nlgs_kernel` once the velocities, the cell
    and the Delassus blocks are set up (``free_rate`` (3, 3) [m/s] the cell's free hdot);
    scratch ``shift`` (C,), wall and cell brakes (W,), (D,), ``open_sweeps`` (C,) int64
    zeros, ``running`` (C, 3) the running-residual shares ((0, 3) with a finite
    ``change_tolerance``: not measured). Returns the sweeps done. Compiled
    without the Numba runtime: the inlined scalar
    laws then take their arrays without atomic reference counting."""
    n_contacts = body_i.shape[0]
    free_norm2 = 0.0
    for k in range(n_contacts):
        shift[k] = gap[k] / dt
        un, ut, us = _relative_velocity(k, body_i, body_j, frame, arm_i, arm_j,
                                        free_velocities, free_spins, wall_normals,
                                        wall_free_speeds, images, free_rate)
        free_norm2 += (un + shift[k]) ** 2 + ut * ut + us * us
    for k in range(n_contacts):  # warm start
        _apply(k, impulses[k, 0], impulses[k, 1], impulses[k, 2], body_i, body_j, frame,
               arm_i, arm_j, inv_mass, inv_inertia, velocities, spins, wall_normals,
               wall_inv_mass, wall_speeds, images, cell_basis, cell_inv_mass, cell_dofs,
               cell_rate)
    iterations = 0
    last_check = 0
    full = True  # visit every contact (SKIP_OPEN, SKIP_REVISIT)
    while iterations < max_iterations:
        iterations += 1
        change2 = 0.0
        sweep_p2 = 0.0
        skip = SKIP_OPEN if not full else max_iterations + 1
        for m in range(n_contacts):
            k = order[m]
            change2 += skipped_update(
                k, skip, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
                wall_normals, wall_inv_mass, mu, shift, impulses, velocities, spins,
                wall_speeds, delassus, open_sweeps, images, cell_basis, cell_inv_mass,
                cell_dofs, cell_rate, running)
            sweep_p2 += impulses[k, 0] ** 2 + impulses[k, 1] ** 2 + impulses[k, 2] ** 2
        brake_walls(wall_inv_mass, wall_max_speeds, brakes, wall_speeds)
        brake_cell(cell_basis, cell_inv_mass, cell_bounds, cell_brakes, cell_dofs, cell_rate)
        full = iterations % SKIP_REVISIT == 0
        change = 0.0 if change2 == 0.0 else math.sqrt(change2 / max(sweep_p2, _TINY))
        residuals[0] = change
        if not math.isfinite(change):  # non-finite impulses: stop, the caller refuses them
            residuals[1] = math.nan
            break
        if iterations < max_iterations:
            if change_tolerance < np.inf:
                if change > change_tolerance or not check_spaced(iterations, last_check):
                    continue  # the residual pass only once the change is small
            else:
                run_res2, run_wp2, run_u2 = 0.0, 0.0, 0.0
                for k in range(n_contacts):
                    run_res2 += running[k, 0]
                    run_wp2 += running[k, 1]
                    run_u2 += running[k, 2]
                if not check_due(running_residual(run_res2, run_wp2, run_u2, free_norm2),
                                 tolerance, iterations, last_check):
                    continue  # the residual pass only once the running residual is small
        # check pass (no update)
        last_check = iterations
        p_norm2, wp_norm2, u_norm2, res2 = 0.0, 0.0, 0.0, 0.0
        for k in range(n_contacts):
            un, ut, us = _relative_velocity(k, body_i, body_j, frame, arm_i, arm_j,
                                            velocities, spins, wall_normals, wall_speeds,
                                            images, cell_rate)
            p_norm2 += impulses[k, 0] ** 2 + impulses[k, 1] ** 2 + impulses[k, 2] ** 2
            r2, z2, u2 = natural_map(mu[k], delassus[k, 0, 0], impulses[k, 0], impulses[k, 1],
                                     impulses[k, 2], un + shift[k], ut, us)
            wp_norm2 += z2
            u_norm2 += u2
            res2 += r2
        scale = max(math.sqrt(free_norm2), math.sqrt(wp_norm2), math.sqrt(u_norm2), _TINY)
        residual = math.sqrt(res2) / scale
        residuals[0] = change
        residuals[1] = residual
        if (change <= change_tolerance and residual <= tolerance) \
                or not math.isfinite(residual):
            break
        full = True
    return iterations


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


# --------------------------------------------------------------------------------------------
# Python launcher
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class StepReport:
    """Outcome of one :meth:`ContactDynamicsStep.step`.

    ``n_contacts``; NLGS ``iterations`` (sweeps), ``converged``, ``change`` and ``residual``
    (module docstring); ``max_overlap`` [m] = max(0, -min gap) at the detection
    configuration; the ``contacts`` detected, their ``frames`` (C, 3, 3) (rows n, t, s),
    ``impulses`` (C, 3) local (P_n, P_t, P_s) [N s], end-of-step relative velocities
    ``relative_velocity`` (C, 3) local [m/s] (U, without the gap correction) and, in a
    periodic cell, the ``images`` (C, 3) of body j (contact k is with body j translated by
    h m_k); with ``keep_problem`` on the step, the step's plain ``problem``
    (:func:`~grainlab.engine.contact_problem.assemble_problem`; its solution is ``impulses``
    unless a wall or cell speed limit held).
    """

    n_contacts: int
    iterations: int
    converged: bool
    change: float
    residual: float
    max_overlap: float
    contacts: Contacts
    frames: np.ndarray
    impulses: np.ndarray
    relative_velocity: np.ndarray
    images: np.ndarray | None = None
    problem: FrictionalContactProblem | None = None
    explicit: bool = False

    @property
    def convergence(self) -> Convergence | None:
        """The solve's :class:`~grainlab.engine.solver.Convergence` (``iterations``,
        ``converged``, ``change``, ``residual``); None for an ``explicit`` step (the soft
        contacts of polyhedra), which has no iterations."""
        if self.explicit:
            return None
        return Convergence(self.iterations, self.converged, self.change, self.residual)

    @property
    def image_vectors(self) -> np.ndarray:
        """(C, 3) image vectors m_k (zeros outside a periodic cell)."""
        if self.images is None:
            return np.zeros((self.n_contacts, 3))
        return self.images


def contact_frames(normals: np.ndarray) -> np.ndarray:
    """Local frames (C, 3, 3), rows (n, t, s): t is n x e normalised, e the axis least
    aligned with n, and s = n x t."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    axis = np.zeros_like(n)
    axis[np.arange(n.shape[0]), np.argmin(np.abs(n), axis=1)] = 1.0
    t = np.cross(n, axis)
    t /= np.linalg.norm(t, axis=1)[:, None]
    s = np.cross(n, t)
    return np.ascontiguousarray(np.stack([n, t, s], axis=1))


def rotate_quaternions(q: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """exp(rotation / 2) q, normalised, for unit quaternions q (N, 4) and world rotation
    vectors (N, 3) [rad] (:func:`~grainlab.engine.quaternion.turn_quaternions_kernel`: the
    same bits on every processor)."""
    q = np.ascontiguousarray(q, dtype=np.float64).reshape(-1, 4)
    out = np.empty_like(q)
    turn_quaternions_kernel(q, np.ascontiguousarray(rotation, dtype=np.float64).reshape(-1, 3),
                            out)
    return out


class ContactDynamicsStep:
    """One NSCD time step for sphere-based rigid bodies and fixed plane walls.

    Parameters
    ----------
    dt:
        Time step h [s] > 0 (pitfall 6: v_max h <= 0.01-0.05 d_min).
    theta:
        theta-scheme parameter in [0.5, 1].
    tolerance:
        NLGS tolerance on the natural-map residual (> 0, no units).
    change_tolerance:
        Tolerance on the relative change of the impulses between two sweeps (> 0); None
        (default): the same as ``tolerance``; inf: the change is measured and reported, not
        required (module docstring, "Convergence").
    max_iterations:
        NLGS sweep cap (>= 1).
    gravity:
        Acceleration (3,) [m/s^2].
    friction:
        Coulomb coefficient mu >= 0 of every contact.
    alert:
        Alert distance [m] >= 0; None: 0.1 x the smallest member radius (6.2). It grows
        (``alert_growths`` counts it) when bodies could close a larger gap within one step.
    gyroscopic:
        Add w x I w semi-implicitly (module docstring); False neglects it.
    strict:
        Raise :class:`~grainlab.errors.ConvergenceError` when NLGS does not converge.
    seed:
        Seed of the per-step random visiting order (``sweep="serial"``).
    sweep:
        NLGS visiting order: ``"coloured"`` (parallel over graph-coloured contacts) or
        ``"serial"`` (one seeded random permutation per step); module docstring.
    overlap_recovery:
        beta in [0, 1]: an existing overlap (g < 0) must open by beta |g| within the step
        (U_n >= beta |g| / h; module docstring); 0 (default): the pure law, overlaps kept.
    overlap_recovery_speed:
        Largest separation speed [m/s] > 0 the recovery may ask for (U_n >= min(beta |g| / h,
        this)); inf (default): no cap. beta |g| / h grows as the step shrinks: with the short
        steps of spinning polyhedra it reached ~1 m/s and blew an 8-polyhedron sample apart
        (p jumped to 7.7e7 Pa at the first shearing step).
    warm_start_extrapolation:
        lambda in [0, 1]: a contact found in the two previous steps starts from its last
        force plus lambda times that force's change over the last step, projected on its
        Coulomb cone (module docstring, "Warm start"); 0: from its last force.
    """

    def __init__(
        self, dt: float, theta: float = 0.5, tolerance: float = 1e-5,
        max_iterations: int = 1000, gravity=(0.0, 0.0, 0.0), friction: float = 0.4,
        alert: float | None = None, gyroscopic: bool = False, strict: bool = False,
        seed: int = 0, sweep: str = "coloured", overlap_recovery: float = 0.0,
        overlap_recovery_speed: float = math.inf, change_tolerance: float | None = None,
        warm_start_extrapolation: float = 0.0,
    ) -> None:
        self.dt = at_least("dt", dt)
        theta_value = at_least("theta", theta)
        if not 0.5 <= theta_value <= 1.0:
            raise InputError("theta", theta, "a number in [0.5, 1]")
        self.theta = theta_value
        self.tolerance = at_least("tolerance", tolerance)
        self.change_tolerance = change_tolerance if change_tolerance in (None, math.inf) \
            else at_least("change_tolerance", change_tolerance)
        if isinstance(max_iterations, bool) or not isinstance(max_iterations, int | np.integer) \
                or max_iterations < 1:
            raise InputError("max_iterations", max_iterations, "an integer >= 1")
        self.max_iterations = int(max_iterations)
        g = np.asarray(gravity, dtype=np.float64)
        if g.shape != (3,) or not np.isfinite(g).all():
            raise InputError("gravity", gravity, "a finite (3,) acceleration in m/s^2")
        self.gravity = g
        self.friction = at_least("friction", friction, strict=False)
        self.alert = None if alert is None else at_least("alert", alert, strict=False)
        self.gyroscopic = bool(gyroscopic)
        self.strict = bool(strict)
        self._rng = np.random.default_rng(seed)
        if sweep not in _SWEEPS:
            raise InputError("sweep", sweep, "one of " + ", ".join(map(repr, _SWEEPS)))
        self.sweep = sweep
        recovery = at_least("overlap_recovery", overlap_recovery, strict=False)
        if recovery > 1.0:
            raise InputError("overlap_recovery", overlap_recovery, "a number in [0, 1]")
        self.overlap_recovery = recovery
        self.overlap_recovery_speed = math.inf if overlap_recovery_speed == math.inf else \
            at_least("overlap_recovery_speed", overlap_recovery_speed)
        self.warm_start_extrapolation = in_range(
            "warm_start_extrapolation", warm_start_extrapolation, 0.0, 1.0, closed="[]")
        self._warm_keys = np.zeros(0, dtype=np.int64)
        self._warm_forces = np.zeros((0, 3))
        self._earlier_keys = np.zeros(0, dtype=np.int64)
        self._earlier_forces = np.zeros((0, 3))
        self.alert_growths = 0
        self._detection: DetectionPhases | None = None
        self.keep_problem = False
        """Attach each step's plain problem to its report (``StepReport.problem``)."""

    def _phases(self, library: ShapeLibrary, travel: float = 0.0) -> DetectionPhases:
        """Broad and narrow phases; the alert distance grows (never shrinks) to 1.5 x
        ``travel`` [m] when bodies may close a gap larger than it within one step (so that no
        contact can be missed: tunnelling)."""
        if self._detection is not None and travel > self._detection.alert:
            self._detection = None
            self.alert = 1.5 * travel
            self.alert_growths += 1
        if self._detection is None:
            alert = self.alert if self.alert is not None else \
                0.1 * _smallest_radius(library)
            self._detection = DetectionPhases.with_alert(alert)
        return self._detection

    def _free_spins(self, state: BodyState, rotations: np.ndarray) -> np.ndarray:
        omega = np.array(state.angular_velocities, dtype=np.float64)
        if not self.gyroscopic:
            return omega
        return gyroscopic_spins(omega, rotations, state.inertias, self.dt)


    def step(self, state: BodyState, library: ShapeLibrary, walls=None) -> StepReport:
        """Advance ``state`` in place by one step.

        ``walls`` is the boundary (:mod:`grainlab.engine.boundary`): a
        :class:`~grainlab.engine.wall_box.WallBox` (moving, driven walls; advanced in place,
        reactions recorded, per-wall friction), a periodic cell
        (:class:`~grainlab.engine.periodic_boundary.PeriodicCell`), None (open space) or
        (points (W, 3) [m], normals (W, 3)) of fixed planes with normals pointing into the
        bodies' region (friction ``self.friction``)."""
        h, theta = self.dt, self.theta
        _check_finite_state(state)
        boundary = as_boundary(walls, self.friction)
        bounds = boundary.constraints(h, theta)
        # largest approach within the step: two bodies (or a body and a wall) closing in
        speed = float(np.sqrt(np.max(np.sum(state.velocities**2, axis=1)))) \
            if state.n_bodies else 0.0
        phases = self._phases(library, h * (2.0 * speed + bounds.speed
                                            + float(np.linalg.norm(self.gravity)) * h))
        kernel_normals = np.ascontiguousarray(bounds.wall_normals, dtype=np.float64)
        n_bodies = state.n_bodies
        rotations = quat_to_matrices(state.orientations)
        # free velocities and detection configuration q_m
        free_v = np.ascontiguousarray(state.velocities + h * self.gravity[None, :])
        free_w = np.ascontiguousarray(self._free_spins(state, rotations))
        x_m = state.positions + (1.0 - theta) * h * state.velocities
        q_m = rotate_quaternions(state.orientations, (1.0 - theta) * h * state.angular_velocities)
        predicted = replace(state, positions=x_m, orientations=q_m)
        if np.any(bounds.affine_change != 0.0):  # a periodic cell whose rate changed
            centre = np.average(x_m, axis=0, weights=state.masses)
            free_v += (x_m - centre) @ bounds.affine_change.T
        contacts, images = boundary.detect(predicted, library, phases, bounds)
        n_contacts = contacts.n_contacts
        images = np.ascontiguousarray(images, dtype=np.float64)
        # local frames, arms, masses and world inverse inertia at q_m
        frames = contact_frames(contacts.normal)
        arm_i = np.zeros((n_contacts, 3))
        inner = contacts.body_i >= 0
        arm_i[inner] = contacts.point[inner] - x_m[contacts.body_i[inner]]
        arm_j = np.ascontiguousarray(contacts.point - x_m[contacts.body_j])
        crossing = np.any(images != 0.0, axis=1)
        if np.any(crossing):  # the arm of j reaches from its image: x_j + h_m m_k
            arm_j[crossing] -= images[crossing] @ bounds.cell_matrix.T
        inv_mass = 1.0 / state.masses
        r_m = quat_to_matrices(q_m)
        inv_inertia = np.ascontiguousarray(
            np.einsum("nij,nj,nkj->nik", r_m, 1.0 / state.inertias, r_m))
        keys = contact_keys(contacts, n_bodies, library)
        mu = np.full(n_contacts, self.friction)
        on_wall = ~inner
        if np.any(on_wall):
            mu[on_wall] = bounds.wall_friction[-1 - contacts.body_i[on_wall]]
        impulses = h * np.einsum("cij,cj->ci", frames, self._warm_start_forces(keys))
        if self.warm_start_extrapolation > 0.0:
            impulses = project_on_cones(impulses, mu)
        velocities = np.empty((n_bodies, 3))
        spins = np.empty((n_bodies, 3))
        wall_speeds = np.empty(bounds.n_walls)
        n_cell = bounds.cell_inv_mass.shape[0]
        cell_dofs = np.empty(n_cell)
        cell_rate = np.empty((3, 3))
        delassus = np.empty((n_contacts, 3, 3))
        residuals = np.zeros(2)
        # gap term g* [m] of the law U_n + g*/h >= 0: max(0, g) + max(beta min(0, g), -v_r h)
        gap_term = np.maximum(contacts.gap, 0.0) + np.maximum(
            self.overlap_recovery * np.minimum(contacts.gap, 0.0),
            -self.overlap_recovery_speed * h)
        kernel_inv_mass = np.ascontiguousarray(bounds.wall_inv_mass, dtype=np.float64)
        walls_in = (kernel_normals, kernel_inv_mass,
                    np.ascontiguousarray(bounds.wall_free, dtype=np.float64),
                    np.ascontiguousarray(bounds.wall_max, dtype=np.float64))
        cell_in = (images, np.ascontiguousarray(bounds.cell_fixed, dtype=np.float64),
                   np.ascontiguousarray(bounds.cell_basis, dtype=np.float64),
                   np.ascontiguousarray(bounds.cell_inv_mass, dtype=np.float64),
                   np.ascontiguousarray(bounds.cell_free, dtype=np.float64),
                   np.ascontiguousarray(bounds.cell_bounds, dtype=np.float64))
        change_tolerance = self.tolerance if self.change_tolerance is None else \
            self.change_tolerance
        problem = None
        if self.keep_problem:
            problem = assemble_problem(
                contacts.body_i, contacts.body_j, frames, arm_i, arm_j, inv_mass, inv_inertia,
                free_v, free_w, kernel_normals, kernel_inv_mass, walls_in[2], mu, gap_term, h,
                images, cell_in[1], cell_in[2], cell_in[3], cell_in[4])
        if self.sweep == "serial":
            order = self._rng.permutation(n_contacts).astype(np.int64)
            iterations = nlgs_kernel(
                contacts.body_i, contacts.body_j, frames, np.ascontiguousarray(arm_i), arm_j,
                inv_mass, inv_inertia, free_v, free_w, *walls_in, mu, gap_term, h, *cell_in,
                order, self.tolerance, change_tolerance, self.max_iterations,
                impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus,
                residuals,
            )
        else:
            # imported here: nlgs_parallel reuses this module's scalar laws
            from grainlab.engine.nlgs_parallel import (
                MIN_COLOURS,
                MIN_SLABS,
                nlgs_coloured_kernel,
                parallel_colours,
                slab_count,
            )

            serial = crossing if bounds.has_free_cell else None
            colouring = colour_contacts(contacts.body_i, contacts.body_j, kernel_inv_mass,
                                        n_bodies, serial=serial)
            sizes = np.diff(colouring.offsets[: colouring.n_colours + 1])
            if n_contacts >= MIN_SLABS and (sizes.size == 0 or sizes.max() < MIN_COLOURS):
                # colours too small to be worth waking the threads for each: slabs instead
                # (their count and order from the packing, whatever the number of threads)
                groups = slab_contacts(contacts.body_i, contacts.body_j, x_m,
                                       kernel_inv_mass, serial=serial,
                                       n_slabs=slab_count(n_contacts))
                n_parallel = groups.n_colours if get_num_threads() > 1 else 0
                body_order = groups.body_order
            else:
                groups = colouring
                n_parallel = parallel_colours(colouring.offsets, colouring.n_colours,
                                              get_num_threads())
                body_order = spatial_order(x_m) if n_bodies >= SPATIAL_ORDER_BODIES else \
                    np.arange(n_bodies, dtype=np.int64)
            iterations = nlgs_coloured_kernel(
                contacts.body_i, contacts.body_j, frames, np.ascontiguousarray(arm_i), arm_j,
                inv_mass, inv_inertia, free_v, free_w, *walls_in, mu, gap_term, h, *cell_in,
                groups.order, groups.offsets, groups.chains, body_order, n_parallel,
                self.tolerance,
                change_tolerance, self.max_iterations,
                impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus,
                residuals,
            )
        change, residual = float(residuals[0]), float(residuals[1])
        _check_finite_solve(iterations, change, residual, impulses,
                            {"body velocities": velocities, "angular velocities": spins,
                             "wall speeds": wall_speeds, "cell rate": cell_rate}, h, speed)
        converged = n_contacts == 0 or (change <= change_tolerance
                                        and residual <= self.tolerance)
        if not converged and self.strict:
            raise ConvergenceError(
                f"NLGS did not converge in {iterations} sweeps: relative change {change:.3e}, "
                f"residual {residual:.3e} (tolerance {self.tolerance:.3e}, "
                f"{n_contacts} contacts).")
        # warm start of the next step: forces in the world frame, sorted by key
        forces = np.einsum("cji,cj->ci", frames, impulses) / h
        order_keys = np.argsort(keys, kind="stable")
        self._earlier_keys, self._earlier_forces = self._warm_keys, self._warm_forces
        self._warm_keys = keys[order_keys]
        self._warm_forces = forces[order_keys]
        relative = _relative_velocities(contacts, frames, arm_i, arm_j, velocities, spins)
        if np.any(crossing):
            relative[crossing] += np.einsum("cij,cj->ci", frames[crossing],
                                            images[crossing] @ cell_rate.T)
        if bounds.n_walls and np.any(on_wall):
            relative[on_wall] -= wall_speeds[-1 - contacts.body_i[on_wall], None] * \
                np.einsum("cij,cj->ci", frames[on_wall],
                          kernel_normals[-1 - contacts.body_i[on_wall]])
        # end-of-step configuration
        state.velocities[:] = velocities
        state.angular_velocities[:] = spins
        state.positions[:] = x_m + theta * h * velocities
        state.orientations[:] = rotate_quaternions(q_m, theta * h * spins)
        boundary.finish_step(BoundaryMotion(
            dt=h, theta=theta, wall_speeds=wall_speeds, wall_reactions=np.zeros(0),
            cell_dofs=cell_dofs, cell_rate=cell_rate,
            closed=ClosedContacts(contacts, images, impulses, forces)))
        max_overlap = float(max(0.0, -contacts.gap.min())) if n_contacts else 0.0
        return StepReport(
            n_contacts=n_contacts, iterations=int(iterations), converged=bool(converged),
            change=change, residual=residual, max_overlap=max_overlap, contacts=contacts,
            frames=frames, impulses=impulses, relative_velocity=relative, images=images,
            problem=problem,
        )

    def _warm_start_forces(self, keys: np.ndarray) -> np.ndarray:
        """World forces (C, 3) [N] the contacts of ``keys`` (C,) start from (module docstring,
        "Warm start"): the last step's force f of the same key (zero for a new contact), plus
        lambda (f - f') for a key found in the step before too (f' its force there)."""
        forces = np.zeros((keys.size, 3))
        found, where = _find_keys(self._warm_keys, keys)
        forces[found] = self._warm_forces[where[found]]
        if self.warm_start_extrapolation > 0.0 and self._earlier_keys.size:
            earlier, at = _find_keys(self._earlier_keys, keys)
            both = found & earlier
            forces[both] += self.warm_start_extrapolation * (
                forces[both] - self._earlier_forces[at[both]])
        return forces

    def warm_start_arrays(self) -> dict[str, np.ndarray]:
        """The warm-start memory (contact keys and world forces [N] of the last two steps)
        for checkpoints."""
        return {"keys": self._warm_keys.copy(), "forces": self._warm_forces.copy(),
                "earlier_keys": self._earlier_keys.copy(),
                "earlier_forces": self._earlier_forces.copy()}

    def restore_warm_start(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore the memory saved by :meth:`warm_start_arrays` (a checkpoint without the
        step before the last: no extrapolation at the first step)."""
        self._warm_keys = np.asarray(arrays["keys"], dtype=np.int64)
        self._warm_forces = np.asarray(arrays["forces"], dtype=np.float64).reshape(-1, 3)
        self._earlier_keys = np.asarray(arrays.get("earlier_keys", np.zeros(0)),
                                        dtype=np.int64)
        self._earlier_forces = np.asarray(arrays.get("earlier_forces", np.zeros((0, 3))),
                                          dtype=np.float64).reshape(-1, 3)

    def alert_distance(self, library: ShapeLibrary) -> float:
        """The alert distance [m] the next detection uses (module docstring of
        :meth:`_phases`): bodies farther apart than this at a step's start have no row."""
        if self._detection is not None:
            return self._detection.alert
        return self.alert if self.alert is not None else 0.1 * _smallest_radius(library)

    @property
    def rng_state(self) -> dict:
        """State of the visiting-order generator (checkpoints)."""
        return self._rng.bit_generator.state

    @rng_state.setter
    def rng_state(self, value: dict) -> None:
        self._rng.bit_generator.state = value


def _check_finite_state(state: BodyState) -> None:
    """Refuse a state whose positions, orientations or velocities are not all finite
    (:class:`~grainlab.errors.InputError` naming the array and the first body)."""
    for name in ("positions", "orientations", "velocities", "angular_velocities"):
        array = getattr(state, name)
        bad = np.flatnonzero(~np.all(np.isfinite(array.reshape(len(array), -1)), axis=1))
        if bad.size:
            raise InputError(f"state.{name}[{int(bad[0])}]", array[bad[0]].tolist(),
                             "finite values at the start of a step")


def _check_finite_solve(iterations: int, change: float, residual: float,
                        impulses: np.ndarray, outputs: dict, dt: float, speed: float) -> None:
    """Raise :class:`~grainlab.errors.SolverDivergence` when the sweeps ended on non-finite
    impulses, velocities (``outputs``: name -> array) or convergence measures (module
    docstring, "Convergence"), before the step touches the state; the message says where
    and the likely cause."""
    bad = [name for name, array in outputs.items() if not np.all(np.isfinite(array))]
    finite_impulses = bool(np.all(np.isfinite(impulses)))
    if finite_impulses and not bad and math.isfinite(change) and math.isfinite(residual):
        return
    if not finite_impulses:
        rows = np.flatnonzero(~np.all(np.isfinite(impulses), axis=1))
        bad.insert(0, f"impulses at contacts {rows[:5].tolist()}")
    what = f"non-finite {', '.join(bad)}" if bad else (
        f"its convergence measures overflowed (impulses up to {np.abs(impulses).max():.3g} "
        "N s)")
    raise SolverDivergence(
        f"the contact solve (NLGS) diverged at sweep {iterations}: {what}, beyond the range "
        f"of double precision; the step was not applied. Reduce the time step (dt = {dt:g} s) "
        f"if the speeds grew during the run (up to {speed:.3g} m/s at this step's start), "
        "else check the units of the densities, sizes and speeds.")


def _find_keys(sorted_keys: np.ndarray, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each of ``keys`` (C,): whether it is in ``sorted_keys`` (ascending) and where."""
    if sorted_keys.size == 0:
        return np.zeros(keys.size, dtype=bool), np.zeros(keys.size, dtype=np.int64)
    where = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[where] == keys, where


def contact_keys(contacts: Contacts, n_bodies: int, library: ShapeLibrary) -> np.ndarray:
    """One int64 key per contact (body_i, body_j, member_i, member_j): warm starts match the
    same member pair (polyhedra: feature pair) from step to step (walls: body_i = -1 - w,
    member_i = -1)."""
    stride_m = max(int(library.sphere_count.max()), library.max_features) + 1
    stride_b = n_bodies + 64  # room for up to 63 walls below body 0
    bi = contacts.body_i.astype(np.int64) + 64
    bj = contacts.body_j.astype(np.int64)
    mi = contacts.member_i.astype(np.int64) + 1
    mj = contacts.member_j.astype(np.int64)
    return ((bi * stride_b + bj) * stride_m + mi) * stride_m + mj


def _smallest_radius(library: ShapeLibrary) -> float:
    """Smallest member-sphere radius or polyhedron inradius about the centre of mass [m]:
    half the time-step length d_min of the library's shape kinds
    (:func:`~grainlab.engine.shape_kinds.library_time_step_length`)."""
    return 0.5 * library_time_step_length(library)


def _relative_velocities(contacts, frames, arm_i, arm_j, velocities, spins) -> np.ndarray:
    """Local relative velocities (C, 3) of body j w.r.t. body i (NumPy twin of the kernel's
    scalar law, STYLE.md 12)."""
    bj, bi = contacts.body_j, contacts.body_i
    u = velocities[bj] + np.cross(spins[bj], arm_j)
    inner = bi >= 0
    u[inner] -= velocities[bi[inner]] + np.cross(spins[bi[inner]], arm_i[inner])
    return np.einsum("cij,cj->ci", frames, u)
