"""The serial nonlinear Gauss-Seidel sweeps of one contact-dynamics step: every contact in turn,
in the given order, until the convergence check passes or the sweep cap (Numba; the coloured
and slab sweeps, :mod:`~grainlab.engine.nscd.nlgs_parallel`, visit the same updates in another
order).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainlab.contact.coulomb_cone import natural_map
from grainlab.engine.nscd.contact_update import (
    _TINY,
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


@njit(cache=True)
def nlgs_kernel(
    body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, free_velocities, free_spins,
    wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
    mu, gap, dt, images, cell_fixed, cell_basis, cell_inv_mass, cell_free, cell_bounds,
    order, tolerance, change_tolerance, max_iterations,
    impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus, residuals,
):
    """Frictional unilateral contact problem on impulses by nonlinear Gauss-Seidel.

    Inputs: contact bodies ``body_i``, ``body_j`` (C,) (negative: a fixed wall, infinite
    mass); local frames ``frame`` (C, 3, 3), rows n (from i to j), t, s; arms (C, 3) [m] from
    each body's centre to the contact point; ``inv_mass`` (N,) [1/kg]; world inverse inertia
    tensors ``inv_inertia`` (N, 3, 3) [1/(kg m^2)]; free velocities (N, 3) [m/s] and angular
    velocities (N, 3) [rad/s]; walls: unit normals ``wall_normals`` (W, 3), inverse masses
    ``wall_inv_mass`` (W,) [1/kg] (0: driven), free normal speeds ``wall_free_speeds`` (W,)
    [m/s] and speed limits ``wall_max_speeds`` (W,) [m/s] (inf: none; :func:`brake_walls`);
    friction ``mu`` (C,); ``gap`` (C,) [m] at the detection
    configuration; time step ``dt`` [s]; periodic cell (D = 0 free degrees of freedom and
    zero images in a wall box): image vectors ``images`` (C, 3) (float; body j's image is
    translated by h m_k and moves with v_j + hdot m_k), the prescribed part of hdot
    ``cell_fixed`` (3, 3) [m/s], per free degree of freedom d its direction ``cell_basis``
    (D, 3, 3) [m], inverse mass ``cell_inv_mass`` (D,), free value ``cell_free`` (D,) and
    bounds ``cell_bounds`` (D, 2) (:mod:`grainlab.engine.boundaries.periodic_boundary`); visiting
    ``order`` (C,) (a permutation); ``tolerance`` on the natural-map residual and
    ``change_tolerance`` on the relative change (inf: the change is measured, not required;
    module docstring, "Convergence").

    Outputs: ``impulses`` (C, 3) local (P_n, P_t, P_s) [N s] (in: warm start; out: solution);
    ``velocities``, ``spins`` (N, 3) end-of-step velocities; ``wall_speeds`` (W,) end-of-step
    wall normal speeds; ``cell_dofs`` (D,) end-of-step free degrees of freedom and
    ``cell_rate`` (3, 3) the cell's hdot [m/s]; ``delassus`` (C, 3, 3);
    ``residuals`` (2,) = (relative change, natural-map residual) of the last sweep.
    Returns the number of sweeps done (``max_iterations`` when not converged, fewer when
    a change or residual was not finite: ``residuals`` then holds it).
    """
    n_contacts = body_i.shape[0]
    velocities[:, :] = free_velocities
    spins[:, :] = free_spins
    wall_speeds[:] = wall_free_speeds
    brakes = np.zeros(wall_speeds.shape[0])
    cell_brakes = np.zeros(cell_dofs.shape[0])
    start_cell(cell_fixed, cell_basis, cell_free, cell_dofs, cell_rate)
    free_rate = cell_rate.copy()
    residuals[0] = 0.0
    residuals[1] = 0.0
    if n_contacts == 0:
        brake_walls(wall_inv_mass, wall_max_speeds, brakes, wall_speeds)
        brake_cell(cell_basis, cell_inv_mass, cell_bounds, cell_brakes, cell_dofs, cell_rate)
        return 0
    delassus_kernel(body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                    wall_inv_mass, images, cell_basis, cell_inv_mass, delassus)
    measured = n_contacts if change_tolerance == np.inf else 0  # running residual rows
    return _serial_sweeps(
        body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, free_velocities,
        free_spins, wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
        mu, gap, dt, images, cell_basis, cell_inv_mass, cell_bounds, free_rate,
        order, tolerance, change_tolerance, max_iterations,
        impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus, residuals,
        np.empty(n_contacts), brakes, cell_brakes, np.zeros(n_contacts, dtype=np.int64),
        np.zeros((measured, 3)))


@njit(cache=True, _nrt=False)
def _serial_sweeps(
    body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, free_velocities, free_spins,
    wall_normals, wall_inv_mass, wall_free_speeds, wall_max_speeds,
    mu, gap, dt, images, cell_basis, cell_inv_mass, cell_bounds, free_rate,
    order, tolerance, change_tolerance, max_iterations,
    impulses, velocities, spins, wall_speeds, cell_dofs, cell_rate, delassus, residuals,
    shift, brakes, cell_brakes, open_sweeps, running,
):
    """Warm start, sweeps and checks of :func:`nlgs_kernel` once the velocities, the cell
    and the Delassus blocks are set up (``free_rate`` (3, 3) [m/s] the cell's free hdot);
    scratch ``shift`` (C,), wall and cell brakes (W,), (D,), ``open_sweeps`` (C,) int64
    zeros, ``running`` (C, 3) the running-residual shares ((0, 3) with a finite
    ``change_tolerance``: not measured). Returns the sweeps done. Compiled
    without the Numba runtime: the inlined scalar
    laws then take their arrays without atomic reference counting."""
    n_contacts = body_i.shape[0]
    free_norm2 = 0.0
    for k in range(n_contacts):
        shift[k] = gap[k] / dt
        un, ut, us = _relative_velocity(k, body_i, body_j, frame, arm_i, arm_j,
                                        free_velocities, free_spins, wall_normals,
                                        wall_free_speeds, images, free_rate)
        free_norm2 += (un + shift[k]) ** 2 + ut * ut + us * us
    for k in range(n_contacts):  # warm start
        _apply(k, impulses[k, 0], impulses[k, 1], impulses[k, 2], body_i, body_j, frame,
               arm_i, arm_j, inv_mass, inv_inertia, velocities, spins, wall_normals,
               wall_inv_mass, wall_speeds, images, cell_basis, cell_inv_mass, cell_dofs,
               cell_rate)
    iterations = 0
    last_check = 0
    full = True  # visit every contact (SKIP_OPEN, SKIP_REVISIT)
    while iterations < max_iterations:
        iterations += 1
        change2 = 0.0
        sweep_p2 = 0.0
        skip = SKIP_OPEN if not full else max_iterations + 1
        for m in range(n_contacts):
            k = order[m]
            change2 += skipped_update(
                k, skip, body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia,
                wall_normals, wall_inv_mass, mu, shift, impulses, velocities, spins,
                wall_speeds, delassus, open_sweeps, images, cell_basis, cell_inv_mass,
                cell_dofs, cell_rate, running)
            sweep_p2 += impulses[k, 0] ** 2 + impulses[k, 1] ** 2 + impulses[k, 2] ** 2
        brake_walls(wall_inv_mass, wall_max_speeds, brakes, wall_speeds)
        brake_cell(cell_basis, cell_inv_mass, cell_bounds, cell_brakes, cell_dofs, cell_rate)
        full = iterations % SKIP_REVISIT == 0
        change = 0.0 if change2 == 0.0 else math.sqrt(change2 / max(sweep_p2, _TINY))
        residuals[0] = change
        if not math.isfinite(change):  # non-finite impulses: stop, the caller refuses them
            residuals[1] = math.nan
            break
        if iterations < max_iterations:
            if change_tolerance < np.inf:
                if change > change_tolerance or not check_spaced(iterations, last_check):
                    continue  # the residual pass only once the change is small
            else:
                run_res2, run_wp2, run_u2 = 0.0, 0.0, 0.0
                for k in range(n_contacts):
                    run_res2 += running[k, 0]
                    run_wp2 += running[k, 1]
                    run_u2 += running[k, 2]
                if not check_due(running_residual(run_res2, run_wp2, run_u2, free_norm2),
                                 tolerance, iterations, last_check):
                    continue  # the residual pass only once the running residual is small
        # check pass (no update)
        last_check = iterations
        p_norm2, wp_norm2, u_norm2, res2 = 0.0, 0.0, 0.0, 0.0
        for k in range(n_contacts):
            un, ut, us = _relative_velocity(k, body_i, body_j, frame, arm_i, arm_j,
                                            velocities, spins, wall_normals, wall_speeds,
                                            images, cell_rate)
            p_norm2 += impulses[k, 0] ** 2 + impulses[k, 1] ** 2 + impulses[k, 2] ** 2
            r2, z2, u2 = natural_map(mu[k], delassus[k, 0, 0], impulses[k, 0], impulses[k, 1],
                                     impulses[k, 2], un + shift[k], ut, us)
            wp_norm2 += z2
            u_norm2 += u2
            res2 += r2
        scale = max(math.sqrt(free_norm2), math.sqrt(wp_norm2), math.sqrt(u_norm2), _TINY)
        residual = math.sqrt(res2) / scale
        residuals[0] = change
        residuals[1] = residual
        if (change <= change_tolerance and residual <= tolerance) \
                or not math.isfinite(residual):
            break
        full = True
    return iterations




