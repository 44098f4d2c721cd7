"""Snapshots at strains (``output.snapshot_eps_q``): a strain-driven stage snapshots at the
first record where eps_q has risen past each strain asked, once each, and a run interrupted
in its shear and resumed snapshots at the same steps as the run made straight through."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.snapshot_files import read_snapshots
from grainlab.errors import InputError
from grainlab.lab.discrete_run import SNAPSHOTS, RunInterrupted, resume_run, start_run
from grainlab.lab.discrete_test_settings import DiscreteTestSettings
from grainlab.lab.run_config import RunConfig

MARKS = (0.004, 0.008, 0.012, 0.016)
"""The strains asked [-]; the shear runs to eps_q = 0.02."""

CONFIG = {
    "sample": {"n_particles": 30, "seed": 3, "size_ratio": 2.0},
    "test": {"kind": "triaxial", "eps_q_max": 0.02,
             "quasi_static": {"stress_tolerance": 0.05, "unbalanced_force": 0.05,
                              "kinetic_energy": float("inf")}},
    "solver": {"sweep": "serial", "max_stage_steps": 80, "at_max_stage_steps": "next_stage",
               "compaction": {"inertia_number": 0.1, "time_step_factor": 0.05,
                              "overlap_recovery": 0.5},
               "shear": {"friction": 0.4, "inertia_number": 0.02, "time_step_factor": 0.005}},
    "output": {"record_every": 1, "snapshot_every": 0, "checkpoint_every": 0,
               "snapshot_eps_q": list(MARKS)},
}


def snapshot_rows(folder) -> list[tuple[str, int, float]]:
    return [(s.state["stage"], int(s.state["step"]), float(s.state["eps_q"]))
            for s in read_snapshots(folder / SNAPSHOTS)]


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    folder = tmp_path_factory.mktemp("straight") / "run"
    result = start_run(folder, RunConfig.model_validate(CONFIG)).run()
    return folder, result.table


def test_each_strain_is_snapshotted_once_at_the_first_record_past_it(straight):
    folder, table = straight
    shear = table[table["stage"] == "shear"]
    assert shear["eps_q"].iloc[-1] >= 0.02
    taken = [(step, eps) for stage, step, eps in snapshot_rows(folder) if stage == "shear"]
    expected = sorted({int(shear["step"][shear["eps_q"] >= mark].iloc[0]) for mark in MARKS}
                      | {int(shear["step"].iloc[-1])})  # and the state the stage ends in
    assert [step for step, _ in taken] == expected
    for mark in MARKS:  # the snapshot of a strain is the first record at or past it
        step, eps = next((s, e) for s, e in taken if e >= mark)
        earlier = shear[shear["step"] < step]["eps_q"]
        assert eps >= mark and (earlier.empty or earlier.max() < mark)
    # the compaction (no strain-driven axis) takes only its end state
    compaction = [step for stage, step, _ in snapshot_rows(folder) if stage == "compaction"]
    assert compaction == [int(table[table["stage"] == "compaction"]["step"].iloc[-1])]


def test_a_resumed_run_snapshots_where_the_straight_run_did(straight, tmp_path):
    folder, table = straight
    shear_steps = table[table["stage"] == "shear"]["step"].to_numpy()
    stop = int(shear_steps[len(shear_steps) // 2])
    config = RunConfig.model_validate(CONFIG).with_updates({"output": {"checkpoint_every": 1}})
    run = start_run(tmp_path / "run", config)

    def interrupt(test, row):
        if row["step"] == stop:
            run.request_interrupt()

    run.test.on_record = interrupt
    with pytest.raises(RunInterrupted):
        run.run()
    resume_run(tmp_path / "run").run()
    assert snapshot_rows(tmp_path / "run") == snapshot_rows(folder)
    a = [s.point_normal_forces for s in read_snapshots(folder / SNAPSHOTS)]
    b = [s.point_normal_forces for s in read_snapshots(tmp_path / "run" / SNAPSHOTS)]
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("marks", [[0.02, 0.01], [0.0, 0.01], [float("nan")], [-0.1]])
def test_strains_not_positive_and_increasing_are_refused_by_name(marks):
    with pytest.raises(InputError) as caught:
        RunConfig.model_validate({"output": {"snapshot_eps_q": marks}})
    assert caught.value.field.startswith("output.snapshot_eps_q")  # .0: the first entry
    with pytest.raises(InputError) as caught:
        DiscreteTestSettings(snapshot_eps_q=marks)
    assert caught.value.field == "snapshot_eps_q"


def test_snapshots_every_n_steps_fall_at_the_first_record_past_each_multiple(tmp_path):
    """With records every 4 steps and a snapshot asked every 7, a snapshot is taken at the
    first record at or past each multiple of 7 (about every 7 steps), not every 28 where
    the two counts meet; a run interrupted and resumed takes them at the same steps."""
    config = RunConfig.model_validate({**CONFIG, "output": {
        "record_every": 4, "snapshot_every": 7, "checkpoint_every": 8,
        "snapshot_eps_q": []}})
    folder = tmp_path / "straight"
    table = start_run(folder, config).run().table
    steps = [int(s) for s in table["step"]]
    first = -1 if steps[0] == 0 else 0
    expected = [s for before, s in zip([first, *steps], steps, strict=False)
                if s // 7 > before // 7]
    taken = sorted({step for _, step, _ in snapshot_rows(folder)})
    ends = {int(table[table["stage"] == name]["step"].iloc[-1]) for name in ("compaction",
                                                                             "shear")}
    assert taken == sorted(set(expected) | ends)
    assert len(expected) >= steps[-1] // 7  # one per multiple of 7 reached
    gaps = np.diff(expected)
    assert gaps.max() <= 8 and gaps.min() >= 4  # about 7: records of 4 around multiples of 7
    # interrupted after 30 steps, resumed from its checkpoint: the same snapshot steps
    resumed = tmp_path / "resumed"
    start_run(resumed, config).run(max_steps=30)
    resume_run(resumed).run()
    assert sorted({step for _, step, _ in snapshot_rows(resumed)}) == taken
