"""Periodic disc packings read from and written to files (TOML or CSV).

TOML::

    name = "my packing"
    lattice = [[0.0127, 0.0], [0.0, 0.0127]]   # lattice vectors a1, a2 [m]
    [[particles]]
    x = 0.0          # centre [m]
    y = 0.0
    radius = 0.00635 # [m]
    label = "big"    # optional

CSV (one row per lattice vector and per disc; ``label`` optional)::

    kind,x,y,radius,label
    lattice,0.0127,0.0,,
    lattice,0.0,0.0127,,
    particle,0.0,0.0,0.00635,big
"""

from __future__ import annotations

import csv
import json
import tomllib
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from grainlab.errors import InputError
from grainlab.geometry.disc_packing import DiscPacking2D
from grainlab.geometry.periodic_cell import PeriodicCell2D


class _ParticleRecord(BaseModel):
    model_config = ConfigDict(extra="forbid")
    x: float
    y: float
    radius: float = Field(gt=0.0)
    label: str | None = None


class _PackingRecord(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = "user packing"
    lattice: tuple[tuple[float, float], tuple[float, float]]
    particles: list[_ParticleRecord] = Field(min_length=1)


def _from_record(record: _PackingRecord) -> DiscPacking2D:
    labels = [p.label or f"p{k}" for k, p in enumerate(record.particles)]
    return DiscPacking2D(
        PeriodicCell2D(record.lattice),
        [[p.x, p.y] for p in record.particles],
        [p.radius for p in record.particles],
        record.name,
        tuple(labels),
    )


def _raise_validation(path: Path, error: ValidationError) -> None:
    first = error.errors()[0]
    field = ".".join(str(part) for part in first["loc"])
    raise InputError(f"{path.name}: {field}", first.get("input"), first["msg"].lower()) from None


def read_packing(path: str | Path) -> DiscPacking2D:
    """Read a periodic disc packing from a ``.toml`` or ``.csv`` file (format above)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("packing file", str(path), "an existing .toml or .csv file")
    suffix = path.suffix.lower()
    try:
        if suffix == ".toml":
            with path.open("rb") as handle:
                try:
                    data = tomllib.load(handle)
                except tomllib.TOMLDecodeError as error:
                    raise InputError("packing file", str(path), f"valid TOML ({error})") from None
            data.setdefault("name", path.stem)
            return _from_record(_PackingRecord.model_validate(data))
        if suffix == ".csv":
            lattice, particles = [], []
            with path.open(newline="", encoding="utf-8") as handle:
                for line, row in enumerate(csv.DictReader(handle), start=2):
                    kind = (row.get("kind") or "").strip().lower()
                    if kind == "lattice":
                        lattice.append((row["x"], row["y"]))
                    elif kind == "particle":
                        entry = {k: row[k] for k in ("x", "y", "radius")}
                        if row.get("label"):
                            entry["label"] = row["label"]
                        particles.append(entry)
                    else:
                        raise InputError(f"{path.name}: line {line}: kind", row.get("kind"),
                                         "'lattice' or 'particle'")
            return _from_record(_PackingRecord.model_validate(
                {"name": path.stem, "lattice": lattice, "particles": particles}
            ))
    except ValidationError as error:
        _raise_validation(path, error)
    except UnicodeDecodeError:
        raise InputError("packing file", str(path), f"a {suffix[1:].upper()} text file (this "
                                                    "one is not UTF-8 text)") from None
    raise InputError("packing file", str(path), "a file ending in .toml or .csv")


def write_packing(packing: DiscPacking2D, path: str | Path) -> Path:
    """Write a packing as TOML or CSV (by extension), readable by :func:`read_packing`."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".toml":
        lines = [f"name = {json.dumps(packing.name)}",
                 f"lattice = {[list(map(float, v)) for v in packing.cell.lattice]}", ""]
        for (x, y), r, label in zip(packing.centres, packing.radii, packing.labels, strict=True):
            lines += ["[[particles]]", f"x = {float(x)!r}", f"y = {float(y)!r}",
                      f"radius = {float(r)!r}", f"label = {json.dumps(label)}", ""]
        path.write_text("\n".join(lines), encoding="utf-8")
        return path
    if suffix == ".csv":
        with path.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(["kind", "x", "y", "radius", "label"])
            for vector in packing.cell.lattice:
                writer.writerow(["lattice", repr(float(vector[0])), repr(float(vector[1])), "", ""])
            rows = zip(packing.centres, packing.radii, packing.labels, strict=True)
            for (x, y), r, label in rows:
                writer.writerow(["particle", repr(float(x)), repr(float(y)), repr(float(r)), label])
        return path
    raise InputError("path", str(path), "a file ending in .toml or .csv")
