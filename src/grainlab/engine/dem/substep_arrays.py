"""The arrays of the soft-contact (DEM) sub-steps grouped by what they describe, as NamedTuples
the compiled sub-step loop takes (Numba passes a NamedTuple of arrays as one argument): the
bodies (:class:`BodyArrays`) and the sphere rows of the contact list (:class:`SphereRowArrays`);
the boundary's arrays are its face's (:class:`~grainlab.engine.boundaries.wall_box_face.
WallFace`, :class:`~grainlab.engine.boundaries.periodic_cell_face.CellFace`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class BodyArrays(NamedTuple):
    """The N bodies: constants, state (updated) and the loads of the last evaluation."""

    inv_mass: np.ndarray
    """(N,) [1/kg]."""
    masses: np.ndarray
    """(N,) [kg]."""
    principal: np.ndarray
    """(N, 3) [kg m^2] principal moments of inertia."""
    isotropic: np.ndarray
    """(N,) whether the three principal moments are equal."""
    arm: np.ndarray
    """(N,) [m] rotation arms (the farthest point contacts are computed from)."""
    plain_bodies: np.ndarray
    """Per block of bodies, whether all have isotropic inertia (the vector pass)."""
    positions: np.ndarray
    """(N, 3) [m]."""
    orientations: np.ndarray
    """(N, 4) unit quaternions."""
    velocities: np.ndarray
    """(N, 3) [m/s]."""
    spins: np.ndarray
    """(N, 3) [rad/s] angular velocities."""
    force: np.ndarray
    """(N, 3) [N] net force (contacts and weight)."""
    torque: np.ndarray
    """(N, 3) [N m] net moment."""
    travel: np.ndarray
    """(N,) [m] the largest displacement of a body's contact points since the list was
    built."""


class SphereRowArrays(NamedTuple):
    """The C rows of the sphere contact list (module docstring of
    :mod:`grainlab.engine.dem.soft_contact_kernels`): their description, histories, outputs and
    scratch."""

    body_i: np.ndarray
    body_j: np.ndarray
    off_i: np.ndarray
    off_j: np.ndarray
    rad_i: np.ndarray
    rad_j: np.ndarray
    images: np.ndarray
    mu: np.ndarray
    adj_start: np.ndarray
    adj_entry: np.ndarray
    wall_rows: np.ndarray
    xi: np.ndarray
    roll: np.ndarray
    force: np.ndarray
    torque_i: np.ndarray
    torque_j: np.ndarray
    gap: np.ndarray
    normal: np.ndarray
    point: np.ndarray
    stiffness: np.ndarray
    rel_vel: np.ndarray
    approach: np.ndarray
    partial: np.ndarray
    plain: np.ndarray
    springs: np.ndarray
