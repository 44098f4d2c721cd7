"""The boundaries a discrete run can hold its sample in, one record each
(:class:`BoundaryRecord`), in one registry (:data:`BOUNDARIES`, STYLE.md 3): what the lab, the
config, the CLI, the checkpoints and the sample's preparation know of a boundary is read from
its record or asked of the engine boundary itself
(:attr:`~grainlab.engine.boundaries.boundary.Boundary.periodic`), never from its name.

* ``"walls"``, a box of six walls (:class:`~grainlab.engine.boundaries.wall_box.WallBox`,
  driven by :class:`~grainlab.lab.box_boundary.BoxBoundary` through the stages of
  :func:`~grainlab.lab.wall_stages.wall_stages`), as the seeds: its walls move along its
  axes only; every preparation (loose, deposited, from a file) makes it;
* ``"periodic"``, the periodic deformable cell (:class:`~grainlab.engine.boundaries.
  periodic_boundary.PeriodicCell`, driven by :class:`~grainlab.lab.cell_boundary.
  CellBoundary` through :func:`~grainlab.lab.cell_stages.cell_stages`): no walls, every
  stress and strain component controlled, so it alone runs the shearing tests
  (:data:`~grainlab.lab.run_config.PERIODIC_ONLY`); only a loose sample fills it.

The record's name is ``sample.boundary``'s value (the config's allowed values and the CLI's
``--boundary`` help are generated from :data:`BOUNDARY_NAMES` and the records' words) and the
kind a checkpoint records for the boundary (:func:`restore_boundary`; a checkpoint that
records none holds a box of walls, the first record).

A new boundary is its engine class (``engine/boundaries/<name>.py``: the
:class:`~grainlab.engine.boundaries.boundary.Boundary` protocol with ``periodic``,
``around``, ``to_arrays`` / ``from_arrays``) and one record here; a third file only when its
stages are driven by neither :class:`~grainlab.lab.box_boundary.BoxBoundary` nor
:class:`~grainlab.lab.cell_boundary.CellBoundary` (its own ``lab/<name>_boundary.py``, the
:class:`~grainlab.lab.stage_boundary.StageBoundary` protocol). A subclass of a registered
engine class (a box with other walls) reuses that record's driver and stages.

>>> boundary_record("periodic").periodic, boundary_record("walls").stage_driver.__name__
(True, 'BoxBoundary')
>>> BOUNDARY_NAMES
('walls', 'periodic')
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from grainlab.engine.boundaries.periodic_boundary import PeriodicCell
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.errors import InputError
from grainlab.lab.box_boundary import BoxBoundary
from grainlab.lab.cell_boundary import CellBoundary
from grainlab.lab.cell_stages import cell_stages
from grainlab.lab.cell_thickness import refuse_thin_cell
from grainlab.lab.wall_stages import wall_stages

PREPARATIONS = ("loose", "deposition", "file")
"""The ways a sample is made (``sample.preparation``): only ``"loose"`` takes its boundary
from the record (:meth:`BoundaryRecord.around`); a deposition and a file make a box of
walls."""


def _no_refusal(test, sample_config) -> None:
    """Nothing to refuse before a run starts."""


@dataclass(frozen=True)
class BoundaryRecord:
    """One boundary of a discrete run (module docstring).

    Attributes
    ----------
    name, title, words:
        ``sample.boundary``'s value (and the kind its checkpoints record), its name in a
        sentence (``"a box of walls"``) and its words in the ``--boundary`` help.
    engine_class:
        The engine boundary (:class:`~grainlab.engine.boundaries.boundary.Boundary`): its
        ``around(side, wall_friction, particle_mass)`` makes it around a loose sample, its
        ``from_arrays`` restores it from a checkpoint, its ``periodic`` says whether it is a
        periodic cell.
    stage_driver:
        The lab's driver of its stages (``stage_driver(test)``; the
        :class:`~grainlab.lab.stage_boundary.StageBoundary` protocol).
    stages:
        ``(path, deformable) -> stages``: a lab load path as its stages (refusing what it
        cannot run; ``deformable``: soft contacts), as its driver's ``load_stages``.
    preparations:
        The ``sample.preparation`` values that make a sample in it (:data:`PREPARATIONS`).
    shear_refusal:
        Why it cannot run the shearing tests (:data:`~grainlab.lab.run_config.PERIODIC_ONLY`);
        "" when it can.
    wallless_words:
        Why the keys that set walls (:data:`~grainlab.lab.option_scope.WALLS_ONLY`) do
        nothing in it; "" when it has walls.
    names_stages:
        Whether its stages in the results' load path carry ``"boundary": name`` (the cell's
        do; the box's stages were written before the cell and carry nothing).
    refuse_start:
        ``(test, sample config) -> None``: raises the :class:`InputError` of a test it cannot
        start (the periodic cell: one too thin for its particles after the compaction).
    compile_sample:
        The ``[sample]`` keys of the tiny soft-contact run that compiles its kernels
        (``grainlab precompile --part dem``); None: its kernels are another record's.
    """

    name: str
    title: str
    words: str
    engine_class: type
    stage_driver: type
    stages: Callable[[Any, bool], list]
    preparations: tuple[str, ...] = ("loose",)
    shear_refusal: str = ""
    wallless_words: str = ""
    names_stages: bool = False
    refuse_start: Callable[[Any, Any], None] = field(default=_no_refusal)
    compile_sample: dict | None = None

    @property
    def periodic(self) -> bool:
        """Whether it is a periodic cell (its engine class says)."""
        return bool(self.engine_class.periodic)

    @property
    def shears(self) -> bool:
        """Whether it runs the shearing tests."""
        return not self.shear_refusal

    @property
    def checkpoint_kind(self) -> str:
        """The kind a checkpoint records for it: its name."""
        return self.name

    def around(self, side, wall_friction: float, particle_mass: float, planar: bool = False):
        """Its engine boundary around the box [0, ``side``] [m] of a loose sample, walls (if
        any) of Coulomb coefficient ``wall_friction``, of mass ``particle_mass`` [kg];
        ``planar``: a 2D sample's (:mod:`grainlab.engine.planar`)."""
        return self.engine_class.around(side, wall_friction, particle_mass, planar=planar)

    def restore(self, arrays: dict):
        """Its engine boundary from a checkpoint's arrays (``to_arrays``)."""
        return self.engine_class.from_arrays(arrays)

    def describe(self, description: dict) -> None:
        """Name it in a sample's ``description`` (the default box goes unnamed, as before the
        periodic cell)."""
        if self.name != DEFAULT_BOUNDARY:
            description["boundary"] = self.name

    def stage_data(self, stage) -> dict:
        """A stage as plain data for the results' load path (``names_stages``)."""
        data = stage.to_dict()
        return {**data, "boundary": self.name} if self.names_stages else data


WALLS = BoundaryRecord(
    name="walls", title="a box of walls", words="a box of six walls, as the seeds",
    engine_class=WallBox, stage_driver=BoxBoundary,
    stages=lambda path, deformable: wall_stages(path), preparations=PREPARATIONS,
    shear_refusal="a box of walls moves only along its axes and cannot shear",
    compile_sample={})

PERIODIC = BoundaryRecord(
    name="periodic", title="a periodic cell",
    words=("a periodic deformable cell: no walls, every stress and strain component "
           "controlled; needed to shear"),
    engine_class=PeriodicCell, stage_driver=CellBoundary, stages=cell_stages,
    wallless_words="the cell's own servo holds its stresses", names_stages=True,
    refuse_start=refuse_thin_cell, compile_sample={"n_particles": 60, "size_ratio": 1.2})


BOUNDARIES: dict[str, BoundaryRecord] = {r.name: r for r in (WALLS, PERIODIC)}
"""The registry, by ``sample.boundary``; the first is the default."""

BOUNDARY_NAMES = tuple(BOUNDARIES)
"""The boundaries' names (``sample.boundary``'s values), the default first."""

DEFAULT_BOUNDARY = BOUNDARY_NAMES[0]


def quoted(names) -> str:
    """``"a" or "b"``: names as a message lists them."""
    return " or ".join(f'"{name}"' for name in names)


def boundary_record(name: str, field: str = "sample.boundary") -> BoundaryRecord:
    """The record of ``sample.boundary = name``; an :class:`InputError` naming ``field``,
    the value and the registered names otherwise."""
    if name not in BOUNDARIES:
        raise InputError(field, name, quoted(BOUNDARY_NAMES))
    return BOUNDARIES[name]


def boundary_record_of(boundary) -> BoundaryRecord:
    """The record of an engine boundary: that of its class or of the nearest registered
    class it derives from (a subclass not registered is driven as its base)."""
    by_class = {record.engine_class: record for record in BOUNDARIES.values()}
    for cls in type(boundary).__mro__:
        if cls in by_class:
            return by_class[cls]
    raise InputError("sample.boundary", type(boundary).__name__,
                     "a registered boundary: "
                     + ", ".join(r.engine_class.__name__ for r in BOUNDARIES.values()))


def restore_boundary(kind: str | None, arrays: dict):
    """The engine boundary a checkpoint saved as ``arrays`` with its recorded ``kind`` (None:
    a checkpoint from before the kind was recorded, a box of walls)."""
    return boundary_record(kind or DEFAULT_BOUNDARY, "checkpoint box kind").restore(arrays)


def shearing_names() -> tuple[str, ...]:
    """The boundaries that run the shearing tests."""
    return tuple(name for name, record in BOUNDARIES.items() if record.shears)


def preparing_names(preparation: str) -> tuple[str, ...]:
    """The boundaries a ``sample.preparation`` can make."""
    return tuple(name for name, record in BOUNDARIES.items()
                 if preparation in record.preparations)


def boundary_help() -> str:
    """The ``--boundary`` help: every registered boundary with its words."""
    items = [f"{name} ({record.words})" for name, record in BOUNDARIES.items()]
    listed = items[0] if len(items) == 1 else ", ".join(items[:-1]) + " or " + items[-1]
    return f"What holds the sample: {listed}."
