"""The wall box's compiled face for the explicit soft-contact (DEM) sub-steps (Numba; STYLE.md
2, 8): what the walls do at every sub-step of
:mod:`grainlab.engine.dem.soft_contact_kernels`, given as :class:`WallFace`, a NamedTuple of the
walls' arrays the sub-step loop passes to the ``walls_*`` functions here, so that the loop
holds no wall code:

* :func:`walls_move`: each wall moves along its inward normal at its speed, d_w += h s_w;
* :func:`walls_settle`: the servo walls' speeds for the next sub-step from their loads now
  (:func:`servo_walls`), and the loads summed over time into the walls' impulses;
* :func:`walls_moved`: how far a wall has moved since the contact list was built (the list's
  skin check).

The servo (:func:`servo_rate`) is the overdamped servo of contact dynamics (the module docstring
of :mod:`grainlab.engine.dem.soft_contact`) taken backward in time with the contacts'
stiffness, with an integral memory; :func:`servo_kernel` sets the speeds at the start of a
step from the last step's mean loads.

The face of a boundary without walls (a periodic cell) is the same NamedTuple with empty
arrays: the loop is compiled once for every boundary, and the kernels load from Numba's cache.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

OUTWARD_FACTOR = 4.0
"""A servo wall or cell component moves out at most this many times its inward limit (as
contact dynamics' walls)."""

SUBSTEP_SERVO_FRACTION = 0.1
"""Fraction of a stiff load's error a servo wall corrects per sub-step (:func:`servo_walls`;
as YADE's ``wallDamping`` of its triaxial stress controller). With 0.25 a compaction of 24
Hertz spheres and one of 60 linear ones stalled 2-4 % below sigma0 (likely the walls
chattering against their few contacts, a wall moving in no faster than its bound but out four
times faster); 0.1 settled every case tried (24-300 spheres, kappa 1e3-1e5)."""

SERVO_INTEGRAL = 0.3
"""Fraction of its proportional correction a servo adds to its memory each step (the integral
term), weighted by how much the contacts' stiffness dominates the correction; in steps where
another part of the boundary is driven (a strain-controlled wall or cell component), the only
ones where a servo must keep moving to hold its target. With no driven part (a compaction) it
would only carry the settling's overshoot into the packing (the cell then drifted out of
shape)."""


class WallFace(NamedTuple):
    """The walls' arrays of the sub-steps (W walls; W = 0 without walls)."""

    points: np.ndarray
    """(W, 3) [m] a point of each wall when its displacement is zero."""
    normals: np.ndarray
    """(W, 3) the walls' inward unit normals."""
    disp: np.ndarray
    """(W,) [m] the walls' displacements along their normals (updated)."""
    speed: np.ndarray
    """(W,) [m/s] the walls' normal speeds (the servo walls' updated)."""
    disp_built: np.ndarray
    """(W,) [m] the displacements when the contact list was built."""
    inv_mass: np.ndarray
    """(W,) [1/kg] the servos' gains (0: a driven wall)."""
    free: np.ndarray
    """(W,) [m/s] the walls' free speeds (a driven wall's speed)."""
    max_speed: np.ndarray
    """(W,) [m/s] the servos' inward speed limits."""
    memory: np.ndarray
    """(W,) [m/s] the servos' integral memories (updated)."""
    floor: np.ndarray
    """(W,) [N/m] the largest stiffness of each wall's contacts met (updated)."""
    force: np.ndarray
    """(W,) [N] the walls' normal loads now (compression positive), written by the force
    pass."""
    stiffness: np.ndarray
    """(W,) [N/m] the normal stiffness of each wall's contacts now."""
    impulse: np.ndarray
    """(W,) [N s] the walls' loads summed over time (updated)."""
    macro: float
    """[s] the solver's step, over which a servo's gain is defined."""
    integral: float
    """The servos' integral gain per step (:data:`SERVO_INTEGRAL` or 0)."""
    gain: float
    """The fraction of a stiff load's error corrected per sub-step
    (:data:`SUBSTEP_SERVO_FRACTION`)."""


@njit(inline="always")
def servo_rate(free, gain, load, stiffness, macro, low, high, memory, integral):
    """One servo's speed over a step of ``macro`` [s] and its updated memory (module docstring
    of :mod:`grainlab.engine.dem.soft_contact`): the proportional part is the overdamped servo
    of contact dynamics, s = free - gain load, taken backward in time with the load's
    stiffness K over the step, (free - gain load) / (1 + gain K h): stable at any contact
    stiffness, and it would cancel the load's error in one step if the grains behind the
    contacts did not move. They do, in a sample being deformed: the boundary must then keep
    moving, which the integral ``memory`` learns (+ :data:`SERVO_INTEGRAL` x the proportional
    part, weighted by gain K h / (1 + gain K h), so that a boundary still closing on a loose
    sample does not wind it up). Speed and memory within [low, high]."""
    damping = gain * stiffness * macro
    proportional = (free - gain * load) / (1.0 + damping)
    memory = min(max(memory + integral * proportional * damping / (1.0 + damping), low),
                 high)
    return min(max(proportional + memory, low), high), memory


@njit(inline="always")
def servo_walls(dt, macro, integral, servo_gain, wall_inv_mass, wall_free, wall_max,
                wall_force, wall_stiffness, wall_memory, wall_speed, wall_floor):
    """The servo walls' speeds for the next ``dt`` [s] from their loads now ``wall_force``
    (W,) [N] (:func:`servo_rate` over dt / ``servo_gain``: a fraction ``servo_gain`` of a
    stiff load's error corrected over dt, the servo's gain that of a step of ``macro`` [s],
    its memory learning ``integral`` per dt), with the largest stiffness of each wall's
    contacts met so far, ``wall_floor`` (W,) [N/m] (updated): a wall that loses its contacts
    for a sub-step keeps its stiff-load correction. A driven wall keeps its speed
    ``wall_free``."""
    for w in range(wall_speed.shape[0]):
        inv = wall_inv_mass[w]
        if inv > 0.0:
            high = wall_max[w]
            wall_floor[w] = max(wall_floor[w], wall_stiffness[w])
            wall_speed[w], wall_memory[w] = servo_rate(
                wall_free[w], inv * macro, wall_force[w], wall_floor[w], dt / servo_gain,
                -OUTWARD_FACTOR * high, high, wall_memory[w], integral)
        else:
            wall_speed[w] = wall_free[w]


@njit(cache=True, _nrt=False)
def servo_kernel(macro, integral, wall_inv_mass, wall_free, wall_max, wall_force,
                 wall_stiffness, wall_memory, wall_speed):
    """Speeds of the servo walls over a step of ``macro`` [s] (:func:`servo_rate`) from the
    last step's mean loads ``wall_force`` (W,) [N] and their stiffnesses ``wall_stiffness``
    (W,) [N/m]; the servos' memories are updated (``integral``: :data:`SERVO_INTEGRAL` or 0).
    A driven wall keeps its speed ``wall_free``."""
    servo_walls(macro, macro, integral, 1.0, wall_inv_mass, wall_free, wall_max, wall_force,
                wall_stiffness, wall_memory, wall_speed, wall_stiffness)


@njit(inline="always")
def walls_move(walls, dt):
    """Each wall moves along its normal at its speed over ``dt`` [s]: d_w += dt s_w."""
    for w in range(walls.disp.shape[0]):
        walls.disp[w] += dt * walls.speed[w]


@njit(inline="always")
def walls_settle(walls, dt):
    """The end of a sub-step of ``dt`` [s] for the walls, their loads ``walls.force`` now
    known: the servo walls' speeds for the next sub-step (:func:`servo_walls`, if any wall is
    a servo), then the loads summed into ``walls.impulse`` [N s]."""
    servo = False
    for w in range(walls.inv_mass.shape[0]):
        servo = servo or walls.inv_mass[w] > 0.0
    if servo:
        servo_walls(dt, walls.macro, walls.integral * dt / walls.macro, walls.gain,
                    walls.inv_mass, walls.free, walls.max_speed, walls.force, walls.stiffness,
                    walls.memory, walls.speed, walls.floor)
    for w in range(walls.impulse.shape[0]):
        walls.impulse[w] += dt * walls.force[w]


@njit(inline="always")
def walls_moved(walls):
    """[m] the largest displacement of a wall since the contact list was built."""
    moved = 0.0
    for w in range(walls.disp.shape[0]):
        moved = max(moved, abs(walls.disp[w] - walls.disp_built[w]))
    return moved
