"""Soft-contact DEM: the explicit solver of grainlab, beside contact dynamics (Cundall & Strack
1979; as YADE, LIGGGHTS, PFC; STYLE.md 2, 4, 10).

The grains overlap a little and push each other apart by a force law
(:mod:`grainlab.contact.soft_contact_law`: linear spring-dashpot or Hertz-Mindlin, Coulomb
friction with a tangential spring, optional rolling resistance and local damping). Newton's
equations are integrated by velocity Verlet,

    v += (h/2) F / m,   omega += (h/2) I_w^-1 T        (half kick)
    x += h v,           q <- exp(h omega / 2) q         (drift; anisotropic bodies keep L)
    F, T at the new configuration                       (forces: springs turned and grown)
    v += (h/2) F / m,   omega += (h/2) I_w^-1 T        (half kick)

with I_w = R diag(I) R^T the world inertia tensor of aggregates (the gyroscopic precession of a
free body follows from keeping L = I_w omega through the turn), explicit and second order.

One step of the solver is one step of the simulation, of length ``dt`` (the lab's step,
chosen from the loading speed as for contact dynamics); it is cut into ``n`` equal sub-steps
h = dt / n no longer than the stable step of the law (:meth:`~grainlab.contact.
soft_contact_law.SoftContactLaw.time_step`: a fraction of the Rayleigh time for Hertz, of the
oscillation period sqrt(m/k) 2 pi for springs; ``substep`` reports it). The sub-steps run in
compiled code (:mod:`grainlab.engine.soft_contact_kernels`) on a neighbour list: the member
pairs within a ``skin`` [m] (default 0.1 x the smallest member diameter) found by the
boundary's own detection (every shape kind's broad and narrow phase, walls, the periodic
cell's images), rebuilt when two points may have closed the skin. Convex polyhedra go through
their own list and sub-steps (:mod:`grainlab.engine.soft_polyhedra`: a soft law on the
penetration at each point of the contact-dynamics manifold, recomputed every sub-step).

The boundary (:mod:`grainlab.engine.boundary`) is asked for its constraints once per step, as
by contact dynamics, and moves at constant speed through the step: a driven wall at its speed,
the cell at its prescribed rate; a servo wall and a stress-controlled component of the cell at
the speed their servo gives from the step before (:func:`~grainlab.engine.
soft_contact_kernels.servo_kernel`). The servo takes the mean load of the last step (a wall's
reaction, the cell's generalised force from its image contacts), so that the collisions of
each sub-step do not shake it. Its proportional part is the overdamped servo of contact
dynamics (same gains, same bounds) taken backward in time with the stiffness of the
boundary's contacts, stable at any contact stiffness; an integral part learns the speed a
boundary must keep while the sample is deformed (only in steps with a driven part), starting
from the speeds that would keep the volume (:func:`isochoric_speeds`). A lateral wall of a
sheared sample then holds its target within some 10-20 % (in CD: 1 %), after an overshoot
where the shear starts; the servo of the periodic cell lags more (see docs). The step's
report holds the contacts closed at its end with their forces (``impulses`` = force x dt,
as a step of contact dynamics reports them); a wall's reaction is its mean over the step.

A simulation that blows up stops with a diagnosis: an overlap beyond :data:`OVERLAP_LIMIT`
of the effective radius, and non-finite values (the simulation's health check).

>>> import numpy as np
>>> from grainlab.contact.soft_contact_law import SoftContactLaw
>>> from grainlab.engine.state import BodyState, ShapeLibrary
>>> library = ShapeLibrary.from_spheres([0.5])
>>> state = BodyState.from_library(library, [0], [[0.0, 0.0, 0.5]], density=1000.0)
>>> law = SoftContactLaw.linear(normal_stiffness=1e6)
>>> solver = SoftContactStep(law, dt=1e-3, gravity=(0.0, 0.0, -9.81))
>>> for _ in range(2000):
...     report = solver.step(state, library, walls=([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]]))
>>> weight = 1000.0 * np.pi / 6.0 * 9.81
>>> round(float(report.impulses[0, 0] / 1e-3 / weight), 6)
1.0
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from grainlab._validate import at_least
from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.boundary import BoundaryMotion, DetectionPhases, as_boundary
from grainlab.engine.contact_dynamics import StepReport, contact_frames, contact_keys
from grainlab.engine.narrow_phase import Contacts
from grainlab.engine.simulation import SimulationBlowUp
from grainlab.engine.soft_contact_kernels import SERVO_INTEGRAL, servo_kernel, substeps_kernel
from grainlab.engine.soft_polyhedra import PolyhedronRows, has_polyhedra, smallest_radius
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError

SKIN_FRACTION = 0.1
"""Default skin of the neighbour list: this fraction of the smallest member diameter."""
OVERLAP_LIMIT = 0.5
"""A sub-step that meets an overlap beyond this fraction of the smallest member radius
stops the run (the contacts are far too soft or the time step too long)."""


class SoftContactStep:
    """The explicit soft-contact DEM solver (module docstring); a
    :class:`~grainlab.engine.solver.Solver`.

    Parameters
    ----------
    law:
        The contact law (:class:`~grainlab.contact.soft_contact_law.SoftContactLaw`).
    dt:
        Step [s] > 0 of the simulation (cut into sub-steps no longer than the stable one).
    gravity:
        Acceleration (3,) [m/s^2].
    friction:
        Coulomb coefficient mu >= 0 of the contacts between bodies (walls: their own).
    skin:
        Skin of the neighbour list [m] > 0; None: :data:`SKIN_FRACTION` x the smallest
        member diameter or polyhedron inscribed diameter.
    substep:
        Sub-step [s] > 0; None: the law's stable step for the bodies of the first step.
    """

    def __init__(self, law: SoftContactLaw, dt: float, gravity=(0.0, 0.0, 0.0),
                 friction: float = 0.4, skin: float | None = None,
                 substep: float | None = None) -> None:
        if not isinstance(law, SoftContactLaw):
            raise InputError("law", law, "a SoftContactLaw")
        self.law = law
        self.dt = at_least("dt", dt)
        g = np.asarray(gravity, dtype=np.float64)
        if g.shape != (3,) or not np.isfinite(g).all():
            raise InputError("gravity", gravity, "a finite (3,) acceleration in m/s^2")
        self.gravity = g
        self.friction = at_least("friction", friction, strict=False)
        self.skin = None if skin is None else at_least("skin", skin)
        self.fixed_substep = None if substep is None else at_least("substep", substep)
        self.substep = self.fixed_substep
        # read and set by the lab as for contact dynamics; an explicit step has no iterations
        self.tolerance = 1.0
        self.max_iterations = 1
        self.overlap_recovery = 0.0
        self.overlap_recovery_speed = math.inf
        self.theta = 1.0
        self.alert_growths = 0
        self.n_substeps = 0
        """Sub-steps done since the solver was made."""
        self.n_detections = 0
        """Neighbour lists built since the solver was made."""
        self.last_substeps = 0
        self._history_keys = np.zeros(0, dtype=np.int64)
        self._history = np.zeros((0, 6))
        self._wall_load = np.zeros((0, 3))
        """Per wall: mean reaction over the last step [N], stiffness [N/m], servo memory
        [m/s]."""
        self._cell_load = np.zeros((0, 3))
        """Per free degree of freedom of the cell: mean generalised force [N m], stiffness
        [N m], servo memory [1/s] of the last step."""
        self._driven = False
        """Whether the last step had a driven (strain-controlled) part of the boundary."""
        self._carried = np.zeros((3, 3))
        """The velocity gradient L [1/s] the particles' velocities carry (periodic cell)."""
        self._phases: DetectionPhases | None = None

    # -- Solver protocol ------------------------------------------------------------------------
    @property
    def alert(self) -> float | None:
        """The skin [m] (the detection's alert distance), None before the first step."""
        return self.skin

    @alert.setter
    def alert(self, value: float | None) -> None:
        self.skin = None if value is None else float(value)
        self._phases = None

    @property
    def rng_state(self) -> dict:
        """Nothing random in an explicit step (checkpoints)."""
        return {}

    @rng_state.setter
    def rng_state(self, value: dict) -> None:
        """Nothing to restore."""

    def warm_start_arrays(self) -> dict[str, np.ndarray]:
        """The contacts' springs (keys, tangential displacement [m], rolling moment [N m])
        and the boundary's loads of the last step (the servos' input)."""
        return {"keys": self._history_keys.copy(), "history": self._history.copy(),
                "wall_load": self._wall_load.copy(), "cell_load": self._cell_load.copy(),
                "driven": np.array(int(self._driven)), "carried": self._carried.copy()}

    def restore_warm_start(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore what :meth:`warm_start_arrays` saved."""
        self._history_keys = np.asarray(arrays["keys"], dtype=np.int64)
        self._history = np.asarray(arrays["history"], dtype=np.float64).reshape(-1, 6)
        self._wall_load = np.asarray(arrays["wall_load"], dtype=np.float64).reshape(-1, 3)
        self._cell_load = np.asarray(arrays["cell_load"], dtype=np.float64).reshape(-1, 3)
        self._driven = bool(int(arrays["driven"]))
        self._carried = np.asarray(arrays["carried"], dtype=np.float64).reshape(3, 3).copy()

    # -- stepping ------------------------------------------------------------------------------
    def stable_substep(self, state: BodyState, library: ShapeLibrary) -> float:
        """The law's stable sub-step [s] for these bodies (the lightest mass, counting the
        rotational inertia about a member's surface, and the smallest member radius or
        polyhedron inradius)."""
        has_polyhedra(library, self.law)
        ids = state.shape_ids
        reach = library.bounding_radius[ids]
        rotational = np.min(state.inertias, axis=1) / np.maximum(reach, 1e-300) ** 2
        lightest = float(np.min(np.minimum(state.masses, rotational)))
        radius = smallest_radius(library)
        return self.law.time_step(lightest, radius, state.density)

    def step(self, state: BodyState, library: ShapeLibrary, walls=None) -> StepReport:
        """Advance ``state`` (and the boundary) by one step of ``dt`` (module docstring)."""
        macro = self.dt
        boundary = as_boundary(walls, self.friction)
        bounds = boundary.constraints(macro, 1.0)
        if not bounds.walls_overdamped and np.any(bounds.wall_inv_mass > 0.0):
            raise InputError("wall_servo", False, "servo walls (true) with the soft-contact "
                             "solver: walls with mass are a contact-dynamics option")
        if self.fixed_substep is None:
            self.substep = self.stable_substep(state, library)
        else:
            has_polyhedra(library, self.law)
        n_sub = max(1, math.ceil(macro / self.substep * (1.0 - 1e-12)))
        h = macro / n_sub
        n_walls, n_dofs = bounds.n_walls, bounds.cell_inv_mass.shape[0]
        run = _Run(state, library, bounds, n_walls, n_dofs)
        rows = self._build_list(state, library, boundary, bounds, run)
        if self._wall_load.shape[0] != n_walls or self._cell_load.shape[0] != n_dofs:
            run.advance(self, rows, 0, h)  # the loads now: the servos' first input
            self._wall_load = np.column_stack([run.wall_force, run.wall_stiffness,
                                               np.zeros(n_walls)])
            self._cell_load = np.column_stack([run.cell_force, run.cell_stiffness,
                                               np.zeros(n_dofs)])
        run.was_driven = self._driven
        memory = run.servo(self._wall_load, self._cell_load, macro)
        self._driven = run.driven
        if n_dofs or np.any(bounds.cell_fixed != 0.0) or np.any(self._carried != 0.0):
            # the particles take up the cell's rate of this step at once (contact dynamics'
            # bounds.affine_change would give it to them one step late, from the last rate)
            gradient = run.cell_rate @ np.linalg.inv(bounds.cell_matrix)
            centre = np.average(state.positions, axis=0, weights=state.masses)
            state.velocities += (state.positions - centre) @ (gradient - self._carried).T
            self._carried = gradient
        done = 0
        while done < n_sub:
            if done:
                rows = self._build_list(state, library, boundary, bounds, run)
            done += run.advance(self, rows, n_sub - done, h)
        self.n_substeps += n_sub
        self.last_substeps = n_sub
        self._wall_load = np.column_stack([run.wall_impulse / macro, run.wall_stiffness,
                                           memory[0]])
        self._cell_load = np.column_stack([run.cell_impulse / macro, run.cell_stiffness,
                                           memory[1]])
        report = run.report(self, rows, macro, library)
        boundary.finish_step(BoundaryMotion(
            dt=macro, theta=1.0, wall_speeds=run.wall_speed.copy(),
            wall_reactions=run.wall_impulse / macro, cell_dofs=run.cell_dofs.copy(),
            cell_rate=run.cell_rate.copy(), contacts=report.contacts,
            images=report.image_vectors, impulses=report.impulses,
            forces=np.einsum("cji,cj->ci", report.frames, report.impulses) / macro))
        return report

    def _detection(self, library: ShapeLibrary) -> DetectionPhases:
        if self._phases is None:
            if self.skin is None:
                self.skin = 2.0 * SKIN_FRACTION * smallest_radius(library)
            self._phases = DetectionPhases.with_alert(self.skin)
        return self._phases

    def _build_list(self, state, library, boundary, bounds, run) -> _Rows:
        """The neighbour list at the current configuration, with the springs it carries."""
        phases = self._detection(library)
        now = replace(bounds, wall_points=bounds.wall_points
                      + run.wall_disp[:, None] * bounds.wall_normals,
                      cell_matrix=run.cell_h.copy())
        contacts, images = boundary.detect(state, library, phases, now)
        self.n_detections += 1
        if run.rows is not None:  # keep the springs of the list being replaced
            self._remember(run.rows, state.n_bodies, library)
        if has_polyhedra(library, self.law):  # one row per body pair (soft_polyhedra)
            rows = PolyhedronRows(contacts, images, state, library, bounds, self.friction)
        else:
            rows = _Rows(contacts, np.ascontiguousarray(images, dtype=np.float64), state,
                         library, bounds, self.friction)
            rows.keys = contact_keys(contacts, state.n_bodies, library)
        keys = rows.keys
        if self._history_keys.size and keys.size:
            where = np.minimum(np.searchsorted(self._history_keys, keys),
                               self._history_keys.size - 1)
            found = self._history_keys[where] == keys
            rows.xi[found] = self._history[where[found], :3]
            rows.roll[found] = self._history[where[found], 3:]
        run.rows = rows
        return rows

    def _remember(self, rows, n_bodies, library) -> None:
        order = np.argsort(rows.keys, kind="stable")
        self._history_keys = rows.keys[order]
        self._history = np.hstack([rows.xi, rows.roll])[order]


def isochoric_speeds(bounds) -> tuple[np.ndarray, np.ndarray]:
    """The servos' speeds that keep the volume while the driven parts of the boundary move
    (the first guess of their integral terms when a deformation starts): servo walls (W,)
    [m/s] sharing the volume the driven walls take (each wall of a pair of planes normal to
    an axis, at distance L_a: a speed s changes the volume at -s / L_a per unit volume), and
    cell degrees of freedom (D,) [1/s] sharing -tr(L_0) (L_0 the driven velocity gradient;
    L = L_0 + sum_d e_d G_d)."""
    walls = np.zeros(bounds.n_walls)
    n, points = bounds.wall_normals, bounds.wall_points
    if bounds.n_walls:
        lengths = np.zeros(bounds.n_walls)
        for w in range(bounds.n_walls):
            facing = np.flatnonzero(np.isclose(n @ n[w], -1.0))
            if facing.size:
                lengths[w] = abs(float((points[facing[0]] - points[w]) @ n[w]))
        driven = (bounds.wall_inv_mass == 0.0) & (lengths > 0.0)
        servo = (bounds.wall_inv_mass > 0.0) & (lengths > 0.0)
        rate = float(np.sum(bounds.wall_free[driven] / lengths[driven]))
        if np.any(servo):
            walls[servo] = -rate * lengths[servo] / np.count_nonzero(servo)
    cells = np.zeros(bounds.cell_basis.shape[0])
    if cells.size:
        inverse = np.linalg.inv(bounds.cell_matrix)
        traces = np.einsum("dab,ba->d", bounds.cell_basis, inverse)
        volumetric = float(np.trace(bounds.cell_fixed @ inverse))
        free = np.abs(traces) > 1e-12 * np.abs(traces).max(initial=1.0)
        if np.any(free):
            cells[free] = -volumetric / (np.count_nonzero(free) * traces[free])
    return walls, cells


class _Rows:
    """A neighbour list as the kernels take it (:mod:`grainlab.engine.soft_contact_kernels`)."""

    def __init__(self, contacts: Contacts, images, state, library, bounds, friction):
        self.contacts = contacts
        self.images = images
        c = contacts.n_contacts
        self.body_i = np.ascontiguousarray(contacts.body_i, dtype=np.int64)
        self.body_j = np.ascontiguousarray(contacts.body_j, dtype=np.int64)
        starts = library.sphere_start[state.shape_ids]
        row_j = starts[self.body_j] + contacts.member_j
        self.off_j = np.ascontiguousarray(library.sphere_offsets[row_j])
        self.rad_j = np.ascontiguousarray(library.sphere_radii[row_j])
        inner = self.body_i >= 0
        self.off_i = np.zeros((c, 3))
        self.rad_i = np.zeros(c)
        row_i = starts[self.body_i[inner]] + contacts.member_i[inner]
        self.off_i[inner] = library.sphere_offsets[row_i]
        self.rad_i[inner] = library.sphere_radii[row_i]
        self.mu = np.full(c, float(friction))
        if np.any(~inner):
            self.mu[~inner] = bounds.wall_friction[-1 - self.body_i[~inner]]
        self.wall_rows = np.flatnonzero(~inner).astype(np.int64)
        self.image_rows = np.flatnonzero(np.any(images != 0.0, axis=1)).astype(np.int64)
        # CSR of the rows of each body: 2 k for its j side, 2 k + 1 for its i side
        n = state.n_bodies
        bodies = np.concatenate([self.body_j, self.body_i[inner]])
        entries = np.concatenate([2 * np.arange(c, dtype=np.int64),
                                  2 * np.flatnonzero(inner).astype(np.int64) + 1])
        order = np.lexsort((entries, bodies))
        self.adj_entry = np.ascontiguousarray(entries[order])
        self.adj_start = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(bodies, minlength=n), out=self.adj_start[1:])
        self.xi = np.zeros((c, 3))
        self.roll = np.zeros((c, 3))
        self.keys = np.zeros(c, dtype=np.int64)
        self.force = np.zeros((c, 3))
        self.torque_i = np.zeros((c, 3))
        self.torque_j = np.zeros((c, 3))
        self.gap = np.zeros(c)
        self.normal = np.zeros((c, 3))
        self.point = np.zeros((c, 3))
        self.stiffness = np.zeros(c)
        self.rel_vel = np.zeros((c, 3))


class _Run:
    """What one step carries from sub-step to sub-step and list to list."""

    def __init__(self, state, library, bounds, n_walls, n_dofs):
        self.state = state
        self.bounds = bounds
        self.rows: _Rows | None = None
        ids = state.shape_ids
        self.inv_mass = 1.0 / state.masses
        self.principal = np.ascontiguousarray(state.inertias, dtype=np.float64)
        self.isotropic = np.all(np.isclose(state.inertias, state.inertias[:, :1], rtol=1e-12,
                                           atol=0.0), axis=1)
        self.bounding = np.ascontiguousarray(library.bounding_radius[ids])
        self.wall_disp = np.zeros(n_walls)
        self.wall_speed = np.array(bounds.wall_free, dtype=np.float64)
        self.cell_h = np.array(bounds.cell_matrix, dtype=np.float64)
        self.cell_dofs = np.array(bounds.cell_free, dtype=np.float64)
        self.cell_rate = np.array(bounds.cell_fixed, dtype=np.float64)
        self.wall_impulse = np.zeros(n_walls)
        self.cell_impulse = np.zeros(n_dofs)
        self.was_driven = False
        self.driven = False
        self.body_force = np.zeros((state.n_bodies, 3))
        self.body_torque = np.zeros((state.n_bodies, 3))
        self.wall_force = np.zeros(n_walls)
        self.wall_stiffness = np.zeros(n_walls)
        self.cell_force = np.zeros(n_dofs)
        self.cell_stiffness = np.zeros(n_dofs)
        self.stats = np.zeros(1)

    def servo(self, wall_load: np.ndarray, cell_load: np.ndarray, macro: float
              ) -> tuple[np.ndarray, np.ndarray]:
        """The walls' speeds and the cell's rate over the step (:func:`~grainlab.engine.
        soft_contact_kernels.servo_kernel`) from the last step's mean loads and the servos'
        memories; returns the updated memories (walls, cell). When a driven deformation
        starts, the memories start from :func:`isochoric_speeds`."""
        b, f64 = self.bounds, np.float64
        wall_memory = np.ascontiguousarray(wall_load[:, 2], dtype=f64)
        cell_memory = np.ascontiguousarray(cell_load[:, 2], dtype=f64)
        driven = bool(np.any((b.wall_inv_mass == 0.0) & (b.wall_free != 0.0))
                      or np.any(b.cell_fixed != 0.0))
        if driven and not self.was_driven:  # a deformation starts: guess the servos' speeds
            wall_memory[:], cell_memory[:] = isochoric_speeds(b)
        servo_kernel(
            macro, SERVO_INTEGRAL if driven else 0.0,
            np.ascontiguousarray(b.wall_inv_mass, dtype=f64),
            np.ascontiguousarray(b.wall_free, dtype=f64),
            np.ascontiguousarray(b.wall_max, dtype=f64),
            np.ascontiguousarray(wall_load[:, 0]), np.ascontiguousarray(wall_load[:, 1]),
            np.ascontiguousarray(b.cell_fixed, dtype=f64),
            np.ascontiguousarray(b.cell_basis, dtype=f64),
            np.ascontiguousarray(b.cell_inv_mass, dtype=f64),
            np.ascontiguousarray(b.cell_free, dtype=f64),
            np.ascontiguousarray(b.cell_bounds, dtype=f64),
            np.ascontiguousarray(cell_load[:, 0]), np.ascontiguousarray(cell_load[:, 1]),
            wall_memory, cell_memory, self.wall_speed, self.cell_dofs, self.cell_rate)
        self.driven = driven
        return wall_memory, cell_memory

    def advance(self, solver: SoftContactStep, rows: _Rows, n_steps: int, h: float) -> int:
        """Up to ``n_steps`` sub-steps of ``h`` [s] on ``rows`` (0: only the loads now);
        returns those done."""
        if isinstance(rows, PolyhedronRows):
            return rows.advance(self, solver, n_steps, h, OVERLAP_LIMIT)
        state, bounds, law = self.state, self.bounds, solver.law
        f64 = np.float64
        done = substeps_kernel(
            n_steps, h, float(solver.skin), law.code, law.params,
            law.rolling_friction, law.local_damping, solver.gravity,
            rows.body_i, rows.body_j, rows.off_i, rows.off_j, rows.rad_i, rows.rad_j,
            rows.images, rows.mu, rows.adj_start, rows.adj_entry, rows.wall_rows,
            rows.image_rows, self.inv_mass, np.ascontiguousarray(state.masses, dtype=f64),
            self.principal, self.isotropic, self.bounding,
            np.ascontiguousarray(bounds.wall_points, dtype=f64),
            np.ascontiguousarray(bounds.wall_normals, dtype=f64),
            np.ascontiguousarray(bounds.cell_basis, dtype=f64), self.wall_speed,
            self.cell_rate, self.wall_disp.copy(), self.cell_h.copy(),
            state.positions, state.orientations, state.velocities, state.angular_velocities,
            rows.xi, rows.roll, self.wall_disp, self.cell_h, np.zeros(state.n_bodies),
            rows.force, rows.torque_i, rows.torque_j, rows.gap, rows.normal, rows.point,
            rows.stiffness, rows.rel_vel, self.body_force, self.body_torque, self.wall_force,
            self.wall_stiffness, self.cell_force, self.cell_stiffness, self.wall_impulse,
            self.cell_impulse, self.stats)
        smallest = float(np.min(rows.rad_j)) if rows.rad_j.size else math.inf
        if self.stats[0] > OVERLAP_LIMIT * smallest:
            raise SimulationBlowUp(
                f"runaway overlap in the soft-contact step: {self.stats[0]:.3g} m, more than "
                f"{OVERLAP_LIMIT} x the smallest member radius {smallest:.3g} m; the contacts "
                f"are too soft for the load ({law.model}) or the sub-step "
                f"{h:.3g} s too long for their stiffness.")
        return int(done)

    def report(self, solver: SoftContactStep, rows: _Rows, macro: float,
               library: ShapeLibrary) -> StepReport:
        """The contacts closed at the end of the step, as a step report."""
        solver._remember(rows, self.state.n_bodies, library)
        if isinstance(rows, PolyhedronRows):
            return rows.report(self, macro)
        closed = rows.gap < 0.0
        c = rows.contacts
        contacts = Contacts(
            body_i=c.body_i[closed], body_j=c.body_j[closed], member_i=c.member_i[closed],
            member_j=c.member_j[closed], point=rows.point[closed], normal=rows.normal[closed],
            gap=rows.gap[closed], contact_type=c.contact_type[closed])
        frames = contact_frames(contacts.normal)
        impulses = np.einsum("cij,cj->ci", frames, rows.force[closed]) * macro
        relative = np.einsum("cij,cj->ci", frames, rows.rel_vel[closed])
        return StepReport(
            n_contacts=contacts.n_contacts, iterations=1, converged=True, change=0.0,
            residual=0.0, max_overlap=float(self.stats[0]), contacts=contacts, frames=frames,
            impulses=impulses, relative_velocity=relative, images=rows.images[closed])
