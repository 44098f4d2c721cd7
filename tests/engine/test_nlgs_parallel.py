"""Graph colouring of contacts and the coloured (parallel) NLGS sweep against the serial one
(STYLE.md 11, 12).

The packing: a face-centred cubic lattice of spheres (nearest-neighbour distance 2 R) with
radii R (1 + 1e-4 (2 u - 1)), u uniform in [0, 1), so that the twelve neighbours of a sphere
touch within 2e-4 R = 0.2 um: overlapping slightly (not pushed apart) or apart by a gap that
a step closes at ~2 mm/s ~ 2 g h. It stands on the floor of a wall box whose side walls are
0.5 R away, so that it slumps, with a stress-controlled top wall touching it, under gravity
and with random initial velocities of the order of g h: some contacts open, some stick, some
slide.

With friction, the velocities of a step are not unique in general: from rest, this packing
slumps into slightly different (each converged, each lawful) motions for different visiting
orders. With the random initial velocities the serial and coloured solutions agree to
~1e-7 relative (seeds 0-3), which the comparison checks with margin.
"""

from __future__ import annotations

import copy

import numba
import numpy as np
import pytest

import grainlab.engine.nscd.contact_dynamics as contact_dynamics
import grainlab.engine.nscd.nlgs_parallel as nlgs_parallel
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.nscd.contact_colouring import (
    colour_contacts,
    colour_contacts_slow,
    slab_contacts,
)
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.nscd.sweep_arrays import (
    BodyRows,
    CellRows,
    ContactRows,
    Motion,
    SolveSettings,
    SweepGroups,
    WallRows,
)
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError

R = 1e-3  # m
DENSITY = 2500.0  # kg/m^3
G = 9.81  # m/s^2
DT = 1e-4  # s
MU = 0.3


def fcc_sample(cells=(2, 2, 2), seed=0, speed=2.0 * G * DT):
    """Library, state and box of the module docstring's packing; ``speed`` [m/s] scales the
    random initial velocities."""
    rng = np.random.default_rng(seed)
    a = 2.0 * np.sqrt(2.0) * R  # cubic cell of the FCC lattice
    nx, ny, nz = cells
    sites = np.array([(i, j, k) for i in range(2 * nx + 1) for j in range(2 * ny + 1)
                      for k in range(2 * nz + 1) if (i + j + k) % 2 == 0], dtype=float)
    positions = R + 0.5 * a * sites
    radii = R * (1.0 + 1e-4 * (2.0 * rng.random(len(sites)) - 1.0))
    library = ShapeLibrary.from_spheres(radii)
    state = BodyState.from_library(library, np.arange(len(sites)), positions, density=DENSITY)
    state.velocities[:] = speed * rng.uniform(-1.0, 1.0, state.velocities.shape)
    upper = 2.0 * R + a * np.array(cells, dtype=float) + np.array([0.5, 0.5, 0.0]) * R
    lower = -np.array([0.5, 0.5, 0.0]) * R
    box = WallBox(lower, upper, friction=MU, wall_mass=float(state.masses.sum()))
    weight = float(state.masses.sum()) * G
    box.set_control("z+", "stress", 0.5 * weight / float(box.face_areas[5]))
    return library, state, box


def run(sweep, n_steps, sample, tolerance=1e-8):
    """(state, box, step reports) after ``n_steps`` steps from a copy of ``sample``."""
    library, state, box = copy.deepcopy(sample)
    step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=MU, sweep=sweep,
                               tolerance=tolerance, max_iterations=5000)
    reports = [step.step(state, library, box) for _ in range(n_steps)]
    return state, box, reports


def assert_coulomb_signorini(report):
    p = report.impulses
    assert report.converged, (report.iterations, report.change, report.residual)
    assert (p[:, 0] >= 0.0).all()
    assert (np.linalg.norm(p[:, 1:], axis=1) <= MU * p[:, 0] * (1.0 + 1e-9)).all()


def assert_complementarity(report, state, box, tol=1e-6):
    """The contact law against end-of-step relative velocities recomputed here (NumPy, from
    the end state: x_m = x - theta h v, theta = 0.5): no approach, open or closed, sticking
    or sliding against the friction."""
    c, p = report.contacts, report.impulses
    x_m = state.positions - 0.5 * DT * state.velocities
    inner = c.body_i >= 0
    u = state.velocities[c.body_j] + np.cross(state.angular_velocities[c.body_j],
                                              c.point - x_m[c.body_j])
    i = c.body_i[inner]
    u[inner] -= state.velocities[i] + np.cross(state.angular_velocities[i],
                                               c.point[inner] - x_m[i])
    wall = -1 - c.body_i[~inner]
    u[~inner] -= box.speeds[wall, None] * box.normals[wall]
    u = np.einsum("cij,cj->ci", report.frames, u)
    u[:, 0] += np.maximum(c.gap, 0.0) / DT
    u_scale = max(float(np.abs(u).max()), G * DT)
    active = p[:, 0] > tol * p[:, 0].max()
    assert (u[:, 0] >= -tol * u_scale).all()
    assert (np.abs(u[active, 0]) <= tol * u_scale).all()
    slip = np.linalg.norm(u[:, 1:], axis=1)
    friction = np.linalg.norm(p[:, 1:], axis=1)
    sticking = active & (friction < MU * p[:, 0] * (1.0 - 1e-6))
    assert (slip[sticking] <= tol * u_scale).all()
    sliding = active & (slip > tol * u_scale)
    cosine = np.einsum("ci,ci->c", u[sliding, 1:], p[sliding, 1:]) / (
        slip[sliding] * friction[sliding])
    assert (cosine <= -1.0 + 1e-6).all()
    return int(sticking.sum()), int(sliding.sum())


# --------------------------------------------------------------------------------------------
# Colouring
# --------------------------------------------------------------------------------------------


def random_contacts(rng, n_bodies=60, n_pairs=400, n_wall=80):
    i = rng.integers(0, n_bodies, n_pairs)
    j = (i + rng.integers(1, n_bodies, n_pairs)) % n_bodies  # j != i
    walls = rng.integers(0, 4, n_wall)
    body_i = np.concatenate([i, -1 - walls])
    body_j = np.concatenate([j, rng.integers(0, n_bodies, n_wall)])
    mix = rng.permutation(body_i.size)
    return body_i[mix], body_j[mix]


def assert_valid_colouring(colouring, body_i, body_j, wall_inv_mass):
    n = body_i.size
    assert np.array_equal(np.sort(colouring.order), np.arange(n))
    offsets = colouring.offsets
    assert offsets[0] == 0 and offsets[-1] == n and (np.diff(offsets) >= 0).all()
    assert offsets.size == colouring.n_colours + 2
    mobile = (body_i < 0) & (wall_inv_mass[np.maximum(-1 - body_i, 0)] > 0.0)
    assert np.array_equal(np.sort(colouring.serial), np.flatnonzero(mobile))
    for c in range(colouring.n_colours):
        group = colouring.group(c)
        assert group.size > 0 and np.array_equal(group, np.sort(group))
        assert not mobile[group].any()
        bodies = np.concatenate([body_j[group], body_i[group][body_i[group] >= 0]])
        assert np.unique(bodies).size == bodies.size  # no body twice in one colour
        assert (colouring.colour[group] == c).all()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_colouring_is_valid_and_equals_the_slow_twin(seed):
    rng = np.random.default_rng(seed)
    body_i, body_j = random_contacts(rng)
    wall_inv_mass = np.array([0.0, 2.0, 0.0, 0.5])  # walls 1 and 3 are mobile
    colouring = colour_contacts(body_i, body_j, wall_inv_mass)
    assert_valid_colouring(colouring, body_i, body_j, wall_inv_mass)
    np.testing.assert_array_equal(colouring.colour,
                                  colour_contacts_slow(body_i, body_j, wall_inv_mass))


def test_colouring_spills_past_63_colours():
    # a star: 150 contacts on body 0 need 150 colours (three rounds of bit masks)
    body_j = np.zeros(150, dtype=np.int64)
    body_i = np.arange(1, 151)
    body_i[::7] = -1  # some on a driven wall: they still share body 0
    walls = np.zeros(1)
    colouring = colour_contacts(body_i, body_j, walls)
    assert colouring.n_colours == 150 and colouring.serial.size == 0
    assert_valid_colouring(colouring, body_i, body_j, walls)
    np.testing.assert_array_equal(colouring.colour, colour_contacts_slow(body_i, body_j, walls))


def test_colouring_of_the_packing_is_valid():
    sample = fcc_sample()
    _, _, reports = run("coloured", 1, sample)
    contacts = reports[0].contacts
    box = sample[2]
    wall_inv_mass = box.inverse_masses()
    colouring = colour_contacts(contacts.body_i, contacts.body_j, wall_inv_mass,
                                sample[1].n_bodies)
    assert_valid_colouring(colouring, contacts.body_i, contacts.body_j, wall_inv_mass)
    assert colouring.serial.size > 0  # the stress-controlled top wall carries contacts
    assert colouring.n_colours < 30


# --------------------------------------------------------------------------------------------
# Coloured against serial sweeps
# --------------------------------------------------------------------------------------------


def test_coloured_and_serial_sweeps_agree_and_obey_the_contact_laws():
    sample = fcc_sample()
    results = {sweep: run(sweep, 2, sample) for sweep in ("serial", "coloured")}
    (state_s, box_s, reports_s), (state_c, box_c, reports_c) = results.values()
    for report_s, report_c in zip(reports_s, reports_c, strict=True):
        assert report_s.n_contacts == report_c.n_contacts > 3 * sample[1].n_bodies
        assert_coulomb_signorini(report_s)
        assert_coulomb_signorini(report_c)
    n_stick, n_slide = assert_complementarity(reports_c[-1], state_c, box_c)
    assert n_stick > 10 and n_slide > 10
    assert_complementarity(reports_s[-1], state_s, box_s)
    scale = float(np.abs(state_s.velocities).max())
    assert scale > G * DT
    np.testing.assert_allclose(state_c.velocities, state_s.velocities, rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(state_c.angular_velocities, state_s.angular_velocities, rtol=0,
                               atol=1e-5 * scale / R)
    np.testing.assert_allclose(box_c.speeds, box_s.speeds, rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(state_c.positions, state_s.positions, rtol=0,
                               atol=1e-5 * scale * DT)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two Numba threads")
def test_coloured_sweep_does_not_depend_on_the_threads(monkeypatch):
    # every colour in parallel, whatever its size, on 1 and on 2 threads, and none in parallel
    sample = fcc_sample(seed=4)
    threads = numba.get_num_threads()
    outcomes = []
    try:
        for n_threads, forced in ((1, True), (2, True), (2, False)):
            numba.set_num_threads(n_threads)
            with monkeypatch.context() as patch:
                if forced:
                    patch.setattr(nlgs_parallel, "parallel_colours",
                                  lambda offsets, n_colours, n_threads: n_colours)
                outcomes.append(run("coloured", 2, sample, tolerance=1e-6))
    finally:
        numba.set_num_threads(threads)
    for outcome in outcomes[1:]:
        assert_same_run(outcome, outcomes[0])


def test_one_chain_in_the_serial_order_is_the_serial_sweep(monkeypatch):
    # the serial and coloured sweeps share one sweep body: the coloured kernel given a single
    # chain of every contact in the serial sweep's order (the contacts' own) repeats the
    # serial sweep's arithmetic, bit for bit (fewer contacts than a reduction block: the same
    # sums in the same order), iteration counts and wall motion included
    class InOrder:
        def permutation(self, n):
            return np.arange(n)

    def one_chain(rows, walls, x_m, serial):
        n_contacts = rows.body_i.shape[0]
        return SweepGroups(np.arange(n_contacts), np.array([0, 1]), np.array([0, n_contacts]),
                           np.arange(x_m.shape[0]), 0)

    monkeypatch.setattr(contact_dynamics, "_sweep_groups", one_chain)
    sample = fcc_sample(seed=2)
    outcomes = []
    for sweep in ("serial", "coloured"):
        library, state, box = copy.deepcopy(sample)
        step = ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=MU, sweep=sweep,
                                   tolerance=1e-8, max_iterations=5000)
        step._rng = InOrder()
        reports = [step.step(state, library, box) for _ in range(2)]
        assert 3 * state.n_bodies < reports[-1].n_contacts < nlgs_parallel._BLOCK
        outcomes.append((state, box, reports))
    assert_same_run(outcomes[1], outcomes[0])


def assert_same_run(outcome, reference):
    """Two runs (state, box, reports) bit for bit the same, each step obeying Coulomb and
    Signorini."""
    (state, box, reports), (state_0, box_0, reports_0) = outcome, reference
    np.testing.assert_array_equal(state.velocities, state_0.velocities)
    np.testing.assert_array_equal(state.angular_velocities, state_0.angular_velocities)
    np.testing.assert_array_equal(state.positions, state_0.positions)
    np.testing.assert_array_equal(box.speeds, box_0.speeds)
    for report, report_0 in zip(reports, reports_0, strict=True):
        assert report.iterations == report_0.iterations
        np.testing.assert_array_equal(report.impulses, report_0.impulses)
        assert_coulomb_signorini(report)


def test_kernel_with_no_contacts_returns_free_velocities():
    empty_i = np.zeros(0, dtype=np.int64)
    v_free = np.array([[1.0, 2.0, 3.0]])
    w_free = np.array([[0.1, 0.0, 0.0]])
    velocities, spins, residuals = np.empty((1, 3)), np.empty((1, 3)), np.ones(2)
    iterations = nlgs_parallel.nlgs_coloured_kernel(
        ContactRows(empty_i, empty_i, np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                    np.zeros((0, 3)), np.zeros(0), np.zeros(0)),
        BodyRows(np.ones(1), np.eye(3)[None], v_free, w_free),
        WallRows(np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0)),
        CellRows(np.zeros((3, 3)), np.zeros((0, 3, 3)), np.zeros(0), np.zeros(0),
                 np.zeros((0, 2))),
        SolveSettings(DT, 1e-5, 1e-5, 10),
        SweepGroups(empty_i, np.zeros(2, dtype=np.int64), np.zeros(1, dtype=np.int64),
                    np.zeros(1, dtype=np.int64), 0),
        Motion(velocities, spins, np.zeros(0), np.zeros(0), np.zeros((3, 3))),
        np.zeros((0, 3)), np.zeros((0, 3, 3)), residuals,
    )
    assert iterations == 0
    np.testing.assert_array_equal(velocities, v_free)
    np.testing.assert_array_equal(spins, w_free)
    np.testing.assert_array_equal(residuals, 0.0)


def test_parallel_colours_picks_the_large_leading_colours():
    offsets = np.array([0, 5000, 9000, 9500, 12000, 12010])  # 4 colours + serial group
    assert nlgs_parallel.parallel_colours(offsets, 4, n_threads=2, min_size=4000) == 2
    assert nlgs_parallel.parallel_colours(offsets, 4, n_threads=1, min_size=4000) == 0
    assert nlgs_parallel.parallel_colours(offsets, 4, n_threads=2, min_size=10) == 4
    big = np.array([0, 9000, 17500, 17600])  # 2 colours + serial group
    assert nlgs_parallel.parallel_colours(big, 2, n_threads=2) == 2  # default MIN_PARALLEL


def test_unknown_sweep_is_an_input_error():
    with pytest.raises(InputError, match="sweep"):
        ContactDynamicsStep(dt=DT, sweep="red-black")


# --------------------------------------------------------------------------------------------
# Slabs: packings too small for parallel colours
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n_slabs", [2, 3, 5])
def test_slab_chains_of_a_parallel_group_share_no_body(n_slabs):
    sample = fcc_sample(cells=(3, 2, 2))
    _, _, reports = run("coloured", 1, sample)
    contacts = reports[0].contacts
    _, state, box = sample
    wall_inv_mass = box.inverse_masses()
    slabs = slab_contacts(contacts.body_i, contacts.body_j, state.positions, wall_inv_mass,
                          n_slabs=n_slabs)
    n = contacts.n_contacts
    assert np.array_equal(np.sort(slabs.order), np.arange(n))  # every contact once
    assert slabs.chains[0] == 0 and slabs.chains[-1] == n
    body_i, body_j = contacts.body_i[slabs.order], contacts.body_j[slabs.order]
    mobile = (body_i < 0) & (wall_inv_mass[np.maximum(-1 - body_i, 0)] > 0.0)
    serial_rows = np.arange(slabs.chains[slabs.offsets[3]], n)
    assert mobile.any() and np.all(np.isin(np.flatnonzero(mobile), serial_rows))
    for group in range(3):
        seen: set[int] = set()
        for chain in range(slabs.offsets[group], slabs.offsets[group + 1]):
            rows = slice(slabs.chains[chain], slabs.chains[chain + 1])
            bodies = set(body_j[rows]) | set(body_i[rows][body_i[rows] >= 0])
            assert not bodies & seen  # chains of one group touch disjoint bodies
            seen |= bodies
    inside = slabs.chains[slabs.offsets[1]]
    assert inside > 0.5 * n  # most contacts lie inside a slab


def test_slab_count_is_a_power_of_two_that_follows_the_contacts():
    per = nlgs_parallel.SLAB_CONTACTS
    assert nlgs_parallel.slab_count(0) == 2 and nlgs_parallel.slab_count(4 * per - 1) == 2
    assert nlgs_parallel.slab_count(4 * per) == 4 and nlgs_parallel.slab_count(7 * per) == 4
    assert nlgs_parallel.slab_count(12 * per) == 8
    assert nlgs_parallel.slab_count(10**9) == nlgs_parallel.MAX_SLABS == 16


def test_slabs_are_never_thinner_than_a_contact_branch():
    # a chain of 20 spheres of diameter 1 along x: asked for 16 slabs, it gets 20 / 1 -> the
    # most that keeps every contact inside a slab or between neighbours (none serial)
    positions = np.zeros((21, 3))
    positions[:, 0] = np.arange(21.0)
    body_i, body_j = np.arange(20), np.arange(1, 21)
    wall_inv_mass = np.zeros(1)
    many = slab_contacts(body_i, body_j, positions, wall_inv_mass, n_slabs=16)
    assert many.chains.shape[0] == 2 * 16 + 1
    assert many.chains[-1] - many.chains[-2] == 0  # the serial chain is empty
    # contacts two spheres apart (branches of 2 along x): at most 20 / 2 = 10 slabs, so 8
    wide = slab_contacts(body_i[:-1], body_i[:-1] + 2, positions, wall_inv_mass, n_slabs=16)
    assert wide.chains.shape[0] == 2 * 8 + 1 and wide.chains[-1] == wide.chains[-2]
    # a periodic cell's contact across its boundary (the chain's two ends) does not thin the
    # cut: it goes to the serial chain
    wrapped = slab_contacts(np.append(body_i, 0), np.append(body_j, 20), positions,
                            wall_inv_mass, n_slabs=16)
    assert wrapped.chains.shape[0] == 2 * 16 + 1
    assert wrapped.order[wrapped.chains[-2]:].tolist() == [20]
    # cut into 16 slabs anyway, some of those contacts would skip a slab (the serial chain)
    slab = np.floor(positions[:, 0] / 20.0 * 16).clip(0, 15)
    assert np.any(np.abs(slab[body_i[:-1]] - slab[body_i[:-1] + 2]) > 1)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two Numba threads")
@pytest.mark.parametrize("slab_contacts_per", [nlgs_parallel.SLAB_CONTACTS, 8])
def test_slab_sweep_obeys_the_laws_and_does_not_depend_on_the_threads(monkeypatch,
                                                                     slab_contacts_per):
    # a small packing swept in slabs (MIN_SLABS lowered to reach it), on 1 and 2 threads: in
    # two slabs, and in as many as its size allows (SLAB_CONTACTS lowered)
    monkeypatch.setattr(nlgs_parallel, "MIN_SLABS", 16)
    monkeypatch.setattr(nlgs_parallel, "SLAB_CONTACTS", slab_contacts_per)
    sample = fcc_sample(cells=(3, 2, 2), seed=5)
    threads = numba.get_num_threads()
    outcomes = []
    try:
        for n_threads in (1, 2):
            numba.set_num_threads(n_threads)
            outcomes.append(run("coloured", 3, sample, tolerance=1e-7))
    finally:
        numba.set_num_threads(threads)
    assert_same_run(outcomes[1], outcomes[0])
    state_2, box_2, reports_2 = outcomes[1]
    assert_complementarity(reports_2[-1], state_2, box_2)
    # the same solution as the serial sweep, within the tolerance
    state_s, _, _ = run("serial", 3, sample, tolerance=1e-7)
    scale = float(np.abs(state_s.velocities).max())
    np.testing.assert_allclose(state_2.velocities, state_s.velocities, rtol=0,
                               atol=1e-4 * scale)
