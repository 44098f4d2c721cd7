"""Stress and strain invariants: the closed forms, the seeds' conventions, frame invariance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.result import COLUMNS, strain_invariants, stress_invariants


def random_rotation(rng, d: int) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(d, d)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def test_axisymmetric_compression_both_qs_and_the_seeds_ratio():
    s1, s3 = 4e4, 1e4
    row = stress_invariants(np.diag([s3, s1, s3]))
    p = (s1 + 2 * s3) / 3
    assert (row["sigma_1"], row["sigma_2"], row["sigma_3"]) == (s1, s3, s3)
    assert row["p"] == pytest.approx(p)
    assert row["q"] == pytest.approx(s1 - s3)
    assert row["q_over_3"] == pytest.approx((s1 - s3) / 3)
    ratio = row["q_over_3"] / row["p"]  # seed 002's q/p
    assert row["q_over_trace"] == pytest.approx(ratio)
    assert row["sin_phi"] == pytest.approx(3 * ratio / (2 + ratio))  # seed 002 eq. 11
    assert row["stress_ratio"] == pytest.approx(s1 / s3)
    assert row["b"] == pytest.approx(0.0)


def test_two_dimensional_names_and_ratio():
    row = stress_invariants(np.array([[3.0, 0.0], [0.0, 1.0]]))
    assert set(row) == {"sigma_1", "sigma_3", "p", "q", "q_over_3", "q_over_trace", "sin_phi",
                        "stress_ratio"}
    assert (row["p"], row["q"]) == (2.0, 2.0)
    # 2D: the seeds' q/p takes q = (s1 - s3)/2 and p = (s1 + s3)/2: it is sin phi
    assert row["q_over_trace"] == pytest.approx(0.5) == row["sin_phi"]


def test_every_invariant_is_a_registered_column():
    for d in (2, 3):
        assert set(stress_invariants(np.eye(d))) <= set(COLUMNS)
        assert set(strain_invariants(np.eye(d))) <= set(COLUMNS)


@pytest.mark.parametrize("d", [2, 3])
def test_invariants_do_not_depend_on_the_frame(d):
    rng = np.random.default_rng(d)
    a = rng.normal(size=(d, d))
    stress = a @ a.T + d * np.eye(d)  # a compressive state
    strain = 1e-3 * rng.normal(size=(d, d))
    rotation = random_rotation(rng, d)
    assert stress_invariants(rotation @ stress @ rotation.T) == pytest.approx(
        stress_invariants(stress), rel=1e-9)
    assert strain_invariants(rotation @ strain @ rotation.T) == pytest.approx(
        strain_invariants(strain), rel=1e-9, abs=1e-15)


def test_special_states_give_nan_not_warnings():
    iso = stress_invariants(1e4 * np.eye(3))
    assert iso["q"] == 0.0 and iso["sin_phi"] == 0.0 and math.isnan(iso["b"])
    zero = stress_invariants(np.zeros((3, 3)))
    assert all(math.isnan(zero[k]) for k in ("q_over_trace", "sin_phi", "stress_ratio", "b"))
    tension = stress_invariants(np.diag([1.0, -1.0]))
    assert math.isnan(tension["stress_ratio"])


def test_strain_invariants_of_a_box_and_of_a_shear():
    # a box: principal strains along the axes (seed 002 eqs. 9, 10)
    out = strain_invariants(np.diag([-0.01, -0.02, 0.05]))
    assert out["eps_vol"] == pytest.approx(0.02)
    assert out["eps_q"] == pytest.approx(0.07)
    # simple shear gamma: principal strains +-gamma/2
    gamma = 0.004
    out = strain_invariants(np.array([[0.0, gamma / 2], [gamma / 2, 0.0]]))
    assert out["eps_vol"] == 0.0 and out["eps_q"] == pytest.approx(gamma)


def test_bad_shapes_are_refused():
    with pytest.raises(InputError, match="stress"):
        stress_invariants(np.zeros(6))
    with pytest.raises(InputError, match="strain"):
        strain_invariants(np.zeros((4, 4)))
