"""The step of fast-spinning shapes (polyhedra) follows the particles: no point of a particle
travels more than max(factor x d_min, ALERT_TRAVEL x alert) in a step, times the step
growth's scale (lab.discrete_test)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from grainlab.engine.quaternion import quat_to_matrices
from grainlab.lab import discrete_run, discrete_test
from grainlab.lab.discrete_test import ALERT_TRAVEL, time_step_length
from grainlab.lab.run_config import RunConfig


def vertex_positions(sample) -> np.ndarray:
    """Every vertex of every polyhedron in world coordinates (V, 3) [m]."""
    library, state = sample.library, sample.state
    turns = quat_to_matrices(state.orientations)
    out = []
    for b, s in enumerate(state.shape_ids):
        start, count = library.vertex_start[s], library.vertex_count[s]
        out.append(state.positions[b] + library.vertices[start:start + count] @ turns[b].T)
    return np.concatenate(out)


def spinning_test(factor: float):
    """A polyhedra test in its first stage (time_step_factor ``factor``), one particle
    spinning at 2000 rad/s."""
    config = RunConfig.model_validate({
        "sample": {"shape": "polyhedron", "n_particles": 12, "n_faces": 20, "templates": 2,
                   "seed": 5},
        "test": {"kind": "triaxial"},
        "solver": {"compaction": {"time_step_factor": factor}}})
    test = discrete_run.test_for(discrete_run.build_sample(config), config)
    test.start_stage()
    state = test.sample.state
    state.angular_velocities[3] = [0.0, 0.0, 2000.0]  # one particle spins fast
    return test


@pytest.mark.parametrize("factor", [0.003, 0.05])
def test_no_point_travels_further_than_the_bound_in_a_step(factor):
    test = spinning_test(factor)
    library, state = test.sample.library, test.sample.state
    travel = max(factor * time_step_length(library),
                 ALERT_TRAVEL * test.solver.alert_distance(library))
    reach = np.linalg.norm(state.velocities, axis=1) + np.linalg.norm(
        state.angular_velocities, axis=1) * library.bounding_radius[state.shape_ids]
    h = test._particle_speed_step()
    assert h == pytest.approx(travel / reach.max(), rel=1e-12)
    free = test.sample.state  # a free flight of every particle over that step
    before = vertex_positions(test.sample)
    turn = h * free.angular_velocities
    q = Rotation.from_quat(free.orientations[:, [1, 2, 3, 0]])
    moved = (Rotation.from_rotvec(turn) * q).as_quat()[:, [3, 0, 1, 2]]
    free.orientations[:] = moved
    free.positions[:] += h * free.velocities
    assert np.max(np.linalg.norm(vertex_positions(test.sample) - before, axis=1)) \
        <= travel * (1 + 1e-9)


def test_a_factor_alone_bounds_the_travel_without_an_alert_distance(monkeypatch):
    test = spinning_test(0.003)  # the loading's factor
    library, state = test.sample.library, test.sample.state
    with_alert = test._particle_speed_step()
    monkeypatch.setattr(discrete_test, "ALERT_TRAVEL", 0.0)
    factor_only = test._particle_speed_step()
    reach = np.max(np.linalg.norm(state.angular_velocities, axis=1)
                   * library.bounding_radius[state.shape_ids])
    assert factor_only == pytest.approx(
        test.stage_numerics.time_step_factor * time_step_length(library) / reach, rel=1e-12)
    assert with_alert > factor_only  # in shear the alert distance allows the longer step


@pytest.mark.parametrize("factor", [0.003, 0.05])
def test_the_step_growth_scales_the_whole_travel(factor):
    """The overlap control's scale (lab/step_control.py) lengthens the particles' step in
    proportion, whichever bound (the factor's or the alert distance's) sets the travel."""
    test = spinning_test(factor)
    assert test._particle_speed_step(1.5) == pytest.approx(
        1.5 * test._particle_speed_step(), rel=1e-14)
