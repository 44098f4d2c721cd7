"""The element-test driver: Voigt rotations, mixed control, iterations, sub-steps, failure,
rotating control frames, the results table and its metadata."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainlab.errors import GrainlabWarning, InputError
from grainlab.lab import load_path as lp
from grainlab.lab import presets
from grainlab.lab.element_test import (
    control_matrix,
    strain_rotation,
    stress_rotation,
)
from grainlab.lab.element_test import run_element_test as _run_element_test
from grainlab.lab.load_path import LoadPath, LoadStage, StopCriterion
from grainlab.lab.specimen import tensor_to_voigt, voigt_to_tensor
from grainlab.result import read_test_result

E, NU = 8.0e7, 0.25


def run_element_test(*args, **kwargs):
    """The driver at a tight tolerance (these tests check the iteration mechanics)."""
    kwargs.setdefault("tolerance", 1e-6)
    return _run_element_test(*args, **kwargs)

LAMBDA = E * NU / ((1 + NU) * (1 - 2 * NU))
G = E / (2 * (1 + NU))


def isotropic_stiffness(dimension: int) -> np.ndarray:
    n = 6 if dimension == 3 else 3
    m = np.zeros(n)
    m[:dimension] = 1.0
    return LAMBDA * np.outer(m, m) + G * np.diag(
        np.r_[2.0 * np.ones(dimension), np.ones(n - dimension)])


class ElasticSpecimen:
    """Linear elasticity with any symmetric stiffness D (Voigt, engineering shears); the
    tangent it reports is ``tangent_factor`` D (1: exact)."""

    def __init__(self, stiffness, initial_stress=None, tangent_factor=1.0):
        self.D = np.asarray(stiffness, dtype=float)
        n = self.D.shape[0]
        self.dimension = 3 if n == 6 else 2
        self.eps = np.zeros(n)
        self.s0 = np.zeros(n) if initial_stress is None else np.asarray(initial_stress, float)
        self.tangent_factor = tangent_factor

    def stress(self):
        return self.s0 + self.D @ self.eps

    def strain(self):
        return self.eps.copy()

    def tangent(self):
        return self.tangent_factor * self.D

    def apply_strain(self, increment):
        self.eps = self.eps + increment

    def descriptors(self):
        return {}

    def describe(self):
        return {"kind": "linear elastic", "tangent_factor": self.tangent_factor}


class MohrCoulombSpecimen:
    """Hypoelastic (K ~ p^0.5, G ~ p^0.25, integrated in sub-increments, so the tangent at the
    start of a step is not exact) with a Mohr–Coulomb cap sin(phi_m) <= sin(phi_max): an
    elastic trial beyond the cap has its deviator scaled back at constant mean stress, and on
    the cap the tangent keeps the bulk stiffness only (D = K m m^T, no deviatoric stiffness)."""

    def __init__(self, dimension=3, p0=1e5, phi_deg=30.0, substeps=8):
        self.dimension = dimension
        self.n = 6 if dimension == 3 else 3
        self.m = np.zeros(self.n)
        self.m[:dimension] = 1.0
        self.sin_max = math.sin(math.radians(phi_deg))
        self.substeps = substeps
        self.sigma = p0 * self.m
        self.eps = np.zeros(self.n)

    def _moduli(self):
        x = max(float(self.sigma[:self.dimension].sum()) / self.dimension, 1.0) / 1e5
        return 6e7 * x**0.5, 4e7 * x**0.25

    def _elastic(self):
        bulk, shear = self._moduli()
        d = self.dimension
        stiffness = np.zeros((self.n, self.n))
        stiffness[:d, :d] = bulk + 2 * shear * (np.eye(d) - 1.0 / d)
        stiffness[d:, d:] = shear * np.eye(self.n - d)
        return stiffness

    def sin_phi(self):
        w = np.linalg.eigvalsh(voigt_to_tensor(self.sigma, False))
        return float((w[-1] - w[0]) / (w[-1] + w[0]))

    def stress(self):
        return self.sigma.copy()

    def strain(self):
        return self.eps.copy()

    def tangent(self):
        if self.sin_phi() >= self.sin_max * (1 - 1e-9):
            return self._moduli()[0] * np.outer(self.m, self.m)
        return self._elastic()

    def apply_strain(self, increment):
        for _ in range(self.substeps):
            self.sigma = self.sigma + self._elastic() @ (increment / self.substeps)
        t = voigt_to_tensor(self.sigma, False)
        p = np.trace(t) / self.dimension
        s = t - p * np.eye(self.dimension)
        w = np.linalg.eigvalsh(s)
        if w[-1] - w[0] > self.sin_max * (2 * p + w[-1] + w[0]):
            scale = 2 * p * self.sin_max / (w[-1] - w[0] - self.sin_max * (w[-1] + w[0]))
            self.sigma = tensor_to_voigt(p * np.eye(self.dimension) + scale * s, False)
        self.eps = self.eps + increment

    def descriptors(self):
        return {"sin_phi_model": self.sin_phi()}

    def describe(self):
        return {"kind": "hypoelastic Mohr-Coulomb", "phi_max_deg": 30.0}


def random_rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def random_spd(rng, n) -> np.ndarray:
    a = rng.normal(size=(n, n))
    return 1e7 * (a @ a.T + n * np.eye(n))


# -- Voigt rotations ----------------------------------------------------------------------------
@pytest.mark.parametrize("dimension", [2, 3])
def test_voigt_rotations_match_tensor_rotation_and_conserve_work(dimension):
    rng = np.random.default_rng(1)
    for _ in range(5):
        r = random_rotation(rng) if dimension == 3 else lp.frame_rotation(
            "z", rng.uniform(-3, 3), 2)
        n = 6 if dimension == 3 else 3
        sigma, eps = rng.normal(size=n), rng.normal(size=n)
        t_s, t_e = stress_rotation(r), strain_rotation(r)
        assert np.allclose(t_s @ sigma,
                           tensor_to_voigt(r.T @ voigt_to_tensor(sigma, False) @ r, False))
        assert np.allclose(t_e @ eps,
                           tensor_to_voigt(r.T @ voigt_to_tensor(eps, True) @ r, True))
        assert math.isclose((t_s @ sigma) @ (t_e @ eps), sigma @ eps, rel_tol=1e-12)
        assert np.allclose(t_e, np.linalg.inv(t_s).T)
        assert np.allclose(stress_rotation(r.T), np.linalg.inv(t_s))


def test_voigt_rotation_2d_closed_form_and_composition():
    a = 0.37
    c, s = math.cos(a), math.sin(a)
    t_s = stress_rotation(lp.frame_rotation("z", a, 2))
    expected = np.array([[c * c, s * s, 2 * c * s], [s * s, c * c, -2 * c * s],
                         [-c * s, c * s, c * c - s * s]])
    assert np.allclose(t_s, expected)
    t_e = strain_rotation(lp.frame_rotation("z", a, 2))
    assert np.allclose(t_e[2], [-2 * c * s, 2 * c * s, c * c - s * s])
    r1, r2 = lp.frame_rotation("x", 0.3, 3), lp.frame_rotation("y", -1.1, 3)
    assert np.allclose(stress_rotation(r1 @ r2), stress_rotation(r2) @ stress_rotation(r1))


def test_control_matrix_with_basis_is_work_conjugate():
    path = presets.true_triaxial(p=1e5, b=0.3, strain=0.01, n_steps=2, consolidation_steps=0)
    b = control_matrix(path.stages[0], 1.0)
    assert np.allclose(b @ b.T, np.eye(6))  # no frame rotation: B = Q, orthogonal


# -- mixed control on elastic specimens ---------------------------------------------------------
def test_rotated_control_frame_gives_the_rotated_response():
    """A test run in a frame rotated about y on an anisotropic specimen equals the unrotated
    test on the specimen whose stiffness is expressed in that frame."""
    rng = np.random.default_rng(7)
    stiffness = random_spd(rng, 6)
    angle = 0.6
    stress = {c: 0.0 for c in ("xx", "yy", "yz", "xz", "xy")}
    stage = LoadStage.from_components("uniaxial", 5, 3, strain={"zz": 2e-4}, stress=stress,
                                      rotation_axis="y", rotation_start=angle)
    rotated = run_element_test(ElasticSpecimen(stiffness), LoadPath("rot", 3, (stage,)))
    t_s = stress_rotation(lp.frame_rotation("y", angle, 3))
    t_e = strain_rotation(lp.frame_rotation("y", angle, 3))
    plain_stage = LoadStage.from_components("uniaxial", 5, 3, strain={"zz": 2e-4},
                                            stress=stress)
    plain = run_element_test(ElasticSpecimen(t_s @ stiffness @ t_s.T),
                             LoadPath("plain", 3, (plain_stage,)))
    sig = [f"sigma_{c}" for c in ("xx", "yy", "zz", "yz", "xz", "xy")]
    eps = ["eps_xx", "eps_yy", "eps_zz", "gamma_yz", "gamma_xz", "gamma_xy"]
    assert np.allclose(rotated.table[sig].to_numpy() @ t_s.T, plain.table[sig].to_numpy(),
                       atol=1e-6)
    assert np.allclose(rotated.table[eps].to_numpy() @ t_e.T, plain.table[eps].to_numpy(),
                       atol=1e-16)
    assert rotated.table["frame_angle"].iloc[-1] == angle
    frame_stress = rotated.table[sig].to_numpy() @ t_s.T
    assert np.allclose(np.delete(frame_stress, 2, axis=1), 0.0, atol=1e-6)


@pytest.mark.parametrize(("dimension", "axis"), [(2, "z"), (3, "y"), (3, "x")])
def test_stress_held_in_a_rotating_frame_rotates_the_principal_axes(dimension, axis):
    n = 6 if dimension == 3 else 3
    initial = np.array([1e5, 2e5, 3e5, 0.0, 0.0, 0.0])[:n] if dimension == 3 else np.array(
        [1e5, 3e5, 0.0])
    stage = LoadStage("turn", 8, dimension, ("stress",) * n, (0.0,) * n,
                      rotation_axis=axis, rotation_per_step=math.pi / 16)
    specimen = ElasticSpecimen(isotropic_stiffness(dimension), initial_stress=initial)
    result = run_element_test(specimen, LoadPath("turn", dimension, (stage,)))
    assert result.outcome["status"] == "completed"
    labels = ("xx", "yy", "zz", "yz", "xz", "xy") if dimension == 3 else ("xx", "yy", "xy")
    for k, row in result.table.iterrows():
        r = lp.frame_rotation(axis, k * math.pi / 16, dimension)
        expected = tensor_to_voigt(r @ voigt_to_tensor(initial, False) @ r.T, False)
        got = np.array([row[f"sigma_{c}"] for c in labels])
        assert np.allclose(got, expected, rtol=1e-12, atol=1e-6)
    assert np.allclose(result.table["sigma_1"], initial.max())


def test_tangent_too_soft_needs_halved_corrections_and_still_converges():
    specimen = ElasticSpecimen(isotropic_stiffness(3), tangent_factor=1.0 / 3.0)
    result = run_element_test(specimen, presets.isotropic_compression(p_final=1e5, n_steps=3),
                              max_iterations=40)
    out = result.outcome
    assert out["status"] == "completed" and out["unconverged_steps"] == 0
    assert out["halvings"] > 0 and out["iterations_total"] > 3
    assert math.isclose(result.table["p"].iloc[-1], 1e5, rel_tol=2e-6)
    assert result.table["converged"].all()


def test_unconverged_steps_are_reported_never_silent():
    specimen = ElasticSpecimen(isotropic_stiffness(3), tangent_factor=1.9)
    with pytest.warns(GrainlabWarning, match="stress error above the tolerance"):
        result = run_element_test(specimen, presets.isotropic_compression(p_final=1e5, n_steps=4),
                                  max_iterations=2)
    out = result.outcome
    assert out["status"] == "completed"
    assert out["unconverged_steps"] == 4 and out["unconverged_increments"] == [1, 2, 3, 4]
    assert not result.table["converged"].iloc[1:].any()
    assert (result.table["stress_error"].iloc[1:] > 1e-6).all()
    assert (result.table["iterations"].iloc[1:] == 2).all()


class StuckSpecimen(ElasticSpecimen):
    """Normal stresses capped at 5e4 Pa while the tangent stays elastic."""

    def stress(self):
        sigma = super().stress()
        sigma[:3] = np.minimum(sigma[:3], 5e4)
        return sigma


@pytest.mark.parametrize("max_iterations", [3, 20])
def test_unreachable_stress_is_a_failure(max_iterations):
    result = run_element_test(StuckSpecimen(isotropic_stiffness(3)),
                              presets.isotropic_compression(p_final=1e5, n_steps=4),
                              max_iterations=max_iterations)
    out = result.outcome
    assert out["status"] == "failure"
    assert "cannot be reached" in out["reason"]
    assert (out["stage"], out["step"], out["increment"]) == ("isotropic", 3, 3)
    assert not result.table["converged"].iloc[-1]


# -- failure and sub-steps on the Mohr–Coulomb specimen -----------------------------------------
RATIO = (1 + math.sin(math.radians(30))) / (1 - math.sin(math.radians(30)))


@pytest.mark.parametrize("preset", ["triaxial_compression", "triaxial_extension"])
def test_triaxial_fails_at_the_mohr_coulomb_stress_ratio(preset):
    path = presets.preset(preset, confining=1e5, axial_strain=0.02, n_steps=40)
    result = run_element_test(MohrCoulombSpecimen(), path)
    out = result.outcome
    assert out["status"] == "failure" and "strength reached" in out["reason"]
    assert out["stage"] == "shear" and out["increment"] == 10 + out["step"]
    table = result.table
    assert math.isclose(table["stress_ratio"].iloc[-1], RATIO, rel_tol=1e-9)
    assert (table["stress_ratio"].iloc[:-1] < RATIO).all()
    assert math.isclose(table["sin_phi"].iloc[-1], 0.5, rel_tol=1e-9)
    before = table.iloc[1:-1]
    assert before["converged"].all() and (before["stress_error"] <= 1e-6).all()
    assert out["iterations_total"] > 0  # the hypoelastic tangent is not exact
    shear = before[before["stage"] == "shear"]
    assert np.allclose(shear[["sigma_xx", "sigma_yy"]], 1e5, rtol=2e-6)


def test_true_triaxial_fails_at_the_same_friction_angle_with_p_and_b_held():
    path = presets.true_triaxial(p=1e5, b=0.5, strain=0.02, n_steps=40)
    result = run_element_test(MohrCoulombSpecimen(), path)
    out = result.outcome
    assert out["status"] == "failure" and "strength reached" in out["reason"]
    shear = result.table[result.table["stage"] == "shear"]
    assert np.allclose(shear["p"], 1e5, rtol=1e-9)
    assert np.allclose(shear["b"], 0.5, atol=1e-9)
    assert math.isclose(shear["stress_ratio"].iloc[-1], RATIO, rel_tol=1e-9)


def test_failure_before_any_change_records_no_row():
    specimen = MohrCoulombSpecimen()
    specimen.sigma = np.array([1e5, 1e5, 3e5, 0.0, 0.0, 0.0])  # already on the cap
    path = presets.triaxial_compression(confining=1e5, axial_strain=0.01, n_steps=5,
                                   consolidation_steps=0)
    result = run_element_test(specimen, path)
    assert result.outcome["status"] == "failure"
    assert result.outcome["steps_completed"] == 0 and len(result.table) == 1


def test_biaxial_sub_steps_into_a_plastic_plateau():
    """In 2D the stress-controlled block (sigma_xx) keeps its bulk stiffness on the cap, so the
    strain-controlled test goes on along the plateau; crossing onto the cap halves the pieces,
    which grow back once the tangent predicts well again."""
    result = run_element_test(MohrCoulombSpecimen(dimension=2),
                              presets.biaxial(confining=1e5, strain=0.02, n_steps=40),
                              max_iterations=40)
    out = result.outcome
    assert out["status"] == "completed" and out["unconverged_steps"] == 0
    assert out["halvings"] > 0 and out["sub_steps_total"] > out["steps_completed"]
    shear = result.table[result.table["stage"] == "shear"]
    assert (shear["sub_steps"] > 1).any() and shear["sub_steps"].iloc[-1] == 1
    assert math.isclose(shear["stress_ratio"].max(), RATIO, rel_tol=1e-9)
    assert np.allclose(shear["sigma_xx"], 1e5, rtol=2e-6)


def test_isotropic_compression_iterates_to_tolerance():
    result = run_element_test(MohrCoulombSpecimen(),
                              presets.isotropic_compression(p_final=3e5, n_steps=10))
    table = result.table
    assert result.outcome["status"] == "completed"
    assert (table["iterations"].iloc[1:] > 0).all()
    assert np.allclose(table["p"].iloc[1:], np.linspace(1.2e5, 3e5, 10), rtol=1e-6)
    assert (table["stress_error"] <= 1e-6).all()


# -- stop criteria, progress, table and metadata ------------------------------------------------
def test_stop_criteria_end_a_stage_or_the_test():
    shear = LoadStage.from_components(
        "shear", 100, 3, strain={"zz": 1e-4, "yz": 0, "xz": 0, "xy": 0},
        stress={"xx": 0.0, "yy": 0.0}, stop=(StopCriterion("eps_zz", 5e-4),))
    unload = LoadStage.from_components(
        "unload", 3, 3, strain={"zz": -1e-4, "yz": 0, "xz": 0, "xy": 0},
        stress={"xx": 0.0, "yy": 0.0})
    specimen = ElasticSpecimen(isotropic_stiffness(3), initial_stress=[1e5] * 3 + [0] * 3)
    result = run_element_test(specimen, LoadPath("stop", 3, (shear, unload)))
    assert list(result.table["stage"]) == ["initial"] + ["shear"] * 5 + ["unload"] * 3
    assert result.outcome["stopped"][0]["stage"] == "shear"
    assert result.outcome["stopped"][0]["increment"] == 5
    ends = LoadStage.from_components(
        "shear", 100, 3, strain={"zz": 1e-4, "yz": 0, "xz": 0, "xy": 0},
        stress={"xx": 0.0, "yy": 0.0},
        stop=(StopCriterion("stress_ratio", 2.0, ends="test"),))
    specimen = ElasticSpecimen(isotropic_stiffness(3), initial_stress=[1e5] * 3 + [0] * 3)
    result = run_element_test(specimen, LoadPath("stop", 3, (ends, unload)))
    assert result.outcome["status"] == "completed"
    assert result.table["stage"].iloc[-1] == "shear"
    assert result.table["stress_ratio"].iloc[-1] >= 2.0 > result.table["stress_ratio"].iloc[-2]


def test_table_columns_units_metadata_and_progress(tmp_path):
    calls = []
    path = presets.oedometer(strain_final=0.01, n_steps=3, unload_to_stress=1e5)
    result = run_element_test(MohrCoulombSpecimen(), path,
                              progress=lambda done, total: calls.append((done, total)))
    assert calls == [(k, 6) for k in range(1, 7)]
    columns = list(result.table.columns)
    expected = ["increment", "stage", "step",
                "sigma_xx", "sigma_yy", "sigma_zz", "sigma_yz", "sigma_xz", "sigma_xy",
                "eps_xx", "eps_yy", "eps_zz", "gamma_yz", "gamma_xz", "gamma_xy",
                "sigma_1", "sigma_2", "sigma_3", "p", "q", "q_over_3", "q_over_trace",
                "sin_phi", "stress_ratio", "b", "eps_vol", "eps_q", "frame_angle", "sub_steps",
                "iterations", "stress_error", "converged", "sin_phi_model"]
    assert columns == expected
    assert result.units["sigma_xz"] == "Pa" and result.units["frame_angle"] == "rad"
    assert result.units["gamma_xz"] == "-" and result.units["iterations"] == "-"
    assert result.load_path == path.to_dict()
    assert result.specimen["kind"] == "hypoelastic Mohr-Coulomb"
    assert result.metadata["parameters"]["max_iterations"] == 10
    assert result.metadata["dimension"] == 3
    assert LoadPath.from_dict(result.load_path) == path
    back = read_test_result(result.to_csv(tmp_path / "oedometer.csv"))
    assert back.equals(result)
    t = result.table
    assert np.allclose(t["p"], t[["sigma_xx", "sigma_yy", "sigma_zz"]].sum(axis=1) / 3)
    assert np.allclose(t["q"], t["sigma_1"] - t["sigma_3"])
    assert np.allclose(t["q_over_3"], t["q"] / 3)
    assert np.allclose(t["q_over_trace"], t["q"] / (3 * t["p"]))
    assert np.allclose(t["sin_phi"], t["sin_phi_model"])
    assert np.allclose(t["eps_vol"], t[["eps_xx", "eps_yy", "eps_zz"]].sum(axis=1))
    assert (t["sigma_1"] >= t["sigma_2"]).all() and (t["sigma_2"] >= t["sigma_3"]).all()


def test_two_dimensional_columns():
    result = run_element_test(ElasticSpecimen(isotropic_stiffness(2)),
                              presets.biaxial(confining=1e5, strain=1e-3, n_steps=2))
    columns = set(result.table.columns)
    assert {"sigma_xx", "sigma_yy", "sigma_xy", "eps_xx", "eps_yy", "gamma_xy",
            "sigma_1", "sigma_3"} <= columns
    assert not {"sigma_zz", "sigma_2", "b", "gamma_xz"} & columns
    t = result.table
    assert np.allclose(t["p"], (t["sigma_xx"] + t["sigma_yy"]) / 2)


def test_driver_input_errors():
    specimen = ElasticSpecimen(isotropic_stiffness(2))
    with pytest.raises(InputError, match=r"path\.dimension"):
        run_element_test(specimen, presets.isotropic_compression(p_final=1e5, n_steps=2))
    path = presets.isotropic_compression(p_final=1e5, n_steps=2, dimension=2)
    with pytest.raises(InputError, match="tolerance"):
        run_element_test(specimen, path, tolerance=-1.0)
    with pytest.raises(InputError, match="max_iterations"):
        run_element_test(specimen, path, max_iterations=2.5)
    with pytest.raises(InputError, match="path"):
        run_element_test(specimen, path.to_dict())

    class Clashing(ElasticSpecimen):
        def descriptors(self):
            return {"p": 1.0}

    with pytest.raises(InputError, match="descriptors"):
        run_element_test(Clashing(isotropic_stiffness(2)), path)
    with pytest.raises(InputError, match=r"stop\.quantity"):
        stage = LoadStage("s", 2, 2, ("strain",) * 3, (1e-4, 0, 0),
                          stop=(StopCriterion("void_ratio", 1.0),))
        run_element_test(specimen, LoadPath("s", 2, (stage,)))
