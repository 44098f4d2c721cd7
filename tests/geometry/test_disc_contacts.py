"""Contacts of periodic disc packings: counting, invariances and error messages.

Every expected value is derived from the geometry in the test (no stored outputs of the code).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from grainlab.errors import GeometryError, InputError, RattlerWarning
from grainlab.geometry import DiscPacking2D, PeriodicCell2D, find_disc_contacts
from grainlab.geometry.rotation import rotation_matrix_2d
from grainlab.prep.regular_packings import named_packing

NAMES = ["square", "rhombic", "hexagonal", "A", "B", "C"]


def all_pairs_contacts(packing: DiscPacking2D, tolerance: float = 1e-6, reach: int = 3):
    """Slow, obviously right twin: every pair (i, j, image) with |gap| small, each unordered
    contact once (a contact i->j at image n is the same as j->i at image -n)."""
    lattice = packing.cell.lattice
    found = set()
    for i in range(packing.n_particles):
        for j in range(packing.n_particles):
            for n1 in range(-reach, reach + 1):
                for n2 in range(-reach, reach + 1):
                    if i == j and n1 == 0 and n2 == 0:
                        continue
                    offset = n1 * lattice[0] + n2 * lattice[1]
                    dist = np.linalg.norm(packing.centres[j] + offset - packing.centres[i])
                    rsum = packing.radii[i] + packing.radii[j]
                    if abs(dist - rsum) <= tolerance * rsum:
                        key = min((i, j, n1, n2), (j, i, -n1, -n2))
                        found.add(key)
    return found


def contact_keys(contacts) -> set[tuple[int, int, int, int]]:
    keys = set()
    for i, j, (n1, n2) in zip(
        contacts.particle_i, contacts.particle_j, contacts.image, strict=True
    ):
        keys.add(min((int(i), int(j), int(n1), int(n2)), (int(j), int(i), -int(n1), -int(n2))))
    return keys


@pytest.mark.parametrize("name", NAMES)
def test_each_contact_listed_once_and_matches_all_pairs_twin(name):
    packing = named_packing(name)
    contacts = find_disc_contacts(packing)
    keys = contact_keys(contacts)
    # no duplicates (the same physical contact listed from both sides or twice)
    assert len(keys) == contacts.n_contacts
    assert keys == all_pairs_contacts(packing)
    counts = contacts.per_particle(packing.n_particles)
    assert counts.sum() == 2 * contacts.n_contacts
    assert contacts.coordination_number(packing.n_particles) == pytest.approx(
        counts.sum() / packing.n_particles
    )


@pytest.mark.parametrize("name", NAMES)
def test_branch_normal_tangent_and_gap_are_consistent(name):
    packing = named_packing(name)
    c = find_disc_contacts(packing)
    lattice = packing.cell.lattice
    expected_branch = packing.centres[c.particle_j] + c.image @ lattice - packing.centres[
        c.particle_i
    ]
    np.testing.assert_allclose(c.branch, expected_branch, atol=1e-15)
    length = np.linalg.norm(c.branch, axis=1)
    np.testing.assert_allclose(length, c.radius_i + c.radius_j, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(c.normal, axis=1), 1.0, rtol=1e-14)
    np.testing.assert_allclose(np.einsum("ci,ci->c", c.normal, c.tangent), 0.0, atol=1e-15)
    # n x t = +1: the tangent is the normal turned counter-clockwise
    cross = c.normal[:, 0] * c.tangent[:, 1] - c.normal[:, 1] * c.tangent[:, 0]
    np.testing.assert_allclose(cross, 1.0, rtol=1e-14)
    np.testing.assert_allclose(c.gap, 0.0, atol=1e-12 * packing.radii.max())
    np.testing.assert_allclose(
        c.contact_point_offset_i, c.radius_i[:, None] * c.normal, rtol=1e-15
    )


def _signature(packing):
    contacts = find_disc_contacts(packing)
    counts = contacts.per_particle(packing.n_particles)
    by_label = dict(zip(packing.labels, counts.tolist(), strict=True))
    return (
        packing.void_ratio,
        contacts.coordination_number(packing.n_particles),
        sorted(counts.tolist()),
        by_label,
    )


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize(
    "transform",
    [
        lambda p: p.rotated(0.7312),
        lambda p: p.rotated(-2.0),
        lambda p: p.transformed(np.diag([-1.0, 1.0])),
        lambda p: p.translated([0.3 * p.radii[0], -1.7 * p.radii[0]]),
        lambda p: p.permuted(np.arange(p.n_particles)[::-1]),
        lambda p: p.rotated(1.1).translated([5.0, -3.0]).permuted(
            np.roll(np.arange(p.n_particles), 1)
        ),
        lambda p: p.scaled(3.5),
    ],
    ids=["rot", "rot-neg", "mirror", "translate", "relabel", "all", "scale"],
)
def test_contact_invariants(name, transform):
    packing = named_packing(name)
    e0, cn0, sorted0, by_label0 = _signature(packing)
    e1, cn1, sorted1, by_label1 = _signature(transform(packing))
    assert e1 == pytest.approx(e0, rel=1e-12)
    assert cn1 == cn0
    assert sorted1 == sorted0
    assert by_label1 == by_label0  # the labels follow the particles




@pytest.mark.parametrize(
    "shift",
    [
        [[0, 0], [1, 0]],
        [[-1, 1], [1, -1]],
        [[0, 0], [3, 0]],
        [[3, -2], [-5, 7]],
    ],
)
def test_centres_outside_the_cell_give_the_same_contacts(shift):
    """DiscPacking2D documents that centres need not lie inside the cell: moving a disc by
    whole lattice vectors describes the same periodic packing."""
    packing = named_packing("C")
    moved = DiscPacking2D(
        packing.cell,
        packing.centres + np.array(shift) @ packing.cell.lattice,
        packing.radii,
        labels=packing.labels,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RattlerWarning)
        assert _signature(moved)[1:] == _signature(packing)[1:]


def test_overlap_raises_naming_both_labels():
    cell = PeriodicCell2D([[10.0, 0.0], [0.0, 10.0]])
    packing = DiscPacking2D(cell, [[0.0, 0.0], [1.5, 0.0]], [1.0, 1.0], labels=("left", "right"))
    with pytest.raises(GeometryError) as info:
        find_disc_contacts(packing)
    message = str(info.value)
    assert "left" in message and "right" in message


def test_overlap_with_own_periodic_image_is_reported():
    cell = PeriodicCell2D([[1.5, 0.0], [0.0, 10.0]])
    packing = DiscPacking2D(cell, [[0.0, 0.0]], [1.0], labels=("fat",))
    with pytest.raises(GeometryError, match="fat"):
        find_disc_contacts(packing)


def test_overlap_within_tolerance_is_a_contact():
    cell = PeriodicCell2D([[10.0, 0.0], [0.0, 10.0]])
    packing = DiscPacking2D(
        cell, [[0.0, 0.0], [2.0 - 1e-8, 0.0], [5.0, 5.0]], [1.0, 1.0, 1.0]
    )
    with pytest.warns(RattlerWarning):
        contacts = find_disc_contacts(packing, tolerance=1e-6)
    assert contacts.n_contacts == 1


def test_rattler_warning_names_the_loose_disc():
    d = 1.0
    # square lattice of touching discs with a small disc free in the square pore
    # (pore radius d (sqrt 2 - 1)/2 = 0.207 d; the loose disc has radius 0.1 d)
    cell = PeriodicCell2D([[d, 0.0], [0.0, d]])
    packing = DiscPacking2D(
        cell, [[0.0, 0.0], [d / 2, d / 2]], [d / 2, 0.1 * d], labels=("grain", "loose")
    )
    with pytest.warns(RattlerWarning, match="loose") as record:
        contacts = find_disc_contacts(packing)
    assert all("grain" not in str(w.message) for w in record)
    assert contacts.per_particle(2).tolist() == [4, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        find_disc_contacts(packing, warn_rattlers=False)


def test_parallel_lattice_vectors_raise():
    with pytest.raises(GeometryError, match="parallel"):
        PeriodicCell2D([[1.0, 0.0], [2.0, 0.0]])
    with pytest.raises(GeometryError):
        PeriodicCell2D([[1.0, 1.0], [-3.0, -3.0]])
    with pytest.raises(GeometryError):
        PeriodicCell2D([[0.0, 0.0], [0.0, 1.0]])


@pytest.mark.parametrize("bad", [-0.2, 0.0, np.nan, np.inf])
def test_bad_radius_is_named(bad):
    cell = PeriodicCell2D([[10.0, 0.0], [0.0, 10.0]])
    with pytest.raises(InputError, match=r"radii\[2\]") as info:
        DiscPacking2D(cell, [[0, 0], [3, 0], [6, 0]], [1.0, 1.0, bad])
    assert info.value.field == "radii[2]"


def test_bad_tolerance_rejected():
    with pytest.raises(InputError, match="tolerance"):
        find_disc_contacts(named_packing("square"), tolerance=0.0)


def test_square_contacts_are_along_the_axes():
    packing = named_packing("square")
    d = 2 * packing.radii[0]
    c = find_disc_contacts(packing)
    assert c.n_contacts == 2  # 4 contacts per disc, each shared by two discs
    branches = {tuple(np.round(np.abs(b) / d, 12)) for b in c.branch}
    assert branches == {(1.0, 0.0), (0.0, 1.0)}


def test_rotation_rotates_branches():
    packing = named_packing("A")
    angle = 0.4
    c0 = find_disc_contacts(packing)
    c1 = find_disc_contacts(packing.rotated(angle))
    rotated = c0.branch @ rotation_matrix_2d(angle).T
    # same contact order (particles and images are unchanged by a rotation)
    np.testing.assert_allclose(c1.branch, rotated, atol=1e-15)


BASES = [[[1, 0], [1, 1]], [[2, 1], [1, 1]], [[1, 3], [0, 1]], [[1, 0], [5, 1]]]


@pytest.mark.parametrize("name", ["A", "B", "C", "hexagonal"])
@pytest.mark.parametrize("basis", BASES, ids=["shear1", "u2111", "shear3", "shear5"])
def test_change_of_lattice_basis_gives_the_same_contacts(name, basis):
    """A unimodular change of the lattice vectors draws the same periodic packing."""
    packing = named_packing(name)
    assert abs(np.linalg.det(basis)) == 1
    redrawn = DiscPacking2D(
        PeriodicCell2D(np.array(basis, float) @ packing.cell.lattice),
        packing.centres,
        packing.radii,
        labels=packing.labels,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RattlerWarning)
        assert _signature(redrawn)[1:] == _signature(packing)[1:]
    assert redrawn.void_ratio == pytest.approx(packing.void_ratio, rel=1e-12)
