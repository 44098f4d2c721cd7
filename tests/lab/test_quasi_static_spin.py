"""The quasi-static criterion of a compaction: the spin of a body that bears no load (a
rattler turning in its cage) is left out of its kinetic energy; every other motion counts."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig

CONFIG = {"sample": {"n_particles": 30, "seed": 3, "shape": "aggregate", "eta": 0.3},
          "test": {"kind": "compaction"},
          "solver": {"sweep": "serial"}, "output": {"checkpoint_every": 0}}


@pytest.fixture(scope="module")
def compacting(tmp_path_factory):
    run = start_run(tmp_path_factory.mktemp("spin") / "run", RunConfig.model_validate(CONFIG))
    run.run(max_steps=40)  # still a gas: some bodies touch nothing
    return run.test


def _loaded(test) -> np.ndarray:
    report = test.simulation.last_report
    forces = report.impulses[:, 0] / test.simulation.last_dt
    loaded = np.zeros(test.sample.state.n_bodies, dtype=bool)
    for bodies in (report.contacts.body_i, report.contacts.body_j):
        loaded[bodies[(forces > 0.0) & (bodies >= 0)]] = True
    return loaded


def test_a_free_spin_is_left_out_and_a_loaded_one_counts(compacting):
    test = compacting
    state = test.sample.state
    loaded = _loaded(test)
    assert loaded.any() and not loaded.all(), "the sample needs rattlers and loaded bodies"
    saved = state.angular_velocities.copy()
    try:
        base = test.record()
        free, bearing = int(np.flatnonzero(~loaded)[0]), int(np.flatnonzero(loaded)[0])
        state.angular_velocities[free] += (300.0, -200.0, 100.0)
        spun = test.record()
        # the whole energy grows by the spin's energy; the criterion's ratio does not
        added = spun["kinetic_energy"] - base["kinetic_energy"]
        assert added > 0.0
        assert spun["kinetic_energy_ratio"] == pytest.approx(base["kinetic_energy_ratio"],
                                                             rel=1e-9, abs=1e-300)
        state.angular_velocities[free] = saved[free]
        state.angular_velocities[bearing] += (300.0, -200.0, 100.0)
        counted = test.record()
        scale = state.n_bodies * base["p"] * test.sample.mean_diameter**3  # N p <d>^3
        gained = counted["kinetic_energy"] - base["kinetic_energy"]
        assert counted["kinetic_energy_ratio"] - base["kinetic_energy_ratio"] == \
            pytest.approx(gained / scale, rel=1e-9)
    finally:
        state.angular_velocities[:] = saved
        del test.rows[-3:]
