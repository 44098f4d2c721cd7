"""The discrete sample a simulation advances: the static shape library, the changing body
state and the walls (STYLE.md 1). :mod:`grainlab.prep` makes samples; the engine and the lab
run them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.wall_box import WallBox


@dataclass
class DiscreteSample:
    """Particles and their box: the static ``library``, the changing ``state`` and the walls
    ``box`` (:class:`~grainlab.engine.wall_box.WallBox`); ``description`` is plain data
    (shape, sizes, seed) for the results' metadata."""

    library: ShapeLibrary
    state: BodyState
    box: WallBox
    description: dict

    @property
    def mean_diameter(self) -> float:
        """Mean diameter of the particles' bounding spheres [m]."""
        return float(2.0 * np.mean(self.library.bounding_radius[self.state.shape_ids]))

    @property
    def solid_volume(self) -> float:
        """Sum of the particle volumes [m^3]."""
        return float(np.sum(self.library.volume[self.state.shape_ids]))
