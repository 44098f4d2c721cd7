"""curves.png of a discrete run and anisotropies.png of its snapshots: what a newcomer reads
off them (units on every axis, the run in the title, the shear from eps_q = 0, no legend over
the data, compaction snapshots not joined to the shear ones)."""

import numpy as np
import pandas as pd
import pytest

from grainlab.report.microstructure_figures import anisotropy_evolution_figure
from grainlab.report.run_curves import discrete_curves_figure, shear_from_its_start
from grainlab.result.test_result import TestResult

SOLVER = {"shear": {"friction": 0.4, "inertia_number": 1e-3}}
EARLIER_SOLVER = {"friction": 0.4, "inertia_number": 1e-3}
"""The [solver] table of a result's config, and as results written before [solver.shear]
held it."""


def _run_result(solver=SOLVER) -> TestResult:
    """A discrete triaxial result as a run writes it: compaction rows (strains from the loose
    box) then shear rows (strains from the start of the shear)."""
    compaction = pd.DataFrame({"stage": "compaction", "time": [0.1, 0.2, 0.3],
                               "eps_q": [0.0, 0.01, 0.015], "eps_vol": [0.3, 0.6, 0.64],
                               "q_over_trace": [0.5, 0.1, 0.04],
                               "packing_fraction": [0.35, 0.55, 0.57]})
    shear = pd.DataFrame({"stage": "shear", "time": [0.4, 0.5, 0.6],
                          "eps_q": [0.01, 0.02, 0.03], "eps_vol": [0.001, -0.002, -0.006],
                          "q_over_trace": [0.2, 0.28, 0.3],
                          "packing_fraction": [0.571, 0.569, 0.566]})
    config = {"test": {"kind": "triaxial", "sigma0": 1e4}, "solver": solver}
    return TestResult.create(pd.concat([compaction, shear], ignore_index=True),
                             specimen={"shape": "sphere", "n_particles": 300, "seed": 1},
                             load_path={}, parameters={"config": config}, dimension=3)


def test_the_shear_starts_at_zero_strain_from_the_end_of_compaction():
    shear = shear_from_its_start(_run_result().table)
    assert shear["stage"].tolist() == ["compaction", "shear", "shear", "shear"]
    assert shear["eps_q"].iloc[0] == 0.0 and shear["eps_vol"].iloc[0] == 0.0
    assert shear["packing_fraction"].iloc[0] == 0.57  # the state the shear starts from
    np.testing.assert_array_equal(shear["eps_q"].iloc[1:], [0.01, 0.02, 0.03])


@pytest.mark.parametrize("solver", [SOLVER, EARLIER_SOLVER])
def test_curves_have_units_a_title_stating_the_run_and_no_legend(solver):
    figure = discrete_curves_figure(_run_result(solver))
    axes = figure.axes
    assert len(axes) == 3
    for ax in axes:
        assert ax.get_xlabel().endswith("[-]") and ax.get_ylabel().endswith("[-]")
        assert ax.get_legend() is None
        assert ax.get_xlim()[0] == 0.0
        x = ax.lines[0].get_xdata()
        assert x[0] == 0.0 and np.all(np.diff(x) > 0)  # one curve, forward in eps_q
    title = figure._suptitle.get_text()
    for word in ("300 spheres", "triaxial", "10 kPa", "0.4", "0.001", "seed 1"):
        assert word in title


def test_anisotropies_have_y_labels_and_leave_the_compaction_snapshots_out():
    rng = np.random.default_rng(0)
    table = pd.DataFrame({"stage": ["compaction"] * 3 + ["shear"] * 4,
                          "eps_q": [0.0, 0.01, 0.015, 0.0, 0.01, 0.02, 0.03]})
    for column in ("a_c", "a_fn", "a_c_branch", "q_over_trace", "q_over_trace_27a"):
        table[column] = rng.uniform(0, 0.3, len(table))
    figure = anisotropy_evolution_figure(table)
    for ax in figure.axes:
        assert ax.get_ylabel() and ax.get_xlabel() == "eps_q [-]"
        for line in ax.lines:
            np.testing.assert_array_equal(line.get_xdata(), [0.0, 0.01, 0.02, 0.03])
