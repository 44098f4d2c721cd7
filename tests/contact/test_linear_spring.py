"""Linear springs with Coulomb friction: f_n = k_n delta, df_t = k_t du_t, |f_t| <= mu f_n."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.contact import ContactState2D, LinearSpring2D, friction_mobilisation, is_sliding
from grainlab.errors import InputError

KN, KT, PHI = 2.0e8, 8.0e7, np.radians(20.0)
R = np.array([0.005])


@pytest.fixture
def law():
    return LinearSpring2D(KN, KT, PHI)


def state_with(law, fn, ft=0.0):
    fn = np.atleast_1d(np.asarray(fn, float))
    ft = np.broadcast_to(np.asarray(ft, float), fn.shape).copy()
    approach = law.normal_approach(fn, np.full(fn.shape, R[0]))
    return ContactState2D(approach, law.normal_force(approach, R), ft, np.zeros(fn.shape, bool))


def test_normal_law_and_inverse(law):
    delta = np.array([-1e-6, 0.0, 1e-7, 3e-6])
    np.testing.assert_allclose(law.normal_force(delta, R), [0.0, 0.0, KN * 1e-7, KN * 3e-6])
    forces = np.array([1.0, 50.0, 1e4])
    np.testing.assert_allclose(law.normal_force(law.normal_approach(forces, R), R), forces,
                               rtol=1e-15)


@pytest.mark.parametrize("tilt_deg", [5.0, 15.0, 19.9, 20.1, 30.0, 60.0])
def test_block_on_an_incline(law, tilt_deg):
    """A block of weight W on a slope of angle theta: N = W cos theta, and the tangential
    displacement that would carry W sin theta elastically. It sticks (f_t = W sin theta)
    while tan theta < mu and otherwise slides with f_t = mu N."""
    weight = 400.0
    theta = np.radians(tilt_deg)
    normal = weight * np.cos(theta)
    demand = weight * np.sin(theta)
    state = state_with(law, normal)
    steps = 10
    for _ in range(steps):
        state = law.update(state, np.zeros(1), np.array([demand / KT / steps]), R)
        assert abs(state.tangential_force[0]) <= law.friction_coefficient * normal * (1 + 1e-12)
    assert state.normal_force[0] == pytest.approx(normal, rel=1e-12)
    if np.tan(theta) < np.tan(PHI):
        assert state.tangential_force[0] == pytest.approx(demand, rel=1e-12)
        assert not state.sliding[0]
    else:
        assert state.tangential_force[0] == pytest.approx(np.tan(PHI) * normal, rel=1e-12)
        assert state.sliding[0]


def test_sliding_saturates_and_unloading_is_elastic(law):
    fn = 100.0
    limit = np.tan(PHI) * fn
    state = state_with(law, fn)
    history = []
    du = 0.1 * limit / KT
    for _ in range(25):  # well past the slip displacement limit / KT
        state = law.update(state, np.zeros(1), np.array([du]), R)
        history.append(state.tangential_force[0])
    history = np.array(history)
    expected = np.minimum(KT * du * np.arange(1, 26), limit)
    np.testing.assert_allclose(history, expected, rtol=1e-12)
    assert state.sliding[0]
    # reverse: elastic unloading with k_t from the sliding force, no longer sliding
    back = law.update(state, np.zeros(1), np.array([-0.3 * du]), R)
    assert back.tangential_force[0] == pytest.approx(limit - 0.3 * du * KT, rel=1e-12)
    assert not back.sliding[0]
    # reverse all the way: slides the other way at -mu f_n
    far = law.update(state, np.zeros(1), np.array([-5 * limit / KT]), R)
    assert far.tangential_force[0] == pytest.approx(-limit, rel=1e-12)
    assert far.sliding[0]


def test_opening_releases_both_forces(law):
    state = state_with(law, 50.0, 5.0)
    opened = law.update(state, -2 * state.normal_approach, np.array([1e-6]), R)
    assert opened.normal_force[0] == 0.0
    assert opened.tangential_force[0] == 0.0
    assert bool(opened.open[0])


def test_normal_unloading_pulls_the_shear_force_onto_the_bound(law):
    fn = 100.0
    state = state_with(law, fn, 0.9 * np.tan(PHI) * fn)
    # halve the normal force: the old shear force exceeds the new bound
    after = law.update(state, np.array([-0.5 * fn / KN]), np.zeros(1), R)
    assert after.normal_force[0] == pytest.approx(0.5 * fn)
    assert after.tangential_force[0] == pytest.approx(np.tan(PHI) * 0.5 * fn, rel=1e-12)
    assert after.sliding[0]


def test_tangent_stiffness(law):
    fn = np.array([0.0, 100.0, 100.0, 100.0])
    ft = np.array([0.0, 0.0, 0.5, 1.0]) * np.tan(PHI) * 100.0
    kn, kt = law.tangent_stiffness(fn, ft, np.full(4, R[0]))
    np.testing.assert_array_equal(kn, [0.0, KN, KN, KN])
    np.testing.assert_array_equal(kt, [0.0, KT, KT, 0.0])


def test_coulomb_helpers():
    fn = np.array([-1.0, 0.0, 10.0, 10.0])
    ft = np.array([0.0, 0.0, 2.0, 5.0])
    mob = friction_mobilisation(fn, ft, 0.5)
    np.testing.assert_allclose(mob, [0.0, 0.0, 0.4, 1.0])
    np.testing.assert_array_equal(is_sliding(fn, ft, 0.5), [False, False, False, True])


@pytest.mark.parametrize(
    ("field", "args"),
    [
        ("normal_stiffness", (0.0, 1.0, 0.3)),
        ("tangential_stiffness", (1.0, -1.0, 0.3)),
        ("friction_angle", (1.0, 1.0, 0.0)),
    ],
)
def test_bad_parameters_named(field, args):
    with pytest.raises(InputError, match=field):
        LinearSpring2D(*args)
