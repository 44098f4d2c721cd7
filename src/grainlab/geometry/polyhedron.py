"""Convex polyhedra, their exact mass properties and seed 002's random polyhedra.

A :class:`ConvexPolyhedron` is a static shape: hull vertices and outward triangular faces in
its body frame (origin at the centre of mass, axes along the principal axes of inertia), its
unique edges with their two adjacent faces, volume and principal moments of inertia per unit
density. :func:`from_vertices` builds one from any point cloud (its convex hull, by qhull through
``scipy.spatial.ConvexHull``); :func:`random_polyhedron` draws the particles of seed 002.

Mass properties (exact)
-----------------------
The solid is split into tetrahedra (p, a, b, c), one per outward triangle (a, b, c), from an
interior reference point p (the mean of the vertices). With a, b, c relative to p,

    V_k = a . (b x c) / 6,    int x dV = V_k (a + b + c) / 4,
    int x x^T dV = V_k / 20 (a a^T + b b^T + c c^T + s s^T),   s = a + b + c,

summed over k; the second moment is shifted to the centre of mass and the inertia tensor per
unit density is I = tr(C) 1 - C [m^5]. Its eigenvectors give the body frame.

Seed 002 (Azema, Radjai, Dubois, PRE 87, 062203 (2013), Sec. II.A, Table I)
---------------------------------------------------------------------------
n_v points uniform on a unit sphere; their convex hull has triangular faces (points in general
position on a sphere are all hull vertices), so n_f = 2 n_v - 4. The principal axis lengths
L_p >= l_p >= h_p are "calculated" (Fig. 1) without a formula; we take the extents of the
particle along its principal axes of inertia (see :attr:`ConvexPolyhedron.axis_lengths`). This
reproduces Table I's mean ratios (0.98 ... 0.92) better than the semi-axes of the
inertia-equivalent ellipsoid, which moreover rejects 5-10 times more hulls at small n_f. The
paper keeps a particle when "both ratios L_p/h_p and l_p/h_p [are] greater than 0.9"; with
L_p >= l_p >= h_p these ratios are >= 1 and the test would keep everything, and Table I lists
mean ratios below 1, so the ratios are smaller over larger: h/L >= 0.9 and h/l >= 0.9 (the
first implies the second), i.e. the shortest extent is at least 0.9 of the longest.

Angularity alpha is "the mean exterior angle between [the particle's] touching faces": the
mean over edges of pi minus the dihedral angle, i.e. the angle between the outward normals of
the two faces that share the edge [rad]. qhull triangulates a planar facet with more than three
vertices (a cube face into two triangles); edges inside such a facet (exterior angle below
:data:`COPLANAR_ANGLE`) are not edges of the solid and are left out, which is the same as
merging the coplanar triangles first. Random points on a sphere give triangular facets only.

Units: lengths in m, volume in m^3, inertia per unit density in m^5, angles in rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from grainlab._validate import in_range, positive
from grainlab.errors import ConvergenceError, InputError
from grainlab.geometry.sphere_aggregate import principal_frame

COPLANAR_ANGLE = 1e-7
"""Exterior angle [rad] below which two triangles are one planar facet (edge not counted)."""

TABLE_I = {596: 0.135, 176: 0.248, 96: 0.339, 46: 0.496, 30: 0.631, 20: 0.772, 8: 1.181}
"""Seed 002, Table I: number of faces n_f -> mean angularity <alpha> [rad] of the packing."""

MAX_TRIES = 1_000_000
"""Default number of hulls :func:`random_polyhedron` draws before giving up (n_f = 8 keeps
about one in 900 with the 0.9 criterion)."""


@dataclass(frozen=True, eq=False)
class ConvexPolyhedron:
    """A convex polyhedron in its body frame (static shape; arrays are read-only).

    Parameters
    ----------
    vertices:
        (V, 3) hull vertices in the body frame [m]: origin at the centre of mass, axes along
        the principal axes of inertia (ascending moments).
    faces:
        (F, 3) vertex indices of the triangles, counter-clockwise seen from outside (outward
        normal (b - a) x (c - a)).
    edges:
        (E, 2) vertex indices of the unique edges of the triangulation, i < j.
    edge_faces:
        (E, 2) indices of the two triangles sharing each edge.
    volume:
        Volume [m^3].
    principal_moments:
        (3,) principal moments of inertia per unit density, ascending [m^5].
    rotation:
        (3, 3) proper rotation whose columns are the principal axes in the input frame:
        x_input = centre_of_mass + rotation @ x_body.
    centre_of_mass:
        (3,) centre of mass in the input frame [m].
    name:
        A label for reports.

    >>> cube = from_vertices([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
    >>> round(cube.volume, 12), round(cube.angularity, 12) == round(np.pi / 2, 12)
    (1.0, True)
    """

    vertices: np.ndarray
    faces: np.ndarray
    edges: np.ndarray
    edge_faces: np.ndarray
    volume: float
    principal_moments: np.ndarray
    rotation: np.ndarray
    centre_of_mass: np.ndarray
    name: str = "convex polyhedron"

    def __post_init__(self) -> None:
        arrays = {
            "vertices": np.array(self.vertices, dtype=float).reshape(-1, 3),
            "faces": np.array(self.faces, dtype=np.int64).reshape(-1, 3),
            "edges": np.array(self.edges, dtype=np.int64).reshape(-1, 2),
            "edge_faces": np.array(self.edge_faces, dtype=np.int64).reshape(-1, 2),
            "principal_moments": np.array(self.principal_moments, dtype=float).reshape(3),
            "rotation": np.array(self.rotation, dtype=float).reshape(3, 3),
            "centre_of_mass": np.array(self.centre_of_mass, dtype=float).reshape(3),
        }
        for key, value in arrays.items():
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        object.__setattr__(self, "volume", float(self.volume))

    @classmethod
    def from_vertices(cls, points: np.ndarray, name: str = "convex polyhedron") -> ConvexPolyhedron:
        """The convex hull of ``points`` ((n, 3) [m], any frame, n >= 4, not coplanar).

        Points inside the hull are dropped; mass properties are exact (module docstring).
        """
        vertices, faces = _hull(_check_points(points))
        volume, com, inertia = polyhedron_mass_properties(vertices, faces)
        moments, axes = principal_frame(inertia)
        edges, edge_faces = _edges(faces)
        body = (vertices - com) @ axes
        return cls(body, faces, edges, edge_faces, volume, moments, axes, com, name)

    # ------------------------------------------------------------------ topology and faces
    @property
    def n_vertices(self) -> int:
        """Number of hull vertices V."""
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        """Number of triangles F (2 V - 4 for a triangulated convex polyhedron)."""
        return int(self.faces.shape[0])

    @property
    def n_edges(self) -> int:
        """Number of edges E of the triangulation (3 V - 6)."""
        return int(self.edges.shape[0])

    @property
    def face_normals(self) -> np.ndarray:
        """(F, 3) outward unit normals."""
        cross = self._face_cross()
        return cross / np.linalg.norm(cross, axis=1)[:, None]

    @property
    def face_areas(self) -> np.ndarray:
        """(F,) triangle areas [m^2]."""
        return 0.5 * np.linalg.norm(self._face_cross(), axis=1)

    @property
    def surface_area(self) -> float:
        """Surface area [m^2]."""
        return float(np.sum(self.face_areas))

    def _face_cross(self) -> np.ndarray:
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        return np.cross(b - a, c - a)

    # ------------------------------------------------------------------ planar polygon faces
    @cached_property
    def _polygons(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return _merge_coplanar(self.vertices, self.faces, self.edge_faces, self.edge_angles)

    @property
    def polygon_csr(self) -> tuple[np.ndarray, np.ndarray]:
        """Planar polygon faces as CSR arrays: ``start`` (P + 1,) int64 into ``vertices``
        (K,) int64, vertex ids counter-clockwise seen from outside. Coplanar triangles of the
        hull (exterior angle below :data:`COPLANAR_ANGLE`) are merged: a cube has 6 squares."""
        start, ids, _ = self._polygons
        return start, ids

    @property
    def polygon_faces(self) -> list[np.ndarray]:
        """The P planar faces, each an int64 array of vertex ids, counter-clockwise seen from
        outside (:attr:`polygon_csr` as a list; for drawing the true faceted shape)."""
        start, ids = self.polygon_csr
        return [ids[start[k]:start[k + 1]] for k in range(start.shape[0] - 1)]

    @property
    def n_polygons(self) -> int:
        """Number of planar polygon faces P (6 for a cube, F for a hull in general position)."""
        return int(self._polygons[0].shape[0] - 1)

    @property
    def polygon_normals(self) -> np.ndarray:
        """(P, 3) outward unit normals of the polygon faces (area-weighted mean of their
        triangles' normals)."""
        return self._polygons[2]

    @property
    def polygon_offsets(self) -> np.ndarray:
        """(P,) plane offsets n . v [m] of the polygon faces: the mean over the vertices of a
        triangle, the largest over the vertices of a polygon merged from triangles. Merged
        triangles may differ by up to :data:`COPLANAR_ANGLE` in direction, so such a polygon
        is planar only to ~1e-7 of its size; its plane is then the supporting one, every
        vertex on its inner side (a random hull of 596 faces had a quad 3e-9 x its radius off
        its mean plane)."""
        start, ids, normals = self._polygons
        counts = np.diff(start)
        owner = np.repeat(np.arange(start.shape[0] - 1), counts)
        dots = np.einsum("ij,ij->i", self.vertices[ids], normals[owner])
        mean = np.bincount(owner, dots) / counts
        return np.where(counts > 3, np.maximum.reduceat(dots, start[:-1]), mean)

    @property
    def polygon_edges(self) -> np.ndarray:
        """(E', 2) int64 edges of the solid (i < j): the edges between two different polygon
        faces (12 for a cube); edges inside a merged planar face are left out."""
        keep = self.edge_angles >= COPLANAR_ANGLE
        return self.edges[keep]

    # ------------------------------------------------------------------ shape descriptors
    @property
    def edge_angles(self) -> np.ndarray:
        """(E,) exterior angle at each edge [rad]: the angle between the outward normals of
        its two faces, pi minus the dihedral angle; 0 for an edge inside a planar facet."""
        normals = self.face_normals
        n1, n2 = normals[self.edge_faces[:, 0]], normals[self.edge_faces[:, 1]]
        sine = np.linalg.norm(np.cross(n1, n2), axis=1)
        return np.arctan2(sine, np.einsum("ij,ij->i", n1, n2))

    @property
    def angularity(self) -> float:
        """Seed 002's angularity alpha [rad]: the mean exterior angle over the edges of the
        solid (edges inside a planar facet, angle < :data:`COPLANAR_ANGLE`, left out).

        pi/2 for a cube, pi - arccos(1/3) for a regular tetrahedron.
        """
        angles = self.edge_angles
        return float(np.mean(angles[angles >= COPLANAR_ANGLE]))

    @property
    def sphericity(self) -> float:
        """Surface area of the sphere of equal volume over the surface area [-] (1 for a
        sphere): pi^(1/3) (6 V)^(2/3) / A."""
        return float(math.pi ** (1.0 / 3.0) * (6.0 * self.volume) ** (2.0 / 3.0)
                     / self.surface_area)

    @property
    def axis_lengths(self) -> np.ndarray:
        """(3,) principal axis lengths (L, l, h), descending [m]: the extents (max - min of
        the vertex coordinates) along the three principal axes of inertia (seed 002, Fig. 1;
        module docstring)."""
        extents = self.vertices.max(axis=0) - self.vertices.min(axis=0)
        return np.sort(extents)[::-1]

    @property
    def axis_ratios(self) -> tuple[float, float]:
        """(h/L, h/l) [-], both <= 1: seed 002 keeps a particle when both are >= 0.9."""
        big, mid, small = self.axis_lengths
        return float(small / big), float(small / mid)

    @property
    def circumscribed_radius(self) -> float:
        """Radius of the sphere about the centre of mass that encloses the polyhedron [m]
        (largest vertex distance). For :func:`random_polyhedron` the generating sphere, of
        the requested diameter, is centred elsewhere by O(1 %), so this is slightly larger."""
        return float(np.max(np.linalg.norm(self.vertices, axis=1)))

    @property
    def equivalent_radius(self) -> float:
        """Radius of the sphere of equal volume [m]."""
        return float((3.0 * self.volume / (4.0 * np.pi)) ** (1.0 / 3.0))

    @property
    def inertia_tensor(self) -> np.ndarray:
        """(3, 3) inertia tensor per unit density in the body frame (diagonal) [m^5]."""
        return np.diag(self.principal_moments)

    def mass(self, density: float) -> float:
        """Mass [kg] for a density [kg/m^3]."""
        return self.volume * positive("density", density, "kg/m^3")

    def moments_of_inertia(self, density: float) -> np.ndarray:
        """(3,) principal moments [kg m^2] for a density [kg/m^3]."""
        return self.principal_moments * positive("density", density, "kg/m^3")

    def describe(self) -> str:
        """A few lines for reports: topology, volume, axis lengths, angularity, sphericity."""
        moments = ", ".join(f"{m:.6g}" for m in self.principal_moments)
        axes = ", ".join(f"{x:.6g}" for x in self.axis_lengths)
        ratio_hl, ratio_hm = self.axis_ratios
        return "\n".join(
            [
                f"{self.name}: {self.n_vertices} vertices, {self.n_faces} triangles,"
                f" {self.n_edges} edges",
                f"  volume {self.volume:.6g} m^3, circumscribed radius"
                f" {self.circumscribed_radius:.6g} m, equivalent radius"
                f" {self.equivalent_radius:.6g} m",
                f"  axis lengths L, l, h = [{axes}] m (h/L {ratio_hl:.4f}, h/l {ratio_hm:.4f})",
                f"  angularity {self.angularity:.6g} rad, sphericity {self.sphericity:.6g}",
                f"  principal moments per unit density [{moments}] m^5",
            ]
        )


from_vertices = ConvexPolyhedron.from_vertices


def random_polyhedron(
    n_faces: int,
    rng: np.random.Generator,
    circumscribed_diameter: float = 1.0,
    min_axis_ratio: float = 0.9,
    max_tries: int = MAX_TRIES,
) -> ConvexPolyhedron:
    """A random convex polyhedron of seed 002 with ``n_faces`` triangular faces.

    Draws n_v = (n_f + 4) / 2 points uniform on the unit sphere (normalised Gaussian vectors),
    takes their convex hull and redraws all points until h/L >= ``min_axis_ratio`` and
    h/l >= ``min_axis_ratio`` (axis lengths: extents along the principal axes, module
    docstring), at most ``max_tries`` hulls. The points are then scaled by d/2, so that all
    vertices lie on a sphere of diameter d = ``circumscribed_diameter`` [m] (the smallest
    enclosing sphere, since its centre is inside the hull). ``n_faces`` must be even and
    >= 4. Raises :class:`~grainlab.errors.ConvergenceError` when no hull passes.

    >>> shape = random_polyhedron(20, np.random.default_rng(2))
    >>> shape.n_faces, min(shape.axis_ratios) >= 0.9
    (20, True)
    """
    if isinstance(n_faces, bool) or not isinstance(n_faces, (int, np.integer)):
        raise InputError("n_faces", n_faces, "an even integer >= 4")
    if n_faces < 4 or n_faces % 2:
        raise InputError("n_faces", n_faces, "an even integer >= 4 (n_f = 2 n_v - 4)")
    diameter = positive("circumscribed_diameter", circumscribed_diameter, "m")
    ratio = in_range("min_axis_ratio", min_axis_ratio, 0.0, 1.0, closed="(]")
    if isinstance(max_tries, bool) or not isinstance(max_tries, (int, np.integer)) or (
        max_tries < 1
    ):
        raise InputError("max_tries", max_tries, "a positive integer")
    if not isinstance(rng, np.random.Generator):
        raise InputError("rng", rng, "a numpy.random.Generator")
    n_vertices = (int(n_faces) + 4) // 2
    tried, batch = 0, 1
    while tried < int(max_tries):  # draws in growing batches, judged together, in order
        batch = min(2 * batch if tried else 1, DRAW_BATCH, int(max_tries) - tried)
        before = rng.bit_generator.state
        points = rng.normal(size=(batch, n_vertices, 3))
        points /= np.linalg.norm(points, axis=2)[:, :, None]
        passed = np.flatnonzero(_axes_pass(points, ratio))
        if passed.size:
            first = int(passed[0])
            rng.bit_generator.state = before  # leave the generator after the accepted draw
            rng.normal(size=(first + 1, n_vertices, 3))
            name = f"random polyhedron (n_f = {int(n_faces)})"
            return from_vertices(0.5 * diameter * points[first], name=name)
        tried += batch
    raise ConvergenceError(
        f"random_polyhedron: no hull of {n_vertices} random points met h/L >= {ratio:g} "
        f"in max_tries = {int(max_tries)} draws; raise max_tries or lower min_axis_ratio."
    )


DRAW_BATCH = 64
"""The most point sets :func:`random_polyhedron` draws and judges at once (batches of 1, 2,
4, ... while none passes; the accepted one, and the generator's state after it, are those of
one draw at a time)."""


def _axes_pass(points: np.ndarray, ratio: float) -> np.ndarray:
    """(B,) whether the hull of each point set (B, V, 3) on the unit sphere has V vertices and
    h/L, h/l >= ``ratio`` (:func:`random_polyhedron`): the mass properties of
    :func:`polyhedron_mass_properties`, for the whole batch at once."""
    batch, n_vertices = points.shape[:2]
    n_faces = 2 * n_vertices - 4
    faces = np.zeros((batch, n_faces, 3), dtype=np.int64)
    whole = np.zeros(batch, dtype=bool)
    for k in range(batch):
        try:
            hull = ConvexHull(points[k])
        except QhullError:  # degenerate draw (probability zero)
            continue
        if hull.simplices.shape[0] == n_faces and np.unique(hull.simplices).size == n_vertices:
            faces[k], whole[k] = hull.simplices, True
    rows = np.arange(batch)[:, None]
    reference = points.mean(axis=1)[:, None, :]
    a, b, c = (points[rows, faces[:, :, k]] - reference for k in range(3))
    normal = np.cross(b - a, c - a)
    outward = np.einsum("bfi,bfi->bf", normal, a + b + c) >= 0.0  # the hull holds the centre
    b, c = np.where(outward[..., None], b, c), np.where(outward[..., None], c, b)
    with np.errstate(invalid="ignore", divide="ignore"):  # the draws not whole: no volume
        _, com, inertia = _tetrahedra_mass_properties(a, b, c)
    inertia[~whole] = np.eye(3)
    _, axes = np.linalg.eigh(inertia)
    body = np.einsum("bvi,bij->bvj", points - (reference + com[:, None, :]), axes)
    extents = np.sort(body.max(axis=1) - body.min(axis=1), axis=1)[:, ::-1]
    return whole & (extents[:, 2] >= ratio * extents[:, 0]) & (
        extents[:, 2] >= ratio * extents[:, 1])


def polyhedron_mass_properties(
    vertices: np.ndarray, faces: np.ndarray
) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume [m^3], centre of mass (3,) [m] and inertia tensor about it per unit density
    (3, 3) [m^5] of the closed polyhedron with outward triangles ``faces`` (F, 3) on
    ``vertices`` (V, 3) [m]: tetrahedra from the mean vertex (module docstring; exact).

    >>> v, com, inertia = polyhedron_mass_properties(
    ...     [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 2, 1], [0, 1, 3], [0, 3, 2],
    ...     [1, 2, 3]])
    >>> round(v * 6, 12), (com * 4).round(12).tolist()
    (1.0, [1.0, 1.0, 1.0])
    """
    points = np.asarray(vertices, dtype=float)
    tri = np.asarray(faces, dtype=np.int64)
    reference = points.mean(axis=0)
    a, b, c = (points[tri[:, k]] - reference for k in range(3))
    volume, com, inertia = _tetrahedra_mass_properties(a, b, c)
    return float(volume), reference + com, inertia


def _tetrahedra_mass_properties(a, b, c):
    """Volume, centre of mass and inertia tensor per unit density of the tetrahedra (0, a_f,
    b_f, c_f) summed over the faces f: ``a``, ``b``, ``c`` (..., F, 3) [m] the faces' corners
    from a reference point, any leading batch axes (:func:`polyhedron_mass_properties`, the
    draws of :func:`random_polyhedron`)."""
    volumes = np.einsum("...fi,...fi->...f", a, np.cross(b, c)) / 6.0
    total = a + b + c
    volume = np.sum(volumes, axis=-1)
    com = (volumes[..., None, :] @ total)[..., 0, :] / (4.0 * volume[..., None])
    second = sum(np.einsum("...f,...fi,...fj->...ij", volumes / 20.0, x, x)
                 for x in (a, b, c, total))
    second = second - volume[..., None, None] * (com[..., :, None] * com[..., None, :])
    second = 0.5 * (second + np.swapaxes(second, -1, -2))
    inertia = np.trace(second, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) - second
    return volume, com, inertia


# --------------------------------------------------------------------------- helpers
def _check_points(points) -> np.ndarray:
    try:
        array = np.array(points, dtype=float)
    except (TypeError, ValueError):
        raise InputError("points", points, "an (n, 3) array of coordinates in metres") from None
    if array.ndim != 2 or array.shape[1] != 3 or array.shape[0] < 4:
        raise InputError("points", points, "an (n, 3) array of n >= 4 points in metres")
    for k, row in enumerate(array):
        if not np.all(np.isfinite(row)):
            raise InputError(f"points[{k}]", row.tolist(), "finite coordinates in metres")
    return array


def _hull(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hull vertices (V, 3) and outward triangles (F, 3) indexing them."""
    try:
        hull = ConvexHull(points)
    except QhullError:
        raise InputError(
            "points", points.tolist(), "points spanning a solid (not all coplanar)"
        ) from None
    simplices = hull.simplices.copy()
    a, b, c = (points[simplices[:, k]] for k in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0.0
    simplices[inward] = simplices[inward][:, [0, 2, 1]]
    used = np.unique(simplices)
    index = np.full(len(points), -1, dtype=np.int64)
    index[used] = np.arange(len(used))
    return points[used], index[simplices]


def _edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique edges (E, 2), i < j, and the two faces (E, 2) sharing each."""
    half = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    owner = np.tile(np.arange(len(faces)), 3)
    keys = np.sort(half, axis=1)
    order = np.lexsort((keys[:, 1], keys[:, 0]))
    keys, owner = keys[order], owner[order]
    if len(keys) % 2 or not np.array_equal(keys[0::2], keys[1::2]):
        raise InputError("faces", faces.tolist(), "a closed surface (each edge in two faces)")
    return keys[0::2], np.stack([owner[0::2], owner[1::2]], axis=1)


def _merge_coplanar(vertices, faces, edge_faces, edge_angles):
    """Merge adjacent triangles whose exterior angle is below :data:`COPLANAR_ANGLE` into
    planar polygons; returns (start (P + 1,), vertex ids (K,) counter-clockwise from outside,
    unit normals (P, 3))."""
    n_tri = faces.shape[0]
    parent = np.arange(n_tri)

    def root(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    for e in np.flatnonzero(edge_angles < COPLANAR_ANGLE):
        a, b = root(int(edge_faces[e, 0])), root(int(edge_faces[e, 1]))
        if a != b:
            parent[max(a, b)] = min(a, b)
    roots = np.array([root(k) for k in range(n_tri)])
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    cross = np.cross(b - a, c - a)  # 2 x area x unit normal
    starts, ids, normals = [0], [], []
    for group in np.unique(roots):
        members = np.flatnonzero(roots == group)
        half = {(int(f[i]), int(f[(i + 1) % 3])) for f in faces[members] for i in range(3)}
        boundary = {u: v for (u, v) in half if (v, u) not in half}
        first = min(boundary)
        loop = [first]
        while boundary[loop[-1]] != first:
            loop.append(boundary[loop[-1]])
            if len(loop) > len(boundary):
                raise InputError("faces", faces.tolist(), "a closed convex surface")
        ids.extend(loop)
        starts.append(len(ids))
        normal = cross[members].sum(axis=0)
        normals.append(normal / np.linalg.norm(normal))
    return (np.array(starts, dtype=np.int64), np.array(ids, dtype=np.int64),
            np.array(normals, dtype=float).reshape(-1, 3))
