"""A periodic cell against the particles it holds: whether its compaction would make it too
thin for the contact detection, judged before a run starts.

The detection of a periodic cell refuses a cell narrower than three interaction ranges
across any pair of faces, 3 (2 r_max + alert) (:func:`~grainlab.engine.detect.periodic_detection.
checked_cutoff`), so that no pair touches through two images. A loose sample is compacted
isotropically: the cell shrinks with it, and a sample of few particles reaches that width
before it settles (30 spheres of 1-2 mm: the cell was 5.36 mm across, against 6.13 mm asked,
and the run stopped with the folder already made). The cell's end is predicted from the
solid volume V_s: an isotropic compaction to a packing fraction phi scales every width by
(V_s / (phi V_cell))^(1/3). With :data:`CELL_PACKING_ESTIMATE`, a packing fraction on the low
side, the cell predicted is on the large side, and with the interaction range taken as the
largest diameter alone (no alert distance) so is the width allowed: only a sample whose cell
is certain to get too thin is refused; each detection still checks the real cell.

The particles a cell needs scale with its volume: widths w_i x (N / n)^(1/3) reach the limit
w_min at N = n (w_min / min w_i)^3 (:func:`particles_needed`).

A study that must run to its end is sized before its samples are drawn
(:func:`particles_for_the_shear`): a cell of height ratio h = H / W compacted to a packing
fraction phi holding N particles of mean volume <v> is W = (N <v> / (phi h))^(1/3) wide;
the triaxial compression then shortens it to H exp(-eps_zz) and widens its sides, with
eps_zz <= 2/3 eps_q (logarithmic strains, eps_q = eps_1 - eps_3: equality when the volume
holds, less when the packing dilates, as dense packings do). Its narrowest width over the
run is therefore W min(1, h exp(-2/3 eps_q)), and it must stay above the detection's limit
with the lab's margin, 3.15 (d_max + alert). The packing fraction is taken on the high side
(:data:`CELL_DENSEST_ESTIMATE`): a sample that compacts denser than assumed gets too thin
after hours, one sized on the high side costs a few percent more particles.

>>> import numpy as np
>>> widths = compacted_widths(np.array([10e-3, 10e-3, 10e-3]), 1e-7, 0.5)
>>> [round(float(w) * 1e3, 3) for w in widths]
[5.848, 5.848, 5.848]
"""

from __future__ import annotations

import math

import numpy as np

from grainlab.errors import InputError
from grainlab.lab.cell_boundary import THIN_CELL_MARGIN

CELL_PACKING_ESTIMATE = 0.55
"""Packing fraction [-] assumed for the end of a compaction in a periodic cell when a run is
checked before it starts: on the low side (frictionless spheres settle at 0.62-0.64 with no
walls to loosen them; the random loose packing of frictional spheres is near 0.55)."""

CELL_AREA_ESTIMATE = 0.75
"""The area fraction [-] a planar cell of discs is assumed to reach in its compaction, on the
low side as above (a dense random packing of discs: about 0.82)."""
CELL_MIN_DIAMETERS = 3.0
"""Smallest width of the cell across a pair of faces, in largest particle diameters (three
interaction ranges 2 r_max, the alert distance left out: the module docstring)."""


CELL_DENSEST_ESTIMATE = 0.75
"""Packing fraction [-] assumed for the end of a compaction when a study sizes its cells
(:func:`particles_for_the_shear`): on the high side (measured in a periodic cell of 1000:
spheres of sizes 1-2 0.645, of sizes 1-3 0.664; the densest of seeds 002 and 003, polyhedra
and aggregates, about 0.75), so that the cell predicted is on the narrow side."""

SHEAR_SHORTENING = 2.0 / 3.0
"""Largest axial strain per deviatoric strain of a triaxial compression, eps_zz / eps_q [-]:
2/3 at constant volume, less for a dilating packing (module docstring; measured: 0.57 / 0.9
= 0.63 for 1000 spheres in a cell)."""


def mean_cube_uniform_by_volume(d_min: float, d_max: float) -> float:
    """<d^3> [m^3] of diameters with equal volume in every size class of [d_min, d_max]
    (number density ~ d^-3: :func:`~grainlab.prep.loose_sample.diameters_uniform_by_volume`):
    2 (d_max - d_min) / (d_min^-2 - d_max^-2), and d^3 for one size.

    >>> round(mean_cube_uniform_by_volume(1.0, 2.0), 4)
    2.6667
    """
    if d_max <= d_min:
        return d_min**3
    return 2.0 * (d_max - d_min) / (d_min**-2 - d_max**-2)


def particles_for_the_shear(mean_volume: float, largest_diameter: float, alert: float,
                            height_ratio: float, eps_q_max: float,
                            packing: float = CELL_DENSEST_ESTIMATE) -> int:
    """The particles [-] a periodic cell of ``height_ratio`` (height / width) needs to stay
    wide enough for the contact detection, with the lab's margin, from its compaction to a
    triaxial compression at ``eps_q_max`` [-] (module docstring), for particles of
    ``mean_volume`` [m^3], ``largest_diameter`` [m] and an ``alert`` distance [m].

    >>> particles_for_the_shear(2.6667 * 0.5236, 2.0, 0.05, 2.0, 0.9)  # spheres 1-2 m
    290
    """
    limit = THIN_CELL_MARGIN * CELL_MIN_DIAMETERS * (largest_diameter + alert)
    narrowest = min(1.0, height_ratio * math.exp(-SHEAR_SHORTENING * eps_q_max))
    width = limit / narrowest
    return math.ceil(packing * height_ratio * width**3 / mean_volume)


def compacted_widths(widths: np.ndarray, solid_volume: float, packing: float,
                     dimension: int = 3) -> np.ndarray:
    """(d,) widths [m] across the faces of a cell of ``widths`` (3,) [m] holding
    ``solid_volume`` [m^3] of particles once compacted isotropically to the packing fraction
    ``packing`` [-] (unchanged if it is denser already); a planar cell (``dimension`` 2)
    shrinks in its plane (the area fraction ``packing``)."""
    widths = np.asarray(widths, dtype=float)
    volume = float(np.prod(widths))  # the volume of a cell of these widths, not sheared
    scale = (solid_volume / (packing * volume)) ** (1.0 / dimension)
    return widths[:dimension] * min(scale, 1.0)


def particles_needed(n_particles: int, width: float, limit: float, dimension: int = 3) -> int:
    """The particles a cell of the same shape and particle sizes needs to keep ``width`` [m]
    above ``limit`` [m] (module docstring)."""
    return math.ceil(n_particles * (limit / width) ** dimension)


def thin_cell_after_compaction(widths: np.ndarray, solid_volume: float,
                               largest_diameter: float, n_particles: int,
                               dimension: int = 3) -> str:
    """Why a cell of ``widths`` [m] with ``n_particles`` of ``solid_volume`` [m^3] and
    largest diameter ``largest_diameter`` [m] gets too thin in its compaction, in words;
    "" when it need not (module docstring)."""
    packing = CELL_PACKING_ESTIMATE if dimension == 3 else CELL_AREA_ESTIMATE
    end = compacted_widths(widths, solid_volume, packing, dimension)
    limit = CELL_MIN_DIAMETERS * largest_diameter
    axis = int(np.argmin(end))
    if end[axis] >= limit:
        return ""
    needed = particles_needed(n_particles, float(end[axis]), limit, dimension)
    return (f"at least about {needed} for this cell: {n_particles} particles compacted to a "
            f"packing fraction of {packing:g} leave the periodic cell "
            f"{end[axis] * 1e3:.3g} mm across its faces along axis {axis}, "
            f"{end[axis] / largest_diameter:.2f} largest particle diameters, below the "
            f"{limit * 1e3:.3g} mm ({CELL_MIN_DIAMETERS:g} diameters) the contact detection "
            "needs so that no pair touches through two images")


def refuse_thin_cell(test, sample_config) -> None:
    """An :class:`InputError` naming ``sample.n_particles`` (or the file that gave the
    particles) when the compaction would make the periodic cell of ``test`` (a
    :class:`~grainlab.lab.discrete_test.DiscreteTest` in a periodic cell, not yet run) too
    thin for its particles
    (:func:`thin_cell_after_compaction`); ``sample_config`` is the run's ``[sample]``."""
    state, library = test.sample.state, test.sample.library
    why = thin_cell_after_compaction(test.sample.boundary.widths,
                                     float(np.sum(library.volume[state.shape_ids])),
                                     test.largest_diameter, state.n_bodies,
                                     library.dimension)
    if not why:
        return
    s = sample_config
    if s.preparation == "file":
        key = "sample.particle_file" if s.particle_file else "sample.skeleton_file"
        raise InputError(key, s.particle_file or s.skeleton_file,
                         f"a sample of more particles ({why})")
    raise InputError("sample.n_particles", s.n_particles, why)
