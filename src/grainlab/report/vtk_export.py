"""VTK files for ParaView: particles as their true shapes, contacts as lines carrying their
force, walls as quads (VTK XML UnstructuredGrid ``.vtu`` written by meshio, plus ParaView
collection ``.pvd`` indexes).

Three kinds of file per frame k, in one folder:

* ``particles_<k>.vtu`` -- every member sphere of every body as a triangulated sphere (an
  icosphere of 20 4^s triangles, s = ``subdivisions``; s = 1 gives 80 triangles and 42
  vertices per member) placed in the world frame: member centre c = x + R(q) c_body, vertices
  c + r u for the unit icosphere vertices u. With ``as_points=True`` one vertex per member
  sphere at c instead (draw it with ParaView's Point Gaussian representation or a Glyph
  filter scaled by ``radius``; much lighter for big samples). Point data, one value per vertex
  copied from its body: ``particle_id``, ``shape_id``, ``member`` (index of the member sphere
  in its shape), ``radius`` [m] (of the member), ``velocity`` (3) [m/s] and
  ``angular_velocity`` (3) [rad/s] when given, and any extra per-particle arrays.
* ``contacts_<k>.vtu`` -- one line cell per contact between its two end points (two particle
  centres, or contact point and particle centre for a wall contact). Cell data:
  ``normal_force`` f_n = f . n [N] (compression positive), ``tangential_force``
  |f - f_n n| [N], ``force`` f (3) [N] (on the end side, from the start side), ``normal`` n (3)
  (unit, from start to end side), and optionally ``type`` (integer) and ``sliding`` (0/1).
  Lines have their own two points, so ParaView's "Cell Data to Point Data" is exact and a Tube
  filter can then vary its radius by ``normal_force``.
* ``walls_<k>.vtu`` -- the six planes of a box [lower, upper] as six quads over its eight
  corners, ordered as :data:`~grainlab.engine.boundaries.wall_box.WALL_NAMES` (x-, x+, y-, y+, z-,
  z+),
  each wound so that its right-hand normal points into the box. Cell data: ``wall`` (index
  0..5), ``normal`` (3) (into the box), and ``reaction`` [N] (compression positive) if given.

``<kind>.pvd`` lists the frames of one kind with their times [s]; :func:`write_vtk_frame`
adds each frame to it as soon as the frame's files are written, so the series of an
interrupted run opens in ParaView. :class:`VtkSeries` numbers the frames of a run for you.
Frames without any contact are written uncompressed (ParaView reads them; meshio 5.3 cannot
read empty cell blocks back), all others zlib-compressed binary.

Shapes are drawn by kind (:data:`grainlab.report.shape_drawing.SHAPE_KIND_DRAWERS`): each
kind's drawer gives body-frame vertices and faces, which this writer only rotates and
translates. Spheres and aggregates share the member-sphere drawer (triangles); convex
polyhedra are drawn as their true faceted shapes: hull vertices v_world = x + R(q) v_body and
one polygon cell per planar face (VTK_TRIANGLE, VTK_QUAD or VTK_POLYGON by its vertex
count), with ``member`` 0 and ``radius`` the circumscribed radius.

>>> import tempfile
>>> import meshio
>>> import numpy as np
>>> from grainlab.engine.state import ShapeLibrary
>>> library = ShapeLibrary.from_spheres([0.5])
>>> with tempfile.TemporaryDirectory() as folder:
...     files = write_vtk_frame(
...         folder, 3, 0.25, positions=[[0, 0, 0], [1, 0, 0]],
...         orientations=[[1, 0, 0, 0], [1, 0, 0, 0]], shape_ids=[0, 0], library=library,
...         contacts=ContactLines(start=[[0, 0, 0]], end=[[1, 0, 0]], force=[[2.0, 0, 0]],
...                               normal=[[1.0, 0, 0]]),
...         walls=BoxWalls(lower=[-1, -1, -1], upper=[2, 1, 1]))
...     particles = meshio.read(files["particles"])
...     contacts = meshio.read(files["contacts"])
...     index = read_pvd(files["particles"].parent / "particles.pvd")
>>> sorted(files), files["particles"].name
(['contacts', 'particles', 'walls'], 'particles_000003.vtu')
>>> len(particles.points), len(particles.cells_dict["triangle"])
(84, 160)
>>> float(contacts.cell_data_dict["normal_force"]["line"][0])
2.0
>>> [(t, p.name) for t, p in index]
[(0.25, 'particles_000003.vtu')]
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import meshio
import numpy as np

from grainlab.engine.boundaries.wall_box import WALL_NAMES
from grainlab.engine.quaternion import quat_to_matrices
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.report.shape_drawing import (
    check_subdivisions,
    concatenated_ranges,
    library_meshes,
    offsets_from_counts,
)

if TYPE_CHECKING:
    from grainlab.engine.boundaries.wall_box import WallBox
    from grainlab.engine.step_report import StepReport

FILE_KINDS = ("particles", "contacts", "walls")
"""Kinds of file of a frame: ``<kind>_<frame:06d>.vtu`` and the index ``<kind>.pvd``."""
CONTACT_TYPE_PARTICLE = 0
"""``type`` of a particle-particle contact in :meth:`ContactLines.from_step_report`."""
CONTACT_TYPE_WALL = 1
"""``type`` of a wall-particle contact in :meth:`ContactLines.from_step_report`."""
PARTICLE_ARRAYS = ("particle_id", "shape_id", "member", "radius", "velocity",
                   "angular_velocity")
"""Names of the particle point-data arrays the writer owns (extra arrays may not reuse them)."""
WALL_SHIFT = 6  # wall w (body id -1 - w, 6 walls) -> 5 - w >= 0 when grouping by pair
_UNIT_TOLERANCE = 1e-6  # |1 - |q|| and |1 - |n|| accepted for unit quaternions and normals
_CHUNK = 1 << 17  # vertices rotated at a time (bounds the (chunk, 3, 3) temporary)


# --------------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------------


def _float_rows(name: str, value, columns: int | None, rows: int | None = None) -> np.ndarray:
    """``value`` as a float64 array (rows,) or (rows, columns), finite, else InputError."""
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(name, value, "an array of numbers") from None
    n = array.shape[0] if array.ndim >= 1 else None
    if rows is not None:
        n = rows
    expected = (n,) if columns is None else (n, columns)
    if array.ndim == 0 or array.shape != expected:
        shown = "N" if n is None else n
        wanted = f"({shown},)" if columns is None else f"({shown}, {columns})"
        raise InputError(name, f"array of shape {array.shape}", f"an array of shape {wanted}")
    finite = np.isfinite(array) if columns is None else np.isfinite(array).all(axis=1)
    if not finite.all():
        k = int(np.flatnonzero(~finite)[0])
        raise InputError(f"{name}[{k}]", array[k].tolist(), "finite values")
    array.setflags(write=False)
    return array


def _unit_rows(name: str, value, columns: int, rows: int | None, what: str) -> np.ndarray:
    """Finite rows of unit length (within 1e-6), returned normalised."""
    array = _float_rows(name, value, columns, rows)
    norms = np.linalg.norm(array, axis=1)
    bad = np.abs(norms - 1.0) > _UNIT_TOLERANCE
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"{name}[{k}]", array[k].tolist(),
                         f"{what} of length 1 within {_UNIT_TOLERANCE:g}")
    unit = array / norms[:, None] if array.shape[0] else array.copy()
    unit.setflags(write=False)
    return unit


def _int_rows(name: str, value, rows: int) -> np.ndarray:
    array = np.asarray(value)
    if array.shape != (rows,) or not (np.issubdtype(array.dtype, np.integer) or rows == 0):
        raise InputError(name, f"array of shape {array.shape} and dtype {array.dtype}",
                         f"an integer array of shape ({rows},)")
    return array.astype(np.int64)


def _flag_rows(name: str, value, rows: int) -> np.ndarray:
    array = np.asarray(value)
    if array.shape != (rows,) or not (array.dtype == bool or np.isin(array, (0, 1)).all()):
        raise InputError(name, f"array of shape {array.shape}",
                         f"a boolean (or 0/1) array of shape ({rows},)")
    return array.astype(np.uint8)


def _frame_index(value) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise InputError("frame_index", value, "an integer >= 0")
    return int(value)


def _time(value, name: str = "time") -> float:
    try:
        t = float(value)
    except (TypeError, ValueError):
        t = math.nan
    if not math.isfinite(t):
        raise InputError(name, value, "a finite time in s")
    return t


# --------------------------------------------------------------------------------------------
# Meshes of one frame
# --------------------------------------------------------------------------------------------


def particle_mesh(
    positions, orientations, shape_ids, library: ShapeLibrary, *, velocities=None,
    angular_velocities=None, extra: Mapping[str, np.ndarray] | None = None,
    subdivisions: int = 1, as_points: bool = False,
) -> meshio.Mesh:
    """Particles of one frame as a meshio mesh (module docstring for the arrays written).

    Parameters
    ----------
    positions:
        (N, 3) centres of mass [m].
    orientations:
        (N, 4) unit quaternions (w, x, y, z), body -> world (|q| = 1 within 1e-6).
    shape_ids:
        (N,) integer rows of ``library``.
    library:
        The :class:`~grainlab.engine.state.ShapeLibrary` of the run.
    velocities, angular_velocities:
        (N, 3) [m/s] and world-frame [rad/s], written when given.
    extra:
        More per-particle arrays by name, each (N,) or (N, 3), finite (booleans are written
        as 0/1); names may not be those of :data:`PARTICLE_ARRAYS`.
    subdivisions:
        Icosphere level s in 0 .. 4: 20 4^s triangles per member sphere.
    as_points:
        One vertex cell per member sphere instead of its surface.
    """
    x = _float_rows("positions", positions, 3)
    n = x.shape[0]
    q = _unit_rows("orientations", orientations, 4, n, "a quaternion")
    ids = _int_rows("shape_ids", shape_ids, n)
    if not isinstance(library, ShapeLibrary):
        raise InputError("library", type(library).__name__, "a ShapeLibrary")
    bad = (ids < 0) | (ids >= library.n_shapes)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"shape_ids[{k}]", int(ids[k]),
                         f"a shape id in 0 .. {library.n_shapes - 1}")
    per_particle: dict[str, np.ndarray] = {}
    for name, field_name, value in (("velocity", "velocities", velocities),
                                    ("angular_velocity", "angular_velocities",
                                     angular_velocities)):
        if value is not None:
            per_particle[name] = _float_rows(field_name, value, 3, n)
    for name, value in (extra or {}).items():
        if not isinstance(name, str) or not name or name in PARTICLE_ARRAYS:
            raise InputError("extra", name,
                             "a non-empty array name other than " + ", ".join(PARTICLE_ARRAYS))
        array = np.asarray(value)
        columns = 3 if array.ndim == 2 else None
        if array.dtype == bool:
            per_particle[name] = _flag_rows(f"extra[{name!r}]", array, n)
        elif np.issubdtype(array.dtype, np.integer) and array.shape == (n,):
            per_particle[name] = array.astype(np.int64)
        else:
            per_particle[name] = _float_rows(f"extra[{name!r}]", array, columns, n)

    meshes = library_meshes(library, subdivisions, as_points)
    vertex_counts = np.diff(meshes.vertex_start)[ids]
    rows = concatenated_ranges(meshes.vertex_start[ids], vertex_counts)
    owner = np.repeat(np.arange(n, dtype=np.int64), vertex_counts)
    local = meshes.vertices[rows]
    rotations = quat_to_matrices(q) if n else np.zeros((0, 3, 3))
    points = np.empty_like(local)
    for lo in range(0, local.shape[0], _CHUNK):
        hi = min(lo + _CHUNK, local.shape[0])
        who = owner[lo:hi]
        points[lo:hi] = x[who] + np.einsum("vij,vj->vi", rotations[who], local[lo:hi])
    if as_points:
        cells = [meshio.CellBlock("vertex", np.arange(points.shape[0],
                                                      dtype=np.int64)[:, None])]
    else:
        triangle_counts = np.diff(meshes.triangle_start)[ids]
        first_vertex = offsets_from_counts(vertex_counts)[:-1]
        triangle_rows = concatenated_ranges(meshes.triangle_start[ids], triangle_counts)
        shift = np.repeat(first_vertex, triangle_counts)
        cells = [meshio.CellBlock("triangle", meshes.triangles[triangle_rows] + shift[:, None])]
        polygons = _polygon_cells(meshes, ids, first_vertex)
        if polygons:
            cells = [block for block in cells if len(block)] + polygons
    point_data = {
        "particle_id": owner, "shape_id": ids[owner], "member": meshes.member[rows],
        "radius": meshes.radius[rows],
    }
    for name, value in per_particle.items():
        point_data[name] = value[owner]
    return meshio.Mesh(points, cells, point_data=point_data)


def _polygon_cells(meshes, ids: np.ndarray, first_vertex: np.ndarray) -> list:
    """Polygon faces of the bodies of shapes ``ids`` (N,) whose vertices start at rows
    ``first_vertex`` (N,): one cell block per vertex count ("triangle", "quad", "polygon")."""
    counts = np.diff(meshes.polygon_start)[ids]
    if not counts.sum():
        return []
    rows = concatenated_ranges(meshes.polygon_start[ids], counts)
    starts = meshes.polygon_vertex_start
    sizes = starts[rows + 1] - starts[rows]
    flat = meshes.polygon_vertices[concatenated_ranges(starts[rows], sizes)]
    flat = flat + np.repeat(np.repeat(first_vertex, counts), sizes)
    offsets = offsets_from_counts(sizes)[:-1]
    blocks = []
    for size in np.unique(sizes):
        which = offsets[sizes == size]
        name = {3: "triangle", 4: "quad"}.get(int(size), "polygon")
        blocks.append(meshio.CellBlock(name, flat[which[:, None] + np.arange(size)]))
    return blocks


@dataclass(frozen=True, eq=False)
class ContactLines:
    """Contacts of one frame, one line each (module docstring for the arrays written).

    Attributes
    ----------
    start, end:
        (C, 3) end points of the lines [m]: the centres of bodies i and j, or for a wall
        contact the contact point and the centre of the body.
    force:
        (C, 3) contact force f [N] exerted on the end side (j) by the start side (i).
    normal:
        (C, 3) unit contact normal n from i to j; f . n > 0 is compression.
    type:
        Optional (C,) integers written as ``type`` (e.g. :data:`CONTACT_TYPE_PARTICLE`,
        :data:`CONTACT_TYPE_WALL`).
    sliding:
        Optional (C,) booleans written as ``sliding`` (0/1).
    contact_type:
        Optional (C,) polyhedron contact types written as ``contact_type`` (0 for
        sphere-based contacts, 1 fv, 2 ee, 3 fe, 4 ff:
        ``grainlab.engine.detect.narrow_phase.POLYHEDRON_CONTACT_TYPE_NAMES``).
    normal_force, tangential_force:
        Derived (C,) f_n = f . n and |f - f_n n| [N].
    """

    start: np.ndarray
    end: np.ndarray
    force: np.ndarray
    normal: np.ndarray
    type: np.ndarray | None = None
    sliding: np.ndarray | None = None
    contact_type: np.ndarray | None = None
    normal_force: np.ndarray = field(init=False, repr=False)
    tangential_force: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        start = _float_rows("contacts.start", self.start, 3)
        n = start.shape[0]
        arrays = {
            "start": start, "end": _float_rows("contacts.end", self.end, 3, n),
            "force": _float_rows("contacts.force", self.force, 3, n),
            "normal": _unit_rows("contacts.normal", self.normal, 3, n, "a normal"),
        }
        if self.type is not None:
            arrays["type"] = _int_rows("contacts.type", self.type, n)
        if self.sliding is not None:
            arrays["sliding"] = _flag_rows("contacts.sliding", self.sliding, n) == 1
        if self.contact_type is not None:
            arrays["contact_type"] = _int_rows("contacts.contact_type", self.contact_type, n)
        for name, value in arrays.items():
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        f_n = np.einsum("ci,ci->c", arrays["force"], arrays["normal"])
        f_t = np.linalg.norm(arrays["force"] - f_n[:, None] * arrays["normal"], axis=1)
        for name, value in (("normal_force", f_n), ("tangential_force", f_t)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @property
    def n_contacts(self) -> int:
        """Number of contacts C."""
        return int(self.start.shape[0])

    @classmethod
    def from_network(cls, net, plane_z: float = 0.0, thickness: float | None = None
                     ) -> ContactLines:
        """Contacts of a snapshot's :class:`~grainlab.analysis.contact_network.
        ContactNetwork`: one line per network point, from the centre of its pair's first
        particle along the pair's branch. A 2D network (discs, :mod:`grainlab.engine.planar`)
        is drawn in its plane z = ``plane_z`` [m], its forces per unit thickness times the
        discs' ``thickness`` [m] (forces per disc [N], as a 3D run's)."""
        from grainlab.engine.sample_measures import PAIR_TYPE_NAMES

        def lift(vectors: np.ndarray, z: float = 0.0) -> np.ndarray:
            if net.dimension == 3:
                return vectors
            return np.column_stack([vectors, np.full(vectors.shape[0], z)])

        start = lift(net.positions[net.pair_particles[net.point_pairs, 0]], plane_z)
        force = lift(net.point_forces) * (1.0 if net.dimension == 3 else thickness)
        polyhedra = net.pair_types is not None and net.type_names == PAIR_TYPE_NAMES
        return cls(start=start, end=start + lift(net.pair_branches[net.point_pairs]),
                   force=force, normal=lift(net.point_normals), sliding=net.point_sliding,
                   contact_type=net.pair_types[net.point_pairs] if polyhedra else None)

    @classmethod
    def from_step_report(cls, report: StepReport, positions, dt: float,
                         friction: float | np.ndarray | None = None,
                         cell_matrix=None) -> ContactLines:
        """Contacts of a :class:`~grainlab.engine.step_report.StepReport`.

        Forces are the step's impulses over ``dt`` [s] (the mean force of the step) in the
        world frame; lines join the body centres ``positions`` (N, 3) [m] (give the state
        after the step), or the contact point and the body centre for wall contacts (``type``
        :data:`CONTACT_TYPE_WALL`, others :data:`CONTACT_TYPE_PARTICLE`). With ``friction``
        (mu, one value or (C,)), ``sliding`` marks the contacts that carry load on the
        Coulomb cone, |f_T| >= (1 - 1e-6) mu f_n with f_n > 0. In a periodic cell h =
        ``cell_matrix`` [m] a line reaches the image of body j, x_j + h m.
        """
        try:
            step = float(dt)
        except (TypeError, ValueError):
            step = math.nan
        if not (math.isfinite(step) and step > 0.0):
            raise InputError("dt", dt, "a finite time step > 0 in s")
        x = _float_rows("positions", positions, 3)
        contacts = report.contacts
        on_wall = contacts.body_i < 0
        used = np.concatenate([contacts.body_i[~on_wall], contacts.body_j])
        if used.size and (used.min() < 0 or used.max() >= x.shape[0]):
            raise InputError("positions", f"array of shape {x.shape}",
                             "one row per body of the report's contacts")
        start = np.empty((contacts.n_contacts, 3))
        start[on_wall] = contacts.point[on_wall]
        start[~on_wall] = x[contacts.body_i[~on_wall]]
        from grainlab.engine.sample_measures import contact_types

        force = np.einsum("cji,cj->ci", report.frames, report.impulses) / step
        sliding = None
        if friction is not None:
            try:
                mu = np.broadcast_to(np.asarray(friction, dtype=np.float64), on_wall.shape)
            except (TypeError, ValueError):
                mu = np.full(on_wall.shape, np.nan)
            if not (np.isfinite(mu) & (mu >= 0.0)).all():
                raise InputError("friction", friction,
                                 f"one coefficient >= 0 or {on_wall.shape[0]}, finite")
            p_n = report.impulses[:, 0]
            p_t = np.hypot(report.impulses[:, 1], report.impulses[:, 2])
            sliding = (p_n > 0.0) & (p_t >= (1.0 - 1e-6) * mu * p_n)
        end = x[contacts.body_j]
        if cell_matrix is not None:
            end = end + report.image_vectors @ np.asarray(cell_matrix, dtype=np.float64).T
        lines = cls(
            start=start, end=end, force=force, normal=contacts.normal,
            type=np.where(on_wall, CONTACT_TYPE_WALL, CONTACT_TYPE_PARTICLE), sliding=sliding,
            contact_type=contact_types(contacts),
        )
        return lines.polyhedron_pairs_merged(contacts.body_i, contacts.body_j, contacts.point,
                                             mu=None if friction is None else mu)

    def polyhedron_pairs_merged(self, body_i, body_j, points, mu=None) -> ContactLines:
        """One line per body (or wall-body) pair of a polyhedron instead of one per contact
        point: the resultant force, the mean normal and, for a wall, the line from the
        force-weighted centre of the points (seed 002; :func:`grainlab.engine.
        sample_measures.pair_resultants`); sliding when |F_t| >= (1 - 1e-6) mu F_n > 0.
        Lines without ``contact_type`` > 0 are kept as they are."""
        from grainlab.engine.sample_measures import pair_resultants

        if self.contact_type is None or not np.any(self.contact_type > 0):
            return self
        poly = self.contact_type > 0
        keep = ~poly
        shift = np.asarray(body_i)[poly] + WALL_SHIFT  # walls -1 - w -> >= 0
        n = int(max(np.max(shift), np.max(np.asarray(body_j)[poly]))) + 1
        pairs, first, _, force, centre, normal = pair_resultants(
            shift, np.asarray(body_j)[poly], np.asarray(points)[poly], self.normal[poly],
            self.force[poly], n)
        wall = pairs[:, 0] < WALL_SHIFT
        rows = np.flatnonzero(poly)[first]
        start = self.start[rows].copy()
        start[wall] = centre[wall]
        sliding = None
        if self.sliding is not None:
            f_n = np.einsum("ci,ci->c", force, normal)
            f_t = np.linalg.norm(force - f_n[:, None] * normal, axis=1)
            limit = np.zeros_like(f_n) if mu is None else np.asarray(mu)[rows]
            sliding = np.concatenate([self.sliding[keep],
                                      (f_n > 0.0) & (f_t >= (1.0 - 1e-6) * limit * f_n)])
        merged = {
            "start": np.concatenate([self.start[keep], start]),
            "end": np.concatenate([self.end[keep], self.end[rows]]),
            "force": np.concatenate([self.force[keep], force]),
            "normal": np.concatenate([self.normal[keep], normal]),
            "type": None if self.type is None else np.concatenate([self.type[keep],
                                                                   self.type[rows]]),
            "contact_type": np.concatenate([self.contact_type[keep], self.contact_type[rows]]),
        }
        return ContactLines(sliding=sliding, **merged)


def contact_mesh(contacts: ContactLines) -> meshio.Mesh:
    """Contacts as a meshio mesh of C line cells over 2C points (points 2c, 2c + 1)."""
    if not isinstance(contacts, ContactLines):
        raise InputError("contacts", type(contacts).__name__, "a ContactLines")
    n = contacts.n_contacts
    points = np.stack([contacts.start, contacts.end], axis=1).reshape(-1, 3)
    lines = np.arange(2 * n, dtype=np.int64).reshape(n, 2)
    cell_data = {
        "normal_force": contacts.normal_force, "tangential_force": contacts.tangential_force,
        "force": contacts.force, "normal": contacts.normal,
    }
    if contacts.type is not None:
        cell_data["type"] = contacts.type
    if contacts.sliding is not None:
        cell_data["sliding"] = contacts.sliding.astype(np.uint8)
    if contacts.contact_type is not None:
        cell_data["contact_type"] = contacts.contact_type
    return meshio.Mesh(points, [meshio.CellBlock("line", lines)],
                       cell_data={name: [np.asarray(v)] for name, v in cell_data.items()})


@dataclass(frozen=True, eq=False)
class BoxWalls:
    """The six walls of the box [lower, upper] (module docstring for the arrays written).

    Attributes
    ----------
    lower, upper:
        (3,) corners [m], upper > lower.
    reactions:
        Optional (6,) normal forces of the particles on the walls [N] (compression positive),
        in the order of :data:`~grainlab.engine.boundaries.wall_box.WALL_NAMES`.
    """

    lower: np.ndarray
    upper: np.ndarray
    reactions: np.ndarray | None = None

    def __post_init__(self) -> None:
        lower = _float_rows("walls.lower", self.lower, None, 3)
        upper = _float_rows("walls.upper", self.upper, None, 3)
        if np.any(upper <= lower):
            raise InputError("walls.upper", upper.tolist(),
                             f"three coordinates in m above lower = {lower.tolist()}")
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        if self.reactions is not None:
            object.__setattr__(self, "reactions",
                               _float_rows("walls.reactions", self.reactions, None, 6))

    @classmethod
    def from_wall_box(cls, box: WallBox) -> BoxWalls:
        """The walls of a :class:`~grainlab.engine.boundaries.wall_box.WallBox` now, with the
        reactions
        of its last step."""
        return cls(lower=box.lower, upper=box.upper, reactions=np.array(box.reactions))


def wall_mesh(walls: BoxWalls) -> meshio.Mesh:
    """The box as a meshio mesh of six quads over its eight corners (corner 4 k + 2 j + i at
    (x_i, y_j, z_k) with index 0 for lower, 1 for upper)."""
    if not isinstance(walls, BoxWalls):
        raise InputError("walls", type(walls).__name__, "a BoxWalls")
    bounds = np.stack([walls.lower, walls.upper])  # (2, 3)
    bits = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)])
    points = bounds[bits, np.arange(3)]
    quads = np.empty((6, 4), dtype=np.int64)
    normals = np.zeros((6, 3))
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]  # counter-clockwise in the (u, v) plane
    for w, name in enumerate(WALL_NAMES):
        axis, side = "xyz".index(name[0]), "-+".index(name[1])
        u, v = (axis + 1) % 3, (axis + 2) % 3  # e_u x e_v = e_axis
        corner = []
        for a, b in square if side == 0 else square[::-1]:
            index = np.zeros(3, dtype=np.int64)
            index[axis], index[u], index[v] = side, a, b
            corner.append(index[0] + 2 * index[1] + 4 * index[2])
        quads[w] = corner
        normals[w, axis] = 1.0 if side == 0 else -1.0
    cell_data = {"wall": np.arange(6, dtype=np.int64), "normal": normals}
    if walls.reactions is not None:
        cell_data["reaction"] = walls.reactions
    return meshio.Mesh(points, [meshio.CellBlock("quad", quads)],
                       cell_data={name: [np.asarray(v)] for name, v in cell_data.items()})


# --------------------------------------------------------------------------------------------
# Files: frames and ParaView collections
# --------------------------------------------------------------------------------------------


def frame_file_name(kind: str, frame_index: int) -> str:
    """``<kind>_<frame_index:06d>.vtu`` for a kind of :data:`FILE_KINDS`."""
    if kind not in FILE_KINDS:
        raise InputError("kind", kind, "one of " + ", ".join(FILE_KINDS))
    return f"{kind}_{_frame_index(frame_index):06d}.vtu"


def _write_mesh(path: Path, mesh: meshio.Mesh) -> None:
    empty = len(mesh.points) == 0 or sum(len(block) for block in mesh.cells) == 0
    meshio.write(path, mesh, file_format="vtu", binary=True,
                 compression=None if empty else "zlib")


def write_pvd(path: str | os.PathLike, datasets: Sequence[tuple[float, str]]) -> Path:
    """Write the ParaView collection ``path`` listing ``datasets``, (time [s], file name
    relative to the collection's folder) in the order given; replaces the file atomically.

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     index = write_pvd(Path(folder) / "a.pvd", [(0.0, "a_0.vtu"), (0.5, "a_1.vtu")])
    ...     [(t, p.name) for t, p in read_pvd(index)]
    [(0.0, 'a_0.vtu'), (0.5, 'a_1.vtu')]
    """
    path = Path(path)
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    collection = ET.SubElement(root, "Collection")
    for k, (time, name) in enumerate(datasets):
        t = _time(time, f"datasets[{k}] time")
        ET.SubElement(collection, "DataSet", timestep=repr(t), group="", part="0",
                      file=Path(name).as_posix())
    ET.indent(root)
    temporary = path.with_name(path.name + ".tmp")
    ET.ElementTree(root).write(temporary, encoding="utf-8", xml_declaration=True)
    os.replace(temporary, path)
    return path


def read_pvd(path: str | os.PathLike) -> list[tuple[float, Path]]:
    """The (time [s], file path) entries of the ParaView collection ``path``, in file order;
    paths are resolved against the collection's folder."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as error:
        raise InputError("path", str(path), f"a readable .pvd collection ({error})") from None
    collection = root.find("Collection")
    if root.tag != "VTKFile" or root.get("type") != "Collection" or collection is None:
        raise InputError("path", str(path), "a VTKFile of type Collection")
    return [(float(item.get("timestep", "nan")), path.parent / item.get("file", ""))
            for item in collection.iter("DataSet")]


def _frames_listed(path: Path, kind: str) -> dict[int, float]:
    """Frame index -> time of the frames of ``kind`` in the collection ``path`` (if any)."""
    if not path.exists():
        return {}
    pattern = re.compile(rf"{kind}_(\d+)\.vtu")
    frames = {}
    for time, file in read_pvd(path):
        match = pattern.fullmatch(file.name)
        if match:
            frames[int(match.group(1))] = time
    return frames


def _write_index(directory: Path, kind: str, frames: Mapping[int, float]) -> Path:
    return write_pvd(directory / f"{kind}.pvd",
                     [(frames[k], frame_file_name(kind, k)) for k in sorted(frames)])


def _write_frame_files(
    directory: Path, frame_index: int, *, positions, orientations, shape_ids,
    library: ShapeLibrary, contacts: ContactLines | None, walls: BoxWalls | None,
    velocities, angular_velocities, extra, subdivisions: int, as_points: bool,
) -> dict[str, Path]:
    meshes = {"particles": particle_mesh(
        positions, orientations, shape_ids, library, velocities=velocities,
        angular_velocities=angular_velocities, extra=extra, subdivisions=subdivisions,
        as_points=as_points)}
    if contacts is not None:
        meshes["contacts"] = contact_mesh(contacts)
    if walls is not None:
        meshes["walls"] = wall_mesh(walls)
    directory.mkdir(parents=True, exist_ok=True)
    files = {}
    for kind, mesh in meshes.items():
        files[kind] = directory / frame_file_name(kind, frame_index)
        _write_mesh(files[kind], mesh)
    return files


def write_vtk_frame(
    directory: str | os.PathLike, frame_index: int, time: float, *, positions, orientations,
    shape_ids, library: ShapeLibrary, contacts: ContactLines | None = None,
    walls: BoxWalls | None = None, velocities=None, angular_velocities=None,
    extra: Mapping[str, np.ndarray] | None = None, subdivisions: int = 1,
    as_points: bool = False,
) -> dict[str, Path]:
    """Write frame ``frame_index`` (>= 0) at ``time`` [s] into ``directory`` (created if
    needed) and list it in ``<kind>.pvd``, replacing an entry of the same frame.

    Particles are always written (:func:`particle_mesh` for the arguments, shapes and
    units); contacts (:class:`ContactLines`) and walls (:class:`BoxWalls`) when given.
    Returns the paths of the ``.vtu`` files written by kind (``"particles"``,
    ``"contacts"``, ``"walls"``). All inputs are checked before any file is written.
    """
    directory = Path(directory)
    frame_index, time = _frame_index(frame_index), _time(time)
    files = _write_frame_files(
        directory, frame_index, positions=positions, orientations=orientations,
        shape_ids=shape_ids, library=library, contacts=contacts, walls=walls,
        velocities=velocities, angular_velocities=angular_velocities, extra=extra,
        subdivisions=subdivisions, as_points=as_points)
    for kind in files:
        frames = _frames_listed(directory / f"{kind}.pvd", kind)
        frames[frame_index] = time
        _write_index(directory, kind, frames)
    return files


class VtkSeries:
    """Frames 0, 1, 2, ... of one run in ``directory``, with the ``.pvd`` indexes rewritten
    after every frame (so an interrupted run stays openable).

    The static model (``library``, ``subdivisions``, ``as_points``) is fixed at construction;
    :meth:`add_frame` takes the changing state (:func:`particle_mesh` for shapes and units).
    A new series replaces the ``.pvd`` indexes already in ``directory`` (older ``.vtu``
    files stay until overwritten), unless ``continue_until`` [s] is given: then the frames
    listed up to that time are kept and numbering goes on after them (a resumed run). Use it
    as a context manager or call :meth:`close`.

    >>> import tempfile
    >>> from grainlab.engine.state import BodyState, ShapeLibrary
    >>> library = ShapeLibrary.from_spheres([0.5])
    >>> state = BodyState.from_library(library, [0], [[0.0, 0.0, 0.5]], density=1000.0)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     with VtkSeries(folder, library, as_points=True) as series:
    ...         for k in range(3):
    ...             files = series.add_state(0.1 * k, state)
    ...     times = [t for t, _ in read_pvd(Path(folder) / "particles.pvd")]
    >>> series.n_frames, times
    (3, [0.0, 0.1, 0.2])
    """

    def __init__(self, directory: str | os.PathLike, library: ShapeLibrary, *,
                 subdivisions: int = 1, as_points: bool = False,
                 continue_until: float | None = None) -> None:
        if not isinstance(library, ShapeLibrary):
            raise InputError("library", type(library).__name__, "a ShapeLibrary")
        self.directory = Path(directory)
        self.library = library
        self.subdivisions = check_subdivisions(subdivisions)
        self.as_points = bool(as_points)
        self._frames: dict[str, dict[int, float]] = {kind: {} for kind in FILE_KINDS}
        self._closed = False
        self.directory.mkdir(parents=True, exist_ok=True)
        for kind in FILE_KINDS:
            index = self.directory / f"{kind}.pvd"
            if continue_until is not None:
                # a resumed run: keep the frames written up to its checkpoint time
                limit = _time(continue_until, "continue_until")
                self._frames[kind] = {k: t for k, t in _frames_listed(index, kind).items()
                                      if t <= limit}
            else:
                index.unlink(missing_ok=True)

    @property
    def n_frames(self) -> int:
        """Number of frames written so far."""
        return len(self._frames["particles"])

    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._closed

    def add_frame(
        self, time: float, *, positions, orientations, shape_ids,
        contacts: ContactLines | None = None, walls: BoxWalls | None = None,
        velocities=None, angular_velocities=None,
        extra: Mapping[str, np.ndarray] | None = None,
    ) -> dict[str, Path]:
        """Write the next frame at ``time`` [s]; returns its ``.vtu`` paths by kind."""
        if self._closed:
            raise InputError("VtkSeries", "closed", "a series that is still open")
        time = _time(time)
        frame = max(self._frames["particles"], default=-1) + 1
        files = _write_frame_files(
            self.directory, frame, positions=positions, orientations=orientations,
            shape_ids=shape_ids, library=self.library, contacts=contacts, walls=walls,
            velocities=velocities, angular_velocities=angular_velocities, extra=extra,
            subdivisions=self.subdivisions, as_points=self.as_points)
        for kind in files:
            self._frames[kind][frame] = time
            _write_index(self.directory, kind, self._frames[kind])
        return files

    def add_state(
        self, time: float, state: BodyState, *, contacts: ContactLines | None = None,
        walls: BoxWalls | None = None, extra: Mapping[str, np.ndarray] | None = None,
    ) -> dict[str, Path]:
        """:meth:`add_frame` from a :class:`~grainlab.engine.state.BodyState` (positions,
        orientations, shape ids, velocities and angular velocities)."""
        return self.add_frame(
            time, positions=state.positions, orientations=state.orientations,
            shape_ids=state.shape_ids, contacts=contacts, walls=walls,
            velocities=state.velocities, angular_velocities=state.angular_velocities,
            extra=extra)

    def close(self) -> None:
        """Rewrite the indexes one last time and refuse further frames."""
        if not self._closed:
            for kind, frames in self._frames.items():
                if frames:
                    _write_index(self.directory, kind, frames)
            self._closed = True

    def __enter__(self) -> VtkSeries:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()
