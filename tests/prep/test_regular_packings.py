"""The regular packings of seed 000 (Fig. 1, Fig. 3, Table 1).

Table 1: A e = 0.1880 CN 5.00; B e = 0.4702 CN 4.00; C e = 0.1388 CN 5.00 (D is not built yet).
The expected values are the published ones or closed forms derived here.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.geometry import find_disc_contacts
from grainlab.prep.regular_packings import (
    ROD_DIAMETER,
    named_packing,
    packing_names,
    rhombic_packing,
)

TABLE_1 = {"A": (0.1880, 5.00), "B": (0.4702, 4.00), "C": (0.1388, 5.00)}


def coordination(packing):
    contacts = find_disc_contacts(packing)
    return contacts.coordination_number(packing.n_particles), contacts


@pytest.mark.parametrize("name", sorted(TABLE_1))
def test_table_1(name):
    packing = named_packing(name)
    e, cn = TABLE_1[name]
    assert packing.void_ratio == pytest.approx(e, abs=1e-4)
    assert coordination(packing)[0] == pytest.approx(cn, abs=0.01)


def test_packing_a_void_ratio_closed_form():
    # per disc: d x d (1 + sqrt3/2) / 2 = d^2 (2 + sqrt3) / 4 of area, pi d^2 / 4 of solid,
    # so e = (2 + sqrt3) / pi - 1 (the "2 (2 + sqrt3)/pi - 1" of the packing_a docstring is
    # a typo: it would be 1.376)
    expected = (2 + np.sqrt(3)) / np.pi - 1
    assert expected == pytest.approx(0.18795, abs=1e-5)
    assert named_packing("A").void_ratio == pytest.approx(expected, rel=1e-12)


def test_packing_b_void_ratio_closed_form():
    expected = 8 / (np.pi * np.sqrt(3)) - 1
    assert named_packing("B").void_ratio == pytest.approx(expected, rel=1e-12)


def test_packing_c_sizes_and_contacts_per_disc():
    packing = named_packing("C")
    assert packing.n_particles == 2
    large, small = np.argmax(packing.radii), np.argmin(packing.radii)
    assert packing.radii[large] / packing.radii[small] == pytest.approx(2.0, rel=1e-14)
    assert 2 * packing.radii[large] == pytest.approx(0.5 * 0.0254, rel=1e-14)  # 0.5 in rods
    cn, contacts = coordination(packing)
    counts = contacts.per_particle(packing.n_particles)
    assert counts[large] == 6
    assert counts[small] == 4
    assert cn == pytest.approx(5.0)
    # closed form of the reconstruction: rows sqrt(5) R apart, cell 2R x sqrt(5) R
    R = packing.radii[large]
    expected = 2 * np.sqrt(5) * R**2 / (np.pi * (R**2 + (R / 2) ** 2)) - 1
    assert packing.void_ratio == pytest.approx(expected, rel=1e-12)


def test_packing_a_every_disc_has_five_contacts():
    packing = named_packing("A")
    _, contacts = coordination(packing)
    assert contacts.per_particle(packing.n_particles).tolist() == [5, 5]
    assert np.all(packing.radii == packing.radii[0])


def test_packing_b_every_disc_has_four_contacts():
    packing = named_packing("B")
    _, contacts = coordination(packing)
    assert contacts.per_particle(packing.n_particles).tolist() == [4, 4, 4]


def test_square_packing():
    packing = named_packing("square")
    assert packing.void_ratio == pytest.approx(4 / np.pi - 1, rel=1e-12)
    assert coordination(packing)[0] == 4.0


def test_hexagonal_packing():
    packing = named_packing("hexagonal")
    assert packing.void_ratio == pytest.approx(2 * np.sqrt(3) / np.pi - 1, rel=1e-12)
    assert coordination(packing)[0] == 6.0


@pytest.mark.parametrize("angle_deg", [65.0, 75.0, 89.0])
def test_rhombic_packing(angle_deg):
    packing = rhombic_packing(angle=np.radians(angle_deg))
    # cell d x d sin(angle) holding one disc of area pi d^2 / 4
    assert packing.void_ratio == pytest.approx(
        4 * np.sin(np.radians(angle_deg)) / np.pi - 1, rel=1e-12
    )
    assert coordination(packing)[0] == 4.0


def test_rhombic_limits():
    assert rhombic_packing(angle=np.radians(90.0)).void_ratio == pytest.approx(
        named_packing("square").void_ratio, rel=1e-12
    )
    with pytest.raises(InputError, match="angle"):
        rhombic_packing(angle=np.radians(60.0))


@pytest.mark.parametrize("name", [n for n in packing_names() if n != "D"])
def test_every_disc_touches_exactly(name):
    packing = named_packing(name)
    contacts = find_disc_contacts(packing)
    np.testing.assert_allclose(contacts.gap, 0.0, atol=1e-12 * ROD_DIAMETER)
    assert np.all(contacts.per_particle(packing.n_particles) > 0)


@pytest.mark.parametrize("name", [n for n in packing_names() if n != "D"])
def test_void_ratio_is_scale_free(name):
    packing = named_packing(name)
    assert packing.scaled(7.0).void_ratio == pytest.approx(packing.void_ratio, rel=1e-12)


def test_names():
    names = packing_names()
    for expected in ("square", "rhombic", "hexagonal", "A", "B", "C"):
        assert expected in names
    assert named_packing(" c ").void_ratio == named_packing("C").void_ratio
    with pytest.raises(InputError, match="packing"):
        named_packing("Z")
