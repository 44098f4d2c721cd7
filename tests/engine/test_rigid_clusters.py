"""The coarse level of rigid clusters (:mod:`grainlab.engine.nscd.rigid_clusters`): a group's
rigid motion leaves its internal contacts' relative velocities unchanged, the coarse Delassus
operator is symmetric, positive semi-definite and independent of where the packing sits,
groups of one body give back NLGS itself, and the cycles solve a frictional pile's step."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.nscd.contact_problem import ConstraintSystem, natural_map_error
from grainlab.engine.nscd.plain_problem_methods import solve
from grainlab.engine.nscd.rigid_clusters import (
    ClusterSpace,
    grid_clusters,
    sticking_clusters,
    two_level_solve,
)
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError

RADIUS, DT, G = 0.5e-3, 1e-4, 9.81


@pytest.fixture(scope="module")
def pile():
    """A step of 27 spheres of two sizes settled with friction in a box: its report, with
    the constraint system and the plain problem."""
    rng = np.random.default_rng(4)
    n_side = 3
    grid = np.stack(np.meshgrid(*[np.arange(n_side)] * 3, indexing="ij"), -1).reshape(-1, 3)
    positions = (grid + 0.5) * 2.04 * RADIUS + rng.uniform(-0.02, 0.02, grid.shape) * RADIUS
    library = ShapeLibrary.from_spheres([RADIUS, 0.8 * RADIUS])
    state = BodyState.from_library(library, rng.integers(0, 2, len(positions)), positions,
                                   density=2600.0)
    box = WallBox(np.zeros(3), np.full(3, n_side * 2.06 * RADIUS), friction=0.3)
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=0.3, tolerance=1e-8,
                               max_iterations=5000, seed=1)
    for _ in range(80):
        step.step(state, library, box)
    step.keep_problem = True
    report = step.step(state, library, box)
    assert report.n_contacts > 30 and report.system.centres.shape == (27, 3)
    return report


def halves(centres):
    return (centres[:, 0] > np.median(centres[:, 0])).astype(np.int64)


def test_a_group_s_rigid_motion_leaves_its_internal_contacts_at_rest(pile):
    system, problem = pile.system, pile.problem
    space = ClusterSpace.of(system, problem, halves(system.centres))
    assert space.internal.size and space.external.size
    assert np.union1d(space.internal, space.external).size == problem.n_contacts
    rigid = np.random.default_rng(0).normal(size=space.prolongation.shape[1])
    motion = space.prolongation @ rigid
    relative = (system.constraints @ motion).reshape(-1, 3)
    assert np.abs(relative[space.internal]).max() < 1e-12 * np.abs(motion).max()
    # and moves the external ones (a wall contact or a contact across the halves)
    assert np.abs(relative[space.external]).max() > 1e-3 * np.abs(motion).max()


def test_the_coarse_operator_is_symmetric_semi_definite_and_moves_with_the_packing(pile):
    system, problem = pile.system, pile.problem
    labels = halves(system.centres)
    coarse = ClusterSpace.of(system, problem, labels).coarse_delassus.toarray()
    np.testing.assert_allclose(coarse, coarse.T, atol=1e-12 * np.abs(coarse).max())
    assert np.linalg.eigvalsh(coarse).min() > -1e-9 * np.abs(coarse).max()
    # the same packing elsewhere: the rigid motions about each group's centre of mass
    shifted = ConstraintSystem(system.constraints, system.inverse_mass,
                               system.free_velocity,
                               system.centres + np.array([0.3, -2.0, 7.0]))
    moved = ClusterSpace.of(shifted, problem, labels).coarse_delassus.toarray()
    np.testing.assert_allclose(moved, coarse, atol=1e-9 * np.abs(coarse).max())


def test_groups_of_one_body_are_the_step_s_own_problem(pile):
    system, problem = pile.system, pile.problem
    singletons = np.arange(system.centres.shape[0])
    space = ClusterSpace.of(system, problem, singletons)
    assert space.internal.size == 0
    np.testing.assert_allclose(space.coarse_delassus.toarray(), problem.delassus.toarray(),
                               atol=1e-9 * abs(problem.delassus).max())
    # the coarse sweeps are then NLGS's own sweeps
    start = solve(problem, "nlgs", max_iterations=3, tolerance=1e-300).reactions
    corrected, work = space.correct(system, problem, start, 5, project=False,
                                    internal=False)
    direct = solve(problem, "nlgs", max_iterations=5, tolerance=1e-300, reactions=start)
    np.testing.assert_allclose(corrected, direct.reactions,
                               atol=1e-9 * np.abs(direct.reactions).max())
    assert work == pytest.approx(5.0)


@pytest.mark.parametrize("grouping", ["halves", "sticking"])
def test_the_cycles_solve_a_frictional_pile_step(pile, grouping):
    system, problem = pile.system, pile.problem
    labels = halves(system.centres) if grouping == "halves" else sticking_clusters(
        pile.contacts.body_i, pile.contacts.body_j, pile.impulses, problem.friction,
        system.centres.shape[0], 6)
    history = two_level_solve(system, problem, labels, work_limit=4000.0,
                              smoothing_sweeps=40)
    assert history.errors[-1] < 1e-6
    # Coulomb at every contact: inside the cone, no pull
    r = history.reactions.reshape(-1, 3)
    assert np.all(r[:, 0] >= 0.0)
    assert np.all(np.hypot(r[:, 1], r[:, 2]) <= problem.friction * r[:, 0] * (1 + 1e-9)
                  + 1e-15)
    assert natural_map_error(problem, history.reactions) == pytest.approx(history.errors[-1])


def test_sticking_groups_hold_at_most_their_size_and_follow_sticking_contacts(pile):
    n = pile.system.centres.shape[0]
    labels = sticking_clusters(pile.contacts.body_i, pile.contacts.body_j, pile.impulses,
                               pile.problem.friction, n, 4)
    assert np.bincount(labels).max() <= 4 and labels.min() == 0
    r = pile.impulses
    sticking = (pile.contacts.body_i >= 0) & (r[:, 0] > 0) & (
        np.hypot(r[:, 1], r[:, 2]) < 0.98 * pile.problem.friction * r[:, 0])
    for group in np.unique(labels):
        members = np.flatnonzero(labels == group)
        if members.size == 1:
            continue
        inside = sticking & np.isin(pile.contacts.body_i, members) \
            & np.isin(pile.contacts.body_j, members)
        assert inside.sum() >= members.size - 1  # a tree of sticking contacts at least


def test_bad_groupings_are_refused(pile):
    with pytest.raises(InputError, match="labels"):
        ClusterSpace.of(pile.system, pile.problem, [0, 1])
    with pytest.raises(InputError, match="side"):
        grid_clusters(pile.system.centres, 0.0)
