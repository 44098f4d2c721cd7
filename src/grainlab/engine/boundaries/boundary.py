"""What bounds a discrete sample, as the contact solver sees it (STYLE.md 1, 4).

A boundary is one of

* fixed planes (points and inward normals; :class:`FixedPlanes`, e.g. a floor);
* the box of six walls, fixed, velocity- or stress-controlled
  (:class:`~grainlab.engine.boundaries.wall_box.WallBox`);
* the periodic deformable cell
  (:class:`~grainlab.engine.boundaries.periodic_boundary.PeriodicCell`).

Each implements the :class:`Boundary` protocol, three calls per time step of a solver:

1. :meth:`Boundary.constraints` (h, theta): what the step's contact problem needs from the
   boundary: the walls (points at the detection configuration, inward normals, inverse
   masses, free normal speeds, speed limits, friction) and the cell (the prescribed part of
   its rate hdot, and per free degree of freedom its direction, inverse mass, free value and
   bounds); empty arrays for what the boundary does not have;
2. :meth:`Boundary.detect` (predicted state, library, detection phases, constraints): the
   contacts at the detection configuration, with the image vector m_k of body j of each
   contact (zero but in a periodic cell: contact k is then with the image of body j
   translated by h m_k);
3. :meth:`Boundary.finish_step` (:class:`BoundaryMotion`): move to the end of the step with
   the speeds and the cell rate the contact problem found, record the reactions.

A solver never asks what kind of boundary it has: a new boundary implements the three calls
(and ``volume``, ``speed``, the checkpoint pair ``to_arrays`` / ``from_arrays``, the flag
``periodic`` and, to be made around a loose sample, the class method ``around``) and every
solver runs with it. Whoever needs to know more than the solver asks the boundary itself
(``periodic``), never its class; the lab reads the rest (its name, its stage driver, what it
allows) from its record in :mod:`grainlab.lab.boundary_registry`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from grainlab.engine.detect.broad_phase import CellListBroadPhase
from grainlab.engine.detect.narrow_phase import Contacts, NarrowPhase
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError


def _no_cell_basis() -> np.ndarray:
    return np.zeros((0, 3, 3))


@dataclass(frozen=True, eq=False)
class BoundaryConstraints:
    """What the contact problem of one step needs from the boundary (module docstring).

    Walls (W of them): ``wall_points`` (W, 3) [m] at the detection configuration,
    ``wall_normals`` (W, 3) unit, into the sample; ``wall_inv_mass`` (W,) [1/kg] (0: driven);
    ``wall_free`` (W,) free normal speeds [m/s]; ``wall_max`` (W,) speed limits [m/s] (inf:
    none); ``wall_friction`` (W,). Cell (D free degrees of freedom e_d): ``cell_fixed`` (3, 3)
    the prescribed part of hdot [m/s]; ``cell_basis`` (D, 3, 3) H_d [m] (hdot = cell_fixed +
    sum_d e_d H_d); ``cell_inv_mass`` (D,); ``cell_free`` (D,) and ``cell_bounds`` (D, 2)
    [1/s]; ``cell_matrix`` (3, 3) [m] the cell h at the detection configuration (columns:
    cell vectors); ``affine_change`` (3, 3) [1/s]: a change of the cell's velocity gradient
    that the particles' velocities take up before the step (v_i += A (x_i - x_c), x_c the
    centre of mass; zero but when a periodic cell's rate changed). ``speed`` [m/s]: the
    fastest the boundary may close a gap within the step (alert distance growth).
    ``walls_overdamped``: the mobile walls are servos without inertia, whose speed at the
    end of the step is ``wall_free`` - ``wall_inv_mass`` x (the impulse of their contacts),
    with nothing carried from the step before (False: walls with mass, whose free speed
    carries their speed).
    """

    wall_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    wall_normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    wall_inv_mass: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wall_free: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wall_max: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wall_friction: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cell_fixed: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    cell_basis: np.ndarray = field(default_factory=_no_cell_basis)
    cell_inv_mass: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cell_free: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cell_bounds: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    cell_matrix: np.ndarray = field(default_factory=lambda: np.eye(3))
    affine_change: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    speed: float = 0.0
    walls_overdamped: bool = True

    @property
    def n_walls(self) -> int:
        """W."""
        return int(self.wall_normals.shape[0])

    @property
    def has_free_cell(self) -> bool:
        """Whether a cell degree of freedom is solved with the contacts (its image contacts
        then all share it, like the contacts of a mobile wall)."""
        return bool(np.any(self.cell_inv_mass > 0.0))


@dataclass(frozen=True, eq=False)
class ClosedContacts:
    """A step's contacts as a boundary reads them: the ``contacts``, their ``images``
    (C, 3), local ``impulses`` (C, 3) (P_n, P_t, P_s) [N s] and world ``forces`` (C, 3) [N]
    on body j."""

    contacts: Contacts
    images: np.ndarray
    impulses: np.ndarray
    forces: np.ndarray


@dataclass(frozen=True, eq=False)
class BoundaryMotion:
    """What the contact problem found for the boundary over one step: ``dt`` [s], ``theta``;
    ``wall_speeds`` (W,) [m/s] end-of-step normal speeds and ``wall_reactions`` (W,) [N]
    (normal force of the particles on each wall, compression positive); ``cell_dofs`` (D,)
    and ``cell_rate`` (3, 3) [m/s] (hdot at the end of the step); ``closed``, the step's
    contacts (a :class:`ClosedContacts`, or anything with its four attributes: an explicit
    solver's step report, which makes them only when they are read), also read as
    ``contacts``, ``images``, ``impulses`` and ``forces``; ``stress`` (3, 3) [Pa]: the mean
    stress of all the contacts over the step (compression positive), when the solver
    measured it (an explicit solver; a periodic cell then records it and its servo's
    integral follows it), else None."""

    dt: float
    theta: float
    wall_speeds: np.ndarray
    wall_reactions: np.ndarray
    cell_dofs: np.ndarray
    cell_rate: np.ndarray
    closed: ClosedContacts
    stress: np.ndarray | None = None

    @property
    def contacts(self) -> Contacts:
        """The step's contacts."""
        return self.closed.contacts

    @property
    def images(self) -> np.ndarray:
        """(C, 3) image vectors of body j."""
        return self.closed.images

    @property
    def impulses(self) -> np.ndarray:
        """(C, 3) local (P_n, P_t, P_s) [N s]."""
        return self.closed.impulses

    @property
    def forces(self) -> np.ndarray:
        """(C, 3) world forces on body j [N]."""
        return self.closed.forces


@dataclass
class DetectionPhases:
    """The broad and narrow phases a solver keeps for its alert distance [m]; with
    ``sphere_rows``, a periodic cell finds the contacts of plain spheres by its compiled cell
    list (:mod:`grainlab.engine.detect.periodic_spheres`: the same contacts, rows by body_i then
    body_j; the soft-contact solver's lists), else by the general detection, whose row order
    contact dynamics' sweeps follow."""

    alert: float
    broad: CellListBroadPhase
    narrow: NarrowPhase
    sphere_rows: bool = False

    @classmethod
    def with_alert(cls, alert: float, sphere_rows: bool = False) -> DetectionPhases:
        """New phases for ``alert`` [m]."""
        return cls(alert, CellListBroadPhase(alert=alert), NarrowPhase(alert=alert),
                   sphere_rows)


class Boundary(Protocol):
    """A boundary of a discrete sample (module docstring).

    Attributes
    ----------
    periodic:
        Whether the sample fills a periodic cell (no walls: contacts reach through the
        images of the bodies, the boundary has an ``image_matrix`` h [m] of the last step's
        images) rather than a region closed by walls.
    """

    periodic: bool

    def constraints(self, dt: float, theta: float) -> BoundaryConstraints:
        """The step's boundary data (module docstring, call 1)."""

    def detect(self, predicted: BodyState, library: ShapeLibrary, phases: DetectionPhases,
               constraints: BoundaryConstraints) -> tuple[Contacts, np.ndarray]:
        """Contacts at the detection configuration and their images (C, 3) (call 2)."""

    def finish_step(self, motion: BoundaryMotion) -> None:
        """Advance to the end of the step (call 3)."""

    def health_arrays(self) -> dict[str, np.ndarray]:
        """Named arrays that must stay finite (a simulation's health check)."""


def as_boundary(walls, friction: float = 0.0) -> Boundary:
    """A solver's ``walls`` argument as a boundary: a :class:`Boundary` as it is, None as
    open space, (points (W, 3) [m], normals (W, 3)) as :class:`FixedPlanes` of Coulomb
    coefficient ``friction``."""
    if walls is None:
        return FixedPlanes()
    if isinstance(walls, tuple | list):
        return FixedPlanes(walls[0], walls[1], friction)
    return walls


def detect_in_space(predicted: BodyState, library: ShapeLibrary, phases: DetectionPhases,
                    wall_points: np.ndarray | None, wall_normals: np.ndarray | None
                    ) -> tuple[Contacts, np.ndarray]:
    """Contacts of bodies in open space (no periodicity) and with planes: the broad phase
    over the bounding box of the centres, then the narrow phase; images all zero."""
    x_m = predicted.positions
    bounding = library.bounding_radius[predicted.shape_ids]
    if predicted.n_bodies:
        pad = float(bounding.max()) + phases.alert + 1e-9
        lo, hi = x_m.min(axis=0) - pad, x_m.max(axis=0) + pad
        pairs = phases.broad.find_pairs(x_m, bounding, lo, hi)
    else:
        pairs = np.zeros((0, 2), dtype=np.int64)
    contacts = phases.narrow.detect(predicted, library, pairs, wall_points, wall_normals)
    return contacts, np.zeros((contacts.n_contacts, 3))


class FixedPlanes:
    """Fixed planes through ``points`` (W, 3) [m] with unit ``normals`` (W, 3) into the bodies'
    region and Coulomb coefficient ``friction`` (>= 0); no planes: open space."""

    periodic = False

    def __init__(self, points=None, normals=None, friction: float = 0.0) -> None:
        if points is None and normals is None:
            self.points, self.normals = np.zeros((0, 3)), np.zeros((0, 3))
        else:
            self.points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
            self.normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        if self.points.shape != self.normals.shape:
            raise InputError("wall_normals", np.asarray(normals).tolist(),
                             f"one normal per wall point ({self.points.shape[0]})")
        self.friction = float(friction)

    def constraints(self, dt: float, theta: float) -> BoundaryConstraints:
        n = self.points.shape[0]
        return BoundaryConstraints(
            wall_points=self.points, wall_normals=self.normals, wall_inv_mass=np.zeros(n),
            wall_free=np.zeros(n), wall_max=np.full(n, np.inf),
            wall_friction=np.full(n, self.friction))

    def detect(self, predicted, library, phases, constraints):
        planes = (None, None) if constraints.n_walls == 0 else \
            (constraints.wall_points, constraints.wall_normals)
        return detect_in_space(predicted, library, phases, *planes)

    def finish_step(self, motion: BoundaryMotion) -> None:
        """Fixed planes do not move."""

    def health_arrays(self) -> dict[str, np.ndarray]:
        """Nothing moves."""
        return {}
