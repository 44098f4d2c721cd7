"""The serial nonlinear Gauss-Seidel sweeps of one contact-dynamics step: every contact in turn,
in the given order, until the convergence check passes or the sweep cap (Numba; the coloured
and slab sweeps, :mod:`~grainlab.engine.nscd.nlgs_parallel`, visit the same updates in another
order).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainlab.engine.nscd.contact_update import SKIP_OPEN, SKIP_REVISIT
from grainlab.engine.nscd.delassus import delassus_kernel
from grainlab.engine.nscd.speed_limits import start_cell
from grainlab.engine.nscd.sweep_arrays import Motion, SweepWork
from grainlab.engine.nscd.sweep_runs import (
    brake,
    check_residual,
    check_run,
    check_wanted,
    free_run,
    relative_change,
    running_sums,
    solved,
    sweep_run,
    warm_run,
)


@njit(cache=True)
def nlgs_kernel(contacts, bodies, walls, cell, settings, order, motion, impulses, delassus,
                residuals):
    """Frictional unilateral contact problem on impulses by nonlinear Gauss-Seidel.

    Inputs (named tuples of :mod:`~grainlab.engine.nscd.sweep_arrays`): the contacts' rows
    ``contacts`` (:class:`ContactRows`: bodies, frames, arms, images, friction, gap terms at
    the detection configuration), the bodies ``bodies`` (:class:`BodyRows`: inverse masses
    and inertias, free velocities), the walls ``walls`` (:class:`WallRows`), the periodic
    cell ``cell`` (:class:`CellRows`; D = 0 free degrees of freedom and zero images in a
    wall box), ``settings`` (:class:`SolveSettings`: time step, tolerances, sweep cap);
    visiting ``order`` (C,) (a permutation).

    Outputs: ``motion`` (:class:`Motion`): end-of-step body velocities and spins, wall
    speeds, free degrees of freedom of the cell and its rate hdot; ``impulses`` (C, 3) local
    (P_n, P_t, P_s) [N s] (in: warm start; out: solution); ``delassus`` (C, 3, 3) [1/kg];
    ``residuals`` (2,) = (relative change, natural-map residual) of the last sweep.
    Returns the number of sweeps done (``max_iterations`` when not converged, fewer when
    a change or residual was not finite: ``residuals`` then holds it).
    """
    n_contacts = contacts.body_i.shape[0]
    motion.velocities[:, :] = bodies.free_velocities
    motion.spins[:, :] = bodies.free_spins
    motion.wall_speeds[:] = walls.free_speeds
    work = SweepWork(np.empty(n_contacts), np.zeros(n_contacts, dtype=np.int64),
                     np.zeros((n_contacts if settings.change_tolerance == np.inf else 0, 3)),
                     np.zeros(0), np.zeros(motion.wall_speeds.shape[0]),
                     np.zeros(motion.cell_dofs.shape[0]))  # running residual rows: inf only
    start_cell(cell.fixed, cell.basis, cell.free, motion.cell_dofs, motion.cell_rate)
    free = Motion(bodies.free_velocities, bodies.free_spins, walls.free_speeds,
                  motion.cell_dofs, motion.cell_rate.copy())
    residuals[0] = 0.0
    residuals[1] = 0.0
    if n_contacts == 0:
        brake(walls, cell, motion, work)
        return 0
    delassus_kernel(contacts.body_i, contacts.body_j, contacts.frame, contacts.arm_i,
                    contacts.arm_j, bodies.inv_mass, bodies.inv_inertia, walls.normals,
                    walls.inv_mass, contacts.images, cell.basis, cell.inv_mass, delassus)
    return _serial_sweeps(contacts, bodies, walls, cell, settings, order, free, motion,
                          impulses, delassus, residuals, work)


@njit(cache=True, _nrt=False)
def _serial_sweeps(contacts, bodies, walls, cell, settings, order, free, motion, impulses,
                   delassus, residuals, work):
    """Warm start, sweeps and checks of :func:`nlgs_kernel` once the motion, the cell and
    the Delassus blocks are set up (``free``: the free motion, :class:`Motion`; ``work``:
    :class:`SweepWork`, ``work.delta2`` empty). Returns the sweeps done. Compiled without
    the Numba runtime: the inlined scalar laws then take their arrays without atomic
    reference counting."""
    n_contacts = contacts.body_i.shape[0]
    free_norm2 = free_run(0, n_contacts, contacts, walls, free, settings.dt, work.shift)
    warm_run(0, n_contacts, contacts, bodies, walls, cell, motion, impulses)
    iterations = 0
    last_check = 0
    full = True  # visit every contact (SKIP_OPEN, SKIP_REVISIT)
    while iterations < settings.max_iterations:
        iterations += 1
        skip = SKIP_OPEN if not full else settings.max_iterations + 1
        change2, sweep_p2 = sweep_run(0, n_contacts, order, skip, contacts, bodies, walls,
                                      cell, motion, impulses, delassus, work)
        brake(walls, cell, motion, work)
        full = iterations % SKIP_REVISIT == 0
        change = relative_change(change2, sweep_p2)
        residuals[0] = change
        if not math.isfinite(change):  # non-finite impulses: stop, the caller refuses them
            residuals[1] = math.nan
            break
        if not check_wanted(iterations, last_check, change,
                            running_sums(0, n_contacts, work.running), free_norm2, settings):
            continue  # the residual pass only once the change or running residual is small
        # check pass (no update)
        last_check = iterations
        wp_norm2, u_norm2, res2 = check_run(0, n_contacts, contacts, walls, motion, impulses,
                                            delassus, work.shift)
        residual = check_residual(free_norm2, wp_norm2, u_norm2, res2)
        residuals[0] = change
        residuals[1] = residual
        if solved(change, residual, settings):
            break
        full = True
    return iterations
