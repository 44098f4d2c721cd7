"""The longest stable sub-step of the explicit soft-contact scheme with its dashpots (Numba;
STYLE.md 2, 10): a bound from the contacts of each body, taken at the start of every step
(:class:`~grainlab.engine.dem.soft_contact.SoftContactStep`).

Why. Velocity Verlet (:mod:`grainlab.engine.dem.soft_contact`) evaluates the dashpots with the
half-step velocity, explicitly. For one mode of circular frequency w and damping rate beta
the sub-step h then obeys the leapfrog recurrence

    x_{n+1} - 2 x_n + x_{n-1} = -h^2 w^2 x_n - h beta (x_n - x_{n-1}),

stable only if h^2 w^2 + 2 h beta < 4, i.e. h < (sqrt(beta^2 + 4 w^2) - beta) / w^2 (the
roots of lambda^2 - (2 - h^2 w^2 - h beta) lambda + 1 - h beta; beyond the bound one root is
below -1: the mode flips sign and grows at every sub-step). The springs' rule alone
(:meth:`~grainlab.contact.soft_contact_law.SoftContactLaw.time_step`, a fraction of a
collision or Rayleigh time) does not see beta. In a packing the dashpots act on the grains'
spins through the small rotational inertia (2/5 m R^2) while their coefficients are set with
the pair's translational mass: the uniform spin of equal spheres with z contacts has
w^2 = (10 z / 3) k_t / m and beta = (10 z / 3) c_t / m. A face-centred cubic lattice (z = 12)
at e = 0.5, or a simple cubic one (z = 6) at e = 0.3, is unstable at the springs' step (its
spins grew 1.76 times per sub-step), and a sheared periodic sample at e = 0.2 kept 30 times
the kinetic energy of one at e = 0.5 and lost its friction (peak q/p 0.14 against 0.40).

The bound. Freeze the contacts (positions, stiffnesses and dashpots of one instant): with M
the bodies' masses and inertias (6 per body), K and C the contacts' stiffness and damping
matrices and A = M^-1/2 K M^-1/2, B = M^-1/2 C M^-1/2, the recurrence keeps

    E_n = d_n^T (I - h^2 A / 4 - h B / 2) d_n + h^2 m_n^T A m_n,

d_n = x_{n+1} - x_n, m_n = (x_{n+1} + x_n) / 2, from growing: E_{n+1} - E_n =
-(h / 2) (d_{n+1} + d_n)^T B (d_{n+1} + d_n) <= 0. So the scheme is stable when
h^2 A + 2 h B < 4 I, which for one mode is the condition above and for a network needs
upper bounds of lambda_max(A) and lambda_max(B). Contact c between bodies i and j adds
G_c^T D_c G_c to K (D_c = k_n n n^T + k_t (I - n n^T) on the relative velocity of the contact
point, G_c = [-E_i, E_j], E_b = [I, -[r_b]x] from body b's velocity and spin to the velocity
of the point at arm r_b; a rolling spring k_r acts on the relative spin), and the same with
(c_n, c_t) to C. Young's inequality, (a - b)^T D (a - b) <= (1 + t) a^T D a +
(1 + 1/t) b^T D b for any t > 0, bounds K by a block-diagonal matrix, so

    lambda_max(A) <= max over bodies i of lambda_max(M_i^-1/2 sum_c (1 + t_ic) E_ic^T D_c E_ic
                     M_i^-1/2),      t_ic t_jc = 1,

a Gershgorin-like bound, per body, on its own rows. With t = 1 it is twice the body's own
block, exactly the uniform-spin mode of a lattice of equal spheres (its contacts' two sides
move opposite); here t_ic = D_j / D_i with D_b the body's summed contact stiffness over its
point mass (max(k_n, k_t) (1/m_b + r_b^2 / I_b) per contact), the weights of Merris' bound on
a graph Laplacian (lambda_max <= max_i (d_i + the mean d of i's neighbours)): a body with many
contacts leans on lighter-loaded neighbours. A body's 6 x 6 block [[T, X], [X^T, R]] in its
mass metric (translations over m, rotations over I_min, the smallest principal moment: an
anisotropic body's world tensor is never smaller) is bounded by the 2 x 2 matrix
[[lambda_max(T), |X|_2], [|X|_2, lambda_max(R)]], the 3 x 3 eigenvalues in closed form
(Smith 1961). Measured on compacted lab packings (150 spheres, size ratio 2 or 1.2, linear
and Hertz, kappa 1e3 and 1e4), the bound on the closed contacts is 1.1-1.4 times shorter
than the exact limit of the frozen network (eigenvalues of h^2 A + 2 h B); on a lattice of
equal spheres it is exact.

Which contacts. Each row of the neighbour list (the pairs that can close while the list
lives) counts at the overlap it would reach at the end of the step if it kept approaching
at twice its current normal speed, delta + ``horizon`` max(0, -U_n) (``horizon`` = twice the
step): its stiffness and dashpots are the law's at that overlap (a Hertz contact stiffens as
delta^1/2; a linear one does not), and a row that stays open counts nothing. A row without
friction has no tangential spring or dashpot (its Coulomb cap mu F_n is 0), so a
frictionless stage (the lab's compactions) leaves the spins free and counts the normal
springs only. Polyhedra count their penetrating manifold points (a point's share of the
pair's normal force, w_r F_n(delta_r) with w_r = delta_r / sum delta, has a stiffness at most
2 w_r k_n: the Jacobian k (2 diag(w) - w w^T) <= 2 k diag(w)) and the pair's tangential
spring at its mean point.

A contact's own dashpot. The scheme updates the normal relative velocity u of an isolated
contact by its dashpot alone as u (1 - h c_n / m*_n) (m*_n the pair's effective mass along
the normal at the contact point, the rotations included): stable up to h c_n / m*_n = 2,
but beyond 1 the damped velocity flips sign at every sub-step and the contact no longer
restitutes its e (an isolated impact asked e = 0.01 rebounded at 0.29 at h c_n / m*_n =
1.6). So the sub-step also keeps h c_n / m*_n <= 1 on every row, which binds only for
overdamped contacts (e below ~0.1: at e = 0.5, c_n / m*_n is 0.51 of the pair's w).

Why a bound, not implicit dashpots. Implicit (or exact) dashpots couple the two bodies of
every contact: a linear solve per sub-step, or a per-body split that is exact only for an
isolated contact and leaves the off-diagonal coupling explicit. The bound keeps the force
pass as it is (explicit, gathered per body, the same bits on any number of threads), costs
one pass over the rows per step (about one or two sub-steps' worth), and leaves a run where
it does not bind the same, bit for bit, as before it. Why per step and from the list: the
largest coordination a size distribution allows would fix the bound once, but at that of a
lattice of twelve-fold contacts: about 1.7 times shorter than a lab packing needs.

What an unstable sub-step leaves (:func:`zigzag_sums_kernel`, the solver's
``velocity_zigzag``). Beyond the bound the growing root is below -1: the relative velocity
at a contact flips sign at every sub-step. At the end of a step, velocity Verlet's last
force evaluation saw the half-step velocities; the bodies' velocities after the last half
kick differ from them by h a / 2, little for a motion the sub-steps resolve, by about the
velocity itself for one that flips. So the change of the contacts' relative velocities in
that last half sub-step, over themselves, reads small (measured below 0.05 in lab runs) or
about 1 (0.65-0.96), where the kinetic energy alone, of the full-step velocities in which a
flipping mode nearly cancels, need not look unusual.

Safety. The sub-step is :data:`DAMPED_FRACTION` of the bound: at the bound itself the
uniform spin of a lattice neither grows nor decays, and within a step a Hertz contact may
stiffen further than its predicted overlap says.

>>> limit = damped_limit(4.0, 0.0)        # w^2 = 4 / s^2, no damping: h < 2 / w = 1 s
>>> round(limit / DAMPED_FRACTION, 12)
1.0
>>> round(damped_limit(4.0, 2.0) / DAMPED_FRACTION, 9)  # beta = 2 / s: (sqrt(20) - 2) / 4
0.618033989
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainlab.contact.contact_kinematics import less_body_i, point_velocity, sphere_wall_gap
from grainlab.contact.soft_contact_law import contact_law
from grainlab.engine.detect.narrow_phase import sphere_sphere
from grainlab.engine.quaternion import rotate

DAMPED_FRACTION = 0.9
"""The sub-step as a fraction of the dashpots' stability bound (module docstring)."""
HORIZON_STEPS = 2.0
"""A row counts at its overlap after this many steps of approach at its current speed."""
LAW_COLUMNS = 5
"""Per element: k_n, k_t [N/m], c_n, c_t [N s/m], k_r [N m/rad]."""
BLOCK = 21
"""A body's block: T (6: xx, yy, zz, yz, xz, xy), X (9, row-major), R (6)."""


def damped_limit(stiffness_rate: float, damping_rate: float, relaxation_rate: float = 0.0
                 ) -> float:
    """:data:`DAMPED_FRACTION` of the largest sub-step h [s] with h^2 a + 2 h b < 4 for
    a >= lambda_max(M^-1 K) [1/s^2] and b >= lambda_max(M^-1 C) [1/s], and
    h c_n / m*_n <= 1 for the largest ``relaxation_rate`` c_n / m*_n [1/s] of a contact's
    normal dashpot (module docstring); inf without stiffness or damping."""
    a, b = float(stiffness_rate), float(damping_rate)
    limit = math.inf
    if a > 0.0:
        limit = 4.0 / (math.sqrt(b * b + 4.0 * a) + b)
    elif b > 0.0:
        limit = 2.0 / b
    if relaxation_rate > 0.0:
        limit = min(limit, 1.0 / float(relaxation_rate))
    return DAMPED_FRACTION * limit


@njit(inline="always")
def symmetric_max_eigenvalue(a00, a11, a22, a12, a02, a01):
    """Largest eigenvalue of the symmetric 3 x 3 matrix with diagonal (a00, a11, a22) and
    off-diagonal (a12, a02, a01), in closed form (Smith 1961: q + 2 p cos(phi / 3))."""
    off = a01 * a01 + a02 * a02 + a12 * a12
    q = (a00 + a11 + a22) / 3.0
    b00, b11, b22 = a00 - q, a11 - q, a22 - q
    p = math.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * off) / 6.0)
    if p == 0.0:
        return q
    det = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02)
           + a02 * (a01 * a12 - b11 * a02))
    r = min(max(det / (2.0 * p * p * p), -1.0), 1.0)
    return q + 2.0 * p * math.cos(math.acos(r) / 3.0)


@njit(inline="always")
def _add_element(blocks, b, wk, wc, kn, kt, kr, cn, ct, nx, ny, nz, rx, ry, rz):
    """Body b's stiffness block += wk E^T D_k E (+ kr (I - n n^T) on the spins) and its
    damping block += wc E^T D_c E, D = d_t I + (d_n - d_t) n n^T at arm r (module
    docstring): blocks[b, 0] and blocks[b, 1], each T (xx, yy, zz, yz, xz, xy), X
    (row-major), R as :data:`BLOCK` lays them out."""
    mx, my, mz = ny * rz - nz * ry, nz * rx - nx * rz, nx * ry - ny * rx  # m = n x r
    r2 = rx * rx + ry * ry + rz * rz
    # the geometric parts: n n^T, [r]x, n m^T, |r|^2 I - r r^T, m m^T
    nxx, nyy, nzz, nyz, nxz, nxy = nx * nx, ny * ny, nz * nz, ny * nz, nx * nz, nx * ny
    for which in range(2):
        if which == 0:
            w, dt, s, dr = wk, kt, kn - kt, kr
        else:
            w, dt, s, dr = wc, ct, cn - ct, 0.0
        if w == 0.0:
            continue
        blk = blocks[b, which]
        wt, ws, wr = w * dt, w * s, w * dr
        blk[0] += wt + ws * nxx  # T = dt I + s n n^T
        blk[1] += wt + ws * nyy
        blk[2] += wt + ws * nzz
        blk[3] += ws * nyz
        blk[4] += ws * nxz
        blk[5] += ws * nxy
        blk[6] -= ws * nx * mx  # X = -dt [r]x - s n m^T
        blk[7] += wt * rz - ws * nx * my
        blk[8] -= wt * ry + ws * nx * mz
        blk[9] -= wt * rz + ws * ny * mx
        blk[10] -= ws * ny * my
        blk[11] += wt * rx - ws * ny * mz
        blk[12] += wt * ry - ws * nz * mx
        blk[13] -= wt * rx + ws * nz * my
        blk[14] -= ws * nz * mz
        # R = dt (|r|^2 I - r r^T) + s m m^T + dr (I - n n^T)
        blk[15] += wt * (r2 - rx * rx) + ws * mx * mx + wr * (1.0 - nxx)
        blk[16] += wt * (r2 - ry * ry) + ws * my * my + wr * (1.0 - nyy)
        blk[17] += wt * (r2 - rz * rz) + ws * mz * mz + wr * (1.0 - nzz)
        blk[18] += -wt * ry * rz + ws * my * mz - wr * nyz
        blk[19] += -wt * rx * rz + ws * mx * mz - wr * nxz
        blk[20] += -wt * rx * ry + ws * mx * my - wr * nxy


@njit(inline="always")
def symmetric_eigenvalue_ceiling(a00, a11, a22, a12, a02, a01):
    """q + 2 p >= the largest eigenvalue of a symmetric 3 x 3 matrix
    (:func:`symmetric_max_eigenvalue` with cos(phi / 3) <= 1: exact when the two smaller
    eigenvalues are equal), without its arccosine and cosine."""
    off = a01 * a01 + a02 * a02 + a12 * a12
    q = (a00 + a11 + a22) / 3.0
    b00, b11, b22 = a00 - q, a11 - q, a22 - q
    return q + 2.0 * math.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * off) / 6.0)


@njit(inline="always")
def _block_bound(blk, inv_mass, inv_inertia, exact):
    """An upper bound of lambda_max of the 6 x 6 block in the body's mass metric (module
    docstring); with ``exact`` False a cheaper and larger one (the eigenvalue ceilings)."""
    eigenvalue = symmetric_max_eigenvalue if exact else symmetric_eigenvalue_ceiling
    t = inv_mass * eigenvalue(blk[0], blk[1], blk[2], blk[3], blk[4], blk[5])
    r = inv_inertia * eigenvalue(blk[15], blk[16], blk[17], blk[18], blk[19], blk[20])
    x00, x01, x02 = blk[6], blk[7], blk[8]
    x10, x11, x12 = blk[9], blk[10], blk[11]
    x20, x21, x22 = blk[12], blk[13], blk[14]
    # |X|_2^2 = lambda_max(X^T X)
    g00 = x00 * x00 + x10 * x10 + x20 * x20
    g11 = x01 * x01 + x11 * x11 + x21 * x21
    g22 = x02 * x02 + x12 * x12 + x22 * x22
    g12 = x01 * x02 + x11 * x12 + x21 * x22
    g02 = x00 * x02 + x10 * x12 + x20 * x22
    g01 = x00 * x01 + x10 * x11 + x20 * x21
    x2 = max(0.0, eigenvalue(g00, g11, g22, g12, g02, g01)) * inv_mass * inv_inertia
    half = 0.5 * (t - r)
    return 0.5 * (t + r) + math.sqrt(half * half + x2)


@njit(inline="always")
def _point_mobility(b, rx, ry, rz, inv_mass, inv_inertia):
    """1/m + |r|^2 / I_min of body b at arm r [1/kg]."""
    return inv_mass[b] + (rx * rx + ry * ry + rz * rz) * inv_inertia[b]


@njit(inline="always")
def _normal_mobility(b, rx, ry, rz, nx, ny, nz, inv_mass, inv_inertia):
    """1/m + |r x n|^2 / I_min of body b at arm r along n [1/kg]: the velocity along n a unit
    impulse along n gives the point."""
    cx, cy, cz = ry * nz - rz * ny, rz * nx - rx * nz, rx * ny - ry * nx
    return inv_mass[b] + (cx * cx + cy * cy + cz * cz) * inv_inertia[b]


@njit(cache=True, _nrt=False)
def stable_rates_kernel(elem_i, elem_j, normal, arm_i, arm_j, law, inv_mass, inv_inertia,
                        degree, blocks):
    """Upper bounds (a [1/s^2], b [1/s]) of lambda_max(M^-1 K) and lambda_max(M^-1 C) of the
    contact elements, and the largest relaxation rate c_n / m*_n [1/s] of their normal
    dashpots (module docstring): element e between body ``elem_i[e]`` (-1 - w: wall
    w, which moves with no body) and body ``elem_j[e]``, unit normal ``normal`` (E, 3), arms
    ``arm_i``, ``arm_j`` (E, 3) [m] from the bodies' centres of mass to its point, and
    ``law`` (E, 5): k_n, k_t [N/m], c_n, c_t [N s/m], k_r [N m/rad] (an element of zero
    stiffness and damping counts nothing). ``inv_mass`` (N,) [1/kg], ``inv_inertia`` (N,)
    [1/(kg m^2)] of the smallest principal moment. ``degree`` (N, 2) and ``blocks``
    (N, 2, 21) are scratch. Serial, in element order: the same bits on any number of
    threads."""
    degree[:, :] = 0.0
    blocks[:, :, :] = 0.0
    relaxation = 0.0
    for e in range(elem_j.shape[0]):
        kn, kt, cn, ct, kr = law[e, 0], law[e, 1], law[e, 2], law[e, 3], law[e, 4]
        if kn == 0.0 and kt == 0.0 and cn == 0.0 and ct == 0.0 and kr == 0.0:
            continue
        j, i = elem_j[e], elem_i[e]
        mobility = _point_mobility(j, arm_j[e, 0], arm_j[e, 1], arm_j[e, 2], inv_mass,
                                   inv_inertia)
        degree[j, 0] += max(kn, kt) * mobility + kr * inv_inertia[j]
        degree[j, 1] += max(cn, ct) * mobility
        nx, ny, nz = normal[e, 0], normal[e, 1], normal[e, 2]
        normal_mobility = _normal_mobility(j, arm_j[e, 0], arm_j[e, 1], arm_j[e, 2], nx, ny,
                                           nz, inv_mass, inv_inertia)
        if i >= 0:
            mobility = _point_mobility(i, arm_i[e, 0], arm_i[e, 1], arm_i[e, 2], inv_mass,
                                       inv_inertia)
            degree[i, 0] += max(kn, kt) * mobility + kr * inv_inertia[i]
            degree[i, 1] += max(cn, ct) * mobility
            normal_mobility += _normal_mobility(i, arm_i[e, 0], arm_i[e, 1], arm_i[e, 2], nx,
                                                ny, nz, inv_mass, inv_inertia)
        relaxation = max(relaxation, cn * normal_mobility)
    for e in range(elem_j.shape[0]):
        kn, kt, cn, ct, kr = law[e, 0], law[e, 1], law[e, 2], law[e, 3], law[e, 4]
        if kn == 0.0 and kt == 0.0 and cn == 0.0 and ct == 0.0 and kr == 0.0:
            continue
        j, i = elem_j[e], elem_i[e]
        nx, ny, nz = normal[e, 0], normal[e, 1], normal[e, 2]
        wk = 0.0 if degree[j, 0] == 0.0 else 1.0  # (a block that has nothing: no weight)
        wc = 0.0 if degree[j, 1] == 0.0 else 1.0
        if i >= 0:  # Merris' weights: 1 + the other side's degree over this one's
            wk += 0.0 if degree[j, 0] == 0.0 else degree[i, 0] / degree[j, 0]
            wc += 0.0 if degree[j, 1] == 0.0 else degree[i, 1] / degree[j, 1]
        _add_element(blocks, j, wk, wc, kn, kt, kr, cn, ct, nx, ny, nz, arm_j[e, 0],
                     arm_j[e, 1], arm_j[e, 2])
        if i >= 0:
            wk = 0.0 if degree[i, 0] == 0.0 else 1.0 + degree[j, 0] / degree[i, 0]
            wc = 0.0 if degree[i, 1] == 0.0 else 1.0 + degree[j, 1] / degree[i, 1]
            _add_element(blocks, i, wk, wc, kn, kt, kr, cn, ct, nx, ny, nz, arm_i[e, 0],
                         arm_i[e, 1], arm_i[e, 2])
    a = b = 0.0  # the largest exact block bounds: a body whose ceiling is no larger than
    for n in range(inv_mass.shape[0]):  # the largest so far cannot raise it (same result)
        if degree[n, 0] > 0.0 and _block_bound(blocks[n, 0], inv_mass[n], inv_inertia[n],
                                               False) > a:
            a = max(a, _block_bound(blocks[n, 0], inv_mass[n], inv_inertia[n], True))
        if degree[n, 1] > 0.0 and _block_bound(blocks[n, 1], inv_mass[n], inv_inertia[n],
                                               False) > b:
            b = max(b, _block_bound(blocks[n, 1], inv_mass[n], inv_inertia[n], True))
    return a, b, relaxation


@njit(inline="always")
def _element_law(code, params, rolling, friction, overlap, r_eff, m_eff, law, e):
    """law[e] = the law's k_n (normal tangent stiffness), k_t, c_n, c_t and the rolling
    stiffness at ``overlap`` [m] (zeros for an overlap <= 0; no tangential spring or dashpot
    without ``friction``: the Coulomb cap mu F_n = 0 holds them at zero)."""
    if overlap <= 0.0:
        for a in range(law.shape[1]):
            law[e, a] = 0.0
        return
    _, s_n, k_t, c_n, c_t = contact_law(code, params, overlap, r_eff, m_eff)
    if friction == 0.0:
        k_t = c_t = 0.0
    law[e, 0], law[e, 1], law[e, 2], law[e, 3] = s_n, k_t, c_n, c_t
    law[e, 4] = 2.25 * s_n * rolling * rolling * r_eff * r_eff


@njit(cache=True, _nrt=False)
def sphere_elements_kernel(horizon, code, params, rolling, body_i, body_j, off_i, off_j,
                           rad_i, rad_j, images, mu, inv_mass, positions, orientations,
                           velocities, spins, wall_p0, wall_n, wall_disp, wall_speed, cell_h,
                           cell_rate, normal, arm_i, arm_j, law):
    """The contact elements of a list of member spheres (:mod:`grainlab.engine.
    soft_contact_kernels`' rows, its argument names): per row its normal, the arms from the
    bodies' centres to its contact point [m] and the law at the overlap it reaches after
    ``horizon`` [s] of approach at its current normal speed (module docstring); a row without
    friction (``mu`` 0) has no tangential spring or dashpot: the Coulomb cap holds them at
    zero."""
    for k in range(body_j.shape[0]):
        j, i = body_j[k], body_i[k]
        mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
        qj = orientations[j]
        ox, oy, oz = rotate(qj[0], qj[1], qj[2], qj[3], off_j[k, 0], off_j[k, 1], off_j[k, 2])
        jx = positions[j, 0] + cell_h[0, 0] * mx + cell_h[0, 1] * my + cell_h[0, 2] * mz
        jy = positions[j, 1] + cell_h[1, 0] * mx + cell_h[1, 1] * my + cell_h[1, 2] * mz
        jz = positions[j, 2] + cell_h[2, 0] * mx + cell_h[2, 1] * my + cell_h[2, 2] * mz
        bx, by, bz = jx + ox, jy + oy, jz + oz
        rb = rad_j[k]
        if i >= 0:
            qi = orientations[i]
            px, py, pz = rotate(qi[0], qi[1], qi[2], qi[3], off_i[k, 0], off_i[k, 1],
                                off_i[k, 2])
            ra = rad_i[k]
            g, nx, ny, nz, cx, cy, cz = sphere_sphere(positions[i, 0] + px,
                                                      positions[i, 1] + py,
                                                      positions[i, 2] + pz, ra, bx, by, bz, rb)
            r_eff = ra * rb / (ra + rb)
            m_eff = 1.0 / (inv_mass[i] + inv_mass[j])
            w = 0
        else:
            w = -1 - i
            g, nx, ny, nz = sphere_wall_gap(bx, by, bz, rb, w, wall_n, wall_p0, wall_disp)
            s = rb + 0.5 * g
            cx, cy, cz = bx - s * nx, by - s * ny, bz - s * nz
            r_eff = rb
            m_eff = 1.0 / inv_mass[j]
        rjx, rjy, rjz = cx - jx, cy - jy, cz - jz
        wjx, wjy, wjz = spins[j, 0], spins[j, 1], spins[j, 2]
        ux, uy, uz = point_velocity(velocities[j, 0], velocities[j, 1], velocities[j, 2],
                                    wjx, wjy, wjz, rjx, rjy, rjz)
        ux = ux + cell_rate[0, 0] * mx + cell_rate[0, 1] * my + cell_rate[0, 2] * mz
        uy = uy + cell_rate[1, 0] * mx + cell_rate[1, 1] * my + cell_rate[1, 2] * mz
        uz = uz + cell_rate[2, 0] * mx + cell_rate[2, 1] * my + cell_rate[2, 2] * mz
        ux, uy, uz, rix, riy, riz, _, _, _ = less_body_i(
            i, ux, uy, uz, cx, cy, cz, positions, velocities, spins, wall_n, wall_speed)
        un = ux * nx + uy * ny + uz * nz
        normal[k, 0], normal[k, 1], normal[k, 2] = nx, ny, nz
        arm_i[k, 0], arm_i[k, 1], arm_i[k, 2] = rix, riy, riz
        arm_j[k, 0], arm_j[k, 1], arm_j[k, 2] = rjx, rjy, rjz
        _element_law(code, params[0 if i >= 0 else 1], rolling, mu[k],
                     -g + horizon * max(0.0, -un), r_eff, m_eff, law, k)


def sphere_rows_rates(rows, horizon: float, law, inv_mass, inv_inertia, positions,
                      orientations, velocities, spins, wall_points, wall_normals, wall_disp,
                      wall_speed, cell_h, cell_rate) -> tuple[float, float]:
    """(a [1/s^2], b [1/s], c_n / m*_n [1/s]) of :func:`stable_rates_kernel` for a list of
    member spheres
    (:class:`~grainlab.engine.dem.sphere_row_list.SphereRows`), each row at its overlap after
    ``horizon`` [s] (:func:`sphere_elements_kernel`); ``law`` a
    :class:`~grainlab.contact.soft_contact_law.SoftContactLaw`."""
    c, n = rows.body_j.shape[0], inv_mass.shape[0]
    normal, arm_i, arm_j = np.empty((c, 3)), np.empty((c, 3)), np.empty((c, 3))
    elements = np.empty((c, LAW_COLUMNS))
    sphere_elements_kernel(float(horizon), law.code, law.params, law.rolling_friction,
                           rows.body_i, rows.body_j, rows.off_i, rows.off_j, rows.rad_i,
                           rows.rad_j, rows.images, rows.mu, inv_mass, positions, orientations,
                           velocities, spins, wall_points, wall_normals, wall_disp,
                           wall_speed, cell_h, cell_rate, normal, arm_i, arm_j, elements)
    return stable_rates_kernel(rows.body_i, rows.body_j, normal, arm_i, arm_j, elements,
                               inv_mass, inv_inertia, np.empty((n, 2)),
                               np.empty((n, 2, BLOCK)))


@njit(cache=True, _nrt=False)
def polyhedron_elements_kernel(horizon, code, params, pair_i, pair_j, images, r_eff, mu,
                               inv_mass, inv_inertia,
                               positions, cell_h, n_points, point_gap, point_normal,
                               point_position, point_velocity, mean_point, mean_normal,
                               mean_velocity, elem_i, elem_j, normal, arm_i, arm_j, law):
    """The contact elements of a list of polyhedron pairs (:mod:`grainlab.engine.
    soft_polyhedra`, after an evaluation of its manifolds), K + 1 slots per pair (K the
    points kept): each penetrating point r with normal stiffness 2 w_r S_n and damping
    w_r c_n at its overlap after ``horizon`` [s] of approach (w_r = delta_r / sum delta, module
    docstring), then the pair's tangential spring and dashpot at its mean point and mean
    depth sum delta^2 / sum delta (none without friction ``mu``); unused slots count
    nothing. Returns the largest relaxation rate c_n / m*_n [1/s] of a pair's normal dashpot
    (at its mean point and depth: its points share it)."""
    slots = point_gap.shape[1] + 1
    relaxation = 0.0
    for p in range(pair_j.shape[0]):
        i, j = pair_i[p], pair_j[p]
        mx, my, mz = images[p, 0], images[p, 1], images[p, 2]
        jx = positions[j, 0] + cell_h[0, 0] * mx + cell_h[0, 1] * my + cell_h[0, 2] * mz
        jy = positions[j, 1] + cell_h[1, 0] * mx + cell_h[1, 1] * my + cell_h[1, 2] * mz
        jz = positions[j, 2] + cell_h[2, 0] * mx + cell_h[2, 1] * my + cell_h[2, 2] * mz
        m_eff = 1.0 / (inv_mass[j] + (inv_mass[i] if i >= 0 else 0.0))
        row = params[0 if i >= 0 else 1]
        total = squares = 0.0
        for r in range(n_points[p]):
            total += -point_gap[p, r]
            squares += point_gap[p, r] * point_gap[p, r]
        for s in range(slots):
            e = p * slots + s
            elem_i[e], elem_j[e] = i, j
            for a in range(law.shape[1]):
                law[e, a] = 0.0
            if s < n_points[p]:
                nx, ny, nz = point_normal[p, s, 0], point_normal[p, s, 1], point_normal[p, s, 2]
                cx, cy, cz = point_position[p, s, 0], point_position[p, s, 1], \
                    point_position[p, s, 2]
                un = (point_velocity[p, s, 0] * nx + point_velocity[p, s, 1] * ny
                      + point_velocity[p, s, 2] * nz)
                depth = -point_gap[p, s]
                _, s_n, _, c_n, _ = contact_law(code, row, depth + horizon * max(0.0, -un),
                                                r_eff[p], m_eff)
                share = depth / total
                law[e, 0], law[e, 2] = 2.0 * share * s_n, share * c_n
            elif s == slots - 1 and n_points[p] > 0:
                nx, ny, nz = mean_normal[p, 0], mean_normal[p, 1], mean_normal[p, 2]
                cx, cy, cz = mean_point[p, 0], mean_point[p, 1], mean_point[p, 2]
                un = mean_velocity[p, 0] * nx + mean_velocity[p, 1] * ny \
                    + mean_velocity[p, 2] * nz
                _, _, k_t, c_n, c_t = contact_law(code, row, squares / total
                                                  + horizon * max(0.0, -un), r_eff[p], m_eff)
                if mu[p] > 0.0:  # (no friction: no tangential force)
                    law[e, 1], law[e, 3] = k_t, c_t
                mobility = _normal_mobility(j, cx - jx, cy - jy, cz - jz, nx, ny, nz,
                                            inv_mass, inv_inertia)
                if i >= 0:
                    mobility += _normal_mobility(
                        i, cx - positions[i, 0], cy - positions[i, 1], cz - positions[i, 2],
                        nx, ny, nz, inv_mass, inv_inertia)
                relaxation = max(relaxation, c_n * mobility)
            else:
                nx, ny, nz, cx, cy, cz = 0.0, 0.0, 1.0, jx, jy, jz
            normal[e, 0], normal[e, 1], normal[e, 2] = nx, ny, nz
            arm_j[e, 0], arm_j[e, 1], arm_j[e, 2] = cx - jx, cy - jy, cz - jz
            if i >= 0:
                arm_i[e, 0], arm_i[e, 1] = cx - positions[i, 0], cy - positions[i, 1]
                arm_i[e, 2] = cz - positions[i, 2]
            else:
                arm_i[e, 0], arm_i[e, 1], arm_i[e, 2] = 0.0, 0.0, 0.0
    return relaxation


@njit(cache=True, _nrt=False)
def zigzag_sums_kernel(body_i, body_j, images, closed, point, normal, half, positions,
                       velocities, spins, cell_h, cell_rate, sums):
    """What an unstable sub-step leaves (module docstring): per contact k between two bodies
    with ``closed[k]`` (body j's image at x_j + h m_k, ``images`` (C, 3); wall rows, whose
    servo may change the wall's speed after the last evaluation, are left out), its relative
    velocity ``half`` (C, 3) [m/s] at its ``point`` as the step's last force evaluation saw it
    (velocity Verlet's half-step velocities, half a sub-step before the end) against the one
    of the bodies' velocities and spins at the end (the cell's rate ``cell_rate`` = hdot
    (3, 3) [m/s] for an image); ``sums`` (4,) becomes (sum du_n^2, sum u_n^2, sum |du_t|^2,
    sum |u_t|^2) [m^2/s^2] of the normal and tangential parts (n = ``normal[k]``),
    du = u_end - u_half, u = u_half."""
    for a in range(4):
        sums[a] = 0.0
    for k in range(body_j.shape[0]):
        j, i = body_j[k], body_i[k]
        if not closed[k] or i < 0:
            continue
        mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
        px, py, pz = point[k, 0], point[k, 1], point[k, 2]
        rx = px - positions[j, 0] - (cell_h[0, 0] * mx + cell_h[0, 1] * my + cell_h[0, 2] * mz)
        ry = py - positions[j, 1] - (cell_h[1, 0] * mx + cell_h[1, 1] * my + cell_h[1, 2] * mz)
        rz = pz - positions[j, 2] - (cell_h[2, 0] * mx + cell_h[2, 1] * my + cell_h[2, 2] * mz)
        ux, uy, uz = point_velocity(velocities[j, 0], velocities[j, 1], velocities[j, 2],
                                    spins[j, 0], spins[j, 1], spins[j, 2], rx, ry, rz)
        ux = ux + cell_rate[0, 0] * mx + cell_rate[0, 1] * my + cell_rate[0, 2] * mz
        uy = uy + cell_rate[1, 0] * mx + cell_rate[1, 1] * my + cell_rate[1, 2] * mz
        uz = uz + cell_rate[2, 0] * mx + cell_rate[2, 1] * my + cell_rate[2, 2] * mz
        qx, qy, qz = point_velocity(velocities[i, 0], velocities[i, 1], velocities[i, 2],
                                    spins[i, 0], spins[i, 1], spins[i, 2], px - positions[i, 0],
                                    py - positions[i, 1], pz - positions[i, 2])
        ux, uy, uz = ux - qx, uy - qy, uz - qz
        nx, ny, nz = normal[k, 0], normal[k, 1], normal[k, 2]
        hx, hy, hz = half[k, 0], half[k, 1], half[k, 2]
        dx, dy, dz = ux - hx, uy - hy, uz - hz
        dn, hn = dx * nx + dy * ny + dz * nz, hx * nx + hy * ny + hz * nz
        sums[0] += dn * dn
        sums[1] += hn * hn
        sums[2] += dx * dx + dy * dy + dz * dz - dn * dn
        sums[3] += hx * hx + hy * hy + hz * hz - hn * hn


def zigzag_index(sums) -> float:
    """max(sum du_n^2 / sum u_n^2, sum |du_t|^2 / sum |u_t|^2) of :func:`zigzag_sums_kernel`
    (0 without moving contacts): about (h a / 2u)^2, small, for a motion the sub-steps
    resolve; about 1 and more for one that flips sign at every sub-step."""
    out = 0.0
    for change, speed in ((sums[0], sums[1]), (sums[2], sums[3])):
        if speed > 0.0:
            out = max(out, float(change / speed))
    return out
