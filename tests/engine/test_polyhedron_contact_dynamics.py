"""Contact dynamics with convex polyhedra (several points per pair solved as independent
contacts) against closed forms: a polyhedron dropped on a wall comes to rest on a face with the
wall reaction equal to its weight; a block on an incline sticks when tan(theta) < mu and slides
with a = g (sin theta - mu cos theta) otherwise (tetrahedron on a face: it does not tip for
tan(theta) < 1.41); a cube stacked on a cube rests face to face. Faces here are triangles
(tetrahedron, octahedron) where the point count matters: a square face held by 3 of its 4
corners rocks slowly (polyhedron_contact docstring) (research/cd_engines.md 6.1-6.3;
STYLE.md 11)."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.detect.narrow_phase import POLYHEDRON_CONTACT_TYPE_NAMES
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.quaternion import quat_to_matrices
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import StepReport
from grainlab.geometry.polyhedron import from_vertices

G = 9.81
DT = 1e-3
TOL = 1e-5
CUBE = from_vertices([[x, y, z] for x in (0, 0.1) for y in (0, 0.1) for z in (0, 0.1)])
TETRA = from_vertices(0.1 * np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]))
OCTA = from_vertices(0.1 * np.vstack([np.eye(3), -np.eye(3)]))
FLOOR = ([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])


def _quat(axis, angle):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def _multiply(p, q):
    w1, v1, w2, v2 = p[0], p[1:], q[0], q[1:]
    return np.concatenate([[w1 * w2 - v1 @ v2], w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def _face_down(shape, tilt_axis=(1.0, 0.0, 0.0), tilt=0.0):
    """Orientation putting the shape's first polygon face flat on a floor (normal -z), then
    tilted by ``tilt`` [rad] about ``tilt_axis``; and the height of its centre above the face."""
    n = shape.polygon_normals[0]
    axis = np.cross(n, [0.0, 0.0, -1.0])
    angle = np.arccos(np.clip(-n[2], -1.0, 1.0))
    base = _quat(axis, angle) if np.linalg.norm(axis) > 1e-12 else np.array([1.0, 0, 0, 0])
    return _multiply(_quat(tilt_axis, tilt), base), float(shape.polygon_offsets[0])


def assert_contact_laws(report: StepReport, mu: float, dt: float = DT, tol: float = TOL):
    """Signorini and Coulomb at every contact point of one step."""
    assert report.converged, (report.iterations, report.change, report.residual)
    if report.n_contacts == 0:
        return
    p, u, gap = report.impulses, report.relative_velocity, report.contacts.gap
    p_scale = max(float(np.abs(p[:, 0]).max()), 1e-30)
    u_scale = max(G * dt, float(np.abs(u).max()))
    assert (p[:, 0] >= -tol * p_scale).all()
    assert (np.linalg.norm(p[:, 1:], axis=1) <= mu * p[:, 0] * (1 + tol) + tol * p_scale).all()
    corrected = u[:, 0] + np.maximum(gap, 0.0) / dt
    assert (corrected >= -100.0 * tol * u_scale).all()


@pytest.mark.parametrize("shape", [TETRA, OCTA], ids=["tetrahedron", "octahedron"])
def test_dropped_polyhedron_rests_on_a_face_with_reaction_equal_to_weight(shape):
    library = ShapeLibrary.from_polyhedra([shape])
    quat, height = _face_down(shape, tilt_axis=(1.0, 0.4, 0.0), tilt=0.35)
    state = BodyState.from_library(library, [0], [[0.0, 0.0, 0.12]], 2000.0,
                                   orientations=[quat])
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=0.5, tolerance=TOL,
                               sweep="serial")
    for _ in range(1500):
        report = step.step(state, library, FLOOR)
        assert_contact_laws(report, 0.5)
        assert report.max_overlap < 1e-3 * height
    contacts = report.contacts
    names = {POLYHEDRON_CONTACT_TYPE_NAMES[c] for c in contacts.contact_type}
    assert names == {"ff"} and report.n_contacts == 3
    np.testing.assert_allclose(state.velocities, 0.0, atol=1e-9)
    np.testing.assert_allclose(state.angular_velocities, 0.0, atol=1e-7)
    weight = state.masses[0] * G
    assert report.impulses[:, 0].sum() / DT == pytest.approx(weight, rel=1e-6)
    # resting on a face: the centre at the face's inradius above the floor, a face normal down
    rotation = quat_to_matrices(state.orientations)[0]
    down = shape.polygon_normals @ rotation.T
    k = int(np.argmin(down[:, 2]))
    assert down[k, 2] == pytest.approx(-1.0, abs=1e-6)
    assert state.positions[0, 2] == pytest.approx(shape.polygon_offsets[k], abs=1e-6)


def _incline_run(theta, mu, n_steps=150):
    """A regular tetrahedron resting on a face on a plane tilted by theta."""
    library = ShapeLibrary.from_polyhedra([TETRA])
    quat, height = _face_down(TETRA)
    normal = np.array([-np.sin(theta), 0.0, np.cos(theta)])
    tilt = _quat([0.0, 1.0, 0.0], -theta)  # turns e_z onto the incline's normal
    state = BodyState.from_library(library, [0], [height * normal], 2000.0,
                                   orientations=[_multiply(tilt, quat)])
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=mu, tolerance=TOL,
                               sweep="serial")
    walls = ([[0.0, 0.0, 0.0]], [normal])
    for _ in range(n_steps):
        report = step.step(state, library, walls)
        assert_contact_laws(report, mu)
        assert report.n_contacts == 3
    downhill = -np.array([np.cos(theta), 0.0, np.sin(theta)])
    np.testing.assert_allclose(state.velocities[0] @ normal, 0.0, atol=1e-9)
    np.testing.assert_allclose(state.angular_velocities, 0.0, atol=1e-7)  # no tipping
    return float(state.velocities[0] @ downhill) / (n_steps * DT), state, report


def test_tetrahedron_on_incline_sticks_below_mu():
    a, state, report = _incline_run(np.arctan(0.3), mu=0.4)
    assert abs(a) < 1e-9
    np.testing.assert_allclose(state.velocities, 0.0, atol=1e-10)
    friction = np.linalg.norm(report.impulses[:, 1:].sum(axis=0))
    assert friction < 0.4 * report.impulses[:, 0].sum()


def test_tetrahedron_on_incline_slides_with_coulomb_acceleration():
    theta, mu = np.arctan(0.6), 0.3
    a, _, report = _incline_run(theta, mu)
    assert a == pytest.approx(G * (np.sin(theta) - mu * np.cos(theta)), rel=1e-3)
    np.testing.assert_allclose(np.linalg.norm(report.impulses[:, 1:], axis=1),
                               mu * report.impulses[:, 0], rtol=1e-5)


def test_cube_stacked_on_cube_rests_face_to_face():
    library = ShapeLibrary.from_polyhedra([CUBE])
    twist = _quat([0.0, 0.0, 1.0], 0.4)
    state = BodyState.from_library(library, [0, 0], [[0.0, 0.0, 0.05], [0.01, 0.0, 0.152]],
                                   2000.0, orientations=[[1.0, 0, 0, 0], twist])
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=0.5, tolerance=TOL,
                               sweep="serial")
    for _ in range(500):
        report = step.step(state, library, FLOOR)
        assert_contact_laws(report, 0.5)
    contacts = report.contacts
    pair = contacts.body_i == 0
    # two squares turned by 0.4 rad overlap in an octagon: its 8 corners, on the plane z = 0.1
    assert pair.sum() == 8 and (contacts.contact_type[pair] == 4).all()
    np.testing.assert_allclose(contacts.point[pair, 2], 0.1, atol=1e-6)
    np.testing.assert_allclose(contacts.normal[pair], [[0.0, 0.0, 1.0]] * 8, atol=1e-7)  # no tilt
    weight = state.masses[1] * G
    assert report.impulses[pair, 0].sum() / DT == pytest.approx(weight, rel=1e-4)
    on_floor = contacts.body_i < 0
    assert report.impulses[on_floor, 0].sum() / DT == pytest.approx(2 * weight, rel=1e-4)
    np.testing.assert_allclose(state.positions[1, 2], 0.15, atol=1e-4)
    # warm-start keys: the same feature pairs touch from step to step
    again = step.step(state, library, FLOOR)
    pair_again = again.contacts.body_i == 0
    np.testing.assert_array_equal(again.contacts.member_i[pair_again], contacts.member_i[pair])
    np.testing.assert_array_equal(again.contacts.member_j[pair_again], contacts.member_j[pair])
    assert again.iterations < report.iterations or again.iterations <= 5
