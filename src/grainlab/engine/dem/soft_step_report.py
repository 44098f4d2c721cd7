"""The report of one soft-contact step: the contacts closed at its end, copied out of the
neighbour list when first asked for (:mod:`grainlab.engine.dem.soft_contact`; STYLE.md 2).

A step of the explicit solver is a few tens of sub-steps, and most steps' contacts are read
by no one: the lab reads them only on the steps it records, and the boundaries read the
wall loads and the stress the sub-steps summed. Copying the closed rows out at every step
(their frames, impulses and relative velocities) took ~0.25 ms on 4000 spheres, as long as
the rest of the step's Python. So the report holds the list's outputs of that step and makes
the arrays on first use; the solver gives the list new outputs at the next step
(:meth:`~grainlab.engine.dem.soft_contact.SoftContactStep.step`), so a report stays that of its
own step however long it is kept.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from grainlab.engine.dem.soft_contact_kernels import closed_rows_kernel
from grainlab.engine.detect.narrow_phase import Contacts


class SoftStepReport:
    """Outcome of one soft-contact step, with the attributes of
    :class:`~grainlab.engine.step_report.StepReport`: ``n_contacts`` closed at the end
    of the step (gap < 0), ``convergence`` None (an explicit step has no iterations:
    :mod:`grainlab.engine.solver`), ``max_overlap`` [m] the largest overlap met in
    its sub-steps, and, made on first use, the closed ``contacts``, their ``frames`` (C, 3, 3)
    (rows n, t, s), ``impulses`` (C, 3) local force x dt [N s], ``relative_velocity``
    (C, 3) local [m/s], ``images`` (C, 3); also their world ``forces`` (C, 3) [N] on body j
    (what a boundary reads, :class:`~grainlab.engine.boundaries.boundary.BoundaryMotion`).

    ``rows`` is the neighbour list at the end of the step (:class:`~grainlab.engine.
    sphere_row_list.SphereRows`); the report keeps its arrays, which the list must not write again.
    """

    convergence = None
    problem = None

    def __init__(self, rows, dt: float, max_overlap: float) -> None:
        self._source = (rows.body_i, rows.body_j, rows.member_i, rows.member_j,
                        rows.contact_type, rows.images, rows.gap, rows.normal, rows.point,
                        rows.force, rows.rel_vel)
        self._dt = float(dt)
        self._closed = np.flatnonzero(rows.gap < 0.0)
        self.n_contacts = int(self._closed.shape[0])
        self.max_overlap = float(max_overlap)

    @cached_property
    def _arrays(self) -> dict[str, np.ndarray]:
        kind, images = self._source[4], self._source[5]
        c = self.n_contacts
        out = {"body_i": np.empty(c, dtype=np.int64), "body_j": np.empty(c, dtype=np.int64),
               "member_i": np.empty(c, dtype=np.int64),
               "member_j": np.empty(c, dtype=np.int64),
               "contact_type": np.empty(c, dtype=kind.dtype),
               "images": np.empty((c, 3), dtype=images.dtype), "gap": np.empty(c),
               "normal": np.empty((c, 3)), "point": np.empty((c, 3)),
               "forces": np.empty((c, 3)), "frames": np.empty((c, 3, 3)),
               "impulses": np.empty((c, 3)), "relative_velocity": np.empty((c, 3))}
        closed_rows_kernel(self._closed, *self._source, self._dt, *out.values())
        self._source = None  # the list's arrays are no longer needed
        return out

    @cached_property
    def contacts(self) -> Contacts:
        """The contacts closed at the end of the step."""
        a = self._arrays
        return Contacts(body_i=a["body_i"], body_j=a["body_j"], member_i=a["member_i"],
                        member_j=a["member_j"], point=a["point"], normal=a["normal"],
                        gap=a["gap"], contact_type=a["contact_type"])

    @property
    def frames(self) -> np.ndarray:
        """(C, 3, 3) local frames, rows (n, t, s)."""
        return self._arrays["frames"]

    @property
    def impulses(self) -> np.ndarray:
        """(C, 3) local (P_n, P_t, P_s) = force x dt [N s]."""
        return self._arrays["impulses"]

    @property
    def relative_velocity(self) -> np.ndarray:
        """(C, 3) local relative velocity of body j with respect to body i [m/s]."""
        return self._arrays["relative_velocity"]

    @property
    def images(self) -> np.ndarray:
        """(C, 3) image vectors m_k of body j (zeros outside a periodic cell)."""
        return self._arrays["images"]

    @property
    def image_vectors(self) -> np.ndarray:
        """(C, 3) image vectors m_k (as :attr:`StepReport.image_vectors`)."""
        return self.images

    @property
    def forces(self) -> np.ndarray:
        """(C, 3) world forces on body j [N]."""
        return self._arrays["forces"]
