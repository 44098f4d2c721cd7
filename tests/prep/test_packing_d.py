"""Packing D of seed 000: the reconstruction matches Table 1 and is a stable packing."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.contact import ModifiedHertzMindlin2D
from grainlab.geometry import find_disc_contacts
from grainlab.micromech import RegularPackingModel
from grainlab.micromech.regular_packing import consolidate_isotropically
from grainlab.prep.regular_packings import TABLE_1, named_packing


def test_packing_d_reproduces_table1():
    packing = named_packing("D")
    e_paper, cn_paper = TABLE_1["D"]
    assert packing.void_ratio == pytest.approx(42.0 / (11.0 * np.pi) - 1.0, rel=1e-12)
    assert packing.void_ratio == pytest.approx(e_paper, abs=1e-4)
    contacts = find_disc_contacts(packing)
    assert contacts.coordination_number(packing.n_particles) == pytest.approx(14 / 3)
    assert round(contacts.coordination_number(packing.n_particles), 2) == cn_paper
    # Large discs touch 5 neighbours, the small one 4 (all large).
    assert sorted(contacts.per_particle(3).tolist()) == [4, 5, 5]


def test_packing_d_uses_the_rods_of_the_experiments():
    packing = named_packing("D")
    diameters = sorted(set(np.round(2 * packing.radii / 0.0254, 12)))
    assert diameters == [0.5, 0.75]  # inches


def _same_up_to_lattice(packing, other) -> bool:
    """``other`` is ``packing`` moved by some translation: every disc of ``other``, shifted,
    coincides with a disc of ``packing`` of the same radius up to a lattice vector."""
    inverse = np.linalg.inv(packing.cell.lattice)

    def matches(shift) -> bool:
        for centre, radius in zip(other.centres + shift, other.radii, strict=True):
            fractional = (centre - packing.centres) @ inverse
            on_lattice = np.all(np.abs(fractional - np.round(fractional)) < 1e-9, axis=1)
            if not np.any(on_lattice & np.isclose(packing.radii, radius)):
                return False
        return True

    candidates = packing.centres[np.isclose(packing.radii, other.radii[0])] - other.centres[0]
    return any(matches(shift) for shift in candidates)


def test_packing_d_is_mirror_symmetric_about_both_axes():
    packing = named_packing("D")
    assert _same_up_to_lattice(packing, packing.transformed(np.diag([-1.0, 1.0])))
    assert _same_up_to_lattice(packing, packing.transformed(np.diag([1.0, -1.0])))
    # ... but not under an arbitrary rotation (the check can fail).
    assert not _same_up_to_lattice(packing, packing.rotated(np.radians(90.0)))


def test_packing_d_stiffness_is_symmetric_positive_definite():
    model = RegularPackingModel(named_packing("D"), ModifiedHertzMindlin2D.seed000())
    state = consolidate_isotropically(model, 17.24e3)
    stiffness = model.stiffness_matrix(state)
    assert np.allclose(stiffness, stiffness.T, rtol=0.0, atol=1e-13 * np.abs(stiffness).max())
    assert np.linalg.eigvalsh(stiffness)[0] > 0.0
    # Stress recomputed from the contact forces is the isotropic stress applied.
    assert model.stress(state) == pytest.approx([17.24e3, 17.24e3, 0.0], abs=1e-6)
