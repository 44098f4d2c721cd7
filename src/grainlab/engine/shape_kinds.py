"""Shape kinds: what the engine and the lab know about each kind of particle shape, in one
record per kind, looked up by name or by code (a registry, STYLE.md 3).

Every shape of a :class:`~grainlab.engine.state.ShapeLibrary` carries an integer kind code
(``library.kind``). The :class:`ShapeKind` of a code says

- ``name`` (``"sphere"``), ``code`` (0; stored in libraries and checkpoints, never
  renumbered), ``plural`` (``"spheres"``, for messages) and a one-line ``description``;
- ``narrow_phase``: the family of contact geometry its pairs and walls go through,
  :data:`MEMBER_SPHERES` (a list of member spheres; sphere-sphere geometry,
  :func:`~grainlab.engine.detect.narrow_phase.pair_contacts_kernel`) or :data:`POLYHEDRON_FEATURES`
  (vertices, edges and planar faces; the kernels of
  :mod:`~grainlab.engine.detect.polyhedron_narrow_phase`). The family also says which rows of the
  library a shape fills: member spheres (``sphere_count`` >= 1) or a polyhedron boundary
  (``sphere_count`` 0). A pair of two families goes through the kernels of the family that
  is not :data:`MEMBER_SPHERES` (a polyhedron against the member spheres of an aggregate);
- ``pair_typing``: how a contact network types the pairs between particles when a shape of
  the kind is present, :data:`FEATURE_TYPES` (fv, ee, fe, ff from the narrow phase's
  ``contact_type``; seed 002) before :data:`MEMBER_CLASSES` (s, ds, d, t, q, m from the
  number of member contacts; seed 003), or None (spheres: one kind of pair);
- ``spins_fast``: True where the particles' own speeds shorten the time step and the
  gyroscopic term of free rotation is integrated (polyhedra: a flat face landing on an edge
  spins them up within a step); spheres and aggregates keep the step of the walls' speed;
- ``dimension``: 3, or 2 for a kind that moves in a plane (discs: the plane z = const, two
  translations and one rotation about z; :mod:`grainlab.engine.planar`). A library holds kinds
  of one dimension only;
- ``time_step_length(library, shapes)``: the length d_min [m] that scales the automatic time
  step, over the library's shapes ``shapes`` (K,) of the kind: the smallest member-sphere
  diameter 2 min r, or for polyhedra the smallest inscribed diameter 2 min_f (n_f . v_f)
  about the centre of mass (:func:`library_time_step_length` takes the smallest over the
  kinds of a library).

Lookups: :func:`shape_kind` (a name or a code; anything else is an
:class:`~grainlab.errors.InputError` listing :data:`SHAPE_KIND_NAMES`), :data:`SHAPE_KINDS`
(in code order), :func:`kinds_present`, :func:`kinds_of_family`, :func:`family_mask`. Two
layers above keep their own tables keyed by the same names: how a loose sample of each kind
is made (:data:`grainlab.prep.sample_shapes.SAMPLE_SHAPES`) and how each kind is drawn
(:data:`grainlab.report.shape_drawing.SHAPE_KIND_DRAWERS`); tests check that every
registered kind has an entry in both. Others follow a kind's family: the compile runs
(:data:`grainlab.cli.precompile.FAMILY_TINY_RUNS` and ``FAMILY_PARTS``) and the particle
files (:mod:`grainlab.prep.particle_files`: a kind's points are its member spheres or its
vertices, and a particle reads back with its own code).

A new kind of an existing family (a shape of member spheres, such as a dimer of two
spheres, or a polyhedron of a shape of its own) touches three files:

1. this module: its :class:`ShapeKind` record, in :data:`SHAPE_KINDS` with the next code;
2. :mod:`grainlab.prep.sample_shapes`: its maker (radii -> library) in ``SAMPLE_SHAPES``;
3. :mod:`grainlab.report.shape_drawing`: its drawer in ``SHAPE_KIND_DRAWERS`` (its
   family's: member spheres or polyhedra);

plus its tests (those that list every kind by name: the codes are stored in checkpoints and
never renumbered). Six more when its maker takes parameters of its own (as ``n_faces`` for
polyhedra), which the layers pass by name: the keywords of
:func:`grainlab.prep.loose_sample.loose_sample` and of
:mod:`grainlab.prep.inscribed_sample`, the key of ``[sample]`` in
:mod:`grainlab.lab.run_config`, its passing in :func:`grainlab.lab.discrete_run.build_sample`,
``SHAPE_KEYS`` in :mod:`grainlab.lab.option_scope` and the option in
:mod:`grainlab.cli.run_options`. The CLI's ``--shape`` values and help, the config's allowed
shapes, the time step, the gyroscopic term, the network's pair types, the compile runs and
the particle files follow the registries without change.

A new convex shape that neither member spheres nor planar faces describe (superquadrics,
cylinders) needs a new family beside :data:`POLYHEDRON_FEATURES`, and touches nine files,
two of them new:

1. this module: its :class:`ShapeKind` record and its family in
   :data:`NARROW_PHASE_FAMILIES`;
2. ``geometry/<shape>.py`` (new): its mass properties (volume, principal inertia, body
   frame) and support function;
3. :mod:`grainlab.engine.state`: the library arrays of its parameters, a ``from_<shapes>``
   constructor, their validation and :meth:`~grainlab.engine.state.ShapeLibrary.concatenate`;
4. ``engine/detect/<shape>_narrow_phase.py`` (new): its pair, cross-family and wall kernels;
5. :mod:`grainlab.engine.detect.narrow_phase`: the launcher calling those kernels for the new
   family's pairs (the families' kernels take different arrays: no generic loop);
6. :mod:`grainlab.prep.sample_shapes`: its maker (radii -> library);
7. :mod:`grainlab.report.shape_drawing`: its drawer;
8. :mod:`grainlab.cli.precompile`: its family's tiny run and part;
9. :mod:`grainlab.prep.particle_files`: the points that describe its particles in a file;

and the six above when its maker takes parameters of its own; plus its tests.

>>> shape_kind("polyhedron").code, shape_kind(0).plural
(2, 'spheres')
>>> SHAPE_KIND_NAMES
('sphere', 'aggregate', 'polyhedron', 'disc')
>>> shape_kind("disc").dimension
2
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from grainlab.errors import InputError

if TYPE_CHECKING:
    from grainlab.engine.state import ShapeLibrary

MEMBER_SPHERES = "member_spheres"
"""Narrow-phase family of shapes made of member spheres (spheres, aggregates)."""
POLYHEDRON_FEATURES = "polyhedron_features"
"""Narrow-phase family of convex polyhedra (vertex, edge and face features)."""
NARROW_PHASE_FAMILIES = (MEMBER_SPHERES, POLYHEDRON_FEATURES)
"""The narrow-phase families, each with its own kernels."""

FEATURE_TYPES = "feature_types"
"""Pair typing by the touching features of polyhedra (fv, ee, fe, ff; seed 002)."""
MEMBER_CLASSES = "member_classes"
"""Pair typing by the number of member-sphere contacts (s, ds, d, t, q, m; seed 003)."""
PAIR_TYPINGS = (FEATURE_TYPES, MEMBER_CLASSES)
"""Pair typings, first the one that wins when a sample holds kinds of both."""


def _rows(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Concatenation of arange(s, s + c) over the pairs (s, c) of (K,) int arrays."""
    total = int(np.sum(counts))
    first = np.cumsum(counts) - counts
    return np.arange(total, dtype=np.int64) - np.repeat(first - starts, counts)


def member_sphere_diameter(library: ShapeLibrary, shapes: np.ndarray) -> float:
    """Smallest member-sphere diameter 2 min r [m] of the library's ``shapes`` (K,)."""
    rows = _rows(library.sphere_start[shapes], library.sphere_count[shapes])
    return 2.0 * float(np.min(library.sphere_radii[rows]))


def inscribed_diameter(library: ShapeLibrary, shapes: np.ndarray) -> float:
    """Smallest inscribed diameter 2 min_f (n_f . v_f) [m] of the polyhedra ``shapes`` (K,)
    (face planes about the centre of mass): a cube of side a gives a."""
    rows = _rows(library.face_start[shapes], library.face_count[shapes])
    return 2.0 * float(np.min(library.face_offsets[rows]))


@dataclass(frozen=True)
class ShapeKind:
    """One kind of particle shape (module docstring)."""

    name: str
    code: int
    plural: str
    description: str
    narrow_phase: str
    pair_typing: str | None
    spins_fast: bool
    time_step_length: Callable[[ShapeLibrary, np.ndarray], float]
    dimension: int = 3

    def __post_init__(self) -> None:
        if self.dimension not in (2, 3):
            raise InputError(f"{self.name}.dimension", self.dimension, "2 or 3")
        if self.narrow_phase not in NARROW_PHASE_FAMILIES:
            raise InputError(f"{self.name}.narrow_phase", self.narrow_phase,
                             "one of " + ", ".join(NARROW_PHASE_FAMILIES))
        if self.pair_typing is not None and self.pair_typing not in PAIR_TYPINGS:
            raise InputError(f"{self.name}.pair_typing", self.pair_typing,
                             "None or one of " + ", ".join(PAIR_TYPINGS))

    @property
    def has_member_spheres(self) -> bool:
        """Whether its shapes are lists of member spheres (``sphere_count`` >= 1)."""
        return self.narrow_phase == MEMBER_SPHERES


SPHERE = ShapeKind(
    name="sphere", code=0, plural="spheres",
    description="a sphere: one member sphere at the centre of mass",
    narrow_phase=MEMBER_SPHERES, pair_typing=None, spins_fast=False,
    time_step_length=member_sphere_diameter)
AGGREGATE = ShapeKind(
    name="aggregate", code=1, plural="aggregates",
    description="a rigid aggregate of overlapping spheres",
    narrow_phase=MEMBER_SPHERES, pair_typing=MEMBER_CLASSES, spins_fast=False,
    time_step_length=member_sphere_diameter)
POLYHEDRON = ShapeKind(
    name="polyhedron", code=2, plural="polyhedra",
    description="a convex polyhedron: vertices, planar faces and edges, no member sphere",
    narrow_phase=POLYHEDRON_FEATURES, pair_typing=FEATURE_TYPES, spins_fast=True,
    time_step_length=inscribed_diameter)

DISC = ShapeKind(
    name="disc", code=3, plural="discs",
    description="a disc: a cylinder of the sample's thickness seen end-on, moving in a plane",
    narrow_phase=MEMBER_SPHERES, pair_typing=None, spins_fast=False,
    time_step_length=member_sphere_diameter, dimension=2)

SHAPE_KINDS: tuple[ShapeKind, ...] = (SPHERE, AGGREGATE, POLYHEDRON, DISC)
"""Every registered kind, in code order."""
SHAPE_KIND_NAMES = tuple(kind.name for kind in SHAPE_KINDS)
"""Names of the registered kinds (config and CLI values)."""

_BY_NAME = {kind.name: kind for kind in SHAPE_KINDS}
_BY_CODE = {kind.code: kind for kind in SHAPE_KINDS}


def _allowed() -> str:
    return "a shape kind: " + ", ".join(f"{k.name!r} ({k.code})" for k in SHAPE_KINDS)


def shape_kind(key: str | int | np.integer, field: str = "shape") -> ShapeKind:
    """The :class:`ShapeKind` of a name (``"aggregate"``) or a code (1); an InputError naming
    ``field`` and listing the registered kinds for anything else."""
    if isinstance(key, str):
        found = _BY_NAME.get(key)
    elif isinstance(key, int | np.integer) and not isinstance(key, bool):
        found = _BY_CODE.get(int(key))
    else:
        found = None
    if found is None:
        raise InputError(field, key, _allowed())
    return found


def kinds_present(codes: Iterable[int] | np.ndarray, field: str = "kind"
                  ) -> tuple[ShapeKind, ...]:
    """The kinds of the codes ``codes`` (e.g. ``library.kind``), each once, in code order."""
    return tuple(shape_kind(int(c), field) for c in np.unique(np.asarray(codes, np.int64)))


def kinds_of_family(family: str) -> tuple[ShapeKind, ...]:
    """The registered kinds of the narrow-phase ``family`` (:data:`NARROW_PHASE_FAMILIES`),
    in code order."""
    if family not in NARROW_PHASE_FAMILIES:
        raise InputError("family", family, "one of " + ", ".join(NARROW_PHASE_FAMILIES))
    return tuple(k for k in SHAPE_KINDS if k.narrow_phase == family)


def family_mask(codes: np.ndarray, family: str) -> np.ndarray:
    """(N,) bool: which of the kind codes ``codes`` (N,) belong to the narrow-phase
    ``family`` (:data:`NARROW_PHASE_FAMILIES`)."""
    return np.isin(np.asarray(codes), [k.code for k in kinds_of_family(family)])


def library_time_step_length(library: ShapeLibrary) -> float:
    """The length d_min [m] that scales the automatic time step: the smallest over the kinds
    of the library of each kind's :attr:`ShapeKind.time_step_length` over all its shapes."""
    if library.n_shapes == 0:
        raise InputError("library", "no shapes", "a library of at least one shape")
    return min(kind.time_step_length(library, np.flatnonzero(library.kind == kind.code))
               for kind in kinds_present(library.kind, "library.kind"))
