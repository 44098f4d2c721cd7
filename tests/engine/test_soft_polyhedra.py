"""Convex polyhedra in the soft-contact DEM step against closed forms and invariants
(:mod:`grainlab.engine.dem.soft_polyhedra`; STYLE.md 11): a cube at rest on a face (the law's
static overlap, the wall's reaction = the weight), a flat landing (the restitution set), two
cubes pressed face to face (equal and opposite forces, no moment), an incline (sticks below
mu, slides with a = g (sin theta - mu cos theta) above), frame invariance, a contact through
the periodic cell, a small packing settling and a checkpoint resuming bit for bit.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.boundaries.boundary import FixedPlanes
from grainlab.engine.boundaries.periodic_boundary import PeriodicCell
from grainlab.engine.dem.soft_contact import SoftContactStep
from grainlab.engine.dem.soft_polyhedra import equivalent_radii
from grainlab.engine.detect.narrow_phase import NarrowPhase
from grainlab.engine.quaternion import quat_multiply, quat_to_matrix
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import from_vertices, random_polyhedron
from grainlab.geometry.polyhedron_contact import TYPE_FF
from grainlab.prep.loose_sample import loose_sample

G = 9.81
A = 0.01  # cube side [m]
DENSITY = 2600.0
FLOOR = FixedPlanes([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])


def cubes(positions, orientations=None):
    cube = from_vertices([[x, y, z] for x in (0, A) for y in (0, A) for z in (0, A)])
    library = ShapeLibrary.from_polyhedra([cube])
    state = BodyState.from_library(library, [0] * len(positions), positions, density=DENSITY,
                                   orientations=orientations)
    return library, state


def world_forces(report, dt):
    """(C, 3) world forces [N] on body j of the report's rows."""
    return np.einsum("cji,cj->ci", report.frames, report.impulses) / dt


def rotation_to(a, b):
    """Unit quaternion (w first) turning unit vector a onto b."""
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(np.dot(a, b))
    if s < 1e-15:
        return np.array([1.0, 0.0, 0.0, 0.0])
    angle = math.atan2(s, c)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis / s])


@pytest.mark.parametrize("model", ["linear", "hertz_mindlin"])
def test_cube_at_rest_on_a_face_sinks_by_the_static_overlap_of_the_law(model):
    """Four points at one depth carry the law of one contact at that depth: m g = k_n delta
    (linear) or (4/3) E* sqrt(R*) delta^(3/2) (Hertz, R* the equal-volume radius)."""
    library, state = cubes([[0.0, 0.0, 0.5 * A]])
    if model == "linear":
        law = SoftContactLaw.linear(1e4, restitution=0.3, local_damping=0.3)
    else:
        law = SoftContactLaw.hertz_mindlin(1e7, 0.25, restitution=0.3, local_damping=0.3)
    solver = SoftContactStep(law, dt=1e-3, gravity=(0.0, 0.0, -G))
    for _ in range(600):
        report = solver.step(state, library, FLOOR)
    weight = float(state.masses[0]) * G
    if model == "linear":
        static = weight / law.normal_stiffness
    else:
        e_star = float(law.params[1, 0])
        radius = float(equivalent_radii(state, library)[0])
        static = (0.75 * weight / (e_star * math.sqrt(radius))) ** (2.0 / 3.0)
    assert report.n_contacts == 4
    assert np.all(report.contacts.contact_type == TYPE_FF)
    np.testing.assert_allclose(report.contacts.normal, [[0.0, 0.0, 1.0]] * 4, atol=1e-12)
    assert world_forces(report, 1e-3)[:, 2].sum() == pytest.approx(weight, rel=1e-6)
    np.testing.assert_allclose(-report.contacts.gap, static, rtol=1e-6)
    assert np.abs(state.velocities).max() < 1e-8


@pytest.mark.parametrize("restitution", [0.3, 0.8])
def test_a_flat_landing_rebounds_with_the_restitution_set(restitution):
    speed = 0.1
    library, state = cubes([[0.0, 0.0, 0.5 * A * 1.0001]])
    state.velocities[0] = [0.0, 0.0, -speed]
    k_n = 1e4
    law = SoftContactLaw.linear(k_n, restitution=restitution)
    duration = math.pi * math.sqrt(float(state.masses[0]) / k_n)
    solver = SoftContactStep(law, dt=duration / 100, friction=0.0, substep=duration / 400)
    touched = False
    for _ in range(400):
        report = solver.step(state, library, FLOOR)
        touched = touched or report.n_contacts > 0
        if touched and report.n_contacts == 0:
            break
    assert touched and report.n_contacts == 0
    assert state.velocities[0, 2] / speed == pytest.approx(restitution, rel=0.02)
    assert np.abs(state.angular_velocities).max() < 1e-9


@pytest.mark.parametrize("offset", [0.0, A / 3])
def test_two_cubes_pressed_face_to_face_push_equally_and_oppositely(offset):
    """Momentum and angular momentum are kept; a centred face contact turns neither cube, an
    off-centre one turns both."""
    overlap = 1e-5
    library, state = cubes([[0.0, 0.0, 0.0], [A - overlap, offset, 0.0]])
    k_n = 1e4
    law = SoftContactLaw.linear(k_n, restitution=1.0)  # no dashpot: the spring's force
    dt = 1e-5
    solver = SoftContactStep(law, dt=dt, friction=0.5)

    def angular_momentum():
        inertia = state.inertias  # cubes: isotropic
        return (np.cross(state.positions, state.velocities) * state.masses[:, None]
                + inertia * state.angular_velocities).sum(axis=0)

    report = solver.step(state, library)
    forces = world_forces(report, dt)
    assert report.n_contacts == 4
    total = forces.sum(axis=0)
    assert total[0] == pytest.approx(k_n * overlap, rel=1e-3)
    moment = np.cross(report.contacts.point - state.positions[1], forces).sum(axis=0)
    if offset == 0.0:
        assert np.abs(total[1:]).max() < 1e-12 * total[0]
        assert np.abs(moment).max() < 1e-12 * total[0] * A
    else:  # the points on the side of cube 1 push harder: it turns about z
        assert abs(moment[2]) > 1e-3 * total[0] * A
    for _ in range(20):
        solver.step(state, library)
    momentum = (state.masses[:, None] * state.velocities).sum(axis=0)
    assert np.abs(momentum).max() < 1e-12 * state.masses[0] * np.abs(state.velocities).max()
    assert np.abs(angular_momentum()).max() < 1e-12 * state.masses[0] * A * \
        np.abs(state.velocities).max()
    if offset == 0.0:
        assert np.abs(state.angular_velocities).max() < 1e-10
    else:
        assert np.abs(state.angular_velocities).max() > 1e-3


@pytest.mark.parametrize("tan_theta, mu, sliding", [(0.3, 0.4, False), (0.6, 0.3, True)])
def test_cube_on_an_incline_sticks_below_mu_and_slides_above(tan_theta, mu, sliding):
    theta = math.atan(tan_theta)
    normal = np.array([-math.sin(theta), 0.0, math.cos(theta)])
    library, state = cubes([0.5 * A * 0.9999 * normal],
                           [rotation_to(np.array([0.0, 0.0, 1.0]), normal)])
    law = SoftContactLaw.linear(1e4, stiffness_ratio=0.5, restitution=0.2)
    walls = FixedPlanes([[0.0, 0.0, 0.0]], [normal], friction=mu)
    solver = SoftContactStep(law, dt=1e-3, gravity=(0.0, 0.0, -G), friction=mu)
    for _ in range(200):  # settle on the plane
        report = solver.step(state, library, walls)
    assert report.n_contacts == 4
    downhill = -np.array([math.cos(theta), 0.0, math.sin(theta)])
    v0 = float(state.velocities[0] @ downhill)
    for _ in range(200):
        report = solver.step(state, library, walls)
    a = (float(state.velocities[0] @ downhill) - v0) / 0.2
    if sliding:
        assert a == pytest.approx(G * (math.sin(theta) - mu * math.cos(theta)), rel=1e-2)
        local = report.impulses.sum(axis=0)
        assert np.linalg.norm(local[1:]) == pytest.approx(mu * local[0], rel=1e-3)
    else:
        assert abs(a) < 1e-3 * G
        assert abs(float(state.velocities[0] @ downhill)) < 1e-4
    assert np.abs(state.angular_velocities).max() < 1e-3


def random_pair(rng, overlap=2e-5):
    """Two random polyhedra (n_f = 20, d = 1 cm) in random orientations, the second moved
    along x until they overlap by ``overlap`` [m], with random velocities."""
    shapes = [random_polyhedron(20, rng, circumscribed_diameter=0.01) for _ in range(2)]
    library = ShapeLibrary.from_polyhedra(shapes)
    q = rng.normal(size=(2, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    state = BodyState.from_library(library, [0, 1], [[0.0, 0.0, 0.0], [0.01, 0.001, 0.0]],
                                   density=DENSITY, orientations=q)
    detection = NarrowPhase(alert=0.01)
    low, high = 0.0, 0.01
    for _ in range(60):
        state.positions[1, 0] = 0.5 * (low + high)
        gap = detection.detect(state, library, np.array([[0, 1]])).gap.min()
        low, high = (state.positions[1, 0], high) if gap < -overlap else \
            (low, state.positions[1, 0])
    state.velocities[:] = rng.normal(0.0, 0.01, (2, 3))
    state.angular_velocities[:] = rng.normal(0.0, 2.0, (2, 3))
    return library, state


def test_the_pair_force_turns_and_moves_with_the_frame():
    """The same pair seen in a rotated and shifted frame: the same contacts, forces turned,
    the same motion turned."""
    rng = np.random.default_rng(4)
    law = SoftContactLaw.hertz_mindlin(1e7, 0.25, restitution=0.5)
    library, state = random_pair(rng)
    turn = np.array([0.3, -0.5, 0.2, 0.78])
    turn /= np.linalg.norm(turn)
    rotation, shift = quat_to_matrix(turn), np.array([0.3, -0.2, 0.1])
    moved = copy.deepcopy(state)
    moved.positions[:] = state.positions @ rotation.T + shift
    moved.orientations[:] = [quat_multiply(turn, q) for q in state.orientations]
    moved.velocities[:] = state.velocities @ rotation.T
    moved.angular_velocities[:] = state.angular_velocities @ rotation.T
    reports = []
    for s in (state, moved):
        solver = SoftContactStep(law, dt=2e-5, friction=0.4, substep=2e-6)
        for _ in range(5):
            reports.append(solver.step(s, library))
    first, second = reports[4], reports[9]
    assert first.n_contacts > 0 and first.n_contacts == second.n_contacts
    np.testing.assert_array_equal(first.contacts.member_j, second.contacts.member_j)
    scale = np.abs(world_forces(first, 2e-5)).max()
    np.testing.assert_allclose(world_forces(first, 2e-5) @ rotation.T,
                               world_forces(second, 2e-5), rtol=0, atol=1e-8 * scale)
    np.testing.assert_allclose(state.positions @ rotation.T + shift, moved.positions,
                               rtol=0, atol=1e-14)
    np.testing.assert_allclose(state.angular_velocities @ rotation.T,
                               moved.angular_velocities, rtol=0,
                               atol=1e-9 * np.abs(state.angular_velocities).max())


def test_a_contact_through_the_periodic_cell_is_the_contact_inside_it():
    h = np.diag([0.06, 0.058, 0.059])
    law = SoftContactLaw.linear(1e4, restitution=0.5)
    results = []
    for x0, x1 in (([0.0005, 0.02, 0.02], [0.06 - A + 0.0005 + 2e-5, 0.021, 0.0203]),
                   ([0.0255, 0.02, 0.02], [0.0255 - A + 2e-5, 0.021, 0.0203])):
        library, state = cubes([x0, x1])
        state.velocities[0] = [-0.01, 0.0, 0.0]
        solver = SoftContactStep(law, dt=1e-4, friction=0.4)
        cell = PeriodicCell(h)
        for _ in range(5):
            report = solver.step(state, library, cell)
        results.append((report, state))
    (through, a), (inside, b) = results
    assert through.n_contacts == inside.n_contacts == 4
    assert np.any(through.image_vectors != 0) and not np.any(inside.image_vectors != 0)
    np.testing.assert_allclose(world_forces(through, 1e-4), world_forces(inside, 1e-4),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.velocities, b.velocities, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.angular_velocities, b.angular_velocities, rtol=0, atol=1e-9)


def settle(sample, solver, n_steps):
    for _ in range(n_steps):
        report = solver.step(sample.state, sample.library, sample.boundary)
    return report


@pytest.mark.long
def test_a_small_packing_settles_and_a_checkpoint_resumes_bit_for_bit():
    sample = loose_sample(shape="polyhedron", n_particles=20, n_faces=8, templates=4, d_min=1e-3,
                          size_ratio=1.5, packing_fraction=0.15, seed=3)
    law = SoftContactLaw.linear(20.0, restitution=0.3, local_damping=0.3)
    solver = SoftContactStep(law, dt=1e-3, gravity=(0.0, 0.0, -G), friction=0.4)
    settle(sample, solver, 120)
    saved = (copy.deepcopy(sample), solver.warm_start_arrays())
    report = settle(sample, solver, 60)
    state = sample.state
    weight = float(np.sum(state.masses)) * G
    floor = report.contacts.body_i == -5  # the box's lower z wall
    assert np.all(np.isfinite(state.positions))
    assert state.kinetic_energy() < 1e-3 * weight * 1e-3
    assert world_forces(report, 1e-3)[floor, 2].sum() == pytest.approx(weight, rel=0.02)
    assert report.max_overlap < 0.01 * 1e-3
    resumed, arrays = saved
    again = SoftContactStep(law, dt=1e-3, gravity=(0.0, 0.0, -G), friction=0.4)
    again.restore_warm_start(arrays)
    settle(resumed, again, 60)
    np.testing.assert_array_equal(resumed.state.positions, state.positions)
    np.testing.assert_array_equal(resumed.state.angular_velocities, state.angular_velocities)


def test_what_polyhedra_do_not_run_with_is_refused_with_a_clear_message():
    library, state = cubes([[0.0, 0.0, 0.02]])
    rolling = SoftContactStep(SoftContactLaw.linear(1e5, rolling_friction=0.1), dt=1e-4)
    with pytest.raises(InputError, match="rolling_friction"):
        rolling.step(state, library)
    mixed = library.concatenate(ShapeLibrary.from_spheres([0.005]))
    state = BodyState.from_library(mixed, [0, 1], [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]],
                                   density=DENSITY)
    with pytest.raises(InputError, match="polyhedra with spheres"):
        SoftContactStep(SoftContactLaw.linear(1e5), dt=1e-4).step(state, mixed)


@pytest.mark.parametrize("model", ["linear", "hertz_mindlin"])
@pytest.mark.parametrize("restitution", [0.05, 0.1, 0.5, 1.0])
def test_a_cube_pressed_between_two_walls_stays_at_rest_at_the_solvers_own_substep(
        model, restitution):
    """A cube held face to face between a floor and a ceiling (overlap 1e-3 A), very rough,
    its spin seeded: at the springs' step alone its rocking on the manifold points' dashpots
    grew (linear springs: 5e8 times the seeded energy at e = 0.1, a blow-up at 0.05); with
    the dashpots' bound the kinetic energy does not grow over 400 sub-steps (its twist about
    the walls' normal, which nothing resists, is kept)."""
    squeeze = 1e-3 * A
    library, state = cubes([[0.0, 0.0, 0.5 * (A - squeeze)]])
    walls = FixedPlanes([[0.0, 0.0, 0.0], [0.0, 0.0, A - squeeze]],
                        [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]], friction=10.0)
    if model == "linear":
        law = SoftContactLaw.linear(1e4, restitution=restitution)
    else:
        law = SoftContactLaw.hertz_mindlin(1e8, 0.25, restitution=restitution)
    solver = SoftContactStep(law, dt=1.0, friction=10.0)
    solver.dt = 20 * solver.stable_substep(state, library)
    state.angular_velocities[0] = [1e-3, -1e-3, 1e-3]
    start, substeps = state.kinetic_energy(), 0
    while substeps < 400:
        report = solver.step(state, library, walls)
        substeps += solver.last_substeps
    assert report.n_contacts == 8
    assert state.kinetic_energy() <= 1.01 * start
