"""The cost of a run estimated from its settings before it starts."""

from __future__ import annotations

import math

import pytest

from grainlab.errors import InputError
from grainlab.lab import discrete_run
from grainlab.lab.discrete_run import _new_test, build_sample
from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_estimate import loading_strain, loading_time, simulated_time, substep

SOFT = {"sample": {"n_particles": 30}, "test": {"eps_q_max": 0.01},
        "solver": {"method": "dem"}}


def _config(**dem) -> RunConfig:
    return RunConfig.model_validate({**SOFT, "solver": {"method": "dem", "dem": dem}})


def test_the_loading_lasts_its_strain_over_the_inertia_bounds_rate():
    # I = rate <d> sqrt(rho / p): rate = 1e-3 x sqrt(1e4 / 2500) / 2e-3 = 1 /s
    assert loading_time(0.01, 1e-3, 1e4, 2500.0, 2e-3) == pytest.approx(0.01, rel=1e-14)
    assert loading_time(0.01, 2e-3, 4e4, 2500.0, 2e-3) == pytest.approx(0.0025, rel=1e-14)


def test_the_strain_each_test_travels():
    config = RunConfig.model_validate({"test": {"kind": "cyclic_shear", "amplitude": 0.02,
                                                "n_cycles": 3}})
    assert loading_strain(config.test) == pytest.approx(0.24)
    oedometer = RunConfig.model_validate({"test": {"kind": "oedometer", "axial_strain": 0.02,
                                                   "unload_strain": 0.005}})
    assert loading_strain(oedometer.test) == pytest.approx(0.025)
    assert loading_strain(RunConfig.model_validate({"test": {"kind": "compaction"}}).test) == 0.0


def test_the_simulated_time_is_the_compactions_then_the_loadings():
    config = _config()
    compaction = math.log(0.55 / config.sample.packing_fraction) / 3.0
    expected = (loading_time(compaction, 1e-2, 1e4, 2600.0, 1.5e-3)
                + loading_time(0.01, 1e-3, 1e4, 2600.0, 1.5e-3))
    assert simulated_time(config, 1.5e-3, 2600.0) == pytest.approx(expected, rel=1e-14)


def test_the_sub_step_of_linear_springs_shortens_as_one_over_the_root_of_kappa():
    steps = [substep(discrete_run.test_for(build_sample(_config(kappa=k)), _config(kappa=k)))
             for k in (1e4, 1e6)]
    assert steps[0] / steps[1] == pytest.approx(10.0, rel=1e-12)


def test_stiff_grains_are_refused_naming_their_stiffness_soft_ones_start():
    with pytest.raises(InputError) as caught:
        _new_test(_config(kappa=1e12))
    assert caught.value.field == "solver.dem.kappa" and "sub-steps" in caught.value.allowed
    with pytest.raises(InputError) as caught:
        _new_test(_config(law="hertz_mindlin", young_modulus=1e16))
    assert caught.value.field == "solver.dem.young_modulus"
    assert _new_test(_config(kappa=1e8)).sample.state.n_bodies == 30
