"""The incremental Mindlin tangential spring with its Coulomb cap, at one contact of the soft
(DEM) solver: a scalar law compiled inline into the force passes of spheres, aggregates and
polyhedra (:mod:`grainlab.engine.dem.sphere_rows`, :mod:`grainlab.engine.dem.soft_contact_kernels`,
:mod:`grainlab.engine.dem.soft_polyhedra_kernels`; the physics in
:mod:`grainlab.contact.soft_contact_law`).

The spring holds an elastic force F_e (3,) [N] from the sub-step the contact formed. Over a
sub-step of dt [s] it is carried with the contact frame, its normal part removed and its
length kept, then turned about the unit normal n by the mean spin of the two bodies about n,
Omega_n dt (no spurious force under a rigid rotation of the pair), and loaded incrementally
with the stiffness of the moment (Mindlin's no-slip law with history, YADE's ``MindlinPhys``):

    F_e <- R(Omega_n dt) P_n F_e - k_t U_T dt,

U_T [m/s] the tangential velocity of j relative to i at the contact point, k_t [N/m] the
tangential stiffness. The tangential force is F_T = F_e - c_t U_T (c_t [N s/m] the tangential
dashpot) and Coulomb's law caps it: where |F_T| > mu F_n = ``limit`` [N], F_T is scaled back
onto the limit and the spring holds the force that gives it, F_e = F_T + c_t U_T (the Coulomb
force less the dashpot's).

Both functions are written without a branch on the row's data (LLVM ``select`` through
:func:`~grainlab._vector_loops.pick`, the square root as :func:`~grainlab._vector_loops.root`),
so that the vector rows of plain spheres stay vector code; no division by zero is evaluated,
whatever the caller's Numba error model. The only branch, on ``turn``, is the same for every
row of a pass.
"""

from __future__ import annotations

from numba import njit

from grainlab._vector_loops import pick, root


@njit(inline="always")
def turn_with_frame(hx, hy, hz, nx, ny, nz, spin_n, dt):
    """A tangential history vector (hx, hy, hz) carried into the current tangent plane of
    unit normal n: normal part removed, length kept, then turned by ``spin_n`` [rad/s] times
    ``dt`` [s] about n; a zero vector, or one that the turn leaves zero, stays zero. Returns
    the three components (units of h)."""
    old = hx * hx + hy * hy + hz * hz  # squared lengths: one square root
    dot = hx * nx + hy * ny + hz * nz
    tx, ty, tz = hx - dot * nx, hy - dot * ny, hz - dot * nz
    angle = spin_n * dt
    cx, cy, cz = ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx
    tx, ty, tz = tx + angle * cx, ty + angle * cy, tz + angle * cz
    new = tx * tx + ty * ty + tz * tz
    keep = (old != 0.0) & (new != 0.0)
    f = root(old / pick(new != 0.0, new, 1.0))  # (no division by zero under any error model)
    return pick(keep, f * tx, 0.0), pick(keep, f * ty, 0.0), pick(keep, f * tz, 0.0)


@njit(inline="always")
def mindlin_coulomb(turn, dt, hx, hy, hz, nx, ny, nz, spin_n, utx, uty, utz, k_t, c_t,
                    limit):
    """One sub-step of the tangential spring (module docstring).

    ``turn``: whether the spring is carried and loaded (a sub-step dt [s] > 0), or only read
    (dt = 0: the force of the current spring); (hx, hy, hz) the spring's force F_e [N] at the
    sub-step's start; n the unit normal; ``spin_n`` the bodies' mean spin about n [rad/s];
    (utx, uty, utz) the tangential relative velocity U_T [m/s]; ``k_t`` [N/m], ``c_t``
    [N s/m]; ``limit`` = mu F_n >= 0 [N].

    Returns (F_T, F_e): the tangential force on j (minus on i) [N] and the spring's new force
    [N], three components each.
    """
    if turn:
        hx, hy, hz = turn_with_frame(hx, hy, hz, nx, ny, nz, spin_n, dt)
        f = k_t * dt  # incremental: dF_e = -k_t dU_T with the stiffness of the moment
        hx, hy, hz = hx - f * utx, hy - f * uty, hz - f * utz
    ftx, fty, ftz = hx - c_t * utx, hy - c_t * uty, hz - c_t * utz
    ft2 = ftx * ftx + fty * fty + ftz * ftz
    slide = ft2 > limit * limit  # sliding: the spring holds the Coulomb force less the dashpot's
    f = limit / root(pick(slide, ft2, 1.0))  # (ft2 > 0 where it slides)
    ftx, fty, ftz = pick(slide, f * ftx, ftx), pick(slide, f * fty, fty), \
        pick(slide, f * ftz, ftz)
    hx, hy, hz = pick(slide, ftx + c_t * utx, hx), pick(slide, fty + c_t * uty, hy), \
        pick(slide, ftz + c_t * utz, hz)
    return ftx, fty, ftz, hx, hy, hz
