"""The runs of contacts every nonlinear Gauss-Seidel sweep is made of (Numba, inlined): the
serial, coloured and slab sweeps (:mod:`~grainlab.engine.nscd.serial_sweep`,
:mod:`~grainlab.engine.nscd.nlgs_parallel`) differ only in the order they visit the contacts
in and in how they add up the sums of a sweep, never in what a visit does. A run visits
contacts lo..hi-1 of a visiting order, one after the other, and returns its sums; the
convergence measures of a sweep (relative change, residual of the natural map) are formed
from those sums here too (:mod:`~grainlab.engine.nscd.contact_dynamics`, module docstring,
"Convergence"). Arguments: the named tuples of :mod:`~grainlab.engine.nscd.sweep_arrays`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainlab.contact.coulomb_cone import natural_map
from grainlab.engine.nscd.contact_update import (
    _TINY,
    _apply,
    _relative_velocity,
    check_due,
    check_spaced,
    running_residual,
    skipped_update,
)
from grainlab.engine.nscd.speed_limits import brake_cell, brake_walls


@njit(inline="always")
def _visited(m, order):
    """The contact visited m-th: ``order[m]``, or m itself with an empty ``order`` (0,)
    (contacts already stored in visiting order)."""
    return order[m] if order.shape[0] > 0 else m


@njit(inline="always")
def free_run(lo, hi, contacts, walls, free, dt, shift):
    """Gap shifts g / h [m/s] of contacts lo..hi-1 into ``shift``; returns their
    ||U'_free||^2 [m^2/s^2] in the free motion ``free``, summed in order."""
    free2 = 0.0
    for k in range(lo, hi):
        shift[k] = contacts.gap[k] / dt
        un, ut, us = _relative_velocity(k, contacts, walls.normals, free)
        free2 += (un + shift[k]) ** 2 + ut * ut + us * us
    return free2


@njit(inline="always")
def warm_run(lo, hi, contacts, bodies, walls, cell, motion, impulses):
    """The warm start of contacts lo..hi-1, one after the other: their starting impulses
    applied to ``motion``."""
    for k in range(lo, hi):
        _apply(k, impulses[k, 0], impulses[k, 1], impulses[k, 2], contacts, bodies, walls,
               cell, motion)


@njit(inline="always")
def sweep_run(lo, hi, order, skip, contacts, bodies, walls, cell, motion, impulses, delassus,
              work):
    """One sweep of the contacts ``order[lo..hi-1]`` (:func:`_visited`), one after the
    other (:func:`~grainlab.engine.nscd.contact_update.skipped_update`, ``skip`` its
    open-visit limit); each squared impulse change into ``work.delta2`` unless it is empty.
    Returns (sum of the squared impulse changes, sum of the squared impulses) [N^2 s^2] of
    the run, in visiting order."""
    change2 = 0.0
    p_norm2 = 0.0
    delta2 = work.delta2
    for m in range(lo, hi):
        k = _visited(m, order)
        d2 = skipped_update(k, skip, contacts, bodies, walls, cell, motion, impulses,
                            delassus, work)
        if delta2.shape[0] > 0:
            delta2[k] = d2
        change2 += d2
        p_norm2 += impulses[k, 0] ** 2 + impulses[k, 1] ** 2 + impulses[k, 2] ** 2
    return change2, p_norm2


@njit(inline="always")
def check_run(lo, hi, contacts, walls, motion, impulses, delassus, shift):
    """The check pass (no update) over contacts lo..hi-1: returns (||w P||^2, ||U'||^2,
    ||natural-map residual||^2) [m^2/s^2], summed in order."""
    wp_norm2, u_norm2, res2 = 0.0, 0.0, 0.0
    mu = contacts.mu
    for k in range(lo, hi):
        un, ut, us = _relative_velocity(k, contacts, walls.normals, motion)
        r2, z2, u2 = natural_map(mu[k], delassus[k, 0, 0], impulses[k, 0], impulses[k, 1],
                                 impulses[k, 2], un + shift[k], ut, us)
        wp_norm2 += z2
        u_norm2 += u2
        res2 += r2
    return wp_norm2, u_norm2, res2


@njit(inline="always")
def running_sums(lo, hi, running):
    """Sums over rows lo..hi-1 of the running-residual shares ``running`` (C, 3) (zeros
    when it is empty: not measured)."""
    res2, wp2, u2 = 0.0, 0.0, 0.0
    if running.shape[0] > 0:
        for k in range(lo, hi):
            res2 += running[k, 0]
            wp2 += running[k, 1]
            u2 += running[k, 2]
    return res2, wp2, u2


@njit(inline="always")
def brake(walls, cell, motion, work):
    """The speed limits of the mobile walls and the bounds of the cell's free degrees of
    freedom after a sweep (:mod:`~grainlab.engine.nscd.speed_limits`)."""
    brake_walls(walls.inv_mass, walls.max_speeds, work.wall_brakes, motion.wall_speeds)
    brake_cell(cell.basis, cell.inv_mass, cell.bounds, work.cell_brakes, motion.cell_dofs,
               motion.cell_rate)


@njit(inline="always")
def relative_change(change2, p_norm2):
    """The relative change of a sweep: sqrt(sum |dP|^2 / sum |P|^2) (0 without change)."""
    return 0.0 if change2 == 0.0 else math.sqrt(change2 / max(p_norm2, _TINY))


@njit(inline="always")
def check_wanted(iterations, last_check, change, running_sum, free_norm2, settings):
    """Whether the check pass follows a sweep whose relative change ``change`` is finite: at
    the cap; else, with a change tolerance, once the change is below it (spaced,
    :func:`~grainlab.engine.nscd.contact_update.check_spaced`); without, once the running
    residual (sums ``running_sum`` = (res2, wp2, u2), ``free_norm2``) is small
    (:func:`~grainlab.engine.nscd.contact_update.check_due`)."""
    if iterations >= settings.max_iterations:
        return True
    if settings.change_tolerance < np.inf:
        return change <= settings.change_tolerance and check_spaced(iterations, last_check)
    return check_due(running_residual(running_sum[0], running_sum[1], running_sum[2],
                                      free_norm2),
                     settings.tolerance, iterations, last_check)


@njit(inline="always")
def check_residual(free_norm2, wp_norm2, u_norm2, res2):
    """The residual of the check pass: ||natural map|| over max(||U'_free||, ||w P||,
    ||U'||)."""
    scale = max(math.sqrt(free_norm2), math.sqrt(wp_norm2), math.sqrt(u_norm2), _TINY)
    return math.sqrt(res2) / scale


@njit(inline="always")
def solved(change, residual, settings):
    """Whether the sweeps end after a check pass: both measures within their tolerances, or
    a non-finite residual (the caller refuses the impulses)."""
    return (change <= settings.change_tolerance and residual <= settings.tolerance) \
        or not math.isfinite(residual)
