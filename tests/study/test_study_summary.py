"""The summary's peak: a running mean over a stated width of eps_q, not the largest noisy row;
seed 002 eq. 11 applied to the residual q/p."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from grainlab.errors import InputError
from grainlab.study.study_summary import friction_angle, smoothed_peak


def noisy_peak(noise: float):
    # q/p = A - B (eps - eps0)^2 on rows every h = 1e-3, with a zero-mean fluctuation of
    # period 11 rows: over any 11 consecutive rows it sums to zero exactly
    h, a, b, eps0 = 1e-3, 0.45, 40.0, 0.031
    k = np.arange(120)
    eps = k * h
    q = a - b * (eps - eps0) ** 2 + noise * np.cos(2 * np.pi * k / 11 + 0.3)
    return eps, q, a, b, h, eps0


def test_smoothed_peak_is_the_running_mean_of_the_curve_not_of_its_noise():
    eps, q, a, b, h, eps0 = noisy_peak(0.02)
    peak, at = smoothed_peak(eps, q, 10.5 * h)  # 11 rows: j = -5 ... 5
    # mean of the parabola over the 11 rows about eps0: A - B h^2 (2 x 55 / 11) = A - 10 B h^2
    assert peak == pytest.approx(a - 10.0 * b * h**2, abs=1e-12)
    assert at == pytest.approx(eps0, abs=1e-12)
    raw = float(np.max(q))
    assert raw > a + 0.015  # the largest row carries the fluctuation
    assert smoothed_peak(eps, q, 0.0)[0] == pytest.approx(raw, abs=1e-12)  # cumulative sums


def test_smoothed_peak_ignores_row_order_and_nan_rows():
    eps, q, *_ = noisy_peak(0.01)
    order = np.random.default_rng(1).permutation(eps.size)
    q_nan = q.copy()
    q_nan[5] = np.nan
    assert smoothed_peak(eps[order], q_nan[order], 0.0105) == \
        smoothed_peak(eps, q_nan, 0.0105)
    assert all(math.isnan(v) for v in smoothed_peak(np.array([]), np.array([]), 0.01))
    with pytest.raises(InputError, match="peak_window"):
        smoothed_peak(eps, q, -0.01)


@pytest.mark.parametrize("q_over_p", [0.2, 0.4, 0.6])
def test_friction_angle_is_equation_11(q_over_p):
    assert math.sin(friction_angle(q_over_p)) == pytest.approx(3 * q_over_p / (2 + q_over_p))


def test_replicas_pool_into_one_point_with_the_spread_over_their_seeds():
    from grainlab.study.study_summary import pooled_replicas

    rng = np.random.default_rng(7)
    values = rng.normal(0.3, 0.02, 3)
    table = pd.DataFrame({
        "name": ["S1", "S4", "S8", "S1-seed1", "S1-seed2"],
        "replica_of": ["", "", "", "S1", "S1"], "seed": [0, 0, 0, 1, 2],
        "value": [0.0, 0.34, 1.27, 0.0, 0.0], "status": ["ended"] * 5,
        "q_over_trace_residual": [values[0], 0.4, 0.45, values[1], values[2]],
        "q_over_trace_residual_std": [0.01, 0.02, 0.03, 0.03, 0.02],
        "packing_fraction_initial": [0.60, 0.62, 0.61, 0.62, 0.58],
        "wall_time": [100.0, 200.0, 300.0, 110.0, 120.0]})
    pooled = pooled_replicas(table)
    assert list(pooled["name"]) == ["S1", "S4", "S8"]  # the series' order, one point each
    assert list(pooled["n_seeds"]) == [3, 1, 1]
    s1 = pooled.iloc[0]
    assert s1["q_over_trace_residual"] == pytest.approx(values.mean())
    assert s1["q_over_trace_residual_std"] == pytest.approx(values.std(ddof=1))
    assert s1["q_over_trace_residual_window_std"] == pytest.approx(0.02)
    # the initial state gets an error bar from the seeds too
    assert s1["packing_fraction_initial_std"] == pytest.approx(np.std([0.6, 0.62, 0.58],
                                                                      ddof=1))
    assert s1["wall_time"] == 330.0 and s1["seeds"] == "0,1,2" and s1["status"] == "ended"
    # a sample without replicas keeps its own values and its window's error bar
    s4 = pooled.iloc[1]
    assert s4["q_over_trace_residual"] == 0.4 and s4["q_over_trace_residual_std"] == 0.02
    # relabelling the replicas does not change the point
    shuffled = table.iloc[[4, 1, 3, 0, 2]].reset_index(drop=True)
    again = pooled_replicas(shuffled).set_index("name").loc["S1"]
    assert again["q_over_trace_residual"] == pytest.approx(s1["q_over_trace_residual"])
    assert again["q_over_trace_residual_std"] == pytest.approx(
        s1["q_over_trace_residual_std"])


def test_replicas_whose_own_sample_has_not_ended_still_make_their_point():
    from grainlab.study.study_summary import pooled_replicas

    table = pd.DataFrame({
        "name": ["S4", "S1-seed1", "S1-seed2", "S8-seed2"],
        "replica_of": ["", "S1", "S1", "S8"], "seed": [0, 1, 2, 2],
        "q_over_trace_residual": [0.34, 0.23, 0.25, 0.41],
        "q_over_trace_residual_std": [0.02, 0.01, 0.03, 0.02],
        "wall_time": [200.0, 110.0, 120.0, 300.0]})
    pooled = pooled_replicas(table)
    # one point per shape, in the table's order, none dropped
    assert list(pooled["name"]) == ["S4", "S1-seed1", "S8-seed2"]
    assert list(pooled["n_seeds"]) == [1, 2, 1]
    s1 = pooled.iloc[1]
    assert s1["q_over_trace_residual"] == pytest.approx(0.24)
    assert s1["q_over_trace_residual_std"] == pytest.approx(np.std([0.23, 0.25], ddof=1))
    assert s1["seeds"] == "1,2" and s1["wall_time"] == 230.0
    assert pooled.iloc[2]["seeds"] == "2"
    assert pooled.iloc[2]["q_over_trace_residual_std"] == 0.02  # its window's


@pytest.mark.parametrize("folder", ["angularity-periodic-1000", "nonconvexity-periodic-1000"])
def test_the_committed_series_tables_are_what_their_kept_digests_give(folder, tmp_path):
    """The committed series (slimmed: each sample's kept row and window average) summarised
    again from a copy give their committed summary.csv value for value, and every sample's
    capped share is within the series' bound: the published tables are the runs'."""
    import shutil
    from pathlib import Path

    from grainlab.report.size_check_report import CAPPED_BOUND
    from grainlab.study.study_runner import Study
    from grainlab.study.study_summary import study_summary

    source = Path(__file__).resolve().parents[2] / "studies" / folder
    copy = shutil.copytree(source, tmp_path / folder, ignore=shutil.ignore_patterns("report"))
    study_summary(Study.open(copy))
    again = pd.read_csv(copy / "summary.csv")
    committed = pd.read_csv(source / "summary.csv")
    assert list(again.columns) == list(committed.columns)
    assert again["name"].tolist() == committed["name"].tolist()
    for column in committed.columns:
        if pd.api.types.is_numeric_dtype(committed[column]):
            np.testing.assert_array_equal(again[column].to_numpy(float),
                                          committed[column].to_numpy(float), err_msg=column)
    assert (committed["status"] == "as asked").all()
    assert (committed["capped_share"] <= CAPPED_BOUND).all(), \
        committed[["name", "capped_share"]]
    # (q/p)* is the window's mean over the recorded rows (not over the fewer snapshots),
    # and sin phi* is eq. 11 of that (q/p)*
    lo, hi = Study.open(copy).spec.study.window
    for _, row in committed.iterrows():
        table = pd.read_csv(source / "samples" / row["name"] / "results.csv", comment="#")
        shear = table[table["stage"] != "compaction"]
        window = shear[(shear["eps_q"] >= lo) & (shear["eps_q"] <= hi)]
        assert len(window) > 50
        assert row["q_over_trace_residual"] == pytest.approx(
            window["q_over_trace"].mean(), rel=1e-12), row["name"]
        q = row["q_over_trace_residual"]
        assert row["sin_phi_star"] == pytest.approx(3 * q / (2 + q), rel=1e-12)
