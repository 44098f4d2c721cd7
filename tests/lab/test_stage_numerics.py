"""The numerics of a kind of stage: defaults as the lab tests have always run them, validated
fields named, one rule for which kind a stage is."""

from __future__ import annotations

from dataclasses import replace

import pytest

from grainlab.errors import InputError
from grainlab.lab.discrete_test import DiscreteTestSettings
from grainlab.lab.stage_numerics import COMPACTION, SHEAR, StageNumerics, stage_kind
from grainlab.lab.wall_stages import wall_stages


def test_the_defaults_are_the_documented_values():
    # docs/explanations/walls-and-box-tests.md, "Solver settings of the lab tests"
    assert COMPACTION == StageNumerics(friction=0.0, inertia_number=1e-2,
                                       time_step_factor=0.01, tolerance=1e-4,
                                       max_iterations=1000, overlap_recovery=0.0,
                                       time_step_growth=2.0, overlap_bound=5e-3)
    assert SHEAR == StageNumerics(friction=0.4, inertia_number=1e-3, time_step_factor=0.003,
                                  tolerance=1.666e-4, max_iterations=2000,
                                  overlap_recovery=0.5, time_step_growth=2.0,
                                  overlap_bound=5e-3, capped_share_limit=0.5)
    settings = DiscreteTestSettings()
    assert settings.compaction is COMPACTION and settings.shear is SHEAR


@pytest.mark.parametrize("field, value", [
    ("friction", -0.1), ("inertia_number", 0.0), ("inertia_number", 1.5),
    ("time_step_factor", 0.6), ("tolerance", 1.0), ("tolerance", float("nan")),
    ("max_iterations", 0), ("max_iterations", 2.5), ("max_iterations", True),
    ("overlap_recovery", 1.1), ("time_step_growth", 0.9), ("time_step_growth", 200.0),
    ("time_step_growth", float("inf")), ("overlap_bound", 0.0), ("overlap_bound", 0.1),
])
def test_bad_values_are_refused_naming_the_field(field, value):
    with pytest.raises(InputError) as error:
        replace(SHEAR, **{field: value})
    assert error.value.field == field


def test_the_bounds_are_inclusive_where_the_config_says_so():
    edge = StageNumerics(friction=0.0, inertia_number=1.0, time_step_factor=0.5,
                         tolerance=0.999, max_iterations=1, overlap_recovery=1.0)
    assert edge.inertia_number == 1.0 and edge.overlap_recovery == 1.0


def test_a_stage_with_a_strain_controlled_axis_runs_with_the_shear_numerics():
    from grainlab.lab.run_config import RunConfig

    stages = wall_stages(RunConfig.model_validate(
        {"test": {"kind": "oedometer", "unload_strain": 0.01}}).load_path())
    assert [s.name for s in stages] == ["compaction", "loading", "unloading"]
    kinds = [stage_kind(bool(s.moving_axes)) for s in stages]
    assert kinds == ["compaction", "shear", "shear"]
    settings = DiscreteTestSettings(compaction=replace(COMPACTION, tolerance=1e-6))
    assert settings.numerics_for(False).tolerance == 1e-6
    assert settings.numerics_for(True) is SHEAR


def test_settings_plain_data_hold_each_kind_as_a_table():
    data = DiscreteTestSettings().to_dict()
    assert data["compaction"] == COMPACTION.to_dict()
    assert data["shear"]["friction"] == 0.4
    assert not {"friction", "compaction_friction", "tolerance"} & set(data)
    with pytest.raises(InputError, match="shear"):
        DiscreteTestSettings(shear={"friction": 0.4})
