"""An isotropic linear-elastic specimen for the lab tests: the tangent D is exact, so every
preset has a closed-form answer."""

from __future__ import annotations

import numpy as np

E, NU = 8.0e7, 0.25
"""Young's modulus [Pa] and Poisson ratio [-] of the test material."""
LAMBDA = E * NU / ((1 + NU) * (1 - 2 * NU))
G = E / (2 * (1 + NU))
K = LAMBDA + 2 * G / 3


def isotropic_stiffness(dimension: int) -> np.ndarray:
    """Voigt stiffness [Pa] of isotropic elasticity (2D: plane strain), engineering shears."""
    n = 6 if dimension == 3 else 3
    m = np.zeros(n)
    m[:dimension] = 1.0
    return LAMBDA * np.outer(m, m) + G * np.diag(
        np.r_[2.0 * np.ones(dimension), np.ones(n - dimension)])


class ElasticSpecimen:
    """Isotropic linear elasticity (3D, or 2D plane strain) from an initial stress."""

    def __init__(self, dimension: int = 3, initial_stress=None):
        self.dimension = dimension
        n = 6 if dimension == 3 else 3
        self.D = isotropic_stiffness(dimension)
        self.eps = np.zeros(n)
        self.s0 = np.zeros(n) if initial_stress is None else np.asarray(initial_stress, float)

    def stress(self):
        return self.s0 + self.D @ self.eps

    def strain(self):
        return self.eps.copy()

    def tangent(self):
        return self.D.copy()

    def apply_strain(self, increment):
        self.eps = self.eps + increment

    def descriptors(self):
        return {}

    def describe(self):
        return {"kind": "isotropic linear elastic", "E": E, "nu": NU}
