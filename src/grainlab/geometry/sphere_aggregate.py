"""Rigid aggregates (clumps) of overlapping spheres and their exact mass properties (seed 003).

A :class:`SphereAggregate` is a static shape: sphere centres and radii in its body frame (origin
at the centre of mass, axes along the principal axes of inertia), its volume and principal
moments of inertia per unit density. :func:`from_spheres` builds one from any list of spheres;
:func:`tetrahedral_aggregate` builds the four-sphere aggregates of seed 003.

Mass properties of the union (overlaps counted once)
----------------------------------------------------
The power (radical) diagram of the spheres partitions their union exactly: a point x of the
union belongs to the sphere i of least power |x - c_i|^2 - r_i^2, and that sphere contains x.
Sphere i's share is therefore the ball B_i clipped by the half-spaces

    n_ij . (x - c_i) <= d_ij,   n_ij = (c_j - c_i) / |c_j - c_i|,
    d_ij = (|c_j - c_i|^2 + r_i^2 - r_j^2) / (2 |c_j - c_i|),

one per neighbour j whose radical plane cuts B_i (|d_ij| < r_i). No assumption on the number
of spheres meeting at a point is needed (triple and quadruple overlaps are handled alike).

Each clipped ball is sliced along z. A slice is a disc of radius sqrt(r^2 - z^2) clipped by
half-planes; its area, first and second moments are exact (a fan of signed triangles and
circular sectors from the disc centre). The slice moments are analytic in z between the
break-points where the slice changes combinatorially (the poles, the z-extremes of every
clipping circle, the points where a line of two planes pierces the sphere, the vertices of
three planes inside the ball); at these they have at worst half-integer power singularities
((z - z0)^(3/2)). Each panel between break-points is integrated by Gauss-Legendre in theta
with z = z_mid - h cos(theta), which makes those endpoint singularities analytic, so the
quadrature converges exponentially. With the default 32 nodes per panel, volume, centre of
mass and inertia agree with a 128-node reference to a relative 1e-11 for the tetrahedral
aggregates over the whole lambda range (1e-13 for random clumps of 2-7 unequal spheres) and
with the closed forms of one sphere and of two overlapping spheres to 1e-15; the target was
1e-6. The test suite checks the closed forms to 1e-12 and a quasi-Monte-Carlo twin to 0.1 %.
A tetrahedral aggregate takes ~25 ms.

Units: lengths in m, volume in m^3, inertia per unit density in m^5 (multiply by the density
in kg/m^3 for kg m^2).

Spheres that lie inside another sphere add nothing to the union and are dropped (they would
duplicate contacts in a DEM run); of identical spheres the first is kept.

Seed 003 (Azema, Radjai, Saint-Cyr, Delenne, Sornay, PRE 2013, Sec. II, Fig. 1, eq. 1)
--------------------------------------------------------------------------------------
Four spheres of radius r at the vertices of a regular tetrahedron of edge l; lambda = l/2r
from 0 (one sphere) to sqrt(3)/2 (the three spheres of a face meet at a single point, the face
centre). The circumscribed radius about the centre is R = r (1 + lambda sqrt(3/2)), and the
non-convexity is eta = (R - R')/R (eq. 1) with R' "the radius of the inscribed circle". In
3D we read R' as the radius of the largest sphere concentric with the circumscribed one that
fits inside the aggregate, i.e. the distance from the centre to the nearest point of its outer
surface. That point is where three spheres meet on a three-fold axis, beyond a face centre:

    R' = l / (2 sqrt 6) + sqrt(r^2 - l^2 / 3) = r (lambda / sqrt 6 + sqrt(1 - 4 lambda^2 / 3)).

eta(lambda) = 1 - R'/R rises strictly from 0 at lambda = 0 to 2 sqrt 2 - 2 = 0.828 at
lambda = sqrt(3)/2 (proof in :func:`eta_from_lam`), so the seed's eight packings, eta = 0,
0.1, ..., 0.7, are all in range; eta = 0.7 needs lambda = 0.835, not lambda = sqrt(3)/2.
Two remarks for users of the seed: (i) its closing remark that four tangent spheres give
eta ~ 0.73 does not follow from this (or any 3D) reading -- it is the value of the 2D
three-disc aggregate, 1 - (1/sqrt 3)/(1 + 2/sqrt 3) = 0.732; (ii) for
sqrt(2/3) < lambda < sqrt(3)/2 the centre is farther than r from every sphere centre, so the
union encloses a small sealed cavity around the centre (0.024 % of the volume at
lambda = sqrt(3)/2). The mass properties here are those of the union, without the cavity;
R' ignores the cavity (outer surface).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import brentq

from grainlab._validate import positive
from grainlab.errors import InputError

LAM_MAX = math.sqrt(3.0) / 2.0
"""Largest lambda = l/2r of seed 003: the three spheres of a face meet at the face centre."""

ETA_MAX = 2.0 * math.sqrt(2.0) - 2.0
"""Non-convexity eta at lambda = sqrt(3)/2 (= 0.8284)."""

QUADRATURE_ORDER = 32
"""Gauss-Legendre nodes per z-panel in :func:`union_mass_properties`."""

_ZERO = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


# --------------------------------------------------------------------------- seed 003 shape
def eta_from_lam(lam: float) -> float:
    """Non-convexity eta = (R - R')/R [-] of the tetrahedral aggregate with lambda = l/2r.

    R/r = 1 + lambda sqrt(3/2) and R'/r = lambda/sqrt 6 + sqrt(1 - 4 lambda^2/3) (module
    docstring). eta is strictly increasing on [0, sqrt(3)/2]: with s = sqrt(1 - 4 lambda^2/3)
    and a = sqrt(3/2), d(R'/R)/d lambda has the sign of 1/sqrt 6 - a s - (4 lambda/3)(1 +
    a lambda)/s, negative because a s > 1/sqrt 6 when s >= 1/3, and (4 lambda/3)/s > 3 when
    s < 1/3 (then lambda > 0.8).

    >>> eta_from_lam(0.0), round(eta_from_lam(LAM_MAX), 6)
    (0.0, 0.828427)
    """
    lam = _check_lam(lam)
    outer = 1.0 + lam * math.sqrt(1.5)
    radicand = 1.0 - 4.0 * lam * lam / 3.0
    if radicand < 1e-14:  # lambda = sqrt(3)/2 up to rounding (d eta/d lambda is infinite there)
        radicand = 0.0
    inner = lam / math.sqrt(6.0) + math.sqrt(radicand)
    return max(1.0 - inner / outer, 0.0)


def lam_from_eta(eta: float) -> float:
    """Inverse of :func:`eta_from_lam`: the lambda in [0, sqrt(3)/2] with that eta [-].

    Solved by Brent's method to 1e-15 (eta is strictly monotonic, so the root is unique).

    >>> round(lam_from_eta(0.7), 4)
    0.8348
    """
    try:
        value = float(eta)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and 0.0 <= value <= ETA_MAX):
        raise InputError("eta", eta, f"a non-convexity in [0, {ETA_MAX:.6f}] (2 sqrt 2 - 2)")
    if value == 0.0:
        return 0.0
    if value == ETA_MAX:
        return LAM_MAX
    return float(
        brentq(lambda x: eta_from_lam(x) - value, 0.0, LAM_MAX, xtol=1e-15, rtol=1e-15)
    )


def _check_lam(lam: float) -> float:
    try:
        value = float(lam)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and 0.0 <= value <= LAM_MAX):
        raise InputError("lam", lam, f"a ratio l/2r in [0, {LAM_MAX:.6f}] (sqrt(3)/2)")
    return value


# --------------------------------------------------------------------------- the value object
@dataclass(frozen=True, eq=False)
class SphereAggregate:
    """A rigid aggregate of spheres in its principal body frame (a static shape).

    Attributes
    ----------
    centres:
        (k, 3) sphere centres in the body frame [m]: centre of mass at the origin, axes along
        the principal axes of inertia (ordered as ``principal_moments``).
    radii:
        (k,) sphere radii [m].
    volume:
        Volume of the union of the spheres, overlaps counted once [m^3].
    principal_moments:
        (3,) principal moments of inertia per unit density, ascending [m^5]; times the
        density [kg/m^3] they are in kg m^2.
    rotation:
        (3, 3) proper rotation whose columns are the principal axes in the input
        (construction) frame: x_input = centre_of_mass + rotation @ x_body. Inside a
        degenerate eigenspace the axes are the input axes projected onto it (the identity
        for an isotropic body such as the tetrahedral aggregates).
    centre_of_mass:
        (3,) centre of mass in the input frame [m].
    name:
        A label for reports.

    >>> agg = from_spheres([[0.0, 0.0, 0.0]], [2.0])
    >>> round(agg.volume / (4 / 3 * np.pi * 8), 12), round(agg.bounding_radius, 12)
    (1.0, 2.0)
    """

    centres: np.ndarray
    radii: np.ndarray
    volume: float
    principal_moments: np.ndarray
    rotation: np.ndarray
    centre_of_mass: np.ndarray
    name: str = "sphere aggregate"

    def __post_init__(self) -> None:
        centres = np.array(self.centres, dtype=float)
        radii = np.array(self.radii, dtype=float).reshape(-1)
        if centres.ndim != 2 or centres.shape[1] != 3 or centres.shape[0] != radii.shape[0]:
            raise InputError("centres", self.centres, "a (k, 3) array, one row per radius")
        arrays = {
            "centres": centres,
            "radii": radii,
            "principal_moments": np.array(self.principal_moments, dtype=float).reshape(3),
            "rotation": np.array(self.rotation, dtype=float).reshape(3, 3),
            "centre_of_mass": np.array(self.centre_of_mass, dtype=float).reshape(3),
        }
        for key, value in arrays.items():
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        object.__setattr__(self, "volume", float(self.volume))

    @classmethod
    def from_spheres(
        cls, centres: np.ndarray, radii: np.ndarray, name: str = "sphere aggregate"
    ) -> SphereAggregate:
        """The aggregate of the spheres (centres (k, 3) [m], radii (k,) [m]) in any frame.

        Mass properties by :func:`union_mass_properties`; spheres inside another are dropped.
        """
        centres, radii = _check_spheres(centres, radii)
        keep = _uncovered(centres, radii)
        centres, radii = centres[keep], radii[keep]
        volume, com, inertia = _union_moments(centres, radii, QUADRATURE_ORDER)
        moments, axes = principal_frame(inertia)
        return cls((centres - com) @ axes, radii, volume, moments, axes, com, name)

    @property
    def n_spheres(self) -> int:
        """Number of spheres k."""
        return int(self.radii.shape[0])

    @property
    def bounding_radius(self) -> float:
        """Radius of the sphere about the centre of mass that encloses the aggregate [m]:
        max_i(|c_i| + r_i) (R = r(1 + lambda sqrt(3/2)) for the tetrahedral aggregates)."""
        return float(np.max(np.linalg.norm(self.centres, axis=1) + self.radii))

    @property
    def inertia_tensor(self) -> np.ndarray:
        """(3, 3) inertia tensor per unit density in the body frame (diagonal) [m^5]."""
        return np.diag(self.principal_moments)

    @property
    def equivalent_radius(self) -> float:
        """Radius of the sphere of equal volume [m]."""
        return float((3.0 * self.volume / (4.0 * np.pi)) ** (1.0 / 3.0))

    def mass(self, density: float) -> float:
        """Mass [kg] for a density [kg/m^3]."""
        return self.volume * positive("density", density, "kg/m^3")

    def moments_of_inertia(self, density: float) -> np.ndarray:
        """(3,) principal moments [kg m^2] for a density [kg/m^3]."""
        return self.principal_moments * positive("density", density, "kg/m^3")

    def describe(self) -> str:
        """A few lines for reports: spheres, volume, radii and principal moments."""
        sphere_volume = 4.0 / 3.0 * np.pi * float(np.sum(self.radii**3))
        moments = ", ".join(f"{m:.6g}" for m in self.principal_moments)
        return "\n".join(
            [
                f"{self.name}: {self.n_spheres} sphere(s), radii {self.radii.min():.6g}"
                f"..{self.radii.max():.6g} m",
                f"  volume {self.volume:.6g} m^3 ({self.volume / sphere_volume:.4f} of the sum"
                " of the sphere volumes)",
                f"  bounding radius {self.bounding_radius:.6g} m, equivalent radius"
                f" {self.equivalent_radius:.6g} m",
                f"  principal moments per unit density [{moments}] m^5",
            ]
        )


from_spheres = SphereAggregate.from_spheres


def tetrahedral_aggregate(
    radius: float | None = None,
    circumscribed_radius: float | None = None,
    lam: float | None = None,
    eta: float | None = None,
) -> SphereAggregate:
    """Seed 003's aggregate: four spheres of radius r at the vertices of a regular tetrahedron.

    Give exactly one of ``lam`` (lambda = l/2r in [0, sqrt(3)/2]) or ``eta`` (non-convexity
    (R - R')/R in [0, 2 sqrt 2 - 2]), and exactly one of ``radius`` (r [m]) or
    ``circumscribed_radius`` (R = r (1 + lambda sqrt(3/2)) [m]). The construction frame has the
    centres at a (1, 1, 1), a (1, -1, -1), a (-1, 1, -1), a (-1, -1, 1), a = l / (2 sqrt 2);
    the inertia is isotropic (tetrahedral symmetry), so the body frame is this frame. At
    lambda = 0 the four spheres coincide and the aggregate is one sphere.

    >>> agg = tetrahedral_aggregate(circumscribed_radius=1.0, eta=0.3)
    >>> agg.n_spheres, round(agg.bounding_radius, 12)
    (4, 1.0)
    """
    if (lam is None) == (eta is None):
        raise InputError("lam/eta", (lam, eta), "exactly one of lam or eta")
    if (radius is None) == (circumscribed_radius is None):
        raise InputError(
            "radius/circumscribed_radius",
            (radius, circumscribed_radius),
            "exactly one of radius or circumscribed_radius",
        )
    if lam is None:
        eta_value = float(eta)  # type: ignore[arg-type]
        lam_value = lam_from_eta(eta)  # type: ignore[arg-type]
    else:
        lam_value = _check_lam(lam)
        eta_value = eta_from_lam(lam_value)
    if radius is not None:
        r = positive("radius", radius, "m")
    else:
        r = positive("circumscribed_radius", circumscribed_radius, "m") / (
            1.0 + lam_value * math.sqrt(1.5)
        )
    a = lam_value * r / math.sqrt(2.0)  # = l / (2 sqrt 2), l = 2 lambda r
    signs = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    name = f"tetrahedral aggregate (lambda = {lam_value:.6g}, eta = {eta_value:.6g})"
    return from_spheres(a * signs, np.full(4, r), name=name)


# --------------------------------------------------------------------------- mass properties
def union_mass_properties(
    centres: np.ndarray, radii: np.ndarray, order: int = QUADRATURE_ORDER
) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume [m^3], centre of mass (3,) [m] and inertia tensor about it per unit density
    (3, 3) [m^5] of the union of spheres (centres (k, 3) [m], radii (k,) [m]).

    Power-diagram split and z-sliced Gauss-Legendre quadrature with ``order`` nodes per panel
    (module docstring); relative accuracy ~1e-11 or better at the default order.

    >>> v, com, inertia = union_mass_properties([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]], [1.0, 1.0])
    >>> round(v / (8 * np.pi / 3), 12), com.round(12).tolist()
    (1.0, [1.5, 0.0, 0.0])
    """
    centres, radii = _check_spheres(centres, radii)
    if int(order) < 2:
        raise InputError("order", order, "an integer >= 2 (Gauss-Legendre nodes per panel)")
    keep = _uncovered(centres, radii)
    return _union_moments(centres[keep], radii[keep], int(order))


def principal_frame(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ascending principal moments (3,) and a proper rotation (3, 3) whose columns are the
    principal axes of a symmetric inertia tensor (3, 3).

    Signs: each axis of a simple eigenvalue has its largest component positive; the axes of a
    degenerate eigenspace are the coordinate axes projected onto it (so an isotropic tensor
    gives the identity); the last axis is flipped if needed to make det = +1.
    """
    tensor = np.asarray(inertia, dtype=float)
    tensor = 0.5 * (tensor + tensor.T)
    moments, axes = np.linalg.eigh(tensor)
    scale = max(float(np.max(np.abs(moments))), np.finfo(float).tiny)
    tol = 1e-9 * scale
    gaps = np.diff(moments) <= tol
    if gaps.all():
        axes = np.eye(3)
    elif gaps.any():
        single = 2 if gaps[0] else 0  # index of the simple eigenvalue
        pair = [0, 1] if gaps[0] else [1, 2]
        n = axes[:, single] * np.sign(axes[np.argmax(np.abs(axes[:, single])), single])
        k = int(np.argmin(np.abs(n)))
        q1 = np.eye(3)[k] - n[k] * n
        q1 /= np.linalg.norm(q1)
        axes = axes.copy()
        axes[:, single] = n
        axes[:, pair[0]] = q1
        axes[:, pair[1]] = np.cross(n, q1)
    else:
        axes = axes * np.sign(axes[np.argmax(np.abs(axes), axis=0), np.arange(3)])
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] *= -1.0
    return moments, axes


def _check_spheres(centres, radii) -> tuple[np.ndarray, np.ndarray]:
    c = np.array(centres, dtype=float)
    r = np.array(radii, dtype=float).reshape(-1)
    if c.ndim == 1 and c.shape[0] == 3:
        c = c.reshape(1, 3)
    if c.ndim != 2 or c.shape[1] != 3 or c.shape[0] == 0:
        raise InputError("centres", centres, "a non-empty (k, 3) array of centres in metres")
    if r.shape[0] != c.shape[0]:
        raise InputError("radii", radii, f"one radius per centre ({c.shape[0]} values)")
    for k, value in enumerate(c):
        if not np.all(np.isfinite(value)):
            raise InputError(f"centres[{k}]", value.tolist(), "finite coordinates in metres")
    for k, value in enumerate(r):
        if not (np.isfinite(value) and value > 0.0):
            raise InputError(f"radii[{k}]", float(value), "a positive radius in metres")
    return c, r


def _uncovered(centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Mask of the spheres not inside another one (of identical spheres, the first is kept)."""
    tol = 1e-12 * float(np.max(radii))
    distance = np.linalg.norm(centres[:, None, :] - centres[None, :, :], axis=2)
    inside = distance + radii[:, None] <= radii[None, :] + tol  # [i, j]: i inside j
    keep = np.ones(len(radii), dtype=bool)
    for i in range(len(radii)):
        for j in range(len(radii)):
            if i != j and keep[j] and inside[i, j] and not (inside[j, i] and j > i):
                keep[i] = False
                break
    return keep


def _union_moments(
    centres: np.ndarray, radii: np.ndarray, order: int
) -> tuple[float, np.ndarray, np.ndarray]:
    """Union moments for spheres none of which lies inside another."""
    reference = centres.mean(axis=0)
    volume, first, second = 0.0, np.zeros(3), np.zeros((3, 3))
    for i in range(len(radii)):
        delta = np.delete(centres, i, axis=0) - centres[i]
        dist = np.linalg.norm(delta, axis=1)
        others = np.delete(radii, i)
        offsets = (dist**2 + radii[i] ** 2 - others**2) / (2.0 * dist)
        cut = np.abs(offsets) < radii[i]
        normals = delta[cut] / dist[cut, None]
        v, m1, m2 = _clipped_ball_moments(float(radii[i]), normals, offsets[cut], order)
        shift = centres[i] - reference
        volume += v
        first += m1 + v * shift
        second += m2 + np.outer(shift, m1) + np.outer(m1, shift) + v * np.outer(shift, shift)
    com = first / volume
    second_about_com = second - volume * np.outer(com, com)
    second_about_com = 0.5 * (second_about_com + second_about_com.T)
    inertia = np.trace(second_about_com) * np.eye(3) - second_about_com
    return volume, reference + com, inertia


@lru_cache(maxsize=8)
def _theta_rule(order: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Nodes cos(theta_k) and weights w_k sin(theta_k) of Gauss-Legendre on [0, pi]."""
    x, w = np.polynomial.legendre.leggauss(order)
    theta = 0.5 * np.pi * (x + 1.0)
    return tuple(np.cos(theta).tolist()), tuple((0.5 * np.pi * w * np.sin(theta)).tolist())


def _clipped_ball_moments(
    r: float, normals: np.ndarray, offsets: np.ndarray, order: int
) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume, first (3,) and second (3, 3) moments about the centre of the ball |y| <= r
    clipped by the half-spaces normals[j] . y <= offsets[j]."""
    if len(offsets) == 0:
        v = 4.0 / 3.0 * np.pi * r**3
        return v, np.zeros(3), 0.2 * v * r * r * np.eye(3)
    breaks = _breakpoints(r, normals, offsets)
    planes = [(float(n[0]), float(n[1]), float(n[2]), float(d)) for n, d in zip(
        normals, offsets, strict=True)]
    cosines, weights = _theta_rule(order)
    acc = [0.0] * 10  # A, zA, z^2 A, Sx, Sy, zSx, zSy, Sxx, Syy, Sxy
    for a, b in itertools.pairwise(breaks):
        half, mid = 0.5 * (b - a), 0.5 * (a + b)
        if half <= 1e-15 * r:
            continue
        for c, w in zip(cosines, weights, strict=True):
            z = mid - half * c
            rho2 = r * r - z * z
            if rho2 <= 0.0:
                continue
            halfplanes = [(nx, ny, d - nz * z) for nx, ny, nz, d in planes]
            area, sx, sy, sxx, syy, sxy = _disc_polygon_moments(math.sqrt(rho2), halfplanes)
            wz = half * w
            acc[0] += wz * area
            acc[1] += wz * z * area
            acc[2] += wz * z * z * area
            acc[3] += wz * sx
            acc[4] += wz * sy
            acc[5] += wz * z * sx
            acc[6] += wz * z * sy
            acc[7] += wz * sxx
            acc[8] += wz * syy
            acc[9] += wz * sxy
    first = np.array([acc[3], acc[4], acc[1]])
    second = np.array(
        [[acc[7], acc[9], acc[5]], [acc[9], acc[8], acc[6]], [acc[5], acc[6], acc[2]]]
    )
    return acc[0], first, second


def _breakpoints(r: float, normals: np.ndarray, offsets: np.ndarray) -> list[float]:
    """Heights z in [-r, r] where a z-slice of the clipped ball changes combinatorially."""
    zs = [-r, r]
    m = len(offsets)
    for j in range(m):
        nz, d = normals[j, 2], offsets[j]
        reach = math.sqrt(max(r * r - d * d, 0.0)) * math.sqrt(max(1.0 - nz * nz, 0.0))
        zs += [d * nz - reach, d * nz + reach]
    for j in range(m):
        for k in range(j + 1, m):
            u = np.cross(normals[j], normals[k])
            norm_u = float(np.linalg.norm(u))
            if norm_u < 1e-12:
                continue
            point = np.linalg.solve(
                np.array([normals[j], normals[k], u]), np.array([offsets[j], offsets[k], 0.0])
            )
            h2 = r * r - float(point @ point)
            if h2 > 0.0:
                s = math.sqrt(h2) * u[2] / norm_u
                zs += [point[2] - s, point[2] + s]
            for n in range(k + 1, m):
                matrix = np.array([normals[j], normals[k], normals[n]])
                if abs(np.linalg.det(matrix)) < 1e-12:
                    continue
                vertex = np.linalg.solve(matrix, offsets[[j, k, n]])
                if float(vertex @ vertex) < r * r:
                    zs.append(float(vertex[2]))
    zs = sorted(min(max(float(z), -r), r) for z in zs)
    merged = [zs[0]]
    for z in zs[1:]:
        if z - merged[-1] > 1e-14 * r:
            merged.append(z)
    merged[-1] = r
    return merged


def _disc_polygon_moments(rho: float, halfplanes: list[tuple[float, float, float]]):
    """Exact area, first and second moments (A, Sx, Sy, Sxx, Syy, Sxy) of the disc |p| <= rho
    clipped by the half-planes ax x + ay y <= b: a fan of signed triangles (along the clipped
    chords) and circular sectors (along the arcs) from the disc centre."""
    big = 2.0 * rho
    polygon = [(-big, -big), (big, -big), (big, big), (-big, big)]
    centre_inside = True
    for ax, ay, b in halfplanes:
        if b < 0.0:
            centre_inside = False
        if ax == 0.0 and ay == 0.0:
            if b < 0.0:
                return _ZERO
            continue
        polygon = _clip(polygon, ax, ay, b)
        if len(polygon) < 3:
            return _ZERO
    pieces = []
    tiny = 1e-11 * rho
    count = len(polygon)
    for k in range(count):
        px, py = polygon[k]
        qx, qy = polygon[(k + 1) % count]
        dx, dy = qx - px, qy - py
        aa = dx * dx + dy * dy
        if aa == 0.0:
            continue
        bb = px * dx + py * dy
        disc = bb * bb - aa * (px * px + py * py - rho * rho)
        if disc <= 0.0:
            continue
        root = math.sqrt(disc)
        lo = max((-bb - root) / aa, 0.0)
        hi = min((-bb + root) / aa, 1.0)
        if (hi - lo) * math.sqrt(aa) <= tiny:
            continue
        pieces.append((px + lo * dx, py + lo * dy, px + hi * dx, py + hi * dy, hi < 1.0))
    if not pieces:
        if centre_inside:
            area = math.pi * rho * rho
            return (area, 0.0, 0.0, 0.25 * area * rho * rho, 0.25 * area * rho * rho, 0.0)
        return _ZERO
    total = [0.0] * 6
    for k, (sx, sy, ex, ey, exits_on_circle) in enumerate(pieces):
        _add_triangle(total, sx, sy, ex, ey)
        if not exits_on_circle:
            continue  # the boundary goes on along the next polygon edge
        nx, ny = pieces[(k + 1) % len(pieces)][:2]
        alpha = math.atan2(ey, ex)
        delta = math.atan2(ex * ny - ey * nx, ex * nx + ey * ny)
        if delta < 0.0:
            delta += 2.0 * math.pi
        if len(pieces) > 1 and delta > 2.0 * math.pi - 1e-9:
            delta = 0.0  # the exit and the next entry are one vertex on the circle
        if delta > 0.0:
            _add_sector(total, rho, alpha, alpha + delta)
    return tuple(total)


def _clip(polygon, ax: float, ay: float, b: float):
    """Sutherland-Hodgman: the part of a convex polygon with ax x + ay y <= b."""
    out = []
    count = len(polygon)
    for k in range(count):
        px, py = polygon[k]
        qx, qy = polygon[(k + 1) % count]
        sp = ax * px + ay * py - b
        sq = ax * qx + ay * qy - b
        if sp <= 0.0:
            out.append((px, py))
        if (sp < 0.0 < sq) or (sq < 0.0 < sp):
            t = sp / (sp - sq)
            out.append((px + t * (qx - px), py + t * (qy - py)))
    return out


def _add_triangle(total: list[float], px: float, py: float, qx: float, qy: float) -> None:
    """Add the signed moments of the triangle (0, P, Q)."""
    area = 0.5 * (px * qy - py * qx)
    total[0] += area
    total[1] += area * (px + qx) / 3.0
    total[2] += area * (py + qy) / 3.0
    total[3] += area * (px * px + px * qx + qx * qx) / 6.0
    total[4] += area * (py * py + py * qy + qy * qy) / 6.0
    total[5] += area * (2.0 * px * py + px * qy + qx * py + 2.0 * qx * qy) / 12.0


def _add_sector(total: list[float], rho: float, alpha: float, beta: float) -> None:
    """Add the moments of the circular sector of radius rho from angle alpha to beta > alpha."""
    sa, ca, sb, cb = math.sin(alpha), math.cos(alpha), math.sin(beta), math.cos(beta)
    r2, r3, r4 = rho * rho, rho**3, rho**4
    sin2 = 2.0 * sb * cb - 2.0 * sa * ca
    total[0] += 0.5 * r2 * (beta - alpha)
    total[1] += r3 / 3.0 * (sb - sa)
    total[2] += r3 / 3.0 * (ca - cb)
    total[3] += 0.25 * r4 * (0.5 * (beta - alpha) + 0.25 * sin2)
    total[4] += 0.25 * r4 * (0.5 * (beta - alpha) - 0.25 * sin2)
    total[5] += 0.125 * r4 * (sb * sb - sa * sa)
