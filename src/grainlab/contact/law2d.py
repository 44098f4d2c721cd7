"""What a 2D incremental contact law provides to the regular-packing theory.

A law maps the history of one contact (normal approach, tangential force) and a relative
displacement increment (du_n, du_t) to new forces, and gives its tangent stiffness (seed 000
eq. 16: dt_n = c_n du_n, dt_t = c_t du_t). Arrays hold one entry per contact.

Sign conventions: the normal approach delta and the normal force f_n are positive in
compression; f_n = 0 when the contact is open (delta <= 0). The tangential force is the
component along t = n turned by +90 degrees of the force that particle i exerts on particle j.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


@dataclass(frozen=True)
class ContactState2D:
    """Forces and history of a set of contacts (arrays of shape (m,)).

    Attributes
    ----------
    normal_approach:
        delta [m], positive when the springs are compressed.
    normal_force:
        f_n [N/m], >= 0.
    tangential_force:
        f_t [N/m], |f_t| <= mu f_n.
    sliding:
        True where |f_t| has reached mu f_n.
    """

    normal_approach: np.ndarray
    normal_force: np.ndarray
    tangential_force: np.ndarray
    sliding: np.ndarray

    @property
    def open(self) -> np.ndarray:
        """True where the contact has separated (no normal force)."""
        return self.normal_force <= 0.0


class ContactLaw2D(Protocol):
    """Protocol of the contact laws the 2D theory accepts."""

    friction_angle: float

    @property
    def friction_coefficient(self) -> float:
        """mu = tan(phi_mu) [-]."""

    def normal_force(self, approach: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """Normal force [N/m] for a normal approach [m] (0 where open)."""

    def normal_approach(self, force: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`normal_force` for positive forces [m]."""

    def tangent_stiffness(
        self, normal_force: np.ndarray, tangential_force: np.ndarray, radius: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(c_n, c_t) [N/m^2] on the loading branch at the current forces."""

    def update(
        self, state: ContactState2D, d_normal: np.ndarray, d_tangential: np.ndarray,
        radius: np.ndarray,
    ) -> ContactState2D:
        """Forces after relative displacements (du_n, du_t) [m] from ``state``."""

    def describe(self) -> dict:
        """Parameters as plain data for test-result metadata."""
