"""Seed 001's spring contact law: Hertz stiffness, Coulomb, separation, bonds, unloading."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.contact.spring_contact import (
    HERTZ_ALPHA,
    HERTZ_C1,
    SpringContactLaw,
    SpringState,
    mindlin_c2,
)
from grainlab.errors import InputError

N = np.array([[0.0, 0.0, 1.0]])
R = np.array([1e-3])


def state_with(law, normal_force, shear=(0.0, 0.0, 0.0), bonded=False):
    fn = np.array([normal_force])
    return SpringState(law.approach_of_normal_force(fn, R), fn, np.array([shear], float),
                       np.zeros(1, bool), np.array([bonded]))


def test_hertz_normal_law_integrates_eq_2_6():
    law = SpringContactLaw(shear_modulus=29e9, poisson_ratio=0.2, friction_angle=0.5)
    e_mu = 29e9 / 0.8
    for force in (0.01, 1.0, 50.0):
        approach = law.approach_of_normal_force(np.array([force]), R)
        h = 1e-6 * approach
        slope = (law.normal_force_of_approach(approach + h, R)
                 - law.normal_force_of_approach(approach - h, R)) / (2 * h)
        eq_26 = HERTZ_C1 * R * e_mu * (force / (R**2 * e_mu)) ** HERTZ_ALPHA
        assert slope[0] == pytest.approx(eq_26[0], rel=1e-6)
        kn, kr = law.stiffness(np.array([force]), np.zeros(1), R)
        assert kn[0] == pytest.approx(eq_26[0], rel=1e-12)
        assert kr[0] / kn[0] == pytest.approx(mindlin_c2(0.2), rel=1e-12)  # eq. 2.8


def test_mindlin_tangential_stiffness_vanishes_at_sliding():
    law = SpringContactLaw(shear_modulus=29e9, poisson_ratio=0.2, friction_angle=0.5)
    mu = np.tan(0.5)
    ratios = np.array([0.0, 0.5, 0.999, 1.0])
    kn, kr = law.stiffness(np.full(4, 10.0), ratios * mu * 10.0, np.full(4, 1e-3))
    np.testing.assert_allclose(kr / kn, mindlin_c2(0.2) * (1 - ratios) ** (1 / 3), rtol=1e-12)


def test_block_on_an_incline_sticks_then_slides():
    """Push a loaded contact sideways: elastic until |f_t| = mu f_n, then it slides with the
    excess returned as residual force (eqs. 2.3-2.4)."""
    law = SpringContactLaw(normal_stiffness=1e5, shear_stiffness=5e4,
                           friction_angle=np.radians(20))
    mu = np.tan(np.radians(20))
    state = state_with(law, 10.0)
    first_excess = None
    for _ in range(40):
        before = np.linalg.norm(state.shear_force[0])
        state, residual = law.update(state, np.array([[1e-5, 0.0, 0.0]]), N, R)
        shear = np.linalg.norm(state.shear_force[0])
        assert shear <= mu * state.normal_force[0] * (1 + 1e-12)
        if state.sliding[0] and first_excess is None:
            # the step that crosses the cone returns the trial's excess as residual
            first_excess = residual[0, 0]
            assert first_excess == pytest.approx(before + 0.5 - mu * 10.0, rel=1e-9)
    assert first_excess is not None and first_excess > 0
    assert state.sliding[0]
    assert np.linalg.norm(state.shear_force[0]) == pytest.approx(mu * 10.0, rel=1e-12)
    # Before reaching the cone the response is elastic with k_s.
    fresh, residual = law.update(state_with(law, 10.0), np.array([[1e-5, 0, 0]]), N, R)
    assert fresh.shear_force[0, 0] == pytest.approx(0.5) and not fresh.sliding[0]
    assert np.allclose(residual, 0.0)


def test_unloading_is_elastic_with_the_initial_stiffness():
    law = SpringContactLaw(shear_modulus=29e9, poisson_ratio=0.2, friction_angle=0.5)
    mu = np.tan(0.5)
    state = state_with(law, 10.0, shear=(0.9 * mu * 10.0, 0.0, 0.0))
    kn, _ = law.stiffness(np.array([10.0]), np.zeros(1), R)
    back, _ = law.update(state, np.array([[-1e-9, 0.0, 0.0]]), N, R)
    stiffness = (state.shear_force[0, 0] - back.shear_force[0, 0]) / 1e-9
    assert stiffness == pytest.approx(mindlin_c2(0.2) * kn[0], rel=1e-9)


def test_separation_and_reforming():
    law = SpringContactLaw(normal_stiffness=1e5, friction_angle=0.5)
    state = state_with(law, 1.0, shear=(0.1, 0.0, 0.0))
    opened, residual = law.update(state, np.array([[0.0, 0.0, -2e-5]]), N, R)
    assert opened.normal_force[0] == 0.0 and np.all(opened.shear_force == 0.0)
    assert opened.open[0]
    assert residual[0, 2] == pytest.approx(-1.0, rel=1e-9)  # 1 N - 2 N predicted = excess
    closed, _ = law.update(opened, np.array([[0.0, 0.0, 3e-5]]), N, R)
    assert closed.normal_force[0] == pytest.approx(1e5 * 2e-5, rel=1e-9)  # gap closed
    assert np.all(closed.shear_force == 0.0)  # tangential force restarts from zero


def test_bond_tension_then_permanent_break():
    law = SpringContactLaw(normal_stiffness=1e5, friction_angle=0.5,
                           bond_tensile_strength=0.5, bond_shear_strength=0.5)
    state = law.initial_state((1,), 3)
    assert state.bonded[0]
    pulled, _ = law.update(state, np.array([[0.0, 0.0, -3e-6]]), N, R)
    assert pulled.normal_force[0] == pytest.approx(-0.3) and pulled.bonded[0]
    broken, _ = law.update(pulled, np.array([[0.0, 0.0, -3e-6]]), N, R)
    assert not broken.bonded[0] and broken.normal_force[0] == 0.0
    pushed, _ = law.update(broken, np.array([[0.0, 0.0, 1e-5]]), N, R)
    assert not pushed.bonded[0] and pushed.normal_force[0] > 0


def test_frictional_and_rotational_invariance():
    law = SpringContactLaw(normal_stiffness=1e5, shear_stiffness=8e4, friction_angle=0.4)
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    state = state_with(law, 5.0)
    inc = np.array([[2e-5, -1e-5, 1e-6]])
    a, ra = law.update(state, inc, N, R)
    rotated_state = SpringState(state.normal_approach, state.normal_force,
                                state.shear_force @ q.T, state.sliding, state.bonded)
    b, rb = law.update(rotated_state, inc @ q.T, N @ q.T, R)
    np.testing.assert_allclose(b.shear_force, a.shear_force @ q.T, atol=1e-12)
    np.testing.assert_allclose(b.normal_force, a.normal_force)
    np.testing.assert_allclose(rb, ra @ q.T, atol=1e-12)


def test_bad_parameters_are_named():
    with pytest.raises(InputError, match="friction_angle"):
        SpringContactLaw(normal_stiffness=1.0, friction_angle=2.0)
    with pytest.raises(InputError, match="normal_stiffness"):
        SpringContactLaw(normal_stiffness=-1.0)
    with pytest.raises(InputError, match="poisson_ratio"):
        SpringContactLaw(shear_modulus=1e9, poisson_ratio=0.6)
