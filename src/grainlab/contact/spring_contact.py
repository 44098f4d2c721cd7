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
frictional. A separated contact re-forms when its accumulated normal approach becomes positive
again (the gap has closed); its tangential force restarts from zero.

Forces are those the first particle (the micro-element's centre) exerts on the second, positive
in compression; f_r is the tangential (resultant shear) force vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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

    @property
    def force(self) -> np.ndarray:
        """Force vectors f = f_n n + f_r need the normals: see :func:`force_vectors`."""
        raise AttributeError("use force_vectors(state, normals)")


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

        Returns the new state and the residual force vectors S + (d,) [N] removed by sliding,
        separation or bond breakage (eqs. 2.3–2.4). ``active`` masks padded entries.
        """
        normals = np.asarray(normals, dtype=float)
        dd = np.asarray(approach_increment, dtype=float)
        dn = np.einsum("...i,...i->...", dd, normals)
        dt = dd - dn[..., None] * normals
        shear_old = state.shear_force - np.einsum(
            "...i,...i->...", state.shear_force, normals)[..., None] * normals  # re-project
        kn, kr = self.stiffness(state.normal_force, np.linalg.norm(shear_old, axis=-1), radius,
                                force_floor, touching=state.normal_approach >= 0.0)
        approach = state.normal_approach + dn
        # Normal: exact spring law of the approach; bonded contacts also carry tension.
        normal = np.where(approach > 0.0, self.normal_force_of_approach(approach, radius), 0.0)
        if self.cemented:
            tension = np.where(approach < 0.0, -self._tension_stiffness(radius, kn) * -approach,
                               0.0)
            normal = np.where(state.bonded & (approach < 0.0), tension, normal)
        trial_normal_increment = kn * dn  # what the linearised K predicted
        # Tangential: trial with the instantaneous k_r; unloading uses the initial stiffness.
        k_unload = self._initial_shear_stiffness(state.normal_force, radius)
        reversing = np.einsum("...i,...i->...", dt, shear_old) < 0.0
        k_shear = np.where(reversing, k_unload, kr)
        shear_trial = shear_old + k_shear[..., None] * dt
        magnitude = np.linalg.norm(shear_trial, axis=-1)
        mu = self.friction_coefficient
        bonded = state.bonded.copy()
        if self.cemented:
            shear_strength = self.bond_shear_strength + mu * np.maximum(normal, 0)
            broken = bonded & ((normal < -self.bond_tensile_strength)
                               | (magnitude > shear_strength))
            bonded &= ~broken
            normal = np.where(~bonded & (approach <= 0.0), 0.0, normal)
        limit = np.where(bonded, self.bond_shear_strength + mu * np.maximum(normal, 0.0),
                         mu * np.maximum(normal, 0.0))
        sliding = (magnitude > limit) & (limit >= 0.0) & ~bonded
        scale = np.divide(limit, magnitude, out=np.zeros_like(magnitude), where=magnitude > 0)
        shear = np.where((magnitude > limit)[..., None], scale[..., None] * shear_trial,
                         shear_trial)
        closed = (normal > 0.0) | bonded
        shear = np.where(closed[..., None], shear, 0.0)
        sliding &= closed
        # Residual force: the linearised trial minus what the contact carries.
        predicted_normal = state.normal_force + trial_normal_increment
        residual = ((predicted_normal - normal)[..., None] * normals + (shear_trial - shear))
        if active is not None:
            keep = np.asarray(active, dtype=bool)
            normal = np.where(keep, normal, 0.0)
            shear = np.where(keep[..., None], shear, 0.0)
            residual = np.where(keep[..., None], residual, 0.0)
            sliding &= keep
            approach = np.where(keep, approach, 0.0)
        return SpringState(approach, normal, shear, sliding, bonded), residual

    def _initial_shear_stiffness(self, normal_force, radius) -> np.ndarray:
        kn, _ = self.stiffness(np.maximum(normal_force, 0.0), np.zeros_like(normal_force), radius,
                               touching=np.ones(np.shape(normal_force), bool))
        ratio = mindlin_c2(self.poisson_ratio) if self.hertzian else (
            self.shear_stiffness / self.normal_stiffness)
        return ratio * kn

    def _tension_stiffness(self, radius, kn) -> np.ndarray:
        """Stiffness of a bond in tension [N/m]: the normal stiffness (constant springs) or
        the Hertzian stiffness at the bond strength."""
        if not self.hertzian:
            return np.full_like(np.asarray(kn, dtype=float), self.normal_stiffness)
        k, _ = self.stiffness(np.full_like(np.asarray(kn, float), max(
            self.bond_tensile_strength, 1e-12)), np.zeros_like(np.asarray(kn, float)), radius)
        return k
