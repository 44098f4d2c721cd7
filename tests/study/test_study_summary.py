"""The summary's peak: a running mean over a stated width of eps_q, not the largest noisy row;
seed 002 eq. 11 applied to the residual q/p."""

from __future__ import annotations

import math

import numpy as np
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
