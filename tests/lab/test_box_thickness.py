"""Targets that would flatten a box below a few particles are found before the run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainlab.lab.box_thickness import box_limits, predicted_end, predicted_flattening
from grainlab.lab.presets import isotropic_compression, oedometer
from grainlab.lab.run_config import RunConfig
from grainlab.lab.wall_stages import wall_stages

D_MAX = 2e-3
BOX = np.array([20e-3, 20e-3, 20e-3])  # consolidated already: 10 d_max


def _triaxial(eps_q: float):
    config = RunConfig.model_validate({"test": {"kind": "triaxial", "eps_q_max": eps_q}})
    return wall_stages(config.load_path())[1:]  # the shear alone


def test_a_triaxial_target_is_refused_past_constant_volume_at_three_diameters():
    # 20 mm down to 3 d_max = 6 mm: eps_1 = ln(20/6), eps_q = 1.5 eps_1 = 1.806
    largest = 1.5 * math.log(20.0 / 6.0)
    assert not predicted_flattening(_triaxial(largest - 1e-6), BOX, BOX, 1.0, D_MAX, 1000)
    flat, = predicted_flattening(_triaxial(largest + 1e-3), BOX, BOX, 1.0, D_MAX, 1000)
    assert flat.quantity == "eps_q" and flat.axis == 2
    assert flat.largest == pytest.approx(largest)
    assert flat.limit == pytest.approx(3 * D_MAX) and flat.end < flat.limit
    assert flat.particles_needed() > 1000


def test_a_thin_box_may_lose_a_fifth_of_its_height():
    thin = np.array([4e-3, 4e-3, 4e-3])  # 2 d_max: 30 spheres' box
    np.testing.assert_allclose(box_limits(D_MAX, thin), 0.8 * thin)
    stages = wall_stages(oedometer(strain_final=0.25, n_steps=1))
    flat, = predicted_flattening(stages, thin, thin, 1.0, D_MAX, 30)
    assert flat.quantity == "eps_zz" and flat.largest == pytest.approx(math.log(1 / 0.8))
    assert not predicted_flattening(wall_stages(oedometer(strain_final=0.2, n_steps=1)),
                                    thin, thin, 1.0, D_MAX, 30)


def test_a_compaction_first_is_assumed_to_end_at_half_packing():
    loose = np.array([30e-3, 30e-3, 30e-3])
    solid = 0.25 * float(np.prod(loose))  # packing fraction 0.25 -> 0.5: edges / 2^(1/3)
    stages = wall_stages(isotropic_compression(p_final=1e4, n_steps=1)) + _triaxial(2.0)
    flat, = predicted_flattening(stages, loose, loose, solid, 1.5 * D_MAX, 1000)
    assert flat.start == pytest.approx(30e-3 / 2 ** (1 / 3))
    end = predicted_end(_triaxial(2.0)[0], BOX, BOX)
    assert end[2] == pytest.approx(20e-3 * math.exp(-4.0 / 3.0)) and end[0] == BOX[0]
