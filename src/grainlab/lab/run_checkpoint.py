"""Checkpoint files of a discrete run: two kept, written atomically, read with a fallback.

A run folder keeps its last two checkpoints::

    checkpoint.h5        the last one
    checkpoint.prev.h5   the one before

A checkpoint is written to ``checkpoint.h5.tmp``, fsynced, then the last one is renamed to
``checkpoint.prev.h5`` and the new one to ``checkpoint.h5`` (each rename atomic), and the
folder is fsynced. A crash at any moment leaves at least one complete checkpoint: before the
first rename both old ones, between the renames ``checkpoint.prev.h5`` alone, after them both
new ones.

The shape library does not change during a run: it is written once, to ``shapes-<digest>.h5``
beside the checkpoints, and each checkpoint names it (:mod:`grainlab.lab.shape_library_file`;
checkpoints before it hold the library inline).

Reading (:func:`load_checkpoint`) tries ``checkpoint.h5``, then ``checkpoint.prev.h5``; a file
that is missing, truncated, empty or not a checkpoint is named with what is wrong with it
(:class:`CheckpointDamaged`), and with none usable nothing in the folder is touched. A write
that fails (a full disk: ``OSError`` ``ENOSPC``) removes its temporary file and raises
:class:`RunStorageError`; the checkpoints already on disk stay as they were.
"""

from __future__ import annotations

import errno
import json
import math
import os
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import h5py

from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import GrainlabError
from grainlab.lab.boundary_registry import restore_boundary
from grainlab.lab.shape_library_file import (
    LIBRARY_DIGEST_ATTR,
    LIBRARY_FILE_ATTR,
    LibraryFileError,
    read_library_file,
    remove_unnamed_library_files,
    write_library_file,
)

CHECKPOINT = "checkpoint.h5"
PREVIOUS_CHECKPOINT = "checkpoint.prev.h5"
DAMAGED_SUFFIX = ".damaged"
"""A damaged ``checkpoint.h5`` passed over for ``checkpoint.prev.h5`` is kept under its name
plus this suffix (so that the next checkpoint does not rotate it over the good one)."""
CHECKPOINT_FORMAT = "grainlab.discrete_checkpoint"
CHECKPOINT_VERSION = 1

STATE_FIELDS = ("positions", "orientations", "velocities", "angular_velocities", "masses",
                "inertias", "shape_ids")
LIBRARY_FIELDS = tuple(f.name for f in fields(ShapeLibrary))
"""Every array of the shape library (member spheres and polyhedron vertices, faces, edges)."""


class NoCheckpoint(GrainlabError):
    """A run folder holds no checkpoint to resume from."""


class CheckpointDamaged(GrainlabError):
    """No usable checkpoint: the message names each file and what is wrong with it."""


class RunStorageError(GrainlabError):
    """A run's file could not be written (full disk, no permission); the files already on
    disk are kept as they were. ``errno``: the operating system's error number."""

    def __init__(self, errno_: int, message: str) -> None:
        self.errno = errno_
        super().__init__(message)


@dataclass
class CheckpointContents:
    """What one checkpoint holds: ``groups`` of arrays, scalar ``attrs`` (JSON text or
    numbers) and text ``datasets`` (no 64 kB limit)."""

    groups: dict[str, dict[str, Any]] = field(default_factory=dict)
    group_attrs: dict[str, dict[str, Any]] = field(default_factory=dict)
    attrs: dict[str, Any] = field(default_factory=dict)
    datasets: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class LoadedCheckpoint:
    """A checkpoint read back: its contents (:func:`read_checkpoint`), the file it came
    from, and the files passed over with what was wrong with them."""

    saved: dict[str, Any]
    path: Path
    passed_over: tuple[tuple[Path, str], ...] = ()

    @property
    def fell_back(self) -> bool:
        """True when the previous checkpoint was used."""
        return self.path.name == PREVIOUS_CHECKPOINT


def _write_file(path: Path, contents: CheckpointContents) -> None:
    """Write ``contents`` to the HDF5 file ``path`` and fsync it."""
    with h5py.File(path, "w") as handle:
        handle.attrs["format"] = CHECKPOINT_FORMAT
        handle.attrs["format_version"] = CHECKPOINT_VERSION
        for name, arrays in contents.groups.items():
            group = handle.create_group(name)
            for key, array in arrays.items():
                group[key] = array
            for key, value in contents.group_attrs.get(name, {}).items():
                group.attrs[key] = value
        for name, value in contents.attrs.items():
            handle.attrs[name] = value
        for name, text in contents.datasets.items():
            handle[name] = text
    with open(path, "rb") as f:
        os.fsync(f.fileno())


def _fsync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # not every file system opens folders
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def storage_error(error: OSError, what: str, kept: str) -> RunStorageError:
    """The one message of a failed write: what could not be written, why (a full disk said
    as such), and what is kept."""
    why = "the disk is full" if error.errno == errno.ENOSPC else \
        (error.strerror or str(error))
    return RunStorageError(error.errno or errno.EIO,
                           f"could not write {what}: {why}. {kept} Free some space (or fix "
                           "the cause) and continue with `grainlab resume`.")


def write_checkpoint(folder: Path, contents: CheckpointContents, *, kept: str = "",
                     rotate: bool = True) -> Path:
    """Write a checkpoint into ``folder`` with rotation (module docstring; ``rotate=False``:
    replace the last one, atomically too); returns its path. A ``library`` group goes to the
    run's library file, written once (:mod:`grainlab.lab.shape_library_file`). A failed write
    raises :class:`RunStorageError` (``kept`` says what is still on disk)."""
    path = folder / CHECKPOINT
    groups = dict(contents.groups)
    library = groups.pop("library", None)
    if library is not None:
        try:
            name, digest = write_library_file(folder, library)
        except OSError as error:
            raise storage_error(error, f"the shape library in {folder}", kept) from None
        contents = replace(contents, groups=groups,
                           attrs={**contents.attrs, LIBRARY_FILE_ATTR: name,
                                  LIBRARY_DIGEST_ATTR: digest})
    tmp = path.with_name(path.name + ".tmp")
    try:
        _write_file(tmp, contents)
    except OSError as error:
        tmp.unlink(missing_ok=True)
        raise storage_error(error, f"the checkpoint {tmp}", kept) from None
    if rotate and path.exists():
        os.replace(path, folder / PREVIOUS_CHECKPOINT)
    os.replace(tmp, path)
    _fsync_folder(folder)
    if library is not None:
        remove_unnamed_library_files(folder, (path, folder / PREVIOUS_CHECKPOINT))
    return path


def _damage(error: BaseException) -> str:
    """What is wrong with a checkpoint file, in words."""
    text = str(error)
    if "truncated file" in text:
        return "truncated (the file ends early)"
    if "file signature not found" in text:
        return "not an HDF5 file (empty or overwritten)"
    if isinstance(error, LibraryFileError):
        return str(error)
    if isinstance(error, KeyError):
        return f"incomplete (no {text})"
    return f"unreadable ({type(error).__name__}: {text})"


def _boundary(group) -> Any:
    """The boundary saved in ``group``, restored by the record of the kind it names
    (:func:`~grainlab.lab.boundary_registry.restore_boundary`; checkpoints before the periodic
    cell name none and hold a wall box)."""
    arrays = {k: v[()] for k, v in group.items()}
    kind = group.attrs.get("kind")
    return restore_boundary(None if kind is None else str(kind), arrays)


def _library_arrays(handle, path: Path) -> dict[str, Any]:
    """The library arrays of a checkpoint: inline (older checkpoints) or from the library
    file it names, checked against its digest."""
    if "library" in handle:
        return {n: handle["library"][n][()] for n in LIBRARY_FIELDS if n in handle["library"]}
    return read_library_file(path.parent / str(handle.attrs[LIBRARY_FILE_ATTR]),
                             str(handle.attrs[LIBRARY_DIGEST_ATTR]), LIBRARY_FIELDS)


def read_checkpoint(path: str | Path) -> dict[str, Any]:
    """Everything a checkpoint holds: ``library``, ``state``, ``box`` (objects),
    ``warm_start`` (arrays), ``rng_state``, ``progress``, ``outcome``, ``description``,
    ``rows`` (plain data), ``config`` (plain data, None in checkpoints older than it),
    ``wall_time`` [s] (the run's so far: NaN in checkpoints older than it).
    A damaged file raises :class:`CheckpointDamaged` naming it."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as handle:
            if handle.attrs.get("format") != CHECKPOINT_FORMAT:
                raise CheckpointDamaged(f"{path} is damaged: not a {CHECKPOINT_FORMAT} file")
            saved: dict[str, Any] = {
                "library": ShapeLibrary(**_library_arrays(handle, path)),
                "state": BodyState(**{n: handle["state"][n][()] for n in STATE_FIELDS},
                                   density=float(handle["state"].attrs["density"])),
                "box": _boundary(handle["box"]),
                "warm_start": {k: v[()] for k, v in handle["warm_start"].items()},
                "rows": json.loads(handle["rows"][()]),
            }
            for name in ("rng_state", "progress", "outcome", "description"):
                saved[name] = json.loads(handle.attrs[name])
            saved["config"] = json.loads(handle.attrs["config"]) \
                if "config" in handle.attrs else None
            saved["wall_time"] = float(handle.attrs["wall_time"]) \
                if "wall_time" in handle.attrs else math.nan
    except CheckpointDamaged:
        raise
    except (OSError, KeyError, ValueError, TypeError) as error:
        raise CheckpointDamaged(f"{path} is damaged: {_damage(error)}") from None
    return saved


def load_checkpoint(folder: Path) -> LoadedCheckpoint:
    """The newest usable checkpoint of ``folder`` (module docstring). Raises
    :class:`NoCheckpoint` when there is none and :class:`CheckpointDamaged` when none is
    usable; the folder is not touched."""
    passed: list[tuple[Path, str]] = []
    for name in (CHECKPOINT, PREVIOUS_CHECKPOINT):
        path = folder / name
        if not path.exists():
            passed.append((path, "missing"))
            continue
        try:
            return LoadedCheckpoint(read_checkpoint(path), path, tuple(passed))
        except CheckpointDamaged as error:
            passed.append((path, str(error).split(" is damaged: ", 1)[-1]))
    restart = (f"Nothing in {folder} was changed. To start the run over from step 0: "
               f"`grainlab resume {folder} --restart` (moves the run's files to "
               f"{folder}/previous-N first).")
    if all(why == "missing" for _, why in passed):
        raise NoCheckpoint(
            f"{folder} has no checkpoint ({CHECKPOINT} or {PREVIOUS_CHECKPOINT}): nothing to "
            f"resume from (the run stopped before its first checkpoint). {restart}")
    said = "; ".join(f"{path.name} is {'missing' if why == 'missing' else 'damaged: ' + why}"
                     for path, why in passed)
    raise CheckpointDamaged(f"no usable checkpoint in {folder}: {said}. {restart}")


def set_damaged_aside(path: Path) -> Path:
    """Rename a damaged checkpoint to ``<name>.damaged`` (kept for inspection); returns the
    new path."""
    aside = path.with_name(path.name + DAMAGED_SUFFIX)
    os.replace(path, aside)
    return aside
