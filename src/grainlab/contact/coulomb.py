"""Coulomb friction at a contact: |f_t| <= mu f_n, sliding when the bound is reached."""

from __future__ import annotations

import numpy as np

SLIDING_TOLERANCE = 1e-9
"""A contact slides when |f_t| >= (1 - tol) mu f_n."""


def coulomb_limit(normal_force: np.ndarray, friction_coefficient: float) -> np.ndarray:
    """Largest tangential force the contact can carry, mu max(f_n, 0) [N or N/m]."""
    return friction_coefficient * np.maximum(np.asarray(normal_force, dtype=float), 0.0)


def friction_mobilisation(
    normal_force: np.ndarray, tangential_force: np.ndarray, friction_coefficient: float
) -> np.ndarray:
    """Mobilised friction |f_t| / (mu f_n) in [0, 1]; 0 where the contact carries no load."""
    limit = coulomb_limit(normal_force, friction_coefficient)
    tangential = np.abs(np.asarray(tangential_force, dtype=float))
    return np.divide(tangential, limit, out=np.zeros_like(tangential), where=limit > 0.0)


def is_sliding(
    normal_force: np.ndarray, tangential_force: np.ndarray, friction_coefficient: float
) -> np.ndarray:
    """Boolean mask of contacts on the Coulomb bound (within :data:`SLIDING_TOLERANCE`)."""
    limit = coulomb_limit(normal_force, friction_coefficient)
    return (limit > 0.0) & (np.abs(tangential_force) >= (1.0 - SLIDING_TOLERANCE) * limit)
