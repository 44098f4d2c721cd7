"""What any solver's step reports, and the contact vocabulary every solver shares: the local
frames (n, t, s) of the contacts and one key per contact, by which warm starts and tangential
springs follow a contact from step to step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainlab.engine.convergence import Convergence
from grainlab.engine.detect.narrow_phase import Contacts
from grainlab.engine.state import ShapeLibrary


@dataclass(frozen=True, eq=False)
class StepReport:
    """Outcome of one solver step (:meth:`~grainlab.engine.nscd.contact_dynamics.
    ContactDynamicsStep.step`; the soft DEM's adds its own records,
    :class:`~grainlab.engine.dem.soft_step_report.SoftStepReport`).

    ``n_contacts``; NLGS ``iterations`` (sweeps), ``converged``, ``change`` and ``residual``
    (module docstring); ``max_overlap`` [m] = max(0, -min gap) at the detection
    configuration; the ``contacts`` detected, their ``frames`` (C, 3, 3) (rows n, t, s),
    ``impulses`` (C, 3) local (P_n, P_t, P_s) [N s], end-of-step relative velocities
    ``relative_velocity`` (C, 3) local [m/s] (U, without the gap correction) and, in a
    periodic cell, the ``images`` (C, 3) of body j (contact k is with body j translated by
    h m_k); with ``keep_problem`` on the step, the step's plain ``problem``
    (a :class:`~grainlab.engine.nscd.contact_problem.FrictionalContactProblem` of
    :func:`~grainlab.engine.nscd.contact_problem.assemble_problem`; its solution is ``impulses``
    unless a wall or cell speed limit held) and its ``system`` (the
    :class:`~grainlab.engine.nscd.contact_problem.ConstraintSystem` H, M^-1, q and the
    bodies' centres it came from).
    """

    n_contacts: int
    iterations: int
    converged: bool
    change: float
    residual: float
    max_overlap: float
    contacts: Contacts
    frames: np.ndarray
    impulses: np.ndarray
    relative_velocity: np.ndarray
    images: np.ndarray | None = None
    problem: object | None = None
    system: object | None = None
    explicit: bool = False

    @property
    def convergence(self) -> Convergence | None:
        """The solve's :class:`~grainlab.engine.convergence.Convergence` (``iterations``,
        ``converged``, ``change``, ``residual``); None for an ``explicit`` step (the soft
        contacts of polyhedra), which has no iterations."""
        if self.explicit:
            return None
        return Convergence(self.iterations, self.converged, self.change, self.residual)

    @property
    def image_vectors(self) -> np.ndarray:
        """(C, 3) image vectors m_k (zeros outside a periodic cell)."""
        if self.images is None:
            return np.zeros((self.n_contacts, 3))
        return self.images


def contact_frames(normals: np.ndarray) -> np.ndarray:
    """Local frames (C, 3, 3), rows (n, t, s): t is n x e normalised, e the axis least
    aligned with n, and s = n x t."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    axis = np.zeros_like(n)
    axis[np.arange(n.shape[0]), np.argmin(np.abs(n), axis=1)] = 1.0
    t = np.cross(n, axis)
    t /= np.linalg.norm(t, axis=1)[:, None]
    s = np.cross(n, t)
    return np.ascontiguousarray(np.stack([n, t, s], axis=1))




def contact_keys(contacts: Contacts, n_bodies: int, library: ShapeLibrary) -> np.ndarray:
    """One int64 key per contact (body_i, body_j, member_i, member_j): warm starts match the
    same member pair (polyhedra: feature pair) from step to step (walls: body_i = -1 - w,
    member_i = -1)."""
    stride_m = max(int(library.sphere_count.max()), library.max_features) + 1
    stride_b = n_bodies + 64  # room for up to 63 walls below body 0
    bi = contacts.body_i.astype(np.int64) + 64
    bj = contacts.body_j.astype(np.int64)
    mi = contacts.member_i.astype(np.int64) + 1
    mj = contacts.member_j.astype(np.int64)
    return ((bi * stride_b + bj) * stride_m + mi) * stride_m + mj




