"""The test result: one format for every lab test on every kind of specimen.

A :class:`TestResult` holds

* ``metadata`` — plain JSON-able data: the specimen, the load path, the parameters, the outcome
  (e.g. failure), the versions of the software, the time of creation, the sign convention and
  the unit of every column;
* ``table`` — a :class:`pandas.DataFrame`, one row per recorded increment, with stress, strain
  and any descriptor as columns (names in :mod:`grainlab.result.columns`);
* ``snapshots`` — named numpy arrays whose first axis runs over the recorded increments (contact
  forces, stiffness matrices, ...).

Files: HDF5 keeps all three; CSV keeps metadata (a JSON header line) and the table. Both read
back losslessly (floats written with 17 significant digits, dtypes restored).

Format versions: 2 gives every column one meaning (:mod:`grainlab.result.columns`). In version
1, discrete runs wrote ``q`` = (sigma_1 - sigma_3)/3, ``q_over_p`` = that q over p and ``eps_p``
for the volumetric strain; such tables (recognised by ``eps_p``) are upgraded on reading to
``q`` = sigma_1 - sigma_3, ``q_over_3``, ``q_over_trace`` and ``eps_vol``. Other version-1
tables read unchanged (their ``q`` was already sigma_1 - sigma_3).
"""

from __future__ import annotations

import json
import platform
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd

from grainlab._version import __version__
from grainlab.errors import InputError
from grainlab.result.columns import unit_of

FORMAT_NAME = "grainlab.test_result"
FORMAT_VERSION = 2
CSV_HEADER_PREFIX = "# grainlab-test-result "


TEXT_DTYPES = ("object", "str", "string")
"""Column dtypes stored as text (pandas 2 uses ``object``, pandas 3 ``str``)."""


def software_versions() -> dict[str, str]:
    """Versions of grainlab and of the libraries that shape its numbers."""
    import scipy

    return {
        "grainlab": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "pandas": pd.__version__,
    }


def _jsonable(value: Any) -> Any:
    """Convert numpy scalars/arrays inside nested metadata into plain Python."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


@dataclass(eq=False)
class TestResult:
    """The outcome of one lab test on one specimen.

    Build one with :meth:`create`; write it with :meth:`save`, :meth:`to_csv` or
    :meth:`to_hdf5`; read it with :func:`read_test_result`.

    >>> import pandas as pd
    >>> r = TestResult.create(pd.DataFrame({"eps_yy": [0.0, 1e-3], "sigma_yy": [1e4, 2e4]}),
    ...                       specimen={"kind": "example"}, load_path={"name": "demo"})
    >>> r.units["sigma_yy"]
    'Pa'
    """

    __test__ = False  # not a pytest test class, despite the name

    table: pd.DataFrame
    metadata: dict[str, Any]
    snapshots: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def create(
        cls,
        table: pd.DataFrame,
        *,
        specimen: dict[str, Any],
        load_path: dict[str, Any],
        parameters: dict[str, Any] | None = None,
        outcome: dict[str, Any] | None = None,
        units: dict[str, str] | None = None,
        snapshots: dict[str, np.ndarray] | None = None,
        snapshot_units: dict[str, str] | None = None,
        dimension: int = 2,
        title: str = "",
    ) -> TestResult:
        """Assemble a result and stamp it with versions, time and units.

        Units default to those of :mod:`grainlab.result.columns`; ``units`` overrides or adds.
        """
        if dimension not in (2, 3):
            raise InputError("dimension", dimension, "2 or 3")
        snapshots = {k: np.asarray(v) for k, v in (snapshots or {}).items()}
        for name, array in snapshots.items():
            if array.ndim == 0 or array.shape[0] != len(table):
                raise InputError(
                    f"snapshots[{name!r}]", array.shape,
                    f"an array whose first axis has one entry per table row ({len(table)})",
                )
        column_units = {c: unit_of(str(c)) for c in table.columns}
        column_units.update(units or {})
        metadata = {
            "format": FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "title": title,
            "dimension": dimension,
            "sign_convention": "compression positive (stresses and strains)",
            "specimen": specimen,
            "load_path": load_path,
            "parameters": parameters or {},
            "outcome": outcome or {},
            "units": column_units,
            "snapshot_units": snapshot_units or {},
            "versions": software_versions(),
            "created": datetime.now(UTC).isoformat(timespec="seconds"),
        }
        return cls(table.reset_index(drop=True), _jsonable(metadata), snapshots)

    # -- conveniences -------------------------------------------------------------------------
    @property
    def units(self) -> dict[str, str]:
        """Unit of every table column."""
        return self.metadata.get("units", {})

    @property
    def specimen(self) -> dict[str, Any]:
        """Description of the specimen (kind, name, geometry, contact law...)."""
        return self.metadata.get("specimen", {})

    @property
    def load_path(self) -> dict[str, Any]:
        """Description of the load path."""
        return self.metadata.get("load_path", {})

    @property
    def outcome(self) -> dict[str, Any]:
        """How the test ended (completed, failure and why, ...)."""
        return self.metadata.get("outcome", {})

    def summary(self) -> str:
        """What the result is, in a few lines: title, specimen, load path, outcome, table
        size (what ``print(result)`` and a notebook show above the table)."""
        specimen = self.specimen
        outcome = self.outcome
        lines = [self.metadata.get("title") or "test result",
                 f"specimen: {specimen.get('kind', '?')}"
                 + (f" ({specimen['name']})" if specimen.get("name") else ""),
                 f"load path: {self.load_path.get('name', '?')}",
                 f"outcome: {outcome.get('status', '?')}"
                 + (f" ({outcome['reason']})" if outcome.get("reason") else ""),
                 f"table: {len(self.table)} rows x {len(self.table.columns)} columns"
                 + (f", snapshots: {', '.join(self.snapshots)}" if self.snapshots else "")]
        return "\n".join(lines)

    def __repr__(self) -> str:
        """One line: title, specimen kind, path, outcome, table size (not the whole table)."""
        return (f"<TestResult {self.metadata.get('title') or ''!r}: "
                f"{self.specimen.get('kind', '?')}, {self.load_path.get('name', '?')}, "
                f"{self.outcome.get('status', '?')}, {len(self.table)} rows x "
                f"{len(self.table.columns)} columns>")

    def __str__(self) -> str:
        return self.summary()

    def _repr_html_(self) -> str:
        """A notebook's view: the summary, then the table as pandas shows it (truncated)."""
        import html

        head, *rest = self.summary().split("\n")
        items = "".join(f"<li>{html.escape(line)}</li>" for line in rest)
        return (f"<p><b>{html.escape(head)}</b></p><ul>{items}</ul>"
                + self.table._repr_html_())

    def column(self, name: str) -> np.ndarray:
        """One table column as a numpy array; a clear error names the available ones."""
        if name not in self.table.columns:
            raise InputError("column", name, f"one of {', '.join(map(str, self.table.columns))}")
        return self.table[name].to_numpy()

    def equals(self, other: TestResult) -> bool:
        """True when metadata, table (values and dtypes) and snapshots are identical."""
        if self.metadata != other.metadata or set(self.snapshots) != set(other.snapshots):
            return False
        try:
            pd.testing.assert_frame_equal(self.table, other.table, check_exact=True)
        except AssertionError:
            return False
        return all(
            self.snapshots[k].dtype == other.snapshots[k].dtype
            and np.array_equal(self.snapshots[k], other.snapshots[k], equal_nan=True)
            for k in self.snapshots
        )

    # -- files --------------------------------------------------------------------------------
    def _metadata_with_dtypes(self) -> dict[str, Any]:
        meta = dict(self.metadata)
        meta["columns"] = [str(c) for c in self.table.columns]
        meta["dtypes"] = {str(c): str(t) for c, t in self.table.dtypes.items()}
        return meta

    def to_csv(self, path: str | Path) -> Path:
        """Write metadata (one JSON header line) and the table; snapshots are not kept."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", encoding="utf-8", newline="") as handle:
            handle.write(CSV_HEADER_PREFIX + json.dumps(self._metadata_with_dtypes()) + "\n")
            self.table.to_csv(handle, index=False, float_format="%.17g")
        return path

    def to_hdf5(self, path: str | Path) -> Path:
        """Write metadata, table and snapshots to one HDF5 file."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with h5py.File(path, "w") as f:
            f.attrs["format"] = FORMAT_NAME
            f.attrs["format_version"] = FORMAT_VERSION
            f.attrs["metadata"] = json.dumps(self._metadata_with_dtypes())
            table = f.create_group("table")
            for name in self.table.columns:
                values = self.table[name].to_numpy()
                if str(self.table[name].dtype) in TEXT_DTYPES or values.dtype.kind in "OUT":
                    values = np.array([str(v) for v in values], dtype=h5py.string_dtype())
                table.create_dataset(str(name), data=values)
            snaps = f.create_group("snapshots")
            for name, array in self.snapshots.items():
                snaps.create_dataset(name, data=array, compression="gzip")
        return path

    def save(self, folder: str | Path, stem: str = "result") -> tuple[Path, Path]:
        """Write ``stem.csv`` and ``stem.h5`` into ``folder``; return both paths."""
        folder = Path(folder)
        return self.to_csv(folder / f"{stem}.csv"), self.to_hdf5(folder / f"{stem}.h5")


def _restore_dtypes(table: pd.DataFrame, dtypes: dict[str, str]) -> pd.DataFrame:
    for name, dtype in dtypes.items():
        table[name] = table[name].astype(dtype)
    return table


def _split_metadata(meta: dict[str, Any]) -> tuple[dict[str, Any], list[str], dict[str, str]]:
    meta = dict(meta)
    columns = meta.pop("columns")
    dtypes = meta.pop("dtypes")
    if meta.get("format") != FORMAT_NAME:
        raise InputError("format", meta.get("format"), f"a {FORMAT_NAME} file")
    if meta.get("format_version", 0) > FORMAT_VERSION:
        raise InputError(
            "format_version", meta.get("format_version"),
            f"at most {FORMAT_VERSION} (upgrade grainlab to read this file)",
        )
    return meta, columns, dtypes


def _upgrade(table: pd.DataFrame, meta: dict[str, Any]) -> pd.DataFrame:
    """Version-1 discrete-run columns renamed to their version-2 names (module docstring)."""
    if meta.get("format_version", FORMAT_VERSION) >= 2 or "eps_p" not in table.columns:
        return table
    units = dict(meta.get("units", {}))
    renames = {"eps_p": "eps_vol", "q": "q_over_3", "q_over_p": "q_over_trace"}
    table = table.rename(columns=renames)
    for old, new in renames.items():
        if old in units:
            units[new] = units.pop(old)
    if "q_over_3" in table.columns:
        table.insert(table.columns.get_loc("q_over_3"), "q", 3.0 * table["q_over_3"])
        units["q"] = "Pa"
    meta["units"] = units
    meta["upgraded_from_format_version"] = meta.get("format_version")
    meta["format_version"] = FORMAT_VERSION
    return table


def read_test_result(path: str | Path) -> TestResult:
    """Read a test result written by :meth:`TestResult.to_csv` or :meth:`TestResult.to_hdf5`.

    The kind is chosen by the file extension (``.csv``; ``.h5``/``.hdf5``).
    """
    path = Path(path)
    if not path.exists():
        raise InputError("path", str(path), "an existing test-result file (.csv or .h5)")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        with path.open(encoding="utf-8") as handle:
            header = handle.readline()
            if not header.startswith(CSV_HEADER_PREFIX):
                raise InputError("path", str(path), "a CSV written by grainlab (header missing)")
            meta, columns, dtypes = _split_metadata(json.loads(header[len(CSV_HEADER_PREFIX):]))
            text = [c for c, t in dtypes.items() if t in TEXT_DTYPES]
            table = pd.read_csv(
                handle,
                dtype={c: str for c in text},
                keep_default_na=False,
                na_values={c: [""] for c in columns if c not in text},
            )
        table = _upgrade(_restore_dtypes(table[columns], dtypes), meta)
        return TestResult(table, meta, {})
    if suffix in (".h5", ".hdf5"):
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT_NAME:
                raise InputError("path", str(path), f"an HDF5 file in the {FORMAT_NAME} format")
            meta, columns, dtypes = _split_metadata(json.loads(f.attrs["metadata"]))
            data = {}
            for name in columns:
                values = f["table"][name][()]
                if dtypes[name] in TEXT_DTYPES:
                    values = np.array([v.decode() if isinstance(v, bytes) else v for v in values],
                                      dtype=object)
                data[name] = values
            snapshots = {name: f["snapshots"][name][()] for name in f["snapshots"]}
        table = _upgrade(_restore_dtypes(pd.DataFrame(data, columns=columns), dtypes), meta)
        return TestResult(table, meta, snapshots)
    raise InputError("path", str(path), "a file ending in .csv, .h5 or .hdf5")
