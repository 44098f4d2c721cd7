"""Shapes drawn in their body frame, one drawer per shape kind (for the VTK writer,
:mod:`grainlab.report.vtk_export`).

A :class:`ShapeKindDrawer` turns the shapes of one kind of a
:class:`~grainlab.engine.state.ShapeLibrary` into body-frame vertices and triangles
(:class:`ShapeMeshes`, concatenated over shapes); writers only rotate and translate them,
v_world = x + R(q) v_body. :data:`SHAPE_KIND_DRAWERS` maps each shape kind of the registry
(:mod:`grainlab.engine.shape_kinds`), by name, to its drawer:
spheres and aggregates share :data:`MEMBER_SPHERES`, one icosphere per member sphere (centre
c_body, radius r: vertices c_body + r u for the unit icosphere vertices u), or one point per
member sphere. Convex polyhedra have their own drawer, :data:`POLYHEDRA`: their hull
vertices and their planar polygon faces as they are (a cube has 6 quads, not 12 triangles),
from the library's ``vertices`` and face CSR (``face_vertex_start``, ``face_vertices``); or one
point at the centre of mass carrying the circumscribed radius.

The icosphere of level s splits each face of an icosahedron into four s times and projects
the new vertices on the unit sphere: 10 4^s + 2 vertices, 20 4^s triangles (s = 1: 42, 80).
Its face planes pass inside the sphere, at most 21, 6.6, 1.8, 0.45, 0.11 % of r below its
surface for s = 0 .. 4 (shrinking as 4^-s).

>>> from grainlab.engine.state import ShapeLibrary
>>> library = ShapeLibrary.from_spheres([0.5, 1.0])
>>> meshes = library_meshes(library, subdivisions=1)
>>> meshes.vertex_start.tolist(), meshes.triangle_start.tolist()
([0, 42, 84], [0, 80, 160])
>>> round(float(np.linalg.norm(meshes.vertices[50])), 12)
1.0
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from grainlab.engine.shape_kinds import AGGREGATE, DISC, POLYHEDRON, SPHERE, kinds_present
from grainlab.engine.state import ShapeLibrary
from grainlab.errors import InputError

MAX_SUBDIVISIONS = 4
"""Finest icosphere accepted: 20 4^4 = 5120 triangles per member sphere."""


def check_subdivisions(value) -> int:
    """``value`` as an icosphere level in 0 .. :data:`MAX_SUBDIVISIONS`, else InputError."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) \
            or not 0 <= value <= MAX_SUBDIVISIONS:
        raise InputError("subdivisions", value, f"an integer in 0 .. {MAX_SUBDIVISIONS}")
    return int(value)


@lru_cache(maxsize=MAX_SUBDIVISIONS + 1)
def _icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    g = (1.0 + math.sqrt(5.0)) / 2.0
    vertices = np.array([
        (-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0), (0, -1, g), (0, 1, g),
        (0, -1, -g), (0, 1, -g), (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1),
    ], dtype=np.float64)
    triangles = np.array([
        (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
        (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
        (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1),
    ], dtype=np.int64)
    vertices /= np.linalg.norm(vertices, axis=1)[:, None]
    for _ in range(subdivisions):
        # edge midpoints, one new vertex per undirected edge
        edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]],
                                triangles[:, [2, 0]]])
        unique, inverse = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
        middle = vertices[unique[:, 0]] + vertices[unique[:, 1]]
        middle /= np.linalg.norm(middle, axis=1)[:, None]
        mid = inverse.reshape(3, -1) + vertices.shape[0]  # rows ab, bc, ca per triangle
        a, b, c = triangles.T
        ab, bc, ca = mid
        triangles = np.concatenate([
            np.stack([a, ab, ca], axis=1), np.stack([b, bc, ab], axis=1),
            np.stack([c, ca, bc], axis=1), np.stack([ab, bc, ca], axis=1),
        ])
        vertices = np.concatenate([vertices, middle])
    # wind every triangle counter-clockwise seen from outside (outward right-hand normal)
    p = vertices[triangles]
    outward = np.einsum("ti,ti->t", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]),
                        p.sum(axis=1)) > 0.0
    triangles[~outward] = triangles[~outward][:, ::-1]
    vertices.setflags(write=False)
    triangles.setflags(write=False)
    return vertices, triangles


def icosphere(subdivisions: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Unit sphere triangulated from an icosahedron split ``subdivisions`` times.

    Returns read-only ``vertices`` (10 4^s + 2, 3) on the unit sphere and ``triangles``
    (20 4^s, 3) int64 rows of vertices, wound counter-clockwise seen from outside.

    >>> vertices, triangles = icosphere(1)
    >>> vertices.shape, triangles.shape
    ((42, 3), (80, 3))
    """
    return _icosphere(check_subdivisions(subdivisions))


@dataclass(frozen=True, eq=False)
class ShapeMeshes:
    """Body-frame drawings of K shapes, concatenated (what a :class:`ShapeKindDrawer` returns).

    Attributes
    ----------
    vertex_start:
        (K + 1,) int64: shape k owns vertex rows ``vertex_start[k] .. vertex_start[k+1] - 1``.
    vertices:
        (V, 3) vertex positions in the body frame [m].
    member:
        (V,) int64 index of the member sphere each vertex belongs to (0 for one-piece shapes).
    radius:
        (V,) radius [m] written with each vertex (the member's radius; a polyhedron would give
        its bounding radius).
    triangle_start:
        (K + 1,) int64: shape k owns triangle rows ``triangle_start[k] .. [k+1] - 1``.
    triangles:
        (T, 3) int64 vertex rows counted from the shape's first vertex (0 .. its count - 1),
        counter-clockwise seen from outside; (0, 3) for a point drawing.
    polygon_start:
        (K + 1,) int64: shape k owns polygon rows ``polygon_start[k] .. [k+1] - 1`` (planar
        faces of any number of vertices, besides its triangles); zeros when None.
    polygon_vertex_start, polygon_vertices:
        (P + 1,) CSR offsets into (Q,) int64 vertex rows counted from the shape's first
        vertex, counter-clockwise seen from outside; ``[0]`` and empty when None.
    """

    vertex_start: np.ndarray
    vertices: np.ndarray
    member: np.ndarray
    radius: np.ndarray
    triangle_start: np.ndarray
    triangles: np.ndarray
    polygon_start: np.ndarray | None = None
    polygon_vertex_start: np.ndarray | None = None
    polygon_vertices: np.ndarray | None = None

    def __post_init__(self) -> None:
        defaults = {"polygon_start": np.zeros(np.shape(self.vertex_start), dtype=np.int64),
                    "polygon_vertex_start": np.zeros(1, dtype=np.int64),
                    "polygon_vertices": np.zeros(0, dtype=np.int64)}
        for name, value in defaults.items():
            if getattr(self, name) is None:
                object.__setattr__(self, name, value)
        for name, dtype in (("vertex_start", np.int64), ("vertices", np.float64),
                            ("member", np.int64), ("radius", np.float64),
                            ("triangle_start", np.int64), ("triangles", np.int64),
                            ("polygon_start", np.int64), ("polygon_vertex_start", np.int64),
                            ("polygon_vertices", np.int64)):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=dtype))
        n_vertices = self.vertices.shape[0]
        if self.vertices.shape != (n_vertices, 3) or self.member.shape != (n_vertices,) \
                or self.radius.shape != (n_vertices,):
            raise InputError("ShapeMeshes.vertices/member/radius",
                             (self.vertices.shape, self.member.shape, self.radius.shape),
                             "shapes (V, 3), (V,) and (V,)")
        if self.triangles.ndim != 2 or self.triangles.shape[1] != 3:
            raise InputError("ShapeMeshes.triangles", self.triangles.shape, "shape (T, 3)")
        if self.vertex_start.shape != self.triangle_start.shape \
                or self.vertex_start[-1] != n_vertices \
                or self.triangle_start[-1] != self.triangles.shape[0]:
            raise InputError("ShapeMeshes.vertex_start/triangle_start",
                             (self.vertex_start.tolist(), self.triangle_start.tolist()),
                             "(K + 1,) offsets ending at the number of vertices / triangles")
        n_polygons = self.polygon_vertex_start.shape[0] - 1
        if self.polygon_start.shape != self.vertex_start.shape \
                or self.polygon_start[-1] != n_polygons \
                or self.polygon_vertex_start[-1] != self.polygon_vertices.shape[0] \
                or np.any(np.diff(self.polygon_vertex_start) < 3):
            raise InputError("ShapeMeshes.polygon_start/polygon_vertex_start",
                             (self.polygon_start.tolist(), self.polygon_vertex_start.tolist()),
                             "(K + 1,) offsets ending at the number of polygons, and CSR "
                             "offsets of polygons of >= 3 vertices")


def concatenated_ranges(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Concatenation of arange(s, s + c) over the pairs (s, c) of (K,) int arrays.

    >>> concatenated_ranges(np.array([5, 0]), np.array([2, 3])).tolist()
    [5, 6, 0, 1, 2]
    """
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    first = np.cumsum(counts) - counts
    return np.arange(total, dtype=np.int64) - np.repeat(first - starts, counts)


def offsets_from_counts(counts: np.ndarray) -> np.ndarray:
    """(K + 1,) int64 offsets [0, c0, c0 + c1, ...] of blocks of (K,) sizes ``counts``."""
    out = np.zeros(counts.shape[0] + 1, dtype=np.int64)
    np.cumsum(counts, out=out[1:])
    return out


def _members(library: ShapeLibrary, shapes: np.ndarray):
    counts = library.sphere_count[shapes]
    rows = concatenated_ranges(library.sphere_start[shapes], counts)
    index = rows - np.repeat(library.sphere_start[shapes], counts)
    return counts, library.sphere_offsets[rows], library.sphere_radii[rows], index


def member_sphere_surfaces(library: ShapeLibrary, shapes: np.ndarray,
                           subdivisions: int) -> ShapeMeshes:
    """Sphere-based shapes (spheres, aggregates): one icosphere per member sphere, centred at
    its body-frame offset and scaled by its radius [m]."""
    unit, tri = icosphere(subdivisions)
    counts, centres, radii, index = _members(library, shapes)
    nv, nt = unit.shape[0], tri.shape[0]
    vertices = centres[:, None, :] + radii[:, None, None] * unit[None, :, :]
    triangles = tri[None, :, :] + (index * nv)[:, None, None]
    return ShapeMeshes(
        vertex_start=offsets_from_counts(counts * nv), vertices=vertices.reshape(-1, 3),
        member=np.repeat(index, nv), radius=np.repeat(radii, nv),
        triangle_start=offsets_from_counts(counts * nt), triangles=triangles.reshape(-1, 3),
    )


def member_sphere_points(library: ShapeLibrary, shapes: np.ndarray) -> ShapeMeshes:
    """Sphere-based shapes drawn as points: one vertex per member sphere at its body-frame
    offset [m], carrying its radius [m]."""
    counts, centres, radii, index = _members(library, shapes)
    return ShapeMeshes(
        vertex_start=offsets_from_counts(counts), vertices=centres, member=index, radius=radii,
        triangle_start=np.zeros(shapes.shape[0] + 1, dtype=np.int64),
        triangles=np.zeros((0, 3), dtype=np.int64),
    )


def polyhedron_surfaces(library: ShapeLibrary, shapes: np.ndarray,
                        subdivisions: int = 0) -> ShapeMeshes:
    """Convex polyhedra as they are: their hull vertices (body frame [m]) and planar polygon
    faces (``subdivisions`` unused); every vertex carries the circumscribed radius."""
    vertex_counts = library.vertex_count[shapes]
    vertices = library.vertices[concatenated_ranges(library.vertex_start[shapes],
                                                    vertex_counts)]
    face_counts = library.face_count[shapes]
    faces = concatenated_ranges(library.face_start[shapes], face_counts)
    starts = library.face_vertex_start
    sizes = starts[faces + 1] - starts[faces]
    ids = library.face_vertices[concatenated_ranges(starts[faces], sizes)]
    k = shapes.shape[0]
    return ShapeMeshes(
        vertex_start=offsets_from_counts(vertex_counts), vertices=vertices,
        member=np.zeros(vertices.shape[0], dtype=np.int64),
        radius=np.repeat(library.bounding_radius[shapes], vertex_counts),
        triangle_start=np.zeros(k + 1, dtype=np.int64),
        triangles=np.zeros((0, 3), dtype=np.int64),
        polygon_start=offsets_from_counts(face_counts),
        polygon_vertex_start=offsets_from_counts(sizes), polygon_vertices=ids,
    )


def polyhedron_points(library: ShapeLibrary, shapes: np.ndarray) -> ShapeMeshes:
    """Polyhedra drawn as points: one vertex at the centre of mass carrying the circumscribed
    radius [m]."""
    k = shapes.shape[0]
    return ShapeMeshes(
        vertex_start=np.arange(k + 1, dtype=np.int64), vertices=np.zeros((k, 3)),
        member=np.zeros(k, dtype=np.int64), radius=library.bounding_radius[shapes],
        triangle_start=np.zeros(k + 1, dtype=np.int64),
        triangles=np.zeros((0, 3), dtype=np.int64),
    )


@dataclass(frozen=True)
class ShapeKindDrawer:
    """How the shapes of one kind are drawn, in their body frame.

    ``surface(library, shapes, subdivisions)`` and ``points(library, shapes)`` receive the
    library and the ids (K,) of shapes of this kind and return their :class:`ShapeMeshes` in
    that order. A convex polyhedron kind would return its vertices and triangulated faces
    (``subdivisions`` unused) and one point at the centre with its bounding radius.
    """

    surface: Callable[[ShapeLibrary, np.ndarray, int], ShapeMeshes]
    points: Callable[[ShapeLibrary, np.ndarray], ShapeMeshes]


MEMBER_SPHERES = ShapeKindDrawer(surface=member_sphere_surfaces, points=member_sphere_points)
"""Drawer of sphere-based shapes (spheres and aggregates)."""

POLYHEDRA = ShapeKindDrawer(surface=polyhedron_surfaces, points=polyhedron_points)
"""Drawer of convex polyhedra (true faceted shapes)."""

SHAPE_KIND_DRAWERS: dict[str, ShapeKindDrawer] = {
    SPHERE.name: MEMBER_SPHERES,
    AGGREGATE.name: MEMBER_SPHERES,
    POLYHEDRON.name: POLYHEDRA,
    DISC.name: MEMBER_SPHERES,
}
"""Drawer of each shape kind, by the name of its
:class:`~grainlab.engine.shape_kinds.ShapeKind`; add an entry for a new kind."""


def library_meshes(library: ShapeLibrary, subdivisions: int = 1,
                   as_points: bool = False) -> ShapeMeshes:
    """Body-frame drawings of all S shapes of ``library``, in shape-id order, each drawn by
    the drawer of its kind (:data:`SHAPE_KIND_DRAWERS`)."""
    subdivisions = check_subdivisions(subdivisions)
    n_shapes = library.n_shapes
    blocks = []
    vertex_counts = np.zeros(n_shapes, dtype=np.int64)
    triangle_counts = np.zeros(n_shapes, dtype=np.int64)
    for kind in kinds_present(library.kind, "library.kind"):
        drawer = SHAPE_KIND_DRAWERS.get(kind.name)
        if drawer is None:
            raise InputError("library.kind", kind.code,
                             "a shape kind with a drawer in SHAPE_KIND_DRAWERS "
                             f"({', '.join(SHAPE_KIND_DRAWERS)})")
        shapes = np.flatnonzero(library.kind == kind.code)
        block = drawer.points(library, shapes) if as_points else \
            drawer.surface(library, shapes, subdivisions)
        if block.vertex_start.shape != (shapes.shape[0] + 1,):
            raise InputError(f"drawer of kind {kind.name!r}", block.vertex_start.shape,
                             f"({shapes.shape[0] + 1},) offsets, one block per shape")
        vertex_counts[shapes] = np.diff(block.vertex_start)
        triangle_counts[shapes] = np.diff(block.triangle_start)
        blocks.append((shapes, block))
    if len(blocks) == 1:  # one kind: the block is already in shape-id order
        return blocks[0][1]
    vertex_start = offsets_from_counts(vertex_counts)
    triangle_start = offsets_from_counts(triangle_counts)
    vertices = np.empty((vertex_start[-1], 3))
    member = np.empty(vertex_start[-1], dtype=np.int64)
    radius = np.empty(vertex_start[-1])
    triangles = np.empty((triangle_start[-1], 3), dtype=np.int64)
    polygon_counts = np.zeros(n_shapes, dtype=np.int64)
    for shapes, block in blocks:
        rows = concatenated_ranges(vertex_start[shapes], vertex_counts[shapes])
        vertices[rows], member[rows], radius[rows] = block.vertices, block.member, block.radius
        rows = concatenated_ranges(triangle_start[shapes], triangle_counts[shapes])
        triangles[rows] = block.triangles
        polygon_counts[shapes] = np.diff(block.polygon_start)
    # polygons: gather each shape's rows (and their vertex lists) in shape-id order
    polygon_start = offsets_from_counts(polygon_counts)
    sizes = np.zeros(polygon_start[-1], dtype=np.int64)
    lists: list[tuple[np.ndarray, np.ndarray]] = []
    for shapes, block in blocks:
        rows = concatenated_ranges(polygon_start[shapes], polygon_counts[shapes])
        sizes[rows] = np.diff(block.polygon_vertex_start)
        lists.append((rows, block))
    polygon_vertex_start = offsets_from_counts(sizes)
    polygon_vertices = np.empty(polygon_vertex_start[-1], dtype=np.int64)
    for rows, block in lists:
        target = concatenated_ranges(polygon_vertex_start[rows], sizes[rows])
        polygon_vertices[target] = block.polygon_vertices
    return ShapeMeshes(vertex_start=vertex_start, vertices=vertices, member=member,
                       radius=radius, triangle_start=triangle_start, triangles=triangles,
                       polygon_start=polygon_start, polygon_vertex_start=polygon_vertex_start,
                       polygon_vertices=polygon_vertices)
