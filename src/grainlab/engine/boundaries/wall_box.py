"""A box of six planar walls, each fixed, velocity-controlled or stress-controlled
(seeds 002/003 §II; research/cd_engines.md 6.5; STYLE.md 9).

Walls are named by the axis they cut and their side: ``x-``, ``x+``, ``y-``, ``y+``, ``z-``,
``z+``. Wall w is the plane {x_a = c_w} of its axis a with the unit normal n_w pointing into the
box (+e_a for the ``-`` side, -e_a for the ``+`` side). A wall moves only along its normal, with
the normal speed s_w [m/s] (s_w > 0: moving into the box, compressing it); its velocity is
s_w n_w. Controls:

* ``fixed``: s_w = 0;
* ``velocity``: s_w = value [m/s], prescribed (infinite mass in the contact problem);
* ``stress``: the wall is a body of mass m_w [kg] pushed into the box by F_w = sigma A_w [N]
  with sigma = value [Pa] and A_w the current area of its face (the product of the box's two
  other lengths). Its free speed over a step h is s_w + h F_w / m_w; the contact impulses
  then act on it like on any body, so that in equilibrium the reaction of the particles equals
  sigma A_w (LMGC90's driven-force walls). With ``servo = True`` a stress-controlled wall
  carries no speed from one step to the next: its free speed is h F_w / m_w alone, so that
  with m_w = c_w h it moves at s_w = (F_w - R_w) / c_w, an overdamped servo of damping c_w
  [N s/m] (PFC's servo walls; :meth:`servo_masses`). A wall with momentum that was pushed
  out by a stress spike kept flying out after the particles stopped pushing, and a rigid
  sample behind it unloaded completely (docs/benchmarks/polyhedra.md).

A **planar** box holds a 2D sample of discs (:mod:`grainlab.engine.planar`): its z extent is
the discs' thickness t, so that its volume and the areas of its four side walls (L t) give
stresses in Pa, and its two z walls are out of reach (their planes lie :data:`PLANAR_REACH`
box lengths beyond the faces, where no disc meets them) and stay fixed.

The reaction R_w [N] of a wall is the normal force the particles exert on it over the last
step (sum of the normal impulses of its contacts / h), compression positive; the wall stress
on axis a is the mean of its two walls' R_w / A_w.

>>> box = WallBox(lower=[0, 0, 0], upper=[1, 2, 4])
>>> box.lengths.tolist(), box.volume, float(box.face_areas[4])
([1.0, 2.0, 4.0], 8.0, 2.0)
>>> box.set_control("z+", "velocity", 0.1)
>>> box.free_speeds(0.5).tolist()
[0.0, 0.0, 0.0, 0.0, 0.0, 0.1]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grainlab.engine.boundaries.boundary import BoundaryConstraints, BoundaryMotion, detect_in_space
from grainlab.errors import InputError

WALL_NAMES = ("x-", "x+", "y-", "y+", "z-", "z+")
"""Names of the six walls, in storage order."""
WALL_CONTROLS = ("fixed", "velocity", "stress")
"""Control modes of a wall."""
SERVO_GAIN = 20.0
"""Outward speed of a servo wall, in units of its speed limit, per unit relative overpressure
(R_w - F_w) / F_w: a lateral wall following a dilating sample at 0.4 s_max sits 2 % above
its stress."""
PLANAR_REACH = 1.0e3
"""How far (in box lengths) the z walls of a planar box lie beyond its faces."""
_AXIS = np.array([0, 0, 1, 1, 2, 2])
_SIGN = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])


def wall_index(name: str) -> int:
    """Storage index of the wall called ``name`` (one of :data:`WALL_NAMES`)."""
    if name not in WALL_NAMES:
        raise InputError("wall", name, "one of " + ", ".join(WALL_NAMES))
    return WALL_NAMES.index(name)


@dataclass(frozen=True)
class WallControl:
    """How one wall is driven: ``mode`` in :data:`WALL_CONTROLS` and its ``value`` (normal
    speed [m/s] into the box for ``velocity``, compressive stress [Pa] for ``stress``)."""

    mode: str = "fixed"
    value: float = 0.0

    def __post_init__(self) -> None:
        if self.mode not in WALL_CONTROLS:
            raise InputError("wall control", self.mode, "one of " + ", ".join(WALL_CONTROLS))
        v = float(self.value)
        if not math.isfinite(v):
            raise InputError("wall control value", self.value, "a finite number")
        if self.mode == "stress" and v < 0.0:
            raise InputError("wall stress", self.value, "a compressive stress >= 0 Pa")
        object.__setattr__(self, "value", v)


class WallBox:
    """Six walls around the box [lower, upper] (module docstring).

    Parameters
    ----------
    lower, upper:
        (3,) corners of the box [m], upper > lower.
    friction:
        Coulomb coefficient of the wall-particle contacts (one value or six), >= 0.
    wall_mass:
        Mass m_w [kg] of the stress-controlled walls (one value or six), > 0; may be set later
        (:meth:`set_masses`) from the particles' mass.
    planar:
        A box of a 2D sample (module docstring): the z walls out of reach and fixed.
    """

    periodic = False
    """A box of walls is not periodic (:class:`~grainlab.engine.boundaries.boundary.Boundary`)."""

    def __init__(self, lower: Sequence[float], upper: Sequence[float],
                 friction: float | Sequence[float] = 0.0,
                 wall_mass: float | Sequence[float] = 1.0, planar: bool = False) -> None:
        lo = np.asarray(lower, dtype=np.float64)
        hi = np.asarray(upper, dtype=np.float64)
        if lo.shape != (3,) or not np.isfinite(lo).all():
            raise InputError("lower", lower, "three finite coordinates in m")
        if hi.shape != (3,) or not np.isfinite(hi).all() or np.any(hi <= lo):
            raise InputError("upper", upper, "three finite coordinates in m, above lower")
        self.coordinates = np.array([lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]])
        self.speeds = np.zeros(6)
        self.reactions = np.zeros(6)
        self.controls = [WallControl() for _ in WALL_NAMES]
        self.friction = self._six("friction", friction, allow_zero=True)
        self.masses = self._six("wall_mass", wall_mass, allow_zero=False)
        self.max_speeds = np.full(6, np.inf)
        self.servo = False
        self.planar = bool(planar)

    @classmethod
    def around(cls, side, wall_friction: float, particle_mass: float,
               planar: bool = False) -> WallBox:
        """The box [0, side] (``side`` (3,) [m]) around a loose sample: fixed walls of Coulomb
        coefficient ``wall_friction``, each of mass ``particle_mass`` [kg] (the particles'
        total) until a stage sets the masses of its stress-controlled walls; ``planar``: a
        2D sample's box (``side[2]`` the discs' thickness)."""
        box = cls(np.zeros(3), side, friction=wall_friction, planar=planar)
        box.set_masses(particle_mass)
        return box

    @staticmethod
    def _six(name: str, value, allow_zero: bool) -> np.ndarray:
        values = np.broadcast_to(np.asarray(value, dtype=np.float64), (6,)).copy() \
            if np.ndim(value) == 0 else np.asarray(value, dtype=np.float64)
        if values.shape != (6,) or not np.isfinite(values).all() or np.any(values < 0.0) \
                or (not allow_zero and np.any(values == 0.0)):
            raise InputError(name, value, "one finite number or six, "
                             + (">= 0" if allow_zero else "> 0"))
        return values

    # -- geometry ----------------------------------------------------------------------------
    @property
    def normals(self) -> np.ndarray:
        """(6, 3) unit normals pointing into the box."""
        n = np.zeros((6, 3))
        n[np.arange(6), _AXIS] = _SIGN
        return n

    @property
    def lower(self) -> np.ndarray:
        """(3,) lower corner [m]."""
        return self.coordinates[0::2].copy()

    @property
    def upper(self) -> np.ndarray:
        """(3,) upper corner [m]."""
        return self.coordinates[1::2].copy()

    @property
    def lengths(self) -> np.ndarray:
        """(3,) box lengths [m] along x, y, z."""
        return self.coordinates[1::2] - self.coordinates[0::2]

    @property
    def volume(self) -> float:
        """Box volume [m^3]."""
        return float(np.prod(self.lengths))

    @property
    def face_areas(self) -> np.ndarray:
        """(6,) current areas of the walls' faces [m^2]."""
        lengths = self.lengths
        areas = np.array([lengths[1] * lengths[2], lengths[0] * lengths[2],
                          lengths[0] * lengths[1]])
        return areas[_AXIS]

    def planes(self, advance: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Points (6, 3) [m] and normals (6, 3) of the planes after moving them for
        ``advance`` [s] at their current speeds."""
        coordinates = self.coordinates + advance * self.speeds * _SIGN
        if self.planar:  # the z walls out of reach
            coordinates[4:] -= PLANAR_REACH * float(np.max(self.lengths)) * _SIGN[4:]
        centre = 0.5 * (self.coordinates[0::2] + self.coordinates[1::2])
        points = np.tile(centre, (6, 1))
        points[np.arange(6), _AXIS] = coordinates
        return points, self.normals

    # -- control -----------------------------------------------------------------------------
    def set_control(self, wall: str, mode: str, value: float = 0.0) -> None:
        """Drive ``wall`` (a name of :data:`WALL_NAMES`) by ``mode`` with ``value``."""
        control = WallControl(mode, value)
        w = wall_index(wall)
        if self.planar and _AXIS[w] == 2 and mode != "fixed":
            raise InputError("wall", wall, "x-, x+, y- or y+: the z walls of a planar box "
                             "(a 2D sample) stay fixed")
        self.controls[w] = control
        if mode == "fixed":
            self.speeds[w] = 0.0
        elif mode == "velocity":
            self.speeds[w] = control.value

    def servo_masses(self, dt: float) -> np.ndarray:
        """(6,) masses m_w = c_w h [kg] of servo walls over a step of ``dt`` [s], with the
        damping c_w = F_w / (G s_max,w) [N s/m], G = :data:`SERVO_GAIN`: a wall moves out at
        G s_max (R_w / F_w - 1) against the reaction R_w (an overpressure of 1/G per s_max
        of outward speed), in at its limit s_max when nothing holds it (1 kg where the wall
        is not stress-controlled or has no limit)."""
        limited = self.stress_controlled & np.isfinite(self.max_speeds)
        force = self.driving_forces()
        masses = np.ones(6)
        ok = limited & (force > 0.0)
        masses[ok] = force[ok] / (SERVO_GAIN * self.max_speeds[ok]) * dt
        return masses

    def set_masses(self, wall_mass: float | Sequence[float]) -> None:
        """Set the masses [kg] of the walls (used by stress-controlled ones)."""
        self.masses = self._six("wall_mass", wall_mass, allow_zero=False)

    @property
    def stress_controlled(self) -> np.ndarray:
        """(6,) True where the wall is stress-controlled."""
        return np.array([c.mode == "stress" for c in self.controls])

    def driving_forces(self) -> np.ndarray:
        """(6,) forces F_w = sigma A_w [N] pushing stress-controlled walls into the box."""
        sigma = np.array([c.value if c.mode == "stress" else 0.0 for c in self.controls])
        return sigma * self.face_areas

    def inverse_masses(self) -> np.ndarray:
        """(6,) inverse masses [1/kg] in the contact problem (0 for driven walls)."""
        return np.where(self.stress_controlled, 1.0 / self.masses, 0.0)

    def free_speeds(self, dt: float) -> np.ndarray:
        """(6,) normal speeds [m/s] at the end of a step of ``dt`` [s] without contacts."""
        speeds = np.empty(6)
        for w, control in enumerate(self.controls):
            if control.mode == "fixed":
                speeds[w] = 0.0
            elif control.mode == "velocity":
                speeds[w] = control.value
            else:
                speeds[w] = 0.0 if self.servo else self.speeds[w]
        stress = self.stress_controlled
        speeds[stress] += dt * self.driving_forces()[stress] / self.masses[stress]
        return speeds

    def set_max_speeds(self, max_speed: float | Sequence[float]) -> None:
        """Limit [m/s] (one value or six, > 0, inf for none) on the inward speed of the
        stress-controlled walls, enforced by the contact solver as a unilateral constraint
        (a brake that acts only when the wall would move in faster; it never weakens the
        wall's push on the particles at rest). Used to bound the inertia number."""
        values = np.broadcast_to(np.asarray(max_speed, dtype=np.float64), (6,)).copy()
        if np.any(np.isnan(values)) or np.any(values <= 0.0):
            raise InputError("max_speed", max_speed, "one number or six, > 0 m/s (inf: none)")
        self.max_speeds = values

    def move(self, speeds: np.ndarray, predicted: float, advance: float,
             reactions: np.ndarray) -> None:
        """End a step: move the walls by ``predicted`` [s] at their old speeds (to where
        :meth:`planes` put them for detection) and then by ``advance`` [s] at the end-of-step
        ``speeds`` (6,) [m/s]; record ``reactions`` (6,) [N]."""
        self.coordinates += predicted * self.speeds * _SIGN
        self.speeds[:] = speeds
        self.coordinates += advance * self.speeds * _SIGN
        self.reactions[:] = reactions
        if np.any(self.lengths <= 0.0):
            raise InputError("wall box", self.lengths.tolist(),
                             "positive lengths: two opposite walls crossed")

    @property
    def wall_stress(self) -> np.ndarray:
        """(3,) normal stresses [Pa] on x, y, z: mean of the two walls' R_w / A_w."""
        per_wall = self.reactions / self.face_areas
        return 0.5 * (per_wall[0::2] + per_wall[1::2])

    # -- the boundary protocol (grainlab.engine.boundaries.boundary) -------------------------------
    def constraints(self, dt: float, theta: float) -> BoundaryConstraints:
        """The walls over a step of ``dt`` [s]: planes where they are at the detection
        configuration (moved by (1 - theta) dt at their speeds), inverse masses, free speeds,
        speed limits, friction; ``speed`` the fastest a wall may move."""
        points, normals = self.planes((1.0 - theta) * dt)
        free = self.free_speeds(dt)
        wall_max = np.ascontiguousarray(self.max_speeds, dtype=np.float64)
        moving = np.minimum(np.abs(free), wall_max)
        return BoundaryConstraints(
            wall_points=points, wall_normals=normals, wall_inv_mass=self.inverse_masses(),
            wall_free=free, wall_max=wall_max, wall_friction=self.friction,
            walls_overdamped=bool(self.servo),
            speed=float(max(np.max(np.abs(self.speeds)), np.max(moving))))

    def health_arrays(self) -> dict[str, np.ndarray]:
        """Arrays that must stay finite (the simulation's health check)."""
        return {"wall coordinates": self.coordinates}

    def detect(self, predicted, library, phases, constraints):
        """Contacts between the bodies and with the six walls (images all zero)."""
        return detect_in_space(predicted, library, phases, constraints.wall_points,
                               constraints.wall_normals)

    def finish_step(self, motion: BoundaryMotion) -> None:
        """Move the walls to the end of the step (:meth:`move`) and record the reactions:
        the solver's ``wall_reactions`` when it gives six (an explicit solver's mean over the
        step), else the normal impulses of each wall's contacts / dt."""
        reactions = np.zeros(6)
        if motion.wall_reactions.shape == (6,):  # a solver that measured them itself
            reactions[:] = motion.wall_reactions
        else:
            body_i = motion.contacts.body_i
            on_wall = body_i < 0
            np.add.at(reactions, -1 - body_i[on_wall], motion.impulses[on_wall, 0] / motion.dt)
        self.move(motion.wall_speeds, (1.0 - motion.theta) * motion.dt,
                  motion.theta * motion.dt, reactions)

    # -- persistence -------------------------------------------------------------------------
    def to_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays that restore the box with :meth:`from_arrays` (checkpoints)."""
        return {
            "coordinates": self.coordinates.copy(), "speeds": self.speeds.copy(),
            "reactions": self.reactions.copy(), "friction": self.friction.copy(),
            "masses": self.masses.copy(), "max_speeds": self.max_speeds.copy(),
            "control_modes": np.array([WALL_CONTROLS.index(c.mode) for c in self.controls]),
            "control_values": np.array([c.value for c in self.controls]),
            "servo": np.array(int(self.servo)), "planar": np.array(int(self.planar)),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> WallBox:
        """Inverse of :meth:`to_arrays`."""
        c = np.asarray(arrays["coordinates"], dtype=np.float64)
        box = cls(c[0::2], c[1::2], friction=arrays["friction"], wall_mass=arrays["masses"],
                  planar=bool(int(arrays.get("planar", 0))))
        box.coordinates[:] = c
        box.speeds[:] = arrays["speeds"]
        box.reactions[:] = arrays["reactions"]
        box.max_speeds[:] = arrays["max_speeds"]
        box.servo = bool(int(arrays.get("servo", 0)))
        box.controls = [WallControl(WALL_CONTROLS[int(m)], float(v)) for m, v in
                        zip(arrays["control_modes"], arrays["control_values"], strict=True)]
        return box
