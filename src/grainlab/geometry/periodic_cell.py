"""The periodic cell of a 2D regular packing: a small value object holding the lattice.

A periodic packing repeats a cell spanned by two lattice vectors a1, a2 [m]. Points are
equivalent when they differ by n1 a1 + n2 a2 with integer n1, n2 (STYLE.md 7: the cell is a value
object; displacement and wrapping are pure functions of its matrix).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainlab.errors import GeometryError, InputError


@dataclass(frozen=True, eq=False)
class PeriodicCell2D:
    """A 2D periodic cell.

    Attributes
    ----------
    lattice:
        (2, 2) array whose rows are the lattice vectors a1 and a2 [m].
    """

    lattice: np.ndarray

    def __post_init__(self) -> None:
        lattice = np.array(self.lattice, dtype=float)
        if lattice.shape != (2, 2):
            raise InputError("lattice", self.lattice, "two lattice vectors of two components")
        if not np.all(np.isfinite(lattice)):
            raise InputError("lattice", self.lattice, "finite numbers")
        scale = np.linalg.norm(lattice, axis=1)
        if np.any(scale <= 0.0):
            raise GeometryError(
                f"The cell does not tile the plane: lattice vector {np.argmin(scale) + 1} "
                "has zero length."
            )
        if abs(np.linalg.det(lattice)) <= 1e-9 * scale[0] * scale[1]:
            raise GeometryError(
                "The cell does not tile the plane: lattice vectors "
                f"a1 = {lattice[0].tolist()} and a2 = {lattice[1].tolist()} are parallel."
            )
        lattice.setflags(write=False)
        object.__setattr__(self, "lattice", lattice)

    @property
    def area(self) -> float:
        """Area of the cell [m^2] (|det| of the lattice)."""
        return float(abs(np.linalg.det(self.lattice)))

    def images_near(self, separation: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
        """Integer images n (k, 2) and their offsets n.A (k, 2) [m] that include every n with
        |separation + n.A| <= reach (a superset: callers filter by distance).

        Works for any separation, however many cells apart the two points are."""
        inverse = np.linalg.inv(self.lattice)
        fractional = np.asarray(separation, dtype=float) @ inverse
        span = reach * np.linalg.norm(inverse, axis=0)
        low = np.floor(-fractional - span).astype(int)
        high = np.ceil(-fractional + span).astype(int)
        n1, n2 = np.meshgrid(
            np.arange(low[0], high[0] + 1), np.arange(low[1], high[1] + 1), indexing="ij"
        )
        images = np.column_stack([n1.ravel(), n2.ravel()])
        return images, images @ self.lattice

    def wrap(self, points: np.ndarray) -> np.ndarray:
        """Map points (k, 2) [m] into the cell (lattice coordinates in [0, 1))."""
        fractional = np.asarray(points, dtype=float) @ np.linalg.inv(self.lattice)
        return (fractional - np.floor(fractional)) @ self.lattice

    def transformed(self, matrix: np.ndarray) -> PeriodicCell2D:
        """The cell mapped by the linear map x -> M x (rotation, mirror, scaling)."""
        return PeriodicCell2D(self.lattice @ np.asarray(matrix, dtype=float).T)
