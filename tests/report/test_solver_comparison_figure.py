"""compare.png: both solvers on the same axes with a legend naming them, the test's own curves
(q/p, eps_vol and z against eps_q; sigma_zz, K0 and z against eps_zz; the compaction against
time), the stages after the compaction from zero strain."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_outcome import RunCost, RunOutcome
from grainlab.report.solver_comparison import solver_comparison_figure
from grainlab.result.test_result import TestResult


def run_result(method: str, kind: str, table: pd.DataFrame) -> TestResult:
    config = RunConfig.model_validate({"sample": {"n_particles": 30, "seed": 1},
                                       "test": {"kind": kind}, "solver": {"method": method}})
    result = TestResult.create(
        table, specimen={"shape": "sphere", "n_particles": 30, "seed": 1}, load_path={},
        parameters={"config": config.model_dump()},
        outcome=RunOutcome(stages=(), finished=True, steps=10).to_dict(), dimension=3)
    result.metadata["cost"] = RunCost(1.0, 10, 100 if method == "dem" else None).to_dict()
    return result


def table(kind: str, scale: float) -> pd.DataFrame:
    """A compaction (strains from the loose box), then the test's stages."""
    later = {"triaxial": ["shear"] * 3, "oedometer": ["loading", "loading", "unloading"],
             "compaction": []}[kind]
    stages = ["compaction"] * 2 + later
    n = len(stages)
    return pd.DataFrame({
        "stage": stages, "time": 0.1 * np.arange(1, n + 1), "step": 10 * np.arange(1, n + 1),
        "eps_q": [0.0, 0.02, *[0.01, 0.02, 0.03][:len(later)]],
        "eps_vol": [0.3, 0.4, *[0.001, 0.0, -0.002][:len(later)]],
        "eps_zz": [0.1, 0.15, *[0.001, 0.002, 0.0015][:len(later)]],
        "q_over_trace": scale * np.linspace(0.05, 0.3, n),
        "packing_fraction": np.linspace(0.4, 0.6, n), "z": scale * np.linspace(1, 4, n),
        "p": 1e4 * np.linspace(0.2, 1, n), "sigma_zz": 1e4 * scale * np.linspace(1, 3, n),
        "K0": np.linspace(1, 0.5, n)})


@pytest.mark.parametrize("kind, x_label, y_labels", [
    ("triaxial", "varepsilon_q", ("q/p", "varepsilon_\\mathrm{vol}", "coordination number z")),
    ("oedometer", "varepsilon_{zz}", ("sigma_{zz}", "K_0", "coordination number z")),
    ("compaction", "time [s]", ("packing fraction", "coordination number z", "p [Pa]")),
])
def test_both_solvers_are_drawn_on_the_same_axes_with_a_legend(kind, x_label, y_labels):
    figure = solver_comparison_figure({"cd": run_result("cd", kind, table(kind, 1.0)),
                                       "dem": run_result("dem", kind, table(kind, 0.9))})
    axes = figure.axes
    assert len(axes) == 3
    for ax, y_label in zip(axes, y_labels, strict=True):
        assert x_label in ax.get_xlabel() and y_label in ax.get_ylabel()
        assert len(ax.lines) == 2
        if kind != "compaction":  # from the end of the compaction, at zero strain
            assert all(line.get_xdata()[0] == 0.0 for line in ax.lines)
            assert all(len(line.get_xdata()) == 4 for line in ax.lines)
    legend = [text.get_text() for text in axes[0].get_legend().get_texts()]
    assert legend == ["contact dynamics (cd)", "soft-contact DEM (dem): linear, kappa = 10000"]
    assert "30 spheres" in figure._suptitle.get_text()
