"""Discs (2D samples) in the 3D engine against 2D closed forms, and planar motion kept exactly
(grainlab.engine.planar; seed 000's regular packings; STYLE.md 11).

Incline cases (gravity in the plane, the incline's normal tilted by theta, friction mu): a disc
(I = m r^2 / 2) rolls without slipping with a = 2/3 g sin theta if tan theta < 3 mu, and
otherwise slips with a = g (sin theta - mu cos theta). A sphere (I = 2/5 m r^2) would roll at
5/7 g sin theta: the acceleration tells which inertia the engine used.

Hexagonal packing: under a homogeneous normal strain (eps_xx, eps_yy) every disc of a
triangular lattice is a centre of symmetry whose contact moments cancel, so the packing
deforms affinely, and its stress is seed 000's D eps with the springs per unit thickness,
k / t (eq. 15; :class:`~grainlab.micromech.regular_packing.RegularPackingModel`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainlab.contact.linear_spring import LinearSpring2D
from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.boundaries.boundary import FixedPlanes
from grainlab.engine.boundaries.periodic_boundary import PeriodicCell
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.dem.soft_contact import SoftContactStep
from grainlab.engine.detect.periodic_detection import PeriodicDetection
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.planar import planar_drift
from grainlab.engine.shape_kinds import DISC
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.triclinic_cell import TriclinicCell
from grainlab.micromech.regular_packing import RegularPackingModel
from grainlab.prep.loose_sample import loose_sample
from grainlab.prep.regular_packings import hexagonal_packing

G = 9.81


def test_a_disc_has_the_mass_and_inertia_of_a_cylinder_of_the_thickness():
    radii, t, rho = np.array([1e-3, 2e-3]), 5e-4, 2600.0
    library = ShapeLibrary.from_discs(radii, t)
    state = BodyState.from_library(library, [0, 1], [[0, 0, 0], [1e-2, 0, 0]], rho)
    mass = rho * math.pi * radii**2 * t
    np.testing.assert_allclose(state.masses, mass, rtol=1e-15)
    np.testing.assert_allclose(state.inertias, np.repeat(0.5 * mass * radii**2, 3)
                               .reshape(2, 3), rtol=1e-15)
    assert library.dimension == 2 and library.thickness == pytest.approx(t, rel=1e-15)
    assert DISC.dimension == 2 and ShapeLibrary.from_spheres([1.0]).thickness is None


def test_discs_off_their_plane_mixed_with_spheres_or_of_two_thicknesses_are_refused():
    library = ShapeLibrary.from_discs([1e-3], 1e-3)
    with pytest.raises(InputError, match=r"positions\[1\]"):
        BodyState.from_library(library, [0, 0], [[0, 0, 0], [1e-2, 0, 1e-4]], 1000.0)
    with pytest.raises(InputError, match=r"orientations\[0\]"):
        BodyState.from_library(library, [0], [[0, 0, 0]], 1000.0,
                               orientations=[[math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0]])
    with pytest.raises(InputError, match="one dimension"):
        library.concatenate(ShapeLibrary.from_spheres([1e-3]))
    with pytest.raises(InputError, match="one thickness"):
        library.concatenate(ShapeLibrary.from_discs([1e-3], 2e-3))
    with pytest.raises(InputError, match="thickness"):
        ShapeLibrary.from_discs([1e-3], 0.0)


@pytest.mark.parametrize("restitution", [0.3, 0.8])
def test_two_discs_rebound_with_the_restitution_asked_and_stay_in_their_plane(restitution):
    r, speed = 1e-3, 0.5
    library = ShapeLibrary.from_discs([r], 2 * r)
    state = BodyState.from_library(library, [0, 0], [[0, 0, 0], [2.002 * r, 2e-4, 0]], 2600.0)
    state.velocities[:, 0] = [speed, -speed]
    law = SoftContactLaw.linear(1e5, stiffness_ratio=0.5, restitution=restitution)
    m_eff = 0.5 * float(state.masses[0])
    dt = math.pi * math.sqrt(m_eff / 1e5) / 400
    solver = SoftContactStep(law, dt=dt, friction=0.5, substep=dt)
    normal = None
    for _ in range(2000):
        report = solver.step(state, library, None)
        if report.n_contacts and normal is None:
            normal = report.contacts.normal[0].copy()
        if normal is not None and not report.n_contacts:
            break
    relative = state.velocities[1] - state.velocities[0]
    approach = 2 * speed * normal[0]
    assert float(relative @ normal) / approach == pytest.approx(restitution, abs=0.02)
    np.testing.assert_allclose(state.momentum(), 0.0, atol=1e-15)
    assert planar_drift(state.positions, state.velocities, state.angular_velocities, 0.0) == 0.0


def incline(theta, mu, solver):
    """Acceleration [m/s^2] down an incline of a disc, and its state after the run."""
    r = 0.05
    normal = np.array([-math.sin(theta), math.cos(theta), 0.0])
    library = ShapeLibrary.from_discs([r], 0.02)
    state = BodyState.from_library(library, [0], [r * 0.999 * normal], 1000.0)
    plane = FixedPlanes([[0.0, 0.0, 0.0]], [normal], friction=mu)
    downhill = -np.array([math.cos(theta), math.sin(theta), 0.0])
    for _ in range(100):  # settle on the plane
        solver.step(state, library, plane)
    v0, steps = float(state.velocities[0] @ downhill), 200
    for _ in range(steps):
        solver.step(state, library, plane)
    return (float(state.velocities[0] @ downhill) - v0) / (steps * solver.dt), state


def solvers(mu):
    return {"dem": SoftContactStep(SoftContactLaw.linear(1e6, stiffness_ratio=0.5,
                                                         restitution=0.2),
                                   dt=1e-3, gravity=(0.0, -G, 0.0), friction=mu),
            "cd": ContactDynamicsStep(dt=1e-3, gravity=(0.0, -G, 0.0), friction=mu)}


@pytest.mark.parametrize("solver", ["dem", "cd"])
@pytest.mark.parametrize("tan_theta, mu, rolls", [(0.5, 0.4, True), (1.0, 0.2, False)])
def test_a_disc_on_an_incline_rolls_at_two_thirds_g_sin_theta_or_slips(solver, tan_theta, mu,
                                                                       rolls):
    theta = math.atan(tan_theta)  # rolls: tan < 3 mu; slips: tan > 3 mu
    a, state = incline(theta, mu, solvers(mu)[solver])
    expected = 2.0 / 3.0 * G * math.sin(theta) if rolls else \
        G * (math.sin(theta) - mu * math.cos(theta))
    assert a == pytest.approx(expected, rel=1e-2)
    assert planar_drift(state.positions, state.velocities, state.angular_velocities, 0.0) == 0.0


def compacted_discs(solver_name, boundary_name, steps=300):
    """A loose sample of 40 discs pushed in by their box's four side walls or their cell's
    two in-plane axes at 2e4 Pa, run for ``steps`` steps of the solver."""
    around = WallBox.around if boundary_name == "walls" else PeriodicCell.around
    sample = loose_sample(shape="disc", n_particles=40, d_min=1e-3, size_ratio=1.5, seed=4,
                          boundary=around, packing_fraction=0.3)
    state, library, boundary = sample.state, sample.library, sample.box
    sigma, rate, dt = 2e4, 20.0, 1e-4
    if boundary_name == "walls":
        for wall in ("x-", "x+", "y-", "y+"):
            boundary.set_control(wall, "stress", sigma)
        boundary.servo = True
        boundary.set_max_speeds(rate * float(np.max(boundary.lengths[:2])))
        boundary.set_masses(boundary.servo_masses(dt))
    else:
        directions = np.zeros((2, 3, 3))
        directions[0, 0, 0] = directions[1, 1, 1] = -1.0  # conjugate: sigma, compression +
        boundary.set_control(np.zeros((3, 3)), directions, [sigma, sigma],
                             reference_stress=sigma, max_rate=rate)
    if solver_name == "dem":
        solver = SoftContactStep(SoftContactLaw.linear(1e4, stiffness_ratio=0.5,
                                                       restitution=0.3),
                                 dt=dt, friction=0.3)
    else:
        solver = ContactDynamicsStep(dt=dt, friction=0.3)
    z0 = float(state.positions[0, 2])
    for _ in range(steps):
        report = solver.step(state, library, boundary)
    return state, library, boundary, report, z0


@pytest.mark.parametrize("boundary_name", ["walls", "cell"])
@pytest.mark.parametrize("solver_name", ["dem", "cd"])
def test_discs_compacted_by_walls_or_a_cell_stay_exactly_in_their_plane(solver_name,
                                                                        boundary_name):
    state, library, boundary, report, z0 = compacted_discs(solver_name, boundary_name)
    assert report.n_contacts > state.n_bodies  # compacted into a network
    assert planar_drift(state.positions, state.velocities, state.angular_velocities, z0) == 0.0
    np.testing.assert_array_equal(report.contacts.normal[:, 2], 0.0)
    np.testing.assert_array_equal(report.contacts.point[:, 2], z0)
    if boundary_name == "walls":  # the z walls are out of reach; the volume is L_x L_y t
        assert not np.any(np.isin(report.contacts.body_i, [-5, -6]))
        assert boundary.volume == pytest.approx(
            boundary.lengths[0] * boundary.lengths[1] * library.thickness, rel=1e-12)
    else:
        np.testing.assert_array_equal(boundary.matrix[2], [0.0, 0.0, library.thickness])


def test_a_planar_box_keeps_its_z_walls_fixed():
    box = WallBox.around([1e-2, 1e-2, 1e-3], 0.0, 1.0, planar=True)
    with pytest.raises(InputError, match="z walls"):
        box.set_control("z+", "stress", 1e4)
    cell = PeriodicCell.around([1e-2, 1e-2, 1e-3], planar=True)
    with pytest.raises(InputError, match="fixed_gradient"):
        cell.set_control(np.diag([0.0, 0.0, -1.0]))


def test_planar_detection_finds_the_in_plane_contacts_of_a_cell_thinner_than_a_disc():
    """The same discs in a planar cell of thickness d/2 and in a 3D cell deep enough for no
    z image to reach: the same contacts, images and gaps."""
    sample = loose_sample(shape="disc", n_particles=60, d_min=1e-3, seed=2,
                          boundary=PeriodicCell.around, packing_fraction=0.34)
    state, library = sample.state, sample.library
    h = sample.box.matrix.copy()
    h[0, 1] = 0.2 * h[0, 0]  # sheared
    thin = h.copy()
    thin[2, 2] = 5e-4
    deep = h.copy()
    deep[2, 2] = 20e-3
    state.positions[:, 2] = 2.5e-4
    found = [PeriodicDetection(alert=5e-4, planar=planar).detect(state, library,
                                                                  TriclinicCell(cell))
             for planar, cell in ((True, thin), (False, deep))]
    assert found[0].n_contacts > 30

    def rows(f):
        order = np.lexsort((f.images[:, 1], f.images[:, 0], f.contacts.body_j,
                            f.contacts.body_i))
        return (np.column_stack([f.contacts.body_i, f.contacts.body_j, f.images])[order],
                f.contacts.gap[order])

    (ids_thin, gap_thin), (ids_deep, gap_deep) = rows(found[0]), rows(found[1])
    np.testing.assert_array_equal(ids_thin, ids_deep)
    np.testing.assert_allclose(gap_thin, gap_deep, rtol=0.0, atol=1e-15)


def hexagonal_cell(d, columns=4, rows=3):
    """Discs of diameter d on a triangular lattice filling a rectangular periodic cell of
    ``columns`` x ``rows`` two-disc cells (each d x sqrt(3) d), just touching."""
    a = math.sqrt(3.0) * d
    base = np.array([[0.0, 0.0], [0.5 * d, 0.5 * a]])
    shifts = np.array([[i * d, j * a] for i in range(columns) for j in range(rows)])
    centres = (shifts[:, None, :] + base[None]).reshape(-1, 2)
    return centres + np.array([0.25 * d, 0.25 * a]), np.array([columns * d, rows * a])


@pytest.mark.parametrize("strain", [(1e-4, 1e-4), (1e-4, 0.4e-4), (0.3e-4, 1e-4)])
def test_a_hexagonal_packing_of_discs_has_seed_000s_stiffness(strain):
    d, t, k_n, ratio = 1e-3, 1e-3, 1e5, 0.6
    centres, sides = hexagonal_cell(d)
    library = ShapeLibrary.from_discs([0.5 * d], t)
    n = centres.shape[0]
    state = BodyState.from_library(library, np.zeros(n, dtype=np.int64),
                                   np.column_stack([centres, np.full(n, 0.5 * t)]), 2600.0)
    h0 = np.diag([sides[0], sides[1], t])
    cell = PeriodicCell(h0, planar=True)
    law = SoftContactLaw.linear(k_n, stiffness_ratio=ratio, restitution=0.5)
    solver = SoftContactStep(law, dt=1e-5, friction=1.0)
    steps, duration = 50, 50 * 1e-5
    eps = np.array(strain)
    cell.set_control(np.diag([-eps[0] / duration, -eps[1] / duration, 0.0]))
    for _ in range(steps):
        solver.step(state, library, cell)
    cell.set_control(np.zeros((3, 3)))
    for _ in range(5):
        solver.step(state, library, cell)
    model = RegularPackingModel(hexagonal_packing(d), LinearSpring2D(k_n / t, ratio * k_n / t,
                                                                     math.radians(45.0)))
    voigt = np.array([*-np.log(cell.matrix.diagonal()[:2] / h0.diagonal()[:2]), 0.0])
    assert voigt[:2] == pytest.approx(eps, rel=1e-3)
    expected = model.stiffness_matrix(model.unloaded_state(), force_floor=1e-6) @ voigt
    stress = cell.boundary_stress
    scale = float(np.max(np.abs(expected)))
    assert stress[0, 0] == pytest.approx(expected[0], abs=2e-3 * scale)
    assert stress[1, 1] == pytest.approx(expected[1], abs=2e-3 * scale)
    assert abs(stress[0, 1]) < 2e-3 * scale
    # the contact moments cancel: no disc turns (round-off aside) and none leaves the plane
    affine_speed = float(np.max(np.abs(eps))) / duration * 0.5 * d
    assert np.max(np.abs(state.angular_velocities[:, 2])) * 0.5 * d < 1e-6 * affine_speed
    assert planar_drift(state.positions, state.velocities, state.angular_velocities,
                        0.5 * t) == 0.0
    assert stress[2, 2] == 0.0
