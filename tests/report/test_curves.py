"""Standard curves: a micro-element prediction and a discrete simulation of the same
triaxial test overlaid by ``plot_curves`` with no glue (one meaning per column)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from grainlab.errors import GrainlabWarning
from grainlab.lab.discrete_run import start_run
from grainlab.lab.element_test import run_element_test
from grainlab.lab.micro_element_setup import build_model, build_structure, default_path_parameters
from grainlab.lab.presets import preset
from grainlab.lab.run_config import RunConfig
from grainlab.report.curves import plot_curves
from grainlab.result import COLUMNS, TestResult, read_test_result

SHARED = ("sigma_xx", "sigma_yy", "sigma_zz", "sigma_1", "sigma_2", "sigma_3", "p", "q",
          "q_over_3", "q_over_trace", "sin_phi", "stress_ratio", "b", "eps_xx", "eps_yy",
          "eps_zz", "eps_vol", "eps_q")
"""Columns both specimens record, with the meaning of :mod:`grainlab.result.columns`."""


@pytest.fixture(scope="module")
def micro_element() -> TestResult:
    model = build_model(build_structure("idealized"))
    parameters = default_path_parameters("triaxial_compression", model, 12)
    with warnings.catch_warnings():  # coarse steps may leave some unconverged: not tested here
        warnings.simplefilter("ignore", GrainlabWarning)
        return run_element_test(model, preset("triaxial_compression", **parameters))


@pytest.fixture(scope="module")
def discrete(tmp_path_factory) -> TestResult:
    config = RunConfig.model_validate({
        "sample": {"n_particles": 40, "seed": 4},
        "test": {"kind": "triaxial", "eps_q_max": 0.02},
        "solver": {"sweep": "serial",
                   "compaction": {"inertia_number": 0.05, "max_iterations": 400},
                   "shear": {"inertia_number": 0.01, "overlap_recovery": 0.0}},
        "output": {"record_every": 10, "checkpoint_every": 0, "snapshot_every": 0},
    })
    folder = tmp_path_factory.mktemp("run") / "triaxial"
    start_run(folder, config).run()
    return read_test_result(folder / "results.csv")  # as a user reads it back


COMPONENTS = {(0, 0): "xx", (1, 1): "yy", (2, 2): "zz", (1, 2): "yz", (0, 2): "xz",
              (0, 1): "xy"}


def principal_values(table, kind: str) -> np.ndarray:
    """(n, 3) principal stresses (``kind`` "sigma") or strains ("eps"), descending, from the
    component columns (absent shear strains are zero; gamma = 2 eps)."""
    tensors = np.zeros((len(table), 3, 3))
    for (i, j), axes in COMPONENTS.items():
        if kind == "sigma":
            values = table[f"sigma_{axes}"]
        elif i == j:
            values = table[f"eps_{axes}"]
        else:
            values = 0.5 * table[f"gamma_{axes}"] if f"gamma_{axes}" in table else 0.0 * table["p"]
        tensors[:, i, j] = tensors[:, j, i] = np.asarray(values, dtype=float)
    return np.linalg.eigvalsh(tensors)[:, ::-1]


def sheared(result: TestResult):
    """The rows of the shear stage (not the start, compaction or consolidation)."""
    table = result.table
    return table[~table["stage"].isin(("initial", "compaction", "consolidation"))]


@pytest.mark.parametrize("which", ["micro_element", "discrete"])
def test_every_shared_column_has_the_registry_meaning(which, request):
    result = request.getfixturevalue(which)
    t = result.table
    assert set(SHARED) <= set(t.columns)
    for name in SHARED:
        assert result.units[name] == COLUMNS[name].unit, name
    principal = principal_values(t, "sigma")
    scale = float(t["p"].abs().max())
    for k, name in enumerate(("sigma_1", "sigma_2", "sigma_3")):
        np.testing.assert_allclose(t[name], principal[:, k], rtol=0, atol=1e-9 * scale)
    q = principal[:, 0] - principal[:, 2]
    trace = principal.sum(axis=1)
    np.testing.assert_allclose(t["q"], q, rtol=0, atol=1e-9 * scale)  # sigma_1 - sigma_3
    np.testing.assert_allclose(t["q_over_3"], q / 3, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(t["p"], trace / 3, rtol=1e-12)
    loaded = trace > 0
    np.testing.assert_allclose(t["q_over_trace"][loaded], (t["q_over_3"] / t["p"])[loaded],
                               rtol=1e-9)  # the seeds' q/p
    np.testing.assert_allclose(t["sin_phi"][loaded],
                               (q / (principal[:, 0] + principal[:, 2]))[loaded], rtol=1e-9)
    strains = principal_values(t, "eps")
    np.testing.assert_allclose(t["eps_vol"], t[["eps_xx", "eps_yy", "eps_zz"]].sum(axis=1),
                               rtol=0, atol=1e-15)
    np.testing.assert_allclose(t["eps_q"], strains[:, 0] - strains[:, 2], rtol=0, atol=1e-12)


def test_a_prediction_and_a_simulation_overlay_with_no_glue(micro_element, discrete):
    results = [micro_element, discrete]
    for y, label in (("q_over_trace", "q_over_trace"), ("q", "q [Pa]"),
                     ("eps_vol", "eps_vol")):
        ax = plot_curves(results, "eps_q", y, labels=["micro-element", "discrete"])
        assert ax.get_xlabel() == "eps_q" and ax.get_ylabel() == label
        assert [line.get_label() for line in ax.lines] == ["micro-element", "discrete"]
        for line, result in zip(ax.lines, results, strict=True):
            np.testing.assert_array_equal(line.get_xdata(), result.column("eps_q"))
            np.testing.assert_array_equal(line.get_ydata(), result.column(y))
    # both are triaxial compressions along z: at the end the axial stress is the major one,
    # the seeds' q/p lies in (0, 1) and the axial strain is compressive
    for result in results:
        shear = sheared(result)
        assert len(shear) > 1
        last = shear.iloc[-1]
        assert last["sigma_zz"] > max(last["sigma_xx"], last["sigma_yy"])
        assert 0.0 < last["q_over_trace"] < 1.0 and last["eps_zz"] > 0.0
