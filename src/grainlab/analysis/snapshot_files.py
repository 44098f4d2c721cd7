"""Files of contact-network snapshots: one HDF5 file holding the snapshots of a run.

Layout: root attributes ``format = "grainlab.snapshots"`` and ``format_version``; one group per
snapshot under ``/snapshots/000000``, ``/snapshots/000001``, ... each written by
:meth:`ContactNetwork.to_hdf5` (its ``state`` attribute carries step, time and strains). The
discrete engine appends to such a file during a run; ``grainlab analyse`` reads it.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

import h5py

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.errors import InputError

SNAPSHOTS_FORMAT = "grainlab.snapshots"
SNAPSHOTS_FORMAT_VERSION = 1
SNAPSHOTS_FILE = "snapshots.h5"
"""Name of the snapshot file inside a run folder."""


def _open_checked(path: Path) -> h5py.File:
    if not path.is_file():
        raise InputError("snapshot file", str(path), "an existing HDF5 snapshot file")
    try:
        handle = h5py.File(path, "r")
    except OSError:
        raise InputError("snapshot file", str(path), "an HDF5 file") from None
    if handle.attrs.get("format") != SNAPSHOTS_FORMAT:
        handle.close()
        raise InputError("snapshot file", str(path), f"a {SNAPSHOTS_FORMAT} HDF5 file")
    return handle


def resolve_snapshot_file(path: str | Path) -> Path:
    """A snapshot file, or the ``snapshots.h5`` inside a run folder."""
    path = Path(path)
    if path.is_dir():
        path = path / SNAPSHOTS_FILE
    if not path.is_file():
        raise InputError("RUN|SNAPSHOT", str(path),
                         f"a run folder holding {SNAPSHOTS_FILE} or a snapshot file (.h5)")
    return path


def append_snapshot(path: str | Path, network: ContactNetwork) -> int:
    """Append one snapshot to ``path`` (created if needed); returns its index."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "a") as handle:
        if "format" not in handle.attrs:
            handle.attrs["format"] = SNAPSHOTS_FORMAT
            handle.attrs["format_version"] = SNAPSHOTS_FORMAT_VERSION
        elif handle.attrs["format"] != SNAPSHOTS_FORMAT:
            raise InputError("snapshot file", str(path), f"a {SNAPSHOTS_FORMAT} HDF5 file")
        group = handle.require_group("snapshots")
        index = len(group)
        network.to_hdf5(group.create_group(f"{index:06d}"))
    return index


def write_snapshots(path: str | Path, networks: Iterable[ContactNetwork]) -> Path:
    """Write a new snapshot file holding ``networks`` in order."""
    path = Path(path)
    if path.exists():
        path.unlink()
    for network in networks:
        append_snapshot(path, network)
    return path


def count_snapshots(path: str | Path) -> int:
    """Number of snapshots in a file."""
    with _open_checked(Path(path)) as handle:
        return len(handle.get("snapshots", {}))


def read_snapshots(path: str | Path) -> Iterator[ContactNetwork]:
    """Yield the snapshots of a file one at a time (memory stays at one snapshot)."""
    with _open_checked(Path(path)) as handle:
        group = handle.get("snapshots")
        if group is None:
            return
        for name in sorted(group):
            yield ContactNetwork.from_hdf5(group[name])


def read_snapshot(path: str | Path, index: int = -1) -> ContactNetwork:
    """One snapshot by position (negative counts from the end)."""
    with _open_checked(Path(path)) as handle:
        names = sorted(handle.get("snapshots", {}))
        if not names:
            raise InputError("snapshot file", str(path), "a file with at least one snapshot")
        try:
            name = names[index]
        except IndexError:
            raise InputError("index", index, f"a snapshot index in [-{len(names)}, "
                                             f"{len(names) - 1}]") from None
        return ContactNetwork.from_hdf5(handle["snapshots"][name])
