"""Figures of element tests on seed 001's model: the failure surfaces against their closed
forms, and every figure function on short real runs (a Figure with the expected axes)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from grainlab.errors import GrainlabWarning, InputError
from grainlab.lab.element_test import run_element_test
from grainlab.lab.micro_element_setup import (
    build_model,
    build_structure,
    default_path_parameters,
)
from grainlab.lab.presets import preset
from grainlab.prep.regular_packings import named_packing
from grainlab.report.element_test_figures import (
    b_sweep_figure,
    circular_path_figure,
    cyclic_figure,
    failure_surface,
    hysteresis_figure,
    k0_figure,
    oedometer_stages_figure,
    simple_shear_figure,
    triaxial_figure,
)
from grainlab.result.test_result import TestResult

PHI = math.radians(30.0)


def q_over_p(points: np.ndarray) -> np.ndarray:
    """q/p of octahedral-plane points (distance sqrt(2/3) q/p from the origin)."""
    return np.hypot(points[:, 0], points[:, 1]) / math.sqrt(2.0 / 3.0)


@pytest.mark.parametrize("criterion", ["mohr-coulomb", "matsuoka-nakai", "lade-duncan"])
def test_every_surface_passes_through_triaxial_compression(criterion):
    points = failure_surface(PHI, criterion, n=13)  # alpha = 0, 30, ..., 360 deg
    s = math.sin(PHI)
    compression = 6 * s / (3 - s)
    np.testing.assert_allclose(q_over_p(points[[0, 4, 8, 12]]), compression, rtol=1e-9)
    # three-fold symmetry and the mirror about each compression axis
    ratios = q_over_p(points)
    np.testing.assert_allclose(ratios[1:4], ratios[5:8], rtol=1e-9)
    np.testing.assert_allclose(ratios[1], ratios[3], rtol=1e-9)


def test_surfaces_in_extension_against_closed_forms():
    s = math.sin(PHI)
    extension = 6 * s / (3 + s)  # Mohr-Coulomb at alpha = 60 deg (b = 1)
    at_60 = {c: q_over_p(failure_surface(PHI, c, n=7))[1] for c in
             ("mohr-coulomb", "matsuoka-nakai", "lade-duncan")}
    assert at_60["mohr-coulomb"] == pytest.approx(extension, rel=1e-9)
    # Matsuoka-Nakai meets Mohr-Coulomb in extension too; Lade-Duncan lies outside
    assert at_60["matsuoka-nakai"] == pytest.approx(extension, rel=1e-9)
    assert at_60["lade-duncan"] > extension * 1.01


def test_failure_surface_rejects_bad_input():
    with pytest.raises(InputError, match="criterion"):
        failure_surface(PHI, "tresca")
    with pytest.raises(InputError, match="phi"):
        failure_surface(math.pi / 2, "lade-duncan")


# -- figures on short runs ----------------------------------------------------------------------
def run(name: str, structure: str = "idealized", steps: int = 12, **changes) -> TestResult:
    model = build_model(build_structure(structure))
    parameters = {**default_path_parameters(name, model, steps), **changes}
    with warnings.catch_warnings():  # coarse steps leave some unconverged: not tested here
        warnings.simplefilter("ignore", GrainlabWarning)
        return run_element_test(model, preset(name, **parameters))


@pytest.fixture(scope="module")
def idealized_runs():
    return {
        "triaxial": run("triaxial_compression"),
        "extension": run("triaxial_extension"),
        "oedometer": run("oedometer", steps=16),
        "simple_shear": run("simple_shear", steps=10, k0_consolidation_steps=3),
        "circle": run("circular_octahedral", steps=12, approach_steps=3),
        "cyclic": run("cyclic_shear", steps=16, n_cycles=1),
    }


def axes_of(figure) -> int:
    assert isinstance(figure, Figure)
    return len(figure.axes)


def test_triaxial_figure(idealized_runs):
    figure = triaxial_figure([idealized_runs["triaxial"], idealized_runs["extension"]],
                             labels=["compression", "extension"])
    assert axes_of(figure) == 2
    assert len(figure.axes[0].lines) == 2


def test_triaxial_figure_2d_uses_biaxial_stress_ratio(tmp_path):
    from grainlab.prep.packing_files import write_packing

    packing = write_packing(named_packing("C"), tmp_path / "c.toml")
    result = run("biaxial", str(packing), steps=8)
    figure = triaxial_figure(result)
    assert axes_of(figure) == 2
    assert "(s1 + s3)/2" in figure.axes[0].get_ylabel()
    ratio = figure.axes[0].lines[0].get_ydata()
    assert np.all(ratio[np.isfinite(ratio)] <= 1.0)  # q/p = sin(phi) in 2D


def test_k0_figure(idealized_runs):
    figure = k0_figure(idealized_runs["oedometer"])
    assert axes_of(figure) == 2
    assert len(figure.axes[1].lines) == 1  # K0 against OCR on unloading
    assert min(figure.axes[1].lines[0].get_xdata()) == pytest.approx(1.0)


def test_simple_shear_figure(idealized_runs):
    figure = simple_shear_figure(idealized_runs["simple_shear"])
    assert axes_of(figure) == 4
    assert len(figure.axes[3].lines) == 6  # five angles and the zero line


def test_circular_path_figure(idealized_runs):
    assert axes_of(circular_path_figure(idealized_runs["circle"])) == 2


def test_hysteresis_figure(idealized_runs):
    assert axes_of(hysteresis_figure(idealized_runs["cyclic"])) == 1


def test_cyclic_figure():
    summary = TestResult.create(
        pd.DataFrame({"gamma_amplitude": [1e-4, 1e-6, 1e-5], "modulus_ratio": [0.8, 1.0, 0.95],
                      "damping_ratio": [0.05, 0.001, 0.01]}),
        specimen={}, load_path={"name": "cyclic_sweep"}, dimension=3)
    figure = cyclic_figure(summary)
    assert axes_of(figure) == 2
    assert all(ax.get_xscale() == "log" for ax in figure.axes)
    np.testing.assert_allclose(figure.axes[0].lines[0].get_xdata(), [1e-4, 1e-3, 1e-2])


def test_b_sweep_figure():
    b = np.array([0.0, 0.5, 1.0])
    table = pd.DataFrame({"b": b, "phi_peak": np.radians([40.0, 46.0, 44.0]),
                          "oct_x_over_p": [0.0, 0.5, 0.8], "oct_y_over_p": [1.3, 0.9, 0.45],
                          "deps_oct_x": [0.0, 1e-4, 2e-4], "deps_oct_y": [3e-4, 2e-4, 1e-4]})
    summary = TestResult.create(table, specimen={}, load_path={"name": "b_sweep"}, dimension=3)
    figure = b_sweep_figure(summary)
    assert axes_of(figure) == 3
    labels = [line.get_label() for line in figure.axes[1].lines]
    assert {"mohr-coulomb", "matsuoka-nakai", "lade-duncan"} <= set(labels)
    with pytest.raises(InputError, match="deps_oct_x"):
        b_sweep_figure(TestResult.create(table.drop(columns="deps_oct_x"), specimen={},
                                         load_path={}, dimension=3))


def test_oedometer_stages_figure_draws_k0_and_sigma_zz_by_stage():
    table = pd.DataFrame({
        "stage": ["compaction"] * 2 + ["loading"] * 3 + ["unloading"] * 2,
        "eps_zz": [0.2, 0.25, 0.0, 1e-3, 2e-3, 1.5e-3, 1e-3],
        "sigma_xx": [1e4, 1e4, 1e4, 2e4, 3e4, 2e4, 1.5e4],
        "sigma_yy": [1e4, 1e4, 1e4, 2e4, 3e4, 2.5e4, 1.5e4],
        "sigma_zz": [1e4, 1e4, 1e4, 4e4, 6e4, 3e4, 2e4]})
    figure = oedometer_stages_figure(TestResult.create(table, specimen={}, load_path={}))
    ax_k, ax_s = figure.axes
    assert "K0" in ax_k.get_ylabel() and "sigma_zz" in ax_s.get_ylabel()
    assert "eps_zz" in ax_k.get_xlabel()
    for ax in (ax_k, ax_s):
        assert [line.get_label() for line in ax.lines] == ["loading", "unloading"]
    loading, unloading = ax_k.lines
    # from the end of the compaction, at zero strain (strains are from its last box)
    np.testing.assert_allclose(loading.get_xdata(), [0.0, 0.0, 0.1, 0.2])  # percent
    np.testing.assert_allclose(loading.get_ydata(), [1.0, 1.0, 0.5, 0.5])
    # the unloading starts where the loading ended
    np.testing.assert_allclose(unloading.get_xdata(), [0.2, 0.15, 0.1])
    np.testing.assert_allclose(unloading.get_ydata(), [0.5, 0.75, 0.75])
    np.testing.assert_allclose(ax_s.lines[1].get_ydata(), [60.0, 30.0, 20.0])  # kPa


def test_a_discrete_simple_shear_is_drawn_from_zero_strain():
    """The row the shear starts from (the compaction's last) counts its strains from the
    initial cell; the shear's from its end: drawn at gamma = 0, not at the compaction's
    drift."""
    rows = {"stage": ["compaction", "shear", "shear"], "gamma_xy": [0.09, 0.01, 0.02],
            "sigma_xx": [1e4, 1e4, 1e4], "sigma_yy": [1e4, 1e4, 1e4],
            "sigma_xy": [0.0, 2e3, 3e3], "eps_xx": [0.1, 0.0, 0.0], "eps_yy": [0.1, 0.0, 0.0]}
    result = TestResult.create(pd.DataFrame(rows), specimen={}, load_path={}, dimension=2)
    figure = simple_shear_figure(result)
    np.testing.assert_allclose(figure.axes[0].lines[0].get_xdata(), [0.0, 1.0, 2.0])
