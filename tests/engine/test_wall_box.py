"""Walls driven by velocity or stress, and the simulation's health checks."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.sample_measures import contact_stress
from grainlab.engine.simulation import Periodic, Simulation, SimulationBlowUp
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.prep.loose_sample import loose_sample

R = 1e-3
RHO = 2600.0


def one_sphere_in_box(height: float = 2.0 * R):
    library = ShapeLibrary.from_spheres([R])
    state = BodyState.from_library(library, [0], [[2 * R, 2 * R, R]], density=RHO)
    box = WallBox([0, 0, 0], [4 * R, 4 * R, height])
    return DiscreteSample(library, state, box, {})


def test_stress_wall_reaction_equals_sigma_times_area_at_rest():
    sample = one_sphere_in_box(height=2.0 * R + 1e-5)
    sigma = 1e3
    sample.box.set_control("z+", "stress", sigma)
    sample.box.set_masses(float(sample.state.masses[0]))
    step = ContactDynamicsStep(dt=1e-5, friction=0.0, tolerance=1e-10, max_iterations=100)
    for _ in range(400):
        step.step(sample.state, sample.library, sample.box)
    area = sample.box.face_areas[5]
    assert sample.box.reactions[5] == pytest.approx(sigma * area, rel=1e-6)
    assert sample.box.reactions[4] == pytest.approx(sigma * area, rel=1e-6)  # floor
    assert abs(sample.box.speeds[5]) < 1e-9
    assert sample.box.wall_stress[2] == pytest.approx(sigma * area / area, rel=1e-6)


def test_velocity_wall_moves_at_its_speed_and_pushes_the_sphere():
    sample = one_sphere_in_box(height=2.0 * R)
    sample.box.set_control("z+", "velocity", 0.0)
    sample.box.set_control("x+", "velocity", 0.01)  # moving in along -x
    x0 = sample.box.coordinates[1]
    step = ContactDynamicsStep(dt=1e-5, friction=0.0, tolerance=1e-10)
    for _ in range(150):
        step.step(sample.state, sample.library, sample.box)
    assert sample.box.coordinates[1] == pytest.approx(x0 - 150 * 1e-5 * 0.01, rel=1e-12)
    # the wall reached the sphere (gap 1 mm at 0.01 m/s = 0.1 s?) -> not yet: 15 um moved
    assert sample.state.velocities[0, 0] == 0.0
    fast = one_sphere_in_box()
    fast.box.set_control("x+", "velocity", 1.0)
    for _ in range(200):
        step.step(fast.state, fast.library, fast.box)
    # pushed: the sphere moves with the wall, never through it
    assert fast.state.velocities[0, 0] == pytest.approx(-1.0, rel=1e-6)
    assert fast.state.positions[0, 0] + R <= fast.box.coordinates[1] + 1e-9


def test_wall_box_validation_names_the_field():
    with pytest.raises(InputError, match="upper"):
        WallBox([0, 0, 0], [1, -1, 1])
    box = WallBox([0, 0, 0], [1, 1, 1])
    with pytest.raises(InputError, match="wall"):
        box.set_control("top", "stress", 1.0)
    with pytest.raises(InputError, match="wall stress"):
        box.set_control("z+", "stress", -5.0)
    with pytest.raises(InputError, match="wall_mass"):
        box.set_masses(0.0)


def test_box_round_trips_through_arrays():
    box = WallBox([0, 0, 0], [1, 2, 3], friction=0.3)
    box.set_control("y+", "stress", 7.0)
    box.set_control("z+", "velocity", 0.5)
    box.set_max_speeds(2.0)
    copy = WallBox.from_arrays(box.to_arrays())
    assert copy.controls == box.controls
    np.testing.assert_array_equal(copy.coordinates, box.coordinates)
    np.testing.assert_array_equal(copy.max_speeds, box.max_speeds)
    np.testing.assert_array_equal(copy.friction, box.friction)


def test_contact_stress_equals_wall_stress_in_equilibrium():
    """A compressed column of 3 spheres between the floor and a stress wall: the particle
    moment average (walls included) equals the wall stress exactly at rest."""
    library = ShapeLibrary.from_spheres([R])
    positions = [[2 * R, 2 * R, R], [2 * R, 2 * R, 3 * R], [2 * R, 2 * R, 5 * R]]
    state = BodyState.from_library(library, [0, 0, 0], positions, density=RHO)
    box = WallBox([0, 0, 0], [4 * R, 4 * R, 6 * R + 1e-6])
    box.set_control("z+", "stress", 500.0)
    box.set_masses(float(state.masses.sum()))
    step = ContactDynamicsStep(dt=1e-5, friction=0.0, tolerance=1e-12, max_iterations=200)
    for _ in range(300):
        report = step.step(state, library, box)
    stress = contact_stress(report, state, box.volume, step.dt)
    assert stress[2, 2] == pytest.approx(box.wall_stress[2], rel=1e-6)
    assert stress[2, 2] == pytest.approx(500.0 * box.face_areas[5] / box.face_areas[5]
                                         * 1.0, rel=1e-6)
    np.testing.assert_allclose(stress[:2, :2], 0.0, atol=1e-9)


def test_simulation_runs_operations_in_order_and_reports_blow_up():
    sample = loose_sample(n_particles=30, seed=2)
    sim = Simulation(sample, ContactDynamicsStep(dt=1e-5))
    calls = []

    class Op:
        def __init__(self, name, period):
            self.name, self.trigger = name, Periodic(period)

        def act(self, simulation):
            calls.append((simulation.step_index, self.name))

    sim.add(Op("a", 2))
    sim.add(Op("b", 1))
    with pytest.raises(InputError, match=r"operation\.name"):
        sim.add(Op("a", 3))
    sim.run(4)
    assert calls == [(1, "b"), (2, "a"), (2, "b"), (3, "b"), (4, "a"), (4, "b")]
    sample.state.velocities[3, 1] = np.nan
    with pytest.raises(SimulationBlowUp, match="non-finite velocities"):
        sim.step()


def test_runaway_overlap_is_diagnosed():
    sample = one_sphere_in_box()
    sample.state.positions[0, 2] = 0.5 * R  # half a radius into the floor
    sim = Simulation(sample, ContactDynamicsStep(dt=1e-5), max_overlap=0.1)
    with pytest.raises(SimulationBlowUp, match="runaway overlap"):
        sim.step()


def test_speed_limit_never_weakens_the_push_at_rest():
    """A speed-limited stress wall on a sphere at rest still pushes with sigma A: the limit
    is a brake (a unilateral constraint on the wall's speed), not a cap on its force."""
    sample = one_sphere_in_box(height=2.0 * R)
    sigma = 1e3
    sample.box.set_control("z+", "stress", sigma)
    sample.box.set_masses(float(sample.state.masses[0]))
    sample.box.set_max_speeds(1e-6)  # far below h sigma A / m
    step = ContactDynamicsStep(dt=1e-4, friction=0.0, tolerance=1e-10, max_iterations=100)
    for _ in range(20):
        step.step(sample.state, sample.library, sample.box)
    assert sample.box.reactions[5] == pytest.approx(sigma * sample.box.face_areas[5], rel=1e-6)
    # free of contact, the wall moves in at the limit
    free = one_sphere_in_box(height=4.0 * R)
    free.box.set_control("z+", "stress", sigma)
    free.box.set_masses(float(free.state.masses[0]))
    free.box.set_max_speeds(1e-3)
    step.step(free.state, free.library, free.box)
    assert free.box.speeds[5] == pytest.approx(1e-3, rel=1e-12)


def _servo_box(sample, sigma, limit, dt):
    sample.box.set_control("z+", "stress", sigma)
    sample.box.set_max_speeds(limit)
    sample.box.servo = True
    sample.box.set_masses(sample.box.servo_masses(dt))


def test_servo_wall_rests_at_its_stress_and_keeps_no_momentum():
    """An overdamped servo wall (no speed carried between steps, mass c h): free, it moves in
    at its limit; on a sphere it comes to rest pushing with sigma A; a sphere thrown at it
    pushes it out at G v_max (R / F - 1), at most OUTWARD_SPEED_FACTOR v_max, and as soon
    as the sphere is gone it moves in again, with no outward speed left."""
    from grainlab.engine.boundaries.wall_box import SERVO_GAIN
    from grainlab.engine.nscd.speed_limits import OUTWARD_SPEED_FACTOR

    sigma, limit, dt = 1e3, 1e-3, 1e-5
    step = ContactDynamicsStep(dt=dt, friction=0.0, tolerance=1e-10, max_iterations=100)
    free = one_sphere_in_box(height=4.0 * R)
    _servo_box(free, sigma, limit, dt)
    assert free.box.free_speeds(dt)[5] == pytest.approx(SERVO_GAIN * limit, rel=1e-12)
    step.step(free.state, free.library, free.box)
    assert free.box.speeds[5] == pytest.approx(limit, rel=1e-12)  # braked at the limit
    resting = one_sphere_in_box(height=2.0 * R)
    _servo_box(resting, sigma, limit, dt)
    for _ in range(50):
        step.step(resting.state, resting.library, resting.box)
    area = resting.box.face_areas[5]
    assert resting.box.reactions[5] == pytest.approx(sigma * area, rel=1e-6)
    assert abs(resting.box.speeds[5]) < 1e-9
    thrown = one_sphere_in_box(height=2.0 * R)
    _servo_box(thrown, sigma, limit, dt)
    thrown.state.velocities[0, 2] = 1.0  # up, into the wall, at 1000 v_max
    step.step(thrown.state, thrown.library, thrown.box)
    assert thrown.box.speeds[5] == pytest.approx(-OUTWARD_SPEED_FACTOR * limit, rel=1e-9)
    assert thrown.state.velocities[0, 2] == pytest.approx(OUTWARD_SPEED_FACTOR * limit,
                                                           rel=1e-6)  # held by the wall
    thrown.state.velocities[0] = [0.0, 0.0, -1.0]  # the sphere leaves
    thrown.state.positions[0, 2] = R
    step.step(thrown.state, thrown.library, thrown.box)
    assert thrown.box.speeds[5] == pytest.approx(limit, rel=1e-12)  # in again at once
    momentum = one_sphere_in_box(height=2.0 * R)  # a wall with mass keeps flying out
    momentum.box.set_control("z+", "stress", sigma)
    momentum.box.set_masses(float(momentum.state.masses[0]))
    momentum.state.velocities[0, 2] = 1.0
    step.step(momentum.state, momentum.library, momentum.box)
    momentum.state.velocities[0] = [0.0, 0.0, -1.0]
    momentum.state.positions[0, 2] = R
    step.step(momentum.state, momentum.library, momentum.box)
    assert momentum.box.speeds[5] < -0.1


def test_servo_walls_go_through_a_checkpoint():
    box = WallBox([0, 0, 0], [1, 1, 1])
    box.set_control("y+", "stress", 5e3)
    box.set_max_speeds(0.01)
    box.servo = True
    again = WallBox.from_arrays(box.to_arrays())
    assert again.servo
    np.testing.assert_allclose(again.servo_masses(1e-4), box.servo_masses(1e-4))
    np.testing.assert_allclose(box.servo_masses(1e-4)[3], 5e3 / (20.0 * 0.01) * 1e-4)


def test_solver_divergence_is_judged_by_the_residual():
    """Steps at the sweep cap count towards a divergence stop only when their natural-map
    residual is far from the tolerance: impulses that keep moving along a freedom of
    hyperstatic points (a large relative change) with a small residual do not stop a run."""
    from dataclasses import replace

    sample = one_sphere_in_box()
    solver = ContactDynamicsStep(dt=1e-5, tolerance=1e-4)
    sim = Simulation(sample, solver, max_unconverged=3)
    report = solver.step(sample.state, sample.library, sample.box)

    class Scripted:
        """The real solver's settings, a scripted report."""

        def __init__(self, residual, change):
            self.dt, self.tolerance, self.max_iterations = 1e-5, 1e-4, 200
            self.report = replace(report, converged=False, residual=residual, change=change)

        def step(self, *_):
            return self.report

    sim.solver = Scripted(residual=1.5e-4, change=0.02)
    sim.run(10)
    assert sim.unconverged_steps == 10 and sim.unconverged_in_row == 0
    sim.solver = Scripted(residual=0.05, change=1e-6)
    sim.run(2)
    with pytest.raises(SimulationBlowUp, match="solver divergence"):
        sim.step()
