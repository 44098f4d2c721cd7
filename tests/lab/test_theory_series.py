"""Seed 001 chapter 3 as a series (``grainlab theory-series``): the plan builds the report's
specimen (12 discs of radius 0.21 mm, 13 of 0.105 mm, k_n = 200 kN/m, sigma0 = 203 kPa) and
the report's cases; the report's q/p is (sigma_v - sigma_h)/(sigma_v + sigma_h); on one
packing loaded at two friction angles, more friction leaves less lateral stress (K0 falls)
for the run and for the model, which starts from the run's stress; bad input is refused
naming the option."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.errors import InputError
from grainlab.lab.theory_comparison import INITIAL, SIMULATION
from grainlab.lab.theory_series import (
    NORMAL_STIFFNESS,
    SeriesCase,
    SeriesPlan,
    run_series,
    side_measures,
)
from grainlab.prep.loose_sample import binary_diameters

runner = CliRunner()


def test_the_default_plan_is_the_reports_chapter_3():
    plan = SeriesPlan()
    oedometer = [c for c in plan.cases if c.test == "oedometer"]
    biaxial = [c for c in plan.cases if c.test == "biaxial"]
    assert sorted({c.phi_mu for c in oedometer}) == [14.0, 17.0, 20.0, 25.0]
    assert {c.stiffness_ratio for c in oedometer} == {1.0}
    assert sorted({c.stiffness_ratio for c in biaxial}) == [0.3, 1.0]
    assert {c.phi_mu for c in biaxial} == {25.0}
    assert {c.sigma0 for c in plan.cases} == {203e3}
    assert len(oedometer) == 4 * 3 and len(biaxial) == 2 * 3
    assert len({c.folder_name for c in plan.cases}) == len(plan.cases)


def test_the_specimen_is_the_reports_25_discs():
    plan = SeriesPlan()
    config = plan.config(SeriesCase("oedometer", 1, 25.0, 1.0, 203e3))
    assert config.sample.shape == "disc" and config.sample.boundary == "periodic"
    assert config.test.kind == "oedometer" and config.test.sigma0 == 203e3
    assert config.solver.dem.normal_stiffness == NORMAL_STIFFNESS == 2e5
    assert math.isclose(config.solver.shear.friction, math.tan(math.radians(25.0)))
    s = config.sample
    radii = np.sort(binary_diameters(s.n_particles, s.d_min, s.d_min * s.size_ratio,
                                     s.fine_fraction, np.random.default_rng(0))) / 2.0
    np.testing.assert_allclose(radii[:13], 0.105e-3)
    np.testing.assert_allclose(radii[13:], 0.21e-3)
    biaxial = plan.config(SeriesCase("biaxial", 1, 25.0, 0.3, 203e3))
    assert biaxial.test.kind == "triaxial" and biaxial.solver.dem.stiffness_ratio == 0.3


def test_the_reports_stress_ratio_is_the_half_difference_over_the_half_sum():
    sigma_v = np.array([100.0, 150.0, 250.0, 220.0])
    sigma_h = np.array([100.0, 100.0, 100.0, 100.0])
    p = 0.5 * (sigma_v + sigma_h)
    curve = pd.DataFrame({"side": SIMULATION, "stage": [INITIAL, "shear", "shear", "shear"],
                          "eps_axial": [0.0, 0.01, 0.02, 0.03],
                          "eps_q": 0.0, "q_over_p": (sigma_v - sigma_h) / p,
                          "eps_vol": [0.0, 0.001, -0.002, -0.004], "K0": sigma_h / sigma_v,
                          "sigma_v": sigma_v, "p": p})
    measures = side_measures(curve)
    assert measures["ratio_peak"] == pytest.approx(150.0 / 350.0)
    assert measures["ratio_end"] == pytest.approx(120.0 / 320.0)
    assert measures["K0_min"] == pytest.approx(0.4) and measures["K0_end"] == \
        pytest.approx(100.0 / 220.0)
    assert measures["eps_vol_end"] == -0.004 and measures["eps_v_end"] == 0.03


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"tests": ("triaxial",)}, "--test"),
    ({"seeds": (-1,)}, "--seed"),
    ({"k0_angles": (95.0,)}, "--phi-mu"),
    ({"biaxial_angle": 0.0}, "--biaxial-phi-mu"),
    ({"stiffness_ratios": (0.0,)}, "--stiffness-ratio"),
    ({"sigma0s": (-1e5,)}, "--sigma0"),
    ({"n_particles": 2}, "--particles"),
    ({"distributions": ("voigt",)}, "--distribution"),
])
def test_bad_input_names_the_option(kwargs, field):
    with pytest.raises(InputError) as raised:
        SeriesPlan(**kwargs)
    assert field in raised.value.field


@pytest.mark.long
def test_more_friction_leaves_less_lateral_stress_run_and_model(tmp_path):
    plan = SeriesPlan(tests=("oedometer",), seeds=(1,), k0_angles=(14.0, 25.0),
                      distributions=("homogeneous",), axial_strain=0.003, model_steps=40)
    outcome = run_series(plan, tmp_path)
    table = outcome.table.set_index(["phi_mu", "side"])
    assert len(table) == 4 and table["run_as_asked"].all()
    for side in (SIMULATION, "homogeneous"):
        low, high = table.loc[(14.0, side)], table.loc[(25.0, side)]
        # one-dimensional compression from the isotropic state: K0 falls below 1 ...
        assert 0.0 < high["K0_end"] < low["K0_end"] < 1.0
    curves = outcome.curves
    for angle in (14.0, 25.0):
        # ... and the model starts from the run's own stress (its snapshot's forces)
        starts = curves[(curves["phi_mu"] == angle) & (curves["stage"] == INITIAL)]
        assert starts["p"].iloc[1] == pytest.approx(starts["p"].iloc[0], rel=1e-6)
    # a second call reuses the runs that ended: the same numbers
    again = run_series(plan, tmp_path)
    pd.testing.assert_frame_equal(again.table, outcome.table)


@pytest.mark.long
def test_the_command_writes_its_table_and_figures(tmp_path):
    out = tmp_path / "ch3"
    result = runner.invoke(app, ["theory-series", "-o", str(out), "--test", "biaxial",
                                 "--seed", "2", "--stiffness-ratio", "1", "--eps-q", "0.01",
                                 "--distribution", "homogeneous", "--model-steps", "30"])
    assert result.exit_code == 0, result.output
    for name in ("series.csv", "series-summary.csv", "series-curves.csv", "biaxial-ks1.png",
                 "packing.png"):
        assert (out / name).stat().st_size > 0
    table = pd.read_csv(out / "series.csv")
    assert set(table["side"]) == {SIMULATION, "homogeneous"}
    # the report's q/p is a sine: between 0 and 1
    assert ((table["ratio_peak"] > 0.0) & (table["ratio_peak"] < 1.0)).all()
    bad = runner.invoke(app, ["theory-series", "-o", str(out), "--test", "shear"])
    assert bad.exit_code == 2 and "--test" in bad.output
