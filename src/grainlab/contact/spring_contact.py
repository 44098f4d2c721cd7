"""Elastic–plastic spring contacts of seed 001 (eqs. 2.3–2.8), in 2D or 3D, on arrays.

Each contact is a spring between two rigid particles: an increment of relative displacement
(approach vector) d_delta gives the trial force increment K d_delta with
K = k_n n n + k_r (I - n n) (eq. 2.5). The stiffnesses are either constant (k_n, k_s) or the
Hertz–Mindlin forms of seed 001:

* k_n = C1 r E_mu (f_n / (r^2 E_mu))^alpha, C1 = 3^(1/3), alpha = 1/3, E_mu = G_mu/(1 - nu_mu)
  (eq. 2.6, MISSION's reading), integrating to f_n = kappa delta_n^(1/(1 - alpha));
* k_r = C2 k_n (1 - f_r / (f_n tan phi_mu))^(1/3), C2 = 2 (1 - nu_mu)/(2 - nu_mu) (eqs. 2.7–2.8).

Within an increment the spring is linear (the instantaneous K). A trial force beyond the
contact's strength is cut back and the excess is the residual force of eqs. 2.3–2.4: sliding
(|f_r| > mu f_n, k_r -> 0) or separation (f_n < 0, k_n -> 0). Optional cementation adds a bond
with tensile and shear strengths; a bond that is exceeded breaks for good and the contact becomes
frictional. A sliding contact (at the Coulomb limit, k_r = 0 in K) that is loaded on takes the
elastic trial and is returned to the cone, so that its shear force stays equal to the strength
mu f_n while f_n changes (Fig. 2.5b) instead of falling below it and alternating between
sticking and sliding from one increment to the next. A separated contact re-forms when its
accumulated normal approach becomes positive again (the gap has closed); its tangential force
restarts from zero.

Forces are those the first particle (the micro-element's centre) exerts on the second, positive
in compression; f_r is the tangential (resultant shear) force vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from grainlab._validate import in_range, positive

HERTZ_C1 = 3.0 ** (1.0 / 3.0)
HERTZ_ALPHA = 1.0 / 3.0


def mindlin_c2(poisson_ratio: float) -> float:
    """C2 = 2 (1 - nu)/(2 - nu), the ratio k_r/k_n of Mindlin at zero shear (eq. 2.8)."""
    return 2.0 * (1.0 - poisson_ratio) / (2.0 - poisson_ratio)


@dataclass(frozen=True)
class SpringState:
    """Contact forces and history (arrays of any common shape S).

    Attributes
    ----------
    normal_approach:
        S: accumulated normal approach delta_n [m] (> 0 closed).
    normal_force:
        S: f_n [N], >= -bond tensile strength.
    shear_force:
        S + (d,): tangential force vector f_r [N].
    sliding, bonded:
        S: booleans.
    """

    normal_approach: np.ndarray
    normal_force: np.ndarray
    shear_force: np.ndarray
    sliding: np.ndarray
    bonded: np.ndarray

    @property
    def open(self) -> np.ndarray:
        """Contacts that carry no force (separated)."""
        return (self.normal_force <= 0.0) & ~self.bonded



def force_vectors(state: SpringState, normals: np.ndarray) -> np.ndarray:
    """Force vectors f_n n + f_r [N], shape S + (d,)."""
    return state.normal_force[..., None] * normals + state.shear_force


@dataclass(frozen=True)
class SpringContactLaw:
    """Seed 001's contact law: linear or Hertz–Mindlin springs, Coulomb, separation, bonds.

    Give either ``normal_stiffness`` (and ``shear_stiffness``) for constant springs [N/m], or
    ``shear_modulus`` and ``poisson_ratio`` of the grains for Hertz–Mindlin (eqs. 2.6–2.8).

    Attributes
    ----------
    friction_angle:
        phi_mu [rad].
    bond_tensile_strength, bond_shear_strength:
        Cementation [N]; zero means no bond.

    >>> law = SpringContactLaw(normal_stiffness=1e5, shear_stiffness=1e5,
    ...                        friction_angle=np.radians(25))
    >>> kn, kr = law.stiffness(np.array([1.0]), np.array([0.0]), np.array([2e-4]))
    >>> float(kn[0]), float(kr[0])
    (100000.0, 100000.0)
    """

    friction_angle: float = float(np.radians(25.0))
    normal_stiffness: float | None = None
    shear_stiffness: float | None = None
    shear_modulus: float | None = None
    poisson_ratio: float | None = None
    bond_tensile_strength: float = 0.0
    bond_shear_strength: float = 0.0

    def __post_init__(self) -> None:
        in_range("friction_angle", self.friction_angle, 0.0, np.pi / 2, "rad", closed="[)")
        constant = self.normal_stiffness is not None
        hertz = self.shear_modulus is not None
        if constant == hertz:
            from grainlab.errors import InputError

            raise InputError("contact law", "both or neither of normal_stiffness and "
                             "shear_modulus", "constant springs (normal_stiffness, "
                             "shear_stiffness) or Hertz-Mindlin (shear_modulus, poisson_ratio)")
        if constant:
            positive("normal_stiffness", self.normal_stiffness, "N/m")
            if self.shear_stiffness is None:
                object.__setattr__(self, "shear_stiffness", float(self.normal_stiffness))
            in_range("shear_stiffness", self.shear_stiffness, 0.0, np.inf, "N/m", closed="[)")
        else:
            positive("shear_modulus", self.shear_modulus, "Pa")
            if self.poisson_ratio is None:
                object.__setattr__(self, "poisson_ratio", 0.25)
            in_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, closed="[)")
        in_range("bond_tensile_strength", self.bond_tensile_strength, 0.0, np.inf, "N",
                 closed="[)")
        in_range("bond_shear_strength", self.bond_shear_strength, 0.0, np.inf, "N",
                 closed="[)")

    @property
    def hertzian(self) -> bool:
        """True for the Hertz–Mindlin stiffnesses of eqs. 2.6–2.8."""
        return self.shear_modulus is not None

    @property
    def friction_coefficient(self) -> float:
        """mu = tan(phi_mu)."""
        return float(np.tan(self.friction_angle))

    @property
    def cemented(self) -> bool:
        """True when contacts start bonded."""
        return self.bond_tensile_strength > 0.0 or self.bond_shear_strength > 0.0

    def describe(self) -> dict:
        """Parameters as plain data (SI units, angle in degrees)."""
        out = {"friction_angle_deg": float(np.degrees(self.friction_angle)),
               "bond_tensile_strength_N": self.bond_tensile_strength,
               "bond_shear_strength_N": self.bond_shear_strength}
        if self.hertzian:
            out.update(law="Hertz-Mindlin (seed 001 eqs. 2.6-2.8)",
                       shear_modulus_Pa=self.shear_modulus, poisson_ratio=self.poisson_ratio)
        else:
            out.update(law="linear springs (seed 001 eq. 2.5)",
                       normal_stiffness_N_per_m=self.normal_stiffness,
                       shear_stiffness_N_per_m=self.shear_stiffness)
        return out

    # -- stiffness ----------------------------------------------------------------------------
    def _modulus(self) -> float:
        return self.shear_modulus / (1.0 - self.poisson_ratio)

    def normal_force_of_approach(self, approach: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """f_n(delta_n) [N] of the normal spring (0 where delta_n <= 0)."""
        approach = np.maximum(np.asarray(approach, dtype=float), 0.0)
        if not self.hertzian:
            return self.normal_stiffness * approach
        e = self._modulus()
        a = HERTZ_ALPHA
        kappa = ((1 - a) * HERTZ_C1 * np.asarray(radius) ** (1 - 2 * a) * e ** (1 - a)) ** (
            1 / (1 - a))
        return kappa * approach ** (1 / (1 - a))

    def approach_of_normal_force(self, force: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`normal_force_of_approach` [m]."""
        force = np.maximum(np.asarray(force, dtype=float), 0.0)
        if not self.hertzian:
            return force / self.normal_stiffness
        e = self._modulus()
        a = HERTZ_ALPHA
        kappa = ((1 - a) * HERTZ_C1 * np.asarray(radius) ** (1 - 2 * a) * e ** (1 - a)) ** (
            1 / (1 - a))
        return (force / kappa) ** (1 - a)

    def stiffness(
        self, normal_force: np.ndarray, shear_magnitude: np.ndarray, radius: np.ndarray,
        force_floor: float = 0.0, touching: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(k_n, k_r) [N/m] on the loading branch at the current forces.

        ``touching`` marks contacts that touch without force (they are stiff for linear
        springs); ``force_floor`` [N] evaluates Hertzian stiffness at no less than that normal
        force (a Hertzian contact has no stiffness at zero force; used to start a loading)."""
        fn = np.asarray(normal_force, dtype=float)
        closed = fn > 0.0
        if touching is not None:
            closed = closed | np.asarray(touching, dtype=bool)
        mu = self.friction_coefficient
        limit = mu * np.maximum(fn, 0.0)
        ratio = np.divide(shear_magnitude, limit, out=np.ones_like(fn), where=limit > 0)
        if self.hertzian:
            e = self._modulus()
            r = np.broadcast_to(np.asarray(radius, dtype=float), fn.shape)
            f_eval = np.maximum(fn, force_floor)
            kn = HERTZ_C1 * r * e * np.maximum(f_eval / (r**2 * e), 0.0) ** HERTZ_ALPHA
            kn = np.where(closed | (force_floor > 0), kn, 0.0)
            kr = mindlin_c2(self.poisson_ratio) * kn * np.clip(1.0 - ratio, 0.0, 1.0) ** (1 / 3)
            kr = np.where(closed, kr, np.where(force_floor > 0, mindlin_c2(self.poisson_ratio)
                                               * kn, 0.0))
        else:
            kn = np.where(closed | (force_floor > 0), self.normal_stiffness, 0.0)
            kr = np.where(closed & (ratio < 1.0 - 1e-9), self.shear_stiffness, 0.0)
            kr = np.where(~closed & (force_floor > 0), self.shear_stiffness, kr)
        return kn, kr

    # -- increment ----------------------------------------------------------------------------
    def initial_state(self, shape: tuple[int, ...], dimension: int) -> SpringState:
        """Contacts just touching, no force (bonded if the law is cemented)."""
        zeros = np.zeros(shape)
        return SpringState(zeros, zeros.copy(), np.zeros((*shape, dimension)),
                           np.zeros(shape, bool), np.full(shape, self.cemented))

    def update(
        self, state: SpringState, approach_increment: np.ndarray, normals: np.ndarray,
        radius: np.ndarray, active: np.ndarray | None = None, force_floor: float = 0.0,
    ) -> tuple[SpringState, np.ndarray]:
        """Apply relative-displacement (approach) increments S + (d,) [m].

        Returns the new state and the residual force vectors S + (d,) [N]: the linearised trial
        (instantaneous K) minus what the contact carries after sliding, separation, bond
        breakage or the curvature of the Hertzian law (eqs. 2.3–2.4). ``active`` masks padded
        entries. Integrated by the compiled :func:`spring_update_kernel`.
        """
        increment = np.asarray(approach_increment, dtype=float)
        shape, d = increment.shape[:-1], increment.shape[-1]
        rows = int(np.prod(shape))
        flat = lambda a, dt=float: np.ascontiguousarray(  # noqa: E731
            np.broadcast_to(np.asarray(a, dtype=dt), shape).reshape(rows))
        vec = lambda a: np.ascontiguousarray(  # noqa: E731
            np.broadcast_to(np.asarray(a, dtype=float), (*shape, d)).reshape(rows, d))
        out = (np.empty(rows), np.empty(rows), np.empty((rows, d)), np.empty(rows, bool),
               np.empty(rows, bool), np.empty((rows, d)))
        hertz = self.hertzian
        spring_update_kernel(
            flat(state.normal_approach), flat(state.normal_force), vec(state.shear_force),
            flat(state.bonded, bool), vec(increment), vec(normals), flat(radius),
            flat(np.ones(shape, bool) if active is None else active, bool), float(force_floor),
            hertz, float(self.normal_stiffness or 0.0), float(self.shear_stiffness or 0.0),
            float(self._modulus()) if hertz else 0.0,
            mindlin_c2(self.poisson_ratio) if hertz else 0.0, self.friction_coefficient,
            float(self.bond_tensile_strength), float(self.bond_shear_strength), self.cemented,
            *out,
        )
        approach, normal, shear, sliding, bonded, residual = out
        return SpringState(approach.reshape(shape), normal.reshape(shape),
                           shear.reshape(*shape, d), sliding.reshape(shape),
                           bonded.reshape(shape)), residual.reshape(*shape, d)


# -- compiled update (scalar law -> array kernel; the class methods above launch it) -----------
@njit(inline="always")
def _stiffness_scalar(fn, shear, radius, touching, force_floor, hertzian, kn_const, ks_const,
                      modulus, c2, mu):
    """(k_n, k_r) of one contact on the loading branch (see SpringContactLaw.stiffness)."""
    closed = fn > 0.0 or touching
    limit = mu * max(fn, 0.0)
    ratio = shear / limit if limit > 0.0 else 1.0
    if hertzian:
        f_eval = max(fn, force_floor)
        kn = 0.0
        if closed or force_floor > 0.0:
            kn = HERTZ_C1 * radius * modulus * max(f_eval / (radius * radius * modulus),
                                                   0.0) ** HERTZ_ALPHA
        if fn > 0.0:
            kr = c2 * kn * min(max(1.0 - ratio, 0.0), 1.0) ** (1.0 / 3.0)
        elif force_floor > 0.0:
            kr = c2 * kn
        else:
            kr = 0.0
        return kn, kr
    kn = kn_const if (closed or force_floor > 0.0) else 0.0
    kr = ks_const if (closed and ratio < 1.0 - 1e-9) else 0.0
    if (not closed) and force_floor > 0.0:
        kr = ks_const
    return kn, kr


@njit(inline="always")
def _normal_force_scalar(approach, radius, hertzian, kn_const, modulus):
    if approach <= 0.0:
        return 0.0
    if not hertzian:
        return kn_const * approach
    a = HERTZ_ALPHA
    kappa = ((1 - a) * HERTZ_C1 * radius ** (1 - 2 * a) * modulus ** (1 - a)) ** (1 / (1 - a))
    return kappa * approach ** (1 / (1 - a))


@njit(cache=True)
def spring_update_kernel(approach0, normal0, shear0, bonded0, increment, normals, radius,
                         active, force_floor, hertzian, kn_const, ks_const, modulus, c2, mu,
                         bond_tensile, bond_shear, cemented,
                         approach, normal, shear, sliding, bonded, residual):
    """Integrate seed 001's contact law for N contacts (rows), outputs last (see
    SpringContactLaw.update for the rules)."""
    n_rows, d = increment.shape
    dt = np.empty(d)  # per-row scratch, allocated once
    old = np.empty(d)
    trial = np.empty(d)
    for c in range(n_rows):
        for i in range(d):
            shear[c, i] = 0.0
            residual[c, i] = 0.0
        sliding[c] = False
        bonded[c] = bonded0[c]
        if not active[c]:
            approach[c] = 0.0
            normal[c] = 0.0
            continue
        dn = 0.0
        old_n = 0.0
        for i in range(d):
            dn += increment[c, i] * normals[c, i]
            old_n += shear0[c, i] * normals[c, i]
        old_mag = 0.0
        reverse = 0.0
        for i in range(d):
            dt[i] = increment[c, i] - dn * normals[c, i]
            old[i] = shear0[c, i] - old_n * normals[c, i]
            old_mag += old[i] * old[i]
            reverse += dt[i] * old[i]
        old_mag = np.sqrt(old_mag)
        kn, kr = _stiffness_scalar(normal0[c], old_mag, radius[c], approach0[c] >= 0.0,
                                   force_floor, hertzian, kn_const, ks_const, modulus, c2, mu)
        a = approach0[c] + dn
        approach[c] = a
        fn = _normal_force_scalar(a, radius[c], hertzian, kn_const, modulus)
        if cemented and bonded0[c] and a < 0.0:
            k_tension = kn_const if not hertzian else _stiffness_scalar(
                max(bond_tensile, 1e-12), 0.0, radius[c], True, 0.0, True, kn_const,
                ks_const, modulus, c2, mu)[0]
            fn = k_tension * a
        # tangential trial: unloading (against the current shear) with the initial stiffness
        if reverse < 0.0:
            k0 = _stiffness_scalar(max(normal0[c], 0.0), 0.0, radius[c], True, 0.0, hertzian,
                                   kn_const, ks_const, modulus, c2, mu)[0]
            k_shear = (c2 if hertzian else ks_const / kn_const) * k0
        elif kr == 0.0 and old_mag > 0.0 and normal0[c] > 0.0:
            # a sliding contact loaded on: elastic trial, returned to the cone below, so that
            # its shear force stays at mu f_n as f_n changes (Fig. 2.5b: f_r = strength)
            k0 = _stiffness_scalar(normal0[c], 0.0, radius[c], True, 0.0, hertzian,
                                   kn_const, ks_const, modulus, c2, mu)[0]
            k_shear = (c2 if hertzian else ks_const / kn_const) * k0
        else:
            k_shear = kr
        magnitude = 0.0
        for i in range(d):
            trial[i] = old[i] + k_shear * dt[i]
            magnitude += trial[i] * trial[i]
        magnitude = np.sqrt(magnitude)
        is_bonded = bonded0[c]
        if cemented and is_bonded:
            if fn < -bond_tensile or magnitude > bond_shear + mu * max(fn, 0.0):
                is_bonded = False
                if a <= 0.0:
                    fn = 0.0
        bonded[c] = is_bonded
        limit = (bond_shear if is_bonded else 0.0) + mu * max(fn, 0.0)
        slides = magnitude >= (1.0 - 1e-9) * limit and limit > 0.0 and not is_bonded
        scale = limit / magnitude if (magnitude > limit and magnitude > 0.0) else 1.0
        closed = fn > 0.0 or is_bonded
        predicted = normal0[c] + kn * dn
        for i in range(d):
            s_i = scale * trial[i] if closed else 0.0
            shear[c, i] = s_i
            residual[c, i] = (predicted - fn) * normals[c, i] + (trial[i] - s_i)
        normal[c] = fn
        sliding[c] = slides and closed
