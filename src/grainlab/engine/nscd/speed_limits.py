"""Speed limits of the mobile walls and of the periodic cell inside the contact sweep (Numba,
inlined): a wall or a cell degree of freedom that would move faster than its limit is held at it
(:mod:`~grainlab.engine.nscd.contact_dynamics`, module docstring).
"""

from __future__ import annotations

import numpy as np
from numba import njit

OUTWARD_SPEED_FACTOR = 4.0
"""A speed-limited wall moves out at most this many times its inward limit."""


@njit(inline="always")
def brake_cell(cell_basis, cell_inv_mass, cell_bounds, brakes, cell_dofs, cell_rate):
    """Bounds lo_d <= e_d <= hi_d (``cell_bounds`` (D, 2)) on the cell's free degrees of
    freedom, solved in the sweep like :func:`brake_walls`: a brake impulse with the exact local
    solution, kept from sweep to sweep so that it lets go when the contacts hold the cell."""
    for d in range(cell_dofs.shape[0]):
        inv = cell_inv_mass[d]
        if inv > 0.0:
            free = cell_dofs[d] + brakes[d] * inv
            held = min(max(free, cell_bounds[d, 0]), cell_bounds[d, 1])
            brakes[d] = (free - held) / inv
            delta = held - cell_dofs[d]
            cell_dofs[d] = held
            if delta != 0.0:
                for a in range(3):
                    for b in range(3):
                        cell_rate[a, b] += delta * cell_basis[d, a, b]


@njit(inline="always")
def start_cell(cell_fixed, cell_basis, cell_free, cell_dofs, cell_rate):
    """hdot = hdot_fixed + sum_d e_d H_d with the free values e_d = ``cell_free[d]``."""
    cell_rate[:, :] = cell_fixed
    for d in range(cell_free.shape[0]):
        cell_dofs[d] = cell_free[d]
        for a in range(3):
            for b in range(3):
                cell_rate[a, b] += cell_free[d] * cell_basis[d, a, b]


@njit(inline="always")
def brake_walls(wall_inv_mass, wall_max_speeds, brakes, wall_speeds):
    """Speed limits of the mobile walls, -OUTWARD_SPEED_FACTOR s_max <= s_w <= s_max, solved
    in the Gauss-Seidel sweep: a brake impulse B_w [N s] (positive outward), the exact local
    solution B_w = m_w (s_free - clamp(s_free)) with s_free = s_w + B_w / m_w the speed
    without it. Inwards the limit bounds the inertia number; outwards (a looser bound) it
    keeps a wall shoved by a stress spike from jumping away from a rigid sample."""
    for w in range(wall_speeds.shape[0]):
        if wall_inv_mass[w] > 0.0 and wall_max_speeds[w] < np.inf:
            free = wall_speeds[w] + brakes[w] * wall_inv_mass[w]
            held = min(max(free, -OUTWARD_SPEED_FACTOR * wall_max_speeds[w]),
                       wall_max_speeds[w])
            brakes[w] = (free - held) / wall_inv_mass[w]
            wall_speeds[w] = held




