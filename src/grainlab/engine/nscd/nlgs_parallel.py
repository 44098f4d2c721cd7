"""Parallel nonlinear Gauss-Seidel over graph-coloured contacts (Numba; research/cd_engines.md
6.3; STYLE.md 2, 12).

Same problem, local solver, body accumulators, warm start and convergence measures as
:func:`~grainlab.engine.nscd.serial_sweep.nlgs_kernel` (see the module docstring of
:mod:`~grainlab.engine.nscd.contact_dynamics`, whose scalar laws are reused); only the visiting
order differs. The contacts are grouped by
:func:`~grainlab.engine.nscd.contact_colouring.colour_contacts`: no two contacts of one colour share
a body, so a colour is swept with ``numba.prange`` (each iteration reads and writes only its own
two bodies: no race, and the result does not depend on which thread ran it), the colours one
after the other, then the serial group (contacts of mobile walls, which all share their wall)
in a plain loop. The caller chooses how many leading colours go parallel
(:func:`parallel_colours`): a colour of fewer than :data:`MIN_PARALLEL` contacts, and every
colour with one thread, is swept in a plain loop, since waking the threads costs more than
such a colour's work; the result is the same either way.

Layout. The per-contact arrays are first gathered into colour order (one parallel copy per
step, like one sweep), so that each colour is a contiguous range: a sweep streams through
memory instead of striding by the number of colours (which missed the cache on every contact
from ~10^4 contacts on), and the impulses and Delassus blocks are scattered back at the end.
The sweeps are compiled without the Numba runtime (``_nrt=False``): they allocate nothing, and
the arrays handed to the inlined scalar laws are then not reference-counted. With the runtime,
every inlined call increments and decrements the shared reference count of each array argument
atomically (measured: ~35 of the ~42 ns of one ``_relative_velocity`` call), which also
serialises the threads on those counters.

Convergence as in ``nlgs_kernel``: the relative change after every sweep, the residual pass
only after a sweep whose change is below the tolerance (and at the cap); a non-finite change
or residual ends the sweeps at once (the step then refuses the impulses).

Determinism. The update sweep is bitwise independent of the number of threads: the colour
order is fixed and contacts within a colour commute exactly. The sums of the convergence
measures (relative change, natural-map residual and their norms) are formed over fixed blocks
of ``_BLOCK`` contacts in parallel, then the block sums are added in block order, so they too
are independent of the thread count (they differ in rounding from the serial kernel's running
sums, as does the visiting order). The whole solve, iteration count included, is therefore
reproducible across thread counts.

>>> import numpy as np
>>> from grainlab.engine.nscd.sweep_arrays import (BodyRows, CellRows, ContactRows, Motion,
...     SolveSettings, SweepGroups, WallRows)
>>> contacts = ContactRows(                                     # floor - sphere 0 - sphere 1
...     np.array([-1, 0]), np.array([0, 1]), np.tile(np.eye(3)[[2, 0, 1]], (2, 1, 1)),
...     np.array([[0, 0, 0], [0, 0, 0.5]]), np.array([[0, 0, -0.5], [0, 0, -0.5]]),
...     np.zeros((2, 3)), np.full(2, 0.4), np.zeros(2))     # frames: rows n = e_z, t, s
>>> bodies = BodyRows(np.ones(2), np.tile(np.eye(3), (2, 1, 1)),
...                   np.array([[0, 0, -0.01], [0, 0, -0.01]]), np.zeros((2, 3)))
>>> walls = WallRows(np.array([[0.0, 0, 1]]), np.zeros(1), np.zeros(1), np.full(1, np.inf))
>>> no_cell = CellRows(np.zeros((3, 3)), np.zeros((0, 3, 3)), np.zeros(0), np.zeros(0),
...                    np.zeros((0, 2)))                        # wall box: no cell
>>> groups = SweepGroups(np.array([0, 1]), np.array([0, 1, 2, 2]), np.array([0, 1, 2]),
...                      np.array([0, 1]), 2)   # colours {0}, {1}, no serial; one per chain
>>> motion = Motion(np.empty((2, 3)), np.empty((2, 3)), np.zeros(1), np.zeros(0),
...                 np.zeros((3, 3)))
>>> impulses, delassus, residuals = np.zeros((2, 3)), np.empty((2, 3, 3)), np.zeros(2)
>>> sweeps = nlgs_coloured_kernel(contacts, bodies, walls, no_cell,
...     SolveSettings(1e-3, 1e-10, 1e-10, 100), groups, motion, impulses, delassus, residuals)
>>> bool(np.abs(motion.velocities).max() < 1e-9), impulses[:, 0].round(6).tolist()  # P_n
(True, [0.02, 0.01])
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainlab.engine.nscd.contact_colouring import power_of_two_below
from grainlab.engine.nscd.contact_update import SKIP_OPEN, SKIP_REVISIT
from grainlab.engine.nscd.delassus import delassus_kernel
from grainlab.engine.nscd.speed_limits import start_cell
from grainlab.engine.nscd.sweep_arrays import (
    BodyRows,
    ContactRows,
    Motion,
    SweepGroups,
    SweepWork,
)
from grainlab.engine.nscd.sweep_runs import (
    brake,
    check_residual,
    check_run,
    check_wanted,
    free_run,
    relative_change,
    solved,
    sweep_run,
    warm_run,
)

_BLOCK = 1024  # contacts per block of the parallel reductions (fixed: thread-independent)
_PARALLEL_BLOCKS = 8  # fewer blocks: the reductions in a plain loop (the same sums)
MIN_SLABS = 1024
"""From this many contacts, a step whose colours are all below :data:`MIN_COLOURS` is swept
in slabs (:func:`~grainlab.engine.nscd.contact_colouring.slab_contacts`) rather than colour by
colour, so that the threads share it; below it, colours (too little work to wake threads)."""
MIN_COLOURS = 8192
"""From this many contacts in its largest colour, a step is swept colour by colour (the
colours of :data:`MIN_PARALLEL` contacts or more in parallel); below it, in slabs. Measured
with ``benchmarks/benchmark_engine_contact_dynamics.py``'s packings on 2 cores, 2 threads,
ns per contact update: 10^4 spheres (colours of 1.4-2.6 thousand contacts) 34-35 in colours,
21 in slabs (2 to 16 of them: the same), as each colour's work is little more than waking
the threads; 10^5 spheres (colours of ~14 thousand) 37 in colours, 39 in slabs."""
SLAB_CONTACTS = 4096
"""Contacts per slab when a step is swept in slabs: :func:`slab_count` cuts a packing into
the largest power of two of slabs up to C // SLAB_CONTACTS, between 2 and :data:`MAX_SLABS`
(2 up to 16 383 contacts: 1000 spheres, 1000 polyhedra of 30 faces), so that more threads
than two have slabs to share. A power of two shares them evenly between 2, 4, 8 or 16
threads: 3 slabs on 2 threads leave one thread two slabs' work and the other one (1000
polyhedra of 30 faces: 141 ms a step instead of 131). The count depends on the packing
only, never on the threads."""
MAX_SLABS = 16
"""Most slabs of one step (:data:`SLAB_CONTACTS`)."""


def slab_count(n_contacts: int) -> int:
    """Slabs of a step of ``n_contacts`` contacts swept in slabs (:data:`SLAB_CONTACTS`): a
    power of two from 2 to :data:`MAX_SLABS`."""
    return power_of_two_below(min(MAX_SLABS, max(2, n_contacts // SLAB_CONTACTS)))


MIN_PARALLEL = 1024
"""Colours with fewer contacts are swept in a plain loop (:func:`parallel_colours`). Measured
with the TBB layer on 2 cores (``benchmarks/benchmark_engine_contact_dynamics.py``, one
thread 109-138 ns per contact update at 10^4 spheres): colours of ~2600 contacts in parallel
take 10^4 spheres from 127 ns (all colours in a loop, the former threshold of 8192 set for the
workqueue layer's ~80 us launches) to 63-74 ns per update; colours of 250-500 contacts (1000
spheres) lose: 47 ns in a loop, 65 ns in parallel."""


# --------------------------------------------------------------------------------------------
# Runs of contacts (the sweep body of :mod:`~grainlab.engine.nscd.sweep_runs`, compiled once)
# --------------------------------------------------------------------------------------------


@njit(_nrt=False)  # not inlined: one compiled body for the threads and the plain loop
def _free_block(b, contacts, walls, free, dt, shift, partial):
    """Gap shifts g / h [m/s] of the contacts of block b, and their ||U'_free||^2
    [m^2/s^2] into ``partial[b, 0]``."""
    lo = b * _BLOCK
    hi = min(lo + _BLOCK, contacts.body_i.shape[0])
    partial[b, 0] = free_run(lo, hi, contacts, walls, free, dt, shift)


@njit(_nrt=False)  # not inlined: one compiled body for the threads and the plain loop
def _change_block(b, impulses, delta2, running, partial):
    """Sums over the contacts of block b of the sweep's squared impulse changes ``delta2``
    and squared impulses [N^2 s^2] into ``partial[b, :2]``, and of the running-residual
    shares ``running`` (C, 3) into ``partial[b, 2:5]``."""
    lo = b * _BLOCK
    hi = min(lo + _BLOCK, impulses.shape[0])
    change2, p_norm2 = 0.0, 0.0
    res2, wp2, u2 = 0.0, 0.0, 0.0
    for k in range(lo, hi):
        change2 += delta2[k]
        p_norm2 += impulses[k, 0] ** 2 + impulses[k, 1] ** 2 + impulses[k, 2] ** 2
        if running.shape[0] > 0:
            res2 += running[k, 0]
            wp2 += running[k, 1]
            u2 += running[k, 2]
    partial[b, 0] = change2
    partial[b, 1] = p_norm2
    partial[b, 2] = res2
    partial[b, 3] = wp2
    partial[b, 4] = u2


@njit(_nrt=False)  # not inlined: one compiled body for the threads and the plain loop
def _check_block(b, contacts, walls, motion, impulses, delassus, shift, partial):
    """Sums over the contacts of block b of the check pass (as in ``nlgs_kernel``):
    ``partial[b, :3]`` = (||w P||^2, ||U'||^2, ||natural-map residual||^2) [m^2/s^2]."""
    lo = b * _BLOCK
    hi = min(lo + _BLOCK, contacts.body_i.shape[0])
    partial[b, 0], partial[b, 1], partial[b, 2] = check_run(lo, hi, contacts, walls, motion,
                                                            impulses, delassus, shift)


_PIECES = 64
"""The chains of a parallel group are shared out in about this many pieces, each a run of
consecutive chains (consecutive contacts) swept by one compiled call: the law is compiled once
for the threads and the plain loops, and a call costs nothing beside a piece's updates."""


@njit(inline="always")
def _chains_per_piece(lo, hi):
    """Chains per piece of the group of chains lo..hi-1 (:data:`_PIECES`)."""
    return max(1, (hi - lo + _PIECES - 1) // _PIECES)


@njit(_nrt=False)  # a call per piece or plain group: the law compiled once, not per loop
def _apply_run(lo, hi, contacts, bodies, walls, cell, motion, impulses):
    """The warm start of contacts lo..hi-1, one after the other."""
    warm_run(lo, hi, contacts, bodies, walls, cell, motion, impulses)


@njit(_nrt=False)
def _update_run(lo, hi, order, skip, contacts, bodies, walls, cell, motion, impulses, delassus,
                work):
    """One sweep of contacts lo..hi-1 (``order`` empty: in place), one after the other
    (their squared impulse changes into ``work.delta2``)."""
    sweep_run(lo, hi, order, skip, contacts, bodies, walls, cell, motion, impulses, delassus,
              work)


# --------------------------------------------------------------------------------------------
# Array kernels (outputs last)
# --------------------------------------------------------------------------------------------


@njit(cache=True, parallel=True, _nrt=False)
def _coloured_sweeps(contacts, bodies, walls, cell, settings, groups, free, motion, impulses,
                     delassus, residuals, work, partial):
    """Warm start, sweeps and checks of :func:`nlgs_coloured_kernel` on contacts already in
    group order (``groups.order`` empty; group g = chains ``groups.offsets[g] ..
    groups.offsets[g + 1] - 1``, chain c = contacts ``groups.chains[c] .. groups.chains[c +
    1] - 1``; the chains of each of the first ``groups.n_parallel`` groups swept in
    parallel), with their Delassus blocks given; ``free`` the free motion; scratch ``work``
    (:class:`~grainlab.engine.nscd.sweep_arrays.SweepWork`, ``work.delta2`` (C,)),
    ``partial`` (n_blocks, 5). Returns the sweeps done. Compiled without the Numba runtime
    (module docstring, "Layout").
    """
    n_blocks = partial.shape[0]
    offsets, chains, n_parallel = groups.offsets, groups.chains, groups.n_parallel
    n_groups = offsets.shape[0] - 1
    # the reductions in parallel too, when they are worth waking the threads for
    parallel = n_parallel > 0 and n_blocks >= _PARALLEL_BLOCKS
    # gap shifts and ||U'_free||^2 per block
    if parallel:
        for b in prange(n_blocks):  # prange's index is unsigned: cast, one signature
            _free_block(np.int64(b), contacts, walls, free, settings.dt, work.shift, partial)
    else:
        for b in range(n_blocks):
            _free_block(b, contacts, walls, free, settings.dt, work.shift, partial)
    free_norm2 = 0.0
    for b in range(n_blocks):
        free_norm2 += partial[b, 0]
    for g in range(n_groups):  # warm start, group by group
        lo, hi = offsets[g], offsets[g + 1]
        if g < n_parallel and hi - lo > 1:
            per = _chains_per_piece(lo, hi)
            for piece in prange((hi - lo + per - 1) // per):
                c = lo + np.int64(piece) * per
                _apply_run(chains[c], chains[min(c + per, hi)], contacts, bodies, walls, cell,
                           motion, impulses)
        else:
            _apply_run(chains[lo], chains[hi], contacts, bodies, walls, cell, motion, impulses)
    iterations = 0
    last_check = 0
    full = True  # the first sweep, every SKIP_REVISIT-th and the one after a failed check
    while iterations < settings.max_iterations:
        iterations += 1
        skip = SKIP_OPEN if not full else settings.max_iterations + 1
        for g in range(n_groups):
            lo, hi = offsets[g], offsets[g + 1]
            if g < n_parallel and hi - lo > 1:
                per = _chains_per_piece(lo, hi)
                for piece in prange((hi - lo + per - 1) // per):
                    c = lo + np.int64(piece) * per
                    _update_run(chains[c], chains[min(c + per, hi)], groups.order, skip,
                                contacts, bodies, walls, cell, motion, impulses, delassus, work)
            else:
                _update_run(chains[lo], chains[hi], groups.order, skip, contacts, bodies, walls,
                            cell, motion, impulses, delassus, work)
        full = iterations % SKIP_REVISIT == 0
        brake(walls, cell, motion, work)
        # relative change of the sweep: sums per block of _BLOCK contacts, then in block order
        if parallel:
            for b in prange(n_blocks):
                _change_block(np.int64(b), impulses, work.delta2, work.running, partial)
        else:
            for b in range(n_blocks):
                _change_block(b, impulses, work.delta2, work.running, partial)
        change2, p_norm2 = 0.0, 0.0
        run_res2, run_wp2, run_u2 = 0.0, 0.0, 0.0
        for b in range(n_blocks):
            change2 += partial[b, 0]
            p_norm2 += partial[b, 1]
            run_res2 += partial[b, 2]
            run_wp2 += partial[b, 3]
            run_u2 += partial[b, 4]
        change = relative_change(change2, p_norm2)
        residuals[0] = change
        if not math.isfinite(change):  # non-finite impulses: stop, the caller refuses them
            residuals[1] = math.nan
            break
        if not check_wanted(iterations, last_check, change, (run_res2, run_wp2, run_u2),
                            free_norm2, settings):
            continue  # the residual pass only once the change or running residual is small
        # check pass (no update)
        last_check = iterations
        if parallel:
            for b in prange(n_blocks):
                _check_block(np.int64(b), contacts, walls, motion, impulses, delassus,
                             work.shift, partial)
        else:
            for b in range(n_blocks):
                _check_block(b, contacts, walls, motion, impulses, delassus, work.shift,
                             partial)
        wp_norm2, u_norm2, res2 = 0.0, 0.0, 0.0
        for b in range(n_blocks):
            wp_norm2 += partial[b, 0]
            u_norm2 += partial[b, 1]
            res2 += partial[b, 2]
        residual = check_residual(free_norm2, wp_norm2, u_norm2, res2)
        residuals[1] = residual
        if solved(change, residual, settings):
            break
        full = True  # a skipped contact may be the one that fails
    return iterations


@njit(cache=True, parallel=True)
def nlgs_coloured_kernel(contacts, bodies, walls, cell, settings, groups, motion, impulses,
                         delassus, residuals):
    """Frictional unilateral contact problem on impulses by coloured (parallel) nonlinear
    Gauss-Seidel.

    Arguments as :func:`~grainlab.engine.nscd.serial_sweep.nlgs_kernel`, with its visiting
    ``order`` replaced by a colouring or slabs ``groups``
    (:class:`~grainlab.engine.nscd.sweep_arrays.SweepGroups`,
    :mod:`~grainlab.engine.nscd.contact_colouring`): ``groups.order`` (C,) int64, the
    contacts grouped; ``groups.chains`` (K + 1,) int64, chain c at rows ``chains[c] ..
    chains[c + 1] - 1`` of ``groups.order`` (a colouring: one contact per chain);
    ``groups.offsets`` (G + 1,) int64, group g the chains ``offsets[g] .. offsets[g + 1] -
    1``. The groups are visited in order; the chains of each of the first
    ``groups.n_parallel`` groups with ``prange``, each chain's contacts one after the other;
    the other groups in a plain loop (results do not depend on ``n_parallel``; see
    :func:`parallel_colours`). Chains of a parallel group must not share a body >= 0 nor a
    mobile wall, nor (with free cell degrees of freedom) have an image (the kernel does not
    check: a conflict would race). ``groups.body_order`` (N,) int64, a permutation of the
    bodies: the sweeps work on the bodies' arrays gathered in that order (row r holds body
    ``body_order[r]``) and scattered back at the end; the same arithmetic, so the same bits
    whatever the order. Bodies in slab order keep the threads of a slab sweep off each
    other's cache lines (with bodies numbered at random in space, two threads updating
    neighbours in memory shared their lines: the slabs were no faster than one thread).

    Outputs as ``nlgs_kernel``: ``motion``, ``impulses`` (C, 3), ``delassus`` (C, 3, 3),
    ``residuals`` (2,). Returns the number of sweeps done (``max_iterations`` when not
    converged, fewer when a change or residual was not finite: ``residuals`` then holds it).
    """
    n_contacts = contacts.body_i.shape[0]
    motion.velocities[:, :] = bodies.free_velocities
    motion.spins[:, :] = bodies.free_spins
    motion.wall_speeds[:] = walls.free_speeds
    residuals[0] = 0.0
    residuals[1] = 0.0
    work = SweepWork(np.empty(n_contacts), np.zeros(n_contacts, dtype=np.int64),
                     np.zeros((n_contacts if settings.change_tolerance == np.inf else 0, 3)),
                     np.zeros(n_contacts), np.zeros(motion.wall_speeds.shape[0]),
                     np.zeros(motion.cell_dofs.shape[0]))  # running residual rows: inf only
    start_cell(cell.fixed, cell.basis, cell.free, motion.cell_dofs, motion.cell_rate)
    free_rate = motion.cell_rate.copy()
    if n_contacts == 0:
        brake(walls, cell, motion, work)
        return 0
    rank, c_bodies, c_motion = _gathered_bodies(bodies, motion, groups.body_order)
    c_contacts, c_impulses = _gathered_contacts(contacts, impulses, groups.order, rank)
    c_free = Motion(c_bodies.free_velocities, c_bodies.free_spins, walls.free_speeds,
                    motion.cell_dofs, free_rate)
    n_blocks = (n_contacts + _BLOCK - 1) // _BLOCK
    c_delassus = np.empty((n_contacts, 3, 3))
    # (a parallel loop takes named tuples made by a call or passed in: their arrays here)
    body_i, body_j, frame = c_contacts.body_i, c_contacts.body_j, c_contacts.frame
    arm_i, arm_j, images = c_contacts.arm_i, c_contacts.arm_j, c_contacts.images
    inv_mass, inv_inertia = c_bodies.inv_mass, c_bodies.inv_inertia
    for b in prange(n_blocks):  # Delassus blocks (they allocate: outside _coloured_sweeps)
        lo = b * _BLOCK
        hi = min(lo + _BLOCK, n_contacts)
        delassus_kernel(body_i[lo:hi], body_j[lo:hi], frame[lo:hi], arm_i[lo:hi],
                        arm_j[lo:hi], inv_mass, inv_inertia, walls.normals, walls.inv_mass,
                        images[lo:hi], cell.basis, cell.inv_mass, c_delassus[lo:hi])
    in_place = SweepGroups(np.zeros(0, dtype=np.int64), groups.offsets, groups.chains,
                           groups.body_order, groups.n_parallel)
    iterations = _coloured_sweeps(c_contacts, c_bodies, walls, cell, settings, in_place, c_free,
                                  c_motion, c_impulses, c_delassus, residuals, work,
                                  np.zeros((n_blocks, 5)))
    body_order, order = groups.body_order, groups.order
    velocities, spins = motion.velocities, motion.spins
    c_velocities, c_spins = c_motion.velocities, c_motion.spins
    for r in prange(rank.shape[0]):  # scatter the bodies back
        b = body_order[r]
        for a in range(3):
            velocities[b, a] = c_velocities[r, a]
            spins[b, a] = c_spins[r, a]
    for m in prange(n_contacts):  # scatter back (a permutation: each row written once)
        k = order[m]
        for a in range(3):
            impulses[k, a] = c_impulses[m, a]
            for b in range(3):
                delassus[k, a, b] = c_delassus[m, a, b]
    return iterations


@njit(parallel=True)
def _gathered_bodies(bodies, motion, body_order):
    """The bodies' rows gathered into ``body_order`` (row r holds body ``body_order[r]``):
    (rank (N,) int64, its inverse permutation; the gathered
    :class:`~grainlab.engine.nscd.sweep_arrays.BodyRows`; the gathered :class:`Motion`, its
    velocities and spins the free ones, its walls and cell those of ``motion``)."""
    n_bodies = bodies.inv_mass.shape[0]
    rank = np.empty(n_bodies, dtype=np.int64)
    b_inv_mass = np.empty(n_bodies)
    b_inv_inertia = np.empty((n_bodies, 3, 3))
    b_free_v = np.empty((n_bodies, 3))
    b_free_w = np.empty((n_bodies, 3))
    b_velocities = np.empty((n_bodies, 3))
    b_spins = np.empty((n_bodies, 3))
    for r in prange(n_bodies):
        b = body_order[r]
        rank[b] = r
        b_inv_mass[r] = bodies.inv_mass[b]
        for a in range(3):
            b_free_v[r, a] = bodies.free_velocities[b, a]
            b_free_w[r, a] = bodies.free_spins[b, a]
            b_velocities[r, a] = bodies.free_velocities[b, a]
            b_spins[r, a] = bodies.free_spins[b, a]
            for e in range(3):
                b_inv_inertia[r, a, e] = bodies.inv_inertia[b, a, e]
    return (rank, BodyRows(b_inv_mass, b_inv_inertia, b_free_v, b_free_w),
            Motion(b_velocities, b_spins, motion.wall_speeds, motion.cell_dofs,
                   motion.cell_rate))


@njit(parallel=True)
def _gathered_contacts(contacts, impulses, order, rank):
    """The contacts' rows and their impulses gathered into ``order`` (row m holds contact
    ``order[m]``), their bodies renumbered by ``rank``: (the gathered
    :class:`~grainlab.engine.nscd.sweep_arrays.ContactRows`, impulses (C, 3))."""
    n_contacts = order.shape[0]
    c_body_i = np.empty(n_contacts, dtype=np.int64)
    c_body_j = np.empty(n_contacts, dtype=np.int64)
    c_frame = np.empty((n_contacts, 3, 3))
    c_arm_i = np.empty((n_contacts, 3))
    c_arm_j = np.empty((n_contacts, 3))
    c_mu = np.empty(n_contacts)
    c_gap = np.empty(n_contacts)
    c_images = np.empty((n_contacts, 3))
    c_impulses = np.empty((n_contacts, 3))
    for m in prange(n_contacts):
        k = order[m]
        c_body_i[m] = rank[contacts.body_i[k]] if contacts.body_i[k] >= 0 else contacts.body_i[k]
        c_body_j[m] = rank[contacts.body_j[k]]
        c_mu[m] = contacts.mu[k]
        c_gap[m] = contacts.gap[k]
        for a in range(3):
            c_arm_i[m, a] = contacts.arm_i[k, a]
            c_arm_j[m, a] = contacts.arm_j[k, a]
            c_images[m, a] = contacts.images[k, a]
            c_impulses[m, a] = impulses[k, a]
            for b in range(3):
                c_frame[m, a, b] = contacts.frame[k, a, b]
    return (ContactRows(c_body_i, c_body_j, c_frame, c_arm_i, c_arm_j, c_images, c_mu, c_gap),
            c_impulses)


# --------------------------------------------------------------------------------------------
# Python helper
# --------------------------------------------------------------------------------------------


def parallel_colours(colour_offsets, n_colours: int, n_threads: int,
                     min_size: int = MIN_PARALLEL) -> int:
    """How many leading colours of a colouring (``colour_offsets``, ``n_colours``; module
    :mod:`~grainlab.engine.nscd.contact_colouring`) :func:`nlgs_coloured_kernel` should sweep in
    parallel with ``n_threads`` threads: those before the first colour of fewer than
    ``min_size`` contacts (greedy colours shrink), none with one thread."""
    if n_threads <= 1:
        return 0
    sizes = np.diff(np.asarray(colour_offsets)[: n_colours + 1])
    small = np.flatnonzero(sizes < min_size)
    return int(small[0]) if small.size else int(n_colours)
