"""The modified Hertz–Mindlin law for two cylinders in line contact (seed 000 eqs. 16–19).

Per unit length of the cylinders (forces f in N/m, stiffnesses c in N/m^2):

* normal compliance (eq. 17):  1/c_n = (1 - nu) / (2 pi G) [2 ln(2 r / a) - 1],
  with the contact half-width a = (2 (1 - nu) f_n r / (pi G))^(1/2) (Hertz for cylinders);
* tangential compliance (eq. 18):  1/c_t = Psi / c_n [1 - f_t / (tan(phi_mu) f_n)]^(-1/2),
  so c_t = (c_n / Psi) sqrt(1 - |f_t| / (mu f_n)) falls to zero as the contact reaches sliding;
  Psi = 1 is Mindlin's law, Psi > 1 the softening of local yielding (Misra 1987);
* equivalent radius (eq. 19):  1/r = (1/r_1 + 1/r_2) / 2.

G is the equivalent shear modulus (seed 000: 105000 kN/m^2 = 1.05e8 Pa, Psi = 2.5, nu = 0.1,
phi_mu = 15 deg).

Integrating eq. 17 gives the normal approach in closed form,
delta(f_n) = (1 - nu) / (pi G) f_n ln(2 r / a(f_n)), increasing while 2 ln(2r/a) > 1, i.e. up to
the force 2 pi G r / (e (1 - nu)); the inverse is found by a safeguarded Newton iteration.
With f_n held, eq. 18 integrates too: writing s = (1 - |f_t|/(mu f_n))^(1/2), loading moves s
by -c_n |du_t| / (2 Psi mu f_n). Unloading (|f_t| decreasing) follows the initial stiffness
c_n / Psi (elastic unloading; seed 000 does not treat reversals).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from grainlab._validate import in_range, positive
from grainlab.contact.coulomb import SLIDING_TOLERANCE, coulomb_limit
from grainlab.contact.law2d import ContactState2D
from grainlab.errors import ConvergenceError

# -- compiled kernels (scalar law -> array kernel; the class below is the thin launcher) -------


@njit(inline="always")
def _normal_stiffness_scalar(force, radius, shear_modulus, poisson_ratio):
    """c_n of eq. 17 for one contact [N/m^2]; 0 when open, -1 past the law's range."""
    if force <= 0.0:
        return 0.0
    a = np.sqrt(2.0 * (1.0 - poisson_ratio) * radius * force / (np.pi * shear_modulus))
    bracket = 2.0 * np.log(2.0 * radius / a) - 1.0
    if bracket <= 0.0:
        return -1.0
    return 2.0 * np.pi * shear_modulus / ((1.0 - poisson_ratio) * bracket)


@njit(inline="always")
def _normal_force_scalar(approach, radius, shear_modulus, poisson_ratio, guess):
    """Invert delta(f) = (1 - nu)/(pi G) f ln(2r/a(f)) for one contact by a safeguarded Newton
    iteration on y = ln f. Returns 0 when open and -1 past the law's range or on failure."""
    if approach <= 0.0:
        return 0.0
    compliance = (1.0 - poisson_ratio) / (np.pi * shear_modulus)
    log_kappa = np.log(2.0 * (1.0 - poisson_ratio) * radius / (np.pi * shear_modulus))
    log_2r = np.log(2.0 * radius)
    hi = np.log(2.0 * np.pi * shear_modulus * radius / (np.e * (1.0 - poisson_ratio)))
    if approach >= compliance * np.exp(hi) * 0.5 * (1.0 - 1e-12):
        return -1.0
    lo = np.log(np.finfo(np.float64).tiny)
    start = guess if guess > 0.0 else approach / (compliance * np.log(2e3))
    y = min(max(np.log(start), lo), hi)
    for _ in range(200):
        f = np.exp(y)
        log_ratio = log_2r - 0.5 * (log_kappa + y)
        g = compliance * f * log_ratio - approach
        slope = compliance * f * (log_ratio - 0.5)
        step = g / slope if slope > 0.0 else np.inf
        if abs(step) <= 1e-13 * max(1.0, abs(y)):
            return np.exp(y - step)
        if g < 0.0:
            lo = y
        elif g > 0.0:
            hi = y
        y_new = y - step
        y = y_new if lo < y_new < hi else 0.5 * (lo + hi)
    return -1.0


@njit(inline="always")
def _tangential_piece_scalar(ft, du, fn_mid, fn_end, radius, shear_modulus, poisson_ratio,
                             psi, mu):
    """One sub-increment of eq. 18 at normal force fn_mid, cut to mu fn_end at its end."""
    limit = mu * max(fn_mid, 0.0)
    if limit <= 0.0:
        return 0.0
    kn = _normal_stiffness_scalar(fn_mid, radius, shear_modulus, poisson_ratio)
    k0 = kn / psi
    start, load = ft, du
    if ft * du < 0.0:  # unloading: elastic with c_n / Psi until f_t reaches zero
        trial = ft + k0 * du
        if trial * ft >= 0.0:
            start, load = trial, 0.0
        else:
            start, load = 0.0, trial / k0
    result = start
    if load != 0.0:  # loading: s = sqrt(1 - |f_t|/T) falls by c_n |du| / (2 Psi T)
        s0 = np.sqrt(min(max(1.0 - abs(start) / limit, 0.0), 1.0))
        s1 = max(s0 - kn * abs(load) / (2.0 * psi * limit), 0.0)
        result = np.sign(load) * limit * (1.0 - s1 * s1)
    end_limit = mu * max(fn_end, 0.0)
    return min(max(result, -end_limit), end_limit)


@njit(cache=True)
def hertz_mindlin_normal_kernel(force_or_approach, radius, shear_modulus, poisson_ratio, guess,
                                invert, out):
    """c_n(f) (invert=False) or f(delta) (invert=True) for every contact, into ``out``."""
    for c in range(out.shape[0]):
        if invert:
            out[c] = _normal_force_scalar(force_or_approach[c], radius[c], shear_modulus,
                                          poisson_ratio, guess[c])
        else:
            out[c] = _normal_stiffness_scalar(force_or_approach[c], radius[c], shear_modulus,
                                              poisson_ratio)


@njit(cache=True)
def hertz_mindlin_update_kernel(
    approach0, normal0, tangential0, d_normal, d_tangential, radius,
    shear_modulus, poisson_ratio, psi, mu, substeps,
    approach, normal, tangential,
):
    """Integrate eqs. 17-18 over one displacement increment for every contact (outputs last).

    Returns the number of contacts whose force left the range of eq. 17 (then -1 in normal)."""
    out_of_range = 0
    for c in range(approach0.shape[0]):
        approach[c] = approach0[c] + d_normal[c]
        fn = _normal_force_scalar(approach[c], radius[c], shear_modulus, poisson_ratio, normal0[c])
        normal[c] = fn
        if fn < 0.0:
            out_of_range += 1
            tangential[c] = 0.0
            continue
        ft = tangential0[c]
        du = d_tangential[c] / substeps
        fn_start = normal0[c]
        for k in range(substeps):
            # The displacement path is straight: the approach grows linearly along it.
            fn_mid = _normal_force_scalar(approach0[c] + d_normal[c] * (k + 0.5) / substeps,
                                          radius[c], shear_modulus, poisson_ratio, fn_start)
            fn_end = fn if k == substeps - 1 else _normal_force_scalar(
                approach0[c] + d_normal[c] * (k + 1.0) / substeps, radius[c], shear_modulus,
                poisson_ratio, fn_mid)
            if fn_mid < 0.0 or fn_end < 0.0:
                out_of_range += 1
                break
            ft = _tangential_piece_scalar(ft, du, fn_mid, fn_end, radius[c], shear_modulus,
                                          poisson_ratio, psi, mu)
            fn_start = fn_end
        tangential[c] = ft if fn > 0.0 else 0.0
    return out_of_range


PAPER_SHEAR_MODULUS = 1.05e8
"""G~ of seed 000 [Pa] (15000 psi = 105000 kN/m^2)."""


def equivalent_radius(radius_1: np.ndarray, radius_2: np.ndarray) -> np.ndarray:
    """Equivalent radius r = 2 r1 r2 / (r1 + r2) [m] (seed 000 eq. 19); r = r1 for equal discs."""
    r1, r2 = np.asarray(radius_1, dtype=float), np.asarray(radius_2, dtype=float)
    return 2.0 * r1 * r2 / (r1 + r2)


@dataclass(frozen=True)
class ModifiedHertzMindlin2D:
    """Parameters of the modified Hertz–Mindlin line-contact law (seed 000 eqs. 17–18).

    Attributes
    ----------
    shear_modulus:
        Equivalent shear modulus G~ [Pa].
    poisson_ratio:
        nu [-], in [0, 0.5).
    psi:
        Psi [-], >= 1 (1 = Mindlin).
    friction_angle:
        Interparticle friction angle phi_mu [rad], in (0, pi/2).
    substeps:
        Sub-increments used to integrate the tangential law when f_n changes in a step.

    >>> law = ModifiedHertzMindlin2D.seed000()
    >>> kn, kt = law.tangent_stiffness(np.array([100.0]), np.array([0.0]), np.array([0.00635]))
    >>> float(kn[0] / kt[0])  # c_n / c_t = Psi with no shear force
    2.5
    """

    shear_modulus: float = PAPER_SHEAR_MODULUS
    poisson_ratio: float = 0.1
    psi: float = 2.5
    friction_angle: float = float(np.radians(15.0))
    substeps: int = 8

    def __post_init__(self) -> None:
        positive("shear_modulus", self.shear_modulus, "Pa")
        in_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, closed="[)")
        in_range("psi", self.psi, 1.0, 1e6, closed="[)")
        in_range("friction_angle", self.friction_angle, 0.0, np.pi / 2, "rad")
        in_range("substeps", self.substeps, 0, 10000, closed="(]")

    @classmethod
    def seed000(cls) -> ModifiedHertzMindlin2D:
        """The constants of seed 000: G~ = 1.05e8 Pa, Psi = 2.5, nu = 0.1, phi_mu = 15 deg."""
        return cls()

    @property
    def friction_coefficient(self) -> float:
        """mu = tan(phi_mu) [-]."""
        return float(np.tan(self.friction_angle))

    def describe(self) -> dict:
        """Parameters as plain data (SI units, angle in degrees) for metadata."""
        return {
            "law": "modified Hertz-Mindlin (seed 000 eqs. 17-19)",
            "shear_modulus_Pa": self.shear_modulus,
            "poisson_ratio": self.poisson_ratio,
            "psi": self.psi,
            "friction_angle_deg": float(np.degrees(self.friction_angle)),
        }

    # -- normal law -------------------------------------------------------------------------
    def _kappa(self, radius: np.ndarray) -> np.ndarray:
        """a^2 / f_n = 2 (1 - nu) r / (pi G) [m^3/N]."""
        return 2.0 * (1.0 - self.poisson_ratio) * radius / (np.pi * self.shear_modulus)

    def half_width(self, normal_force: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """Contact half-width a = (2 (1 - nu) f_n r / (pi G))^(1/2) [m]."""
        return np.sqrt(self._kappa(radius) * np.maximum(normal_force, 0.0))

    def largest_normal_force(self, radius: np.ndarray) -> np.ndarray:
        """Force [N/m] past which eq. 17 gives a negative compliance (a = 2 r e^(-1/2))."""
        return 2.0 * np.pi * self.shear_modulus * radius / (np.e * (1.0 - self.poisson_ratio))

    def _normal_kernel(self, values, radius, guess, invert: bool) -> np.ndarray:
        values = np.asarray(values, dtype=float)
        flat = np.ascontiguousarray(values.reshape(-1))
        m = flat.shape[0]
        out = np.empty(m)
        guesses = np.zeros(m) if guess is None else np.ascontiguousarray(
            np.broadcast_to(np.asarray(guess, dtype=float).reshape(-1), (m,)))
        hertz_mindlin_normal_kernel(
            flat,
            np.ascontiguousarray(np.broadcast_to(np.asarray(radius, float).reshape(-1), (m,))),
            self.shear_modulus, self.poisson_ratio, guesses, invert, out,
        )
        if np.any(out < 0.0):
            raise ConvergenceError(
                "A contact left the range of seed 000 eq. 17 (contact half-width beyond "
                "2 r e^(-1/2)): the stress is too high for this shear modulus."
            )
        return out.reshape(values.shape)

    def normal_stiffness(self, normal_force: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """c_n [N/m^2] from eq. 17; zero for an open contact."""
        return self._normal_kernel(normal_force, radius, None, invert=False)

    def normal_approach(self, normal_force: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """delta(f_n) = (1 - nu) / (pi G) f_n ln(2 r / a) [m], the integral of eq. 17."""
        force = np.maximum(np.asarray(normal_force, dtype=float), 0.0)
        radius = np.broadcast_to(np.asarray(radius, dtype=float), force.shape)
        approach = np.zeros_like(force)
        loaded = force > 0.0
        a = self.half_width(force[loaded], radius[loaded])
        approach[loaded] = (
            (1.0 - self.poisson_ratio) / (np.pi * self.shear_modulus)
            * force[loaded] * np.log(2.0 * radius[loaded] / a)
        )
        return approach

    def normal_force(
        self, approach: np.ndarray, radius: np.ndarray, guess: np.ndarray | None = None
    ) -> np.ndarray:
        """Invert delta(f_n) [N/m] by a safeguarded Newton iteration on y = ln f_n; 0 where
        delta <= 0. ``guess`` (forces [N/m], e.g. of the previous increment) speeds it up."""
        return self._normal_kernel(approach, radius, guess, invert=True)

    # -- tangential law ---------------------------------------------------------------------
    def tangent_stiffness(
        self, normal_force: np.ndarray, tangential_force: np.ndarray, radius: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(c_n, c_t) [N/m^2] on the loading branch (eqs. 17–18)."""
        kn = self.normal_stiffness(normal_force, radius)
        limit = coulomb_limit(normal_force, self.friction_coefficient)
        ratio = np.divide(
            np.abs(tangential_force), limit, out=np.ones_like(kn), where=limit > 0.0
        )
        kt = kn / self.psi * np.sqrt(np.clip(1.0 - ratio, 0.0, 1.0))
        return kn, kt

    def update(
        self, state: ContactState2D, d_normal: np.ndarray, d_tangential: np.ndarray,
        radius: np.ndarray,
    ) -> ContactState2D:
        """Integrate eqs. 17–18 over displacement increments (du_n, du_t) [m].

        The normal force follows the closed-form approach exactly; the tangential force is
        integrated in :attr:`substeps` pieces of the straight displacement path (the approach
        growing linearly), each with the closed-form solution of eq. 18 at the normal force of
        the piece's mid-point (compiled kernel
        :func:`hertz_mindlin_update_kernel`).
        """
        m = state.normal_force.shape[0]
        approach, normal, tangential = np.empty(m), np.empty(m), np.empty(m)
        out_of_range = hertz_mindlin_update_kernel(
            np.ascontiguousarray(state.normal_approach, dtype=float),
            np.ascontiguousarray(state.normal_force, dtype=float),
            np.ascontiguousarray(state.tangential_force, dtype=float),
            np.ascontiguousarray(d_normal, dtype=float),
            np.ascontiguousarray(d_tangential, dtype=float),
            np.ascontiguousarray(np.broadcast_to(radius, (m,)), dtype=float),
            self.shear_modulus, self.poisson_ratio, self.psi, self.friction_coefficient,
            self.substeps, approach, normal, tangential,
        )
        if out_of_range:
            raise ConvergenceError(
                f"{out_of_range} contact(s) left the range of seed 000 eq. 17 (half-width beyond "
                "2 r e^(-1/2)): the stress is too high for this shear modulus."
            )
        limit = coulomb_limit(normal, self.friction_coefficient)
        sliding = (normal > 0.0) & (np.abs(tangential) >= (1.0 - SLIDING_TOLERANCE) * limit)
        return ContactState2D(approach, normal, tangential, sliding)
