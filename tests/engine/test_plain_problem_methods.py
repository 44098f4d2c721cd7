"""The plain frictional contact problem and its solvers: closed-form solutions of small
problems (a sphere on a floor or an incline, a stack, a wedge), every solver to the same error
on a problem stored from a grainlab step, the step's own impulses solving its assembled
problem, relabelling invariance, FCLib files (research/cd_engines.md 6.2-6.3)."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import scipy.sparse as sp

from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.nscd import plain_problem_methods
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.nscd.contact_problem import (
    FrictionalContactProblem,
    assemble_problem,
    natural_map_error,
    read_fclib,
    write_fclib,
)
from grainlab.engine.nscd.plain_problem_methods import METHODS, jacobi_relaxation_bound, solve
from grainlab.engine.nscd.sweep_arrays import BodyRows, ContactRows, WallRows
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import contact_frames
from grainlab.errors import InputError, SolverDivergence

G, H, MASS = 9.81, 1e-3, 0.5
TIGHT = 1e-10
DT_PILE = 1e-4
CAPS = {"nlgs": 2000, "psor": 2000, "apgd": 20000, "jacobi": 20000, "nlgs-subspace": 2000}

FLOOR_ROWS = WallRows([[0.0, 0.0, 1.0]], [0.0], [0.0], [np.inf])  # a fixed floor z = 0


def wall_problem(normals, mu, inv_inertia=None, gravity=(0.0, 0.0, -G)):
    """One body of mass MASS at rest at the origin touching fixed walls (plane normals
    ``normals``, pointing at the body) at the points -n R, after one step of gravity."""
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    c = normals.shape[0]
    inertia = np.zeros((1, 3, 3)) if inv_inertia is None else inv_inertia
    return assemble_problem(
        ContactRows(body_i=-1 - np.arange(c), body_j=np.zeros(c, dtype=np.int64),
                    frame=contact_frames(normals), arm_i=np.zeros((c, 3)),
                    arm_j=-0.1 * normals, images=np.zeros((c, 3)), mu=np.full(c, mu),
                    gap=np.zeros(c)),
        BodyRows(inv_mass=[1.0 / MASS], inv_inertia=inertia,
                 free_velocities=[np.asarray(gravity) * H], free_spins=np.zeros((1, 3))),
        WallRows(normals=normals, inv_mass=np.zeros(c), free_speeds=np.zeros(c),
                 max_speeds=np.full(c, np.inf)), None, H)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("theta_deg,mu", [(20.0, 0.5), (35.0, 0.5), (10.0, 0.0)])
def test_sphere_on_an_incline_sticks_or_slides_as_coulomb_says(method, theta_deg, mu):
    theta = np.radians(theta_deg)
    normal = [np.sin(theta), 0.0, np.cos(theta)]  # the incline rises along -x
    problem = wall_problem([normal], mu)  # rotation locked (zero inverse inertia)
    solution = solve(problem, method, tolerance=TIGHT, max_iterations=CAPS[method])
    assert solution.converged, solution.error
    r = solution.reactions
    weight = MASS * G * H
    assert r[0] == pytest.approx(weight * np.cos(theta), rel=1e-8)
    slip = solution.velocities[1:]
    if np.tan(theta) < mu:  # sticks: friction carries the whole tangential weight
        assert np.hypot(r[1], r[2]) == pytest.approx(weight * np.sin(theta), rel=1e-8)
        assert np.abs(slip).max() < 1e-9 * G * H
    else:  # slides down with a = g (sin - mu cos), friction at its limit
        assert np.hypot(r[1], r[2]) == pytest.approx(mu * r[0], rel=1e-8, abs=1e-15)
        assert np.hypot(*slip) == pytest.approx(
            G * H * (np.sin(theta) - mu * np.cos(theta)), rel=1e-7)


@pytest.mark.parametrize("method", METHODS)
def test_a_stack_of_three_spheres_carries_its_weight_down(method):
    # spheres 0, 1, 2 stacked on the floor: contacts floor-0, 0-1, 1-2
    body_i = np.array([-1, 0, 1])
    body_j = np.array([0, 1, 2])
    normals = np.tile([0.0, 0.0, 1.0], (3, 1))
    problem = assemble_problem(
        ContactRows(body_i, body_j, contact_frames(normals), np.tile([0.0, 0.0, 0.1], (3, 1)),
                    np.tile([0.0, 0.0, -0.1], (3, 1)), np.zeros((3, 3)), np.full(3, 0.4),
                    np.zeros(3)),
        BodyRows(np.full(3, 1.0 / MASS), np.tile(np.eye(3) * 250.0, (3, 1, 1)),
                 np.tile([0.0, 0.0, -G * H], (3, 1)), np.zeros((3, 3))),
        FLOOR_ROWS, None, H)
    solution = solve(problem, method, tolerance=TIGHT, max_iterations=CAPS[method])
    assert solution.converged
    np.testing.assert_allclose(solution.reactions.reshape(3, 3)[:, 0],
                               MASS * G * H * np.array([3.0, 2.0, 1.0]), rtol=1e-8)
    np.testing.assert_allclose(solution.reactions.reshape(3, 3)[:, 1:], 0.0, atol=1e-14)
    assert np.abs(solution.velocities).max() < 1e-9 * G * H  # all at rest


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_a_sphere_in_a_wedge_is_held_at_rest(method, mu):
    alpha = np.radians(30.0)  # each wall's normal alpha from the vertical
    normals = [[np.sin(alpha), 0.0, np.cos(alpha)], [-np.sin(alpha), 0.0, np.cos(alpha)]]
    problem = wall_problem(normals, mu)
    solution = solve(problem, method, tolerance=TIGHT, max_iterations=CAPS[method])
    assert solution.converged
    r = solution.reactions.reshape(2, 3)
    frames = contact_frames(np.array(normals) / np.linalg.norm(normals, axis=1)[:, None])
    world = np.einsum("cji,cj->i", frames, r)  # total impulse on the sphere
    np.testing.assert_allclose(world, [0.0, 0.0, MASS * G * H], atol=1e-8 * MASS * G * H)
    assert np.abs(solution.velocities).max() < 1e-8 * G * H
    if mu == 0.0:  # frictionless: unique, P_n = m g h / (2 cos alpha)
        np.testing.assert_allclose(r[:, 0], MASS * G * H / (2 * np.cos(alpha)), rtol=1e-8)


def settled_pile(n_side=3, steps=300, seed=2):
    """A small pile of spheres falling into a fixed box, and the solver that moved it."""
    rng = np.random.default_rng(seed)
    radius = 0.5e-3
    grid = np.stack(np.meshgrid(*[np.arange(n_side)] * 3, indexing="ij"), -1).reshape(-1, 3)
    positions = (grid + 0.5) * 2.2 * radius + rng.uniform(-0.05, 0.05, grid.shape) * radius
    library = ShapeLibrary.from_spheres([radius, 0.8 * radius])
    ids = rng.integers(0, 2, len(positions))
    state = BodyState.from_library(library, ids, positions, density=2600.0)
    box = WallBox(np.zeros(3), np.full(3, n_side * 2.2 * radius), friction=0.3)
    step = ContactDynamicsStep(dt=DT_PILE, gravity=(0.0, 0.0, -G), friction=0.4,
                               tolerance=1e-7, max_iterations=5000, seed=seed)
    for _ in range(steps):
        step.step(state, library, box)
    return state, library, box, step


@pytest.fixture(scope="module")
def stored_step():
    state, library, box, step = settled_pile()
    step.keep_problem = True
    report = step.step(state, library, box)
    assert report.converged and report.n_contacts > 40
    return report


def test_the_steps_impulses_solve_its_assembled_problem(stored_step):
    problem = stored_step.problem
    assert problem.n_contacts == stored_step.n_contacts
    r = stored_step.impulses.ravel()
    # u = W r + q is the end-of-step relative velocity with the gap term on the normal
    u = problem.velocity(r).reshape(-1, 3)
    expected = stored_step.relative_velocity.copy()
    expected[:, 0] += np.maximum(stored_step.contacts.gap, 0.0) / DT_PILE
    scale = np.abs(problem.free_velocity).max()
    np.testing.assert_allclose(u, expected, atol=1e-10 * scale)
    assert natural_map_error(problem, r) < 1e-5
    w = problem.delassus
    assert abs(w - w.T).max() <= 1e-12 * abs(w).max()  # symmetric


def test_every_solver_reaches_the_same_solution_on_a_stored_step(stored_step):
    problem = stored_step.problem
    reference = solve(problem, "nlgs", tolerance=1e-12, max_iterations=20000)
    assert reference.converged
    scale = np.abs(reference.reactions).max()
    for method in METHODS:
        solution = solve(problem, method, tolerance=1e-9, max_iterations=CAPS[method] * 10)
        assert solution.converged, (method, solution.error, solution.iterations)
        assert solution.errors[-1] == pytest.approx(solution.error, rel=1e-6)
        # the normal impulses are unique here (a strictly monotone network); compare them
        np.testing.assert_allclose(solution.velocities, reference.velocities,
                                   atol=1e-6 * np.abs(problem.free_velocity).max())
        np.testing.assert_allclose(solution.reactions[0::3], reference.reactions[0::3],
                                   atol=1e-4 * scale)


def test_relabelled_contacts_give_the_relabelled_solution(stored_step):
    problem = stored_step.problem
    n = problem.n_contacts
    permutation = np.random.default_rng(5).permutation(n)
    rows = (3 * permutation[:, None] + np.arange(3)).ravel()
    relabelled = FrictionalContactProblem(problem.delassus[rows][:, rows],
                                          problem.free_velocity[rows],
                                          problem.friction[permutation])
    original = solve(problem, "nlgs", tolerance=1e-12, max_iterations=20000)
    # visiting the relabelled contacts in the same physical order: the same iterates
    inverse = np.argsort(permutation)
    again = solve(relabelled, "nlgs", tolerance=1e-12, max_iterations=20000,
                  order=inverse[np.arange(n)])
    np.testing.assert_allclose(again.reactions, original.reactions[rows],
                               atol=1e-12 * np.abs(original.reactions).max())
    assert again.iterations == original.iterations


def test_fclib_files_round_trip_in_every_matrix_layout(stored_step, tmp_path):
    problem = stored_step.problem
    solution = solve(problem, "nlgs", tolerance=1e-10, max_iterations=20000)
    path = write_fclib(problem, tmp_path / "step.hdf5", title="pile",
                       reactions=solution.reactions)
    stored = read_fclib(path)
    assert stored.title == "pile"
    assert abs(stored.problem.delassus - problem.delassus).max() == 0.0
    np.testing.assert_array_equal(stored.problem.free_velocity, problem.free_velocity)
    np.testing.assert_array_equal(stored.reactions, solution.reactions)
    assert natural_map_error(stored.problem, stored.reactions) == pytest.approx(
        solution.error)
    # the same W written as compressed columns and as triplets, as other codes do
    for nz, matrix in ((-1, sp.csc_matrix(problem.delassus)),
                       (7, sp.coo_matrix(problem.delassus))):
        with h5py.File(path, "r+") as f:
            group = f["fclib_local/W"]
            for name in ("p", "i", "x", "nz", "nzmax"):
                del group[name]
            if nz == -1:
                p, i = matrix.indptr, matrix.indices
            else:
                nz = matrix.nnz
                p, i = matrix.col, matrix.row
            group["p"], group["i"], group["x"] = p.astype(np.int32), i.astype(np.int32), \
                matrix.data
            group["nz"] = np.array([nz], dtype=np.int32)
            group["nzmax"] = np.array([matrix.nnz], dtype=np.int32)
        again = read_fclib(path).problem
        assert abs(again.delassus - problem.delassus).max() == 0.0


def test_bad_problems_and_options_are_refused_with_the_field_named():
    w = np.eye(3)
    with pytest.raises(InputError, match="friction"):
        FrictionalContactProblem(w, [-1.0, 0.0, 0.0], [-0.1])
    with pytest.raises(InputError, match="delassus"):
        FrictionalContactProblem(np.eye(6), [-1.0, 0.0, 0.0], [0.1])
    with pytest.raises(InputError, match="free_velocity"):
        FrictionalContactProblem(w, [-1.0, 0.0], [0.1])
    problem = FrictionalContactProblem(w, [-1.0, 0.0, 0.0], [0.1])
    with pytest.raises(InputError, match="method"):
        solve(problem, "newton")
    with pytest.raises(InputError, match="order"):
        solve(problem, "nlgs", order=[1])
    with pytest.raises(InputError, match="relaxation"):
        solve(problem, "psor", relaxation=2.5)


def test_a_capped_solve_says_it_did_not_converge():
    # a 40-sphere chain pressed from both ends converges slowly: 3 sweeps are not enough
    n = 40
    body_i = np.concatenate([[-1], np.arange(n - 1)])
    body_j = np.arange(n)
    normals = np.tile([0.0, 0.0, 1.0], (n, 1))
    problem = assemble_problem(
        ContactRows(body_i, body_j, contact_frames(normals), np.tile([0.0, 0.0, 0.1], (n, 1)),
                    np.tile([0.0, 0.0, -0.1], (n, 1)), np.zeros((n, 3)), np.full(n, 0.4),
                    np.zeros(n)),
        BodyRows(np.ones(n), np.tile(np.eye(3), (n, 1, 1)), np.tile([0.0, 0.0, -1.0], (n, 1)),
                 np.zeros((n, 3))),
        FLOOR_ROWS, None, 1.0)
    capped = solve(problem, "nlgs", tolerance=1e-10, max_iterations=3)
    assert not capped.converged and capped.iterations == 3 and capped.error > 1e-10
    assert np.all(np.diff(capped.errors) <= 0.0) or capped.errors.size == 3


@pytest.mark.parametrize("sweep", ["serial", "coloured"])
def test_a_step_may_converge_on_the_residual_alone(sweep):
    """Without a change tolerance (inf) a step stops once the natural-map residual is below
    the tolerance, found by the running residual: never more sweeps than with both criteria,
    and the residual still held."""
    import copy

    state, library, box, _ = settled_pile(steps=200)
    reports = {}
    for change_tolerance in (None, np.inf):
        step = ContactDynamicsStep(dt=DT_PILE, gravity=(0.0, 0.0, -G), friction=0.4,
                                   tolerance=1e-6, max_iterations=5000, seed=2, sweep=sweep,
                                   change_tolerance=change_tolerance)
        moved, walls = copy.deepcopy(state), copy.deepcopy(box)
        reports[change_tolerance] = [step.step(moved, library, walls) for _ in range(20)]
    both, residual_only = reports[None], reports[np.inf]
    assert all(r.converged and r.residual <= 1e-6 for r in both + residual_only)
    assert all(r.change <= 1e-6 for r in both)
    assert sum(r.iterations for r in residual_only) < sum(r.iterations for r in both)


def sticking_cluster(n=48, rank=20, spread=0.1, mu=0.7, seed=0):
    """A local problem of n contacts whose W = A A^T + spread rank 1 (A (3n, rank) random
    normal) couples every contact to every other through ``rank`` degrees of freedom, as in
    a dense cluster where every body carries many contacts: lambda_max(D W) ~ 7-9, far above
    the 4 that Jacobi's default relaxation 0.5 tolerates. q = -W r* for impulses r* inside
    their cones, so r* (with u = 0, sticking everywhere) is the solution. Returns the
    problem and r* (3n,) [N s]."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(3 * n, rank))
    w = a @ a.T + spread * rank * np.eye(3 * n)
    r = np.zeros((n, 3))
    r[:, 0] = rng.uniform(0.5, 1.5, n)
    t = rng.normal(size=(n, 2))
    t /= np.linalg.norm(t, axis=1)[:, None]
    r[:, 1:] = t * 0.5 * mu * r[:, :1] * rng.uniform(0.0, 1.0, (n, 1))
    return FrictionalContactProblem(w, -w @ r.ravel(), np.full(n, mu)), r.ravel()


def test_a_divergence_is_caught_through_the_package_as_a_convergence_error():
    import grainlab as gl

    problem, _ = sticking_cluster()
    with pytest.raises(gl.ConvergenceError) as caught:  # what a script catches
        solve(problem, "jacobi", tolerance=1e-10, max_iterations=100_000)
    assert type(caught.value) is gl.SolverDivergence is SolverDivergence


def test_a_diverging_jacobi_stops_early_and_names_the_relaxation_that_helps():
    problem, exact = sticking_cluster()
    bound = jacobi_relaxation_bound(problem)
    assert bound < 0.5 / 2  # Jacobi's default is twice beyond its stable bound here
    with pytest.raises(SolverDivergence) as caught:
        solve(problem, "jacobi", tolerance=1e-10, max_iterations=100_000)
    message = str(caught.value)
    assert "'jacobi' diverged" in message and "48 contacts" in message
    assert "relaxation = 0.5 (the default)" in message
    stated = float(message.split("2 / lambda_max(D W) = ")[1].split()[0])
    assert stated == pytest.approx(bound, rel=1e-2)
    iterations = int(message.split(" iterations")[0].rsplit(" ", 1)[1])
    assert iterations < 1000  # stopped once the error passed the bound, not at the cap
    # the advice works: below the bound Jacobi finds the sticking solution
    advised = float(message.split("relaxation=")[1].split(")")[0])
    assert advised < bound
    solution = solve(problem, "jacobi", tolerance=1e-10, max_iterations=20_000,
                     relaxation=advised)
    assert solution.converged
    np.testing.assert_allclose(solution.reactions, exact, atol=1e-6 * np.abs(exact).max())


def test_a_non_finite_error_stops_the_solve_even_without_the_growth_bound(monkeypatch):
    monkeypatch.setattr(plain_problem_methods, "DIVERGENCE_FACTOR", np.inf)
    problem, _ = sticking_cluster(seed=1)
    with pytest.raises(SolverDivergence, match=r"error became (inf|nan) at iteration"):
        solve(problem, "jacobi", tolerance=1e-10, max_iterations=100_000)


@pytest.mark.parametrize("method", METHODS)
def test_the_flag_and_the_error_returned_are_the_stop_tests_own(method, stored_step):
    """The error returned is the one the iterations stopped on (errors[-1], the same bits),
    and converged is that number against the tolerance, on problems of several kinds and at
    tolerances down to where double precision cannot follow (1e-15, 1e-16): the flag and
    the error may not come from two evaluations that differ in the last bits."""
    theta = np.radians(35.0)
    problems = [wall_problem([[np.sin(theta), 0.0, np.cos(theta)]], 0.5),
                wall_problem([[0.5, 0.0, 0.866], [-0.5, 0.0, 0.866]], 0.3),
                stored_step.problem]
    problems += [sticking_cluster(spread=2.0, seed=seed)[0] for seed in range(3)]
    checked = {True: 0, False: 0}
    for problem in problems:
        relaxation = min(0.5, 0.9 * jacobi_relaxation_bound(problem)) \
            if method == "jacobi" else None
        for tolerance in (1e-6, 1e-10, 1e-12, 1e-13, 1e-15, 1e-16):
            solution = solve(problem, method, tolerance=tolerance, max_iterations=CAPS[method],
                             relaxation=relaxation)
            assert solution.error == solution.errors[-1]
            assert solution.converged == (solution.error <= tolerance)
            assert solution.iterations == solution.errors.size
            # the compiled error is the twin of natural_map_error, up to round-off
            assert solution.error == pytest.approx(
                natural_map_error(problem, solution.reactions), rel=1e-6, abs=1e-14)
            np.testing.assert_allclose(solution.velocities,
                                       problem.velocity(solution.reactions), rtol=0,
                                       atol=1e-12 * np.abs(problem.free_velocity).max())
            checked[solution.converged] += 1
    assert checked[True] and checked[False]  # both verdicts were met
