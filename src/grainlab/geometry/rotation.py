"""Rotations in the plane (and later in space)."""

from __future__ import annotations

import numpy as np


def rotation_matrix_2d(angle: float) -> np.ndarray:
    """Counter-clockwise rotation by ``angle`` [rad] as a (2, 2) matrix R, so that x' = R x.

    >>> np.allclose(rotation_matrix_2d(np.pi / 2) @ [1.0, 0.0], [0.0, 1.0])
    True
    """
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])
