"""The skeleton of a series of samples: non-overlapping spheres in a box of walls, in which
every shape of the series is inscribed (seeds 002 and 003, §II: "the same sphere packing is
then used with each sphere serving as the circumscribing sphere").

A :class:`SphereSkeleton` holds the centres (N, 3) [m], the radii (N,) [m] and the box
[lower, upper] (3,) [m]. It is made by :func:`grainlab.prep.deposition.deposit_spheres` or
read from a file (:func:`read_skeleton`):

- ``.npz`` (NumPy): arrays ``centres`` (N, 3) and ``radii`` (N,) [m], optionally ``lower``
  and ``upper`` (3,) [m] (the box; else the spheres' extent);
- ``.csv``: a header ``x,y,z,radius`` and one row per sphere [m]; the box is the spheres'
  extent (walls touching the outermost spheres).

>>> skeleton = SphereSkeleton.around(np.array([[0.0, 0.0, 1.0]]), np.array([1.0]))
>>> skeleton.lower.tolist(), skeleton.upper.tolist()
([-1.0, -1.0, 0.0], [1.0, 1.0, 2.0])
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grainlab.errors import InputError

CSV_COLUMNS = ("x", "y", "z", "radius")
"""The header of a skeleton CSV file (metres)."""


@dataclass(frozen=True)
class SphereSkeleton:
    """Spheres ``centres`` (N, 3) [m] and ``radii`` (N,) [m] in the box [``lower``,
    ``upper``] (3,) [m] (module docstring); checked on construction (shapes, finite values,
    positive radii, every sphere inside the box to a relative 1e-9)."""

    centres: np.ndarray
    radii: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    def __post_init__(self) -> None:
        c = np.asarray(self.centres, dtype=np.float64)
        r = np.asarray(self.radii, dtype=np.float64)
        lo = np.asarray(self.lower, dtype=np.float64)
        hi = np.asarray(self.upper, dtype=np.float64)
        if c.ndim != 2 or c.shape[1] != 3 or c.shape[0] == 0 or not np.all(np.isfinite(c)):
            raise InputError("centres", f"array of shape {c.shape}",
                             "(N, 3) finite coordinates in m, N >= 1")
        if r.shape != (c.shape[0],) or not np.all(np.isfinite(r)) or np.any(r <= 0.0):
            raise InputError("radii", f"array of shape {r.shape}",
                             f"({c.shape[0]},) positive radii in m")
        if lo.shape != (3,) or hi.shape != (3,) or not np.all(np.isfinite(lo)) \
                or not np.all(np.isfinite(hi)) or np.any(hi <= lo):
            raise InputError("box", (lo.tolist(), hi.tolist()), "lower < upper, (3,) each")
        slack = 1e-9 * float(r.max())
        out = np.any(c - r[:, None] < lo - slack, axis=1) | \
            np.any(c + r[:, None] > hi + slack, axis=1)
        if np.any(out):
            k = int(np.argmax(out))
            raise InputError(f"centres[{k}]", c[k].tolist(), "a sphere inside the box")
        for name, value in (("centres", c), ("radii", r), ("lower", lo), ("upper", hi)):
            object.__setattr__(self, name, value)

    @classmethod
    def around(cls, centres: np.ndarray, radii: np.ndarray) -> SphereSkeleton:
        """The spheres in the box of their extent (walls touching the outermost)."""
        c = np.asarray(centres, dtype=np.float64)
        r = np.asarray(radii, dtype=np.float64)
        if c.ndim != 2 or c.shape[1:] != (3,) or r.shape != (c.shape[0],) or c.shape[0] == 0:
            raise InputError("centres", f"array of shape {c.shape}",
                             "(N, 3) coordinates in m with (N,) radii, N >= 1")
        return cls(c, r, np.min(c - r[:, None], axis=0), np.max(c + r[:, None], axis=0))

    @property
    def n_spheres(self) -> int:
        """Number of spheres N."""
        return int(self.radii.shape[0])

    @property
    def side(self) -> np.ndarray:
        """(3,) box sides [m]."""
        return self.upper - self.lower

    @property
    def packing_fraction(self) -> float:
        """Sphere volume over the box's volume [-]."""
        return float(np.sum(4.0 / 3.0 * np.pi * self.radii**3) / np.prod(self.side))


def write_skeleton(skeleton: SphereSkeleton, path: str | Path) -> Path:
    """Write a skeleton as ``.npz`` (with its box) or ``.csv`` (spheres only; module
    docstring), readable by :func:`read_skeleton`; the numbers round-trip exactly."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        with path.open("wb") as handle:
            np.savez(handle, centres=skeleton.centres, radii=skeleton.radii,
                     lower=skeleton.lower, upper=skeleton.upper)
        return path
    if suffix == ".csv":
        with path.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(CSV_COLUMNS)
            for (x, y, z), r in zip(skeleton.centres, skeleton.radii, strict=True):
                writer.writerow([repr(float(x)), repr(float(y)), repr(float(z)),
                                 repr(float(r))])
        return path
    raise InputError("path", str(path), "a file ending in .npz or .csv")


def read_skeleton(path: str | Path, field: str = "skeleton file") -> SphereSkeleton:
    """Read a skeleton from a ``.npz`` or ``.csv`` file (module docstring); an
    :class:`InputError` naming ``field`` when the file is missing or not of that form."""
    path = Path(path)
    if not path.is_file():
        raise InputError(field, str(path), "an existing .npz or .csv file of spheres")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {key: np.array(data[key]) for key in data.files}
        except (OSError, ValueError) as error:
            raise InputError(field, str(path), f"a NumPy .npz file ({error})") from None
        if "centres" not in arrays or "radii" not in arrays:
            raise InputError(field, str(path), "arrays 'centres' (N, 3) and 'radii' (N,) [m]")
        try:
            if "lower" in arrays and "upper" in arrays:
                return SphereSkeleton(arrays["centres"], arrays["radii"], arrays["lower"],
                                      arrays["upper"])
            return SphereSkeleton.around(arrays["centres"], arrays["radii"])
        except InputError as error:
            raise InputError(f"{field} {path.name}: {error.field}", error.value,
                             error.allowed) from None
    if suffix == ".csv":
        rows = []
        try:
            with path.open(newline="", encoding="utf-8") as handle:
                reader = csv.DictReader(handle)
                if tuple(reader.fieldnames or ()) != CSV_COLUMNS:
                    raise InputError(field, str(path), "a CSV file with the header "
                                     + ",".join(CSV_COLUMNS))
                for line, row in enumerate(reader, start=2):
                    try:
                        rows.append([float(row[key]) for key in CSV_COLUMNS])
                    except (TypeError, ValueError):
                        raise InputError(f"{field} {path.name}: line {line}",
                                         list(row.values()), "four numbers (m)") from None
        except UnicodeDecodeError:
            raise InputError(field, str(path), "a UTF-8 CSV text file") from None
        if not rows:
            raise InputError(field, str(path), "at least one sphere")
        table = np.array(rows)
        try:
            return SphereSkeleton.around(table[:, :3], table[:, 3])
        except InputError as error:
            raise InputError(f"{field} {path.name}: {error.field}", error.value,
                             error.allowed) from None
    raise InputError(field, str(path), "a file ending in .npz or .csv")
