"""The step of a contact-dynamics stage grows while the overlaps stay small and halves when
they exceed the bound (lab/step_control.py): the rule, its bounds, its effect on a lab test,
its place in a checkpoint, and the solvers and boundaries that keep a fixed step."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.simulation import Periodic
from grainlab.errors import InputError
from grainlab.lab.discrete_run import resume_run, start_run
from grainlab.lab.run_config import RunConfig
from grainlab.lab.stage_numerics import SHEAR
from grainlab.lab.step_control import GROWTH_RATE, SHRINK_RATE, OverlapStepControl

TRIAXIAL = {  # 40 spheres to eps_q = 0.05: ~50 shear steps of fixed length
    "sample": {"n_particles": 40, "seed": 4},
    "test": {"kind": "triaxial", "eps_q_max": 0.05},
    "solver": {"sweep": "serial", "compaction": {"inertia_number": 0.05},
               "shear": {"inertia_number": 0.01}},
    "output": {"record_every": 5, "checkpoint_every": 0},
}


def test_the_scale_grows_geometrically_to_its_bound_and_stays():
    control = OverlapStepControl(growth=2.0, bound=1e-4)
    scales = [control.after_step(0.0) for _ in range(30)]
    steps_to_top = int(np.ceil(np.log(2.0) / np.log(GROWTH_RATE)))
    np.testing.assert_allclose(scales[:steps_to_top - 1],
                               GROWTH_RATE ** np.arange(1, steps_to_top))
    assert scales[steps_to_top - 1:] == [2.0] * (30 - steps_to_top + 1)


def test_an_overlap_above_the_bound_halves_the_scale_never_below_one():
    control = OverlapStepControl(growth=3.0, bound=1e-4, scale=3.0)
    assert control.after_step(1.1e-4) == pytest.approx(3.0 * SHRINK_RATE)
    assert control.after_step(5e-4) == 1.0
    assert control.after_step(1.0) == 1.0


def test_between_half_the_bound_and_the_bound_the_scale_holds():
    control = OverlapStepControl(growth=2.0, bound=1e-4, scale=1.5)
    assert [control.after_step(x) for x in (0.5e-4, 0.75e-4, 1e-4)] == [1.5, 1.5, 1.5]
    assert control.after_step(0.49e-4) == pytest.approx(1.5 * GROWTH_RATE)


def test_a_growth_of_one_is_a_fixed_step():
    control = OverlapStepControl(growth=1.0, bound=1e-4)
    assert {control.after_step(x) for x in (0.0, 1e-5, 1.0)} == {1.0}


@pytest.mark.parametrize(("growth", "bound", "scale", "field"), [
    (0.5, 1e-4, 1.0, "time_step_growth"), (float("nan"), 1e-4, 1.0, "time_step_growth"),
    (2.0, 0.0, 1.0, "overlap_bound"), (2.0, -1e-4, 1.0, "overlap_bound"),
    (2.0, 1e-4, 2.5, "step scale"), (2.0, 1e-4, 0.9, "step scale"),
])
def test_bad_settings_are_refused_naming_the_field(growth, bound, scale, field):
    with pytest.raises(InputError) as error:
        OverlapStepControl(growth, bound, scale)
    assert error.value.field == field


@pytest.mark.parametrize(("table", "field"), [
    ({"time_step_growth": 0.5}, "solver.shear.time_step_growth"),
    ({"overlap_bound": 0.2}, "solver.shear.overlap_bound"),
])
def test_bad_config_values_name_the_key(table, field):
    with pytest.raises(InputError) as error:
        RunConfig.model_validate({"solver": {"shear": table}})
    assert error.value.field == field


def test_a_growth_past_the_largest_step_is_refused_naming_both_numbers():
    config = RunConfig.model_validate({"solver": {"shear": {"time_step_factor": 0.3,
                                                            "time_step_growth": 2.0}}})
    with pytest.raises(InputError) as error:
        config.settings()
    assert error.value.field == "time_step_growth" and "0.3" in error.value.allowed


class _Steps:
    """Per step of the shear: its length [s], the stage's step h_0 [s] and the largest overlap
    of its detection / mean diameter."""

    name, trigger = "steps", Periodic(1)

    def __init__(self, test) -> None:
        self.test, self.rows = test, []

    def act(self, simulation) -> None:
        test = self.test
        if test.stage_index == 1 and simulation.step_index > test.stage_start_step:
            self.rows.append((simulation.last_dt, test.stage_dt,
                              simulation.last_report.max_overlap / test.sample.mean_diameter))


def _shear_steps(config: dict, folder):
    run = start_run(folder, RunConfig.model_validate(config))
    trace = run.test.simulation.add(_Steps(run.test))
    result = run.run()
    return np.array(trace.rows), result


@pytest.fixture(scope="module")
def grown_and_fixed(tmp_path_factory):
    fixed = {**TRIAXIAL, "solver": {**TRIAXIAL["solver"], "shear": {
        **TRIAXIAL["solver"]["shear"], "time_step_growth": 1.0}}}
    folder = tmp_path_factory.mktemp("steps")
    return _shear_steps(TRIAXIAL, folder / "grown"), _shear_steps(fixed, folder / "fixed")


def test_the_shear_step_grows_to_its_bound_while_the_overlaps_are_small(grown_and_fixed):
    (steps, result), (fixed_steps, fixed_result) = grown_and_fixed
    dt, h0, overlap = steps.T
    bound = SHEAR.overlap_bound
    full = dt[:-2]  # the last two steps may be cut to end on eps_q
    assert np.all(full >= h0[:-2] * (1 - 1e-12))
    assert np.all(full <= 2.0 * h0[:-2] * (1 + 1e-12))
    assert overlap.max() < 0.5 * bound  # this sample's overlaps stay small ...
    assert full.max() == pytest.approx(2.0 * h0[0], rel=1e-12)  # ... so the step doubles
    # the same strain in fewer steps, and the fixed run's step is h_0 throughout
    assert len(dt) < 0.75 * len(fixed_steps)
    np.testing.assert_allclose(fixed_steps[:-2, 0], fixed_steps[0, 1], rtol=1e-12)
    for table in (result.table, fixed_result.table):
        assert table["eps_q"].iloc[-1] == pytest.approx(0.05, abs=2e-3)


def test_an_overlap_above_the_bound_shortens_the_next_step(tmp_path):
    """A bound below the overlaps this sample reaches: wherever a step's overlap is above
    it, the next step is half as long or h_0."""
    config = {**TRIAXIAL, "solver": {**TRIAXIAL["solver"], "shear": {
        **TRIAXIAL["solver"]["shear"], "overlap_bound": 2e-4}}}
    steps, _ = _shear_steps(config, tmp_path / "run")
    dt, h0, overlap = steps.T
    above = np.flatnonzero(overlap[:-3] > 2e-4)
    assert above.size >= 3
    for k in above:
        assert dt[k + 1] == pytest.approx(max(h0[k], 0.5 * dt[k]), rel=1e-12)


def test_a_resumed_run_takes_the_same_steps(tmp_path):
    """Checkpointed in the shear with the step grown: the resumed run's rows are the
    uninterrupted run's, bit for bit."""
    config = {**TRIAXIAL, "output": {"record_every": 5, "checkpoint_every": 0}}
    whole = start_run(tmp_path / "whole", RunConfig.model_validate(config)).run().table
    shear_start = int(whole[whole["stage"] == "shear"]["step"].iloc[0])
    run = start_run(tmp_path / "cut", RunConfig.model_validate(config))
    run.run(max_steps=shear_start + 20)
    assert run.test.step_control.scale > 1.0
    run.checkpoint()
    resumed = resume_run(tmp_path / "cut").run().table
    for column in ("step", "dt", "eps_q", "q_over_trace"):
        np.testing.assert_array_equal(resumed[column], whole[column], err_msg=column)


def test_soft_contact_dem_keeps_a_fixed_step(tmp_path):
    config = {**TRIAXIAL, "solver": {**TRIAXIAL["solver"], "method": "dem"}}
    run = start_run(tmp_path / "run", RunConfig.model_validate(config))
    run.run(max_steps=3)
    assert run.test.step_control.growth == 1.0
