"""What a specimen offers to the laboratory's element-test driver.

An element test controls, in a (possibly rotating) frame, each component of the stress or the
strain (6 in 3D, 3 in 2D). Any specimen that can report its stress and a tangent stiffness and
can be strained by an increment can be driven: a micromechanical model now, a discrete sample
later.

Voigt conventions (compression positive, SI units):

* 3D: stress [s_xx, s_yy, s_zz, s_yz, s_xz, s_xy] [Pa], strain
  [e_xx, e_yy, e_zz, g_yz, g_xz, g_xy] with engineering shears g = 2 e [-];
* 2D: stress [s_xx, s_yy, s_xy], strain [e_xx, e_yy, g_xy].
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

VOIGT_3D = ("xx", "yy", "zz", "yz", "xz", "xy")
VOIGT_2D = ("xx", "yy", "xy")


def voigt_labels(dimension: int) -> tuple[str, ...]:
    """Component names in Voigt order for 2D or 3D."""
    return VOIGT_3D if dimension == 3 else VOIGT_2D


def voigt_to_tensor(values: np.ndarray, engineering_shear: bool) -> np.ndarray:
    """Symmetric (d, d) tensor from a Voigt vector (shears halved when engineering)."""
    v = np.asarray(values, dtype=float)
    factor = 0.5 if engineering_shear else 1.0
    if v.shape == (3,):
        return np.array([[v[0], factor * v[2]], [factor * v[2], v[1]]])
    if v.shape == (6,):
        return np.array([
            [v[0], factor * v[5], factor * v[4]],
            [factor * v[5], v[1], factor * v[3]],
            [factor * v[4], factor * v[3], v[2]],
        ])
    raise ValueError(f"a Voigt vector has 3 or 6 components, not {v.shape}")


def tensor_to_voigt(tensor: np.ndarray, engineering_shear: bool) -> np.ndarray:
    """Voigt vector of the symmetric part of a (d, d) tensor (shears doubled when
    engineering)."""
    t = 0.5 * (np.asarray(tensor, dtype=float) + np.asarray(tensor, dtype=float).T)
    factor = 2.0 if engineering_shear else 1.0
    if t.shape == (2, 2):
        return np.array([t[0, 0], t[1, 1], factor * t[0, 1]])
    return np.array([t[0, 0], t[1, 1], t[2, 2], factor * t[1, 2], factor * t[0, 2],
                     factor * t[0, 1]])


class ElementSpecimen(Protocol):
    """A specimen the element-test driver can load."""

    @property
    def dimension(self) -> int:
        """2 or 3."""

    def stress(self) -> np.ndarray:
        """Current Voigt stress [Pa], compression positive."""

    def strain(self) -> np.ndarray:
        """Cumulative Voigt strain since the start of the test [-]."""

    def tangent(self) -> np.ndarray:
        """Voigt tangent stiffness D [Pa] (dsigma ~ D deps for the next small increment)."""

    def apply_strain(self, strain_increment: np.ndarray) -> None:
        """Advance the specimen by a Voigt strain increment; the stress reached may differ
        from stress + D increment (sliding, separation), the driver corrects it."""

    def descriptors(self) -> dict[str, Any]:
        """Scalar descriptors of the current state for the results table (may be empty)."""

    def describe(self) -> dict[str, Any]:
        """The specimen as plain data for test-result metadata."""
