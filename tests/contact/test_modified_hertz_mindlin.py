"""The modified Hertz–Mindlin line-contact law of seed 000 (eqs. 17–19).

Eq. 17: 1/c_n = (1 - nu)/(2 pi G) [2 ln(2 r / a) - 1], a = (2 (1 - nu) f_n r / (pi G))^(1/2).
Eq. 18: 1/c_t = (Psi / c_n) [1 - f_t / (mu f_n)]^(-1/2).
Eq. 19: 1/r = (1/r_1 + 1/r_2) / 2.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.contact import ContactState2D, ModifiedHertzMindlin2D, equivalent_radius
from grainlab.errors import ConvergenceError, InputError

G, NU, PSI, PHI = 1.05e8, 0.1, 2.5, np.radians(15.0)
R = 0.00635  # equal rods of 0.5 in, r = r1 (eq. 19)


@pytest.fixture
def law():
    return ModifiedHertzMindlin2D.seed000()


def eq17_stiffness(force, radius, g=G, nu=NU):
    a = np.sqrt(2.0 * (1.0 - nu) * force * radius / (np.pi * g))
    return 1.0 / ((1.0 - nu) / (2.0 * np.pi * g) * (2.0 * np.log(2.0 * radius / a) - 1.0))


def test_seed000_constants(law):
    # the paper quotes 15000 psi as 105000 kN/m^2 (15000 psi is 103.4 MPa: a rounding)
    assert law.shear_modulus == pytest.approx(105000e3, rel=1e-12)
    assert law.shear_modulus == pytest.approx(15000 * 6894.757, rel=0.02)
    assert law.poisson_ratio == NU
    assert law.psi == PSI
    assert law.friction_coefficient == pytest.approx(np.tan(PHI), rel=1e-15)


def test_equivalent_radius():
    r1 = np.array([1.0, 0.5, 2.0, 3.0])
    r2 = np.array([1.0, 0.25, 2.0, 1.0])
    r = equivalent_radius(r1, r2)
    np.testing.assert_allclose(1.0 / r, 0.5 * (1.0 / r1 + 1.0 / r2), rtol=1e-15)
    assert r[0] == 1.0 and r[2] == 2.0  # equal discs: r = r1
    np.testing.assert_allclose(equivalent_radius(r2, r1), r, rtol=1e-15)  # symmetric


def test_half_width_is_hertz_for_cylinders(law):
    f = np.array([1.0, 100.0, 1e4])
    np.testing.assert_allclose(
        law.half_width(f, R), np.sqrt(2 * (1 - NU) * f * R / (np.pi * G)), rtol=1e-14
    )


@pytest.mark.parametrize("radius", [R, 0.003175, 0.05])
def test_normal_law_inverse(law, radius):
    forces = np.logspace(-3, np.log10(0.5 * float(law.largest_normal_force(radius))), 40)
    approach = law.normal_approach(forces, radius)
    assert np.all(np.diff(approach) > 0)  # monotonic
    np.testing.assert_allclose(law.normal_force(approach, radius), forces, rtol=1e-11)
    np.testing.assert_allclose(
        law.normal_approach(law.normal_force(approach, radius), radius), approach, rtol=1e-11
    )


def test_normal_stiffness_is_eq17(law):
    forces = np.logspace(-2, 5, 15)
    np.testing.assert_allclose(law.normal_stiffness(forces, R), eq17_stiffness(forces, R),
                               rtol=1e-13)


@pytest.mark.parametrize("force", [0.1, 10.0, 500.0, 2e4])
def test_normal_stiffness_is_the_derivative_of_the_force(law, force):
    """dF/d(delta) by central differences of the law itself equals c_n (eq. 17)."""
    h = 1e-4 * force
    approach = law.normal_approach(np.array([force - h, force, force + h]), R)
    slope = 2 * h / (approach[2] - approach[0])
    assert slope == pytest.approx(float(law.normal_stiffness(np.array([force]), R)[0]),
                                  rel=1e-6)
    # and from the force side
    d = approach[1]
    dd = 1e-5 * d
    fp, fm = law.normal_force(np.array([d + dd, d - dd]), R)
    assert (fp - fm) / (2 * dd) == pytest.approx(eq17_stiffness(force, R), rel=1e-6)


def test_open_contact_carries_no_force(law):
    approach = np.array([-1e-6, 0.0, -1.0])
    assert np.all(law.normal_force(approach, R) == 0.0)
    assert np.all(law.normal_stiffness(np.zeros(3), R) == 0.0)
    assert np.all(law.normal_approach(np.array([0.0, -5.0]), R) == 0.0)


def test_out_of_range_approach_raises(law):
    too_far = 2.0 * law.normal_approach(law.largest_normal_force(R), R)
    with pytest.raises(ConvergenceError):
        law.normal_force(np.array([too_far]), R)


def test_stiffness_ratio_is_psi_without_shear(law):
    fn = np.array([1.0, 100.0, 1e4])
    kn, kt = law.tangent_stiffness(fn, np.zeros(3), np.full(3, R))
    np.testing.assert_allclose(kn / kt, PSI, rtol=1e-14)


def test_tangential_stiffness_is_eq18(law):
    fn = np.full(5, 200.0)
    mu = np.tan(PHI)
    ft = np.array([0.0, 0.3, -0.6, 0.9, -0.999]) * mu * fn
    kn, kt = law.tangent_stiffness(fn, ft, np.full(5, R))
    compliance = PSI / kn * (1.0 - np.abs(ft) / (mu * fn)) ** -0.5
    np.testing.assert_allclose(kt, 1.0 / compliance, rtol=1e-12)
    # symmetric in the sign of the shear force
    _, kt_neg = law.tangent_stiffness(fn, -ft, np.full(5, R))
    np.testing.assert_allclose(kt_neg, kt, rtol=1e-15)


def test_tangential_stiffness_vanishes_at_sliding(law):
    fn = np.full(6, 50.0)
    mu = np.tan(PHI)
    mobilisation = 1.0 - np.logspace(-2, -12, 6)
    _, kt = law.tangent_stiffness(fn, mobilisation * mu * fn, np.full(6, R))
    assert np.all(np.diff(kt) < 0)
    assert kt[-1] < 1e-5 * kt[0]
    _, kt_slide = law.tangent_stiffness(np.array([50.0]), np.array([mu * 50.0]), np.array([R]))
    assert kt_slide[0] == 0.0


def loaded_state(law, fn, ft=None):
    fn = np.asarray(fn, dtype=float)
    ft = np.zeros_like(fn) if ft is None else np.asarray(ft, dtype=float)
    approach = law.normal_approach(fn, R)
    return ContactState2D(approach, law.normal_force(approach, R), ft, np.zeros(fn.shape, bool))


def test_pure_tangential_loading_follows_the_closed_form(law):
    """At fixed f_n, df_t/du = (c_n/Psi) sqrt(1 - f_t/T), T = mu f_n, integrates to
    f_t(u) = T (1 - (1 - c_n u / (2 Psi T))^2) until u = 2 Psi T / c_n, then f_t = T."""
    fn = 300.0
    state = loaded_state(law, [fn, fn])
    T = law.friction_coefficient * fn
    kn = float(eq17_stiffness(fn, R))
    u_slide = 2 * PSI * T / kn
    steps = 37
    du = 1.3 * u_slide / steps
    u = 0.0
    for _ in range(steps):
        state = law.update(state, np.zeros(2), np.array([du, -du]), np.full(2, R))
        u += du
        s = max(1.0 - kn * u / (2 * PSI * T), 0.0)
        expected = T * (1.0 - s**2)
        assert state.normal_force[0] == pytest.approx(fn, rel=1e-12)
        assert state.tangential_force[0] == pytest.approx(expected, rel=1e-9, abs=1e-12 * T)
        assert state.tangential_force[1] == pytest.approx(-expected, rel=1e-9, abs=1e-12 * T)
        assert bool(state.sliding[0]) == (u >= u_slide)


def test_tangential_force_does_not_depend_on_step_size_at_fixed_normal_force(law):
    fn = np.array([80.0])
    one = law.update(loaded_state(law, fn), np.zeros(1), np.array([2e-7]), np.array([R]))
    many = loaded_state(law, fn)
    for _ in range(20):
        many = law.update(many, np.zeros(1), np.array([1e-8]), np.array([R]))
    assert many.tangential_force[0] == pytest.approx(one.tangential_force[0], rel=1e-10)


def test_unloading_is_elastic_with_initial_stiffness(law):
    fn = 300.0
    T = law.friction_coefficient * fn
    state = loaded_state(law, [fn], [0.6 * T])
    kn = float(eq17_stiffness(fn, R))
    du = -1e-3 * T / kn
    after = law.update(state, np.zeros(1), np.array([du]), np.array([R]))
    assert after.tangential_force[0] == pytest.approx(0.6 * T + kn / PSI * du, rel=1e-12)
    # unloading through zero continues on the virgin curve in the other direction
    u_back = 0.6 * T / (kn / PSI) + 1e-3 * T / kn
    through = law.update(state, np.zeros(1), np.array([-u_back]), np.array([R]))
    u_rest = 1e-3 * T / kn
    expected = -T * (1.0 - (1.0 - kn * u_rest / (2 * PSI * T)) ** 2)
    assert through.tangential_force[0] == pytest.approx(expected, rel=1e-6)


def test_update_never_violates_coulomb(law):
    rng = np.random.default_rng(42)
    m = 64
    radius = rng.uniform(0.002, 0.01, m)
    fn = rng.uniform(10.0, 500.0, m)
    approach = law.normal_approach(fn, radius)
    state = ContactState2D(approach, law.normal_force(approach, radius), np.zeros(m),
                           np.zeros(m, bool))
    mu = law.friction_coefficient
    scale = float(np.median(approach))
    for _ in range(150):
        d_normal = rng.normal(0.0, 0.08 * scale, m)
        d_tangential = rng.normal(0.0, 0.3 * scale, m)
        state = law.update(state, d_normal, d_tangential, radius)
        assert np.all(state.normal_force >= 0.0)
        assert np.all(np.abs(state.tangential_force) <= mu * state.normal_force * (1 + 1e-12))
        opened = state.normal_approach <= 0
        assert np.all(state.normal_force[opened] == 0.0)
        assert np.all(state.tangential_force[opened] == 0.0)
        np.testing.assert_allclose(
            state.normal_force, law.normal_force(state.normal_approach, radius), rtol=1e-12
        )
        sliding = np.abs(state.tangential_force) >= (1 - 1e-9) * mu * state.normal_force
        np.testing.assert_array_equal(state.sliding, sliding & (state.normal_force > 0))


def test_separation_drops_all_forces(law):
    state = loaded_state(law, [100.0], [10.0])
    after = law.update(state, -2 * state.normal_approach, np.array([1e-6]), np.array([R]))
    assert after.normal_force[0] == 0.0
    assert after.tangential_force[0] == 0.0
    assert not after.sliding[0]


@pytest.mark.parametrize(
    ("field", "kwargs"),
    [
        ("psi", {"psi": 0.5}),
        ("poisson_ratio", {"poisson_ratio": 0.5}),
        ("shear_modulus", {"shear_modulus": -1.0}),
        ("friction_angle", {"friction_angle": np.pi / 2}),
    ],
)
def test_bad_parameters_named(field, kwargs):
    with pytest.raises(InputError, match=field):
        ModifiedHertzMindlin2D(**kwargs)


def _combined_loading_reference(normal_growth):
    """(delta0, a, b, exact f_t): f_n follows the normal law along delta0 + s a, s in [0, 1],
    while u_t = s b; eq. 18 integrated by an independent ODE solver (far from sliding)."""
    from scipy.integrate import solve_ivp

    fn0 = 200.0
    law = ModifiedHertzMindlin2D.seed000()
    delta0 = float(law.normal_approach(np.array([fn0]), R)[0])
    a = normal_growth * delta0
    mu = np.tan(PHI)
    b = 0.5 * 2 * PSI * mu * fn0 / float(eq17_stiffness(fn0, R))

    def rhs(s, y):
        fn = float(law.normal_force(np.array([delta0 + a * s]), R)[0])
        return [b * eq17_stiffness(fn, R) / PSI * np.sqrt(1.0 - y[0] / (mu * fn))]

    exact = solve_ivp(rhs, (0.0, 1.0), [0.0], rtol=1e-11, atol=1e-12 * fn0).y[0, -1]
    assert exact < 0.9 * mu * float(law.normal_force(np.array([delta0 + a]), R)[0])
    return delta0, a, b, exact


@pytest.mark.parametrize("normal_growth", [0.5, -0.15])
def test_tangential_integration_with_changing_normal_force(normal_growth):
    """Many small updates converge to the ODE solution of eq. 18 with a varying f_n; one big
    update is within the sub-stepping error."""
    delta0, a, b, exact = _combined_loading_reference(normal_growth)
    law = ModifiedHertzMindlin2D.seed000()
    start = ContactState2D(np.array([delta0]), law.normal_force(np.array([delta0]), R),
                           np.zeros(1), np.zeros(1, bool))
    state = start
    for _ in range(400):
        state = law.update(state, np.array([a / 400]), np.array([b / 400]), np.array([R]))
    assert state.tangential_force[0] == pytest.approx(exact, rel=1e-7)
    one = law.update(start, np.array([a]), np.array([b]), np.array([R]))
    assert one.tangential_force[0] == pytest.approx(exact, rel=5e-3)


def test_substeps_converge_to_the_ode_solution():
    delta0, a, b, exact = _combined_loading_reference(0.5)
    law = ModifiedHertzMindlin2D(substeps=512)
    start = ContactState2D(np.array([delta0]), law.normal_force(np.array([delta0]), R),
                           np.zeros(1), np.zeros(1, bool))
    one = law.update(start, np.array([a]), np.array([b]), np.array([R]))
    assert one.tangential_force[0] == pytest.approx(exact, rel=1e-5)
