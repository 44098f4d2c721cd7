"""The periodic cell's compiled face for the explicit soft-contact (DEM) sub-steps (Numba;
STYLE.md 2, 8): what the cell does at every sub-step of
:mod:`grainlab.engine.dem.soft_contact_kernels`, given as :class:`CellFace`, a NamedTuple of the
cell's arrays the sub-step loop passes to the ``cell_*`` functions here, so that the loop holds
no cell code:

* :func:`cell_move`: the cell deforms at its rate, h += dt hdot;
* :func:`cell_settle`: the stress-controlled degrees of freedom set the velocity gradient L from
  the contacts' stress (:func:`cell_servo_kernel`), and that stress is summed over time;
* :func:`cell_start`: the same at the start of a run of sub-steps, with the stiffness the servo
  reads (:func:`cell_stiffness_kernel`), and the bodies take up L at once
  (:func:`carry_gradient_kernel`);
* :func:`cell_shift`: how far the cell's corners may have moved since the list was built;
* :func:`gradient_changed`, :func:`centre_of_mass`, :func:`carry_body`, :func:`take_up`: the
  bodies taking up a change of L in the bodies' pass of a sub-step.

The face of a boundary without a cell (the wall box) is the same NamedTuple, its cell fixed (no
stress-controlled degree of freedom, L = L_0 = 0): the loop is compiled once for every boundary,
and the kernels load from Numba's cache.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit


class CellFace(NamedTuple):
    """The periodic cell's arrays of the sub-steps (D stress-controlled degrees of freedom,
    D = 0 for a cell wholly driven or a boundary without a cell)."""

    h: np.ndarray
    """(3, 3) [m] the cell matrix, its columns the cell's edges (updated)."""
    h_built: np.ndarray
    """(3, 3) [m] the cell matrix when the contact list was built."""
    rate: np.ndarray
    """(3, 3) [m/s] the cell's rate hdot = L h (updated)."""
    gradient_fixed: np.ndarray
    """(3, 3) [1/s] L_0, the prescribed part of the velocity gradient."""
    directions: np.ndarray
    """(D, 3, 3) [-] G_d, the gradient's direction of each stress-controlled degree of
    freedom."""
    scale: np.ndarray
    """(D,) [1/(Pa s)] the servos' gains."""
    free: np.ndarray
    """(D,) [1/s] the servos' free values scale_d (c*_d + J_d)."""
    bounds: np.ndarray
    """(D, 2) [1/s] the bounds of e_d."""
    stiffness: np.ndarray
    """(D,) [Pa] K_d of :func:`cell_stiffness_kernel` (updated)."""
    filtered: np.ndarray
    """(3, 3) [Pa] the springs' stress low-passed over ``filter_time`` (updated)."""
    dofs: np.ndarray
    """(D,) [1/s] e_d (written)."""
    gradient: np.ndarray
    """(3, 3) [1/s] L = L_0 + sum_d e_d G_d (written)."""
    carried: np.ndarray
    """(3, 3) [1/s] the L the bodies' velocities carry (updated)."""
    stress_impulse: np.ndarray
    """(3, 3) [Pa s] the contacts' stress summed over time, in a periodic cell (updated)."""
    filter_time: float
    """[s] tau, the stress filter's time."""
    periodic: bool
    """Whether the boundary is a periodic cell (the bodies then follow L)."""


@njit(inline="always")
def copy33(source, target):
    """target[:, :] = source for (3, 3) arrays, written out (no NRT in the kernels)."""
    for a in range(3):
        for b in range(3):
            target[a, b] = source[a, b]


@njit(inline="always")
def det3(h):
    """det h of a (3, 3) array."""
    return (h[0, 0] * (h[1, 1] * h[2, 2] - h[1, 2] * h[2, 1])
            - h[0, 1] * (h[1, 0] * h[2, 2] - h[1, 2] * h[2, 0])
            + h[0, 2] * (h[1, 0] * h[2, 1] - h[1, 1] * h[2, 0]))


@njit(inline="always")
def branch(k, i, j, images, positions, cell_h):
    """l_k = x_j + h m_k - x_i [m], the branch vector of row k through the cell."""
    mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
    return (positions[j, 0] - positions[i, 0] + cell_h[0, 0] * mx + cell_h[0, 1] * my
            + cell_h[0, 2] * mz,
            positions[j, 1] - positions[i, 1] + cell_h[1, 0] * mx + cell_h[1, 1] * my
            + cell_h[1, 2] * mz,
            positions[j, 2] - positions[i, 2] + cell_h[2, 0] * mx + cell_h[2, 1] * my
            + cell_h[2, 2] * mz)


@njit(cache=True, _nrt=False)
def cell_stiffness_kernel(body_i, body_j, images, stiffness, normal, positions, cell_h,
                          cell_directions, cell_stiffness):
    """K_d = (1/V) sum_k S_k (n_k . G_d l_k)^2 [Pa] (D,): how fast the springs' conjugate
    stress c_d grows per unit strain e_d of the cell when the bodies follow it affinely
    (S_k the rows' normal stiffness [N/m], l_k their branch vectors)."""
    volume = det3(cell_h)
    cell_stiffness[:] = 0.0
    for k in range(body_j.shape[0]):
        i, j = body_i[k], body_j[k]
        if i < 0 or stiffness[k] == 0.0:
            continue
        lx, ly, lz = branch(k, i, j, images, positions, cell_h)
        nx, ny, nz = normal[k, 0], normal[k, 1], normal[k, 2]
        for d in range(cell_directions.shape[0]):
            g = cell_directions[d]
            s = (nx * (g[0, 0] * lx + g[0, 1] * ly + g[0, 2] * lz)
                 + ny * (g[1, 0] * lx + g[1, 1] * ly + g[1, 2] * lz)
                 + nz * (g[2, 0] * lx + g[2, 1] * ly + g[2, 2] * lz))
            cell_stiffness[d] += stiffness[k] * s * s / volume


@njit(cache=True, _nrt=False)
def cell_servo_kernel(dt, virial, cell_h, cell_gradient, cell_directions, cell_scale,
                      cell_free, cell_bounds, cell_stiffness, filter_time, filtered,
                      cell_dofs, gradient):
    """The periodic cell's stress-controlled degrees of freedom, at every sub-step of ``dt``
    [s], from the stress of the contacts' springs (the servo of
    :mod:`grainlab.engine.boundaries.periodic_boundary` made fit for vibrating contacts):

        e_d = clip((free_d - scale_d c_d) / (1 + scale_d K_d 4 tau), bounds_d),

    c_d = -G_d : sym(sigma_f) [Pa], sigma_f the springs' stress ``virial`` / det h
    (compression positive) low-passed over ``filter_time`` tau [s] (``filtered`` (3, 3),
    updated here), free_d = scale_d (c*_d + J_d) (``cell_free`` (D,) [1/s], ``cell_scale``
    (D,) [1/(Pa s)], ``cell_directions`` G_d (D, 3, 3), ``cell_stiffness`` K_d (D,) [Pa] of
    :func:`cell_stiffness_kernel`). On a loose sample (K_d = 0) it is contact dynamics'
    servo; on a dense one the stress closes on its target in 4 tau, the critically damped
    response of a servo that reads through a filter of time tau. Why so: the instantaneous
    stress of a small packing shakes with every collision, and a servo that follows it
    shakes the bodies it carries; and the springs' stress, not the dashpots', because the
    dashpots answer at once to the velocity the servo gives the bodies, a loop that made the
    servo chatter from bound to bound. Writes ``cell_dofs`` (D,) [1/s] and the velocity
    gradient ``gradient`` = L_0 + sum_d e_d G_d (3, 3) [1/s] (``cell_gradient`` L_0 the
    prescribed part)."""
    volume = det3(cell_h)
    blend = min(1.0, dt / filter_time)
    for a in range(3):
        for b in range(3):
            filtered[a, b] += blend * (virial[a, b] / volume - filtered[a, b])
    copy33(cell_gradient, gradient)
    for d in range(cell_dofs.shape[0]):
        conjugate = 0.0
        for a in range(3):
            for b in range(3):
                conjugate -= cell_directions[d, a, b] * 0.5 * (filtered[a, b]
                                                               + filtered[b, a])
        e = (cell_free[d] - cell_scale[d] * conjugate) \
            / (1.0 + 4.0 * cell_scale[d] * cell_stiffness[d] * filter_time)
        e = min(max(e, cell_bounds[d, 0]), cell_bounds[d, 1])
        cell_dofs[d] = e
        for a in range(3):
            for b in range(3):
                gradient[a, b] += e * cell_directions[d, a, b]


@njit(inline="always")
def gradient_changed(gradient, carried):
    """Whether the cell's velocity gradient L differs from the one the bodies carry."""
    change = False
    for a in range(3):
        for b in range(3):
            if gradient[a, b] != carried[a, b]:
                change = True
    return change


@njit(inline="always")
def centre_of_mass(masses, positions):
    """x_c [m] of the bodies, summed in body order."""
    total, cx, cy, cz = 0.0, 0.0, 0.0, 0.0
    for n in range(masses.shape[0]):
        m = masses[n]
        total += m
        cx += m * positions[n, 0]
        cy += m * positions[n, 1]
        cz += m * positions[n, 2]
    return cx / total, cy / total, cz / total


@njit(inline="always")
def carry_body(n, gradient, carried, cx, cy, cz, positions, velocities):
    """v_n += (L - L_carried) (x_n - x_c)."""
    d00, d01, d02 = gradient[0, 0] - carried[0, 0], gradient[0, 1] - carried[0, 1], \
        gradient[0, 2] - carried[0, 2]
    d10, d11, d12 = gradient[1, 0] - carried[1, 0], gradient[1, 1] - carried[1, 1], \
        gradient[1, 2] - carried[1, 2]
    d20, d21, d22 = gradient[2, 0] - carried[2, 0], gradient[2, 1] - carried[2, 1], \
        gradient[2, 2] - carried[2, 2]
    rx, ry, rz = positions[n, 0] - cx, positions[n, 1] - cy, positions[n, 2] - cz
    velocities[n, 0] += d00 * rx + d01 * ry + d02 * rz
    velocities[n, 1] += d10 * rx + d11 * ry + d12 * rz
    velocities[n, 2] += d20 * rx + d21 * ry + d22 * rz


@njit(inline="always")
def take_up(change, gradient, carried, cell_h, cell_rate):
    """L_carried = L (if it changed) and the cell's rate hdot = L h."""
    if change:
        copy33(gradient, carried)
    for a in range(3):
        for b in range(3):
            cell_rate[a, b] = (gradient[a, 0] * cell_h[0, b] + gradient[a, 1] * cell_h[1, b]
                               + gradient[a, 2] * cell_h[2, b])


@njit(cache=True, _nrt=False)
def carry_gradient_kernel(gradient, carried, masses, positions, velocities, cell_h, cell_rate):
    """The bodies take up a change of the cell's velocity gradient at once (YADE's
    homogeneous deformation): v_i += (L - L_carried) (x_i - x_c), x_c the centre of mass
    (momentum kept); then L_carried = L and the cell's rate hdot = L h (``cell_rate``
    (3, 3) [m/s])."""
    change = gradient_changed(gradient, carried)
    if change:
        cx, cy, cz = centre_of_mass(masses, positions)
        for n in range(masses.shape[0]):
            carry_body(n, gradient, carried, cx, cy, cz, positions, velocities)
    take_up(change, gradient, carried, cell_h, cell_rate)


@njit(inline="always")
def cell_servo(cell, dt, virial):
    """:func:`cell_servo_kernel` on the face ``cell`` over ``dt`` [s] (0 at the start of a
    run of sub-steps), the contacts' springs' ``virial`` (3, 3) [N m] read."""
    cell_servo_kernel(dt, virial, cell.h, cell.gradient_fixed, cell.directions, cell.scale,
                      cell.free, cell.bounds, cell.stiffness, cell.filter_time, cell.filtered,
                      cell.dofs, cell.gradient)


@njit(inline="always")
def cell_start(cell, virial, body_i, body_j, images, stiffness, normal, masses, positions,
               velocities):
    """The start of a run of sub-steps, the contacts' loads known: a cell with
    stress-controlled degrees of freedom reads the rows' stiffness
    (:func:`cell_stiffness_kernel`) and sets L (:func:`cell_servo_kernel`), else L = L_0; the
    bodies take up L (:func:`carry_gradient_kernel`)."""
    if cell.dofs.shape[0] > 0:
        cell_stiffness_kernel(body_i, body_j, images, stiffness, normal, positions, cell.h,
                              cell.directions, cell.stiffness)
        cell_servo(cell, 0.0, virial)
    else:
        copy33(cell.gradient_fixed, cell.gradient)
    carry_gradient_kernel(cell.gradient, cell.carried, masses, positions, velocities, cell.h,
                          cell.rate)


@njit(inline="always")
def cell_move(cell, dt):
    """The cell deforms at its rate over ``dt`` [s]: h += dt hdot."""
    for a in range(3):
        for b in range(3):
            cell.h[a, b] += dt * cell.rate[a, b]


@njit(inline="always")
def cell_settle(cell, dt, virial):
    """The end of a sub-step of ``dt`` [s] for the cell, the contacts' ``virial`` (3, 3)
    [N m] known: its stress-controlled degrees of freedom set L (:func:`cell_servo_kernel`),
    and in a periodic cell the contacts' stress virial / det h [Pa] is summed into
    ``cell.stress_impulse`` [Pa s]."""
    if cell.dofs.shape[0] > 0:
        cell_servo(cell, dt, virial)
    if cell.periodic:
        volume = det3(cell.h)
        for a in range(3):
            for b in range(3):
                cell.stress_impulse[a, b] += dt * virial[a, b] / volume


@njit(inline="always")
def cell_shift(cell):
    """[m] sqrt(3 sum_ab (h - h_built)_ab^2): a bound on how far a corner of the cell has moved
    since the contact list was built."""
    shift = 0.0
    for a in range(3):
        for b in range(3):
            shift += (cell.h[a, b] - cell.h_built[a, b]) ** 2
    return math.sqrt(3.0 * shift)
