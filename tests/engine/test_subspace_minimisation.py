"""Subspace minimisation between Gauss-Seidel sweeps of a frictionless step: the closed-form
column, the same impulses as NLGS alone on a settled pile, a correction that never raises the
step's energy and does not depend on the contacts' numbering, steps with friction swept alone
(:mod:`grainlab.engine.nscd.subspace_minimisation`)."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.nscd.contact_problem import assemble_problem, natural_map_error
from grainlab.engine.nscd.plain_problem_methods import solve
from grainlab.engine.nscd.subspace_minimisation import NormalCoupling, subspace_correction
from grainlab.engine.nscd.sweep_arrays import BodyRows, CellRows, ContactRows, WallRows
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import contact_frames
from grainlab.errors import InputError
from grainlab.lab.run_config import RunConfig

G, R, DT = 9.81, 0.5, 1e-3
FLOOR = ([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])


def column(n: int):
    library = ShapeLibrary.from_spheres([R])
    positions = [[0.0, 0.0, R + 2 * R * k] for k in range(n)]
    return library, BodyState.from_library(library, [0] * n, positions, density=1000.0)


@pytest.mark.parametrize("sweep", ["serial", "coloured"])
def test_a_tall_frictionless_column_carries_its_weight_down_in_few_sweeps(sweep):
    # contact k from the floor carries the weight of the n - k spheres above it: the slow
    # case of Gauss-Seidel, whose error spreads one contact per sweep
    n = 40
    sweeps = {}
    for correction in ("none", "subspace"):
        library, state = column(n)
        m = state.masses[0]
        step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=0.0,
                                   tolerance=1e-9, max_iterations=20000, sweep=sweep,
                                   correction=correction)
        report = step.step(state, library, FLOOR)
        assert report.converged
        below = np.where(report.contacts.body_i < 0, -1, report.contacts.body_i)
        np.testing.assert_allclose(report.impulses[:, 0], (n - 1 - below) * m * G * DT,
                                   rtol=1e-6)
        assert np.abs(state.velocities).max() < 1e-6 * G * DT
        sweeps[correction] = report.iterations
        if correction == "subspace":
            assert step.correction_products > 0
    assert sweeps["subspace"] * 5 < sweeps["none"]


def frictionless_pile(n_side: int = 4, steps: int = 60, seed: int = 2):
    """Spheres of two sizes dropped into a frictionless box and settled by NLGS alone."""
    rng = np.random.default_rng(seed)
    radius = 0.5e-3
    grid = np.stack(np.meshgrid(*[np.arange(n_side)] * 3, indexing="ij"), -1).reshape(-1, 3)
    positions = (grid + 0.5) * 2.2 * radius + rng.uniform(-0.05, 0.05, grid.shape) * radius
    library = ShapeLibrary.from_spheres([radius, 0.8 * radius])
    state = BodyState.from_library(library, rng.integers(0, 2, len(positions)), positions,
                                   density=2600.0)
    box = WallBox(np.zeros(3), np.full(3, n_side * 2.2 * radius), friction=0.0)
    step = ContactDynamicsStep(dt=1e-4, gravity=(0.0, 0.0, -G), friction=0.0,
                               tolerance=1e-7, max_iterations=5000, seed=seed)
    for _ in range(steps):
        step.step(state, library, box)
    return state, library, box


def test_a_pile_step_has_the_same_impulses_with_and_without_the_correction():
    state, library, box = frictionless_pile()
    reports = {}
    for correction in ("none", "subspace"):
        copy = BodyState.from_library(library, state.shape_ids, state.positions.copy(),
                                      density=2600.0)
        copy.velocities[:] = state.velocities
        step = ContactDynamicsStep(dt=1e-4, gravity=(0.0, 0.0, -G), friction=0.0,
                                   tolerance=1e-9, max_iterations=20000,
                                   correction=correction)
        step.keep_problem = True
        reports[correction] = (step.step(copy, library, box), copy)
    (plain, plain_state), (corrected, corrected_state) = reports["none"], reports["subspace"]
    assert plain.converged and corrected.converged
    np.testing.assert_array_equal(plain.contacts.body_j, corrected.contacts.body_j)
    scale = plain.impulses[:, 0].max()
    np.testing.assert_allclose(corrected.impulses, plain.impulses, atol=1e-6 * scale)
    speed = np.abs(plain_state.velocities).max() + G * 1e-4
    np.testing.assert_allclose(corrected_state.velocities, plain_state.velocities,
                               atol=1e-6 * speed)
    # Signorini at every contact: the corrected impulses solve the step's own problem
    assert natural_map_error(corrected.problem, corrected.impulses) < 1e-7


def chain_system(n: int, free_speed: float = -1.0):
    """A frictionless chain of n unit masses on a fixed floor (contacts floor-0, 0-1, ...,
    all along z), every body moving down at ``free_speed``, rotation locked."""
    normals = np.tile([0.0, 0.0, 1.0], (n, 1))
    rows = ContactRows(np.arange(-1, n - 1), np.arange(n), contact_frames(normals),
                       np.tile([0.0, 0.0, 0.1], (n, 1)), np.tile([0.0, 0.0, -0.1], (n, 1)),
                       np.zeros((n, 3)), np.zeros(n), np.zeros(n))
    bodies = BodyRows(np.ones(n), np.zeros((n, 3, 3)), np.tile([0.0, 0.0, free_speed], (n, 1)),
                      np.zeros((n, 3)))
    walls = WallRows([[0.0, 0.0, 1.0]], [0.0], [0.0], [np.inf])
    return rows, bodies, walls


def energy(problem, normal):
    r = np.zeros(3 * normal.size)
    r[0::3] = normal
    return 0.5 * r @ (problem.delassus @ r) + problem.free_velocity @ r


def test_a_correction_never_raises_the_energy_and_reaches_the_chain_s_solution():
    n = 12
    rows, bodies, walls = chain_system(n)
    coupling = NormalCoupling.of(rows, bodies, walls, None)
    problem = assemble_problem(rows, bodies, walls, None, 1.0)
    rng = np.random.default_rng(0)
    normal = rng.uniform(0.0, 2.0 * n, n)
    normal[3] = 0.0  # an unloaded contact: left out of the subspace, then loaded by the sweeps
    energies = [energy(problem, normal)]
    for _ in range(30):
        start = solve(problem, "nlgs", reactions=np.column_stack(
            [normal, np.zeros((n, 2))]).ravel(), max_iterations=1, tolerance=1e-300)
        normal = start.reactions[0::3]
        energies.append(energy(problem, normal))
        velocity = problem.velocity(np.column_stack([normal, np.zeros((n, 2))]))[0::3]
        normal, gain = subspace_correction(coupling, normal, velocity, iterations=n)
        assert gain <= 0.0
        assert energy(problem, normal) == pytest.approx(energies[-1] + gain, abs=1e-9 * n * n)
        energies.append(energy(problem, normal))
    assert np.all(np.diff(energies) <= 1e-9 * n * n)
    # exact: contact k carries the momentum of the n - k bodies above it
    np.testing.assert_allclose(normal, n - np.arange(n), rtol=1e-9)


def test_a_correction_does_not_depend_on_the_numbering_of_the_contacts():
    n = 10
    rows, bodies, walls = chain_system(n)
    normal = np.linspace(1.0, 3.0, n)

    def corrected(contact_rows, impulses):
        problem = assemble_problem(contact_rows, bodies, walls, None, 1.0)
        velocity = problem.velocity(np.column_stack([impulses, np.zeros((n, 2))]))[0::3]
        return subspace_correction(NormalCoupling.of(contact_rows, bodies, walls, None),
                                   impulses, velocity, iterations=4)[0]

    order = np.random.default_rng(1).permutation(n)
    permuted = ContactRows(*(np.asarray(field)[order] for field in rows))
    np.testing.assert_allclose(corrected(permuted, normal[order]),
                               corrected(rows, normal)[order], rtol=1e-12)


def random_scene(seed: int):
    """Five bodies with random inverse masses and inertias, twelve contacts in random
    frames: between bodies, on fixed and on mobile walls, across a periodic cell with two
    free degrees of freedom."""
    rng = np.random.default_rng(seed)
    n_bodies, n_contacts = 5, 12
    body_i = rng.integers(-3, n_bodies, n_contacts)
    body_j = rng.integers(0, n_bodies, n_contacts)
    body_j[body_j == body_i] = (body_j[body_j == body_i] + 1) % n_bodies
    normals = rng.normal(size=(n_contacts, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    images = np.where(rng.random((n_contacts, 1)) < 0.4,
                      rng.integers(-1, 2, (n_contacts, 3)), 0).astype(float)
    rows = ContactRows(body_i, body_j, contact_frames(normals),
                       rng.normal(size=(n_contacts, 3)) * 1e-3,
                       rng.normal(size=(n_contacts, 3)) * 1e-3, images, np.zeros(n_contacts),
                       np.zeros(n_contacts))
    inertia = rng.normal(size=(n_bodies, 3, 3))
    inertia = np.einsum("bij,bkj->bik", inertia, inertia) * 1e8 + np.eye(3) * 1e8
    bodies = BodyRows(rng.uniform(10.0, 100.0, n_bodies), inertia,
                      rng.normal(size=(n_bodies, 3)), rng.normal(size=(n_bodies, 3)))
    wall_normals = rng.normal(size=(3, 3))
    wall_normals /= np.linalg.norm(wall_normals, axis=1)[:, None]
    walls = WallRows(wall_normals, [0.0, 5.0, 7.0], rng.normal(size=3), np.full(3, np.inf))
    basis = np.zeros((2, 3, 3))
    basis[0, 0, 0], basis[1, 0, 2] = 1e-2, 1e-2
    cell = CellRows(np.zeros((3, 3)), basis, np.array([3.0, 4.0]), np.zeros(2),
                    np.tile([-np.inf, np.inf], (2, 1)))
    return rows, bodies, walls, cell


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_products_are_the_normal_block_of_w(seed):
    rows, bodies, walls, cell = random_scene(seed)
    w_nn = assemble_problem(rows, bodies, walls, cell, 1.0).delassus[0::3, 0::3].toarray()
    coupling = NormalCoupling.of(rows, bodies, walls, cell)
    everything = np.arange(w_nn.shape[0])
    x = np.random.default_rng(seed + 10).normal(size=w_nn.shape[0])
    np.testing.assert_allclose(coupling.product(everything, x), w_nn @ x, rtol=1e-12,
                               atol=1e-12 * np.abs(w_nn).max() * np.abs(x).max())
    np.testing.assert_allclose(coupling.diagonal(everything), np.diag(w_nn), rtol=1e-12)
    subset = everything[::3]
    np.testing.assert_allclose(coupling.product(subset, x[subset]),
                               w_nn[np.ix_(subset, subset)] @ x[subset], rtol=1e-12,
                               atol=1e-12 * np.abs(w_nn).max() * np.abs(x).max())


def test_a_step_with_friction_is_swept_alone():
    library, state = column(6)
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=0.4, tolerance=1e-9,
                               correction="subspace")
    report = step.step(state, library, FLOOR)
    assert report.converged
    assert step.correction_products == 0


def test_an_unknown_correction_is_refused_by_name():
    with pytest.raises(InputError, match="correction"):
        ContactDynamicsStep(dt=DT, correction="multigrid")
    with pytest.raises(Exception, match="correction"):
        RunConfig.model_validate({"solver": {"correction": "multigrid"}})
    assert RunConfig.model_validate({}).settings().correction == "subspace"
    assert RunConfig.model_validate(
        {"solver": {"correction": "none"}}).settings().correction == "none"


def test_the_plain_method_solves_a_stored_pile_step_as_nlgs_does():
    state, library, box = frictionless_pile()
    step = ContactDynamicsStep(dt=1e-4, gravity=(0.0, 0.0, -G), friction=0.0,
                               tolerance=1e-7, max_iterations=5000)
    step.keep_problem = True
    problem = step.step(state, library, box).problem
    plain = solve(problem, "nlgs", tolerance=1e-10, max_iterations=20000)
    corrected = solve(problem, "nlgs-subspace", tolerance=1e-10, max_iterations=20000)
    assert plain.converged and corrected.converged
    assert corrected.products > 0
    scale = plain.reactions.max()
    np.testing.assert_allclose(corrected.reactions, plain.reactions, atol=1e-7 * scale)
    assert natural_map_error(problem, corrected.reactions) <= 1e-10
