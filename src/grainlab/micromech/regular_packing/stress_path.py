"""The stress path of seed 000's tests (Fig. 6): principal stresses rotated by alpha.

From the isotropic state sigma_0 (seed 000: 2.5 psi = 17.24 kPa) the principal stress ratio
R = sigma_1 / sigma_3 grows while the major principal direction m stays at the angle alpha from
the material Y axis, measured counter-clockwise (from +Y towards -X):
m = (-sin alpha, cos alpha). The stress is
sigma = sigma_3 I + (sigma_1 - sigma_3) m m^T, with either sigma_3 = sigma_0 held (``"sigma3"``,
default: the lateral stress of a biaxial test) or the mean stress (sigma_1 + sigma_3)/2 = sigma_0
held (``"p"``). In the (deviator, shear) plane of Fig. 6 the path is a ray at 2 alpha.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from grainlab._validate import in_range, positive
from grainlab.errors import InputError

PAPER_CONFINING_STRESS = 17.24e3
"""Initial isotropic stress of seed 000's tests [Pa] (2.5 psi)."""


@dataclass(frozen=True)
class RotatedStressPath:
    """A proportional stress path with rotated principal axes (seed 000 Fig. 6).

    Attributes
    ----------
    alpha:
        Angle of the major principal stress from the Y axis, counter-clockwise [rad], in
        [-pi/2, pi/2].
    confining_stress:
        sigma_0 of the isotropic start [Pa].
    control:
        ``"sigma3"`` (sigma_3 held at sigma_0) or ``"p"`` (mean stress held at sigma_0).
    ratio_step:
        Increment of the stress ratio R = sigma_1/sigma_3 between records [-]; halved near
        failure as needed.
    max_ratio:
        Stress ratio at which the test stops if the packing has not failed [-].

    >>> path = RotatedStressPath(alpha=0.0, confining_stress=1e4)
    >>> path.stress(2.0).tolist()  # sigma_1 = 2 sigma_3 along Y
    [10000.0, 20000.0, 0.0]
    """

    alpha: float = 0.0
    confining_stress: float = PAPER_CONFINING_STRESS
    control: Literal["sigma3", "p"] = "sigma3"
    ratio_step: float = 0.05
    max_ratio: float = 10.0

    def __post_init__(self) -> None:
        in_range("alpha", self.alpha, -np.pi / 2, np.pi / 2, "rad", closed="[]")
        positive("confining_stress", self.confining_stress, "Pa")
        if self.control not in ("sigma3", "p"):
            raise InputError("control", self.control, "'sigma3' or 'p'")
        in_range("ratio_step", self.ratio_step, 0.0, 10.0)
        in_range("max_ratio", self.max_ratio, 1.0, 1e6, closed="(]")

    @property
    def direction(self) -> np.ndarray:
        """Unit vector m of the major principal stress."""
        return np.array([-np.sin(self.alpha), np.cos(self.alpha)])

    def principal_stresses(self, ratio: float) -> tuple[float, float]:
        """(sigma_1, sigma_3) [Pa] at stress ratio R."""
        if self.control == "sigma3":
            minor = self.confining_stress
        else:
            minor = 2.0 * self.confining_stress / (1.0 + ratio)
        return ratio * minor, minor

    def stress(self, ratio: float) -> np.ndarray:
        """Voigt stress [sigma_xx, sigma_yy, sigma_xy] [Pa] at stress ratio R."""
        major, minor = self.principal_stresses(ratio)
        m = self.direction
        tensor = minor * np.eye(2) + (major - minor) * np.outer(m, m)
        return np.array([tensor[0, 0], tensor[1, 1], tensor[0, 1]])

    def describe(self) -> dict:
        """The path as plain data (angles in degrees) for test-result metadata."""
        return {
            "name": "rotated principal stress path (seed 000 Fig. 6)",
            "alpha_deg": float(np.degrees(self.alpha)),
            "confining_stress_Pa": self.confining_stress,
            "control": self.control,
            "ratio_step": self.ratio_step,
            "max_ratio": self.max_ratio,
        }
