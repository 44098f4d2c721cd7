"""Frictionless isotropic compaction of rigid spheres ends isostatic (issue 4; seed 002 z0 ~ 6).

Rigid frictionless spheres have 3 degrees of freedom each (rotations do not matter), and a
generic jammed packing has exactly as many force-carrying contacts as needed to block them:
C_pp + C_pw = 3 N_m among the N_m non-rattlers (+ one per stress-controlled wall), a wall
contact being one constraint like a particle contact. So z_m = 2 (C_pp + C_pw) / N_m = 6
within O(1/N_m). The contact count here is a plain loop (slow twin of
``sample_measures.mechanical_coordination``).
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.sample_measures import mechanical_coordination
from grainlab.lab.discrete_test import DiscreteTest, DiscreteTestSettings
from grainlab.lab.presets import isotropic_compression
from grainlab.prep.loose_sample import loose_sample


def compacted(n_particles: int, seed: int) -> DiscreteTest:
    sample = loose_sample(n_particles=n_particles, packing_fraction=0.3, seed=seed)
    test = DiscreteTest(sample, isotropic_compression(p_final=1e4, n_steps=1),
                        DiscreteTestSettings(record_every=10))
    assert test.run()
    assert test.outcome["stages"][-1]["reason"] == "quasi-static"
    return test


def isostatic_counts(test: DiscreteTest) -> tuple[int, int, int]:
    """(C_pp, C_pw, N_m) over force-carrying contacts after removing, repeatedly, particles
    with fewer than 4 of them (a loop twin)."""
    report = test.simulation.last_report
    c = report.contacts
    loaded = [(int(i), int(j)) for i, j, pn in zip(c.body_i, c.body_j, report.impulses[:, 0],
                                                   strict=True) if pn > 0.0]
    alive = set(range(test.sample.state.n_bodies))
    while True:
        count = dict.fromkeys(alive, 0)
        for i, j in loaded:
            if j in alive and (i < 0 or i in alive):
                count[j] += 1
                if i >= 0:
                    count[i] += 1
        weak = {b for b, n in count.items() if n < 4}
        if not weak:
            break
        alive -= weak
    live = [(i, j) for i, j in loaded if j in alive and (i < 0 or i in alive)]
    c_pp = sum(1 for i, _ in live if i >= 0)
    return c_pp, len(live) - c_pp, len(alive)


def check_isostatic(test: DiscreteTest, tolerance: float) -> float:
    c_pp, c_pw, n_m = isostatic_counts(test)
    row = test.rows[-1]
    z_m = 2.0 * (c_pp + c_pw) / n_m
    assert row["z_mechanical"] == pytest.approx(z_m, rel=1e-12)
    assert mechanical_coordination(test.simulation.last_report, test.sample.state.n_bodies,
                                   4) == pytest.approx(z_m, rel=1e-12)
    assert abs(z_m - 6.0) <= tolerance, (c_pp, c_pw, n_m, z_m)
    # walls counted once would miss isostaticity by C_pw / N_m (~0.5-0.8 in a small box)
    assert (2 * c_pp + c_pw) / n_m < 6.0 - tolerance
    assert row["max_overlap_over_d"] < 0.01
    return z_m


def test_frictionless_compaction_of_200_spheres_is_isostatic():
    # 2 (3 N_m + 3 stress walls) / N_m = 6.03 at N_m ~ 180: isostatic within 0.2
    check_isostatic(compacted(200, seed=1), tolerance=0.2)


@pytest.mark.validate
def test_frictionless_compaction_of_1000_spheres_is_isostatic():
    test = compacted(1000, seed=0)
    check_isostatic(test, tolerance=0.08)
    assert 0.58 <= test.rows[-1]["packing_fraction"] <= 0.61
    assert np.isfinite(test.rows[-1]["z_no_rattlers"])
