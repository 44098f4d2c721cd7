"""The stress of a granular sample as the volume average of contact force dyads.

sigma_ij = (1/V) sum_c f_i^c l_j^c  (seed 000 eqs. 2–5 summed over both particles of each
contact; seed 002 eq. 3), with f^c the force that particle i exerts on particle j and l^c the
branch vector from i to j, so that compression is positive. In 2D, V is an area and f a force
per unit length, giving Pa.
"""

from __future__ import annotations

import numpy as np


def stress_from_contact_dyads(
    forces: np.ndarray, branches: np.ndarray, volume: float
) -> np.ndarray:
    """Full (not symmetrised) stress tensor (d, d) [Pa], compression positive.

    Parameters
    ----------
    forces:
        (m, d) contact forces exerted by the first particle on the second [N, or N/m in 2D].
    branches:
        (m, d) branch vectors from the first to the second particle centre [m].
    volume:
        Sample volume [m^3] (area [m^2] in 2D).

    The antisymmetric part is non-zero only when particles are out of moment equilibrium.

    >>> stress_from_contact_dyads(np.array([[2.0, 0.0]]), np.array([[1.0, 0.0]]), 4.0)
    array([[0.5, 0. ],
           [0. , 0. ]])
    """
    forces = np.asarray(forces, dtype=float)
    branches = np.asarray(branches, dtype=float)
    return np.einsum("ci,cj->ij", forces, branches) / volume


def principal_stresses_2d(stress: np.ndarray) -> tuple[float, float, float]:
    """Major and minor principal stresses [Pa] of the symmetric part of a 2D stress, and the
    direction of the major one as an angle from the x axis, counter-clockwise [rad] in
    (-pi/2, pi/2]."""
    s = 0.5 * (np.asarray(stress) + np.asarray(stress).T)
    centre = 0.5 * (s[0, 0] + s[1, 1])
    radius = float(np.hypot(0.5 * (s[0, 0] - s[1, 1]), s[0, 1]))
    angle = 0.5 * np.arctan2(2.0 * s[0, 1], s[0, 0] - s[1, 1])
    return centre + radius, centre - radius, float(angle)
