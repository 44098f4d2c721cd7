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

from grainlab._validate import in_range, positive
from grainlab.contact.coulomb import SLIDING_TOLERANCE, coulomb_limit
from grainlab.contact.law2d import ContactState2D
from grainlab.errors import ConvergenceError

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

    def normal_stiffness(self, normal_force: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """c_n [N/m^2] from eq. 17; zero for an open contact."""
        force = np.asarray(normal_force, dtype=float)
        radius = np.broadcast_to(np.asarray(radius, dtype=float), force.shape)
        stiffness = np.zeros_like(force)
        loaded = force > 0.0
        a = self.half_width(force[loaded], radius[loaded])
        bracket = 2.0 * np.log(2.0 * radius[loaded] / a) - 1.0
        if np.any(bracket <= 0.0):
            raise ConvergenceError(
                "A normal force exceeds the range of seed 000 eq. 17 (contact half-width "
                "beyond 2 r e^(-1/2)); the stress level is too high for this G."
            )
        stiffness[loaded] = 2.0 * np.pi * self.shear_modulus / ((1.0 - self.poisson_ratio) * bracket)
        return stiffness

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

    def normal_force(self, approach: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """Invert delta(f_n) [N/m]: safeguarded Newton on y = ln f_n; 0 where delta <= 0."""
        approach = np.asarray(approach, dtype=float)
        radius = np.broadcast_to(np.asarray(radius, dtype=float), approach.shape)
        force = np.zeros_like(approach)
        loaded = approach > 0.0
        if not np.any(loaded):
            return force
        delta, r = approach[loaded], radius[loaded]
        f_max = self.largest_normal_force(r)
        if np.any(delta > self.normal_approach(f_max, r) * (1.0 - 1e-12)):
            raise ConvergenceError(
                "A normal approach exceeds the range of seed 000 eq. 17: the contact would need "
                "a half-width beyond 2 r e^(-1/2). Lower the stress or raise the shear modulus."
            )
        compliance_factor = (1.0 - self.poisson_ratio) / (np.pi * self.shear_modulus)
        log_kappa = np.log(self._kappa(r))
        log_2r = np.log(2.0 * r)
        lo = np.full_like(delta, np.log(np.finfo(float).tiny))
        hi = np.log(f_max)
        # Start from the linear estimate delta ~ compliance * f * ln(2r/a(f)) with a ~ 1e-3 r.
        y = np.clip(np.log(delta / (compliance_factor * np.log(2e3))), lo, hi)
        for _ in range(100):
            f = np.exp(y)
            log_ratio = log_2r - 0.5 * (log_kappa + y)  # ln(2r/a)
            g = compliance_factor * f * log_ratio - delta
            lo = np.where(g < 0.0, y, lo)
            hi = np.where(g > 0.0, y, hi)
            slope = compliance_factor * f * (log_ratio - 0.5)  # dg/dy
            step = np.divide(g, slope, out=np.full_like(g, np.inf), where=slope > 0.0)
            y_new = y - step
            outside = ~((y_new > lo) & (y_new < hi))
            y_new = np.where(outside, 0.5 * (lo + hi), y_new)
            if np.all(np.abs(y_new - y) <= 1e-14 * np.maximum(1.0, np.abs(y))):
                y = y_new
                break
            y = y_new
        else:
            raise ConvergenceError("Inverting the normal law of seed 000 eq. 17 did not converge.")
        force[loaded] = np.exp(y)
        return force

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
        integrated in :attr:`substeps` pieces along which f_n varies linearly, each with the
        closed-form solution of eq. 18 at that piece's mean normal force.
        """
        approach = state.normal_approach + d_normal
        normal = self.normal_force(approach, radius)
        tangential = np.array(state.tangential_force, dtype=float)
        mu = self.friction_coefficient
        du = np.asarray(d_tangential, dtype=float) / self.substeps
        f0 = state.normal_force
        for k in range(self.substeps):
            fn_mid = f0 + (normal - f0) * (k + 0.5) / self.substeps
            fn_end = f0 + (normal - f0) * (k + 1.0) / self.substeps
            tangential = self._tangential_piece(tangential, du, fn_mid, fn_end, radius, mu)
        closed = normal > 0.0
        tangential = np.where(closed, tangential, 0.0)
        limit = coulomb_limit(normal, mu)
        sliding = closed & (np.abs(tangential) >= (1.0 - SLIDING_TOLERANCE) * limit)
        return ContactState2D(approach, normal, tangential, sliding)

    def _tangential_piece(self, ft, du, fn_mid, fn_end, radius, mu):
        """One sub-increment of eq. 18 at normal force fn_mid, then cut to mu fn_end."""
        kn = self.normal_stiffness(fn_mid, radius)
        k0 = kn / self.psi
        limit = mu * np.maximum(fn_mid, 0.0)
        # Unloading (du against f_t): elastic with c_n / Psi until f_t reaches zero.
        against = ft * du < 0.0
        trial = ft + k0 * du
        crosses = against & (trial * ft < 0.0)
        remainder = np.where(
            crosses, np.divide(trial, k0, out=np.zeros_like(trial), where=k0 > 0), 0.0
        )
        start = np.where(against & ~crosses, trial, np.where(crosses, 0.0, ft))
        load = np.where(against & ~crosses, 0.0, np.where(crosses, remainder, du))
        # Loading: s = sqrt(1 - |f_t|/T) decreases by c_n |du| / (2 Psi T).
        safe = np.where(limit > 0.0, limit, 1.0)
        s0 = np.sqrt(np.clip(1.0 - np.abs(start) / safe, 0.0, 1.0))
        s1 = np.maximum(s0 - kn * np.abs(load) / (2.0 * self.psi * safe), 0.0)
        direction = np.where(load != 0.0, np.sign(load), np.sign(start))
        loaded_value = direction * safe * (1.0 - s1**2)
        result = np.where(load != 0.0, loaded_value, start)
        result = np.where(limit > 0.0, result, 0.0)
        end_limit = mu * np.maximum(fn_end, 0.0)
        return np.clip(result, -end_limit, end_limit)
