"""Stages of discrete tests end on their targets whatever the record interval: the strain of
a strain-controlled axis exactly, a stop criterion on a strain within a step; the end state is
a row; the cut last step goes through a checkpoint; K0 of one-dimensional compression; a
compaction ends at the first record that meets its quasi-static criteria, as set."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from grainlab.engine.simulation import Periodic
from grainlab.lab.discrete_run import resume_run, start_run
from grainlab.lab.run_config import RunConfig
from grainlab.lab.stage_boundary import SHORTEST_CUT
from grainlab.lab.wall_stages import QuasiStaticCriteria

AXIAL, UNLOAD = 0.002, 0.001

OEDOMETER = {  # as small as tests/cli's oedometer; loading needs ~4 steps, unloading ~2
    "sample": {"n_particles": 30, "seed": 3},
    "test": {"kind": "oedometer", "axial_strain": AXIAL, "unload_strain": UNLOAD},
    "solver": {"inertia_number": 0.01, "sweep": "serial"},
    "output": {"record_every": 50, "checkpoint_every": 0},
}

TRIAXIAL = {  # tests/lab/test_discrete_run.py's sample; the shear needs ~21 steps, all of
    # one length (no growth), so that the overshoot is measured against a step's increment
    "sample": {"n_particles": 40, "seed": 4},
    "test": {"kind": "triaxial", "eps_q_max": 0.02},
    "solver": {"sweep": "serial", "compaction": {"inertia_number": 0.05, "max_iterations": 400},
               "shear": {"inertia_number": 0.01, "overlap_recovery": 0.0,
                         "time_step_growth": 1.0}},
    "output": {"record_every": 50, "checkpoint_every": 0},
}


class _WallStrains:
    """Records the wall strains after every step of the stages after the compaction."""

    name, trigger = "wall_strains", Periodic(1)

    def __init__(self, test) -> None:
        self.test, self.strains = test, []

    def act(self, simulation) -> None:
        if self.test.stage_index >= 1:
            eps = np.log(self.test.boundary.reference_lengths / self.test.sample.box.lengths)
            self.strains.append({"eps_zz": eps[2], "eps_q": eps.max() - eps.min()})


def _stage(table: pd.DataFrame, name: str) -> pd.DataFrame:
    return table[table["stage"] == name]


@pytest.fixture(scope="module")
def oedometer_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("oedometer") / "run"
    run = start_run(folder, RunConfig.model_validate(OEDOMETER))
    trace = run.test.simulation.add(_WallStrains(run.test))
    return folder, run.run(), trace.strains


def test_oedometer_stages_end_on_their_strains_with_a_coarse_record(oedometer_run):
    _, result, strains = oedometer_run
    table, stages = result.table, result.metadata["outcome"]["stages"]
    assert [s["reason"] for s in stages[1:]] == ["strain reached", "strain reached"]
    assert all(s["steps"] < OEDOMETER["output"]["record_every"] for s in stages[1:])
    loading, unloading = _stage(table, "loading"), _stage(table, "unloading")
    # the last row of each stage is its end state, recorded though no record was due
    assert loading["step"].iloc[-1] == stages[1]["end_step"]
    assert unloading["step"].iloc[-1] == stages[2]["end_step"]
    top, bottom = loading["eps_zz"].iloc[-1], unloading["eps_zz"].iloc[-1]
    # within a step: the loading takes several steps of eps_zz
    increments = np.diff([0.0] + [s["eps_zz"] for s in strains])
    assert len(increments) > 4 and np.max(np.abs(increments)) > 5e-4
    assert abs(top - AXIAL) < 1e-3 * np.max(np.abs(increments))
    # exactly, to round-off: the wall moves at a prescribed speed
    assert top == pytest.approx(AXIAL, abs=1e-10)
    assert top - bottom == pytest.approx(UNLOAD, abs=1e-10)
    # the lateral walls stay put
    assert np.max(np.abs(table.loc[table["stage"] != "compaction", "eps_xx"])) < 1e-12


def test_oedometer_reports_k0(oedometer_run):
    _, result, _ = oedometer_run
    table = result.table
    expected = (table["sigma_xx"] + table["sigma_yy"]) / (2.0 * table["sigma_zz"])
    np.testing.assert_allclose(table["K0"], expected, rtol=1e-14)
    assert result.units["K0"] == "-"
    assert np.isfinite(_stage(table, "loading")["K0"]).all()


def test_a_cut_last_step_goes_through_a_checkpoint(oedometer_run, tmp_path):
    _, reference, _ = oedometer_run
    end = reference.metadata["outcome"]["stages"][1]["end_step"]
    run = start_run(tmp_path / "run", RunConfig.model_validate(OEDOMETER))
    run.run(max_steps=end - 1)  # the next step is the loading's cut last one
    assert run.test.stage.name == "loading"
    assert run.test.solver.dt != run.test.stage_dt  # cut short or stretched (no sliver)
    run.checkpoint()
    table, expected = resume_run(tmp_path / "run").run().table, reference.table
    for column in ("step", "dt", "eps_zz"):
        np.testing.assert_array_equal(table[column], expected[column])
    np.testing.assert_allclose(table["sigma_zz"], expected["sigma_zz"], rtol=1e-9)


def test_triaxial_ends_at_eps_q_within_a_step_with_a_coarse_record(tmp_path):
    run = start_run(tmp_path / "run", RunConfig.model_validate(TRIAXIAL))
    trace = run.test.simulation.add(_WallStrains(run.test))
    result = run.run()
    shear = _stage(result.table, "shear")
    stage = result.metadata["outcome"]["stages"][1]
    assert stage["reason"] == "stop criterion eps_q above 0.02"
    assert stage["steps"] < TRIAXIAL["output"]["record_every"]
    assert shear["step"].iloc[-1] == stage["end_step"]
    increment = np.max(np.diff([0.0] + [s["eps_q"] for s in trace.strains]))
    overshoot = shear["eps_q"].iloc[-1] - 0.02
    # never short; past it by a small part of a step (the last step is cut to the crossing
    # the walls' speeds predict, at least SHORTEST_CUT of a step)
    assert 0.0 <= overshoot < SHORTEST_CUT * increment


def test_every_stage_ends_in_a_snapshot_whatever_the_snapshot_interval(oedometer_run):
    """Snapshots on (every 500 steps by default) but the run far shorter: the state each of
    the three stages ends in is still a snapshot, with its stage and step, so that
    `grainlab analyse` of a short run has the compaction and the end to read."""
    from grainlab.analysis.snapshot_files import read_snapshots

    folder, result, _ = oedometer_run
    table = result.table
    states = [net.state for net in read_snapshots(folder / "snapshots.h5")]
    ends = {name: int(_stage(table, name)["step"].iloc[-1])
            for name in ("compaction", "loading", "unloading")}
    assert ends["unloading"] - ends["compaction"] < 500  # loading, unloading: no periodic one
    periodic = [s for s in states if int(s["step"]) % 500 == 0]
    at_ends = [(s["stage"], int(s["step"])) for s in states if int(s["step"]) % 500]
    assert at_ends == [(name, step) for name, step in ends.items() if step % 500]
    assert len(states) == len(periodic) + len(at_ends) and len(at_ends) >= 2


@pytest.mark.parametrize("criteria", [{}, {"kinetic_energy": math.inf},
                                      {"kinetic_energy": math.inf, "unbalanced_force": math.inf}])
def test_a_compaction_ends_at_the_first_record_that_meets_its_criteria(tmp_path, criteria):
    config = RunConfig.model_validate({
        "sample": {"n_particles": 30, "seed": 3},
        "test": {"kind": "compaction", "quasi_static": criteria}, "solver": {"sweep": "serial"},
        "output": {"record_every": 5, "checkpoint_every": 0, "snapshot_every": 0}})
    table = start_run(tmp_path / "run", config).run().table
    settled = QuasiStaticCriteria(**criteria)
    sigma0 = {axis: config.test.sigma0 for axis in range(3)}
    met = [settled.met(row, sigma0) for row in table.to_dict("records")]
    assert met[-1] and not any(met[:-1])
