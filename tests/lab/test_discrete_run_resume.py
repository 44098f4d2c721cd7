"""Resuming a discrete run with other settings: the keys that may change take effect at once
(in config.toml or as ``--set``), the others are refused naming the key; a target that would
flatten the box is refused, a box that gets too thin stops its stage with the diagnosis, and a
blow-up says how to resume."""

from __future__ import annotations

import json
import math

import h5py
import numpy as np
import pytest
import tomli_w

from grainlab.engine.simulation import SimulationBlowUp
from grainlab.errors import InputError
from grainlab.lab.discrete_run import resume_run, start_run
from grainlab.lab.run_config import EARLIER_SOLVER_KEYS, RunConfig
from grainlab.lab.run_outcome import BOX_TOO_THIN
from grainlab.lab.stage_numerics import COMPACTION
from grainlab.lab.wall_stages import QuasiStaticCriteria

TINY = {
    "sample": {"n_particles": 30, "seed": 3},
    "test": {"kind": "compaction"},
    "solver": {"sweep": "serial"},
    "output": {"record_every": 5, "checkpoint_every": 10},
}

SHEARING = {  # the compaction cut after 10 steps, so that a shear is under way at once
    **TINY, "test": {"kind": "triaxial", "eps_q_max": 0.2},
    "solver": {"sweep": "serial", "max_stage_steps": 10, "at_max_stage_steps": "next_stage"},
}


def earlier_layout(config: dict) -> dict:
    """A config (current layout, plain data, fixed steps) as the earlier layout spelt it:
    the per-stage keys flat in [solver], compaction without overlap recovery, no capped-share
    limits, no growth of the step."""
    solver = dict(config["solver"])
    for kind in ("compaction", "shear"):
        table = dict(solver.pop(kind))
        table.pop("capped_share_limit")  # read back as 1: any share, as runs were judged then
        assert table.pop("time_step_growth") == 1.0
        table.pop("overlap_bound")
        if kind == "compaction":
            assert table.pop("overlap_recovery") == 0.0
        for key, value in table.items():
            old = next(o for o, n in EARLIER_SOLVER_KEYS.items() if n == f"{kind}.{key}")
            solver[old] = value
    return {**config, "solver": solver}


@pytest.fixture()
def compacting(tmp_path):
    folder = tmp_path / "run"
    start_run(folder, RunConfig.model_validate(TINY)).run(max_steps=12)  # checkpoint at 10
    return folder


def test_settings_set_on_resume_take_effect_at_once(compacting):
    run = resume_run(compacting, ["solver.compaction.tolerance=1e-6",
                                  "solver.compaction.max_iterations=50"])
    assert run.test.solver.tolerance == 1e-6 and run.test.solver.max_iterations == 50
    assert RunConfig.read(compacting / "config.toml").solver.compaction.tolerance == 1e-6
    assert "changed on resume: solver.compaction.tolerance" in \
        (compacting / "run.log").read_text()


def test_the_other_kind_of_stage_keeps_its_settings_until_it_starts(compacting):
    run = resume_run(compacting, ["solver.shear.tolerance=1e-5"])
    assert run.test.settings.shear.tolerance == 1e-5
    assert run.test.solver.tolerance == COMPACTION.tolerance  # still compacting
    assert RunConfig.read(compacting / "config.toml").solver.shear.tolerance == 1e-5


def test_a_compaction_under_way_takes_new_quasi_static_criteria(compacting):
    run = resume_run(compacting, ["test.quasi_static.kinetic_energy=inf",
                                  "test.quasi_static.unbalanced_force=0.05"])
    assert run.test.settings.quasi_static == QuasiStaticCriteria(
        unbalanced_force=0.05, kinetic_energy=math.inf)
    assert run.test.solver.tolerance == COMPACTION.tolerance
    table = run.run().table
    assert run.test.finished and table["unbalanced_force_ratio"].iloc[-1] <= 0.05
    assert RunConfig.read(compacting / "config.toml").test.quasi_static.kinetic_energy == \
        math.inf


def test_keys_edited_in_config_toml_take_effect_at_once(compacting):
    path = compacting / "config.toml"
    text = path.read_text()
    assert "[solver.compaction]" in text and text.count("max_iterations = 1000") == 1
    path.write_text(text.replace("max_iterations = 1000", "max_iterations = 60"))
    assert resume_run(compacting).test.solver.max_iterations == 60


def test_a_run_of_the_earlier_config_layout_resumes(compacting):
    """config.toml and the checkpoint's config as runs wrote them before [solver.compaction]
    and [solver.shear]: read as the same config, nothing counted as changed."""
    config = RunConfig.read(compacting / "config.toml").with_updates(
        {"solver": {kind: {"time_step_growth": 1.0} for kind in ("compaction", "shear")}}
    ).model_dump()
    earlier = earlier_layout(config)
    assert "shear" not in earlier["solver"] and earlier["solver"]["compaction_tolerance"] == 1e-4
    (compacting / "config.toml").write_text(tomli_w.dumps(earlier))
    with h5py.File(compacting / "checkpoint.h5", "a") as handle:
        handle.attrs["config"] = json.dumps(earlier)
    run = resume_run(compacting, ["solver.shear.tolerance=1e-5"])
    assert run.config == RunConfig.model_validate(config).with_updates(
        {"solver": {"shear": {"tolerance": 1e-5, "capped_share_limit": 1.0},
                    "compaction": {"capped_share_limit": 1.0}}})
    log = (compacting / "run.log").read_text()
    assert "changed on resume: solver.shear.tolerance" in log
    assert log.count("changed on resume") == 1
    assert "[solver.shear]" in (compacting / "config.toml").read_text()  # rewritten, new layout
    step = run.test.simulation.step_index
    run.run(max_steps=2)  # and goes on
    assert run.test.simulation.step_index == step + 2


def test_a_new_inertia_bound_scales_the_loading_speed(compacting):
    before = resume_run(compacting)
    rate, speeds = before.test.strain_rate, before.test.sample.box.max_speeds.copy()
    after = resume_run(compacting, ["solver.compaction.inertia_number=0.02"])
    assert after.test.strain_rate == pytest.approx(2.0 * rate, rel=1e-12)
    np.testing.assert_allclose(after.test.sample.box.max_speeds, 2.0 * speeds, rtol=1e-12)


@pytest.mark.parametrize(("assignment", "key"), [
    ("sample.n_particles=31", "sample.n_particles"),
    ("solver.shear.friction=0.5", "solver.shear.friction"),
    ("solver.compaction.friction=0.1", "solver.compaction.friction"),
    ("solver.friction=0.5", "solver.shear.friction"),  # the earlier name, read as the new
    ("solver.sweep=coloured", "solver.sweep"), ("test.sigma0=2e4", "test.sigma0"),
])
def test_keys_that_made_the_run_are_refused_on_resume(compacting, assignment, key):
    with pytest.raises(InputError) as error:
        resume_run(compacting, [assignment])
    assert error.value.field == key
    assert "cannot change on resume" in str(error.value)
    assert "solver.shear.tolerance" in str(error.value)  # says which keys can


def test_a_target_of_the_stage_under_way_can_change_unless_it_flattens_the_box(tmp_path):
    folder = tmp_path / "run"
    run = start_run(folder, RunConfig.model_validate(SHEARING))
    run.run(max_steps=12)
    assert run.test.stage.name == "shear" and run.test.stage_started
    run.checkpoint()
    assert resume_run(folder, ["test.eps_q_max=0.1"]).test.stages[1].stop[0].limit == 0.1
    resumed = resume_run(folder, ["solver.shear.tolerance=1e-5"])
    assert resumed.test.solver.tolerance == 1e-5  # the shear under way takes it at once
    with pytest.raises(InputError, match="largest diameters") as error:
        resume_run(folder, ["test.eps_q_max=1.5"])
    assert error.value.field == "test.eps_q_max"


def test_a_target_of_the_shear_under_way_in_a_periodic_cell_can_change(tmp_path):
    """The cell's stages are checked as the cell runs them (not as walls would): the shear
    under way takes a new eps_q target."""
    folder = tmp_path / "run"
    config = {**SHEARING, "sample": {"n_particles": 80, "seed": 3, "boundary": "periodic"}}
    run = start_run(folder, RunConfig.model_validate(config))
    run.run(max_steps=12)
    assert run.test.stage.name == "shear" and run.test.stage_started
    run.checkpoint()
    resumed = resume_run(folder, ["test.eps_q_max=0.1"])
    assert resumed.test.stages[1].stop[0].limit == 0.1
    assert resumed.test.stages[1].modes == run.test.stages[1].modes


def test_a_box_too_thin_stops_its_stage_with_the_diagnosis(tmp_path):
    run = start_run(tmp_path / "run", RunConfig.model_validate(SHEARING))
    run.run(max_steps=12)
    test = run.test
    lengths = test.sample.box.lengths
    test.largest_diameter = float(lengths.max())  # 3 d_max > the box: the limit is 80 % of it
    test.boundary.reference_lengths = lengths / 0.75
    done, reason = test.boundary_end()
    assert done and "box too thin" in reason and "largest particle diameters" in reason
    test.close_stage(reason)
    assert test.halted["ended"] == BOX_TOO_THIN
    assert "NOT reached: box too thin" in run.outcome.summary()


def test_a_blow_up_in_a_thin_box_says_so_and_how_to_resume(compacting):
    run = resume_run(compacting)
    run.test.largest_diameter = float(run.test.sample.box.lengths.min()) / 1.4
    said = run._blow_up_diagnosis(SimulationBlowUp("runaway overlap at step 12"))
    assert "1.40 largest particle diameters" in said and "will not help" in said
    assert f"grainlab resume {compacting} --set solver.compaction.time_step_factor=" in said
    assert "last good checkpoint is at step 10" in said
