"""The arrays of a contact-dynamics solve, grouped by what they describe (named tuples of
arrays, which the Numba kernels take as arguments): the contacts' rows, the bodies, the walls,
the periodic cell, the solve's settings, the motion the sweeps update and their scratch
(:func:`~grainlab.engine.nscd.serial_sweep.nlgs_kernel`,
:func:`~grainlab.engine.nscd.nlgs_parallel.nlgs_coloured_kernel`).

C contacts, N bodies, W walls, D free degrees of freedom of a periodic cell (0 and zero images
in a wall box). A wall is a body index -1 - w.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class ContactRows(NamedTuple):
    """Per contact k: the bodies ``body_i``, ``body_j`` (C,) int64 (body_i < 0: the wall
    -1 - body_i), local ``frame`` (C, 3, 3) (rows n from i to j, t, s), arms ``arm_i``,
    ``arm_j`` (C, 3) [m] from each body's centre to the contact point, ``images`` (C, 3)
    (float: body j's periodic image m_k, translated by h m_k), Coulomb ``mu`` (C,) and the
    gap term ``gap`` (C,) [m] of the law U_n + g / h >= 0."""

    body_i: np.ndarray
    body_j: np.ndarray
    frame: np.ndarray
    arm_i: np.ndarray
    arm_j: np.ndarray
    images: np.ndarray
    mu: np.ndarray
    gap: np.ndarray


class BodyRows(NamedTuple):
    """Per body: ``inv_mass`` (N,) [1/kg], world ``inv_inertia`` (N, 3, 3) [1/(kg m^2)],
    free velocities ``free_velocities`` (N, 3) [m/s] and ``free_spins`` (N, 3) [rad/s]."""

    inv_mass: np.ndarray
    inv_inertia: np.ndarray
    free_velocities: np.ndarray
    free_spins: np.ndarray


class WallRows(NamedTuple):
    """Per wall: unit ``normals`` (W, 3), ``inv_mass`` (W,) [1/kg] (0: driven), free normal
    speeds ``free_speeds`` (W,) [m/s] and speed limits ``max_speeds`` (W,) [m/s] (inf: none;
    :func:`~grainlab.engine.nscd.speed_limits.brake_walls`)."""

    normals: np.ndarray
    inv_mass: np.ndarray
    free_speeds: np.ndarray
    max_speeds: np.ndarray


class CellRows(NamedTuple):
    """The periodic cell: the prescribed part of hdot ``fixed`` (3, 3) [m/s]; per free degree
    of freedom d its direction ``basis`` (D, 3, 3) [m], inverse mass ``inv_mass`` (D,), free
    value ``free`` (D,) and bounds ``bounds`` (D, 2)
    (:mod:`grainlab.engine.boundaries.periodic_boundary`)."""

    fixed: np.ndarray
    basis: np.ndarray
    inv_mass: np.ndarray
    free: np.ndarray
    bounds: np.ndarray


class SolveSettings(NamedTuple):
    """Time step ``dt`` [s], ``tolerance`` on the natural-map residual, ``change_tolerance``
    on the relative change (inf: measured, not required), sweep cap ``max_iterations``
    (:mod:`~grainlab.engine.nscd.contact_dynamics`, module docstring, "Convergence")."""

    dt: float
    tolerance: float
    change_tolerance: float
    max_iterations: int


class Motion(NamedTuple):
    """What the contacts move (outputs of a solve, end of step): body ``velocities`` (N, 3)
    [m/s] and ``spins`` (N, 3) [rad/s], ``wall_speeds`` (W,) [m/s], the cell's free degrees
    of freedom ``cell_dofs`` (D,) and its rate hdot ``cell_rate`` (3, 3) [m/s]. The free
    motion (no contact impulse) has the same form."""

    velocities: np.ndarray
    spins: np.ndarray
    wall_speeds: np.ndarray
    cell_dofs: np.ndarray
    cell_rate: np.ndarray


class SweepGroups(NamedTuple):
    """A colouring or slabs (:mod:`~grainlab.engine.nscd.contact_colouring`) for the coloured
    sweeps: ``order`` (C,) int64 the contacts grouped; ``offsets`` (G + 1,) int64, group g
    the chains ``offsets[g] .. offsets[g + 1] - 1``; ``chains`` (K + 1,) int64, chain c the
    rows ``chains[c] .. chains[c + 1] - 1`` of ``order``; ``body_order`` (N,) int64 the
    bodies' order in memory; ``n_parallel`` the leading groups swept in parallel."""

    order: np.ndarray
    offsets: np.ndarray
    chains: np.ndarray
    body_order: np.ndarray
    n_parallel: int


class SweepWork(NamedTuple):
    """Scratch of the sweeps: gap shifts ``shift`` (C,) [m/s]; ``open_sweeps`` (C,) int64,
    visits in a row a contact was found open; ``running`` (C, 3) the running-residual shares
    ((0, 3): not measured); ``delta2`` (C,) the squared impulse changes of a sweep ((0,): not
    kept); brake impulses of the walls ``wall_brakes`` (W,) and of the cell ``cell_brakes``
    (D,) [N s]."""

    shift: np.ndarray
    open_sweeps: np.ndarray
    running: np.ndarray
    delta2: np.ndarray
    wall_brakes: np.ndarray
    cell_brakes: np.ndarray


__all__ = ["BodyRows", "CellRows", "ContactRows", "Motion", "SolveSettings", "SweepGroups",
           "SweepWork", "WallRows"]
