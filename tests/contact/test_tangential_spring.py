"""The Mindlin tangential spring with its Coulomb cap and the rolling spring
(grainlab.contact.tangential_spring, grainlab.contact.rolling_resistance): analytic loading,
sliding on the Coulomb limit, the frame turn, and the branch-free forms against a plain
branching twin written here (same operations, so the same bits)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainlab.contact.rolling_resistance import rolling_spring
from grainlab.contact.tangential_spring import mindlin_coulomb, turn_with_frame

N = (0.0, 0.0, 1.0)


def test_a_sticking_spring_is_loaded_by_minus_k_t_u_t_dt():
    k_t, c_t, dt = 2.0e5, 3.0, 1.0e-6
    ft_x, _, _, hx, hy, hz = mindlin_coulomb(True, dt, 0.0, 0.0, 0.0, *N, 0.0, 0.5, 0.0, 0.0,
                                             k_t, c_t, 10.0)
    assert (hx, hy, hz) == (-k_t * dt * 0.5, 0.0, 0.0)
    assert ft_x == pytest.approx(-k_t * dt * 0.5 - c_t * 0.5, rel=1e-15)


def test_a_spring_only_read_keeps_its_force():
    out = mindlin_coulomb(False, 0.0, 0.1, -0.2, 0.0, *N, 7.0, 1.0, 2.0, 0.0, 1e6, 0.0, 10.0)
    assert out == (0.1, -0.2, 0.0, 0.1, -0.2, 0.0)


def test_a_sliding_contact_carries_the_coulomb_force_and_the_spring_that_gives_it():
    limit, c_t = 0.3, 0.05
    utx, uty = 0.4, -0.3
    ftx, fty, ftz, hx, hy, hz = mindlin_coulomb(True, 1e-3, 2.0, 1.0, 0.0, *N, 0.0, utx, uty,
                                                0.0, 1e4, c_t, limit)
    assert math.hypot(ftx, fty) == pytest.approx(limit, rel=1e-15)
    assert ftz == 0.0 and hz == 0.0
    assert (hx, hy) == pytest.approx((ftx + c_t * utx, fty + c_t * uty), rel=1e-15)


def test_the_frame_turn_keeps_the_length_in_the_new_tangent_plane():
    rng = np.random.default_rng(2)
    for _ in range(50):
        h = rng.normal(size=3)
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        t = np.array(turn_with_frame(*h, *n, rng.normal(), 1e-3))
        assert np.linalg.norm(t) == pytest.approx(np.linalg.norm(h), rel=1e-14)
        assert abs(t @ n) <= 1e-14 * np.linalg.norm(h)
    assert turn_with_frame(0.0, 0.0, 0.0, *N, 1.0, 1.0) == (0.0, 0.0, 0.0)
    assert turn_with_frame(0.0, 0.0, 2.0, *N, 1.0, 1.0) == (0.0, 0.0, 0.0)  # all normal


def test_a_rolling_spring_resists_rolling_not_twisting_and_is_capped():
    s_n, mu_r, r_eff, fn, dt = 1e5, 0.1, 1e-3, 2.0, 1e-5
    k_r = 2.25 * s_n * mu_r * mu_r * r_eff * r_eff
    m = rolling_spring(True, dt, 0.0, 0.0, 0.0, *N, 0.0, 3.0, 0.0, 50.0, s_n, mu_r, r_eff, fn)
    assert m == pytest.approx((-k_r * 3.0 * dt, 0.0, 0.0), rel=1e-15)  # the twist (z) is free
    capped = rolling_spring(False, 0.0, 1.0, 1.0, 0.0, *N, 0.0, 0.0, 0.0, 0.0, s_n, mu_r,
                            r_eff, fn)
    assert math.hypot(*capped) == pytest.approx(mu_r * r_eff * fn, rel=1e-15)


def _branching_twin(turn, dt, h, n, spin_n, ut, k_t, c_t, limit):
    """The spring as the kernels wrote it with branches (plain Python floats: IEEE double,
    no fused operations)."""
    hx, hy, hz = h
    if turn:
        hx, hy, hz = turn_with_frame(hx, hy, hz, *n, spin_n, dt)
        f = k_t * dt
        hx, hy, hz = hx - f * ut[0], hy - f * ut[1], hz - f * ut[2]
    ftx, fty, ftz = hx - c_t * ut[0], hy - c_t * ut[1], hz - c_t * ut[2]
    ft2 = ftx * ftx + fty * fty + ftz * ftz
    if ft2 > limit * limit:
        f = limit / math.sqrt(ft2)
        ftx, fty, ftz = f * ftx, f * fty, f * ftz
        hx, hy, hz = ftx + c_t * ut[0], fty + c_t * ut[1], ftz + c_t * ut[2]
    return ftx, fty, ftz, hx, hy, hz


def test_the_branch_free_spring_gives_the_bits_of_the_branching_one():
    rng = np.random.default_rng(7)
    slid = 0
    for trial in range(400):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        h, ut = rng.normal(size=3), rng.normal(size=3)
        args = (trial % 3 != 0, 1e-3 * rng.random(), tuple(h), tuple(n), rng.normal(),
                tuple(ut), 1e3 * rng.random(), rng.random(), 2.0 * rng.random())
        expected = _branching_twin(*args)
        turn, dt, h, n, spin_n, ut, k_t, c_t, limit = args
        got = mindlin_coulomb(turn, dt, *h, *n, spin_n, *ut, k_t, c_t, limit)
        assert got == expected
        slid += math.hypot(*expected[:3]) < math.hypot(*(np.array(h) - c_t * np.array(ut)))
    assert 50 < slid < 350  # both branches met
