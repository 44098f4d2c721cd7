"""The comparison of one test run with both solvers, on results made by hand: the measures are
the numbers of each run's table (peak and residual q/p, the state at the end of each stage, K0),
the cost is the one each run recorded, a pair of runs that are not the same test is refused
naming the key, and a run folder of another config is refused before anything is written."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.errors import InputError
from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_outcome import RunCost, RunOutcome
from grainlab.lab.solver_comparison import (
    SolverComparison,
    check_solver_run,
    solver_configs,
    solver_label,
)
from grainlab.result.test_result import TestResult


def run_result(method: str, kind: str, table: pd.DataFrame, *, cost: RunCost,
               as_asked: bool = True, seed: int = 1) -> TestResult:
    """A result as a discrete run writes it: the config, the outcome and the cost in its
    metadata."""
    config = RunConfig.model_validate({"sample": {"n_particles": 30, "seed": seed},
                                       "test": {"kind": kind},
                                       "solver": {"method": method, "dem": {"kappa": 1e3}}})
    outcome = RunOutcome(stages=(), finished=as_asked, steps=cost.steps,
                         stopped="" if as_asked else "stopped by hand")
    result = TestResult.create(table, specimen={"shape": "sphere", "n_particles": 30},
                               load_path={}, parameters={"config": config.model_dump()},
                               outcome=outcome.to_dict(), dimension=3)
    result.metadata["cost"] = cost.to_dict()
    return result


def triaxial_table(q_over_trace: list[float], offset: float = 0.0) -> pd.DataFrame:
    compaction = pd.DataFrame({"stage": "compaction", "time": [0.1, 0.2],
                               "packing_fraction": [0.5, 0.6 + offset], "z": [3.0, 4.0],
                               "z_no_rattlers": [4.0, 4.5], "p": [9e3, 1e4],
                               "eps_q": [0.0, 0.01], "eps_vol": [0.2, 0.3],
                               "q_over_trace": [0.1, 0.02]})
    n = len(q_over_trace)
    shear = pd.DataFrame({"stage": "shear", "time": 0.2 + 0.1 * np.arange(1, n + 1),
                          "packing_fraction": np.linspace(0.6, 0.58, n) + offset,
                          "z": np.linspace(4.0, 3.5, n), "z_no_rattlers": 4.0, "p": 1e4,
                          "eps_q": np.linspace(0.01, 0.1, n),
                          "eps_vol": np.linspace(0.0, -0.01, n),
                          "q_over_trace": q_over_trace})
    return pd.concat([compaction, shear], ignore_index=True)


@pytest.fixture()
def triaxial_pair():
    cd = run_result("cd", "triaxial", triaxial_table([0.2, 0.35, 0.3, 0.28, 0.26, 0.25]),
                    cost=RunCost(wall_time=20.0, steps=400))
    dem = run_result("dem", "triaxial",
                     triaxial_table([0.1, 0.3, 0.4, 0.3, 0.3, 0.2], offset=0.01),
                     cost=RunCost(wall_time=5.0, steps=800, substeps=24000), as_asked=False)
    return cd, dem


def rows(comparison: SolverComparison) -> pd.DataFrame:
    return comparison.table.set_index("quantity")


def test_the_table_holds_each_runs_measures_and_cost(triaxial_pair):
    cd, dem = triaxial_pair
    table = rows(SolverComparison().compute({"cd": cd, "dem": dem}))
    assert table.loc["peak_q_over_trace", "cd"] == 0.35
    assert table.loc["peak_q_over_trace", "dem"] == 0.4
    # residual: the records with eps_q >= 0.7 x 0.1 (the last two of six at 0.082, 0.1)
    assert table.loc["residual_q_over_trace", "cd"] == pytest.approx((0.26 + 0.25) / 2)
    assert table.loc["residual_q_over_trace", "dem"] == pytest.approx((0.3 + 0.2) / 2)
    assert table.loc["compaction_packing_fraction", "dem"] == pytest.approx(0.61)
    assert table.loc["compaction_z", "cd"] == 4.0
    assert table.loc["final_eps_vol", "cd"] == pytest.approx(-0.01)
    assert table.loc["wall_time", "dem_over_cd"] == 0.25
    assert table.loc["steps", "dem_minus_cd"] == 400
    assert math.isnan(table.loc["substeps", "cd"]) and table.loc["substeps", "dem"] == 24000
    assert table.loc["as_asked", "cd"] == 1.0 and table.loc["as_asked", "dem"] == 0.0
    assert math.isnan(table.loc["as_asked", "dem_over_cd"])
    assert table.loc["compaction_p", "unit"] == "Pa" and table.loc["wall_time", "unit"] == "s"


def test_the_pair_names_the_columns_and_the_reference(triaxial_pair):
    """The pair compared is a parameter (the registry's COMPARED by default): its first
    solver is the reference the differences are taken from, the columns named after both."""
    cd, dem = triaxial_pair
    assert SolverComparison().pair == ("cd", "dem")
    reverse = SolverComparison(pair=("dem", "cd")).compute({"cd": cd, "dem": dem})
    table = rows(reverse)
    assert list(table.columns[-2:]) == ["cd_minus_dem", "cd_over_dem"]
    assert table.loc["wall_time", "cd_over_dem"] == 4.0
    assert table.loc["steps", "cd_minus_dem"] == -400
    assert math.isnan(table.loc["as_asked", "cd_over_dem"])
    with pytest.raises(InputError, match=r"runs\['cd'\] sample\.seed.*as in the dem run"):
        other = run_result("cd", "triaxial", cd.table, cost=RunCost(5.0, 800), seed=2)
        SolverComparison(pair=("dem", "cd")).compute({"cd": other, "dem": dem})
    for pair in (("cd", "cd"), ("cd", "lattice"), ("cd",)):
        with pytest.raises(InputError, match="pair"):
            SolverComparison(pair=pair)


def test_an_oedometer_is_compared_at_the_end_of_each_stage():
    table = pd.DataFrame({
        "stage": ["compaction", "loading", "loading", "unloading"],
        "time": [0.1, 0.2, 0.3, 0.4], "packing_fraction": [0.6, 0.61, 0.62, 0.615],
        "z": [4.0, 4.2, 4.4, 4.1], "z_no_rattlers": 4.5, "p": 1e4,
        "eps_zz": [0.2, 0.001, 0.002, 0.0015], "sigma_zz": [1e4, 2e4, 4e4, 1.5e4],
        "K0": [1.0, 0.6, 0.5, 0.9]})
    cd = run_result("cd", "oedometer", table, cost=RunCost(10.0, 100))
    dem = run_result("dem", "oedometer", table.assign(K0=table["K0"] * 0.9),
                     cost=RunCost(8.0, 200, 5000))
    compared = rows(SolverComparison().compute({"cd": cd, "dem": dem}))
    assert compared.loc["loading_K0", "cd"] == 0.5
    assert compared.loc["loading_K0", "dem_over_cd"] == pytest.approx(0.9)
    assert compared.loc["unloading_sigma_zz", "cd"] == 1.5e4
    assert compared.loc["loading_eps_zz", "dem"] == 0.002
    assert "peak_q_over_trace" not in compared.index


def test_runs_that_are_not_the_same_test_are_refused(triaxial_pair):
    cd, dem = triaxial_pair
    other = run_result("dem", "triaxial", dem.table, cost=RunCost(5.0, 800, 24000), seed=2)
    with pytest.raises(InputError, match=r"sample\.seed.*same sample"):
        SolverComparison().compute({"cd": cd, "dem": other})
    with pytest.raises(InputError, match=r"runs\['dem'\].*solver\.method = 'dem'"):
        SolverComparison().compute({"cd": cd, "dem": cd})
    with pytest.raises(InputError, match=r"'cd' and 'dem'"):
        SolverComparison().compute({"cd": cd})
    with pytest.raises(NotComputedError, match="compute"):
        _ = SolverComparison().table


def test_the_solvers_are_named_with_the_dem_law(triaxial_pair):
    cd, dem = triaxial_pair
    assert solver_label(cd) == "contact dynamics (cd)"
    assert solver_label(dem) == "soft-contact DEM (dem): linear, kappa = 1000"


def test_the_two_configs_differ_in_the_method_only_and_a_folder_of_another_run_is_refused(
        tmp_path):
    asked = RunConfig.model_validate({"sample": {"n_particles": 30, "seed": 4},
                                      "test": {"kind": "compaction"},
                                      "solver": {"dem": {"kappa": 1e3}}})
    configs = solver_configs(asked)
    cd, dem = (configs[m].model_dump() for m in ("cd", "dem"))
    assert cd["solver"].pop("method") == "cd" and dem["solver"].pop("method") == "dem"
    assert cd == dem
    folder = tmp_path / "dem"
    folder.mkdir()
    configs["dem"].with_updates({"sample": {"seed": 5}}).write(folder / "config.toml")
    (folder / "results.h5").write_bytes(b"")  # a run that ended
    with pytest.raises(InputError, match=r"sample\.seed = 4 .*expected 5, the value of the run"):
        check_solver_run(folder, configs["dem"])
    # how a run is solved and written may differ: the folder's run keeps its own
    configs["dem"].with_updates({"solver": {"max_stage_steps": 10}}).write(
        folder / "config.toml")
    check_solver_run(folder, configs["dem"])
    # a test target may not: a run that ended at another strain cannot be extended
    configs["dem"].with_updates({"test": {"eps_q_max": 0.2}}).write(folder / "config.toml")
    with pytest.raises(InputError, match=r"test\.eps_q_max"):
        check_solver_run(folder, configs["dem"])
    check_solver_run(folder, configs["dem"], overwrite=True)


def test_the_soft_contact_solver_refuses_rolling_resistance_on_polyhedra_up_front():
    polyhedra = RunConfig.model_validate({"sample": {"shape": "polyhedron"},
                                          "solver": {"method": "dem",
                                                     "dem": {"rolling_friction": 0.1}}})
    with pytest.raises(InputError, match=r"solver\.dem\.rolling_friction = 0\.1.*polyhedra"):
        polyhedra.check_solver()
    RunConfig.model_validate({"sample": {"shape": "aggregate"},
                              "solver": {"method": "dem", "dem": {"rolling_friction": 0.1}}}
                             ).check_solver()
    RunConfig.model_validate({"sample": {"shape": "polyhedron"},
                              "solver": {"method": "dem"}}).check_solver()
