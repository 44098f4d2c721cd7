"""Options of ``grainlab microelement`` for a structure taken from a discrete run's snapshot.

A snapshot file (``--structure RUN/snapshots.h5``) gives one micro-element per particle with
the run's contact forces as the model's initial state
(:mod:`grainlab.micromech.micro_element.from_snapshot`); these options choose the snapshot,
what becomes of its periodic-image and wall contacts, or ask for the geometry alone,
consolidated from zero force as for the other structures.
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Any

import typer

from grainlab.errors import InputError
from grainlab.lab.micro_element_setup import SNAPSHOT_SUFFIXES


class PeriodicContacts(StrEnum):
    """Interactions through a periodic image."""

    keep = "keep"
    drop = "drop"


class WallContacts(StrEnum):
    """Contacts with the walls of a box (not in the snapshot: from the particles' balance)."""

    drop = "drop"
    balance = "balance"


SNAPSHOT_FORCES_OPTION = typer.Option(
    True, "--snapshot-forces/--consolidate", help="Snapshot structure (.h5): start from the "
    "run's contact forces (no consolidation; --sigma0 does not apply), or take its geometry "
    "only and consolidate it from zero force to --sigma0.")
SNAPSHOT_INDEX_OPTION = typer.Option(-1, "--snapshot-index", help="Snapshot structure: which "
                                     "snapshot of the file (negative counts from the end).")
PERIODIC_OPTION = typer.Option(
    PeriodicContacts.keep, "--periodic-contacts", help="Snapshot structure: keep the "
    "interactions that reach through a periodic image (branch through the image: the "
    "complete periodic packing), or drop them (the particles on the cell's faces lose "
    "contacts and the stress their share).")
WALLS_OPTION = typer.Option(
    WallContacts.drop, "--wall-contacts", help="Snapshot structure, wall box: drop the walls "
    "(the model is the grains; its stress is the particle contacts' and lower than the "
    "walls' by the boundary layer's share), or balance each particle's unbalanced force by a "
    "contact with a fixed wall (the model's stress is then the stress on the walls).")


def snapshot_options(structure: str, forces: bool, index: int, periodic: str,
                     walls: str) -> dict[str, Any]:
    """Keyword options of :func:`~grainlab.lab.micro_element_setup.build_structure` for a
    snapshot file; none for other structures, which must keep the defaults."""
    periodic, walls = PeriodicContacts(periodic).value, WallContacts(walls).value
    if Path(str(structure)).suffix.lower() in SNAPSHOT_SUFFIXES:
        if forces:
            return {"index": index, "periodic": periodic, "walls": walls}
        if periodic != "keep" or walls != "drop":
            raise InputError("--periodic-contacts/--wall-contacts", f"{periodic}/{walls}",
                             "the defaults (keep/drop) with --consolidate")
        return {"index": index, "forces": False}
    given = {"--consolidate": not forces, "--snapshot-index": index != -1,
             "--periodic-contacts": periodic != "keep", "--wall-contacts": walls != "drop"}
    for option, changed in given.items():
        if changed:
            raise InputError(option, structure, "a snapshot file (.h5) as --structure")
    return {}
