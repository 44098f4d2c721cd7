"""A periodic cell's compaction grows its step while the packing settles at its targets (the
slow creep of a frictionless packing), and falls back to the shortest step off them: the
same compacted state as with the fixed step."""

from __future__ import annotations

import copy
import math
from dataclasses import replace

import pandas as pd
import pytest

from grainlab.engine.boundaries.periodic_boundary import PeriodicCell
from grainlab.lab import cell_boundary
from grainlab.lab.discrete_test import DiscreteTest, DiscreteTestSettings
from grainlab.lab.presets import isotropic_compression
from grainlab.lab.stage_numerics import COMPACTION
from grainlab.lab.wall_stages import QuasiStaticCriteria
from grainlab.prep.loose_sample import loose_sample

P = 1e4
SETTINGS = DiscreteTestSettings(
    record_every=1, compaction=replace(COMPACTION, inertia_number=0.05),
    quasi_static=QuasiStaticCriteria(stress_tolerance=0.01, unbalanced_force=0.01,
                                     kinetic_energy=math.inf))


def compact(sample, fixed_step: bool, monkeypatch):
    if fixed_step:  # the rule before: a stress-driven stage never grows its step
        monkeypatch.setattr(cell_boundary.CellBoundary, "steps_by_overlap",
                            property(lambda self: self.test.stage.strain_driven))
    test = DiscreteTest(copy.deepcopy(sample), isotropic_compression(p_final=P, n_steps=1),
                        SETTINGS)
    assert test.run(max_steps=20_000), test.halted
    monkeypatch.undo()
    return pd.DataFrame(test.rows)


@pytest.fixture(scope="module")
def loose():
    return loose_sample(n_particles=120, size_ratio=1.2, packing_fraction=0.25, seed=4,
                        boundary=PeriodicCell.around)


def test_the_settling_compaction_grows_its_step_and_ends_in_the_same_state(loose, monkeypatch):
    grown = compact(loose, False, monkeypatch)
    fixed = compact(loose, True, monkeypatch)
    shortest = fixed["dt"].min()
    assert fixed["dt"].max() == pytest.approx(shortest, rel=1e-12)
    # the step grew where the cell carried its targets, and only there
    at_target = (grown["p"] - P).abs() <= 0.01 * P
    assert grown["dt"].max() > 1.5 * shortest
    assert (grown.loc[grown["dt"] > 1.001 * shortest].index.min()
            > at_target[at_target].index.min())
    # both end settled at the target, at the same packing fraction
    for table in (grown, fixed):
        end = table.iloc[-1]
        assert abs(end["p"] - P) <= 0.01 * P
        assert end["unbalanced_force_ratio"] <= 0.01
    assert grown.iloc[-1]["packing_fraction"] == pytest.approx(
        fixed.iloc[-1]["packing_fraction"], abs=0.01)
