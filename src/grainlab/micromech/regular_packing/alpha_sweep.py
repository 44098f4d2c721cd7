"""Seed 000's sweep over the loading direction alpha (Figs. 8 and 9).

For each alpha the rotated stress path is run; the strains, their ratios and the
non-coaxiality are then read at a common reference stress ratio (interpolated between recorded
increments), giving one row per alpha.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import pandas as pd

from grainlab.micromech.regular_packing.model import RegularPackingModel
from grainlab.micromech.regular_packing.stress_path import RotatedStressPath
from grainlab.micromech.regular_packing.stress_path_test import run_rotated_stress_path
from grainlab.result.test_result import TestResult

SUMMARY_COLUMNS = (
    "eps_xx", "eps_yy", "gamma_xy", "gamma_xy_over_eps_xx", "eps_xx_over_eps_yy",
    "noncoaxiality_deg",
)


def value_at_ratio(result: TestResult, column: str, ratio: float) -> float:
    """Linear interpolation of a table column at the stress ratio ``ratio``; NaN if the test
    failed before reaching it."""
    table = result.table[result.table["stage"] == "shear"]
    ratios = table["stress_ratio"].to_numpy()
    if ratios.size == 0 or ratio > ratios[-1] + 1e-12 or ratio < ratios[0] - 1e-12:
        return float("nan")
    return float(np.interp(ratio, ratios, table[column].to_numpy()))


def run_alpha_sweep(
    model: RegularPackingModel,
    alphas: Sequence[float],
    path: RotatedStressPath,
    reference_ratio: float = 1.5,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[TestResult, list[TestResult]]:
    """Run ``path`` (with its alpha replaced) for every alpha [rad].

    Returns the summary (one row per alpha: failure stress ratio, the :data:`SUMMARY_COLUMNS`
    at ``reference_ratio`` and the non-coaxiality of the first increment from the isotropic
    state) as a test result, and the individual results.
    """
    results, rows = [], []
    for k, alpha in enumerate(alphas):
        result = run_rotated_stress_path(model, replace(path, alpha=float(alpha)))
        results.append(result)
        row = {
            "alpha_deg": float(np.degrees(alpha)),
            "failure_stress_ratio": result.outcome.get("failure_stress_ratio", np.nan),
        }
        row.update({c: value_at_ratio(result, c, reference_ratio) for c in SUMMARY_COLUMNS})
        shear = result.table[result.table["stage"] == "shear"]
        row["initial_noncoaxiality_deg"] = (
            float(shear["noncoaxiality_deg"].iloc[0]) if len(shear) else np.nan
        )
        rows.append(row)
        if progress is not None:
            progress(k + 1, len(alphas))
    summary = TestResult.create(
        pd.DataFrame(rows),
        specimen=model.describe(),
        load_path={**path.describe(), "alpha_deg": [r["alpha_deg"] for r in rows],
                   "name": "alpha sweep of the rotated stress path (seed 000 Figs. 8-9)"},
        parameters={"reference_stress_ratio": reference_ratio},
        units={"alpha_deg": "deg", "failure_stress_ratio": "-",
               "gamma_xy_over_eps_xx": "-", "eps_xx_over_eps_yy": "-",
               "noncoaxiality_deg": "deg", "initial_noncoaxiality_deg": "deg"},
        dimension=2,
        title=f"packing {model.packing.name}: alpha sweep at stress ratio {reference_ratio:g}",
    )
    return summary, results
