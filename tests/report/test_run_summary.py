"""The summary of a discrete run in words (:mod:`grainlab.report.run_summary`): the values it
states are those of the results table (the end of the compaction, the peak, the residual
mean over the last 30 % of eps_q, an oedometer's K0), and its figures are written."""

from __future__ import annotations

import numpy as np
import pandas as pd

from grainlab.report.run_summary import RIGID_OEDOMETER, run_summary, write_run_figures
from grainlab.result.test_result import TestResult


def _result(kind: str, table: pd.DataFrame, stages: list[dict]) -> TestResult:
    return TestResult.create(
        table, specimen={"n_particles": 30, "shape": "sphere"}, load_path={"name": kind},
        parameters={"config": {"test": {"kind": kind, "axial_strain": 0.002,
                                        "unload_strain": 0.001, "sigma0": 1e4}}},
        outcome={"stages": stages}, dimension=3, title=f"{kind} of 30 spheres")


def _compaction_rows(n: int) -> pd.DataFrame:
    return pd.DataFrame({"stage": "compaction", "step": np.arange(n) * 10,
                         "time": np.arange(n) * 1e-3, "packing_fraction": 0.6,
                         "z": 4.5, "z_no_rattlers": 4.8, "z_c": 4.6, "p": 1e4,
                         "eps_zz": 0.0, "sigma_xx": 1e4, "sigma_yy": 1e4, "sigma_zz": 1e4})


def test_a_triaxial_summary_states_the_peak_and_the_residual_mean():
    eps_q = np.linspace(0.0, 0.1, 11)
    ratio = np.array([0.0, 0.2, 0.35, 0.42, 0.40, 0.36, 0.33, 0.31, 0.30, 0.30, 0.30])
    shear = pd.DataFrame({"stage": "shear", "step": 100 + np.arange(11) * 10,
                          "time": 1.0 + np.arange(11) * 1e-3, "eps_q": eps_q,
                          "q_over_trace": ratio, "packing_fraction": 0.58, "z": 4.0,
                          "z_no_rattlers": 4.2, "z_c": 4.1, "p": 1e4,
                          "inertia_number": np.linspace(1e-4, 9e-4, 11)})
    result = _result("triaxial", pd.concat([_compaction_rows(5), shear]), [])
    head, compaction, words = run_summary(result)
    assert head == "triaxial of 30 spheres: 16 rows, 200 steps"
    assert compaction.startswith("end of compaction: packing fraction 0.6000, z 4.500 "
                                 "(no rattlers 4.800), z_c 4.600, p 1e+04 Pa")
    # eps_q >= 0.07: the last four records, mean (0.31 + 3 x 0.30) / 4
    assert words.startswith("shear: peak q/p 0.4200; over the last 30 % of eps_q: q/p "
                            "0.3025, packing fraction 0.5800, z 4.000; max inertia number "
                            "9.00e-04")


def test_an_oedometer_summary_states_each_stage_against_what_was_asked(tmp_path):
    loading = pd.DataFrame({"stage": "loading", "step": [60, 70], "time": [1.0, 1.1],
                            "eps_zz": [0.001, 0.002], "sigma_zz": [2e4, 3e4],
                            "K0": [0.5, 0.45], "packing_fraction": 0.6, "z": 4.5,
                            "z_no_rattlers": 4.8, "z_c": 4.6, "p": 2e4, "eps_q": 0.0,
                            "q_over_trace": 0.0, "inertia_number": 1e-4})
    unloading = loading.assign(stage="unloading", step=[80, 90], eps_zz=[0.0015, 0.001],
                               sigma_zz=[1.5e4, 1.2e4], K0=[0.6, 0.7])
    table = pd.concat([_compaction_rows(5), loading, unloading])
    table["sigma_xx"] = table["sigma_yy"] = table["K0"].fillna(1.0) * table["sigma_zz"]
    result = _result("oedometer", table, [{"name": "loading", "steps": 20},
                                          {"name": "unloading", "steps": 20}])
    lines = run_summary(result)
    assert lines[2] == ("loading: to eps_zz 0.002 (asked 0.002) in 20 steps; at the end of "
                        "loading sigma_zz 3e+04 Pa, K0 0.4500")
    assert lines[3] == ("unloading: by 0.001 (asked 0.001) to eps_zz 0.001 in 20 steps; at "
                        "the end of unloading sigma_zz 1.2e+04 Pa, K0 0.7000")
    assert lines[4] == f"note: {RIGID_OEDOMETER}"
    figures = write_run_figures(tmp_path, result)
    assert figures == [tmp_path / "curves.png"] and figures[0].stat().st_size > 0
