"""The Coulomb cone of non-smooth contact dynamics (NSCD) at one contact: the projection on
the cone and the local solve of one contact's impulse, scalar laws compiled inline into the
sweeps of contact dynamics (:mod:`grainlab.engine.nscd.contact_dynamics`,
:mod:`grainlab.engine.nscd.nlgs_parallel`) and the plain-problem methods
(:mod:`grainlab.engine.nscd.plain_problem_methods`).

In the local frame (n, t, s) of a contact, with impulse P = (P_n, P_T) [N s] and Coulomb
coefficient mu, the cone is K = {|P_T| <= mu P_n}. The projection of a point z on K is z itself
inside K, 0 in the polar cone {mu |z_T| <= -z_n}, else the point of the cone's surface
((z_n + mu |z_T|) / (1 + mu^2)) (1, mu z_T / |z_T|).

The local solve (Jean 1999, 6.3; LMGC90's ``nlgs``) finds the impulse P of one contact with
Delassus block W (3, 3) [1/kg] and free relative velocity U'_free [m/s] (the relative velocity
with P = 0): open (P = 0) if U'_free,n >= 0; else the sticking solution P = -W^-1 U'_free
(Cramer's rule) if det W is not tiny and P lies in the cone; else (sliding, or a singular
block) projections from the previous P, normal first P_n = max(0, P_n - U'_n / W_nn), then
tangential on the disc, P_T = proj_{|P_T| <= mu P_n}(P_T - U_T / lambda_max(W_TT)), repeated
(at most 100 times) until the change is below 1e-12 relative.
"""

from __future__ import annotations

import math

from numba import njit

TINY = 1e-300
"""A floor [1] under the denominators of relative changes."""
DET_TINY = 1e-12
"""det W below this times W_nn^3: a singular block, solved by projections."""
LOCAL_ITERATIONS = 100
"""The most projection rounds of one local solve."""
LOCAL_TOLERANCE = 1e-12
"""The projections stop at this change relative to |P|."""


@njit(inline="always")
def project_cone(mu, zn, zt, zs):
    """Projection of (zn, zt, zs) on the Coulomb cone {|z_T| <= mu z_n}."""
    norm_t = math.sqrt(zt * zt + zs * zs)
    if zn >= 0.0 and norm_t <= mu * zn:
        return zn, zt, zs
    if mu * norm_t <= -zn:
        return 0.0, 0.0, 0.0
    a = (zn + mu * norm_t) / (1.0 + mu * mu)
    if norm_t > 0.0:
        f = mu * a / norm_t
        return a, f * zt, f * zs
    return a, 0.0, 0.0


@njit(inline="always")
def local_solve(w, un, ut, us, mu, pn, pt, ps):
    """Impulse (P_n, P_t, P_s) [N s] of one contact with Delassus block ``w`` (3, 3) [1/kg]
    and corrected free relative velocity (un, ut, us) [m/s] (U' with P = 0), starting from
    (pn, pt, ps): open, stick (3 x 3 solve) or projections (module docstring)."""
    if un >= 0.0:
        return 0.0, 0.0, 0.0
    wnn = w[0, 0]
    a, b, c = w[1, 1], w[1, 2], w[2, 2]
    det = (wnn * (a * c - b * w[2, 1]) - w[0, 1] * (w[1, 0] * c - b * w[2, 0])
           + w[0, 2] * (w[1, 0] * w[2, 1] - a * w[2, 0]))
    if det > DET_TINY * wnn * wnn * wnn:
        # Cramer's rule: W x = -U
        rn, rt, rs = -un, -ut, -us
        xn = (rn * (a * c - b * w[2, 1]) - w[0, 1] * (rt * c - b * rs)
              + w[0, 2] * (rt * w[2, 1] - a * rs)) / det
        xt = (wnn * (rt * c - b * rs) - rn * (w[1, 0] * c - b * w[2, 0])
              + w[0, 2] * (w[1, 0] * rs - rt * w[2, 0])) / det
        xs = (wnn * (a * rs - rt * w[2, 1]) - w[0, 1] * (w[1, 0] * rs - rt * w[2, 0])
              + rn * (w[1, 0] * w[2, 1] - a * w[2, 0])) / det
        if xn > 0.0 and math.sqrt(xt * xt + xs * xs) <= mu * xn * (1.0 + 1e-12):
            return xn, xt, xs
    # projections, normal first then tangential on the disc
    half = 0.5 * (a + c)
    lam = half + math.sqrt(0.25 * (a - c) * (a - c) + 0.5 * (b + w[2, 1]) * 0.5 * (b + w[2, 1]))
    rho_t = 1.0 / lam
    pn, pt, ps = project_cone(mu, pn, pt, ps)
    for _ in range(LOCAL_ITERATIONS):
        vn = un + wnn * pn + w[0, 1] * pt + w[0, 2] * ps
        qn = max(0.0, pn - vn / wnn)
        vt = ut + w[1, 0] * qn + a * pt + b * ps
        vs = us + w[2, 0] * qn + w[2, 1] * pt + c * ps
        qt, qs = pt - rho_t * vt, ps - rho_t * vs
        norm_t = math.sqrt(qt * qt + qs * qs)
        limit = mu * qn
        if norm_t > limit:
            f = limit / norm_t
            qt, qs = f * qt, f * qs
        change = abs(qn - pn) + abs(qt - pt) + abs(qs - ps)
        pn, pt, ps = qn, qt, qs
        if change <= LOCAL_TOLERANCE * (abs(pn) + abs(pt) + abs(ps)) + TINY:
            break
    return pn, pt, ps


@njit(inline="always")
def natural_map(mu, wk, pn, pt, ps, un, ut, us):
    """One contact's shares of the natural-map residual of the Coulomb problem (De Saxcé's
    modified velocity, the measure of Siconos): with z = W_nn P [m/s] and the relative velocity
    U' (un, ut, us) [m/s] (gap term included), r = z - proj_K(z - (U'_n + mu |U'_T|, U'_T)).
    Returns (|r|^2, |z|^2, |U'|^2) [m^2/s^2]; ``wk`` = W_nn [1/kg], (pn, pt, ps) = P [N s]."""
    zn, zt, zs = wk * pn, wk * pt, wk * ps
    slip = math.sqrt(ut * ut + us * us)
    cn, ct, cs = project_cone(mu, zn - (un + mu * slip), zt - ut, zs - us)
    return ((zn - cn) ** 2 + (zt - ct) ** 2 + (zs - cs) ** 2, zn * zn + zt * zt + zs * zs,
            un * un + ut * ut + us * us)
