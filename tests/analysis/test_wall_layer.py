"""The wall layer and the core (grainlab.analysis.wall_layer), wall contacts in the stress and
the rattler rule: closed forms on a simple cubic lattice of spheres held by the walls of a box
that fits it."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis import SnapshotAnalysis
from grainlab.analysis.connectivity import Connectivity
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.contact_stress import (
    StressState,
    stress_from_internal_moments,
    stress_from_network,
    wall_reaction_stress,
)
from grainlab.analysis.partial_stress import PartialStresses
from grainlab.analysis.synthetic import cubic_lattice
from grainlab.analysis.wall_layer import (
    CoreConnectivity,
    core_by_margin,
    core_network,
    packing_profile,
    region_volume,
    solid_in_box,
    solid_profile,
)
from grainlab.errors import InputError


def test_stress_needs_the_wall_contacts_to_equal_the_wall_reactions():
    # sigma_aa = force on the wall above (n^2 F_a) / its area (2 R n)^2 = F_a / (4 R^2)
    forces = (1.0, 2.0, 3.0)
    net = cubic_lattice(5, 1.0, forces)
    expected = np.diag(forces) / 4.0
    np.testing.assert_allclose(stress_from_network(net), expected, atol=1e-12)
    np.testing.assert_allclose(wall_reaction_stress(net), expected, atol=1e-12)
    np.testing.assert_allclose(stress_from_internal_moments(net), expected, atol=1e-12)
    # the particle pairs alone carry (n - 1)/n of it: each row of n spheres has n - 1 pair
    # contacts of arm 2R and two wall contacts of arm R
    pairs_only = stress_from_network(_without_walls(net))
    np.testing.assert_allclose(pairs_only, 0.8 * expected, atol=1e-12)
    assert StressState().compute(net).descriptors()["wall_share_of_p"] == pytest.approx(0.2)


def _without_walls(net: ContactNetwork) -> ContactNetwork:
    values = {name: getattr(net, name) for name in net.__dataclass_fields__}
    values.update(wall_particles=None, wall_points=None, wall_normals=None, wall_forces=None)
    return ContactNetwork(**values)


def test_partial_shares_with_the_walls_sum_to_the_sample_q_over_p():
    net = cubic_lattice(4, 1.0, (1.0, 1.0, 3.0))
    partial = PartialStresses().compute(net)
    total = StressState().compute(net).q_over_trace
    assert set(partial.q_over_trace) == {"s", "wall"}
    assert sum(partial.q_over_trace.values()) == pytest.approx(total)
    # (sigma_1 - sigma_3) / (3 p) = (3 - 1) / 5; the pairs carry (n - 1)/n = 3/4 of it
    assert total == pytest.approx(0.4)
    assert partial.q_over_trace["s"] == pytest.approx(0.3)


def test_the_core_of_a_cubic_lattice_is_its_bulk():
    net = cubic_lattice(5, 1.0)
    core = CoreConnectivity(margin=1.0).compute(net)  # one diameter: the 3 x 3 x 3 inside
    assert core.margin == pytest.approx(2.0)
    assert int(core.core.sum()) == 27 and core.core_volume == pytest.approx(6.0**3)
    out = core.descriptors()
    assert out["packing_fraction_core"] == pytest.approx(np.pi / 6.0)
    assert out["coordination_number_core"] == pytest.approx(6.0)
    assert out["connectivity_number_core"] == pytest.approx(6.0)
    assert out["rattler_fraction_core"] == 0.0
    whole = Connectivity().compute(net)
    assert whole.coordination_number == pytest.approx(2 * 300 / 125)  # 4.8: the walls' share
    claimed = core_network(net, core.core, core.core_volume)
    # 27 core spheres x 6 contacts, each a claim: 54 pairs inside listed twice, 54 once
    assert claimed.n_pairs == 27 * 6
    np.testing.assert_allclose(stress_from_network(claimed), np.eye(3) / 4.0, atol=1e-12)


def test_the_core_at_several_margins_reads_low_where_its_edge_cuts_a_layer():
    """A lattice of 5 x 5 x 5 spheres of diameter 2 in a box 10 wide (centres at 1, 3, 5, ...
    from a wall). A margin of a whole number of diameters (1, 2) ends the core between two
    layers, and half a diameter runs its edge through the first layer's centres, whose halves
    inside balance the box's: the bulk's pi/6 each time. 0.75 diameters cuts the first layer
    a radius/2 off its centres: per axis 3 whole spheres and twice a cap of 5/32 over a width
    of 7 instead of 3.5 periods, it reads low, as a margin through a wall layer does. The
    count of centres holds the first layer at 0.5 <d> (125) and not at 0.75 (27)."""
    net = cubic_lattice(5, 1.0)
    table = core_by_margin(net, [0.5, 0.75, 1.0, 2.0])
    assert list(table["n_core"]) == [125, 27, 27, 1]
    sphere = 4.0 / 3.0 * np.pi
    np.testing.assert_allclose(table["packing_fraction"],
                               [np.pi / 6, sphere * (3.0 + 2.0 * 5.0 / 32.0) ** 3 / 7.0**3,
                                np.pi / 6, np.pi / 6])
    np.testing.assert_allclose(table["coordination_number"], [2 * 300 / 125, 6, 6, 6])
    np.testing.assert_allclose(table["connectivity_number"], table["coordination_number"])
    assert list(table["margin"]) == [0.5, 0.75, 1.0, 2.0]


def _one(position, radius: float = 1.0, dimension: int = 3) -> ContactNetwork:
    volume = 4.0 / 3.0 * np.pi * radius**3 if dimension == 3 else np.pi * radius**2
    return _particles(np.atleast_2d(np.asarray(position, float)), np.array([volume]))


def _particles(positions: np.ndarray, volumes: np.ndarray) -> ContactNetwork:
    """Particles without contacts (what the solid inside a box reads)."""
    dimension = positions.shape[1]
    return ContactNetwork(positions=positions, volumes=volumes, volume=1.0,
                          pair_particles=np.zeros((0, 2), int),
                          pair_branches=np.zeros((0, dimension)),
                          point_pairs=np.zeros(0, int),
                          point_positions=np.zeros((0, dimension)),
                          point_normals=np.zeros((0, dimension)),
                          point_forces=np.zeros((0, dimension)))


@pytest.mark.parametrize("s", [-1.5, -1.0, -0.6, -0.25, 0.0, 0.3, 0.8, 1.0, 2.0])
def test_the_solid_in_a_box_is_the_cap_of_a_sphere_cut_by_one_face(s):
    """A sphere of radius 1 whose centre lies s inside the box's face x = 0: the part inside
    is the cap of height h = 1 + s, pi h^2 (3 - h) / 3; its disc is the segment of the same
    height, acos(-s) + s sqrt(1 - s^2); whole inside from s = 1, none from s = -1."""
    far = np.array([10.0, 10.0, 10.0])
    h = float(np.clip(1.0 + s, 0.0, 2.0))
    cap = np.pi * h * h * (3.0 - h) / 3.0
    assert solid_in_box(_one([s, 0.0, 0.0]), np.array([0.0, -10, -10]), far) == \
        pytest.approx(cap, abs=1e-12)
    t = float(np.clip(s, -1.0, 1.0))
    segment = np.arccos(-t) + t * np.sqrt(1.0 - t * t)
    assert solid_in_box(_one([s, 0.0], dimension=2), np.array([0.0, -10]), far[:2]) == \
        pytest.approx(segment, abs=1e-12)


def test_the_solid_in_a_box_at_an_edge_and_a_corner_through_the_centre():
    """A sphere centred on an edge of the box keeps a quarter inside, on a corner an eighth;
    one inside a slab thinner than itself, the sphere's slice between the two planes."""
    sphere = 4.0 / 3.0 * np.pi
    lower, upper = np.zeros(3), np.full(3, 5.0)
    assert solid_in_box(_one([0.0, 0.0, 2.5]), lower, upper) == pytest.approx(sphere / 4)
    assert solid_in_box(_one([0.0, 0.0, 0.0]), lower, upper) == pytest.approx(sphere / 8)
    # the slice |x| <= 1/2 of the unit sphere: pi (1 - x^2) integrated, 11 pi / 12
    assert solid_in_box(_one([0.0, 0.0, 0.0]), np.array([-0.5, -9, -9]),
                        np.array([0.5, 9, 9])) == pytest.approx(11.0 * np.pi / 12.0)


def test_a_core_holding_no_centre_measures_nothing():
    """A margin that leaves a region but no particle centre in it: every core value is NaN,
    not a packing fraction of 0."""
    net = cubic_lattice(4, 1.0)
    core = CoreConnectivity(margin=1.9).compute(net)  # d = 2: the region [3.8, 4.2], no centre
    assert int(core.core.sum()) == 0 and core.core_volume > 0.0
    out = core.descriptors()
    assert all(np.isnan(out[name]) for name in ("packing_fraction_core",
                                                 "coordination_number_core",
                                                 "connectivity_number_core"))


def test_snapshot_analysis_gives_both_the_box_and_the_core():
    net = cubic_lattice(5, 1.0, (1.0, 1.0, 2.0))
    d = SnapshotAnalysis(core_margin=1.0).compute(net).descriptors  # the 3 x 3 x 3 inside
    assert d["packing_fraction"] == pytest.approx(np.pi / 6.0)  # the lattice fits the box
    assert d["coordination_number"] == pytest.approx(4.8)
    assert d["coordination_number_core"] == pytest.approx(6.0)
    assert d["p_core"] == pytest.approx(1.0 / 3.0)  # diag(1, 1, 2) / 4
    assert d["p"] == pytest.approx(1.0 / 3.0)  # walls included: the same in equilibrium
    assert d["q_over_trace_core"] == pytest.approx((2 - 1) / 4 / 3 / (1 / 3))
    assert d["a_c_core"] == pytest.approx(0.0, abs=1e-12)  # normals along the three axes
    assert d["k_s_core"] == 1.0
    assert "coordination_number_core" not in SnapshotAnalysis(core_margin=None).compute(
        net).descriptors


def test_packing_profile_accounts_for_every_particle():
    net = cubic_lattice(6, 1.0)
    edges, fraction = packing_profile(net, 0.5)
    shells = -np.diff([region_volume(net, s) for s in edges])
    assert edges[0] == 0.0 and edges[-1] == pytest.approx(6.0)
    assert np.nansum(fraction * shells) == pytest.approx(net.volumes.sum())
    # the centres lie at 1, 3 and 5 from the nearest wall: three occupied shells
    assert np.count_nonzero(fraction > 0) == 3
    with pytest.raises(InputError, match="bin_width"):
        packing_profile(net, 0.0)


def test_the_solid_in_a_box_does_not_depend_on_labels_place_or_mirror():
    """Relabelling the particles, translating them with the box, or mirroring both through a
    plane leaves the solid inside unchanged; a box holding every particle whole holds all
    their volume."""
    rng = np.random.default_rng(7)
    n = 60
    x = rng.uniform(0.0, 10.0, (n, 3))
    v = 4.0 / 3.0 * np.pi * rng.uniform(0.3, 0.9, n) ** 3

    def solid(positions, volumes, lower, upper):
        return solid_in_box(_particles(positions, volumes), np.asarray(lower, float),
                            np.asarray(upper, float))

    lower, upper = np.array([2.0, 1.5, 3.0]), np.array([7.5, 8.0, 6.5])
    reference = solid(x, v, lower, upper)
    order = rng.permutation(n)
    assert solid(x[order], v[order], lower, upper) == pytest.approx(reference, rel=1e-12)
    shift = np.array([-3.0, 12.5, 0.25])
    assert solid(x + shift, v, lower + shift, upper + shift) == \
        pytest.approx(reference, rel=1e-12)
    mirror = np.array([1.0, -1.0, 1.0])
    assert solid(x * mirror, v, np.minimum(lower * mirror, upper * mirror),
                 np.maximum(lower * mirror, upper * mirror)) == pytest.approx(reference,
                                                                          rel=1e-12)
    assert solid(x, v, np.full(3, -5.0), np.full(3, 15.0)) == pytest.approx(v.sum())
    assert 0.0 < reference < v.sum()


def test_solid_profile_of_a_lattice_reads_its_packing_fraction_over_every_period():
    """A 6 x 6 x 6 lattice of spheres of diameter 2 in a box 12 wide: shells of one diameter
    hold whole layers, pi/6 each; shells of half a diameter split each layer into its outer
    and inner half, equal by symmetry, pi/6 again; every shell's solid sums to the spheres'."""
    net = cubic_lattice(6, 1.0)
    for width in (2.0, 1.0):
        edges, fraction = solid_profile(net, width)
        shells = -np.diff([region_volume(net, s) for s in edges])
        assert edges[-1] == pytest.approx(6.0)
        np.testing.assert_allclose(fraction, np.pi / 6)
        assert np.sum(fraction * shells) == pytest.approx(net.volumes.sum())
    edges, fraction = solid_profile(net, 0.5)  # quarter diameters: the layering shows,
    # the spheres' caps (thin) in the outer quarter, their middles (thick) in the next
    assert fraction[0] < np.pi / 6 < fraction[1]
    assert np.sum(fraction * -np.diff([region_volume(net, s) for s in edges])) == \
        pytest.approx(net.volumes.sum())
    with pytest.raises(InputError, match="bin_width"):
        solid_profile(net, -1.0)


def test_a_particle_held_by_two_walls_and_a_neighbour_is_not_a_rattler():
    # 0 in the corner (walls x- and y-below) touching 1; 1 on the floor (z-below);
    # 2 touches 1 only; 3 presses the wall x-above with three points, nothing else
    net = ContactNetwork.from_arrays(
        positions=[[1, 1, 3], [3, 1, 1], [5, 1, 1], [9, 5, 5]], volumes=[4.19] * 4,
        volume=1000.0, pair_particles=[[0, 1], [1, 2]], pair_branches=[[2, 0, -2], [2, 0, 0]],
        point_pairs=[0, 1], point_positions=[[2, 1, 2], [4, 1, 1]],
        point_normals=[[0.70710678, 0, -0.70710678], [1, 0, 0]],
        point_forces=[[1, 0, -1], [1, 0, 0]],
        wall_particles=[0, 0, 1, 3, 3, 3],
        wall_points=[[0, 1, 3], [1, 0, 3], [3, 1, 0], [10, 5, 5], [10, 5.5, 5], [10, 5, 5.5]],
        wall_normals=[[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [-1, 0, 0], [-1, 0, 0]],
        wall_forces=[[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [-1, 0, 0], [-1, 0, 0]],
        box_lower=[0, 0, 0], box_upper=[10, 10, 10])
    assert Connectivity().compute(net).rattlers.tolist() == [False, False, True, True]
    assert Connectivity(wall_supports=False).compute(net).rattlers.tolist() == [True] * 4


def test_wall_arrays_are_checked_and_survive_files_and_relabelling(tmp_path):
    import h5py

    net = cubic_lattice(3, 1.0)
    with h5py.File(tmp_path / "n.h5", "w") as f:
        net.to_hdf5(f.create_group("net"))
    with h5py.File(tmp_path / "n.h5") as f:
        back = ContactNetwork.from_hdf5(f["net"])
    np.testing.assert_array_equal(back.wall_forces, net.wall_forces)
    np.testing.assert_array_equal(back.box_upper, net.box_upper)
    order = np.arange(net.n_particles)[::-1]
    np.testing.assert_allclose(stress_from_network(net.relabelled(order)),
                               stress_from_network(net), atol=1e-12)
    with pytest.raises(InputError, match="wall_forces"):
        ContactNetwork(**{**{k: getattr(net, k) for k in net.__dataclass_fields__},
                          "wall_forces": None})
    with pytest.raises(InputError, match="box_upper"):
        ContactNetwork(**{**{k: getattr(net, k) for k in net.__dataclass_fields__},
                          "box_upper": np.zeros(3)})


def test_core_connectivity_counts_the_nominal_points_of_polyhedron_pairs():
    # one resultant per pair standing for m points (seed 002 eq. 14): pairs along x face-face
    # (3 points), the others face-vertex (1): z_c = 2 x 3 + 4 x 1 = 10 in the core, z = 6
    net = cubic_lattice(5, 1.0)
    along_x = np.abs(net.pair_branches[:, 0]) > 0
    values = {k: getattr(net, k) for k in net.__dataclass_fields__}
    values.update(pair_types=np.where(along_x, 1, 0), type_names=("fv", "ff"),
                  type_points=(1, 3))
    out = CoreConnectivity(margin=1.0).compute(ContactNetwork(**values)).descriptors()
    assert out["coordination_number_core"] == pytest.approx(6.0)
    assert out["connectivity_number_core"] == pytest.approx(10.0)
    assert out["n_core"] == 27.0
