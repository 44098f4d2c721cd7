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
The sweeps are compiled without the Numba runtime (``_nrt=False``, see
:func:`_coloured_sweeps`).

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
>>> body = np.array([-1, 0]); other = np.array([0, 1])          # floor - sphere 0 - sphere 1
>>> frame = np.tile(np.eye(3)[[2, 0, 1]], (2, 1, 1))                 # rows n = e_z, t, s
>>> arm_i = np.array([[0, 0, 0], [0, 0, 0.5]])
>>> arm_j = np.array([[0, 0, -0.5], [0, 0, -0.5]]); inv_inertia = np.tile(np.eye(3), (2, 1, 1))
>>> v_free = np.array([[0, 0, -0.01], [0, 0, -0.01]])
>>> order, offsets = np.array([0, 1]), np.array([0, 1, 2, 2])  # colours {0}, {1}, no serial
>>> chains = np.array([0, 1, 2])                                # one contact per chain
>>> bodies = np.array([0, 1])                                   # bodies in their own order
>>> out = np.zeros((2, 3)), np.empty((2, 3)), np.empty((2, 3)), np.zeros(1)
>>> delassus, residuals = np.empty((2, 3, 3)), np.zeros(2)
>>> no_cell = (np.zeros((2, 3)), np.zeros((3, 3)), np.zeros((0, 3, 3)), np.zeros(0),
...            np.zeros(0), np.zeros((0, 2)))                       # wall box: no cell
>>> cell_out = np.zeros(0), np.zeros((3, 3))
>>> sweeps = nlgs_coloured_kernel(
...     body, other, frame, arm_i, arm_j, np.ones(2), inv_inertia, v_free, np.zeros((2, 3)),
...     np.array([[0.0, 0, 1]]), np.zeros(1), np.zeros(1), np.full(1, np.inf),
...     np.full(2, 0.4), np.zeros(2), 1e-3, *no_cell,
...     order, offsets, chains, bodies, 2, 1e-10, 1e-10, 100, *out[:3], out[3], *cell_out,
...     delassus, residuals)
>>> bool(np.abs(out[1]).max() < 1e-9), out[0][:, 0].round(6).tolist()   # at rest: P_n = 2mv, mv
(True, [0.02, 0.01])
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainlab.contact.coulomb_cone import natural_map
from grainlab.engine.nscd.contact_colouring import power_of_two_below
from grainlab.engine.nscd.contact_update import (
    SKIP_OPEN,
    SKIP_REVISIT,
    _apply,
    _relative_velocity,
    check_due,
    check_spaced,
    running_residual,
    skipped_update,
)
from grainlab.engine.nscd.delassus import delassus_kernel
from grainlab.engine.nscd.speed_limits import brake_cell, brake_walls, start_cell

_TINY = 1e-300  # as in contact_dynamics
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
# Scalar law: one contact update
# --------------------------------------------------------------------------------------------


@njit(_nrt=False)  # not inlined: one compiled body for the threads and the plain loop
def _free_block(b, body_i, body_j, frame, arm_i, arm_j, free_velocities, free_spins,
                wall_normals, wall_free_speeds, images, free_rate, gap, dt, shift, partial):
    """Gap shifts max(0, g) / h [m/s] of the contacts of block b, and their ||U'_free||^2
    [m^2/s^2] into ``partial[b, 0]``."""
    n_contacts = body_i.shape[0]
    lo = b * _BLOCK
    hi = min(lo + _BLOCK, n_contacts)
    free2 = 0.0
    for k in range(lo, hi):
        shift[k] = gap[k] / dt
        un, ut, us = _relative_velocity(k, body_i, body_j, frame, arm_i, arm_j,
                                        free_velocities, free_spins, wall_normals,
                                        wall_free_speeds, images, free_rate)
        free2 += (un + shift[k]) ** 2 + ut * ut + us * us
    partial[b, 0] = free2


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
def _check_block(b, body_i, body_j, frame, arm_i, arm_j, velocities, spins, wall_normals,
                 wall_speeds, images, cell_rate, mu, shift, impulses, delassus, partial):
    """Sums over the contacts of block b of the check pass (as in ``nlgs_kernel``):
    ``partial[b, :3]`` = (||w P||^2, ||U'||^2, ||natural-map residual||^2) [m^2/s^2]."""
    n_contacts = body_i.shape[0]
    lo = b * _BLOCK
    hi = min(lo + _BLOCK, n_contacts)
    wp_norm2, u_norm2, res2 = 0.0, 0.0, 0.0
    for k in range(lo, hi):
        un, ut, us = _relative_velocity(k, body_i, body_j, frame, arm_i, arm_j,
                                        velocities, spins, wall_normals, wall_speeds, images,
                                        cell_rate)
        r2, z2, u2 = natural_map(mu[k], delassus[k, 0, 0], impulses[k, 0], impulses[k, 1],
                                 impulses[k, 2], un + shift[k], ut, us)
        wp_norm2 += z2
        u_norm2 += u2
        res2 += r2
    partial[b, 0] = wp_norm2
    partial[b, 1] = u_norm2
    partial[b, 2] = res2


_PIECES = 64
"""The chains of a parallel group are shared out in about this many pieces, each a run of
consecutive chains (consecutive contacts) swept by one compiled call: the law is compiled once
for the threads and the plain loops, and a call costs nothing beside a piece's updates."""


@njit(inline="always")
def _chains_per_piece(lo, hi):
    """Chains per piece of the group of chains lo..hi-1 (:data:`_PIECES`)."""
    return max(1, (hi - lo + _PIECES - 1) // _PIECES)


@njit(_nrt=False)  # a call per piece or plain group: the law compiled once, not per loop
def _apply_run(lo, hi, impulses, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
               velocities, spins, wall_normals, wall_inv_mass, wall_speeds, images, cell_basis,
               cell_inv_mass, cell_dofs, cell_rate):
    """The warm start of contacts lo..hi-1, one after the other."""
    for k in range(lo, hi):
        _apply(k, impulses[k, 0], impulses[k, 1], impulses[k, 2], body_i, body_j, frame,
               arm_i, arm_j, inv_mass, inv_inertia, velocities, spins, wall_normals,
               wall_inv_mass, wall_speeds, images, cell_basis, cell_inv_mass, cell_dofs,
               cell_rate)


@njit(_nrt=False)
def _update_run(lo, hi, skip, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
                wall_normals, wall_inv_mass, mu, shift, impulses, velocities, spins,
                wall_speeds, delassus, open_sweeps, images, cell_basis, cell_inv_mass,
                cell_dofs, cell_rate, running, delta2):
    """One sweep of contacts lo..hi-1, one after the other (their squared impulse changes
    into ``delta2``)."""
    for k in range(lo, hi):
        delta2[k] = skipped_update(
            k, skip, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
            wall_inv_mass, mu, shift, impulses, velocities, spins, wall_speeds, delassus,
            open_sweeps, images, cell_basis, cell_inv_mass, cell_dofs, cell_rate, running)


# --------------------------------------------------------------------------------------------
# Array kernels (outputs last)
# --------------------------------------------------------------------------------------------


@njit(cache=True, parallel=True, _nrt=False)
def _coloured_sweeps(
    body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, free_velocities, free_spins,
    wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
    mu, gap, dt, images, cell_basis, cell_inv_mass, cell_bounds, free_rate,
    colour_offsets, chains, n_parallel, tolerance, change_tolerance, max_iterations,
    impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus, residuals, shift,
    delta2, partial, brakes, cell_brakes, open_sweeps, running,
):
    """Warm start, sweeps and checks of :func:`nlgs_coloured_kernel` on contacts already in
    group order (group g = chains ``colour_offsets[g] .. colour_offsets[g + 1] - 1``, chain c
    = contacts ``chains[c] .. chains[c + 1] - 1``; the chains of each of the first
    ``n_parallel`` groups swept in parallel), with their Delassus blocks given; scratch
    ``shift`` (C,), ``delta2`` (C,), ``partial`` (n_blocks, 5), ``running`` (C, 3) ((0, 3)
    with a finite ``change_tolerance``: not measured). Returns the sweeps done.

    Compiled without the Numba runtime (``_nrt=False``): it allocates nothing, and the arrays
    handed to the inlined scalar laws are then not reference-counted. With the runtime, every
    inlined call increments and decrements the shared reference count of each array argument
    atomically (measured: ~35 of the ~42 ns of one ``_relative_velocity`` call), which also
    serialises the threads on those counters.
    """
    n_blocks = partial.shape[0]
    n_groups = colour_offsets.shape[0] - 1
    # the reductions in parallel too, when they are worth waking the threads for
    parallel = n_parallel > 0 and n_blocks >= _PARALLEL_BLOCKS
    # gap shifts and ||U'_free||^2 per block
    if parallel:
        for b in prange(n_blocks):
            _free_block(np.int64(b), body_i, body_j, frame, arm_i, arm_j, free_velocities,
                        free_spins, wall_normals, wall_free_speeds, images, free_rate, gap, dt,
                        shift, partial)  # prange's index is unsigned: cast, one signature
    else:
        for b in range(n_blocks):
            _free_block(b, body_i, body_j, frame, arm_i, arm_j, free_velocities, free_spins,
                        wall_normals, wall_free_speeds, images, free_rate, gap, dt, shift,
                        partial)
    free_norm2 = 0.0
    for b in range(n_blocks):
        free_norm2 += partial[b, 0]
    for g in range(n_groups):  # warm start, group by group
        lo, hi = colour_offsets[g], colour_offsets[g + 1]
        if g < n_parallel and hi - lo > 1:
            per = _chains_per_piece(lo, hi)
            for piece in prange((hi - lo + per - 1) // per):
                c = lo + np.int64(piece) * per
                _apply_run(chains[c], chains[min(c + per, hi)], impulses, body_i, body_j,
                           frame, arm_i, arm_j, inv_mass, inv_inertia, velocities, spins,
                           wall_normals, wall_inv_mass, wall_speeds, images, cell_basis,
                           cell_inv_mass, cell_dofs, cell_rate)
        else:
            _apply_run(chains[lo], chains[hi], impulses, body_i, body_j, frame, arm_i, arm_j,
                       inv_mass, inv_inertia, velocities, spins, wall_normals, wall_inv_mass,
                       wall_speeds, images, cell_basis, cell_inv_mass, cell_dofs, cell_rate)
    iterations = 0
    last_check = 0
    full = True  # the first sweep, every SKIP_REVISIT-th and the one after a failed check
    while iterations < max_iterations:
        iterations += 1
        skip = SKIP_OPEN if not full else max_iterations + 1
        for g in range(n_groups):
            lo, hi = colour_offsets[g], colour_offsets[g + 1]
            if g < n_parallel and hi - lo > 1:
                per = _chains_per_piece(lo, hi)
                for piece in prange((hi - lo + per - 1) // per):
                    c = lo + np.int64(piece) * per
                    _update_run(chains[c], chains[min(c + per, hi)], skip, body_i, body_j,
                                frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                                wall_inv_mass, mu, shift, impulses, velocities, spins,
                                wall_speeds, delassus, open_sweeps, images, cell_basis,
                                cell_inv_mass, cell_dofs, cell_rate, running, delta2)
            else:
                _update_run(chains[lo], chains[hi], skip, body_i, body_j, frame, arm_i, arm_j,
                            inv_mass, inv_inertia, wall_normals, wall_inv_mass, mu, shift,
                            impulses, velocities, spins, wall_speeds, delassus, open_sweeps,
                            images, cell_basis, cell_inv_mass, cell_dofs, cell_rate, running,
                            delta2)
        full = iterations % SKIP_REVISIT == 0
        brake_walls(wall_inv_mass, wall_max_speeds, brakes, wall_speeds)
        brake_cell(cell_basis, cell_inv_mass, cell_bounds, cell_brakes, cell_dofs, cell_rate)
        # relative change of the sweep: sums per block of _BLOCK contacts, then in block order
        if parallel:
            for b in prange(n_blocks):
                _change_block(np.int64(b), impulses, delta2, running, partial)
        else:
            for b in range(n_blocks):
                _change_block(b, impulses, delta2, running, partial)
        change2, p_norm2 = 0.0, 0.0
        run_res2, run_wp2, run_u2 = 0.0, 0.0, 0.0
        for b in range(n_blocks):
            change2 += partial[b, 0]
            p_norm2 += partial[b, 1]
            run_res2 += partial[b, 2]
            run_wp2 += partial[b, 3]
            run_u2 += partial[b, 4]
        change = 0.0 if change2 == 0.0 else math.sqrt(change2 / max(p_norm2, _TINY))
        residuals[0] = change
        if not math.isfinite(change):  # non-finite impulses: stop, the caller refuses them
            residuals[1] = math.nan
            break
        if iterations < max_iterations:
            # the residual pass only once the change (or, without a change tolerance, the
            # running residual) is small, and at the cap
            if change_tolerance < np.inf:
                if change > change_tolerance or not check_spaced(iterations, last_check):
                    continue
            elif not check_due(running_residual(run_res2, run_wp2, run_u2, free_norm2),
                               tolerance, iterations, last_check):
                continue
        # check pass (no update)
        last_check = iterations
        if parallel:
            for b in prange(n_blocks):
                _check_block(np.int64(b), body_i, body_j, frame, arm_i, arm_j, velocities, spins,
                             wall_normals, wall_speeds, images, cell_rate, mu, shift,
                             impulses, delassus, partial)
        else:
            for b in range(n_blocks):
                _check_block(b, body_i, body_j, frame, arm_i, arm_j, velocities, spins,
                             wall_normals, wall_speeds, images, cell_rate, mu, shift,
                             impulses, delassus, partial)
        wp_norm2, u_norm2, res2 = 0.0, 0.0, 0.0
        for b in range(n_blocks):
            wp_norm2 += partial[b, 0]
            u_norm2 += partial[b, 1]
            res2 += partial[b, 2]
        scale = max(math.sqrt(free_norm2), math.sqrt(wp_norm2), math.sqrt(u_norm2), _TINY)
        residual = math.sqrt(res2) / scale
        residuals[1] = residual
        if (change <= change_tolerance and residual <= tolerance) \
                or not math.isfinite(residual):
            break
        full = True  # a skipped contact may be the one that fails
    return iterations


@njit(cache=True, parallel=True)
def nlgs_coloured_kernel(
    body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, free_velocities, free_spins,
    wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
    mu, gap, dt, images, cell_fixed, cell_basis, cell_inv_mass, cell_free, cell_bounds,
    colour_order, colour_offsets, chains, body_order, n_parallel_colours, tolerance,
    change_tolerance, max_iterations, impulses, velocities, spins, wall_speeds, cell_dofs,
    cell_rate, delassus, residuals,
):
    """Frictional unilateral contact problem on impulses by coloured (parallel) nonlinear
    Gauss-Seidel.

    Arguments as :func:`~grainlab.engine.nscd.serial_sweep.nlgs_kernel`, with its visiting
    ``order`` replaced by a colouring or slabs (:mod:`~grainlab.engine.nscd.contact_colouring`):
    ``colour_order`` (C,) int64, the contacts grouped; ``chains`` (K + 1,) int64, chain c at
    rows ``chains[c] .. chains[c + 1] - 1`` of ``colour_order`` (a colouring: one contact
    per chain); ``colour_offsets`` (G + 1,) int64, group g the chains ``colour_offsets[g] ..
    colour_offsets[g + 1] - 1``. The groups are visited in order; the chains of each of the
    first ``n_parallel_colours`` groups with ``prange``, each chain's contacts one after the
    other; the other groups in a plain loop (results do not depend on
    ``n_parallel_colours``; see :func:`parallel_colours`). Chains of a parallel group must
    not share a body >= 0 nor a mobile wall, nor (with free cell degrees of freedom) have an
    image (the kernel does not check: a conflict would race). ``body_order`` (N,) int64, a
    permutation of the bodies: the sweeps work on the bodies' arrays gathered in that order
    (row r holds body ``body_order[r]``) and scattered back at the end; the same arithmetic,
    so the same bits whatever the order. Bodies in slab order keep the threads of a slab sweep
    off each other's cache lines (with bodies numbered at random in space, two threads
    updating neighbours in memory shared their lines: the slabs were no faster than one
    thread).

    Outputs: ``impulses`` (C, 3) local (P_n, P_t, P_s) [N s] (in: warm start; out: solution);
    ``velocities``, ``spins`` (N, 3) end-of-step velocities [m/s], [rad/s]; ``wall_speeds``
    (W,) end-of-step wall normal speeds [m/s]; ``delassus`` (C, 3, 3) [1/kg];
    ``residuals`` (2,) = (relative change, natural-map residual) of the last sweep.
    Returns the number of sweeps done (``max_iterations`` when not converged, fewer when
    a change or residual was not finite: ``residuals`` then holds it).
    """
    n_contacts = body_i.shape[0]
    n_bodies = inv_mass.shape[0]
    velocities[:, :] = free_velocities
    spins[:, :] = free_spins
    wall_speeds[:] = wall_free_speeds
    residuals[0] = 0.0
    residuals[1] = 0.0
    brakes = np.zeros(wall_speeds.shape[0])
    cell_brakes = np.zeros(cell_dofs.shape[0])
    start_cell(cell_fixed, cell_basis, cell_free, cell_dofs, cell_rate)
    free_rate = cell_rate.copy()
    if n_contacts == 0:
        brake_walls(wall_inv_mass, wall_max_speeds, brakes, wall_speeds)
        brake_cell(cell_basis, cell_inv_mass, cell_bounds, cell_brakes, cell_dofs, cell_rate)
        return 0
    # gather the bodies into body_order (row r holds body body_order[r]; rank: its inverse)
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
        b_inv_mass[r] = inv_mass[b]
        for a in range(3):
            b_free_v[r, a] = free_velocities[b, a]
            b_free_w[r, a] = free_spins[b, a]
            b_velocities[r, a] = free_velocities[b, a]
            b_spins[r, a] = free_spins[b, a]
            for e in range(3):
                b_inv_inertia[r, a, e] = inv_inertia[b, a, e]
    # gather the contacts into colour order (row m holds contact colour_order[m])
    c_body_i = np.empty(n_contacts, dtype=np.int64)
    c_body_j = np.empty(n_contacts, dtype=np.int64)
    c_frame = np.empty((n_contacts, 3, 3))
    c_arm_i = np.empty((n_contacts, 3))
    c_arm_j = np.empty((n_contacts, 3))
    c_mu = np.empty(n_contacts)
    c_gap = np.empty(n_contacts)
    c_images = np.empty((n_contacts, 3))
    c_impulses = np.empty((n_contacts, 3))
    c_delassus = np.empty((n_contacts, 3, 3))
    for m in prange(n_contacts):
        k = colour_order[m]
        c_body_i[m] = rank[body_i[k]] if body_i[k] >= 0 else body_i[k]
        c_body_j[m] = rank[body_j[k]]
        c_mu[m] = mu[k]
        c_gap[m] = gap[k]
        for a in range(3):
            c_arm_i[m, a] = arm_i[k, a]
            c_arm_j[m, a] = arm_j[k, a]
            c_images[m, a] = images[k, a]
            c_impulses[m, a] = impulses[k, a]
            for b in range(3):
                c_frame[m, a, b] = frame[k, a, b]
    n_blocks = (n_contacts + _BLOCK - 1) // _BLOCK
    for b in prange(n_blocks):  # Delassus blocks (they allocate: outside _coloured_sweeps)
        lo = b * _BLOCK
        hi = min(lo + _BLOCK, n_contacts)
        delassus_kernel(c_body_i[lo:hi], c_body_j[lo:hi], c_frame[lo:hi], c_arm_i[lo:hi],
                        c_arm_j[lo:hi], b_inv_mass, b_inv_inertia, wall_normals,
                        wall_inv_mass, c_images[lo:hi], cell_basis, cell_inv_mass,
                        c_delassus[lo:hi])
    measured = n_contacts if change_tolerance == np.inf else 0  # running residual rows
    iterations = _coloured_sweeps(
        c_body_i, c_body_j, c_frame, c_arm_i, c_arm_j, b_inv_mass, b_inv_inertia, b_free_v,
        b_free_w, wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
        c_mu, c_gap, dt, c_images, cell_basis, cell_inv_mass, cell_bounds, free_rate,
        colour_offsets, chains, n_parallel_colours, tolerance, change_tolerance,
        max_iterations,
        c_impulses, b_velocities, b_spins, wall_speeds, cell_dofs, cell_rate, c_delassus,
        residuals, np.empty(n_contacts), np.zeros(n_contacts), np.zeros((n_blocks, 5)), brakes,
        cell_brakes, np.zeros(n_contacts, dtype=np.int64),
        np.zeros((measured, 3)))
    for r in prange(n_bodies):  # scatter the bodies back
        b = body_order[r]
        for a in range(3):
            velocities[b, a] = b_velocities[r, a]
            spins[b, a] = b_spins[r, a]
    for m in prange(n_contacts):  # scatter back (a permutation: each row written once)
        k = colour_order[m]
        for a in range(3):
            impulses[k, a] = c_impulses[m, a]
            for b in range(3):
                delassus[k, a, b] = c_delassus[m, a, b]
    return iterations


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
