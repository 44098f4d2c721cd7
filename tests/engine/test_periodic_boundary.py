"""The periodic deformable cell in the contact-dynamics step: affine motion of free particles,
contacts through the cell's faces, invariance under the origin, the primary image and a
rotation, re-mapping, and the stress servo."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from grainlab.analysis.contact_stress import stress_from_network
from grainlab.engine.boundaries.periodic_boundary import PeriodicCell
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.sample_measures import cell_stress, contact_network
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError

R = 0.5e-3
DENSITY = 2600.0


def spheres(positions, radius=R):
    library = ShapeLibrary.from_spheres([radius])
    state = BodyState.from_library(library, [0] * len(positions), positions, density=DENSITY)
    return library, state


def lattice_sample(seed: int = 0, n_side: int = 4, jitter: float = 0.15):
    """n_side^3 spheres of radius R on a jittered cubic lattice of spacing 2.1 R in a
    periodic cube, with random velocities."""
    rng = np.random.default_rng(seed)
    spacing = 2.1 * R
    grid = np.stack(np.meshgrid(*[np.arange(n_side)] * 3, indexing="ij"), -1).reshape(-1, 3)
    positions = (grid + 0.5) * spacing + rng.uniform(-jitter, jitter, (len(grid), 3)) * \
        (spacing - 2 * R)
    library, state = spheres(positions)
    state.velocities[:] = rng.normal(0.0, 1e-3, state.velocities.shape)
    return library, state, np.eye(3) * n_side * spacing


def test_free_particles_follow_a_homogeneous_deformation_affinely():
    # three far-apart spheres in a big cell under shear + compression: no contacts, and the
    # fractional coordinates of every particle stay constant (x = h s)
    h0 = np.diag([0.02, 0.02, 0.02])
    library, state = spheres([[0.003, 0.004, 0.005], [0.012, 0.006, 0.015],
                              [0.016, 0.017, 0.009]])
    cell = PeriodicCell(h0, max_skew=np.inf)
    gradient = np.array([[-0.5, 0.0, 2.0], [0.0, 0.3, 0.0], [0.0, 0.0, -0.8]])
    cell.set_control(gradient)
    fractional = np.linalg.solve(h0, state.positions.T).T
    step = ContactDynamicsStep(dt=1e-3, friction=0.4)
    for _ in range(200):
        report = step.step(state, library, cell)
        assert report.n_contacts == 0
    now = np.linalg.solve(cell.matrix, state.positions.T).T
    centre = np.average(fractional, axis=0, weights=state.masses)
    # fractional coordinates relative to the centre of mass are kept exactly (to round-off)
    np.testing.assert_allclose(now - now.mean(axis=0), fractional - centre, atol=1e-12)
    # the cell moved at hdot = L h: after 0.2 s the shear component grew as integrated
    assert cell.matrix[0, 2] > 0.005
    # hdot = L h_m at each step's detection configuration: L h_m h_end^-1 = L (1 + O(L dt))
    np.testing.assert_allclose(cell.gradient, gradient, atol=2.0 * 1e-3 * 2.0 * 2.0)


def test_a_contact_across_a_face_is_the_contact_inside_the_cell():
    h = np.diag([0.01, 0.008, 0.009])
    # body 0 near x = 0, body 1 near x = L: body 1's image at x - L presses on body 0
    library, state = spheres([[0.0005, 0.004, 0.004], [0.01 - 0.00049, 0.0042, 0.0039]])
    state.velocities[0] = [-1e-2, 0.0, 0.0]
    state.velocities[1] = [1e-2, 0.0, 0.0]
    cell = PeriodicCell(h)
    report = ContactDynamicsStep(dt=1e-4, friction=0.4).step(state, library, cell)
    ref_lib, ref = spheres([[0.0005 + 0.005, 0.004, 0.004],
                            [0.01 - 0.00049 - 0.01 + 0.005, 0.0042, 0.0039]])
    ref.velocities[0] = [-1e-2, 0.0, 0.0]
    ref.velocities[1] = [1e-2, 0.0, 0.0]
    ref_report = ContactDynamicsStep(dt=1e-4, friction=0.4).step(ref, ref_lib, PeriodicCell(h))
    assert report.n_contacts == ref_report.n_contacts == 1
    assert np.any(report.image_vectors != 0) and not np.any(ref_report.image_vectors != 0)
    np.testing.assert_allclose(np.abs(report.impulses), np.abs(ref_report.impulses),
                               rtol=1e-9, atol=1e-18)
    np.testing.assert_allclose(state.velocities, ref.velocities, rtol=1e-9, atol=1e-15)


def _servo_run(library, state, matrix, steps=8, rotation=None, origin=None, move=None):
    state = copy.deepcopy(state)
    if move is not None:  # another image of some bodies is the primary one
        state.positions[:] = state.positions + move @ np.asarray(matrix).T
    if origin is not None:
        state.positions[:] = state.positions + origin
    gradient = np.array([[0.0, 0.0, -20.0], [0.0, 0.0, 0.0], [0.0, 0.0, -10.0]])
    directions = np.array([np.diag([1.0, 0.0, 0.0]), np.diag([0.0, 1.0, 0.0])]) * -1.0
    if rotation is not None:
        matrix = rotation @ matrix
        state.positions[:] = state.positions @ rotation.T
        state.velocities[:] = state.velocities @ rotation.T
        gradient = rotation @ gradient @ rotation.T
        directions = np.einsum("ab,dbc,ec->dae", rotation, directions, rotation)
    cell = PeriodicCell(matrix)
    cell.set_control(gradient, directions, [1e3, 1e3], reference_stress=1e3, max_rate=10.0)
    step = ContactDynamicsStep(dt=2e-6, friction=0.4, sweep="serial", tolerance=1e-10,
                               max_iterations=5000)
    for _ in range(steps):
        report = step.step(state, library, cell)
        assert report.converged
    stress = cell_stress(report, state, cell.matrix, cell.rate, step.dt)
    return stress, cell, report


def test_results_do_not_depend_on_origin_primary_image_or_rotation():
    library, state, matrix = lattice_sample(seed=3)
    stress, _, report = _servo_run(library, state, matrix)
    assert report.n_contacts > 0 and np.any(report.image_vectors != 0)
    scale = np.abs(stress).max()
    assert scale > 0
    # origin of the coordinates
    shifted, _, _ = _servo_run(library, state, matrix, origin=np.array([0.37, -1.2, 5.0]))
    np.testing.assert_allclose(shifted, stress, atol=1e-7 * scale)
    # which image is the primary particle: move some bodies by lattice vectors
    rng = np.random.default_rng(1)
    move = rng.integers(-2, 3, size=(state.n_bodies, 3)).astype(float)
    moved, _, _ = _servo_run(library, state, matrix, move=move)
    np.testing.assert_allclose(moved, stress, atol=1e-7 * scale)
    # a rotation of the whole problem (cell, bodies, control)
    angle = 0.7
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    rotated, _, _ = _servo_run(library, state, matrix, rotation=rotation)
    np.testing.assert_allclose(rotated, rotation @ stress @ rotation.T, atol=1e-7 * scale)


def test_a_remapped_sheared_cell_gives_the_same_contacts_and_forces():
    library, state, matrix = lattice_sample(seed=5)
    sheared = matrix.copy()
    sheared[0, 2] = 0.6 * matrix[2, 2]  # beyond the re-map threshold 0.5
    state.positions[:] = state.positions @ (sheared @ np.linalg.inv(matrix)).T
    results = []
    for remap in (False, True):
        cell = PeriodicCell(sheared, max_skew=np.inf)
        if remap:
            cell.max_skew = 0.5
            assert cell.remap_if_skewed()
            assert abs(cell.matrix[0, 2]) <= 0.5 * cell.matrix[0, 0] + 1e-15
        cell.set_control(np.array([[0.0, 0.0, 30.0], [0, 0, 0], [0, 0, 0]]))
        s = copy.deepcopy(state)
        step = ContactDynamicsStep(dt=2e-6, friction=0.4, sweep="serial", tolerance=1e-12,
                                   max_iterations=5000)
        report = step.step(s, library, cell)
        keys = np.lexsort((report.contacts.body_j, report.contacts.body_i))
        results.append((report, keys, s))
    (a, ka, sa), (b, kb, sb) = results
    assert a.n_contacts == b.n_contacts > 0
    np.testing.assert_array_equal(a.contacts.body_i[ka], b.contacts.body_i[kb])
    np.testing.assert_array_equal(a.contacts.body_j[ka], b.contacts.body_j[kb])
    np.testing.assert_allclose(a.contacts.gap[ka], b.contacts.gap[kb], atol=1e-15)
    scale = np.abs(a.impulses).max()
    np.testing.assert_allclose(a.impulses[ka], b.impulses[kb], atol=1e-8 * scale)
    np.testing.assert_allclose(sa.velocities, sb.velocities, atol=1e-8 * np.abs(
        sa.velocities).max())


def test_stress_servo_compresses_to_its_target_and_the_cell_carries_it():
    library, state, matrix = lattice_sample(seed=7, jitter=0.3)
    state.velocities[:] = 0.0
    cell = PeriodicCell(matrix)
    target = 2e3
    cell.set_control(np.zeros((3, 3)), -np.eye(3)[None] / 3.0, [target],
                     reference_stress=target, max_rate=20.0)
    step = ContactDynamicsStep(dt=1e-5, friction=0.0, sweep="serial", tolerance=1e-6,
                               max_iterations=2000)
    volume0 = cell.volume
    for _ in range(800):
        report = step.step(state, library, cell)
    assert cell.volume < volume0
    carried = cell.conjugate_stress(cell.boundary_stress)[0]
    assert carried == pytest.approx(target, rel=0.05)
    stress = cell_stress(report, state, cell.matrix, cell.rate, step.dt)
    assert np.trace(stress) / 3.0 == pytest.approx(target, rel=0.1)
    # the contact network's branch vectors reach through the images: its stress is the
    # cell's stress from contacts (the kinetic term aside)
    network = contact_network(report, state, library, cell.volume, step.dt, 0.0,
                              cell_matrix=cell.matrix)
    still = copy.deepcopy(state)
    still.velocities[:] = 0.0
    contacts_only = cell_stress(report, still, cell.matrix, np.zeros((3, 3)), step.dt)
    full = stress_from_network(network)
    np.testing.assert_allclose(0.5 * (full + full.T), contacts_only,
                               atol=1e-9 * np.abs(contacts_only).max())
    assert np.linalg.norm(network.pair_branches, axis=1).max() < 4 * R


def test_bad_controls_are_refused_with_the_field():
    cell = PeriodicCell(np.eye(3))
    with pytest.raises(InputError, match="targets"):
        cell.set_control(np.zeros((3, 3)), np.zeros((2, 3, 3)), [1.0])
    with pytest.raises(InputError, match="cell servo"):
        cell.set_control(np.zeros((3, 3)), np.zeros((1, 3, 3)), [1.0], max_rate=0.0)
    with pytest.raises(InputError, match="cell matrix"):
        PeriodicCell(-np.eye(3))


def test_a_step_that_ends_in_a_re_map_measures_the_same_stress():
    # two spheres pressed together across the z faces of a sheared cell that crosses the
    # re-map threshold within the step: the step's image vectors are in the lattice basis
    # of the cell before the re-map (PeriodicCell.image_matrix)
    side = 0.01
    sheared = np.array([[side, 0.0, 0.499998 * side], [0.0, side, 0.0], [0.0, 0.0, side]])
    below = np.array([0.003, 0.005, 0.0004])
    above = below + sheared[:, 2] - np.array([0.0002, 0.0001, 2.0 * R - 0.0004])
    stresses = []
    for skew in (np.inf, 0.5):
        library, state = spheres([below, above])
        state.velocities[0] = [0.0, 0.0, -0.5]
        state.velocities[1] = [0.0, 0.0, 0.5]
        cell = PeriodicCell(sheared, max_skew=skew)
        cell.set_control(np.array([[0.0, 0.0, 5.0], [0, 0, 0], [0, 0, 0]]))
        step = ContactDynamicsStep(dt=2e-6, friction=0.4, sweep="serial", tolerance=1e-12,
                                   max_iterations=5000)
        report = step.step(state, library, cell)
        assert cell.n_remaps == (0 if skew == np.inf else 1)
        assert report.n_contacts == 1 and report.image_vectors[0, 2] != 0
        assert report.impulses[0, 0] > 0.0
        stresses.append(cell_stress(report, state, cell.matrix, cell.rate, step.dt,
                                    cell.image_matrix))
    np.testing.assert_allclose(stresses[1], stresses[0], atol=1e-9 * np.abs(stresses[0]).max())
