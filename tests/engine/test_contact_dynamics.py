"""Moreau-Jean / NSCD time step against closed forms: inelastic impact, resting and sliding
contact, rolling on an incline, a resting column (research/cd_engines.md 6.1-6.3; STYLE.md 11).

Incline cases (gravity g vertical, wall normal tilted by theta, friction mu, solid sphere
I = 2/5 m r^2): with rotation locked the sphere sticks if tan(theta) < mu and otherwise slides
with a = g (sin theta - mu cos theta). Free to rotate it rolls without slipping
(a = 5/7 g sin theta) if tan(theta) < 7 mu / 2, and otherwise slips with
a = g (sin theta - mu cos theta) (the friction torque spins it up, but the contact keeps slipping).
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.nscd.nlgs_parallel import nlgs_coloured_kernel
from grainlab.engine.nscd.serial_sweep import nlgs_kernel
from grainlab.engine.nscd.sweep_arrays import (
    BodyRows,
    CellRows,
    ContactRows,
    Motion,
    SolveSettings,
    SweepGroups,
    WallRows,
)
from grainlab.engine.simulation import Simulation, SimulationBlowUp
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import StepReport
from grainlab.errors import ConvergenceError, InputError, SolverDivergence
from grainlab.geometry.sphere_aggregate import tetrahedral_aggregate
from grainlab.prep.loose_sample import loose_sample

G = 9.81
R = 0.5
DT = 1e-3
TOL = 1e-5
FLOOR = ([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
NO_CELL = CellRows(np.zeros((3, 3)), np.zeros((0, 3, 3)), np.zeros(0), np.zeros(0),
                   np.zeros((0, 2)))  # no periodic cell


def spheres(positions, radius=R):
    library = ShapeLibrary.from_spheres([radius])
    state = BodyState.from_library(library, [0] * len(positions), positions, density=1000.0)
    return library, state


def assert_contact_laws(report: StepReport, mu: float, dt: float = DT, tol: float = TOL):
    """Signorini and Coulomb at every contact of one step (impulse scale: the largest P_n,
    velocity scale: g dt or the largest free velocity)."""
    assert report.converged, (report.iterations, report.change, report.residual)
    if report.n_contacts == 0:
        return
    p, u, gap = report.impulses, report.relative_velocity, report.contacts.gap
    p_scale = max(float(np.abs(p[:, 0]).max()), 1e-30)
    u_scale = max(G * dt, float(np.abs(u).max()))
    assert (p[:, 0] >= -tol * p_scale).all()
    slip_impulse = np.linalg.norm(p[:, 1:], axis=1)
    assert (slip_impulse <= mu * p[:, 0] * (1.0 + tol) + tol * p_scale).all()
    corrected = u[:, 0] + np.maximum(gap, 0.0) / dt
    assert (corrected >= -100.0 * tol * u_scale).all()  # no approach beyond tolerance
    active = p[:, 0] > tol * p_scale
    assert (np.abs(corrected[active]) <= 100.0 * tol * u_scale).all()  # complementarity


def test_head_on_collision_is_perfectly_inelastic_and_conserves_momentum():
    library, state = spheres([[0.0, 0.0, 0.0], [1.02, 0.0, 0.0]])
    state.velocities[0] = [1.0, 0.0, 0.0]
    state.velocities[1] = [-0.5, 0.0, 0.0]
    p0 = state.momentum().copy()
    step = ContactDynamicsStep(dt=DT, friction=0.4)
    # IQS lets the spheres close the gap g at q_m at most by g within a step, so the approach
    # velocity decays geometrically (g/h, g/(4h), ...) to 0: never a rebound
    previous = None
    for _ in range(100):
        report = step.step(state, library)
        assert_contact_laws(report, 0.4)
        np.testing.assert_allclose(state.momentum(), p0, rtol=1e-13, atol=1e-13)
        gap = np.linalg.norm(state.positions[1] - state.positions[0]) - 2 * R
        assert gap >= -1e-12
        approach = state.velocities[0, 0] - state.velocities[1, 0]
        assert approach >= -1e-12  # no separation, no rebound
        if previous is not None:
            assert approach <= previous + 1e-12
        previous = approach
    np.testing.assert_allclose(state.velocities[:, 0], 0.25, atol=1e-9)
    assert report.n_contacts == 1 and report.max_overlap < 1e-12  # in contact, at rest
    np.testing.assert_allclose(state.velocities[:, 1:], 0.0, atol=1e-15)


def test_dropped_sphere_comes_to_rest_on_wall_without_rebound():
    library, state = spheres([[0.0, 0.0, R + 0.02]])
    m = state.masses[0]
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G))
    landed = False
    for _ in range(400):
        report = step.step(state, library, FLOOR)
        assert_contact_laws(report, 0.4)
        assert state.positions[0, 2] - R >= -1e-12  # no penetration
        landed = landed or (report.n_contacts and report.impulses[0, 0] > 0.0)
        if landed:
            assert state.velocities[0, 2] <= 1e-12  # no rebound
    assert landed
    assert abs(state.velocities[0, 2]) < 1e-9
    assert report.impulses[0, 0] == pytest.approx(m * G * DT, rel=1e-6)
    assert report.iterations >= 1 and report.residual <= TOL


def incline_run(theta, mu, lock_rotation, n_steps=100):
    normal = np.array([-np.sin(theta), 0.0, np.cos(theta)])
    library, state = spheres([R * normal])
    if lock_rotation:
        state.inertias[:] = 1e20  # rotation effectively locked
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=mu)
    walls = ([[0.0, 0.0, 0.0]], [normal])
    for _ in range(n_steps):
        report = step.step(state, library, walls)
        assert_contact_laws(report, mu)
        assert report.n_contacts == 1
    downhill = -np.array([np.cos(theta), 0.0, np.sin(theta)])
    t = n_steps * DT
    np.testing.assert_allclose(state.velocities[0] @ normal, 0.0, atol=1e-12)
    return float(state.velocities[0] @ downhill) / t, state, report


def test_incline_sticks_when_rotation_locked_and_tan_below_mu():
    a, state, _ = incline_run(np.arctan(0.3), mu=0.4, lock_rotation=True)
    assert abs(a) < 1e-9
    np.testing.assert_allclose(state.velocities, 0.0, atol=1e-10)


@pytest.mark.parametrize("lock_rotation", [True, False])
def test_incline_slides_with_coulomb_acceleration(lock_rotation):
    # tan(theta) = 1 > 7 mu / 2 = 0.7: slips even when free to roll
    theta, mu = np.pi / 4, 0.2
    a, _, report = incline_run(theta, mu, lock_rotation)
    expected = G * (np.sin(theta) - mu * np.cos(theta))
    assert a == pytest.approx(expected, rel=1e-2)
    np.testing.assert_allclose(np.linalg.norm(report.impulses[0, 1:]),
                               mu * report.impulses[0, 0], rtol=1e-6)


def test_incline_rolls_without_slipping_below_seven_mu_over_two():
    theta, mu = np.arctan(0.5), 0.4  # tan = 0.5 < 1.4
    a, _, report = incline_run(theta, mu, lock_rotation=False)
    assert a == pytest.approx(5.0 / 7.0 * G * np.sin(theta), rel=1e-2)
    np.testing.assert_allclose(report.relative_velocity[0, 1:], 0.0, atol=1e-9)
    assert np.linalg.norm(report.impulses[0, 1:]) < mu * report.impulses[0, 0]


def test_column_of_five_spheres_rests_on_wall():
    n = 5
    library, state = spheres([[0.0, 0.0, R + 2 * R * k] for k in range(n)])
    start = state.positions.copy()
    m = state.masses[0]
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=0.4)
    iterations = []
    for _ in range(200):
        report = step.step(state, library, FLOOR)
        assert_contact_laws(report, 0.4)
        assert report.n_contacts == n
        iterations.append(report.iterations)
        wall = report.contacts.body_i < 0
        assert report.impulses[wall, 0].sum() == pytest.approx(n * m * G * DT, rel=1e-4)
    np.testing.assert_allclose(state.positions, start, atol=1e-8)
    assert report.max_overlap < 1e-8
    assert max(iterations) < step.max_iterations
    assert iterations[-1] <= iterations[0]  # warm start helps


def column_under_growing_gravity(extrapolation: float, n: int = 8, steps: int = 12):
    """A column of n spheres on the floor, gravity growing by 2 % of G a step: every force
    grows linearly in time. Returns the sweeps of each step and the floor impulses over
    n m g h."""
    library, state = spheres([[0.0, 0.0, R + 2 * R * k] for k in range(n)])
    m = state.masses[0]
    step = ContactDynamicsStep(dt=DT, friction=0.4, tolerance=1e-10,
                               warm_start_extrapolation=extrapolation)
    sweeps, floor = [], []
    for k in range(steps):
        g = G * (1.0 + 0.02 * k)
        step.gravity = np.array([0.0, 0.0, -g])
        state.velocities[:] = 0.0  # the forces alone change
        report = step.step(state, library, FLOOR)
        assert report.converged
        sweeps.append(report.iterations)
        wall = report.contacts.body_i < 0
        floor.append(report.impulses[wall, 0].sum() / (n * m * g * DT))
    return np.array(sweeps), np.array(floor)


def test_extrapolated_warm_start_follows_forces_that_grow_linearly():
    # lambda = 1 starts every step at its solution once two steps are known; lambda = 0
    # starts at the previous step's forces and sweeps the change down the column
    plain, plain_floor = column_under_growing_gravity(0.0)
    extrapolated, extrapolated_floor = column_under_growing_gravity(1.0)
    np.testing.assert_allclose(plain_floor, 1.0, rtol=1e-8)
    np.testing.assert_allclose(extrapolated_floor, 1.0, rtol=1e-8)
    assert (extrapolated[2:] == 1).all() and (plain[2:] > 1).all(), (plain, extrapolated)
    half, _ = column_under_growing_gravity(0.5)
    assert plain[2:].sum() > half[2:].sum() > extrapolated[2:].sum()


def test_extrapolated_warm_start_survives_a_checkpoint():
    library, state = spheres([[0.0, 0.0, R + 2 * R * k] for k in range(3)])
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=0.4)
    for _ in range(2):
        step.step(state, library, FLOOR)
    saved = step.warm_start_arrays()
    assert saved["earlier_keys"].size == 3 and saved["earlier_forces"].shape == (3, 3)
    again = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=0.4)
    again.restore_warm_start(saved)
    for key, value in again.warm_start_arrays().items():
        np.testing.assert_array_equal(value, saved[key], err_msg=key)
    older = {key: saved[key] for key in ("keys", "forces")}  # a checkpoint from before
    again.restore_warm_start(older)
    assert again.warm_start_arrays()["earlier_keys"].size == 0


@pytest.mark.parametrize("value", [-0.1, 1.5, float("nan")])
def test_warm_start_extrapolation_outside_zero_one_is_refused(value):
    with pytest.raises(InputError, match="warm_start_extrapolation"):
        ContactDynamicsStep(dt=DT, warm_start_extrapolation=value)


def test_pyramid_obeys_contact_laws_every_step():
    # three spheres on the floor (slightly apart) carrying a fourth; friction holds or slides
    base = [[np.cos(a) * 0.6, np.sin(a) * 0.6, R] for a in (0.0, 2.1, 4.2)]
    top = [[0.0, 0.0, R + np.sqrt((2 * R + 0.01) ** 2 - 0.36)]]
    library, state = spheres(base + top)
    mu = 0.3
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=mu, seed=3)
    for _ in range(100):
        report = step.step(state, library, FLOOR)
        assert_contact_laws(report, mu)
        assert report.n_contacts >= 3


def test_aggregate_settles_with_gyroscopic_term():
    agg = tetrahedral_aggregate(radius=0.25, lam=0.5)
    library = ShapeLibrary.from_aggregates([agg])
    height = float(agg.bounding_radius) + 0.01
    state = BodyState.from_library(library, [0], [[0.0, 0.0, height]], density=1000.0)
    state.angular_velocities[0] = [0.3, -0.2, 0.5]
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), gyroscopic=True)

    def energy():
        return state.kinetic_energy() + state.masses[0] * G * state.positions[0, 2]

    start = energy()
    for _ in range(400):
        report = step.step(state, library, FLOOR)
        assert_contact_laws(report, 0.4)
        assert report.max_overlap < 1e-6
        assert energy() <= start * (1.0 + 1e-9)  # contacts never create energy
    assert report.n_contacts >= 1
    np.testing.assert_allclose(np.linalg.norm(state.orientations, axis=1), 1.0, atol=1e-12)


def test_non_convergence_is_reported_and_strict_mode_raises():
    positions = [[0.0, 0.0, R + 2 * R * k] for k in range(5)]
    library, state = spheres(positions)
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), max_iterations=1)
    report = step.step(state, library, FLOOR)
    assert not report.converged and report.iterations == 1 and report.change > TOL
    library, state = spheres(positions)
    strict = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), max_iterations=1, strict=True)
    with pytest.raises(ConvergenceError, match="did not converge"):
        strict.step(state, library, FLOOR)


def test_kernel_with_no_contacts_returns_free_velocities():
    empty_i = np.zeros(0, dtype=np.int64)
    v_free = np.array([[1.0, 2.0, 3.0]])
    w_free = np.array([[0.1, 0.0, 0.0]])
    velocities, spins, residuals = np.empty((1, 3)), np.empty((1, 3)), np.ones(2)
    iterations = nlgs_kernel(
        ContactRows(empty_i, empty_i, np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                    np.zeros((0, 3)), np.zeros(0), np.zeros(0)),
        BodyRows(np.ones(1), np.eye(3)[None], v_free, w_free),
        WallRows(np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0)), NO_CELL,
        SolveSettings(DT, TOL, TOL, 10), empty_i,
        Motion(velocities, spins, np.zeros(0), np.zeros(0), np.zeros((3, 3))),
        np.zeros((0, 3)), np.zeros((0, 3, 3)), residuals,
    )
    assert iterations == 0
    np.testing.assert_array_equal(velocities, v_free)
    np.testing.assert_array_equal(spins, w_free)
    np.testing.assert_array_equal(residuals, 0.0)


def chain_kernel_arguments(free_velocity_z):
    """floor - sphere 0 - sphere 1 (unit masses, radius 0.5), both with free velocity
    (0, 0, ``free_velocity_z``): the arguments of the NLGS kernels up to the visiting order,
    and their outputs."""
    body, other = np.array([-1, 0]), np.array([0, 1])
    frame = np.tile(np.eye(3)[[2, 0, 1]], (2, 1, 1))
    arm_i = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.5]])
    arm_j = np.array([[0.0, 0.0, -0.5], [0.0, 0.0, -0.5]])
    v_free = np.array([[0.0, 0.0, free_velocity_z]] * 2)
    head = (ContactRows(body, other, frame, arm_i, arm_j, np.zeros((2, 3)), np.full(2, 0.4),
                        np.zeros(2)),
            BodyRows(np.ones(2), np.tile(np.eye(3), (2, 1, 1)), v_free, np.zeros((2, 3))),
            WallRows(np.array([[0.0, 0.0, 1.0]]), np.zeros(1), np.zeros(1), np.full(1, np.inf)),
            NO_CELL, SolveSettings(DT, TOL, TOL, 1000))
    outputs = (Motion(np.empty((2, 3)), np.empty((2, 3)), np.zeros(1), np.zeros(0),
                      np.zeros((3, 3))), np.zeros((2, 3)), np.empty((2, 3, 3)), np.zeros(2))
    return head, outputs


@pytest.mark.parametrize("sweep", ["serial", "coloured"])
def test_the_sweeps_stop_at_the_first_non_finite_sweep(sweep):
    head, outputs = chain_kernel_arguments(np.nan)
    if sweep == "serial":
        done = nlgs_kernel(*head, np.array([0, 1]), *outputs)
    else:
        groups = SweepGroups(np.array([0, 1]), np.array([0, 1, 2, 2]), np.array([0, 1, 2]),
                             np.array([0, 1]), 2)
        done = nlgs_coloured_kernel(*head, groups, *outputs)
    assert done == 1  # not the cap of 1000
    assert np.isnan(outputs[-1]).all()  # change and residual say it


@pytest.mark.parametrize("sweep", ["serial", "coloured"])
def test_a_step_whose_solve_overflows_raises_and_leaves_the_state_alone(sweep):
    # masses of ~5e159 kg: the impulses are finite, their squares are not
    library = ShapeLibrary.from_spheres([R])
    state = BodyState.from_library(library, [0, 0], [[0.0, 0.0, R], [0.0, 0.0, 3 * R]],
                                   density=1e160)
    state.velocities[:, 2] = -1.0
    before = {name: getattr(state, name).copy() for name in
              ("positions", "orientations", "velocities", "angular_velocities")}
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), sweep=sweep)
    with pytest.raises(SolverDivergence, match=r"diverged at sweep 1: .* the step was not "
                                               r"applied\. Reduce the time step \(dt = 0\.001 s\)"):
        step.step(state, library, FLOOR)
    for name, array in before.items():
        np.testing.assert_array_equal(getattr(state, name), array)


def test_a_step_refuses_a_non_finite_state_by_name():
    library, state = spheres([[0.0, 0.0, R], [0.0, 0.0, 3 * R]])
    state.velocities[1, 2] = np.inf
    with pytest.raises(InputError, match=r"state\.velocities\[1\] = \[0\.0, 0\.0, inf\]"):
        ContactDynamicsStep(dt=DT).step(state, library, FLOOR)


def test_a_diverged_step_stops_a_simulation_as_a_blow_up(monkeypatch):
    step = ContactDynamicsStep(dt=DT)
    simulation = Simulation(loose_sample(n_particles=5, seed=1), step)

    def diverging(*args):
        raise SolverDivergence("the contact solve (NLGS) diverged at sweep 3: ...")

    monkeypatch.setattr(step, "step", diverging)
    with pytest.raises(SimulationBlowUp, match=r"diverged at sweep 3: \.\.\. \(step 1, t = 0 s\)"):
        simulation.step()
    assert simulation.step_index == 0


@pytest.mark.parametrize("sweep", ["serial", "coloured"])
@pytest.mark.parametrize("change_tolerance", [None, np.inf])
def test_a_steps_flag_is_its_reported_change_and_residual_against_the_tolerances(
        sweep, change_tolerance):
    """converged is the kernel's own stop test on the change and residual reported (one
    evaluation), whether the step converged or hit its cap."""
    positions = [[0.0, 0.0, R + 2 * R * k] for k in range(5)]
    verdicts = set()
    for tolerance, cap in ((1e-4, 1000), (1e-12, 1000), (1e-5, 2), (1e-16, 50)):
        library, state = spheres(positions)
        step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), tolerance=tolerance,
                                   max_iterations=cap, sweep=sweep,
                                   change_tolerance=change_tolerance)
        limit = tolerance if change_tolerance is None else change_tolerance
        for _ in range(5):
            report = step.step(state, library, FLOOR)
            assert report.converged == (report.change <= limit
                                        and report.residual <= tolerance)
            assert report.converged or report.iterations == cap
            verdicts.add(report.converged)
    assert verdicts == {True, False}


@pytest.mark.long
def test_tumbling_aggregate_conserves_angular_momentum():
    """A free asymmetric aggregate (three spheres in an L) spinning about a non-principal axis:
    with the gyroscopic term its world angular momentum is conserved (semi-implicit step:
    drift within 1 % over a turn) and its kinetic energy does not grow; without the term
    omega stays fixed and L swings (the term matters)."""
    from grainlab.geometry.sphere_aggregate import from_spheres

    aggregate = from_spheres([[0.0, 0.0, 0.0], [1.2, 0.0, 0.0], [0.0, 0.7, 0.0]],
                             [0.5, 0.4, 0.3])
    library = ShapeLibrary.from_aggregates([aggregate])
    drift = {}
    for gyroscopic in (True, False):
        state = BodyState.from_library(library, [0], [[0.0, 0.0, 0.0]], density=1000.0)
        state.angular_velocities[0] = [3.0, 1.0, 2.0]
        state.velocities[0] = [0.1, -0.2, 0.05]
        l0, p0, e0 = state.angular_momentum(), state.momentum(), state.kinetic_energy()
        step = ContactDynamicsStep(dt=5e-4, gyroscopic=gyroscopic)
        worst = 0.0
        for _ in range(2000):  # about a turn
            step.step(state, library)
            worst = max(worst, float(np.linalg.norm(state.angular_momentum() - l0)
                                     / np.linalg.norm(l0)))
        np.testing.assert_allclose(state.momentum(), p0, rtol=1e-12)
        drift[gyroscopic] = worst
        if gyroscopic:
            assert state.kinetic_energy() <= e0 * (1 + 1e-9)
    assert drift[True] < 0.01
    assert drift[False] > 10 * drift[True]


@pytest.mark.parametrize("beta", [0.0, 0.05, 1.0])
def test_overlap_recovery_opens_an_overlap_by_beta_of_it_within_one_step(beta):
    """Two spheres at rest overlapping by delta: with U_n + beta g / h >= 0 they separate at
    exactly beta delta / h (momentum conserved); beta = 0 keeps them at rest (pure law)."""
    delta = 1e-3
    library, state = spheres([[0.0, 0.0, 0.0], [1.0 - delta, 0.0, 0.0]])
    step = ContactDynamicsStep(dt=DT, friction=0.4, tolerance=1e-10, overlap_recovery=beta)
    report = step.step(state, library)
    assert report.converged and report.contacts.gap[0] == pytest.approx(-delta)
    u_n = state.velocities[1, 0] - state.velocities[0, 0]
    assert u_n == pytest.approx(beta * delta / DT, rel=1e-9, abs=1e-15)
    np.testing.assert_allclose(state.momentum(), 0.0, atol=1e-15)
    with pytest.raises(InputError, match="overlap_recovery"):
        ContactDynamicsStep(dt=DT, overlap_recovery=1.5)


@pytest.mark.parametrize("cap_fraction", [0.25, 0.9, 2.0])
def test_overlap_recovery_speed_is_capped(cap_fraction):
    """With the cap v_r the spheres separate at min(beta delta / h, v_r): a short step can no
    longer turn a small overlap into a large separation speed."""
    delta, beta = 1e-3, 0.5
    uncapped = beta * delta / DT
    library, state = spheres([[0.0, 0.0, 0.0], [1.0 - delta, 0.0, 0.0]])
    step = ContactDynamicsStep(dt=DT, friction=0.4, tolerance=1e-10, overlap_recovery=beta)
    step.overlap_recovery_speed = cap_fraction * uncapped
    assert step.step(state, library).converged
    u_n = state.velocities[1, 0] - state.velocities[0, 0]
    assert u_n == pytest.approx(min(cap_fraction, 1.0) * uncapped, rel=1e-9)
    np.testing.assert_allclose(state.momentum(), 0.0, atol=1e-15)
    with pytest.raises(InputError, match="overlap_recovery_speed"):
        step.overlap_recovery_speed = 0.0
