"""Generators of seed 001's micro-element structures: binary units (§4.1), the idealized
material (§4.2), micro-elements of contact networks and disc packings, the ch. 3 packing."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.errors import InputError
from grainlab.geometry import find_disc_contacts, power_tessellation
from grainlab.micromech.micro_element.structures import (
    axis_permutation_rotations,
    binary_units,
    chang_periodic_discs,
    contact_density_parameter,
    from_contact_network,
    from_disc_packing,
    idealized_material,
)
from grainlab.prep.regular_packings import named_packing


def isotropic_fourth_order(dimension: int) -> np.ndarray:
    """d_ij d_kl + d_ik d_jl + d_il d_jk."""
    d = np.eye(dimension)
    return (np.einsum("ij,kl->ijkl", d, d) + np.einsum("ik,jl->ijkl", d, d)
            + np.einsum("il,jk->ijkl", d, d))


def moments(structure):
    n = structure.normals[structure.mask]
    return (n, np.einsum("ki,kj->ij", n, n), np.einsum("ki,kj,kl,km->ijlm", n, n, n, n))


# -- (a) binary units -------------------------------------------------------------------------
def test_icosahedral_binary_units_are_exactly_isotropic_to_fourth_order():
    units = binary_units(radius=0.5e-3, void_ratio=0.6)
    n, second, fourth = moments(units)
    assert n.shape == (12, 3)
    np.testing.assert_allclose(n.sum(axis=0), 0.0, atol=1e-15)
    np.testing.assert_allclose(second, 4.0 * np.eye(3), atol=1e-14)
    np.testing.assert_allclose(fourth, 12.0 / 15.0 * isotropic_fourth_order(3), atol=1e-14)
    # the six axes are distinct and +/- pairs: the 12 vertices of the icosahedron (all at
    # 63.43 deg or 116.57 deg from each other, except the antipode)
    cosines = np.abs(n @ n.T)[~np.eye(12, dtype=bool)]
    np.testing.assert_allclose(np.sort(cosines)[:-12], 1 / np.sqrt(5), atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(units.branches[:, 0], axis=1), 1e-3)


def test_binary_unit_volumes_give_the_void_ratio_and_eq_4_4():
    r, e, z = 0.5e-3, 0.6, 6.0
    units = binary_units(radius=r, void_ratio=e, coordination_number=z)
    v_particle = 4 / 3 * np.pi * r**3
    # z units (contacts seen from one particle) share one particle's share of space
    np.testing.assert_allclose(units.volumes, v_particle * (1 + e) / z)
    np.testing.assert_allclose(z * units.volumes[0] / v_particle - 1.0, e)
    eq44 = units.n_elements / (3 * units.total_volume) * r**3  # (M / 3V) r^3, M double count
    assert eq44 == pytest.approx(z / (4 * np.pi * (1 + e)), rel=1e-12)
    assert units.description["z_eq_4_4"] == pytest.approx(eq44, rel=1e-12)
    assert contact_density_parameter(z, e) == pytest.approx(eq44, rel=1e-12)
    # the uniform-strain stiffness of the units equals that of the packing counted per contact
    stiffness_units = sum(0.5 * np.einsum("i,j,k,l->ijkl", *(4 * [b])) for b in
                          units.branches[:, 0]) / units.total_volume
    contacts_once = units.branches[:6, 0]  # the six axes, each contact counted once
    packing_volume = 2 * v_particle * (1 + e)  # 6 contacts, z = 6: two particles' worth
    assert units.total_volume == pytest.approx(packing_volume, rel=1e-12)
    stiffness_packing = sum(np.einsum("i,j,k,l->ijkl", *(4 * [b])) for b in
                            contacts_once) / packing_volume
    np.testing.assert_allclose(stiffness_units, stiffness_packing, rtol=1e-12)


@pytest.mark.parametrize("n_axes", [3, 4, 7])
def test_two_dimensional_binary_units_are_exactly_isotropic(n_axes):
    units = binary_units(n_axes, radius=1e-3, void_ratio=0.2, dimension=2)
    n, second, fourth = moments(units)
    count = 2 * n_axes
    assert n.shape == (count, 2)
    np.testing.assert_allclose(second, count / 2 * np.eye(2), atol=1e-13)
    np.testing.assert_allclose(fourth, count / 8 * isotropic_fourth_order(2), atol=1e-13)
    np.testing.assert_allclose(units.volumes, np.pi * 1e-6 * 1.2 / 4)


def test_two_axes_in_two_dimensions_are_not_isotropic():
    _, _, fourth = moments(binary_units(2, radius=1e-3, void_ratio=0.2, dimension=2))
    assert not np.allclose(fourth, 4 / 8 * isotropic_fourth_order(2), atol=1e-3)


def test_fibonacci_binary_units_are_nearly_isotropic():
    units = binary_units(200, radius=1e-3, void_ratio=0.5)
    n, second, fourth = moments(units)
    np.testing.assert_allclose(n.sum(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(second / 400, np.eye(3) / 3, atol=5e-3)
    np.testing.assert_allclose(fourth / 400, isotropic_fourth_order(3) / 15, atol=5e-3)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"directions": "dodecahedron"}, "directions"),
    ({"directions": "icosahedron", "dimension": 2}, "directions"),
    ({"directions": 0}, "directions"),
    ({"radius": -1.0}, "radius"),
    ({"void_ratio": 0.0}, "void_ratio"),
    ({"coordination_number": -3}, "coordination_number"),
    ({"dimension": 4}, "dimension"),
])
def test_binary_units_name_bad_arguments(kwargs, field):
    arguments = {"radius": 1e-3, "void_ratio": 0.6, **kwargs}
    with pytest.raises(InputError, match=field):
        binary_units(**arguments)


# -- (b) idealized material -------------------------------------------------------------------
@pytest.fixture(scope="module")
def material():
    return idealized_material(seed=1)


def test_idealized_material_numbers(material):
    assert material.n_elements == 30
    assert material.coordination_number == 7.0
    assert np.all(material.contact_counts == 7)
    assert material.void_ratio() == pytest.approx(0.7, rel=1e-12)
    np.testing.assert_allclose(material.volumes, 4 / 3 * np.pi * 0.2e-3**3 * 1.7)
    np.testing.assert_allclose(np.linalg.norm(material.branches, axis=2), 0.4e-3, rtol=1e-14)
    np.testing.assert_allclose(material.centre_radii, 0.2e-3)


def assert_centre_can_balance(structure):
    """No direction u sees every neighbour on its closed side; positive weights w >= 1 with
    sum w n = 0 exist (the centre can be in equilibrium under compressive forces)."""
    probes = np.random.default_rng(5).normal(size=(20000, 3))
    for element in structure.normals:
        assert np.all((probes @ element.T).min(axis=1) < 0.0)
        m = element.shape[0]
        lp = linprog(np.zeros(m), A_eq=element.T, b_eq=np.zeros(3), bounds=[(1, None)] * m)
        assert lp.status == 0


def test_idealized_neighbours_do_not_overlap_and_hold_the_centre(material):
    n = material.normals
    cosines = np.einsum("emi,eki->emk", n, n)
    off = ~np.eye(7, dtype=bool)
    assert np.degrees(np.arccos(cosines[:, off].max())) >= 60.0 - 1e-9
    assert_centre_can_balance(material)


def test_four_neighbours_are_rejected_when_in_one_hemisphere():
    # 7 of 8 sets of 4 random directions lie in a hemisphere (Wendel): rejection is needed
    sparse = idealized_material(seed=3, n_random=10, n_neighbours=4)
    assert sparse.n_elements == 60
    assert_centre_can_balance(sparse)


def _canonical(branch_sets: np.ndarray) -> list:
    return sorted(tuple(map(tuple, np.round(s[np.lexsort(np.round(s, 12).T[::-1])], 12)))
                  for s in branch_sets)


def test_idealized_material_is_invariant_under_axis_permutations(material):
    rotations = axis_permutation_rotations()
    assert len({tuple(r.ravel()) for r in rotations}) == 6
    np.testing.assert_allclose(np.linalg.det(rotations), 1.0)
    for rotation in rotations:  # each is a signed permutation matrix
        assert np.all(np.abs(rotation).sum(axis=0) == 1)
    original = _canonical(material.branches)
    for rotation in rotations:
        assert _canonical(material.rotated(rotation).branches) == original
    # a generic rotation does not map the material onto itself
    angle = 0.3
    generic = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0],
                        [0, 0, 1]])
    assert _canonical(material.rotated(generic).branches) != original
    # and each permutation of the axes leaves the even-order fabric unchanged
    fabric = np.einsum("emi,emj->ij", material.branches, material.branches)
    for rotation in rotations:
        np.testing.assert_allclose(rotation @ fabric @ rotation.T, fabric, atol=1e-20)


def test_idealized_material_is_reproducible_from_its_seed(material):
    again = idealized_material(seed=1)
    np.testing.assert_array_equal(again.branches, material.branches)
    other = idealized_material(seed=2)
    assert not np.allclose(other.branches, material.branches)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"), ({"n_random": 0}, "n_random"),
    ({"n_neighbours": 3}, "n_neighbours"), ({"n_neighbours": 13}, "n_neighbours"),
    ({"radius": 0.0}, "radius"), ({"void_ratio": -0.1}, "void_ratio"),
])
def test_idealized_material_names_bad_arguments(kwargs, field):
    with pytest.raises(InputError, match=field):
        idealized_material(**kwargs)


# -- (c) contact networks and disc packings ---------------------------------------------------
def three_discs_in_a_row(tension_in_second_pair: bool = False) -> ContactNetwork:
    r = 1e-3
    force = -2.0 if tension_in_second_pair else 3.0
    return ContactNetwork.from_arrays(
        positions=[[0, 0], [2 * r, 0], [4 * r, 0]], volumes=[np.pi * r**2] * 3,
        volume=24 * r**2, pair_particles=[[0, 1], [2, 1]],
        pair_branches=[[2 * r, 0], [-2 * r, 0]], point_pairs=[0, 1],
        point_positions=[[r, 0], [3 * r, 0]], point_normals=[[1, 0], [-1, 0]],
        point_forces=[[5.0, 0], [-force, 0]])


def test_from_contact_network_gives_branch_vectors_with_signs():
    structure = from_contact_network(three_discs_in_a_row())
    r = 1e-3
    assert structure.description["particles"] == [0, 1, 2]
    np.testing.assert_array_equal(structure.contact_counts, [1, 2, 1])
    np.testing.assert_allclose(structure.branches[0, 0], [2 * r, 0])
    np.testing.assert_allclose(structure.branches[1][structure.mask[1]],
                               [[-2 * r, 0], [2 * r, 0]])
    np.testing.assert_allclose(structure.branches[2, 0], [-2 * r, 0])
    np.testing.assert_allclose(structure.centre_radii, r)
    np.testing.assert_allclose(structure.neighbour_radii[structure.mask], r)
    np.testing.assert_allclose(structure.volumes, 8 * r**2)
    assert structure.total_volume == pytest.approx(24 * r**2)


def test_from_contact_network_active_only_drops_tensile_pairs():
    network = three_discs_in_a_row(tension_in_second_pair=True)
    active = from_contact_network(network)
    assert active.description["particles"] == [0, 1]
    assert active.description["n_rattlers"] == 1
    np.testing.assert_allclose(active.branches[1, 0], [-2e-3, 0])
    every = from_contact_network(network, active_only=False)
    assert every.description["particles"] == [0, 1, 2]
    np.testing.assert_allclose(every.volumes, 8e-6)


def test_from_contact_network_particle_volumes_in_3d():
    r1, r2 = 1e-3, 2e-3
    network = ContactNetwork.from_arrays(
        positions=[[0, 0, 0], [0, 0, r1 + r2]],
        volumes=[4 / 3 * np.pi * r1**3, 4 / 3 * np.pi * r2**3], volume=1e-7,
        pair_particles=[[0, 1]], pair_branches=[[0, 0, r1 + r2]], point_pairs=[0],
        point_positions=[[0, 0, r1]], point_normals=[[0, 0, 1]], point_forces=[[0, 0, 1.0]])
    structure = from_contact_network(network, volumes="particle")
    np.testing.assert_allclose(structure.centre_radii, [r1, r2])
    np.testing.assert_allclose(structure.neighbour_radii[:, 0], [r2, r1])
    np.testing.assert_allclose(structure.volumes, np.array([1, 8]) / 9 * 1e-7)
    np.testing.assert_allclose(structure.branches[:, 0], [[0, 0, r1 + r2], [0, 0, -r1 - r2]])
    with pytest.raises(InputError, match="volumes"):
        from_contact_network(network, volumes="power")


def test_from_disc_packing_hexagonal_is_one_element_of_six_contacts():
    packing = named_packing("hexagonal")
    structure = from_disc_packing(packing)
    assert structure.n_elements == 1
    assert structure.contact_counts.tolist() == [6]
    angles = np.sort(np.degrees(np.arctan2(*structure.branches[0].T[::-1])) % 360)
    np.testing.assert_allclose(np.diff(angles), 60.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(structure.branches[0], axis=1),
                               2 * packing.radii[0])
    assert structure.total_volume == pytest.approx(packing.cell.area, rel=1e-12)
    assert structure.void_ratio() == pytest.approx(packing.void_ratio, rel=1e-12)


# -- (d) the random periodic packing of chapter 3 ---------------------------------------------
@pytest.fixture(scope="module")
def chang():
    return chang_periodic_discs(seed=1)


def test_chang_packing_has_25_touching_discs(chang):
    assert chang.n_particles == 25
    assert sorted(chang.radii.tolist()) == sorted([0.21e-3] * 12 + [0.105e-3] * 13)
    contacts = find_disc_contacts(chang, tolerance=1e-9)  # raises on any overlap beyond 1e-9
    counts = contacts.per_particle(25)
    assert counts.min() >= 3
    assert contacts.n_contacts == find_disc_contacts(chang, tolerance=1e-3).n_contacts
    z = contacts.coordination_number(25)
    assert 3.9 <= z <= 4.5
    assert 0.15 <= chang.void_ratio <= 0.3
    # every disc in equilibrium: each disc's contact normals not all in one half plane
    for k in range(25):
        normals = np.concatenate([contacts.normal[contacts.particle_i == k],
                                  -contacts.normal[contacts.particle_j == k]])
        angles = np.sort(np.arctan2(normals[:, 1], normals[:, 0]))
        gaps = np.diff(np.concatenate([angles, [angles[0] + 2 * np.pi]]))
        assert gaps.max() < np.pi


def test_chang_packing_gives_25_micro_elements(chang):
    structure = from_disc_packing(chang)
    assert structure.n_elements == 25
    assert structure.coordination_number == pytest.approx(
        find_disc_contacts(chang).coordination_number(25))
    np.testing.assert_allclose(structure.volumes, power_tessellation(chang).areas, rtol=1e-12)
    assert structure.void_ratio() == pytest.approx(chang.void_ratio, rel=1e-12)
    lengths = np.linalg.norm(structure.branches, axis=2)
    np.testing.assert_allclose(lengths[structure.mask], (structure.centre_radii[:, None]
                                                         + structure.neighbour_radii)[
                                                             structure.mask], rtol=1e-12)


def test_chang_packing_is_reproducible_from_its_seed(chang):
    np.testing.assert_array_equal(chang_periodic_discs(seed=1).centres, chang.centres)
    assert not np.allclose(chang_periodic_discs(seed=7).centres, chang.centres)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"seed": -2}, "seed"), ({"r_large": 0.0}, "r_large"), ({"n_small": -1}, "n_small"),
    ({"n_large": 2, "n_small": 1}, "n_large"), ({"max_attempts": 0}, "max_attempts"),
])
def test_chang_packing_names_bad_arguments(kwargs, field):
    with pytest.raises(InputError, match=field):
        chang_periodic_discs(**kwargs)
