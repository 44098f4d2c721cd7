"""The neighbour list of the soft-contact (DEM) step on member spheres (spheres and
aggregates): its rows as the kernels take them (:mod:`grainlab.engine.dem.soft_contact_kernels`,
the module docstring), the histories and outputs of each row, what decides how long the list
lives, and its checkpoint arrays (:class:`~grainlab.engine.dem.soft_contact.SoftContactStep`
builds and keeps it)."""

from __future__ import annotations

import math

import numpy as np

from grainlab.engine.dem.neighbour_rows import member_rows_kernel
from grainlab.engine.dem.soft_contact_kernels import body_rows, plain_blocks
from grainlab.engine.dem.soft_stability import damped_limit, sphere_rows_rates
from grainlab.engine.dem.soft_step_report import SoftStepReport
from grainlab.engine.dem.substep_arrays import ROW_BLOCK, SphereRowArrays
from grainlab.engine.dem.substep_loop import substeps
from grainlab.engine.detect.narrow_phase import Contacts


class SphereRows:
    """A neighbour list as the kernels take it (:mod:`grainlab.engine.dem.soft_contact_kernels`),
    with what decides how long it lives: the bodies' ``travel`` (N,) [m] since it was built,
    the walls (``built_walls`` (W, 3) [m], ``wall_normals``) and the cell matrix
    ``built_cell`` (3, 3) [m] it was built at, and the kernel's bound ``approach`` (1,) [m]."""

    SAVED = ("body_i", "body_j", "member_i", "member_j", "contact_type", "images", "off_i",
             "off_j", "rad_i", "rad_j", "mu", "wall_rows", "adj_start",
             "adj_entry", "xi", "roll", "keys", "travel", "approach", "built_walls",
             "wall_normals", "built_cell")
    """The arrays that restore a list (checkpoints); the rest is recomputed by the kernels."""
    size_words = "member radius"
    """What :attr:`smallest_radius` is, in a diagnosis."""

    def __init__(self, contacts: Contacts | None, images=None, state=None, library=None,
                 bounds=None, friction=0.0):
        if contacts is None:  # filled by from_arrays
            return
        self.images = images
        c = contacts.n_contacts
        self.member_i = np.ascontiguousarray(contacts.member_i, dtype=np.int64)
        self.member_j = np.ascontiguousarray(contacts.member_j, dtype=np.int64)
        self.contact_type = np.ascontiguousarray(contacts.contact_type)
        self.body_i = np.ascontiguousarray(contacts.body_i, dtype=np.int64)
        self.body_j = np.ascontiguousarray(contacts.body_j, dtype=np.int64)
        self.off_i, self.off_j = np.empty((c, 3)), np.empty((c, 3))
        self.rad_i, self.rad_j = np.empty(c), np.empty(c)
        member_rows_kernel(self.body_i, self.body_j, self.member_i, self.member_j,
                           np.ascontiguousarray(library.sphere_start[state.shape_ids]),
                           np.ascontiguousarray(library.sphere_offsets, dtype=np.float64),
                           np.ascontiguousarray(library.sphere_radii, dtype=np.float64),
                           self.off_i, self.off_j, self.rad_i, self.rad_j)
        self.mu = np.zeros(c)
        self.set_friction(bounds, friction)
        self.wall_rows = np.flatnonzero(self.body_i < 0).astype(np.int64)
        n = state.n_bodies
        self.adj_start, self.adj_entry = body_rows(self.body_i, self.body_j, n)
        self.xi = np.zeros((c, 3))
        self.roll = np.zeros((c, 3))
        self.keys = np.zeros(c, dtype=np.int64)
        self.travel = np.zeros(n)
        self.approach = np.zeros(1)
        self.built_walls = np.zeros((0, 3))
        self.wall_normals = np.zeros((0, 3))
        self.built_cell = np.zeros((3, 3))
        self._outputs()

    def _outputs(self) -> None:
        c = self.body_j.shape[0]
        self.renew_report_outputs()
        self.torque_i = np.zeros((c, 3))
        self.torque_j = np.zeros((c, 3))
        self.stiffness = np.zeros(c)
        self.partial = np.zeros((-(-c // ROW_BLOCK), 10))  # the force pass's block sums
        self.springs = np.zeros((c, 6))  # the vector force pass's springs and branches
        self.plain = plain_blocks(self.body_i, self.off_i, self.off_j)

    def renew_report_outputs(self) -> None:
        """New arrays for the outputs a step report reads (gaps, normals, points, forces,
        relative velocities), so that the report of the step before keeps its own
        (:class:`~grainlab.engine.dem.soft_step_report.SoftStepReport`). Every call of the
        sub-steps starts with an evaluation that writes them all."""
        c = self.body_j.shape[0]
        self.gap = np.empty(c)
        self.normal = np.empty((c, 3))
        self.point = np.empty((c, 3))
        self.force = np.empty((c, 3))
        self.rel_vel = np.empty((c, 3))

    def arrays(self) -> SphereRowArrays:
        """The rows' arrays of the sub-steps."""
        return SphereRowArrays(self.body_i, self.body_j, self.off_i, self.off_j, self.rad_i,
                               self.rad_j, self.images, self.mu, self.adj_start,
                               self.adj_entry, self.wall_rows, self.xi, self.roll, self.force,
                               self.torque_i, self.torque_j, self.gap, self.normal,
                               self.point, self.stiffness, self.rel_vel, self.approach,
                               self.partial, self.plain, self.springs)

    @property
    def smallest_radius(self) -> float:
        """The smallest member radius of the rows [m] (inf for no row): an overlap is judged
        against it."""
        return float(np.min(self.rad_j)) if self.rad_j.size else math.inf

    def advance(self, run, solver, n_steps: int, h: float) -> int:
        """Up to ``n_steps`` sub-steps of ``h`` [s] (0: only the loads now) of the solver's
        step ``run`` (:class:`~grainlab.engine.dem.soft_contact.SoftContactStep`'s) on these
        rows (:func:`~grainlab.engine.dem.substep_loop.substeps`); returns those done."""
        law = solver.law
        return substeps(
            n_steps, h, float(solver.skin), (law.code, law.params, law.rolling_friction),
            law.local_damping, solver.gravity, self.arrays(), run.body_arrays(self.travel),
            run.wall_face(self.built_wall_disp(run.bounds)),
            run.cell_face(solver, self.built_cell), run.virial, run.stats, run.parallel)

    def damped_substep(self, run, solver, horizon: float) -> float:
        """The dashpots' bound [s] on the sub-step for these rows' contacts, each at its
        overlap after ``horizon`` [s] of approach (:mod:`grainlab.engine.dem.soft_stability`)."""
        bounds, f64, state = run.bounds, np.float64, run.state
        return damped_limit(*sphere_rows_rates(
            self, horizon, solver.law, run.inv_mass, run.inv_inertia, state.positions,
            state.orientations, state.velocities, state.angular_velocities,
            np.ascontiguousarray(bounds.wall_points, dtype=f64),
            np.ascontiguousarray(bounds.wall_normals, dtype=f64), run.wall_disp,
            run.wall_speed, run.cell_h, solver.carried_gradient @ run.cell_h))

    def closed_points(self) -> tuple:
        """The rows as contacts of :func:`~grainlab.engine.dem.soft_stability.
        zigzag_sums_kernel`: (body_i, body_j, images, closed, points, normals, relative
        velocities) of the last evaluation."""
        return (self.body_i, self.body_j, self.images, self.gap < 0.0, self.point,
                self.normal, self.rel_vel)

    def report(self, run, macro: float) -> tuple[SoftStepReport, SoftStepReport]:
        """The contacts closed at the end of the step, as a step report copied out only when
        read (:class:`~grainlab.engine.dem.soft_step_report.SoftStepReport`; impulses = force
        x ``macro`` [s]), and as the boundary reads them (the same object)."""
        report = SoftStepReport(self, macro, float(run.stats[0]))
        return report, report

    def set_friction(self, bounds, friction: float) -> None:
        """The Coulomb coefficients of the rows: ``friction`` between bodies, each wall's
        own on its rows (they may change from stage to stage)."""
        inner = self.body_i >= 0
        self.mu[inner] = float(friction)
        if not np.all(inner):
            self.mu[~inner] = bounds.wall_friction[-1 - self.body_i[~inner]]

    def built_wall_disp(self, bounds) -> np.ndarray:
        """(W,) [m] where the walls were when the list was built, along their normals, from
        where they are at the start of this step (the kernel's ``wall_disp_built``)."""
        return np.einsum("wi,wi->w", self.built_walls - bounds.wall_points, self.wall_normals)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The arrays of :data:`SAVED` (copies)."""
        return {name: np.array(getattr(self, name)) for name in self.SAVED}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> SphereRows:
        """The list :meth:`to_arrays` saved."""
        rows = cls(None)
        for name in cls.SAVED:
            value = np.ascontiguousarray(arrays[name])
            if value.dtype.kind in "iu" and name != "contact_type":
                value = value.astype(np.int64)
            elif value.dtype.kind == "f":
                value = value.astype(np.float64)
            setattr(rows, name, value)
        rows.images = rows.images.reshape(-1, 3)
        for name in ("off_i", "off_j", "xi", "roll"):
            setattr(rows, name, getattr(rows, name).reshape(-1, 3))
        rows.built_walls = rows.built_walls.reshape(-1, 3)
        rows.wall_normals = rows.wall_normals.reshape(-1, 3)
        rows.approach = rows.approach.reshape(1)
        rows._outputs()
        return rows
