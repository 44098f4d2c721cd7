"""Rolling resistance at one contact of the soft (DEM) solver: the elastic-plastic rolling
spring of Iwashita & Oda (1998) and Ai et al. (2011) (LIGGGHTS' ``epsd2``), a scalar law
compiled inline into the sphere force pass (:mod:`grainlab.engine.dem.soft_contact_kernels`; the
physics in :mod:`grainlab.contact.soft_contact_law`).

A moment M_r (3,) [N m] on j (minus on i) with rolling stiffness k_r = 2.25 S_n mu_r^2 R*^2
(S_n [N/m] the normal tangent stiffness, mu_r the rolling friction, a length ratio, R* [m] the
effective radius) is carried with the contact frame like the tangential spring
(:func:`~grainlab.contact.tangential_spring.turn_with_frame`), loaded by the relative rolling
spin, dM_r = -k_r (omega_j - omega_i)_T dt, and capped, |M_r| <= mu_r R* F_n. Written without
a branch on the row's data (module docstring of :mod:`grainlab.contact.tangential_spring`).
"""

from __future__ import annotations

from numba import njit

from grainlab._vector_loops import pick, root
from grainlab.contact.tangential_spring import turn_with_frame


@njit(inline="always")
def rolling_spring(turn, dt, lx, ly, lz, nx, ny, nz, spin_n, ex, ey, ez, s_n, mu_r, r_eff,
                   fn):
    """One sub-step of the rolling spring (module docstring): ``turn`` whether it is carried
    and loaded over dt [s] (else only capped); (lx, ly, lz) its moment M_r [N m]; n the unit
    normal; ``spin_n`` the bodies' mean spin about n [rad/s]; (ex, ey, ez) the spin of j
    relative to i, omega_j - omega_i [rad/s]; ``s_n`` [N/m]; ``mu_r`` [1]; ``r_eff`` [m];
    ``fn`` >= 0 the normal force [N]. Returns the new moment on j [N m], three components."""
    k_r = 2.25 * s_n * mu_r * mu_r * r_eff * r_eff
    en = ex * nx + ey * ny + ez * nz
    ex, ey, ez = ex - en * nx, ey - en * ny, ez - en * nz
    if turn:
        lx, ly, lz = turn_with_frame(lx, ly, lz, nx, ny, nz, spin_n, dt)
        lx, ly, lz = lx - k_r * ex * dt, ly - k_r * ey * dt, lz - k_r * ez * dt
    moment = root(lx * lx + ly * ly + lz * lz)
    cap = mu_r * r_eff * fn
    capped = moment > cap
    f = cap / pick(capped, moment, 1.0)  # (moment > 0 where it is capped)
    return pick(capped, f * lx, lx), pick(capped, f * ly, ly), pick(capped, f * lz, lz)
