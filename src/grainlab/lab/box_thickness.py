"""A box of walls against the particles it holds: how thin it may get, and which targets
would take it there.

A box thinner than a few particles cannot hold a granular sample: squeezed into one or two
layers the particles lock, overlaps run away and no time step or tolerance helps (30 spheres
asked to reach eps_q = 1.5 flattened their box to 2.78 mm, 1.4 largest diameters, and blew up).
The smallest edge allowed during a stage with a strain-controlled axis is
:data:`BOX_MIN_DIAMETERS` largest particle diameters, or :data:`BOX_MIN_FRACTION` of the
consolidated box for a box already thinner than that (a sample of a few dozen particles)
(:func:`box_limits`). The end of a stage is predicted from its targets
(:func:`predicted_end`): a strain-controlled axis at its target, or, for a stop criterion on
eps_q with one such axis (a triaxial test), eps_1 = 2 eps_q / 3 (constant volume) if less.

>>> import numpy as np
>>> box_limits(2e-3, np.array([4e-3, 4e-3, 20e-3])) * 1e3
array([3.2, 3.2, 6. ])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grainlab.lab.wall_stages import AXES, WallStage

BOX_MIN_DIAMETERS = 3.0
"""Smallest edge of the box during a stage with a strain-controlled axis, in largest particle
diameters (module docstring)."""

BOX_MIN_FRACTION = 0.8
"""Smallest edge of a box already thinner than :data:`BOX_MIN_DIAMETERS` largest diameters,
as a fraction of the consolidated box's edge (a sample of a few dozen particles: 30 spheres
consolidate to 2.1-2.4 largest diameters)."""

CONSOLIDATED_PACKING_ESTIMATE = 0.5
"""Packing fraction [-] assumed for a compaction's end when a path is checked before a run
(:func:`predicted_flattening`): on the low side (30 spheres between walls reach
0.48, 1000 reach 0.63), so the box predicted is on the large side and only targets that
flatten it for certain are refused before the run; each stage checks the real box when it
starts."""

CONSOLIDATED_AREA_ESTIMATE = 0.7
"""The same for a 2D sample's area fraction (discs: 0.55 at the random placement's jamming,
about 0.82 for a dense packing); the box of a 2D sample shrinks in its plane only."""


def box_limits(largest_diameter: float, reference: np.ndarray) -> np.ndarray:
    """(3,) smallest edges [m] allowed for a consolidated box of edges ``reference`` [m]
    holding particles of largest diameter ``largest_diameter`` [m] (module docstring)."""
    return np.minimum(BOX_MIN_DIAMETERS * largest_diameter,
                      BOX_MIN_FRACTION * np.asarray(reference, dtype=float))


@dataclass(frozen=True)
class Flattening:
    """A stage whose target would take an edge of the box below its limit
    (:func:`box_limits`): which, by how much, and the largest target that keeps
    the box thick enough (``quantity``: ``eps_q`` or ``eps_<axis><axis>``)."""

    stage: str
    axis: int
    quantity: str
    asked: float
    largest: float
    start: float
    end: float
    limit: float
    largest_diameter: float
    n_particles: int

    def particles_needed(self) -> int:
        """Particles for which the box, growing as N^(1/3), stays at least
        :data:`BOX_MIN_DIAMETERS` largest diameters thick at the target asked."""
        needed = BOX_MIN_DIAMETERS * self.largest_diameter * self.start / self.end
        return math.ceil(self.n_particles * (needed / self.start) ** 3)

    def words(self) -> str:
        """What the target does to the box."""
        how = " at constant volume" if self.quantity == "eps_q" else ""
        return (f"stage {self.stage}: {self.quantity} = {self.asked:g} would take the box's "
                f"{AXES[self.axis]} edge from {self.start * 1e3:.3g} mm to "
                f"~{self.end * 1e3:.3g} mm{how}, below the smallest allowed, "
                f"{self.limit * 1e3:.3g} mm ({BOX_MIN_DIAMETERS:g} largest diameters, d_max = "
                f"{self.largest_diameter * 1e3:.3g} mm, or {100 * BOX_MIN_FRACTION:g} % of a "
                "box thinner than that): "
                "squeezed into one or two layers the particles lock and the run blows up")

    def advice(self) -> str:
        """What to ask instead."""
        return (f"ask {self.quantity} <= {self.largest:.3g}, or use about "
                f"{self.particles_needed()} particles")


def eps_q_stop(stage: WallStage) -> float | None:
    """The limit of a stop criterion ``eps_q above`` of ``stage`` (None without one)."""
    limits = [c.limit for c in stage.stop if c.quantity == "eps_q" and c.when == "above"]
    return min(limits) if limits else None


def predicted_end(stage: WallStage, start: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(3,) edges [m] of the box at the end of ``stage`` started on ``start``: the
    strain-controlled axes at their targets, or, with a stop criterion on eps_q and one such
    axis, eps_1 = 2 eps_q / 3 from the ``reference`` box (constant volume) if less."""
    end = np.asarray(start, dtype=float).copy()
    for a in stage.moving_axes:
        end[a] = start[a] * math.exp(-stage.targets[a])
    eps_q = eps_q_stop(stage)
    if eps_q is not None and len(stage.moving_axes) == 1:
        a = stage.moving_axes[0]
        end[a] = max(end[a], reference[a] * math.exp(-2.0 * eps_q / 3.0))
    return end


def stage_flattening(stage: WallStage, start: np.ndarray, reference: np.ndarray,
                     largest_diameter: float, n_particles: int) -> list[Flattening]:
    """The axes that ``stage``, started on a box of edges ``start`` [m] (consolidated:
    ``reference``), is predicted to take below :func:`box_limits`."""
    end = predicted_end(stage, start, reference)
    limits = box_limits(largest_diameter, reference)
    out = []
    for a in stage.moving_axes:
        if end[a] < limits[a]:
            eps_q = eps_q_stop(stage)
            if eps_q is not None and len(stage.moving_axes) == 1:
                quantity, asked = "eps_q", eps_q
                largest = 1.5 * math.log(reference[a] / limits[a])
            else:
                quantity, asked = f"eps_{AXES[a] * 2}", stage.targets[a]
                largest = math.log(start[a] / limits[a])
            out.append(Flattening(stage.name, a, quantity, asked, max(largest, 0.0),
                                  float(start[a]), float(end[a]), float(limits[a]),
                                  largest_diameter, n_particles))
    return out


def predicted_flattening(stages, lengths: np.ndarray, reference: np.ndarray,
                         solid_volume: float, largest_diameter: float,
                         n_particles: int) -> list[Flattening]:
    """The ``stages`` whose targets would flatten a box of edges ``lengths`` [m]
    (consolidated: ``reference``) holding ``solid_volume`` [m^3] of particles. A stage without
    a strain-controlled axis (a compaction) is assumed to end at
    :data:`CONSOLIDATED_PACKING_ESTIMATE`, unless denser already."""
    lengths = np.asarray(lengths, dtype=float).copy()
    reference = np.asarray(reference, dtype=float).copy()
    out = []
    for stage in stages:
        if not stage.moving_axes:
            d = stage.dimension
            phi = solid_volume / float(np.prod(lengths))
            estimate = CONSOLIDATED_PACKING_ESTIMATE if d == 3 else CONSOLIDATED_AREA_ESTIMATE
            if phi < estimate:
                lengths[:d] = lengths[:d] * (phi / estimate) ** (1.0 / d)
            reference = lengths.copy()
            continue
        out += stage_flattening(stage, lengths, reference, largest_diameter, n_particles)
        lengths = predicted_end(stage, lengths, reference)
    return out
