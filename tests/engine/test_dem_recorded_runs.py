"""Regression on recorded soft-contact (DEM) runs (tests/engine/data/README.md): spheres,
aggregates and polyhedra in the servo-wall box and spheres in the servo periodic cell, each
through a short compaction and a little shear, give the results tables they gave when
recorded. Chaotic over their length: bit for bit on the suite's baseline numerics only
(tests/conftest.py, BASELINE_NUMERICS), so marked ``recorded_trajectory``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from dem_recorded_runs import CASES, run_case

DATA = Path(__file__).parent / "data"


@pytest.mark.recorded_trajectory
@pytest.mark.parametrize("name", list(CASES))
def test_a_dem_run_gives_the_results_it_gave_before(name, tmp_path):
    recorded = pd.read_csv(DATA / f"{name}.csv")
    table = run_case(name, tmp_path / name)
    assert list(table["stage"]) == list(recorded["stage"])
    assert list(dict.fromkeys(recorded["stage"])) == ["compaction", "shear"]
    assert list(table["step"]) == list(recorded["step"])
    for column in recorded.columns:
        if column == "stage":
            continue
        values = recorded[column].to_numpy(dtype=float)
        scale = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 0.0
        np.testing.assert_allclose(table[column].to_numpy(dtype=float), values, rtol=1e-9,
                                   atol=1e-12 * scale, err_msg=column)
