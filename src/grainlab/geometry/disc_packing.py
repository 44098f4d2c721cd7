"""A periodic packing of discs (cylinders seen end-on): the specimen of seed 000.

The packing is the periodic cell, the disc centres and radii, and optional names. It knows its
solid area and void ratio; contacts, the power tessellation and the theory live elsewhere and
take a packing as input.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from grainlab.errors import InputError
from grainlab.geometry.periodic_cell import PeriodicCell2D
from grainlab.geometry.rotation import rotation_matrix_2d


@dataclass(frozen=True, eq=False)
class DiscPacking2D:
    """A 2D periodic packing of discs.

    Attributes
    ----------
    cell:
        The periodic cell (lattice vectors in m).
    centres:
        (N, 2) disc centres [m]; they need not lie inside the cell.
    radii:
        (N,) disc radii [m], positive.
    name:
        A label for reports.
    labels:
        N particle names used in messages and figures (default ``"p0"``, ``"p1"``, ...).

    >>> packing = DiscPacking2D(PeriodicCell2D([[2.0, 0.0], [0.0, 2.0]]), [[0.0, 0.0]], [1.0])
    >>> round(packing.void_ratio, 4)  # square packing, e = 4/pi - 1
    0.2732
    """

    cell: PeriodicCell2D
    centres: np.ndarray
    radii: np.ndarray
    name: str = "user packing"
    labels: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        if not isinstance(self.cell, PeriodicCell2D):
            object.__setattr__(self, "cell", PeriodicCell2D(self.cell))
        centres = np.array(self.centres, dtype=float)
        radii = np.array(self.radii, dtype=float).reshape(-1)
        if centres.ndim != 2 or centres.shape[1] != 2 or centres.shape[0] == 0:
            raise InputError("centres", self.centres, "a non-empty list of (x, y) pairs in metres")
        if radii.shape[0] != centres.shape[0]:
            raise InputError(
                "radii", self.radii, f"one radius per centre ({centres.shape[0]} values)"
            )
        for k, value in enumerate(centres):
            if not np.all(np.isfinite(value)):
                raise InputError(f"centres[{k}]", value.tolist(), "finite coordinates in metres")
        for k, value in enumerate(radii):
            if not (np.isfinite(value) and value > 0.0):
                raise InputError(f"radii[{k}]", float(value), "a positive radius in metres")
        labels = tuple(self.labels) or tuple(f"p{k}" for k in range(len(radii)))
        if len(labels) != len(radii):
            raise InputError("labels", self.labels, f"one name per particle ({len(radii)})")
        if len(set(labels)) != len(labels):
            raise InputError("labels", self.labels, "distinct particle names")
        centres.setflags(write=False)
        radii.setflags(write=False)
        object.__setattr__(self, "centres", centres)
        object.__setattr__(self, "radii", radii)
        object.__setattr__(self, "labels", labels)

    @property
    def n_particles(self) -> int:
        """Number of discs in the cell."""
        return int(self.radii.shape[0])

    @property
    def solid_area(self) -> float:
        """Area of the discs in the cell [m^2] (solid 'volume' per unit thickness)."""
        return float(np.pi * np.sum(self.radii**2))

    @property
    def void_ratio(self) -> float:
        """Void ratio e = (cell area - solid area) / solid area [-] (seed 000 eq. 4)."""
        return self.cell.area / self.solid_area - 1.0

    @property
    def solid_fraction(self) -> float:
        """Solid (packing) fraction = solid area / cell area [-]."""
        return self.solid_area / self.cell.area

    def transformed(self, matrix: np.ndarray, name: str | None = None) -> DiscPacking2D:
        """The packing mapped by an orthogonal map x -> M x (a rotation or a mirror)."""
        matrix = np.asarray(matrix, dtype=float)
        if not np.allclose(matrix @ matrix.T, np.eye(2), atol=1e-12):
            raise InputError("matrix", matrix.tolist(), "an orthogonal 2x2 matrix")
        return DiscPacking2D(
            self.cell.transformed(matrix),
            self.centres @ matrix.T,
            self.radii,
            name or self.name,
            self.labels,
        )

    def rotated(self, angle: float) -> DiscPacking2D:
        """The packing rotated counter-clockwise by ``angle`` [rad] about the origin."""
        return self.transformed(rotation_matrix_2d(angle))

    def translated(self, shift: np.ndarray) -> DiscPacking2D:
        """The packing with every centre moved by ``shift`` [m]."""
        return DiscPacking2D(
            self.cell, self.centres + np.asarray(shift, dtype=float), self.radii, self.name,
            self.labels,
        )

    def permuted(self, order: np.ndarray) -> DiscPacking2D:
        """The same packing with its particles listed in ``order`` (a relabelling)."""
        order = np.asarray(order, dtype=int)
        if sorted(order.tolist()) != list(range(self.n_particles)):
            raise InputError("order", order.tolist(), f"a permutation of 0..{self.n_particles - 1}")
        return DiscPacking2D(
            self.cell, self.centres[order], self.radii[order], self.name,
            tuple(self.labels[k] for k in order),
        )

    def scaled(self, factor: float) -> DiscPacking2D:
        """The packing with every length multiplied by ``factor`` (> 0)."""
        if not factor > 0:
            raise InputError("factor", factor, "a positive scale factor")
        return DiscPacking2D(
            PeriodicCell2D(self.cell.lattice * factor), self.centres * factor,
            self.radii * factor, self.name, self.labels,
        )
