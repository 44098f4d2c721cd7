"""The discrete sample a simulation advances: the static shape library, the changing body
state and its boundary -- the wall box, the periodic cell or any other
:class:`~grainlab.engine.boundaries.boundary.Boundary` (STYLE.md 1;
:mod:`grainlab.engine.boundaries.boundary`). :mod:`grainlab.prep` makes samples; the engine and the
lab
run them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainlab.engine.boundaries.boundary import Boundary
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.state import BodyState, ShapeLibrary


@dataclass
class DiscreteSample:
    """Particles and their boundary: the static ``library``, the changing ``state`` and the
    ``boundary`` (:class:`~grainlab.engine.boundaries.wall_box.WallBox` or
    :class:`~grainlab.engine.boundaries.periodic_boundary.PeriodicCell`); ``description`` is plain
    data
    (shape, sizes, seed) for the results' metadata."""

    library: ShapeLibrary
    state: BodyState
    boundary: Boundary
    description: dict

    @property
    def box(self) -> WallBox:
        """The wall box (the boundary, when it is one)."""
        return self.boundary

    @property
    def periodic(self) -> bool:
        """Whether the sample fills a periodic cell (its boundary says:
        :attr:`~grainlab.engine.boundaries.boundary.Boundary.periodic`)."""
        return bool(self.boundary.periodic)

    @property
    def mean_diameter(self) -> float:
        """Mean diameter of the particles' bounding spheres [m]."""
        return float(2.0 * np.mean(self.library.bounding_radius[self.state.shape_ids]))

    @property
    def solid_volume(self) -> float:
        """Sum of the particle volumes [m^3]."""
        return float(np.sum(self.library.volume[self.state.shape_ids]))
