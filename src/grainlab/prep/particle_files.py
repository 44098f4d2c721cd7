"""Samples read from files: every particle's own geometry, in world coordinates [m].

A particle file lists points, each of one particle (seeds 002/003 prepare their samples
themselves; a user may bring a packing made elsewhere, e.g. exported from LMGC90 or YADE, or
one grainlab wrote). Each point names its particle's kind, a name of the registry
:data:`~grainlab.engine.shape_kinds.SHAPE_KINDS`, whose narrow-phase family says what the
points are:

- a ``sphere``: one point, its centre, with its radius;
- a kind of the member-sphere family (an ``aggregate``, seed 003): one point per member
  sphere, its centre, with its radius;
- a kind of the polyhedron family (a ``polyhedron``, seed 002): one point per vertex (radius
  0 or empty); the particle is the convex hull of its vertices (qhull).

A particle read back keeps its kind's code (a kind written is the kind read).

grainlab finds each particle's centre of mass, principal axes and mass properties from this
geometry (:meth:`~grainlab.geometry.polyhedron.ConvexPolyhedron.from_vertices`,
:meth:`~grainlab.geometry.sphere_aggregate.SphereAggregate.from_spheres`): the body sits at
its centre of mass, oriented by its principal axes, at rest. Kinds of one family may be
mixed in one file (spheres and aggregates); kinds of the two families may not (polyhedra
are not paired with sphere-based particles here). The box of walls is the file's own
(``lower`` and ``upper`` corners) or, when it gives none, the particles' extent (walls
touching the outermost particles).

Two formats, by suffix:

- ``.csv``: a header ``particle,kind,x,y,z,radius`` and one row per point; ``particle`` is any
  integer naming the particle (its rows need not be consecutive; particles keep the order of
  their first row); two optional rows of kind ``lower`` and ``upper`` (``particle`` -1, no
  radius) give the box corners;
- ``.npz`` (NumPy): arrays ``particle`` (M,) int, ``kind`` (M,) str, ``points`` (M, 3) [m],
  ``radii`` (M,) [m], optionally ``lower`` and ``upper`` (3,) [m].

:func:`write_particles` writes any sample in either format (world coordinates of its current
configuration), so that a sample prepared once, by grainlab or by hand, can be read back
(:func:`read_particles`) and tested many times.

>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> _ = (folder / "two.csv").write_text(
...     "particle,kind,x,y,z,radius\\n0,sphere,0,0,1e-3,1e-3\\n1,sphere,0,0,3e-3,1e-3\\n")
>>> sample = read_particles(folder / "two.csv")
>>> sample.state.n_bodies, sample.box.lengths.round(6).tolist()
(2, [0.002, 0.002, 0.004])
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from grainlab._validate import at_least
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.quaternion import quat_to_matrices
from grainlab.engine.shape_kinds import POLYHEDRON_FEATURES, SPHERE, ShapeKind, shape_kind
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import ConvexPolyhedron
from grainlab.geometry.sphere_aggregate import SphereAggregate

CSV_COLUMNS = ("particle", "kind", "x", "y", "z", "radius")
"""The header of a particle CSV file (coordinates and radii in metres)."""

BOX_ROWS = ("lower", "upper")
"""The kinds of the two optional rows that give the box corners."""


def read_particles(path: str | Path, *, density: float = 2600.0, wall_friction: float = 0.0,
                   field: str = "particle file") -> DiscreteSample:
    """The sample of the particle file ``path`` (module docstring) at rest in its box of
    walls; ``density`` [kg/m^3] and ``wall_friction`` as
    :func:`~grainlab.prep.inscribed_sample.inscribed_sample`. Errors name ``field``."""
    path = Path(path)
    if not path.is_file():
        raise InputError(field, str(path), "an existing .csv or .npz particle file")
    if path.suffix == ".npz":
        rows = _npz_rows(path, field)
    elif path.suffix == ".csv":
        rows = _csv_rows(path, field)
    else:
        raise InputError(field, str(path), "a .csv or .npz particle file")
    return _sample(rows, density=at_least("density", density),
                   wall_friction=at_least("wall_friction", wall_friction, strict=False),
                   where=f"{field} {path}")


def write_particles(sample: DiscreteSample, path: str | Path) -> Path:
    """Write ``sample`` (a box of walls) as a particle file (``.csv`` or ``.npz``, module
    docstring): each particle's points in world coordinates of its configuration now."""
    path = Path(path)
    if path.suffix not in (".csv", ".npz"):
        raise InputError("path", str(path), "a file name ending in .csv or .npz")
    if not isinstance(sample.boundary, WallBox):  # the file keeps a box's two corners
        raise InputError("sample.boundary", type(sample.boundary).__name__,
                         "a box of walls (a WallBox or a box derived from it: the file keeps "
                         "its corners, which a periodic cell or another boundary has not)")
    particle, kind, points, radii = _world_points(sample.library, sample.state)
    vertices = {name for name in set(kind) if not shape_kind(name).has_member_spheres}
    lower, upper = sample.boundary.lower, sample.boundary.upper
    if path.suffix == ".npz":
        np.savez(path, particle=particle, kind=np.array(kind), points=points, radii=radii,
                 lower=lower, upper=upper)
        return path
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(CSV_COLUMNS)
        for p, k, x, r in zip(particle, kind, points, radii, strict=True):
            writer.writerow([int(p), k, *(repr(float(c)) for c in x),
                             "" if k in vertices else repr(float(r))])
        for name, corner in zip(BOX_ROWS, (lower, upper), strict=True):
            writer.writerow([-1, name, *(repr(float(c)) for c in corner), ""])
    return path


# --------------------------------------------------------------------------------------------
# Reading: rows (particle, kind, point, radius) -> sample
# --------------------------------------------------------------------------------------------


class _Rows:
    """The file's points (M,) with the box corners set apart (None when not given)."""

    def __init__(self, particle, kind, points, radii, lower=None, upper=None) -> None:
        self.particle, self.kind = particle, kind
        self.points, self.radii = points, radii
        self.lower, self.upper = lower, upper


def _number(text: str, where: str, column: str, allow_empty: bool = False) -> float:
    text = text.strip()
    if allow_empty and text == "":
        return 0.0
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{where}: {column}", text, "a number") from None
    if not np.isfinite(value):
        raise InputError(f"{where}: {column}", text, "a finite number")
    return value


def _csv_rows(path: Path, field: str) -> _Rows:
    with path.open(newline="") as handle:
        reader = csv.reader(handle)
        header = [h.strip() for h in next(reader, [])]
        if tuple(header) != CSV_COLUMNS:
            raise InputError(f"{field} {path}: header", ",".join(header),
                             ",".join(CSV_COLUMNS))
        particle, kind, points, radii, box = [], [], [], [], {}
        for line, row in enumerate(reader, start=2):
            if not row or all(not cell.strip() for cell in row):
                continue
            where = f"{field} {path}, line {line}"
            if len(row) != len(CSV_COLUMNS):
                raise InputError(where, ",".join(row), f"{len(CSV_COLUMNS)} columns: "
                                 + ",".join(CSV_COLUMNS))
            name = row[1].strip()
            point = [_number(row[k], where, CSV_COLUMNS[k]) for k in (2, 3, 4)]
            if name in BOX_ROWS:
                box[name] = np.array(point)
                continue
            try:
                particle.append(int(row[0]))
            except ValueError:
                raise InputError(f"{where}: particle", row[0], "an integer") from None
            kind.append(name)
            points.append(point)
            radii.append(_number(row[5], where, "radius", allow_empty=True))
    return _Rows(np.array(particle, dtype=np.int64), kind,
                 np.array(points, dtype=np.float64).reshape(-1, 3), np.array(radii),
                 box.get("lower"), box.get("upper"))


def _npz_rows(path: Path, field: str) -> _Rows:
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except (OSError, ValueError) as error:
        raise InputError(field, str(path), f"a readable .npz file ({error})") from None
    missing = [n for n in ("particle", "kind", "points", "radii") if n not in arrays]
    if missing:
        raise InputError(f"{field} {path}", "arrays " + ", ".join(sorted(arrays)),
                         "arrays particle, kind, points, radii (lower, upper optional); "
                         "missing " + ", ".join(missing))
    points = np.asarray(arrays["points"], dtype=np.float64)
    m = points.shape[0] if points.ndim == 2 and points.shape[1] == 3 else -1
    for name, shape in (("particle", (m,)), ("kind", (m,)), ("radii", (m,))):
        if m < 0 or np.shape(arrays[name]) != shape:
            raise InputError(f"{field} {path}: {name}", f"shape {np.shape(arrays[name])}",
                             f"one entry per row of points (M, 3), points {points.shape}")
    corners = {}
    for name in BOX_ROWS:
        if name in arrays:
            corner = np.asarray(arrays[name], dtype=np.float64)
            if corner.shape != (3,):
                raise InputError(f"{field} {path}: {name}", f"shape {corner.shape}", "(3,)")
            corners[name] = corner
    return _Rows(np.asarray(arrays["particle"]).astype(np.int64),
                 [str(k) for k in arrays["kind"]], points,
                 np.asarray(arrays["radii"], dtype=np.float64),
                 corners.get("lower"), corners.get("upper"))


def _sample(rows: _Rows, *, density: float, wall_friction: float, where: str
            ) -> DiscreteSample:
    if rows.points.shape[0] == 0:
        raise InputError(where, "no particle", "at least one particle")
    if not np.all(np.isfinite(rows.points)) or not np.all(np.isfinite(rows.radii)):
        raise InputError(where, "non-finite coordinates or radii", "finite numbers in m")
    # rows grouped by particle (stable: each particle's rows in file order), the particles
    # in the order of their first row; linear in the rows after one sort
    ids, first, inverse = np.unique(rows.particle, return_index=True, return_inverse=True)
    by_particle = np.argsort(inverse, kind="stable")
    bounds = np.concatenate([[0], np.cumsum(np.bincount(inverse, minlength=ids.size))])
    shapes, kinds = [], []
    congruent = _CongruentAggregates()
    for k in np.argsort(first):
        pid, mine = ids[k], by_particle[bounds[k]:bounds[k + 1]]
        label = f"{where}: particle {pid}"
        kind = _kind_of_rows({rows.kind[i] for i in mine}, label)
        shapes.append(_shape(kind, rows.points[mine], rows.radii[mine], label, congruent))
        kinds.append(kind)
    families = {kind.narrow_phase for kind in kinds}
    if len(families) > 1:
        raise InputError(f"{where}: kind", ", ".join(sorted({k.name for k in kinds})),
                         "kinds of one narrow-phase family: polyhedra alone, or spheres and "
                         "aggregates (polyhedra are not paired with sphere-based particles)")
    library, positions, rotations = _library(shapes, kinds)
    lower, upper = _box(rows, library, where)
    orientations = Rotation.from_matrix(rotations).as_quat()[:, [3, 0, 1, 2]]  # w first
    state = BodyState.from_library(library, np.arange(len(shapes)), positions, density,
                                   orientations)
    _check_inside(rows, float(library.bounding_radius.max()), lower, upper, where)
    box = WallBox(lower, upper, friction=wall_friction)
    box.set_masses(float(np.sum(state.masses)))
    diameters = 2.0 * library.bounding_radius
    shape = kinds[0].name if len(set(kinds)) == 1 else "mixed"
    description = {"shape": shape, "n_particles": len(shapes),
                   "d_min": float(diameters.min()), "d_max": float(diameters.max()),
                   "density": density, "preparation": "file"}
    if families == {POLYHEDRON_FEATURES}:
        description["mean_angularity"] = float(np.mean([p.angularity for p in shapes]))
    return DiscreteSample(library, state, box, description)


def _kind_of_rows(names: set[str], label: str) -> ShapeKind:
    """The registered kind named by every row of one particle (``names``, the names its
    rows give); an InputError naming ``label``'s kind for none, several or an unknown one."""
    try:
        return shape_kind(next(iter(names)) if len(names) == 1 else None, f"{label} kind")
    except InputError as error:
        raise InputError(f"{label} kind", ", ".join(sorted(names)),
                         f"{error.allowed}, one for all its rows") from None


def _shape(kind: ShapeKind, points: np.ndarray, radii: np.ndarray, label: str,
           congruent: _CongruentAggregates):
    """The shape of one particle of ``kind`` from its world points: a sphere (centre,
    radius), member spheres (a :class:`SphereAggregate`; ``congruent`` finds a copy of one
    already made) or a polyhedron (their body frame, rotation and centre of mass)."""
    if not kind.has_member_spheres:
        if points.shape[0] < 4:
            raise InputError(f"{label} vertices", points.shape[0],
                             "at least 4 vertices, not all in one plane")
        try:
            return ConvexPolyhedron.from_vertices(points, name=label)
        except InputError as error:  # e.g. coplanar vertices: name the particle
            raise InputError(f"{label} vertices", error.value, error.allowed) from None
    if np.any(radii <= 0.0):
        raise InputError(f"{label} radius", float(radii.min()), "positive radii in m")
    if kind == SPHERE:
        if points.shape[0] != 1:
            raise InputError(f"{label} rows", points.shape[0],
                             "one row (its centre and radius) for a sphere")
        return (points[0], float(radii[0]))
    try:
        return congruent.aggregate(points, radii, label)
    except InputError as error:
        raise InputError(f"{label} {error.field}", error.value, error.allowed) from None


class _CongruentAggregates:
    """Aggregates made once per shape: the union's mass properties take a quadrature
    (~30 ms an aggregate), and a file of N copies of one shape in N sizes and orientations
    (as grainlab writes them) would take N of them. An aggregate whose member radii and
    member-to-member distances (in file order), over its largest radius, match one already
    made to 1e-10 is that one scaled by the ratio f of the largest radii and moved rigidly:
    the rotation Q and translation that carry the first copy's centres, scaled about their
    mean, onto its own (Kabsch, a proper rotation, every centre within 1e-10 of its size)
    give its frame (Q R) and centre of mass; its volume scales as f^3 and its moments as
    f^5. Else it is made anew."""

    def __init__(self) -> None:
        self.made: dict[tuple, tuple[np.ndarray, float, SphereAggregate]] = {}

    def aggregate(self, points: np.ndarray, radii: np.ndarray, label: str) -> SphereAggregate:
        size = float(np.max(radii))
        offsets = points[:, None, :] - points[None, :, :]
        distances = np.sqrt(np.sum(offsets * offsets, axis=2))
        key = (points.shape[0], tuple(np.round(radii / size * 1e10).astype(np.int64)),
               tuple(np.round(distances.ravel() / size * 1e10).astype(np.int64)))
        found = self.made.get(key)
        if found is not None:
            first, first_size, shape = found
            f = size / first_size
            mean = first.mean(axis=0)
            turn = _rotation_onto(f * (first - mean), points, 1e-10 * size)
            if turn is not None:
                return SphereAggregate(f * shape.centres, f * shape.radii, f**3 * shape.volume,
                                       f**5 * shape.principal_moments, turn @ shape.rotation,
                                       points.mean(axis=0)
                                       + f * turn @ (shape.centre_of_mass - mean), label)
        shape = SphereAggregate.from_spheres(points, radii, name=label)
        self.made.setdefault(key, (points.copy(), size, shape))
        return shape


def _rotation_onto(centred: np.ndarray, points: np.ndarray, tolerance: float
                   ) -> np.ndarray | None:
    """The proper rotation Q with points = mean(points) + centred Q^T to ``tolerance`` [m]
    on every point (Kabsch; ``centred`` has zero mean), or None."""
    mean = points.mean(axis=0)
    u, _, vt = np.linalg.svd(centred.T @ (points - mean))
    turn = vt.T @ u.T
    if np.linalg.det(turn) < 0.0:
        return None
    if np.max(np.abs(centred @ turn.T + mean - points)) > tolerance:
        return None
    return turn


def _library(shapes: list, kinds: list[ShapeKind]
             ) -> tuple[ShapeLibrary, np.ndarray, np.ndarray]:
    """The library (one shape per particle, in file order, each of its kind's code), the
    centres of mass (N, 3) [m] and the body-to-world rotations (N, 3, 3)."""
    n = len(shapes)
    positions, rotations = np.empty((n, 3)), np.tile(np.eye(3), (n, 1, 1))
    parts = []  # runs of consecutive particles of one kind, concatenated in order
    start = 0
    while start < n:
        stop, kind = start, kinds[start]
        while stop < n and kinds[stop] == kind:
            stop += 1
        run = shapes[start:stop]
        if kind == SPHERE:
            positions[start:stop] = [centre for centre, _ in run]
            parts.append(ShapeLibrary.from_spheres(np.array([r for _, r in run])))
            start = stop
            continue
        for k, shape in enumerate(run, start=start):
            positions[k], rotations[k] = shape.centre_of_mass, shape.rotation
        parts.append(ShapeLibrary.from_aggregates(run, kind) if kind.has_member_spheres
                     else ShapeLibrary.from_polyhedra(run, kind))
        start = stop
    library = parts[0]
    for part in parts[1:]:
        library = library.concatenate(part)
    return library, positions, rotations


def _box(rows: _Rows, library: ShapeLibrary, where: str) -> tuple[np.ndarray, np.ndarray]:
    """The file's box, or the extent of its particles' points (spheres with their radii)."""
    if (rows.lower is None) != (rows.upper is None):
        raise InputError(f"{where}: box", "one corner", "both lower and upper, or neither")
    if rows.lower is not None:
        if np.any(rows.upper <= rows.lower):
            raise InputError(f"{where}: box", (rows.lower.tolist(), rows.upper.tolist()),
                             "lower < upper on every axis")
        return rows.lower.copy(), rows.upper.copy()
    reach = rows.radii[:, None]
    return (np.min(rows.points - reach, axis=0), np.max(rows.points + reach, axis=0))


def _check_inside(rows: _Rows, largest: float, lower: np.ndarray, upper: np.ndarray,
                  where: str) -> None:
    """Every point of the file (with its radius) inside the box, to 1e-9 of the largest
    particle's circumscribed radius ``largest`` [m]."""
    slack = 1e-9 * largest
    reach = rows.radii[:, None]
    out = np.any(rows.points - reach < lower - slack, axis=1) | \
        np.any(rows.points + reach > upper + slack, axis=1)
    if np.any(out):
        raise InputError(f"{where}: box", (lower.tolist(), upper.tolist()),
                         f"a box holding every particle ({int(np.sum(out))} point(s) "
                         "outside)")


def _world_points(library: ShapeLibrary, state: BodyState
                  ) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray]:
    """(particle (M,), kind (M,), points (M, 3) [m], radii (M,) [m]) of every body in world
    coordinates: member spheres of sphere-based bodies, vertices of polyhedra."""
    rotations = quat_to_matrices(state.orientations)
    particle, kind, points, radii = [], [], [], []
    for b in range(state.n_bodies):
        s = int(state.shape_ids[b])
        shape = shape_kind(int(library.kind[s]), f"library.kind[{s}]")
        if not shape.has_member_spheres:
            start, count = int(library.vertex_start[s]), int(library.vertex_count[s])
            local, r = library.vertices[start:start + count], np.zeros(count)
        else:
            start, count = int(library.sphere_start[s]), int(library.sphere_count[s])
            local = library.sphere_offsets[start:start + count]
            r = library.sphere_radii[start:start + count]
        points.append(state.positions[b] + local @ rotations[b].T)
        radii.append(r)
        particle += [b] * count
        kind += [shape.name] * count
    return (np.array(particle, dtype=np.int64), kind, np.concatenate(points),
            np.concatenate(radii))
