"""Derived outputs of element tests (seed 001 §4.1.3 and §4.2): K0 and OCR, friction angles,
octahedral coordinates, principal-direction angles and kappa in simple shear, cyclic modulus
and damping."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from elastic_specimens import LAMBDA, NU, E, ElasticSpecimen, G  # noqa: F401

from grainlab.errors import InputError
from grainlab.lab import derived, presets
from grainlab.lab.element_test import run_element_test

K0_ELASTIC = NU / (1 - NU)


# -- K0 -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("dimension", [2, 3])
def test_k0_of_the_elastic_oedometer(dimension):
    path = presets.oedometer(strain_final=0.01, n_steps=5, unload_to_stress=2e5,
                        dimension=dimension)
    result = run_element_test(ElasticSpecimen(dimension), path)
    series = derived.k0_series(result)
    loading = result.table["stage"] == "loading"
    unloading = result.table["stage"] == "unloading"
    assert np.allclose(series["K0"][loading | unloading], K0_ELASTIC, rtol=1e-10)
    assert np.allclose(series["OCR"][loading], 1.0)
    sigma_v_max = series["sigma_v"][loading].max()
    assert np.allclose(series["OCR"][unloading], sigma_v_max / series["sigma_v"][unloading])
    assert math.isclose(series["OCR"].iloc[-1], sigma_v_max / 2e5, rel_tol=1e-10)
    assert np.isnan(series["K0"].iloc[0])  # no vertical stress at the start


def test_k0_rises_with_ocr_from_an_isotropic_start():
    """From sigma_0 isotropic, sigma_h = sigma_0 + K0e (sigma_v - sigma_0): K0 falls towards
    K0e on loading and rises again on unloading (elastic analogue of seed 001 Fig. 4.6)."""
    p0 = 1e5
    result = run_element_test(ElasticSpecimen(3, [p0] * 3 + [0.0] * 3),
                              presets.oedometer(strain_final=0.01, n_steps=5, unload_to_stress=2e5))
    series = derived.k0_series(result)
    expected = (p0 + K0_ELASTIC * (series["sigma_v"] - p0)) / series["sigma_v"]
    assert np.allclose(series["K0"], expected, rtol=1e-10)
    unloading = series[result.table["stage"] == "unloading"]
    assert np.all(np.diff(unloading["K0"]) > 0) and np.all(np.diff(unloading["OCR"]) > 0)


# -- strength and the octahedral plane ---------------------------------------------------------
def test_friction_angle_and_peak():
    assert math.isclose(float(derived.mobilised_friction_angle(3.0, 1.0)), math.pi / 6)
    table = pd.DataFrame({"sigma_1": [1.0, 2.0, 3.0, 2.5, 0.0],
                          "sigma_3": [1.0, 1.0, 1.0, 1.0, 0.0]})
    phi, row = derived.peak_friction_angle(table)
    assert row == 2 and math.isclose(phi, math.pi / 6)
    assert np.isnan(derived.mobilised_friction_angle(table["sigma_1"], table["sigma_3"])[-1])
    # a row left off its stress targets (the failing step) is not a reached state
    table["converged"] = [True, True, False, True, True]
    phi, row = derived.peak_friction_angle(table)
    assert row == 3 and math.isclose(phi, math.asin(1.5 / 3.5))


def test_lode_angle_matches_b():
    b = np.linspace(0.0, 1.0, 11)
    s1, s3 = 3.0, 1.0
    s2 = s3 + b * (s1 - s3)
    theta = derived.lode_angle(s1, s2, s3)
    assert np.allclose(np.tan(theta), np.sqrt(3) * b / (2 - b))


def test_octahedral_coordinates_of_the_circular_path():
    p, q = 1e5, 4e4
    result = run_element_test(ElasticSpecimen(3),
                              presets.circular_octahedral(p=p, radius_q=q, n_steps=12, alpha0=0.1))
    circle = result.table[result.table["stage"] == "circle"]
    c = derived.octahedral_coordinates(circle["sigma_xx"], circle["sigma_yy"],
                                       circle["sigma_zz"])
    assert np.allclose(c["sigma_oct"], p) and np.allclose(c["q_equivalent"], q)
    assert np.allclose(np.hypot(c["oct_x"], c["oct_y"]), np.sqrt(2 / 3) * q)
    assert np.allclose(c["tau_oct"], np.sqrt(2) * q / 3)
    expected = 0.1 + 2 * np.pi * np.arange(1, 13) / 12
    assert np.allclose(np.angle(np.exp(1j * (c["alpha"].to_numpy() - expected))), 0.0)
    assert ((c["lode_angle"] >= -1e-12) & (c["lode_angle"] <= np.pi / 3 + 1e-12)).all()


def test_failure_point_on_the_octahedral_plane():
    table = pd.DataFrame({"sigma_xx": [1.0, 1.5, 1.4], "sigma_yy": [1.0, 1.0, 1.0],
                          "sigma_zz": [1.0, 2.5, 2.0]})
    table["sigma_1"], table["sigma_2"], table["sigma_3"] = (
        table["sigma_zz"], table["sigma_xx"], table["sigma_yy"])
    point = derived.failure_point(table)
    assert point["row"] == 1 and math.isclose(point["b"], 1.0 / 3.0)
    assert math.isclose(math.tan(point["lode_angle"]), math.sqrt(3) * (1 / 3) / (2 - 1 / 3))
    p = 5.0 / 3.0
    assert math.isclose(point["oct_x / p"], 0.5 / math.sqrt(2) / p)
    assert math.isclose(point["oct_y / p"], 2.5 / math.sqrt(6) / p)
    with pytest.raises(InputError):
        derived.failure_point(table.drop(columns="sigma_zz"))


# -- simple shear -------------------------------------------------------------------------------
def synthetic_simple_shear(kappa: float, psi: np.ndarray, sigma_v: float = 1e5) -> pd.DataFrame:
    """In-plane stresses obeying tau/sigma_v = kappa tan(psi) with tan(2 psi) = 2 tau /
    (sigma_v - sigma_h)."""
    tau = kappa * sigma_v * np.tan(psi)
    sigma_h = sigma_v - 2 * tau / np.tan(2 * psi)
    n = psi.size
    return pd.DataFrame({
        "sigma_xx": sigma_h, "sigma_yy": sigma_h, "sigma_zz": np.full(n, sigma_v),
        "sigma_xz": tau, "eps_xx": np.zeros(n), "eps_zz": np.zeros(n),
        "gamma_xz": np.linspace(0.0, 0.01, n),
    })


def test_kappa_is_recovered_from_synthetic_data():
    psi = np.radians(np.linspace(5.0, 40.0, 15))
    table = synthetic_simple_shear(0.64, psi)
    angles = derived.principal_angles(table)
    assert np.allclose(angles["psi"], psi)
    assert math.isclose(derived.fit_kappa(angles["tau_over_sigma_v"], angles["psi"]), 0.64,
                        rel_tol=1e-12)
    noisy = angles["tau_over_sigma_v"] * (1 + 0.01 * np.cos(np.arange(15)))
    assert abs(derived.fit_kappa(noisy, angles["psi"]) - 0.64) < 0.01
    with pytest.raises(InputError):
        derived.fit_kappa([0.0, 0.0], [0.0, np.nan])


def test_principal_angles_definitions():
    # sigma_v = sigma_h, tau > 0: psi = 45 deg, sin(phi_m) = tau / sigma_v = 1/2
    table = pd.DataFrame({"sigma_xx": [1e5], "sigma_zz": [1e5], "sigma_xz": [5e4],
                          "sigma_yy": [1e5], "eps_xx": [0.0], "eps_zz": [0.0],
                          "gamma_xz": [0.0]})
    angles = derived.principal_angles(table).iloc[0]
    assert math.isclose(angles["psi"], math.pi / 4)
    assert abs(angles["beta"]) < 1e-15
    assert math.isclose(angles["phi_m"], math.asin(0.5))
    assert math.isclose(angles["omega"], math.asin(0.5) / 2)
    # brute force: the planes of maximum stress ratio lie at psi -+ (pi/4 + phi_m/2) from the
    # horizontal (normal n = (sin a, cos a) in (x, z), a in the sense of psi); omega is the
    # one that turns towards the horizontal: a = -omega
    s = np.array([[1e5, 5e4], [5e4, 1e5]])
    a = np.linspace(-np.pi / 2, np.pi / 2, 200001)
    n = np.stack([np.sin(a), np.cos(a)])
    traction = s @ n
    normal = np.sum(traction * n, axis=0)
    shear = np.abs(traction[0] * n[1] - traction[1] * n[0])
    ratio = shear / normal
    assert math.isclose(ratio.max(), math.tan(math.asin(0.5)), rel_tol=1e-9)
    best = a[ratio > ratio.max() * (1 - 1e-9)]
    assert np.min(np.abs(best + angles["omega"])) < 1e-4
    assert np.min(np.abs(best - (angles["psi"] + math.pi / 4 + angles["phi_m"] / 2 - math.pi))
                  ) < 1e-4


@pytest.mark.parametrize("dimension", [2, 3])
def test_elastic_simple_shear_increments_are_coaxial(dimension):
    """Isotropic elasticity: stress and strain increments share principal axes (chi = xi,
    seed 001 §4.2.4 b), the shear increments give 45 degrees."""
    path = presets.simple_shear(gamma_final=0.002, n_steps=5, vertical_stress=1e5,
                           k0_consolidation_steps=3, dimension=dimension)
    result = run_element_test(ElasticSpecimen(dimension), path)
    angles = derived.principal_angles(result)
    shear = result.table["stage"] == "shear"
    assert np.allclose(angles["chi"][shear], angles["xi"][shear])
    assert np.allclose(angles["xi"][shear], np.pi / 4)
    assert np.isnan(angles["chi"].iloc[0])
    c, v = ("xz", "zz") if dimension == 3 else ("xy", "yy")
    t = result.table
    assert np.allclose(np.tan(2 * angles["psi"][shear]),
                       2 * t[f"sigma_{c}"][shear] / (t[f"sigma_{v}"] - t["sigma_xx"])[shear])
    assert np.allclose(angles["psi"][~shear & (t["stage"] != "initial")], 0.0)


# -- cyclic shear -------------------------------------------------------------------------------
def test_damping_of_an_elliptic_loop():
    gamma_a, tau_a, delta = 2e-3, 3e4, 0.3
    t = np.linspace(0.0, 2 * np.pi, 4001)[1:]
    gamma = gamma_a * np.sin(t)
    tau = tau_a * np.sin(t + delta)
    loops = derived.cyclic_loops(np.r_[0.0, gamma], np.r_[tau_a * np.sin(delta), tau],
                                 np.r_[0, np.ones(t.size, int)])
    loop = loops.iloc[0]
    assert math.isclose(loop["loop_area"], np.pi * gamma_a * tau_a * np.sin(delta),
                        rel_tol=1e-5)
    assert math.isclose(loop["damping_ratio"], np.sin(delta) / 2, rel_tol=1e-5)
    assert math.isclose(loop["secant_modulus"], tau_a / gamma_a, rel_tol=1e-5)


def test_elastic_cyclic_shear_has_no_damping():
    path = presets.cyclic_shear(amplitude=1e-3, n_cycles=3, steps_per_quarter=4,
                           vertical_stress=1e5, k0_consolidation_steps=2)
    result = run_element_test(ElasticSpecimen(3), path)
    loops = derived.cyclic_shear_response(result)
    assert list(loops["cycle"]) == [1, 2, 3]
    assert np.allclose(loops["secant_modulus"], G, rtol=1e-9)
    assert np.allclose(loops["gamma_amplitude"], 1e-3)
    assert (loops["damping_ratio"].abs() < 1e-9).all()
    with pytest.raises(InputError, match="cycle_"):
        derived.cyclic_shear_response(result.table[result.table["stage"] != "cycle_1"]
                                      .replace({"cycle_2": "c2", "cycle_3": "c3"}))


def test_input_errors_name_the_column():
    with pytest.raises(InputError, match="sigma_yy"):
        derived.k0_series(pd.DataFrame({"sigma_xx": [1.0]}))
    with pytest.raises(InputError, match="TestResult"):
        derived.k0_series({"sigma_xx": [1.0]})
    with pytest.raises(InputError):
        derived.cyclic_loops(np.zeros(3), np.zeros(4), np.zeros(3, int))


def test_increment_direction_turning_through_the_vertical_stays_continuous():
    # a stress-increment direction turning steadily from 60 to 120 deg: the canonical angle
    # jumps from +90 to -90, the continuous branch follows the rotation and is congruent to
    # it modulo pi
    turned = np.radians(np.linspace(60.0, 120.0, 31))
    d_h, d_v, d_tau = (np.sin(turned) ** 2, np.cos(turned) ** 2,
                       np.sin(turned) * np.cos(turned))
    table = pd.DataFrame({
        "sigma_xx": np.cumsum(np.r_[1e5, d_h[1:]]), "sigma_zz": np.cumsum(np.r_[1e5, d_v[1:]]),
        "sigma_xz": np.cumsum(np.r_[0.0, d_tau[1:]]), "sigma_yy": np.full(31, 1e5),
        "eps_xx": np.zeros(31), "eps_zz": np.zeros(31), "gamma_xz": np.zeros(31)})
    chi = derived.principal_angles(table)["chi"].to_numpy()
    assert np.nanmax(np.abs(np.diff(chi[1:]))) > np.radians(170.0)  # the canonical jump
    branch = derived.continuous_inclination(chi)
    np.testing.assert_allclose(branch[1:], turned[1:], atol=1e-9)
    np.testing.assert_allclose(np.sin(2 * (branch[1:] - chi[1:])), 0.0, atol=1e-12)
    assert np.isnan(branch[0])
