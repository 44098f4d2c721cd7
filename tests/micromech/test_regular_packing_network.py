"""A seed 000 specimen seen as a contact network: the analysis layer agrees with the theory."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.contact_stress import stress_from_network
from grainlab.contact import ModifiedHertzMindlin2D
from grainlab.micromech import RegularPackingModel, RotatedStressPath
from grainlab.micromech.regular_packing import consolidate_isotropically
from grainlab.prep.regular_packings import named_packing


@pytest.mark.parametrize("name", ["A", "C", "D"])
def test_network_stress_equals_the_theory(name):
    model = RegularPackingModel(named_packing(name), ModifiedHertzMindlin2D.seed000())
    state = consolidate_isotropically(model, 17.24e3)
    network = model.contact_network(state)
    np.testing.assert_allclose(stress_from_network(network), model.stress_tensor(state),
                               rtol=1e-12, atol=1e-9)
    assert 2 * network.n_pairs / network.n_particles == pytest.approx(
        model.contacts.coordination_number(model.packing.n_particles))


def test_network_of_a_loaded_packing_feeds_the_snapshot_analysis():
    from grainlab.analysis.snapshot_analysis import SnapshotAnalysis

    model = RegularPackingModel(named_packing("C"), ModifiedHertzMindlin2D.seed000())
    path = RotatedStressPath(alpha=np.radians(30.0), max_ratio=2.0)
    state = consolidate_isotropically(model, path.confining_stress)
    analysis = SnapshotAnalysis().compute(model.contact_network(state))
    assert analysis.descriptors["p"] == pytest.approx(17.24e3, rel=1e-9)
    assert analysis.descriptors["packing_fraction"] == pytest.approx(
        model.packing.solid_fraction)
