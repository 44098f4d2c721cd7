"""The contact network: the one data class the analysis layer reads.

A snapshot of a granular sample at two levels (seeds 002/003):

* **interactions** (particle pairs, "neighbours"): the two particles, the branch vector from the
  first to the second (periodic images resolved) and, for non-spherical particles, the pair's
  contact type (fv/ee/fe/ff for polyhedra, s/ds/d/t/q for aggregates);
* **contact points**: the interaction each belongs to, its position, unit normal (from the first
  particle of the pair towards the second) and the force the first particle exerts on the
  second — so that f . n > 0 in compression.

A sample held by walls also carries its **wall contacts** (the particle, the point, the
normal pointing from the wall into the particle and the force the wall exerts on it) and the
box (its lower and upper corners): the stress counts them (the walls hold the sample: without
them the contact stress falls short of the wall reactions) and so does the rattler rule; the
analysis of the core (:mod:`grainlab.analysis.wall_layer`) reads the box.

z counts interactions per particle, z_c contact points per particle (seed 002 eqs. 13–14). The
engine fills a network, files restore it (:meth:`ContactNetwork.to_hdf5`), tests build it by
hand. Arrays only: no particle or contact objects.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import h5py
import numpy as np

from grainlab.errors import InputError

NETWORK_FORMAT = "grainlab.contact_network"
NETWORK_FORMAT_VERSION = 1


def _array(name: str, value, shape: tuple, dtype=float) -> np.ndarray:
    """Validate the shape (None = any length) and finiteness of an input array; an empty
    input is accepted as an empty array of the right shape."""
    array = np.array(value, dtype=dtype)  # a copy: the caller's arrays stay writable
    if array.size == 0:
        array = array.reshape(tuple(0 if s is None else s for s in shape))
    if array.ndim != len(shape) or any(s is not None and s != a for s, a in
                                        zip(shape, array.shape, strict=False)):
        expected = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise InputError(name, f"array of shape {array.shape}", f"an array of shape {expected}")
    if array.dtype.kind == "f" and not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise InputError(f"{name}[{', '.join(map(str, bad))}]", float(array[tuple(bad)]),
                         "a finite number")
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class ContactNetwork:
    """A snapshot of particles, their interactions and contact points (SI units).

    Attributes
    ----------
    positions:
        (N, d) particle centres (centres of mass) [m], d = 2 or 3.
    volumes:
        (N,) particle volumes [m^3] (areas [m^2] in 2D).
    volume:
        Volume of the sample [m^3] (area in 2D).
    pair_particles:
        (P, 2) indices of the two particles of each interaction.
    pair_branches:
        (P, d) branch vectors from the first to the second particle centre [m].
    point_pairs:
        (C,) interaction index of each contact point; every interaction has at least one.
    point_positions:
        (C, d) contact points [m], absolute, next to the first particle's centre as stored in
        ``positions`` (for a periodic pair the second particle is at x_i + l, not x_j).
    point_normals:
        (C, d) unit contact normals, from the first particle towards the second.
    point_forces:
        (C, d) forces the first particle exerts on the second [N] (N/m in 2D).
    pair_types:
        (P,) integer contact-type codes indexing ``type_names``, or None.
    type_names:
        Names of the contact types (e.g. ``("fv", "ee", "fe", "ff")``).
    type_points:
        For networks that store each pair as its one resultant point (polyhedra, seed 002:
        "the net resultant ... is attributed to the contact"): the number of contact points
        a pair of each type stands for, e.g. fv 1, ee 1, fe 2, ff 3 (eq. 14); connectivity
        numbers count these. Empty (default) when every stored point is a real contact.
    friction_coefficient:
        Interparticle friction coefficient mu [-], needed for friction descriptors.
    point_sliding:
        (C,) solver-reported sliding flags, or None (then |f_t| >= mu f_n decides).
    wall_particles:
        (W,) particle of each loaded wall contact point, or None (a network without walls,
        or one whose walls were not recorded).
    wall_points, wall_normals, wall_forces:
        (W, d) the points [m], unit normals (from the wall into the particle) and the forces
        the walls exert on the particles [N]; given with ``wall_particles``.
    box_lower, box_upper:
        (d,) corners of the axis-aligned wall box [m], or None (no walls, a periodic cell).
    state:
        Plain data about the snapshot (step, time, strains such as ``eps_q``, ...).

    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0, 0, 0], [2, 0, 0]], volumes=[4.19, 4.19], volume=30.0,
    ...     pair_particles=[[0, 1]], pair_branches=[[2, 0, 0]], point_pairs=[0],
    ...     point_positions=[[1, 0, 0]], point_normals=[[1, 0, 0]], point_forces=[[5, 0, 0]])
    >>> net.n_particles, net.n_pairs, net.n_points
    (2, 1, 1)
    """

    positions: np.ndarray
    volumes: np.ndarray
    volume: float
    pair_particles: np.ndarray
    pair_branches: np.ndarray
    point_pairs: np.ndarray
    point_positions: np.ndarray
    point_normals: np.ndarray
    point_forces: np.ndarray
    pair_types: np.ndarray | None = None
    type_names: tuple[str, ...] = ()
    type_points: tuple[int, ...] = ()
    friction_coefficient: float | None = None
    point_sliding: np.ndarray | None = None
    wall_particles: np.ndarray | None = None
    wall_points: np.ndarray | None = None
    wall_normals: np.ndarray | None = None
    wall_forces: np.ndarray | None = None
    box_lower: np.ndarray | None = None
    box_upper: np.ndarray | None = None
    state: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_arrays(cls, **arrays) -> ContactNetwork:
        """Build and validate a network from array-likes (same names as the attributes)."""
        return cls(**arrays)

    def __post_init__(self) -> None:
        positions = np.asarray(self.positions, dtype=float)
        if positions.ndim != 2 or positions.shape[1] not in (2, 3):
            raise InputError("positions", f"array of shape {positions.shape}",
                             "an (N, 2) or (N, 3) array of particle centres")
        n, d = positions.shape
        set_ = object.__setattr__
        set_(self, "positions", _array("positions", positions, (n, d)))
        volumes = _array("volumes", self.volumes, (n,))
        if np.any(volumes <= 0):
            k = int(np.argmax(volumes <= 0))
            raise InputError(f"volumes[{k}]", float(volumes[k]), "a positive particle volume")
        set_(self, "volumes", volumes)
        if not (np.isfinite(self.volume) and self.volume > 0):
            raise InputError("volume", self.volume, "a positive sample volume")
        set_(self, "volume", float(self.volume))
        pairs = _array("pair_particles", self.pair_particles, (None, 2), dtype=np.int64)
        if pairs.size and (pairs.min() < 0 or pairs.max() >= n):
            bad = int(pairs.max() if pairs.max() >= n else pairs.min())
            raise InputError("pair_particles", bad, f"particle indices in [0, {n - 1}]")
        set_(self, "pair_particles", pairs)
        p = pairs.shape[0]
        branches = _array("pair_branches", self.pair_branches, (p, d))
        if p and np.any(np.linalg.norm(branches, axis=1) <= 0):
            k = int(np.argmin(np.linalg.norm(branches, axis=1)))
            raise InputError(f"pair_branches[{k}]", branches[k].tolist(),
                             "a non-zero branch vector")
        set_(self, "pair_branches", branches)
        point_pairs = _array("point_pairs", self.point_pairs, (None,), dtype=np.int64)
        if point_pairs.size and (point_pairs.min() < 0 or point_pairs.max() >= p):
            bad = int(point_pairs.max() if point_pairs.max() >= p else point_pairs.min())
            raise InputError("point_pairs", bad, f"interaction indices in [0, {p - 1}]")
        if p and np.bincount(point_pairs, minlength=p).min() == 0:
            k = int(np.argmin(np.bincount(point_pairs, minlength=p)))
            raise InputError(f"pair_particles[{k}]", pairs[k].tolist(),
                             "an interaction with at least one contact point")
        set_(self, "point_pairs", point_pairs)
        c = point_pairs.shape[0]
        for name in ("point_positions", "point_normals", "point_forces"):
            set_(self, name, _array(name, getattr(self, name), (c, d)))
        lengths = np.linalg.norm(self.point_normals, axis=1)
        if c and np.any(np.abs(lengths - 1.0) > 1e-6):
            k = int(np.argmax(np.abs(lengths - 1.0)))
            raise InputError(f"point_normals[{k}]", self.point_normals[k].tolist(),
                             "a unit vector (length 1 within 1e-6)")
        if self.pair_types is not None:
            types = _array("pair_types", self.pair_types, (p,), dtype=np.int64)
            if types.size and (types.min() < 0 or types.max() >= len(self.type_names)):
                raise InputError("pair_types", int(types.max()),
                                 f"codes indexing type_names {tuple(self.type_names)}")
            set_(self, "pair_types", types)
        set_(self, "type_names", tuple(str(t) for t in self.type_names))
        points = tuple(self.type_points)
        if points and (self.pair_types is None or len(points) != len(self.type_names) or not all(
                isinstance(m, (int, np.integer)) and not isinstance(m, bool) and m >= 1
                for m in points)):
            raise InputError("type_points", points, "one integer >= 1 per name of type_names "
                             f"{tuple(self.type_names)}, with pair_types given")
        set_(self, "type_points", tuple(int(m) for m in points))
        if self.friction_coefficient is not None and not (
            np.isfinite(self.friction_coefficient) and self.friction_coefficient >= 0
        ):
            raise InputError("friction_coefficient", self.friction_coefficient,
                             "a friction coefficient >= 0")
        if self.point_sliding is not None:
            set_(self, "point_sliding",
                 _array("point_sliding", self.point_sliding, (c,), dtype=bool))
        self._check_walls(n, d)

    def _check_walls(self, n: int, d: int) -> None:
        """Validate the wall contacts and the box (attributes above)."""
        set_ = object.__setattr__
        names = ("wall_points", "wall_normals", "wall_forces")
        if self.wall_particles is None:
            given = [name for name in names if getattr(self, name) is not None]
            if given:
                raise InputError(given[0], "an array", "None without wall_particles")
        else:
            particles = _array("wall_particles", self.wall_particles, (None,), dtype=np.int64)
            if particles.size and (particles.min() < 0 or particles.max() >= n):
                bad = int(particles.max() if particles.max() >= n else particles.min())
                raise InputError("wall_particles", bad, f"particle indices in [0, {n - 1}]")
            set_(self, "wall_particles", particles)
            w = particles.shape[0]
            for name in names:
                if getattr(self, name) is None:
                    raise InputError(name, None, f"a ({w}, {d}) array with wall_particles")
                set_(self, name, _array(name, getattr(self, name), (w, d)))
            lengths = np.linalg.norm(self.wall_normals, axis=1)
            if w and np.any(np.abs(lengths - 1.0) > 1e-6):
                k = int(np.argmax(np.abs(lengths - 1.0)))
                raise InputError(f"wall_normals[{k}]", self.wall_normals[k].tolist(),
                                 "a unit vector (length 1 within 1e-6)")
        if (self.box_lower is None) != (self.box_upper is None):
            raise InputError("box_lower" if self.box_lower is None else "box_upper", None,
                             "both corners of the box, or neither")
        if self.box_lower is not None:
            lower = _array("box_lower", self.box_lower, (d,))
            upper = _array("box_upper", self.box_upper, (d,))
            if np.any(upper <= lower):
                raise InputError("box_upper", upper.tolist(),
                                 f"a corner above box_lower {lower.tolist()} on every axis")
            set_(self, "box_lower", lower)
            set_(self, "box_upper", upper)

    @property
    def has_box(self) -> bool:
        """Whether the sample is held by the walls of a box (``box_lower``, ``box_upper``)."""
        return self.box_lower is not None

    @property
    def n_wall_points(self) -> int:
        """Number of loaded wall contact points W (0 without wall contacts)."""
        return 0 if self.wall_particles is None else int(self.wall_particles.shape[0])

    @property
    def wall_ids(self) -> np.ndarray:
        """(W,) the wall of each wall contact point, known by its normal in an axis-aligned
        box: 2 a for the wall below on axis a (normal +e_a), 2 a + 1 for the one above."""
        if self.wall_particles is None:
            return np.zeros(0, dtype=np.int64)
        axis = np.argmax(np.abs(self.wall_normals), axis=1)
        below = self.wall_normals[np.arange(axis.size), axis] > 0
        return (2 * axis + np.where(below, 0, 1)).astype(np.int64)

    # -- sizes --------------------------------------------------------------------------------
    @property
    def dimension(self) -> int:
        """2 or 3."""
        return int(self.positions.shape[1])

    @property
    def n_particles(self) -> int:
        """Number of particles N."""
        return int(self.positions.shape[0])

    @property
    def n_pairs(self) -> int:
        """Number of interactions (particle pairs) P."""
        return int(self.pair_particles.shape[0])

    @property
    def n_points(self) -> int:
        """Number of contact points C."""
        return int(self.point_pairs.shape[0])

    # -- derived arrays -----------------------------------------------------------------------
    @property
    def point_normal_forces(self) -> np.ndarray:
        """(C,) normal force f_n = f . n [N], positive in compression."""
        return np.einsum("ci,ci->c", self.point_forces, self.point_normals)

    @property
    def point_tangential_forces(self) -> np.ndarray:
        """(C, d) tangential force vectors f - f_n n [N]."""
        return self.point_forces - self.point_normal_forces[:, None] * self.point_normals

    @property
    def point_branches(self) -> np.ndarray:
        """(C, d) branch vector of the interaction each point belongs to [m]."""
        return self.pair_branches[self.point_pairs]

    @property
    def pair_forces(self) -> np.ndarray:
        """(P, d) resultant force of each interaction (sum over its points) [N]."""
        forces = np.zeros((self.n_pairs, self.dimension))
        for axis in range(self.dimension):
            forces[:, axis] = np.bincount(self.point_pairs, self.point_forces[:, axis],
                                          minlength=self.n_pairs)
        return forces

    @property
    def pair_point_counts(self) -> np.ndarray:
        """(P,) number of contact points of each interaction."""
        return np.bincount(self.point_pairs, minlength=self.n_pairs)

    def active_points(self, threshold: float = 0.0) -> np.ndarray:
        """(C,) True where the contact point carries a normal force above ``threshold`` [N]."""
        return self.point_normal_forces > threshold

    def active_pairs(self, threshold: float = 0.0) -> np.ndarray:
        """(P,) True where at least one point of the interaction is active."""
        return np.bincount(self.point_pairs, self.active_points(threshold).astype(float),
                           minlength=self.n_pairs) > 0

    # -- transformations (for invariance checks and frames) -----------------------------------
    def transformed(self, rotation: np.ndarray, shift: np.ndarray | None = None) -> ContactNetwork:
        """The network rotated by the orthogonal matrix R (x -> R x + shift). Entries of
        ``state`` (plain data) are copied unchanged."""
        rotation = np.asarray(rotation, dtype=float)
        d = self.dimension
        if rotation.shape != (d, d) or not np.allclose(rotation @ rotation.T, np.eye(d),
                                                       atol=1e-10):
            raise InputError("rotation", rotation.tolist(), f"an orthogonal {d}x{d} matrix")
        shift = np.zeros(self.dimension) if shift is None else np.asarray(shift, dtype=float)
        walls = {}
        if self.wall_particles is not None:
            walls = {"wall_points": self.wall_points @ rotation.T + shift,
                     "wall_normals": self.wall_normals @ rotation.T,
                     "wall_forces": self.wall_forces @ rotation.T}
        box = {}
        if self.has_box:  # an axis-aligned box stays one only without rotation
            same = np.allclose(rotation, np.eye(d), atol=1e-12)
            box = {"box_lower": self.box_lower + shift if same else None,
                   "box_upper": self.box_upper + shift if same else None}
        return _replace(
            self,
            positions=self.positions @ rotation.T + shift,
            pair_branches=self.pair_branches @ rotation.T,
            point_positions=self.point_positions @ rotation.T + shift,
            point_normals=self.point_normals @ rotation.T,
            point_forces=self.point_forces @ rotation.T,
            **walls, **box,
        )

    def relabelled(self, particle_order: np.ndarray, pair_order: np.ndarray | None = None,
                   point_order: np.ndarray | None = None) -> ContactNetwork:
        """The same network with particles (and optionally pairs and points) listed in another
        order: ``particle_order[k]`` is the old index of new particle k."""
        particle_order = np.asarray(particle_order)
        new_index = np.empty_like(particle_order)
        new_index[particle_order] = np.arange(particle_order.size)
        pair_order = np.arange(self.n_pairs) if pair_order is None else np.asarray(pair_order)
        point_order = np.arange(self.n_points) if point_order is None else np.asarray(point_order)
        new_pair = np.empty_like(pair_order)
        new_pair[pair_order] = np.arange(pair_order.size)
        return _replace(
            self,
            positions=self.positions[particle_order],
            volumes=self.volumes[particle_order],
            pair_particles=new_index[self.pair_particles[pair_order]],
            pair_branches=self.pair_branches[pair_order],
            pair_types=None if self.pair_types is None else self.pair_types[pair_order],
            point_pairs=new_pair[self.point_pairs[point_order]],
            point_positions=self.point_positions[point_order],
            point_normals=self.point_normals[point_order],
            point_forces=self.point_forces[point_order],
            point_sliding=None if self.point_sliding is None else self.point_sliding[point_order],
            wall_particles=None if self.wall_particles is None
            else new_index[self.wall_particles],
        )

    # -- files --------------------------------------------------------------------------------
    ARRAYS = ("positions", "volumes", "pair_particles", "pair_branches", "point_pairs",
              "point_positions", "point_normals", "point_forces", "pair_types", "point_sliding",
              "wall_particles", "wall_points", "wall_normals", "wall_forces", "box_lower",
              "box_upper")
    """Arrays of a network group; the wall arrays and the box are absent from files written
    before networks carried them (they read as None)."""

    def to_hdf5(self, group: h5py.Group) -> None:
        """Write the network into an (empty) HDF5 group."""
        import json

        group.attrs["format"] = NETWORK_FORMAT
        group.attrs["format_version"] = NETWORK_FORMAT_VERSION
        group.attrs["volume"] = self.volume
        group.attrs["type_names"] = json.dumps(list(self.type_names))
        group.attrs["type_points"] = json.dumps(list(self.type_points))
        group.attrs["friction_coefficient"] = (
            np.nan if self.friction_coefficient is None else self.friction_coefficient
        )
        group.attrs["state"] = json.dumps(self.state)
        for name in self.ARRAYS:
            value = getattr(self, name)
            if value is not None:
                group.create_dataset(name, data=value, compression="gzip", compression_opts=1)

    @classmethod
    def from_hdf5(cls, group: h5py.Group) -> ContactNetwork:
        """Read a network written by :meth:`to_hdf5`."""
        import json

        if group.attrs.get("format") != NETWORK_FORMAT:
            raise InputError("HDF5 group", group.name, f"a {NETWORK_FORMAT} group")
        mu = float(group.attrs["friction_coefficient"])
        arrays = {name: group[name][()] for name in cls.ARRAYS if name in group}
        return cls(
            volume=float(group.attrs["volume"]),
            type_names=tuple(json.loads(group.attrs["type_names"])),
            type_points=tuple(json.loads(group.attrs.get("type_points", "[]"))),
            friction_coefficient=None if np.isnan(mu) else mu,
            state=json.loads(group.attrs["state"]),
            **arrays,
        )


def _replace(network: ContactNetwork, **changes) -> ContactNetwork:
    values = {name: getattr(network, name) for name in network.__dataclass_fields__}
    values.update(changes)
    return ContactNetwork(**values)
