"""Static shape library and changing body state, as structure-of-arrays (STYLE.md 1).

:class:`ShapeLibrary` is the static model: one row per shape, frozen for a run. Every shape
carries a ``kind`` code (a :class:`~grainlab.engine.shape_kinds.ShapeKind` of the registry
:mod:`grainlab.engine.shape_kinds`) and its mass properties per unit density. Sphere-based
shapes (spheres and aggregates) list their member spheres in concatenated arrays
``sphere_offsets`` (M, 3) [m] (body frame: origin at the centre of mass, axes along the
principal axes) and ``sphere_radii`` (M,) [m]; shape s owns rows
``sphere_start[s] .. sphere_start[s] + sphere_count[s] - 1``. A sphere is a one-member shape
with a zero offset, so the narrow phase treats spheres and aggregates alike.

A convex polyhedron (seed 002; the kinds of the narrow-phase family
:data:`~grainlab.engine.shape_kinds.POLYHEDRON_FEATURES`) has no member sphere
(``sphere_count`` 0); its boundary is stored in concatenated arrays, body frame, local vertex
ids (0 .. vertex_count - 1):

- ``vertices`` (V, 3) [m], rows ``vertex_start[s] ..`` (``vertex_count[s]`` rows);
- planar polygon faces, rows ``face_start[s] ..`` (``face_count[s]``) of ``face_normals``
  (F, 3) (outward, unit) and ``face_offsets`` (F,) [m] (n . v for the face's vertices); face f
  lists its vertices counter-clockwise seen from outside in
  ``face_vertices[face_vertex_start[f]:face_vertex_start[f + 1]]`` (CSR, (F + 1,) and (K,));
- ``edges`` (E, 2) (each edge of the solid once), rows ``edge_start[s] ..`` (``edge_count[s]``),
  and ``edge_faces`` (E, 2): the local ids of the two faces sharing each edge;
- ``vertex_neighbour_start`` (V + 1,) CSR into ``vertex_neighbours`` (2E,): the local ids of
  the vertices joined to each vertex by an edge (hill-climbing supports).

Spheres and aggregates have empty ranges there (count 0).

:class:`BodyState` is what changes: positions x (N, 3) [m] of the centres of mass, unit
quaternions q (N, 4) (w first; body -> world, :mod:`grainlab.engine.quaternion`), velocities
v (N, 3) [m/s], angular velocities omega (N, 3) [rad/s] in the world frame, masses m (N,) [kg],
principal inertias I (N, 3) [kg m^2], shape ids (N,), and the density [kg/m^3].

Kinetic energy, momentum and angular momentum about the origin:

    E = sum_i 1/2 m_i |v_i|^2 + 1/2 omega_i . (R_i diag(I_i) R_i^T) omega_i    [J]
    p = sum_i m_i v_i                                                         [kg m/s]
    L = sum_i m_i x_i x v_i + R_i diag(I_i) R_i^T omega_i                     [kg m^2/s]

>>> import numpy as np
>>> library = ShapeLibrary.from_spheres([0.5])
>>> state = BodyState.from_library(library, [0, 0], [[0, 0, 0], [2, 0, 0]], density=1000.0)
>>> state.velocities[0] = [1.0, 0.0, 0.0]
>>> round(float(state.kinetic_energy() / (0.5 * state.masses[0])), 12)
1.0
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainlab._numba_setup import kernel_input
from grainlab.engine.planar import check_planar
from grainlab.engine.quaternion import quat_to_matrices
from grainlab.engine.shape_kinds import (
    AGGREGATE,
    DISC,
    MEMBER_SPHERES,
    POLYHEDRON,
    POLYHEDRON_FEATURES,
    SPHERE,
    ShapeKind,
    family_mask,
    kinds_of_family,
    kinds_present,
    shape_kind,
)
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import ConvexPolyhedron
from grainlab.geometry.sphere_aggregate import SphereAggregate

_UNIT_TOLERANCE = 1e-8  # |1 - |q|| accepted for a unit quaternion
_PLANE_TOLERANCE = 1e-9  # relative: vertices may lie this far (x circumradius) outside a face

_POLYHEDRON_FIELDS = {
    "vertex_start": (np.int64, 1), "vertex_count": (np.int64, 1),
    "vertices": (np.float64, 3), "face_start": (np.int64, 1), "face_count": (np.int64, 1),
    "face_normals": (np.float64, 3), "face_offsets": (np.float64, 1),
    "face_vertex_start": (np.int64, 1), "face_vertices": (np.int64, 1),
    "edge_start": (np.int64, 1), "edge_count": (np.int64, 1), "edges": (np.int64, 2),
    "edge_faces": (np.int64, 2),
    "vertex_neighbour_start": (np.int64, 1), "vertex_neighbours": (np.int64, 1),
}


def _readonly(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array)
    array.setflags(write=False)
    return array


class ReadOnlyArrays:
    """The arrays of an object (a :class:`ShapeLibrary`) as compiled kernels take them:
    C-contiguous and read-only (a read-only view of a writeable array, no copy). A library is
    read-only when built, but a copy of it (``copy.deepcopy`` of a sample) is not, and Numba
    compiles a kernel again for each layout of its arguments."""

    def __init__(self, owner) -> None:
        self._owner = owner

    def __getattr__(self, name: str) -> np.ndarray:
        array = getattr(self._owner, name)
        if not array.flags.writeable and array.flags.c_contiguous:
            return array
        return kernel_input(array)


@dataclass(frozen=True, eq=False)
class ShapeLibrary:
    """Shapes of a run, one row per shape (module docstring).

    Attributes
    ----------
    kind:
        (S,) int64 shape kind codes.
    sphere_start, sphere_count:
        (S,) int64 first row and number of member spheres of each shape.
    sphere_offsets:
        (M, 3) member-sphere centres in the body frame [m].
    sphere_radii:
        (M,) member-sphere radii [m].
    volume:
        (S,) volumes [m^3] (union of the members, overlaps counted once).
    principal_inertia:
        (S, 3) principal moments of inertia per unit density [m^5].
    bounding_radius:
        (S,) radius about the centre of mass enclosing the shape [m].
    vertex_start, vertex_count, vertices, face_start, face_count, face_normals,
    face_offsets, face_vertex_start, face_vertices, edge_start, edge_count, edges,
    edge_faces, vertex_neighbour_start, vertex_neighbours:
        Polyhedron boundaries (module docstring); optional, empty by default.
    """

    kind: np.ndarray
    sphere_start: np.ndarray
    sphere_count: np.ndarray
    sphere_offsets: np.ndarray
    sphere_radii: np.ndarray
    volume: np.ndarray
    principal_inertia: np.ndarray
    bounding_radius: np.ndarray
    vertex_start: np.ndarray | None = None
    vertex_count: np.ndarray | None = None
    vertices: np.ndarray | None = None
    face_start: np.ndarray | None = None
    face_count: np.ndarray | None = None
    face_normals: np.ndarray | None = None
    face_offsets: np.ndarray | None = None
    face_vertex_start: np.ndarray | None = None
    face_vertices: np.ndarray | None = None
    edge_start: np.ndarray | None = None
    edge_count: np.ndarray | None = None
    edges: np.ndarray | None = None
    edge_faces: np.ndarray | None = None
    vertex_neighbour_start: np.ndarray | None = None
    vertex_neighbours: np.ndarray | None = None

    def __post_init__(self) -> None:
        self._fill_polyhedron_defaults()
        for name, dtype in (
            ("kind", np.int64), ("sphere_start", np.int64), ("sphere_count", np.int64),
            ("sphere_offsets", np.float64), ("sphere_radii", np.float64),
            ("volume", np.float64), ("principal_inertia", np.float64),
            ("bounding_radius", np.float64),
        ):
            object.__setattr__(self, name, _readonly(np.asarray(getattr(self, name), dtype)))
        n_shapes = self.kind.shape[0]
        for name in ("sphere_start", "sphere_count", "volume", "bounding_radius"):
            if getattr(self, name).shape != (n_shapes,):
                raise InputError(name, f"shape {getattr(self, name).shape}", f"({n_shapes},)")
        if self.principal_inertia.shape != (n_shapes, 3):
            raise InputError("principal_inertia", f"shape {self.principal_inertia.shape}",
                             f"({n_shapes}, 3)")
        n_members = self.sphere_radii.shape[0]
        if self.sphere_offsets.shape != (n_members, 3):
            raise InputError("sphere_offsets", f"shape {self.sphere_offsets.shape}",
                             f"({n_members}, 3), one row per member radius")
        for s in range(n_shapes):
            kind = shape_kind(int(self.kind[s]), f"kind[{s}]")
            start, count = int(self.sphere_start[s]), int(self.sphere_count[s])
            if not kind.has_member_spheres:
                if count != 0:
                    raise InputError(f"sphere_count[{s}]", count,
                                     f"0 for a {kind.name} (no member sphere)")
                continue
            if count < 1 or start < 0 or start + count > n_members:
                raise InputError(f"sphere_start[{s}]/sphere_count[{s}]", (start, count),
                                 f"a non-empty range of rows inside 0 .. {n_members - 1}")
        self._validate_polyhedra()
        self._validate_dimension()

    def _validate_dimension(self) -> None:
        """Kinds of one dimension only; discs of one thickness (relative 1e-12)."""
        kinds = kinds_present(self.kind, "kind")
        if len({kind.dimension for kind in kinds}) > 1:
            raise InputError("kind", [kind.name for kind in kinds],
                             "shapes of one dimension: discs (2D) are not mixed with 3D shapes")
        if kinds and kinds[0].dimension == 2:
            r = self.sphere_radii[self.sphere_start]
            t = self.volume / (np.pi * r * r)
            if np.ptp(t) > 1e-12 * np.max(t):
                raise InputError("volume", f"thicknesses {np.min(t):g}..{np.max(t):g} m",
                                 "discs of one thickness (volume = pi r^2 t)")

    def _fill_polyhedron_defaults(self) -> None:
        """Empty polyhedron arrays (count 0 for every shape) where none were given."""
        n_shapes = np.asarray(self.kind).reshape(-1).shape[0]
        for name, (dtype, width) in _POLYHEDRON_FIELDS.items():
            value = getattr(self, name)
            if value is None:
                if name.endswith(("_start", "_count")) and name not in (
                        "face_vertex_start", "vertex_neighbour_start"):
                    value = np.zeros(n_shapes, dtype=dtype)
                elif name in ("face_vertex_start", "vertex_neighbour_start"):
                    value = np.zeros(1, dtype=dtype)
                else:
                    value = np.zeros((0, width) if width > 1 else 0, dtype=dtype)
            array = np.asarray(value, dtype=dtype)
            if width > 1:
                array = array.reshape(-1, width)
            object.__setattr__(self, name, _readonly(array))

    def _validate_polyhedra(self) -> None:
        """Ranges, CSR arrays, local ids, unit normals and convexity of polyhedron shapes."""
        n_shapes = self.kind.shape[0]
        for name in ("vertex_start", "vertex_count", "face_start", "face_count",
                     "edge_start", "edge_count"):
            if getattr(self, name).shape != (n_shapes,):
                raise InputError(name, f"shape {getattr(self, name).shape}", f"({n_shapes},)")
        n_faces = self.face_normals.shape[0]
        n_vertices = self.vertices.shape[0]
        checks = (
            ("face_offsets", self.face_offsets.shape, (n_faces,)),
            ("face_vertex_start", self.face_vertex_start.shape, (n_faces + 1,)),
            ("vertex_neighbour_start", self.vertex_neighbour_start.shape, (n_vertices + 1,)),
        )
        for name, shape, wanted in checks:
            if shape != wanted:
                raise InputError(name, f"shape {shape}", f"{wanted}")
        for name, starts, total in (
            ("face_vertex_start", self.face_vertex_start, self.face_vertices.shape[0]),
            ("vertex_neighbour_start", self.vertex_neighbour_start,
             self.vertex_neighbours.shape[0]),
        ):
            if starts[0] != 0 or starts[-1] != total or np.any(np.diff(starts) < 0):
                raise InputError(name, starts.tolist(),
                                 f"non-decreasing CSR offsets from 0 to {total}")
        for s in np.flatnonzero(family_mask(self.kind, POLYHEDRON_FEATURES)):
            self._validate_polyhedron(int(s))

    def _validate_polyhedron(self, s: int) -> None:
        ranges = {}
        for name, total in (("vertex", self.vertices.shape[0]),
                            ("face", self.face_normals.shape[0]),
                            ("edge", self.edges.shape[0])):
            start = int(getattr(self, f"{name}_start")[s])
            count = int(getattr(self, f"{name}_count")[s])
            minimum = 4 if name in ("vertex", "face") else 6
            if count < minimum or start < 0 or start + count > total:
                raise InputError(f"{name}_start[{s}]/{name}_count[{s}]", (start, count),
                                 f"a range of at least {minimum} rows inside 0 .. {total - 1}")
            ranges[name] = (start, start + count)
        v0, v1 = ranges["vertex"]
        f0, f1 = ranges["face"]
        e0, e1 = ranges["edge"]
        n_local = v1 - v0
        local = self.face_vertices[self.face_vertex_start[f0]:self.face_vertex_start[f1]]
        if np.any(np.diff(self.face_vertex_start[f0:f1 + 1]) < 3):
            raise InputError(f"face_vertex_start (shape {s})", "a face with < 3 vertices",
                             "polygons of at least 3 vertices")
        if self.edge_faces.shape != self.edges.shape:
            raise InputError("edge_faces", f"shape {self.edge_faces.shape}",
                             f"{self.edges.shape}, two faces per edge")
        faces_of_edges = self.edge_faces[e0:e1]
        if faces_of_edges.size and (faces_of_edges.min() < 0
                                    or faces_of_edges.max() >= f1 - f0):
            raise InputError(f"edge_faces (shape {s})", faces_of_edges.tolist(),
                             f"local face ids in 0 .. {f1 - f0 - 1}")
        for name, ids in (("face_vertices", local), ("edges", self.edges[e0:e1]),
                          ("vertex_neighbours", self.vertex_neighbours[
                              self.vertex_neighbour_start[v0]:self.vertex_neighbour_start[v1]])):
            if ids.size and (ids.min() < 0 or ids.max() >= n_local):
                raise InputError(f"{name} (shape {s})", [int(ids.min()), int(ids.max())],
                                 f"local vertex ids in 0 .. {n_local - 1}")
        normals = self.face_normals[f0:f1]
        lengths = np.linalg.norm(normals, axis=1)
        bad = _first_bad_row(~(np.abs(lengths - 1.0) <= 1e-9))
        if bad is not None:
            raise InputError(f"face_normals[{f0 + bad}]", normals[bad].tolist(),
                             "an outward unit normal")
        points = self.vertices[v0:v1]
        radius = float(np.max(np.linalg.norm(points, axis=1)))
        heights = points @ normals.T - self.face_offsets[f0:f1][None, :]
        if np.max(heights) > _PLANE_TOLERANCE * radius:
            k = int(np.argmax(np.max(heights, axis=0)))
            raise InputError(f"face_offsets[{f0 + k}]", float(self.face_offsets[f0 + k]),
                             "a supporting plane: every vertex on its inner side (convex)")

    @property
    def n_shapes(self) -> int:
        """Number of shapes S."""
        return int(self.kind.shape[0])

    @classmethod
    def from_spheres(cls, radii) -> ShapeLibrary:
        """One sphere shape per radius (S,) [m], each radius finite and > 0."""
        r = np.asarray(radii, dtype=np.float64).reshape(-1)
        bad = ~(np.isfinite(r) & (r > 0.0))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputError(f"radii[{k}]", float(r[k]), "a finite radius > 0 in m")
        n = r.shape[0]
        volume = 4.0 / 3.0 * np.pi * r**3
        inertia = np.repeat((0.4 * volume * r * r)[:, None], 3, axis=1)
        return cls(
            kind=np.full(n, SPHERE.code), sphere_start=np.arange(n),
            sphere_count=np.ones(n, dtype=np.int64), sphere_offsets=np.zeros((n, 3)),
            sphere_radii=r, volume=volume, principal_inertia=inertia, bounding_radius=r,
        )

    @classmethod
    def from_discs(cls, radii, thickness: float) -> ShapeLibrary:
        """One disc shape per radius (S,) [m], each a cylinder of length ``thickness`` t [m]
        (> 0) seen end-on (:mod:`grainlab.engine.planar`): volume pi r^2 t [m^3] and the
        cylinder's moment about its axis, r^2/2 per unit mass, on all three principal axes
        (isotropic: no gyroscopic coupling; a disc turns about z only)."""
        library = cls.from_spheres(radii)
        t = float(thickness) if isinstance(thickness, int | float | np.floating) \
            and not isinstance(thickness, bool) else float("nan")
        if not (np.isfinite(t) and t > 0.0):
            raise InputError("thickness", thickness, "a finite disc thickness > 0 in m")
        r = library.sphere_radii
        volume = np.pi * r * r * t
        return cls(
            kind=np.full(r.shape[0], DISC.code), sphere_start=library.sphere_start,
            sphere_count=library.sphere_count, sphere_offsets=library.sphere_offsets,
            sphere_radii=r, volume=volume,
            principal_inertia=np.repeat((0.5 * volume * r * r)[:, None], 3, axis=1),
            bounding_radius=r,
        )

    @property
    def dimension(self) -> int:
        """3, or 2 when the shapes are discs (:mod:`grainlab.engine.planar`)."""
        dimensions = {kind.dimension for kind in kinds_present(self.kind, "kind")}
        return dimensions.pop() if len(dimensions) == 1 else 3

    @property
    def thickness(self) -> float | None:
        """The discs' common thickness t = V / (pi r^2) [m] of a 2D library; None in 3D."""
        if self.dimension != 2:
            return None
        r = self.sphere_radii[self.sphere_start]
        return float(np.mean(self.volume / (np.pi * r * r)))

    @classmethod
    def from_aggregates(cls, aggregates: list[SphereAggregate],
                        kind: ShapeKind = AGGREGATE) -> ShapeLibrary:
        """One shape of ``kind`` (a kind of the member-sphere family; aggregates unless told)
        per :class:`SphereAggregate` (its body frame is kept)."""
        if len(aggregates) == 0:
            raise InputError("aggregates", aggregates, "a non-empty list of SphereAggregate")
        _check_family("kind", kind, MEMBER_SPHERES)
        for k, agg in enumerate(aggregates):
            if not isinstance(agg, SphereAggregate):
                raise InputError(f"aggregates[{k}]", type(agg).__name__, "a SphereAggregate")
        counts = np.array([agg.n_spheres for agg in aggregates], dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        return cls(
            kind=np.full(len(aggregates), kind.code), sphere_start=starts,
            sphere_count=counts,
            sphere_offsets=np.concatenate([agg.centres for agg in aggregates]),
            sphere_radii=np.concatenate([agg.radii for agg in aggregates]),
            volume=np.array([agg.volume for agg in aggregates]),
            principal_inertia=np.array([agg.principal_moments for agg in aggregates]),
            bounding_radius=np.array([agg.bounding_radius for agg in aggregates]),
        )

    @classmethod
    def from_polyhedra(cls, polyhedra: list[ConvexPolyhedron],
                       kind: ShapeKind = POLYHEDRON) -> ShapeLibrary:
        """One shape of ``kind`` (a kind of the polyhedron family; polyhedra unless told) per
        :class:`~grainlab.geometry.polyhedron.ConvexPolyhedron` (its body frame, merged planar
        faces and edges of the solid are kept)."""
        if len(polyhedra) == 0:
            raise InputError("polyhedra", polyhedra, "a non-empty list of ConvexPolyhedron")
        _check_family("kind", kind, POLYHEDRON_FEATURES)
        for k, shape in enumerate(polyhedra):
            if not isinstance(shape, ConvexPolyhedron):
                raise InputError(f"polyhedra[{k}]", type(shape).__name__,
                                 "a ConvexPolyhedron")
        n = len(polyhedra)
        vertex_count = np.array([p.n_vertices for p in polyhedra], dtype=np.int64)
        face_count = np.array([p.n_polygons for p in polyhedra], dtype=np.int64)
        edges = [p.polygon_edges for p in polyhedra]
        edge_count = np.array([e.shape[0] for e in edges], dtype=np.int64)
        csr = [p.polygon_csr for p in polyhedra]
        face_sizes = np.concatenate([np.diff(start) for start, _ in csr])
        face_vertex_start = np.zeros(face_sizes.shape[0] + 1, dtype=np.int64)
        np.cumsum(face_sizes, out=face_vertex_start[1:])
        neighbour_start, neighbours = _vertex_neighbours(edges, vertex_count)
        return cls(
            kind=np.full(n, kind.code), sphere_start=np.zeros(n, dtype=np.int64),
            sphere_count=np.zeros(n, dtype=np.int64), sphere_offsets=np.zeros((0, 3)),
            sphere_radii=np.zeros(0), volume=np.array([p.volume for p in polyhedra]),
            principal_inertia=np.array([p.principal_moments for p in polyhedra]),
            bounding_radius=np.array([p.circumscribed_radius for p in polyhedra]),
            vertex_start=_starts(vertex_count), vertex_count=vertex_count,
            vertices=np.concatenate([p.vertices for p in polyhedra]),
            face_start=_starts(face_count), face_count=face_count,
            face_normals=np.concatenate([p.polygon_normals for p in polyhedra]),
            face_offsets=np.concatenate([p.polygon_offsets for p in polyhedra]),
            face_vertex_start=face_vertex_start,
            face_vertices=np.concatenate([ids for _, ids in csr]),
            edge_start=_starts(edge_count), edge_count=edge_count,
            edges=np.concatenate(edges),
            edge_faces=np.concatenate([_edge_faces(e, start, ids)
                                       for e, (start, ids) in zip(edges, csr, strict=True)]),
            vertex_neighbour_start=neighbour_start, vertex_neighbours=neighbours,
        )

    def concatenate(self, other: ShapeLibrary) -> ShapeLibrary:
        """The shapes of ``self`` then those of ``other`` (ids of ``other`` shift by S)."""
        n_members = self.sphere_radii.shape[0]
        n_vertices = self.vertices.shape[0]
        n_faces = self.face_normals.shape[0]
        return ShapeLibrary(
            kind=np.concatenate([self.kind, other.kind]),
            sphere_start=np.concatenate([self.sphere_start, other.sphere_start + n_members]),
            sphere_count=np.concatenate([self.sphere_count, other.sphere_count]),
            sphere_offsets=np.concatenate([self.sphere_offsets, other.sphere_offsets]),
            sphere_radii=np.concatenate([self.sphere_radii, other.sphere_radii]),
            volume=np.concatenate([self.volume, other.volume]),
            principal_inertia=np.concatenate([self.principal_inertia, other.principal_inertia]),
            bounding_radius=np.concatenate([self.bounding_radius, other.bounding_radius]),
            vertex_start=np.concatenate([self.vertex_start, other.vertex_start + n_vertices]),
            vertex_count=np.concatenate([self.vertex_count, other.vertex_count]),
            vertices=np.concatenate([self.vertices, other.vertices]),
            face_start=np.concatenate([self.face_start, other.face_start + n_faces]),
            face_count=np.concatenate([self.face_count, other.face_count]),
            face_normals=np.concatenate([self.face_normals, other.face_normals]),
            face_offsets=np.concatenate([self.face_offsets, other.face_offsets]),
            face_vertex_start=np.concatenate([
                self.face_vertex_start[:-1],
                other.face_vertex_start + self.face_vertex_start[-1]]),
            face_vertices=np.concatenate([self.face_vertices, other.face_vertices]),
            edge_start=np.concatenate([self.edge_start,
                                       other.edge_start + self.edges.shape[0]]),
            edge_count=np.concatenate([self.edge_count, other.edge_count]),
            edges=np.concatenate([self.edges, other.edges]),
            edge_faces=np.concatenate([self.edge_faces, other.edge_faces]),
            vertex_neighbour_start=np.concatenate([
                self.vertex_neighbour_start[:-1],
                other.vertex_neighbour_start + self.vertex_neighbour_start[-1]]),
            vertex_neighbours=np.concatenate([self.vertex_neighbours,
                                              other.vertex_neighbours]),
        )

    @property
    def max_features(self) -> int:
        """Largest number of vertices + edges + faces of one polyhedron shape (0 without
        polyhedra): the range of the feature ids of polyhedron contacts."""
        if not np.any(family_mask(self.kind, POLYHEDRON_FEATURES)):
            return 0
        return int(np.max(self.vertex_count + self.edge_count + self.face_count))


def _check_family(field: str, kind: ShapeKind, family: str) -> None:
    """An InputError naming ``field`` unless ``kind`` is a registered kind of ``family``."""
    if not isinstance(kind, ShapeKind) or shape_kind(kind.code, field) != kind \
            or kind.narrow_phase != family:
        raise InputError(field, getattr(kind, "name", kind),
                         "a registered shape kind of the narrow-phase family " + family + ": "
                         + ", ".join(k.name for k in kinds_of_family(family)))


def _starts(counts: np.ndarray) -> np.ndarray:
    starts = np.zeros(counts.shape[0], dtype=np.int64)
    np.cumsum(counts[:-1], out=starts[1:])
    return starts


def _edge_faces(edges: np.ndarray, start: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """(E, 2) local ids of the two polygon faces sharing each edge (u, v), u < v."""
    owner = {}
    for f in range(start.shape[0] - 1):
        loop = ids[start[f]:start[f + 1]]
        for k in range(loop.shape[0]):
            u, v = int(loop[k]), int(loop[(k + 1) % loop.shape[0]])
            owner.setdefault((min(u, v), max(u, v)), []).append(f)
    out = np.array([owner[(int(u), int(v))] for u, v in edges], dtype=np.int64)
    return out.reshape(-1, 2)


def _vertex_neighbours(edges: list[np.ndarray], vertex_count: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """CSR (V + 1,), (2E,) of the local ids of each vertex's edge neighbours, shape by shape."""
    starts, lists = [np.zeros(1, dtype=np.int64)], []
    total = 0
    for edge, count in zip(edges, vertex_count, strict=True):
        ends = np.concatenate([edge, edge[:, ::-1]])
        ends = ends[np.lexsort((ends[:, 1], ends[:, 0]))]
        degree = np.bincount(ends[:, 0], minlength=int(count))
        starts.append(total + np.cumsum(degree))
        lists.append(ends[:, 1])
        total += ends.shape[0]
    return np.concatenate(starts), np.concatenate(lists).astype(np.int64)


def _first_bad_row(bad: np.ndarray) -> int | None:
    rows = np.flatnonzero(bad)
    return int(rows[0]) if rows.size else None


@dataclass(eq=False)
class BodyState:
    """Mutable structure-of-arrays state of N rigid bodies (module docstring for units).

    Build it with :meth:`from_library`, which derives masses and inertias from the shapes and
    the density. :meth:`validate` checks shapes, finiteness and unit quaternions and raises
    :class:`~grainlab.errors.InputError` naming the field and row.
    """

    positions: np.ndarray
    orientations: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    masses: np.ndarray
    inertias: np.ndarray
    shape_ids: np.ndarray
    density: float

    def __post_init__(self) -> None:
        self.validate()

    @property
    def n_bodies(self) -> int:
        """Number of bodies N."""
        return int(self.positions.shape[0])

    @classmethod
    def from_library(
        cls, library: ShapeLibrary, shape_ids, positions, density: float, orientations=None,
    ) -> BodyState:
        """Bodies at rest of the given shapes (N,) at ``positions`` (N, 3) [m], with
        ``orientations`` (N, 4) (w first; identity when None) and ``density`` [kg/m^3]."""
        ids = np.asarray(shape_ids)
        if ids.ndim != 1 or not np.issubdtype(ids.dtype, np.integer):
            raise InputError("shape_ids", ids.tolist(), "a 1-D array of integer shape ids")
        ids = ids.astype(np.int64)
        bad = _first_bad_row((ids < 0) | (ids >= library.n_shapes))
        if bad is not None:
            raise InputError(f"shape_ids[{bad}]", int(ids[bad]),
                             f"a shape id in 0 .. {library.n_shapes - 1}")
        try:
            rho = float(density)
        except (TypeError, ValueError):
            rho = float("nan")
        if not (np.isfinite(rho) and rho > 0.0):
            raise InputError("density", density, "a finite density > 0 in kg/m^3")
        n = ids.shape[0]
        if orientations is None:
            orientations = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        state = cls(
            positions=np.array(positions, dtype=np.float64),
            orientations=np.array(orientations, dtype=np.float64),
            velocities=np.zeros((n, 3)), angular_velocities=np.zeros((n, 3)),
            masses=rho * library.volume[ids], inertias=rho * library.principal_inertia[ids],
            shape_ids=ids, density=rho,
        )
        if library.dimension == 2:
            check_planar(state.positions, state.orientations, state.velocities,
                         state.angular_velocities)
        return state

    def validate(self) -> None:
        """Check shapes, finite values, positive masses/inertias and unit quaternions."""
        n = np.asarray(self.shape_ids).shape[0]
        expected = {
            "positions": (n, 3), "orientations": (n, 4), "velocities": (n, 3),
            "angular_velocities": (n, 3), "masses": (n,), "inertias": (n, 3),
        }
        for name, shape in expected.items():
            value = np.asarray(getattr(self, name))
            if value.shape != shape:
                raise InputError(name, f"array of shape {value.shape}", f"shape {shape}")
            finite = np.isfinite(value) if value.ndim == 1 else np.isfinite(value).all(axis=1)
            bad = _first_bad_row(~finite)
            if bad is not None:
                raise InputError(f"{name}[{bad}]", value[bad].tolist(), "finite values")
        bad = _first_bad_row(~(np.asarray(self.masses) > 0.0))
        if bad is not None:
            raise InputError(f"masses[{bad}]", float(self.masses[bad]), "a mass > 0 in kg")
        bad = _first_bad_row(~(np.asarray(self.inertias) > 0.0).all(axis=1))
        if bad is not None:
            raise InputError(f"inertias[{bad}]", self.inertias[bad].tolist(),
                             "principal moments > 0 in kg m^2")
        norms = np.linalg.norm(self.orientations, axis=1)
        bad = _first_bad_row(np.abs(norms - 1.0) > _UNIT_TOLERANCE)
        if bad is not None:
            raise InputError(f"orientations[{bad}]", self.orientations[bad].tolist(),
                             f"a unit quaternion (w, x, y, z), |q| = 1 within {_UNIT_TOLERANCE}")

    def _world_inertia_times(self, omega: np.ndarray) -> np.ndarray:
        """R diag(I) R^T omega (N, 3) for world-frame vectors ``omega`` (N, 3)."""
        rotations = quat_to_matrices(self.orientations)
        body = np.einsum("nji,nj->ni", rotations, omega)  # R^T omega
        return np.einsum("nij,nj->ni", rotations, self.inertias * body)

    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy [J]."""
        translation = 0.5 * float(np.sum(self.masses * np.sum(self.velocities**2, axis=1)))
        spin = self._world_inertia_times(self.angular_velocities)
        rotation = 0.5 * float(np.sum(self.angular_velocities * spin))
        return translation + rotation

    def rotational_energies(self) -> np.ndarray:
        """Rotational kinetic energy of each body (n,) [J]: omega . I_world omega / 2."""
        spin = self._world_inertia_times(self.angular_velocities)
        return 0.5 * np.sum(self.angular_velocities * spin, axis=1)

    def momentum(self) -> np.ndarray:
        """Total linear momentum (3,) [kg m/s]."""
        return np.sum(self.masses[:, None] * self.velocities, axis=0)

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the origin (3,) [kg m^2/s]: orbital plus spin."""
        orbital = np.cross(self.positions, self.masses[:, None] * self.velocities)
        spin = self._world_inertia_times(self.angular_velocities)
        return np.sum(orbital + spin, axis=0)
