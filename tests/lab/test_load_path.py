"""Load paths as data: validation, the preset registry, and every preset's closed-form answer
on an isotropic linear-elastic specimen (seed 001 §4.2)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from elastic_specimens import (
    LAMBDA,
    NU,
    E,
    ElasticSpecimen,
    G,
    K,
)

from grainlab.errors import InputError
from grainlab.lab import load_path as lp
from grainlab.lab import presets
from grainlab.lab.element_test import run_element_test
from grainlab.lab.load_path import LoadPath, LoadStage, StopCriterion


def run(path, dimension=3, initial_stress=None):
    result = run_element_test(ElasticSpecimen(dimension, initial_stress), path)
    assert result.outcome["status"] == "completed", result.outcome
    return result


def stage_rows(result, name):
    return result.table[result.table["stage"] == name]


# -- data and validation ------------------------------------------------------------------------
def test_stage_from_components_orders_voigt_and_checks_names():
    stage = LoadStage.from_components("s", 4, 3, strain={"zz": 1e-3, "yz": 0, "xz": 0, "xy": 0},
                                      stress={"xx": 0.0, "yy": 0.0})
    assert stage.control == ("stress", "stress", "strain", "strain", "strain", "strain")
    assert stage.values == (0.0, 0.0, 1e-3, 0.0, 0.0, 0.0)
    with pytest.raises(InputError, match="strain\\['zx'\\]"):
        LoadStage.from_components("s", 4, 3, strain={"zx": 0.0})
    with pytest.raises(InputError, match="every Voigt component"):
        LoadStage.from_components("s", 4, 2, strain={"xx": 0.0})
    with pytest.raises(InputError, match="not both"):
        LoadStage.from_components("s", 4, 2, strain={"xx": 0.0, "yy": 0, "xy": 0},
                                  stress={"xx": 1.0})


@pytest.mark.parametrize(("changes", "field"), [
    ({"n_steps": 0}, "n_steps"),
    ({"n_steps": 2.5}, "n_steps"),
    ({"dimension": 4}, "dimension"),
    ({"control": ("strain",) * 5}, "control"),
    ({"control": ("strain", "stress", "force")}, "control[2]"),
    ({"values": (0.0, math.nan, 0.0)}, "values[1]"),
    ({"stress_mode": "final"}, "stress_mode"),
    ({"stress_mode": "schedule"}, "schedule"),
    ({"schedule": ((1.0, 2.0, 3.0),)}, "schedule"),
    ({"rotation_axis": "x"}, "rotation_axis"),
    ({"rotation_per_step": math.inf}, "rotation_per_step"),
    ({"component_basis": ((1.0, 1.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))},
     "component_basis"),
    ({"stop": ("eps_yy > 1",)}, "stop[0]"),
    ({"name": ""}, "stage.name"),
])
def test_stage_validation_names_the_field(changes, field):
    arguments = {"name": "s", "n_steps": 2, "dimension": 2,
                 "control": ("strain", "stress", "strain"), "values": (0.0, 0.0, 0.0)}
    arguments.update(changes)
    with pytest.raises(InputError) as info:
        LoadStage(**arguments)
    assert field in info.value.field


def test_path_validation():
    stage2 = LoadStage("s", 1, 2, ("strain",) * 3, (0.0,) * 3)
    with pytest.raises(InputError, match=r"path.stages\[0\].dimension"):
        LoadPath("p", 3, (stage2,))
    with pytest.raises(InputError, match=r"path\.stages"):
        LoadPath("p", 2, ())
    with pytest.raises(InputError, match=r"path\.dimension"):
        LoadPath("p", 1, (stage2,))


def test_stop_criterion_validation_and_use():
    with pytest.raises(InputError, match=r"stop\.when"):
        StopCriterion("q", 1.0, when="over")
    with pytest.raises(InputError, match=r"stop\.ends"):
        StopCriterion("q", 1.0, ends="run")
    crit = StopCriterion("eps_zz", 0.01, when="above", absolute=True)
    assert crit.met({"eps_zz": -0.02}) and not crit.met({"eps_zz": 0.001})
    assert StopCriterion("q", 5.0, when="below").met({"q": 4.0})
    with pytest.raises(InputError, match=r"stop\.quantity"):
        crit.met({"q": 1.0})


def test_stress_targets_per_mode():
    start = np.array([1.0, 2.0, 3.0])
    control = ("stress", "strain", "stress")
    inc = LoadStage("s", 2, 2, control, (10.0, 0.1, -1.0))
    assert inc.stress_targets(start).tolist() == [[1, 2, 3], [11, 2, 2], [21, 2, 1]]
    tgt = LoadStage("s", 2, 2, control, (11.0, 0.1, 5.0), stress_mode="target")
    assert tgt.stress_targets(start).tolist() == [[1, 2, 3], [6, 2, 4], [11, 2, 5]]
    sch = LoadStage("s", 2, 2, control, (0.0, 0.1, 0.0), stress_mode="schedule",
                    schedule=((7.0, 0.0, 8.0), (9.0, 0.0, 10.0)))
    assert sch.stress_targets(start).tolist() == [[1, 2, 3], [7, 2, 8], [9, 2, 10]]
    assert inc.strain_increment().tolist() == [0.0, 0.1, 0.0]


def test_frame_rotation_is_right_handed():
    for axis, (a, b) in {"x": (1, 2), "y": (2, 0), "z": (0, 1)}.items():
        r = lp.frame_rotation(axis, math.pi / 2, 3)
        assert np.allclose(r @ np.eye(3)[a], np.eye(3)[b])
        assert np.isclose(np.linalg.det(r), 1.0)
    with pytest.raises(InputError, match="rotation_axis"):
        lp.frame_rotation("x", 0.1, 2)


# -- registry and plain data --------------------------------------------------------------------
PRESET_ARGUMENTS = {
    "isotropic_compression": {"p_final": 1e5, "n_steps": 5},
    "oedometer": {"strain_final": 0.01, "n_steps": 5, "unload_strain": 0.002},
    "triaxial_compression": {"confining": 1e5, "axial_strain": 0.01, "n_steps": 5},
    "triaxial_extension": {"confining": 1e5, "axial_strain": 0.01, "n_steps": 5,
                           "drained": False},
    "true_triaxial": {"p": 1e5, "b": 0.5, "n_steps": 5, "q_final": 5e4},
    "cubical_constant_sigma3": {"confining": 1e5, "b": 0.4, "strain": 0.01, "n_steps": 5},
    "circular_octahedral": {"p": 1e5, "radius_q": 3e4, "n_steps": 8},
    "simple_shear": {"gamma_final": 0.01, "n_steps": 5, "vertical_stress": 1e5,
                     "dimension": 2},
    "biaxial": {"confining": 1e5, "strain": 0.01, "n_steps": 5},
    "cyclic_shear": {"amplitude": 1e-3, "n_cycles": 2, "steps_per_quarter": 2},
}


def test_registry_lists_every_preset_with_a_description():
    assert set(presets.preset_names()) == set(PRESET_ARGUMENTS)
    for name in presets.preset_names():
        assert presets.preset_description(name)


@pytest.mark.parametrize("name", sorted(PRESET_ARGUMENTS))
def test_presets_round_trip_as_plain_data(name):
    path = presets.preset(name, **PRESET_ARGUMENTS[name])
    data = json.loads(json.dumps(path.to_dict()))
    assert LoadPath.from_dict(data) == path
    assert path.n_steps == sum(s["n_steps"] for s in data["stages"])


def test_registry_rejects_unknown_names_and_parameters():
    with pytest.raises(InputError, match="preset"):
        presets.preset("triaxial")
    with pytest.raises(InputError, match="oedometer: strain_finale"):
        presets.preset("oedometer", strain_finale=0.1, n_steps=3)
    with pytest.raises(InputError, match="also n_steps"):
        presets.preset("oedometer", strain_final=0.1)


@pytest.mark.parametrize(("call", "field"), [
    (lambda: presets.oedometer(strain_final=-0.1, n_steps=3), "strain_final"),
    (lambda: presets.oedometer(strain_final=0.1, n_steps=3, unload_to_stress=1.0,
                          unload_strain=0.01), "unload_strain"),
    (lambda: presets.true_triaxial(p=1e5, b=1.5, strain=0.01, n_steps=3), "b"),
    (lambda: presets.true_triaxial(p=1e5, b=0.5, n_steps=3), "strain"),
    (lambda: presets.cubical_constant_sigma3(confining=1e5, b=-0.1, strain=0.01, n_steps=3),
     "b"),
    (lambda: presets.cubical_constant_sigma3(confining=0.0, b=0.5, strain=0.01, n_steps=3),
     "confining"),
    (lambda: presets.simple_shear(gamma_final=0.1, n_steps=3, vertical_stress=1e5,
                             constant="volume"), "constant"),
    (lambda: presets.triaxial_compression(confining=1e5, axial_strain=0.1, n_steps=3,
                                     drained="yes"), "drained"),
    (lambda: presets.isotropic_compression(p_final=1e5, n_steps=3, dimension=1), "dimension"),
])
def test_preset_validation(call, field):
    with pytest.raises(InputError) as info:
        call()
    assert info.value.field == field


def test_true_triaxial_direction_keeps_p_and_b():
    for b in (0.0, 0.25, 0.5, 1.0):
        nx, ny, nz = presets.true_triaxial_direction(b)
        assert abs(nx + ny + nz) < 1e-15
        assert math.isclose((nx - ny), b * (nz - ny), abs_tol=1e-15)


# -- closed-form elastic answers ----------------------------------------------------------------
@pytest.mark.parametrize("dimension", [2, 3])
def test_isotropic_compression(dimension):
    result = run(presets.isotropic_compression(p_final=2e5, n_steps=4, dimension=dimension),
                 dimension)
    last = result.table.iloc[-1]
    bulk = K if dimension == 3 else LAMBDA + G  # plane-strain in-plane bulk modulus
    assert math.isclose(last["p"], 2e5, rel_tol=1e-12)
    assert math.isclose(last["eps_vol"], 2e5 / bulk, rel_tol=1e-12)
    assert abs(last["q"]) < 1e-6


@pytest.mark.parametrize("dimension", [2, 3])
def test_oedometer_k0_and_unloading(dimension):
    result = run(presets.oedometer(strain_final=0.01, n_steps=5, unload_to_stress=1e5,
                              dimension=dimension), dimension)
    v, h = ("sigma_zz", "sigma_xx") if dimension == 3 else ("sigma_yy", "sigma_xx")
    loading = stage_rows(result, "loading")
    assert np.allclose(loading[h] / loading[v], NU / (1 - NU), rtol=1e-12)
    assert np.allclose(loading[v], (LAMBDA + 2 * G) * loading[v.replace("sigma", "eps")],
                       rtol=1e-12)
    unloading = stage_rows(result, "unloading")
    assert math.isclose(unloading[v].iloc[-1], 1e5, rel_tol=1e-12)
    assert np.allclose(unloading[h] / unloading[v], NU / (1 - NU), rtol=1e-10)
    lateral = ["eps_xx"] + (["eps_yy"] if dimension == 3 else [])
    assert np.all(result.table[lateral].to_numpy() == 0.0)


def test_oedometer_unload_by_strain():
    result = run(presets.oedometer(strain_final=0.01, n_steps=4, unload_strain=0.004))
    assert math.isclose(result.table["eps_zz"].iloc[-1], 0.006, rel_tol=1e-12)


@pytest.mark.parametrize("drained", [True, False])
def test_triaxial_compression(drained):
    result = run(presets.triaxial_compression(confining=1e5, axial_strain=0.01, n_steps=5,
                                         drained=drained))
    shear = stage_rows(result, "shear")
    start = stage_rows(result, "consolidation").iloc[-1]
    d_axial = shear["eps_zz"] - start["eps_zz"]
    assert np.allclose(d_axial.iloc[-1], 0.01, rtol=1e-12)
    if drained:
        assert np.allclose(shear["sigma_xx"], 1e5, rtol=1e-12)
        assert np.allclose((shear["sigma_zz"] - 1e5) / d_axial, E, rtol=1e-10)
        assert np.allclose((shear["eps_xx"] - start["eps_xx"]) / d_axial, -NU, rtol=1e-10)
    else:
        assert np.allclose(shear["eps_vol"], start["eps_vol"], atol=1e-15)
        assert np.allclose(shear["q"] / d_axial, 3 * G, rtol=1e-10)
        assert np.allclose(shear["p"], 1e5, rtol=1e-12)


def test_triaxial_extension():
    result = run(presets.triaxial_extension(confining=1e5, axial_strain=0.001, n_steps=5,
                                       consolidation_steps=3))
    shear = stage_rows(result, "shear")
    d_axial = shear["eps_zz"] - stage_rows(result, "consolidation")["eps_zz"].iloc[-1]
    assert np.allclose(d_axial.iloc[-1], -0.001, rtol=1e-12)
    assert np.allclose((shear["sigma_zz"] - 1e5) / d_axial, E, rtol=1e-10)
    assert np.allclose(shear["sigma_3"], shear["sigma_zz"], rtol=1e-12)
    assert np.allclose(shear["b"], 1.0, atol=1e-9)


@pytest.mark.parametrize("b", [0.0, 0.3, 0.75, 1.0])
def test_true_triaxial_keeps_p_and_b(b):
    result = run(presets.true_triaxial(p=1e5, b=b, strain=0.002, n_steps=6))
    shear = stage_rows(result, "shear")
    assert np.allclose(shear["p"], 1e5, rtol=1e-9)
    assert np.allclose(shear["b"], b, atol=1e-9)
    assert np.allclose(shear[["sigma_yz", "sigma_xz", "sigma_xy"]], 0.0, atol=1e-6)
    # deviatoric stress 2G times the conjugate deviatoric strain along n_d
    n_d = presets.true_triaxial_direction(b)
    strain_d = shear[["eps_xx", "eps_yy", "eps_zz"]].to_numpy() @ n_d
    stress_d = shear[["sigma_xx", "sigma_yy", "sigma_zz"]].to_numpy() @ n_d
    assert np.allclose(stress_d, 2 * G * strain_d, rtol=1e-9)
    assert math.isclose(strain_d[-1], 0.002, rel_tol=1e-9)
    major = {"sigma_zz": "sigma_1", "sigma_xx": "sigma_2", "sigma_yy": "sigma_3"}
    if 0.0 < b < 1.0:
        for lab, principal in major.items():
            assert np.allclose(shear[lab], shear[principal], rtol=1e-12)


@pytest.mark.parametrize("b", [0.0, 0.3, 0.6, 1.0])
def test_cubical_constant_sigma3_holds_sigma3_and_b(b):
    """sigma_yy = sigma_3 held, sigma_xx - sigma_3 = b (sigma_zz - sigma_3): with
    d sigma_x = b d sigma_z and d sigma_y = 0, Hooke's law gives the driven strain
    e = (b eps_xx + eps_zz)/sqrt(1 + b^2) = d sigma_z (1 + b^2 - 2 nu b)/(E sqrt(1 + b^2))."""
    result = run(presets.cubical_constant_sigma3(confining=1e5, b=b, strain=0.002, n_steps=6,
                                                 consolidation_steps=2))
    shear = stage_rows(result, "shear")
    start = stage_rows(result, "consolidation").iloc[-1]
    assert np.allclose(shear["sigma_yy"], 1e5, rtol=1e-10)
    assert np.allclose(shear["b"], b, atol=1e-9)
    assert np.allclose(shear[["sigma_yz", "sigma_xz", "sigma_xy"]], 0.0, atol=1e-6)
    d_eps = shear[["eps_xx", "eps_yy", "eps_zz"]].to_numpy() - start[
        ["eps_xx", "eps_yy", "eps_zz"]].to_numpy(dtype=float)
    driven = (b * d_eps[:, 0] + d_eps[:, 2]) / math.sqrt(1.0 + b * b)
    np.testing.assert_allclose(driven, 0.002 * np.arange(1, 7) / 6, rtol=1e-10)
    expected = E * math.sqrt(1.0 + b * b) / (1.0 + b * b - 2.0 * NU * b) * driven
    np.testing.assert_allclose(shear["sigma_zz"] - 1e5, expected, rtol=1e-9)
    np.testing.assert_allclose(shear["sigma_xx"] - 1e5, b * expected, rtol=1e-9, atol=1e-6)
    assert np.allclose(shear["sigma_3"], shear["sigma_yy"], rtol=1e-12)
    assert np.allclose(shear["sigma_1"], shear["sigma_zz"], rtol=1e-12)


def test_true_triaxial_to_q_final():
    result = run(presets.true_triaxial(p=1e5, b=0.4, q_final=6e4, n_steps=4))
    last = result.table.iloc[-1]
    assert math.isclose(last["q"], 6e4, rel_tol=1e-9)
    assert math.isclose(last["b"], 0.4, rel_tol=1e-9)
    assert math.isclose(last["p"], 1e5, rel_tol=1e-12)


def test_circular_octahedral_path():
    p, q = 1e5, 4e4
    result = run(presets.circular_octahedral(p=p, radius_q=q, n_steps=24, alpha0=0.2))
    circle = stage_rows(result, "circle")
    s = circle[["sigma_xx", "sigma_yy", "sigma_zz"]].to_numpy()
    deviator = s - s.mean(axis=1, keepdims=True)
    assert np.allclose(s.mean(axis=1), p, rtol=1e-12)
    assert np.allclose(np.sqrt(1.5 * np.sum(deviator**2, axis=1)), q, rtol=1e-10)
    alpha = np.arctan2((s[:, 0] - s[:, 1]) / np.sqrt(2), (2 * s[:, 2] - s[:, 0] - s[:, 1])
                       / np.sqrt(6))
    expected = 0.2 + 2 * np.pi * np.arange(1, 25) / 24
    assert np.allclose(np.angle(np.exp(1j * (alpha - expected))), 0.0, atol=1e-10)
    # the strain path is a circle in deviatoric strain space: e = s / 2G, |e| constant
    e = circle[["eps_xx", "eps_yy", "eps_zz"]].to_numpy()
    e_dev = e - e.mean(axis=1, keepdims=True)
    assert np.allclose(np.linalg.norm(e_dev, axis=1), np.sqrt(2 / 3) * q / (2 * G), rtol=1e-9)
    assert np.allclose(e_dev.mean(axis=0), 0.0, atol=1e-15)
    assert np.allclose(e.sum(axis=1), p / K, rtol=1e-10)


@pytest.mark.parametrize("dimension", [2, 3])
@pytest.mark.parametrize("constant", ["vertical_stress", "height"])
def test_simple_shear(dimension, constant):
    result = run(presets.simple_shear(gamma_final=0.004, n_steps=4, vertical_stress=1e5,
                                 k0_consolidation_steps=5, constant=constant,
                                 dimension=dimension), dimension)
    shear_c, v = ("xz", "zz") if dimension == 3 else ("xy", "yy")
    k0 = stage_rows(result, "k0_consolidation").iloc[-1]
    assert math.isclose(k0[f"sigma_{v}"], 1e5, rel_tol=1e-12)
    assert math.isclose(k0["sigma_xx"], NU / (1 - NU) * 1e5, rel_tol=1e-12)
    shear = stage_rows(result, "shear")
    assert np.allclose(shear[f"sigma_{shear_c}"], G * shear[f"gamma_{shear_c}"], rtol=1e-12)
    assert np.allclose(shear[f"sigma_{v}"], 1e5, rtol=1e-12)
    assert math.isclose(shear[f"gamma_{shear_c}"].iloc[-1], 0.004, rel_tol=1e-12)


def test_biaxial():
    result = run(presets.biaxial(confining=1e5, strain=0.002, n_steps=4), 2)
    shear = stage_rows(result, "shear")
    start = stage_rows(result, "consolidation").iloc[-1]
    d_v = shear["eps_yy"] - start["eps_yy"]
    assert np.allclose(shear["sigma_xx"], 1e5, rtol=1e-12)
    assert np.allclose((shear["sigma_yy"] - 1e5) / d_v, E / (1 - NU**2), rtol=1e-10)


@pytest.mark.parametrize("dimension", [2, 3])
def test_cyclic_shear(dimension):
    path = presets.cyclic_shear(amplitude=1e-3, n_cycles=2, steps_per_quarter=3,
                                dimension=dimension, vertical_stress=1e5,
                                k0_consolidation_steps=2)
    result = run(path, dimension)
    c = "xz" if dimension == 3 else "xy"
    cycles = result.table[result.table["stage"].str.startswith("cycle_")]
    assert len(cycles) == 2 * 12
    assert math.isclose(cycles[f"gamma_{c}"].max(), 1e-3, rel_tol=1e-12)
    assert math.isclose(cycles[f"gamma_{c}"].min(), -1e-3, rel_tol=1e-12)
    assert abs(cycles[f"gamma_{c}"].iloc[-1]) < 1e-15
    assert np.allclose(cycles[f"sigma_{c}"], G * cycles[f"gamma_{c}"], rtol=1e-9, atol=1e-6)
