"""The config's stage tables are made from :class:`~grainlab.lab.stage_numerics.StageNumerics`
(a key per field, in its order, its defaults those of the kind of stage), and
:meth:`~grainlab.lab.run_config.RunConfig.settings` reads every field of
:class:`~grainlab.lab.discrete_test.DiscreteTestSettings` from the key of its name."""

from __future__ import annotations

from dataclasses import fields

import pytest

from grainlab.errors import InputError
from grainlab.lab.discrete_test import DiscreteTestSettings
from grainlab.lab.run_config import (
    SETTINGS_TABLES,
    STAGE_KEY_TYPES,
    CompactionConfig,
    RunConfig,
    ShearConfig,
    SolverConfig,
    unit_of,
)
from grainlab.lab.setting_bounds import setting_fields
from grainlab.lab.soft_contact_settings import SoftContactSettings
from grainlab.lab.solver_registry import own_settings_records
from grainlab.lab.stage_numerics import COMPACTION, SHEAR, StageNumerics
from grainlab.lab.wall_stages import QuasiStaticCriteria


@pytest.mark.parametrize(("table", "defaults"), [(CompactionConfig, COMPACTION),
                                                 (ShearConfig, SHEAR)])
def test_a_stage_table_has_a_key_per_field_of_the_stage_numerics(table, defaults):
    names = [field.name for field in fields(StageNumerics)]
    assert list(table.model_fields) == names  # the order the TOML is written in
    assert set(STAGE_KEY_TYPES) == set(names)
    assert table().numerics() == defaults
    assert {key: info.default for key, info in table.model_fields.items()} \
        == defaults.to_dict()


@pytest.mark.parametrize(("key", "value", "allowed"), [
    ("friction", -0.1, ">= 0"), ("inertia_number", 2.0, "in (0, 1]"),
    ("tolerance", 1.0, "in (0, 1)"), ("max_iterations", 1.5, "an integer"),
    ("overlap_bound", 0.1, "in (0, 0.1)"),
])
def test_a_stage_tables_bounds_name_the_key(key, value, allowed):
    with pytest.raises(InputError) as caught:
        RunConfig.model_validate({"solver": {"shear": {key: value}}})
    assert caught.value.field == f"solver.shear.{key}"
    assert allowed in caught.value.allowed


@pytest.mark.parametrize("record", own_settings_records(), ids=lambda r: r.name)
def test_a_solvers_table_has_a_key_per_field_of_its_settings(record):
    """``[solver.<settings_key>]`` is made from the solver's settings dataclass: its keys,
    defaults and units are the fields', and a value outside a field's bounds is refused
    naming the key."""
    table = SolverConfig.model_fields[record.settings_key].annotation
    declared = setting_fields(record.settings_type)
    assert list(table.model_fields) == [s.name for s in declared]
    assert table().frozen() == record.settings_type()
    for setting in declared:
        key = f"solver.{record.settings_key}.{setting.name}"
        assert unit_of(key) == setting.bounds.unit
        for bound, value in setting.bounds.limits().items():
            refused = value if bound in ("gt", "lt") else value - 1.0 if bound == "ge" \
                else value + 1.0
            with pytest.raises(InputError) as caught:
                RunConfig.model_validate({"solver": {record.settings_key: {
                    setting.name: float(refused)}}})
            assert caught.value.field == key


def test_settings_read_every_field_from_the_config():
    assert set(SETTINGS_TABLES) == {field.name for field in fields(DiscreteTestSettings)}
    assert SETTINGS_TABLES["seed"] == "solver"  # the solver's visiting order, not the sample


def test_settings_follow_each_key_changed():
    changed = RunConfig.model_validate({
        "sample": {"seed": 11},
        "test": {"quasi_static": {"stress_tolerance": 0.02}},
        "solver": {"method": "dem", "dt": 2e-6, "theta": 0.75, "sweep": "serial",
                   "correction": "none",
                   "warm_start_extrapolation": 0.25, "max_stage_steps": 77,
                   "at_max_stage_steps": "next_stage", "wall_mass_factor": 3.0,
                   "wall_servo": False, "seed": 5,
                   "compaction": {"friction": 0.1, "tolerance": 1e-5},
                   "shear": {"max_iterations": 9}, "dem": {"kappa": 2e3}},
        "output": {"record_every": 4, "snapshot_every": 8, "snapshot_eps_q": [0.01]}})
    settings, default = changed.settings(), RunConfig().settings()
    for field in fields(DiscreteTestSettings):
        assert getattr(settings, field.name) != getattr(default, field.name), field.name
    assert settings.seed == 5 and settings.dt == 2e-6
    assert settings.compaction == StageNumerics(**{**COMPACTION.to_dict(), "friction": 0.1,
                                                   "tolerance": 1e-5})
    assert settings.shear.max_iterations == 9 and settings.shear.friction == SHEAR.friction
    assert settings.dem == SoftContactSettings(kappa=2e3)
    assert settings.quasi_static == QuasiStaticCriteria(stress_tolerance=0.02)
    assert RunConfig().settings().dt is None  # dt = 0: from the stage's time step factor


def test_a_config_written_is_read_back_the_same(tmp_path):
    config = RunConfig.model_validate({"solver": {"shear": {"tolerance": 2e-4},
                                                  "compaction": {"time_step_growth": 1.5}}})
    again = RunConfig.read(config.write(tmp_path / "config.toml"), saved=True)
    assert again == config
    assert again.settings() == config.settings()
