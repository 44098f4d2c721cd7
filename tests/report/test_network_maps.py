"""Maps of one contact network (grainlab.report.microstructure_figures): the particles of a
slab shaded by their contact neighbours (seed 002 Fig. 9), the radial forces coloured by
friction mobilisation (seed 002 Fig. 18, seed 003 Fig. 21)."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.report.microstructure_figures import (
    connectivity_map_figure,
    force_network_figure,
    pair_mobilisation,
)

matplotlib.use("Agg")


def _chain(normal_forces, tangential_forces=(0.0, 0.0)) -> ContactNetwork:
    """Unit spheres 0-1-2 touching in a chain along x at y = 0 (normal forces along x,
    tangential along z; mu = 0.5), sphere 3 at y = 0 touching nothing, and spheres 4, 5 at
    y = +-10, outside a slab about the mid-plane y = 0."""
    positions = np.array([[0, 0, 0], [2, 0, 0], [4, 0, 0], [8, 0, 0], [0, 10, 0],
                          [0, -10, 0]], float)
    forces = [[fn, 0.0, ft] for fn, ft in zip(normal_forces, tangential_forces, strict=True)]
    return ContactNetwork.from_arrays(
        positions=positions, volumes=np.full(6, 4.0 / 3.0 * np.pi), volume=1000.0,
        pair_particles=[[0, 1], [1, 2]], pair_branches=[[2, 0, 0], [2, 0, 0]],
        point_pairs=[0, 1], point_positions=[[1, 0, 0], [3, 0, 0]],
        point_normals=[[1, 0, 0], [1, 0, 0]], point_forces=forces,
        friction_coefficient=0.5)


def test_the_connectivity_map_shades_each_particle_by_its_contact_neighbours():
    figure = connectivity_map_figure(_chain([1.0, 2.0]), plane=(0, 2))
    discs = figure.axes[0].collections[0]
    # the slab (one mean diameter, 2) keeps the four spheres at y = 0; the chain's ends have
    # one neighbour, its middle two, the loose sphere none (white)
    assert list(discs.get_array()) == [1.0, 2.0, 1.0, 0.0]
    assert len(discs.get_paths()) == 4 and "4 particles" in figure.axes[0].get_title()
    assert discs.get_clim() == (0.0, 2.0)
    # a pair without a normal force is open: no neighbour
    shades = connectivity_map_figure(_chain([1.0, 0.0]), plane=(0, 2)).axes[0].collections[0]
    assert list(shades.get_array()) == [1.0, 1.0, 0.0, 0.0]


@pytest.mark.parametrize("tangential, expected", [((0.0, 0.0), [0.0, 0.0]),
                                                   ((0.25, 1.0), [0.5, 1.0])])
def test_the_mobilisation_map_colours_each_pair_by_its_friction_mobilisation(tangential,
                                                                            expected):
    # I_c = |f_t| / (mu f_n): 0.25 / (0.5 x 1) = 0.5 on the first pair, 1 / (0.5 x 2) = 1
    network = _chain([1.0, 2.0], tangential)
    mobilisation = pair_mobilisation(network)
    np.testing.assert_allclose(mobilisation, expected)
    lines = force_network_figure(network, color_by="sliding", mobilisation=mobilisation,
                                 plane=(0, 2)).axes[0].collections[0]
    colours = np.asarray(lines.get_colors())
    np.testing.assert_allclose(colours[:, 0], expected)  # red: I_c
    np.testing.assert_allclose(colours[:, 2], 1.0 - np.array(expected))  # blue: 1 - I_c
