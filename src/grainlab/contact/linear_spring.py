"""Linear springs with Coulomb friction: f_n = k_n delta, df_t = k_t du_t, |f_t| <= mu f_n.

The constant-stiffness law offered beside the modified Hertz–Mindlin law (seed 000 eq. 16 with
constant c_n = k_n and c_t = k_t; seed 001 eq. 2.5 with constant k_n, k_s). Forces and
stiffnesses per unit length in 2D (N/m, N/m^2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainlab._validate import in_range, positive
from grainlab.contact.coulomb import SLIDING_TOLERANCE, coulomb_limit
from grainlab.contact.law2d import ContactState2D


@dataclass(frozen=True)
class LinearSpring2D:
    """Linear normal and tangential springs with Coulomb sliding.

    Attributes
    ----------
    normal_stiffness:
        k_n [N/m^2 per unit length in 2D].
    tangential_stiffness:
        k_t [same unit], >= 0.
    friction_angle:
        phi_mu [rad], in (0, pi/2).

    >>> law = LinearSpring2D(1e8, 5e7, np.radians(15))
    >>> float(law.normal_force(np.array([1e-6]), np.array([0.01]))[0])
    100.0
    """

    normal_stiffness: float
    tangential_stiffness: float
    friction_angle: float = float(np.radians(15.0))

    def __post_init__(self) -> None:
        positive("normal_stiffness", self.normal_stiffness, "N/m^2")
        in_range("tangential_stiffness", self.tangential_stiffness, 0.0, np.inf, closed="[)")
        in_range("friction_angle", self.friction_angle, 0.0, np.pi / 2, "rad")

    @property
    def friction_coefficient(self) -> float:
        """mu = tan(phi_mu) [-]."""
        return float(np.tan(self.friction_angle))

    def describe(self) -> dict:
        """Parameters as plain data for metadata."""
        return {
            "law": "linear springs with Coulomb friction",
            "normal_stiffness": self.normal_stiffness,
            "tangential_stiffness": self.tangential_stiffness,
            "friction_angle_deg": float(np.degrees(self.friction_angle)),
        }

    def normal_force(self, approach: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """f_n = k_n max(delta, 0) [N/m]."""
        return self.normal_stiffness * np.maximum(np.asarray(approach, dtype=float), 0.0)

    def normal_approach(self, normal_force: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """delta = f_n / k_n [m]."""
        return np.maximum(np.asarray(normal_force, dtype=float), 0.0) / self.normal_stiffness

    def tangent_stiffness(
        self, normal_force: np.ndarray, tangential_force: np.ndarray, radius: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(k_n, k_t) on closed contacts, k_t = 0 on sliding ones, both 0 on open ones."""
        normal_force = np.asarray(normal_force, dtype=float)
        closed = normal_force > 0.0
        limit = coulomb_limit(normal_force, self.friction_coefficient)
        sliding = closed & (np.abs(tangential_force) >= (1.0 - SLIDING_TOLERANCE) * limit)
        kn = np.where(closed, self.normal_stiffness, 0.0)
        kt = np.where(closed & ~sliding, self.tangential_stiffness, 0.0)
        return kn, kt

    def update(
        self, state: ContactState2D, d_normal: np.ndarray, d_tangential: np.ndarray,
        radius: np.ndarray,
    ) -> ContactState2D:
        """Elastic predictor, then radial return onto the Coulomb bound."""
        approach = state.normal_approach + d_normal
        normal = self.normal_force(approach, radius)
        trial = state.tangential_force + self.tangential_stiffness * np.asarray(d_tangential)
        limit = coulomb_limit(normal, self.friction_coefficient)
        tangential = np.clip(trial, -limit, limit)
        closed = normal > 0.0
        sliding = closed & (np.abs(trial) >= (1.0 - SLIDING_TOLERANCE) * limit)
        return ContactState2D(approach, normal, np.where(closed, tangential, 0.0), sliding)
