"""Static shape library and changing body state, as structure-of-arrays (STYLE.md 1).

:class:`ShapeLibrary` is the static model: one row per shape, frozen for a run. Every shape
carries a ``kind`` code (:data:`SHAPE_SPHERE`, :data:`SHAPE_AGGREGATE`; :data:`SHAPE_POLYHEDRON`
is reserved for the polyhedra to come) and its mass properties per unit density. Sphere-based
shapes (spheres and aggregates) list their member spheres in concatenated arrays
``sphere_offsets`` (M, 3) [m] (body frame: origin at the centre of mass, axes along the
principal axes) and ``sphere_radii`` (M,) [m]; shape s owns rows
``sphere_start[s] .. sphere_start[s] + sphere_count[s] - 1``. A sphere is a one-member shape
with a zero offset, so the narrow phase treats spheres and aggregates alike.

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

from grainlab.engine.quaternion import quat_to_matrices
from grainlab.errors import InputError
from grainlab.geometry.sphere_aggregate import SphereAggregate

SHAPE_SPHERE = 0
"""Shape kind code of a sphere (one member sphere at the centre)."""
SHAPE_AGGREGATE = 1
"""Shape kind code of a rigid aggregate of spheres."""
SHAPE_POLYHEDRON = 2
"""Shape kind code reserved for convex polyhedra (not yet supported)."""

_UNIT_TOLERANCE = 1e-8  # |1 - |q|| accepted for a unit quaternion


def _readonly(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array)
    array.setflags(write=False)
    return array


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
    """

    kind: np.ndarray
    sphere_start: np.ndarray
    sphere_count: np.ndarray
    sphere_offsets: np.ndarray
    sphere_radii: np.ndarray
    volume: np.ndarray
    principal_inertia: np.ndarray
    bounding_radius: np.ndarray

    def __post_init__(self) -> None:
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
            if self.kind[s] not in (SHAPE_SPHERE, SHAPE_AGGREGATE):
                raise InputError(f"kind[{s}]", int(self.kind[s]),
                                 "SHAPE_SPHERE (0) or SHAPE_AGGREGATE (1)")
            start, count = int(self.sphere_start[s]), int(self.sphere_count[s])
            if count < 1 or start < 0 or start + count > n_members:
                raise InputError(f"sphere_start[{s}]/sphere_count[{s}]", (start, count),
                                 f"a non-empty range of rows inside 0 .. {n_members - 1}")

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
            kind=np.full(n, SHAPE_SPHERE), sphere_start=np.arange(n),
            sphere_count=np.ones(n, dtype=np.int64), sphere_offsets=np.zeros((n, 3)),
            sphere_radii=r, volume=volume, principal_inertia=inertia, bounding_radius=r,
        )

    @classmethod
    def from_aggregates(cls, aggregates: list[SphereAggregate]) -> ShapeLibrary:
        """One aggregate shape per :class:`SphereAggregate` (its body frame is kept)."""
        if len(aggregates) == 0:
            raise InputError("aggregates", aggregates, "a non-empty list of SphereAggregate")
        for k, agg in enumerate(aggregates):
            if not isinstance(agg, SphereAggregate):
                raise InputError(f"aggregates[{k}]", type(agg).__name__, "a SphereAggregate")
        counts = np.array([agg.n_spheres for agg in aggregates], dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        return cls(
            kind=np.full(len(aggregates), SHAPE_AGGREGATE), sphere_start=starts,
            sphere_count=counts,
            sphere_offsets=np.concatenate([agg.centres for agg in aggregates]),
            sphere_radii=np.concatenate([agg.radii for agg in aggregates]),
            volume=np.array([agg.volume for agg in aggregates]),
            principal_inertia=np.array([agg.principal_moments for agg in aggregates]),
            bounding_radius=np.array([agg.bounding_radius for agg in aggregates]),
        )

    def concatenate(self, other: ShapeLibrary) -> ShapeLibrary:
        """The shapes of ``self`` then those of ``other`` (ids of ``other`` shift by S)."""
        n_members = self.sphere_radii.shape[0]
        return ShapeLibrary(
            kind=np.concatenate([self.kind, other.kind]),
            sphere_start=np.concatenate([self.sphere_start, other.sphere_start + n_members]),
            sphere_count=np.concatenate([self.sphere_count, other.sphere_count]),
            sphere_offsets=np.concatenate([self.sphere_offsets, other.sphere_offsets]),
            sphere_radii=np.concatenate([self.sphere_radii, other.sphere_radii]),
            volume=np.concatenate([self.volume, other.volume]),
            principal_inertia=np.concatenate([self.principal_inertia, other.principal_inertia]),
            bounding_radius=np.concatenate([self.bounding_radius, other.bounding_radius]),
        )


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
        return cls(
            positions=np.array(positions, dtype=np.float64),
            orientations=np.array(orientations, dtype=np.float64),
            velocities=np.zeros((n, 3)), angular_velocities=np.zeros((n, 3)),
            masses=rho * library.volume[ids], inertias=rho * library.principal_inertia[ids],
            shape_ids=ids, density=rho,
        )

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

    def momentum(self) -> np.ndarray:
        """Total linear momentum (3,) [kg m/s]."""
        return np.sum(self.masses[:, None] * self.velocities, axis=0)

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the origin (3,) [kg m^2/s]: orbital plus spin."""
        orbital = np.cross(self.positions, self.masses[:, None] * self.velocities)
        spin = self._world_inertia_times(self.angular_velocities)
        return np.sum(orbital + spin, axis=0)
