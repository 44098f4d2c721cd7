"""The shape library of a run, written once beside its checkpoints.

A sample's shapes (member spheres, polyhedron vertices, faces, edges, volumes:
:class:`~grainlab.engine.state.ShapeLibrary`) do not change during a run, yet for polyhedra
drawn one per particle they are most of what a checkpoint would hold: 1000 polyhedra of 596
faces take 91 MB, their positions, velocities and contact memory 2.4 MB. So a run writes its
library once, to ``shapes-<digest>.h5`` in the run folder, and each checkpoint names that
file and the digest.

* The digest is BLAKE2b (16 hex digits) over every array's name, dtype, shape and bytes: two
  libraries share a file only when they are the same arrays.
* The file is written like a checkpoint: to ``<name>.tmp``, fsynced, renamed (atomic), so a
  crash leaves either no file or a whole one; it is never rewritten.
* Reading checks the digest, so that a file replaced, truncated or copied from another run is
  named, not taken for the run's shapes.
* A library file no checkpoint names any more (a run whose shapes changed) is removed after
  the checkpoint that replaced it (:func:`remove_unnamed_library_files`).

Checkpoints written before this hold their library inline and are read as before
(:func:`~grainlab.lab.run_checkpoint.read_checkpoint`).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

import h5py
import numpy as np

LIBRARY_FILE_GLOB = "shapes-*.h5"
LIBRARY_FORMAT = "grainlab.shape_library"
LIBRARY_FILE_ATTR = "library_file"
"""The checkpoint attribute that names the library file (in the checkpoint's folder)."""
LIBRARY_DIGEST_ATTR = "library_digest"


class LibraryFileError(ValueError):
    """A checkpoint's library file is missing, damaged or not the one it names."""


def library_digest(arrays: Mapping[str, np.ndarray]) -> str:
    """BLAKE2b digest (16 hex digits) of the library's arrays: names, dtypes, shapes, bytes."""
    digest = hashlib.blake2b(digest_size=8)
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}|{array.dtype.str}|{array.shape}|".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


def library_file_name(digest: str) -> str:
    """The file name of the library whose digest is ``digest``."""
    return f"shapes-{digest}.h5"


def write_library_file(folder: Path, arrays: Mapping[str, np.ndarray]) -> tuple[str, str]:
    """Write the library ``arrays`` into ``folder`` unless its file is there already;
    returns ``(file name, digest)``. Raises ``OSError`` when it cannot be written (the
    temporary file removed)."""
    digest = library_digest(arrays)
    name = library_file_name(digest)
    path = folder / name
    if path.exists():
        return name, digest
    tmp = path.with_name(name + ".tmp")
    try:
        with h5py.File(tmp, "w") as handle:
            handle.attrs["format"] = LIBRARY_FORMAT
            handle.attrs["digest"] = digest
            group = handle.create_group("library")
            for key, array in arrays.items():
                group[key] = array
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
    except OSError:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)
    return name, digest


def read_library_file(path: Path, digest: str, names: Iterable[str]) -> dict[str, np.ndarray]:
    """The arrays ``names`` (those present) of the library file ``path``, checked against
    ``digest``; a missing, unreadable or different file raises :class:`LibraryFileError`."""
    if not path.exists():
        raise LibraryFileError(f"its shape library {path.name} is missing (it is written "
                               "once per run beside the checkpoints; copy it with them)")
    try:
        with h5py.File(path, "r") as handle:
            group = handle["library"]
            arrays = {n: group[n][()] for n in names if n in group}
    except (OSError, KeyError) as error:
        raise LibraryFileError(f"its shape library {path.name} is unreadable "
                               f"({type(error).__name__}: {error})") from None
    found = library_digest(arrays)
    if found != digest:
        raise LibraryFileError(f"its shape library {path.name} holds other shapes (digest "
                               f"{found}, the checkpoint names {digest})")
    return arrays


def library_files(folder: Path) -> list[Path]:
    """The library files in a run folder."""
    return sorted(folder.glob(LIBRARY_FILE_GLOB))


def remove_unnamed_library_files(folder: Path, checkpoints: Iterable[Path]) -> None:
    """Remove the library files of ``folder`` that none of ``checkpoints`` names. When one of
    them exists but cannot be read, nothing is removed (it may name any of them)."""
    named = set()
    for checkpoint in checkpoints:
        if not checkpoint.exists():
            continue
        try:
            with h5py.File(checkpoint, "r") as handle:
                name, inline = handle.attrs.get(LIBRARY_FILE_ATTR), "library" in handle
        except OSError:
            return  # unreadable: it may name any of them
        if name is not None:
            named.add(str(name))
        elif not inline:
            return  # neither inline nor named: keep them all
    for path in library_files(folder):
        if path.name not in named:
            path.unlink(missing_ok=True)
