"""config.toml: one table per kind of stage under [solver], the defaults of
:mod:`grainlab.lab.stage_numerics`, errors naming the key as written, the earlier flat layout
read as the same config, ``--set`` on sub-tables."""

from __future__ import annotations

import math

import pytest

from grainlab.errors import InputError
from grainlab.lab.run_config import (
    CHANGEABLE_ON_RESUME,
    EARLIER_SOLVER_KEYS,
    RunConfig,
    parse_assignments,
)
from grainlab.lab.stage_numerics import COMPACTION, SHEAR, STAGE_KINDS, StageNumerics
from grainlab.lab.wall_stages import QuasiStaticCriteria

EARLIER_CONFIG = """
[sample]
n_particles = 40
seed = 4

[test]
kind = "triaxial"
eps_q_max = 0.02

[solver]
friction = 0.3
compaction_friction = 0.0
inertia_number = 0.001
compaction_inertia_number = 0.05
dt = 0.0
time_step_factor = 0.003
compaction_time_step_factor = 0.01
theta = 0.5
tolerance = 0.0001666
max_iterations = 400
sweep = "serial"
max_stage_steps = 200000
at_max_stage_steps = "stop"
wall_mass_factor = 1.0
wall_servo = true
seed = 0
overlap_recovery = 0.02
compaction_max_iterations = 300
compaction_tolerance = 0.0001
"""
"""A config.toml as runs wrote it before [solver.compaction] and [solver.shear] (every key
of that layout)."""


def test_the_config_defaults_are_the_stage_numerics_defaults():
    config = RunConfig()
    assert config.solver.compaction.numerics() == COMPACTION
    assert config.solver.shear.numerics() == SHEAR
    settings = config.settings()
    assert settings.compaction == COMPACTION and settings.shear == SHEAR
    assert set(type(config.solver.shear).model_fields) == \
        set(StageNumerics.__dataclass_fields__)


def test_a_config_of_the_earlier_layout_is_read_as_the_same_config(tmp_path):
    """A run saved it (before the step grew: fixed steps); as a user's input file it takes
    today's defaults for the keys it lacks."""
    path = tmp_path / "config.toml"
    path.write_text(EARLIER_CONFIG)
    as_input = RunConfig.read(path)
    assert as_input.solver.shear.time_step_growth == SHEAR.time_step_growth > 1.0
    config = RunConfig.read(path, saved=True)
    assert config.solver.shear.numerics() == StageNumerics(
        friction=0.3, inertia_number=1e-3, time_step_factor=0.003, tolerance=1.666e-4,
        max_iterations=400, overlap_recovery=0.02, time_step_growth=1.0)
    assert config.solver.compaction.numerics() == StageNumerics(
        friction=0.0, inertia_number=0.05, time_step_factor=0.01, tolerance=1e-4,
        max_iterations=300, overlap_recovery=0.0, time_step_growth=1.0)
    assert config.solver.sweep == "serial"
    assert all(f"\n{old} = " in EARLIER_CONFIG for old in EARLIER_SOLVER_KEYS)
    again = RunConfig.read(config.write(tmp_path / "again.toml"))
    assert again == config
    text = (tmp_path / "again.toml").read_text()
    assert "[solver.compaction]" in text and "compaction_friction" not in text


@pytest.mark.parametrize("data, key, also", [
    ({"solver": {"friction": 0.3, "shear": {"friction": 0.4}}}, "solver.friction",
     "solver.shear.friction"),
    ({"solver": {"compaction_tolerance": 1e-5, "compaction": {"tolerance": 1e-4}}},
     "solver.compaction_tolerance", "solver.compaction.tolerance"),
])
def test_a_key_given_in_both_layouts_is_refused_naming_it(data, key, also):
    with pytest.raises(InputError) as error:
        RunConfig.model_validate(data)
    assert error.value.field == key
    assert also in error.value.allowed


def test_both_layouts_may_mix_for_different_keys():
    config = RunConfig.model_validate({"solver": {"friction": 0.3,
                                                  "shear": {"tolerance": 1e-5}}})
    assert config.solver.shear.friction == 0.3 and config.solver.shear.tolerance == 1e-5


@pytest.mark.parametrize("data, key, allowed", [
    ({"solver": {"compaction": {"inertia_number": 0.0}}}, "solver.compaction.inertia_number",
     "(0, 1]"),
    ({"solver": {"shear": {"tolerance": 1.0}}}, "solver.shear.tolerance", "(0, 1)"),
    ({"solver": {"shear": {"max_iterations": 0}}}, "solver.shear.max_iterations", ">= 1"),
    ({"solver": {"shear": {"frictio": 0.3}}}, "solver.shear.frictio", "no such key"),
    ({"solver": {"compaction_friction": -1.0}}, "solver.compaction_friction",
     "read as solver.compaction.friction"),
])
def test_bad_values_name_the_key_as_written(data, key, allowed):
    with pytest.raises(InputError) as error:
        RunConfig.model_validate(data)
    assert error.value.field == key
    assert allowed in error.value.allowed


def test_assignments_reach_the_sub_tables():
    updates = parse_assignments(["solver.shear.tolerance=1e-5",
                                 "solver.compaction.max_iterations=50", "solver.dt=1e-6"])
    assert updates == {"solver": {"shear": {"tolerance": 1e-5},
                                  "compaction": {"max_iterations": 50}, "dt": 1e-6}}
    config = RunConfig().with_updates(updates)
    assert config.solver.shear.tolerance == 1e-5 and config.solver.shear.friction == 0.4
    assert config.solver.compaction.max_iterations == 50
    earlier = RunConfig().with_updates(parse_assignments(["solver.compaction_tolerance=1e-6"]))
    assert earlier.solver.compaction.tolerance == 1e-6
    with pytest.raises(InputError) as error:
        RunConfig().with_updates(parse_assignments(["solver.tolerance=2"]))
    assert error.value.field == "solver.tolerance"
    with pytest.raises(InputError, match="--set"):
        parse_assignments(["solver.shear.=1"])


def test_every_per_stage_key_but_friction_can_change_on_resume():
    started = RunConfig()
    for kind in STAGE_KINDS:
        assert f"solver.{kind}.friction" not in CHANGEABLE_ON_RESUME
        changed = RunConfig().with_updates({"solver": {kind: {"tolerance": 1e-6}}})
        assert changed.changes_on_resume(started) == {
            f"solver.{kind}.tolerance": (getattr(started.solver, kind).tolerance, 1e-6)}
    with pytest.raises(InputError) as error:
        RunConfig().with_updates({"solver": {"compaction": {"friction": 0.1}}}
                                 ).changes_on_resume(started)
    assert error.value.field == "solver.compaction.friction"


def test_the_quasi_static_criteria_are_a_table_of_the_test(tmp_path):
    assert RunConfig().settings().quasi_static == QuasiStaticCriteria()
    config = RunConfig.model_validate({"test": {"quasi_static": {
        "kinetic_energy": math.inf, "unbalanced_force": 0.02, "stress_tolerance": 0.005}}})
    again = RunConfig.read(config.write(tmp_path / "config.toml"))
    assert "[test.quasi_static]" in (tmp_path / "config.toml").read_text()
    assert again.settings().quasi_static == QuasiStaticCriteria(
        stress_tolerance=0.005, unbalanced_force=0.02, kinetic_energy=math.inf)
    assert again.changes_on_resume(RunConfig()) == {
        "test.quasi_static.stress_tolerance": (0.01, 0.005),
        "test.quasi_static.unbalanced_force": (0.01, 0.02),
        "test.quasi_static.kinetic_energy": (1e-6, math.inf)}


@pytest.mark.parametrize("key, value, allowed", [
    ("unbalanced_force", 0.0, "> 0"), ("kinetic_energy", -1e-6, "> 0"),
    ("kinetic_energy", math.nan, "> 0"), ("stress_tolerance", 1.0, "(0, 1)"),
])
def test_bad_quasi_static_criteria_name_the_key(key, value, allowed):
    with pytest.raises(InputError) as error:
        RunConfig.model_validate({"test": {"quasi_static": {key: value}}})
    assert error.value.field == f"test.quasi_static.{key}"
    assert allowed in error.value.allowed
    with pytest.raises(InputError) as error:
        QuasiStaticCriteria(**{key: value})
    assert error.value.field == key
    with pytest.raises(InputError, match="inf"):
        RunConfig.model_validate({"test": {"quasi_static": {"unbalanced_force": "none"}}})
