"""The periodic, deformable, triclinic cell of the 3D discrete engine: a small value object
holding the matrix h whose columns are the cell vectors (STYLE.md 7).

The cell is the parallelepiped spanned by the columns c1, c2, c3 [m] of h (right-handed,
det h > 0), with one corner at the origin. The medium repeats it: a point x and x + h n,
n in Z^3, are the same material point in different images. With s = h^-1 x the fractional
coordinates::

    wrap counts   w = floor(s)                  (integers, per axis)
    wrapped       x~ = x - h w                  (fractional coordinates in [0, 1))
    volume        V = det h                     [m^3]
    widths        w_a = V / |c_b x c_c|         [m]  (distance between the two faces
                                                      spanned by c_b, c_c; (a, b, c) cyclic)

A fractional coordinate of a displacement d is (h^-1 d)_a, and row a of h^-1 has length
1 / w_a, so |d| <= r moves a fractional coordinate by at most r / w_a (used to size the
ghost layer of :mod:`grainlab.engine.detect.periodic_detection`).

Re-map of a sheared cell (:meth:`TriclinicCell.reduced`): the lattice {h n} does not change
when h is replaced by h M with an integer M of determinant 1, so a cell sheared far (the
columns nearly parallel, the widths small) describes the same periodic medium as a less
skewed one. Particles do not move; only which image is called "the" cell changes, and image
vectors n of the old cell become M^-1 n in the new one.

The 2D :class:`~grainlab.geometry.periodic_cell.PeriodicCell2D` (disc packings of the
micromechanics, ROWS as lattice vectors) is a separate, older object; this 3D cell, with
COLUMNS as cell vectors, is the discrete engine's.

>>> import numpy as np
>>> cell = TriclinicCell(np.array([[1.0, 0.8, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
>>> reduced, m = cell.reduced()
>>> reduced.matrix[:, 1].tolist(), m[:, 1].tolist()
([-0.19999999999999996, 1.0, 0.0], [-1, 1, 0])
>>> cell.wrap_counts(np.array([[1.5, -0.5, 2.0]])).tolist()  # s = (1.9, -0.5, 2.0)
[[1, -1, 2]]
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from grainlab.errors import GrainlabError, InputError

MAX_REDUCTION_SWEEPS = 10_000
"""Most sweeps over the six ordered column pairs in :meth:`TriclinicCell.reduced` (each
change shortens a column, so a finite number always suffices; the cap only stops a cycle
that round-off could cause in a degenerate cell)."""


@dataclass(frozen=True, eq=False)
class TriclinicCell:
    """A periodic parallelepiped (module docstring).

    Attributes
    ----------
    matrix:
        h, shape (3, 3) [m]: COLUMNS are the cell vectors c1, c2, c3; finite, det h > 0
        (right-handed). Stored read-only.
    """

    matrix: np.ndarray
    _inverse: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        try:
            h = np.array(self.matrix, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError("cell matrix", self.matrix,
                             "a (3, 3) array of finite numbers in m, columns the cell "
                             "vectors") from None
        if h.shape != (3, 3) or not np.isfinite(h).all():
            raise InputError("cell matrix", h.tolist() if h.ndim else h,
                             "a (3, 3) array of finite numbers in m, columns the cell vectors")
        det = float(np.linalg.det(h))
        if not det > 0.0:
            raise InputError("cell matrix", h.tolist(),
                             f"right-handed cell vectors (columns) with det h > 0, got "
                             f"det h = {det:g} m^3")
        h.setflags(write=False)
        inverse = np.linalg.inv(h)
        inverse.setflags(write=False)
        object.__setattr__(self, "matrix", h)
        object.__setattr__(self, "_inverse", inverse)

    @classmethod
    def cube(cls, side: float) -> TriclinicCell:
        """The cube [0, side]^3 [m]."""
        return cls(np.eye(3) * float(side))

    @property
    def inverse(self) -> np.ndarray:
        """h^-1, shape (3, 3) [1/m] (read-only)."""
        return self._inverse

    @property
    def volume(self) -> float:
        """V = det h [m^3]."""
        return float(np.linalg.det(self.matrix))

    @property
    def widths(self) -> np.ndarray:
        """Perpendicular distances between opposite faces, (3,) [m]: w_a = 1 / |row a of
        h^-1| = V / |c_b x c_c|."""
        return 1.0 / np.linalg.norm(self._inverse, axis=1)

    def fractional(self, x) -> np.ndarray:
        """Fractional coordinates s = h^-1 x of points ``x`` (..., 3) [m] (same shape)."""
        return np.asarray(x, dtype=np.float64) @ self._inverse.T

    def wrap_counts(self, x) -> np.ndarray:
        """w = floor(h^-1 x), int64 (..., 3): the image of the cell each point lies in."""
        return np.floor(self.fractional(x)).astype(np.int64)

    def wrapped(self, x) -> np.ndarray:
        """x - h floor(h^-1 x) (..., 3) [m]: the points moved by lattice vectors into the cell
        (fractional coordinates in [0, 1), up to round-off at the upper faces)."""
        x = np.asarray(x, dtype=np.float64)
        return x - self.wrap_counts(x) @ self.matrix.T

    def reduced(self, max_skew: float = 0.5) -> tuple[TriclinicCell, np.ndarray]:
        """A less skewed cell of the same lattice: (cell h' = h M, M).

        Re-map of a sheared cell (module docstring): the same periodic medium described by a
        less skewed cell; particles do not move. Repeatedly, for every ordered pair of columns
        (a, b), a != b, with |c_b . c_a| > ``max_skew`` |c_a|^2, c_b is replaced by
        c_b - k c_a, k = round(c_b . c_a / |c_a|^2) (the same column operation on M), until
        nothing changes. Each replacement shortens c_b, so it ends; M is integer with
        det M = 1, h' spans the same lattice and has the same volume, and every
        |c'_b . c'_a| <= ``max_skew`` |c'_a|^2.

        ``max_skew`` >= 0.5 (below 0.5 a column can flip back and forth for ever).
        """
        try:
            skew = float(max_skew)
        except (TypeError, ValueError):
            skew = math.nan
        if not (math.isfinite(skew) and skew >= 0.5):
            raise InputError("max_skew", max_skew, "a finite number >= 0.5")
        h = self.matrix.copy()
        m = np.eye(3, dtype=np.int64)
        for _ in range(MAX_REDUCTION_SWEEPS):
            changed = False
            for a in range(3):
                for b in range(3):
                    if a == b:
                        continue
                    norm2 = float(h[:, a] @ h[:, a])
                    dot = float(h[:, b] @ h[:, a])
                    if abs(dot) > skew * norm2:
                        k = round(dot / norm2)
                        h[:, b] -= k * h[:, a]
                        m[:, b] -= k * m[:, a]
                        changed = True
            if not changed:
                return TriclinicCell(h), m
        raise GrainlabError(
            f"TriclinicCell.reduced did not settle in {MAX_REDUCTION_SWEEPS} sweeps "
            f"(cell matrix {self.matrix.tolist()}): the cell is degenerate at round-off."
        )

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays that restore the cell with :meth:`from_arrays` (checkpoints)."""
        return {"cell_matrix": self.matrix.copy()}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> TriclinicCell:
        """Inverse of :meth:`to_arrays`."""
        return cls(np.asarray(arrays["cell_matrix"], dtype=np.float64))
