"""Contact dynamics (Moreau-Jean / NSCD) time step for rigid sphere-based bodies
(Numba; research/cd_engines.md 6.1-6.3, 6.6; STYLE.md 2, 8, 10, 12).

Time step (theta-scheme, per body; translation and angular velocity in the world frame)::

    v_free = v_i + h M^-1 F_ext              F_ext = m g (constant over the step)
    w_free = w_i                             (gyroscopic term: see below)
    q_m    = q_i (+) (1 - theta) h (v_i, w_i) detection configuration
    detect contacts at q_m: point x_a, frame (n, t, s), gap g_a, arms r_ia, r_ja
    solve  U = U_free + W P,  law(U, P, g)   NLGS on the impulses P [N s]
    v_{i+1} = v_free + M^-1 H P
    q_{i+1} = q_m (+) theta h (v_{i+1}, w_{i+1})

h [s] is the time step, theta in [0.5, 1]. Rotations use the exponential map of the rotation
vector h w on the unit quaternion (world frame: q <- exp(h w / 2) q).

Gyroscopic term. Spheres have isotropic inertia, so w x I w = 0 and nothing is neglected.
For aggregates it is neglected by default, as LMGC90 does (6.1, pitfall 7). With
``gyroscopic=True`` it is added to w_free semi-implicitly (one linearised backward-Euler step
in the body frame, w_b' = w_b - h J^-1 (w_b x I w_b) with J = I + h ([w_b] I - [I w_b]), which
is stable where the explicit term is not; compiled in :mod:`~grainlab.engine.gyroscopic`).

Contact law (IQS_CLB, 6.2). The impulse P = P_n n + P_t t + P_s s acts on body j (and -P on
body i); U is the relative velocity of j with respect to i at the contact point at the END of
the step, in the local frame (U_n > 0: separating). With the gap g at q_m::

    U_n' = U_n + max(0, g) / h,   U_n' >= 0,  P_n >= 0,  U_n' P_n = 0
    |P_T| <= mu P_n;  |P_T| < mu P_n => U_T = 0;  else U_T = -lambda P_T, lambda >= 0

An open gap lets the bodies approach by at most g within the step; an existing overlap
(g < 0) is NOT pushed apart (no max(0, g) < 0 term): overlaps are never corrected violently,
and are reported as ``max_overlap`` (pitfall 4). Optionally (``overlap_recovery`` = beta in
(0, 1], default 0) the gap term is g* = max(0, g) + max(beta min(0, g), -v_r h): an overlap
must open by beta |g| within the step (U_n >= beta |g| / h, at most the cap
``overlap_recovery_speed`` v_r), so overlaps left by unconverged steps decay
geometrically instead of accumulating (a Baumgarte-type stabilisation; the separation speed
is energy put in, beta |g| / h per contact).

NLGS (6.3). Body accumulators: body velocities are kept up to date with every impulse
update, so the local right-hand side of contact a is its current relative velocity minus
W_aa P_a (O(1) per update, no W_ab stored). The exact 3 x 3 Delassus block
W_aa = F (K_i + K_j) F^T, K_b = m_b^-1 1 + [r_b]^T I_b^-1 [r_b] (world inverse inertia, walls:
K = 0) is built from the arms; W_tt is clamped to >= 1e-6 W_nn (pitfall 5). Local solution:
open (P = 0) if U'_free,n >= 0; else the sticking solution P = -W^-1 U'_free if det W is not
tiny and P lies in the cone; else (sliding, or a singular block) projections from the previous
P, normal first P_n = max(0, P_n - U'_n / W_nn), then tangential on the disc,
P_T = proj_{|P_T| <= mu P_n}(P_T - U_T / lambda_max(W_TT)), repeated (at most 100 times) until
the change is below 1e-12 relative. Contacts are visited in one seeded random permutation per
step.

Warm start. A contact starts from the force (impulse / h, world frame) of the same (body_i,
body_j, member_i, member_j) at the previous step, f_n, extrapolated when the contact was there
the step before too: f_n + lambda (f_n - f_(n-1)), projected on its Coulomb cone
(``warm_start_extrapolation`` = lambda; 0 by default: f_n, not projected; the lab tests use
:data:`WARM_START_EXTRAPOLATION` = 0.5); a new contact starts from zero. In quasi-static
shear the forces of the sticking network drift steadily from step to step
(docs/explanations/contact-problem.md, "The contact problem on its own"), and the
extrapolation starts each step further along that drift.
Measured on 1000 spheres sheared from eps_q = 0.06 to 0.08 (tolerance 1.666e-4, every step
converged): 540 / 498 / 465 / 509 / 656 sweeps a step on average with lambda = 0 / 0.25 /
0.5 / 0.75 / 1.
Where the forces are indeterminate and at rest, it feeds their drift: a cube resting on a
cube (four coplanar points, tolerance 1e-5) no longer converged with lambda = 0.5.

Sweeps. ``sweep="serial"`` runs :func:`nlgs_kernel` in the seeded random order above.
``sweep="coloured"`` (the default) greedily colours the contacts so that no two of one colour
share a body (:mod:`~grainlab.engine.nscd.contact_colouring`, linear in C) and runs
:func:`~grainlab.engine.nscd.nlgs_parallel.nlgs_coloured_kernel`: the colours one after the other,
the contacts of a colour in parallel (``numba.prange``), the contacts of mobile
(stress-controlled) walls last in a serial loop, as they all share their wall. When every
colour is below :data:`~grainlab.engine.nscd.nlgs_parallel.MIN_COLOURS` contacts (too little work
per colour to wake the threads for: up to ~10^4 spheres) and there are at least
:data:`~grainlab.engine.nscd.nlgs_parallel.MIN_SLABS` contacts, the contacts are swept in slabs of
the packing instead (:func:`~grainlab.engine.nscd.contact_colouring.slab_contacts`, 2 to 16 of
them: :func:`~grainlab.engine.nscd.nlgs_parallel.slab_count`): each slab's inside by one thread,
then the contacts between neighbouring slabs, then the mobile walls' and those that span
more than one slab. The same
local solver and convergence measures, in a fixed order: the solution agrees with the serial
sweep within the tolerance and does not depend on the number of threads.

Skipping open contacts (LMGC90's iskip idea): a contact found open (P = 0) at
:data:`SKIP_OPEN` visits in a row is left out of the sweeps, except the first sweep, every
:data:`SKIP_REVISIT`-th and the one after a failed check, which visit every contact; the
check pass always covers every contact, so a skipped contact that closes fails the residual.

Subspace minimisation (``correction="subspace"``): in a step where every contact is
frictionless, the sweeps run :data:`~grainlab.engine.nscd.subspace_minimisation.SWEEPS_BETWEEN`
at a time, and after each run that has not converged the normal impulses take one subspace
minimisation (:mod:`~grainlab.engine.nscd.subspace_minimisation`: the loaded contacts' linear
system by conjugate gradients, a projected line search that lowers the step's energy). The
stop test is the kernel's, after the sweeps; ``correction_products`` counts the corrections'
products (each about a third of a sweep's work). Frictional steps are swept alone.

Convergence (both must be <= ``tolerance`` after a sweep; the change is measured in every
sweep, the residual, which costs a pass over the contacts, only after sweeps whose change is
below the tolerance and at the cap):

- change   = ||P^k - P^(k-1)|| / ||P^k||                          (0 when both vanish)
- residual = ||w P - proj_K(w P - (U' + mu |U_T| e_n))|| / max(||U_free||, ||w P||, ||U'||)

with w = W_nn per contact (so w P is a velocity [m/s] and the residual has no units; the
natural-map residual of Siconos, K the Coulomb cone). A step that hits ``max_iterations`` is
flagged (``converged=False``) with its residual in the :class:`StepReport`, never silently;
``strict=True`` raises :class:`~grainlab.errors.ConvergenceError` instead. The flag is the
kernel's own stop test on the change and residual it reports (one evaluation). A sweep whose
impulses, or whose measures, are not finite ends the sweeps at once, and the step raises
:class:`~grainlab.errors.SolverDivergence` before anything of it reaches the state: non-finite
impulses are never an answer. A state that is not finite at the start of a step is refused
(:class:`~grainlab.errors.InputError`).

>>> import numpy as np
>>> from grainlab.engine.state import BodyState, ShapeLibrary
>>> library = ShapeLibrary.from_spheres([0.5])
>>> state = BodyState.from_library(library, [0], [[0.0, 0.0, 0.5]], density=1000.0)
>>> step = ContactDynamicsStep(dt=1e-3, gravity=(0.0, 0.0, -9.81))
>>> report = step.step(state, library, walls=([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]]))
>>> report.n_contacts, report.converged, abs(float(state.velocities[0, 2])) < 1e-12
(1, True, True)
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from numba import get_num_threads

from grainlab._validate import at_least, in_range
from grainlab.engine.body_order import spatial_order
from grainlab.engine.boundaries.boundary import (
    BoundaryMotion,
    ClosedContacts,
    DetectionPhases,
    as_boundary,
)
from grainlab.engine.gyroscopic import gyroscopic_spins
from grainlab.engine.nscd.contact_colouring import colour_contacts, slab_contacts
from grainlab.engine.nscd.contact_problem import (
    constraint_system,
    project_on_cones,
)
from grainlab.engine.nscd.contact_update import closing_velocities_kernel
from grainlab.engine.nscd.nlgs_parallel import (
    MIN_COLOURS,
    MIN_SLABS,
    nlgs_coloured_kernel,
    parallel_colours,
    slab_count,
)
from grainlab.engine.nscd.serial_sweep import nlgs_kernel
from grainlab.engine.nscd.subspace_minimisation import (
    CG_ITERATIONS,
    SWEEPS_BETWEEN,
    NormalCoupling,
    subspace_correction,
)
from grainlab.engine.nscd.sweep_arrays import (
    BodyRows,
    CellRows,
    ContactRows,
    Motion,
    SolveSettings,
    SweepGroups,
    WallRows,
)
from grainlab.engine.quaternion import quat_to_matrices, rotate_quaternions
from grainlab.engine.shape_kinds import library_time_step_length
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import StepReport, contact_frames, contact_keys
from grainlab.errors import ConvergenceError, InputError, SolverDivergence

_SWEEPS = ("coloured", "serial")
CORRECTIONS = ("none", "subspace")
"""The corrections between sweeps (``correction`` of :class:`ContactDynamicsStep`)."""


WARM_START_EXTRAPOLATION = 0.5
"""lambda of the extrapolated warm start in the lab tests (module docstring, "Warm start";
the engine's default is 0)."""


SPATIAL_ORDER_BODIES = 4096
"""From this many bodies, the coloured sweep works on the bodies in Morton order
(:func:`~grainlab.engine.body_order.spatial_order`: the same results, better use of the
caches)."""


# --------------------------------------------------------------------------------------------
# Python launcher
# --------------------------------------------------------------------------------------------




class ContactDynamicsStep:
    """One NSCD time step for sphere-based rigid bodies and fixed plane walls.

    Parameters
    ----------
    dt:
        Time step h [s] > 0 (pitfall 6: v_max h <= 0.01-0.05 d_min).
    theta:
        theta-scheme parameter in [0.5, 1].
    tolerance:
        NLGS tolerance on the natural-map residual (> 0, no units).
    change_tolerance:
        Tolerance on the relative change of the impulses between two sweeps (> 0); None
        (default): the same as ``tolerance``; inf: the change is measured and reported, not
        required (module docstring, "Convergence").
    max_iterations:
        NLGS sweep cap (>= 1).
    gravity:
        Acceleration (3,) [m/s^2].
    friction:
        Coulomb coefficient mu >= 0 of every contact.
    alert:
        Alert distance [m] >= 0; None: 0.1 x the smallest member radius (6.2). It grows
        (``alert_growths`` counts it) when bodies could close a larger gap within one step.
    gyroscopic:
        Add w x I w semi-implicitly (module docstring); False neglects it.
    strict:
        Raise :class:`~grainlab.errors.ConvergenceError` when NLGS does not converge.
    seed:
        Seed of the per-step random visiting order (``sweep="serial"``).
    sweep:
        NLGS visiting order: ``"coloured"`` (parallel over graph-coloured contacts) or
        ``"serial"`` (one seeded random permutation per step); module docstring.
    overlap_recovery:
        beta in [0, 1]: an existing overlap (g < 0) must open by beta |g| within the step
        (U_n >= beta |g| / h; module docstring); 0 (default): the pure law, overlaps kept.
    warm_start_extrapolation:
        lambda in [0, 1]: a contact found in the two previous steps starts from its last
        force plus lambda times that force's change over the last step, projected on its
        Coulomb cone (module docstring, "Warm start"); 0: from its last force.
    correction:
        ``"none"`` (default): NLGS sweeps alone; ``"subspace"``: in a step where every
        contact is frictionless, a subspace minimisation every
        :data:`~grainlab.engine.nscd.subspace_minimisation.SWEEPS_BETWEEN` sweeps
        (:mod:`~grainlab.engine.nscd.subspace_minimisation`; the same stop test, the sweeps
        and the corrections' conjugate-gradient products counted apart); steps with friction
        are swept alone (module docstring, "Subspace minimisation").

    Attributes
    ----------
    overlap_recovery_speed:
        Largest separation speed [m/s] > 0 the recovery may ask for (U_n >= min(beta |g| / h,
        this)); inf (the default): no cap. beta |g| / h grows as the step shrinks: with the
        short steps of spinning polyhedra it reached ~1 m/s and blew an 8-polyhedron sample
        apart (p jumped to 7.7e7 Pa at the first shearing step). A stage's setting, as
        ``overlap_recovery``, ``tolerance`` and ``max_iterations`` (the lab sets them at each
        stage: :meth:`~grainlab.lab.solver_registry.SolverRecord.set_stage`); checked when
        set.
    """

    def __init__(
        self, dt: float, theta: float = 0.5, tolerance: float = 1e-5,
        max_iterations: int = 1000, gravity=(0.0, 0.0, 0.0), friction: float = 0.4,
        alert: float | None = None, gyroscopic: bool = False, strict: bool = False,
        seed: int = 0, sweep: str = "coloured", overlap_recovery: float = 0.0,
        change_tolerance: float | None = None, warm_start_extrapolation: float = 0.0,
        correction: str = "none",
    ) -> None:
        self.dt = at_least("dt", dt)
        theta_value = at_least("theta", theta)
        if not 0.5 <= theta_value <= 1.0:
            raise InputError("theta", theta, "a number in [0.5, 1]")
        self.theta = theta_value
        self.tolerance = at_least("tolerance", tolerance)
        self.change_tolerance = change_tolerance if change_tolerance in (None, math.inf) \
            else at_least("change_tolerance", change_tolerance)
        if isinstance(max_iterations, bool) or not isinstance(max_iterations, int | np.integer) \
                or max_iterations < 1:
            raise InputError("max_iterations", max_iterations, "an integer >= 1")
        self.max_iterations = int(max_iterations)
        g = np.asarray(gravity, dtype=np.float64)
        if g.shape != (3,) or not np.isfinite(g).all():
            raise InputError("gravity", gravity, "a finite (3,) acceleration in m/s^2")
        self.gravity = g
        self.friction = at_least("friction", friction, strict=False)
        self.alert = None if alert is None else at_least("alert", alert, strict=False)
        self.gyroscopic = bool(gyroscopic)
        self.strict = bool(strict)
        self._rng = np.random.default_rng(seed)
        if sweep not in _SWEEPS:
            raise InputError("sweep", sweep, "one of " + ", ".join(map(repr, _SWEEPS)))
        self.sweep = sweep
        if correction not in CORRECTIONS:
            raise InputError("correction", correction,
                             "one of " + ", ".join(map(repr, CORRECTIONS)))
        self.correction = correction
        self.correction_products = 0
        self.overlap_recovery = overlap_recovery
        self.overlap_recovery_speed = math.inf
        self.warm_start_extrapolation = in_range(
            "warm_start_extrapolation", warm_start_extrapolation, 0.0, 1.0, closed="[]")
        self._warm_keys = np.zeros(0, dtype=np.int64)
        self._warm_forces = np.zeros((0, 3))
        self._earlier_keys = np.zeros(0, dtype=np.int64)
        self._earlier_forces = np.zeros((0, 3))
        self.alert_growths = 0
        self._detection: DetectionPhases | None = None
        self.keep_problem = False
        """Attach each step's plain problem to its report (``StepReport.problem``)."""

    @property
    def overlap_recovery(self) -> float:
        """beta in [0, 1] (the ``overlap_recovery`` parameter)."""
        return self._overlap_recovery

    @overlap_recovery.setter
    def overlap_recovery(self, value: float) -> None:
        recovery = at_least("overlap_recovery", value, strict=False)
        if recovery > 1.0:
            raise InputError("overlap_recovery", value, "a number in [0, 1]")
        self._overlap_recovery = recovery

    @property
    def overlap_recovery_speed(self) -> float:
        """The recovery's speed cap v_r [m/s] (class docstring, "Attributes")."""
        return self._overlap_recovery_speed

    @overlap_recovery_speed.setter
    def overlap_recovery_speed(self, value: float) -> None:
        self._overlap_recovery_speed = math.inf if value == math.inf else \
            at_least("overlap_recovery_speed", value)

    def _phases(self, library: ShapeLibrary, travel: float = 0.0) -> DetectionPhases:
        """Broad and narrow phases; the alert distance grows (never shrinks) to 1.5 x
        ``travel`` [m] when bodies may close a gap larger than it within one step (so that no
        contact can be missed: tunnelling)."""
        if self._detection is not None and travel > self._detection.alert:
            self._detection = None
            self.alert = 1.5 * travel
            self.alert_growths += 1
        if self._detection is None:
            alert = self.alert if self.alert is not None else \
                0.1 * _smallest_radius(library)
            self._detection = DetectionPhases.with_alert(alert)
        return self._detection

    def _free_spins(self, state: BodyState, rotations: np.ndarray) -> np.ndarray:
        omega = np.array(state.angular_velocities, dtype=np.float64)
        if not self.gyroscopic:
            return omega
        return gyroscopic_spins(omega, rotations, state.inertias, self.dt)


    def step(self, state: BodyState, library: ShapeLibrary, walls=None) -> StepReport:
        """Advance ``state`` in place by one step.

        ``walls`` is the boundary (:mod:`grainlab.engine.boundaries.boundary`): a
        :class:`~grainlab.engine.boundaries.wall_box.WallBox` (moving, driven walls; advanced in
        place,
        reactions recorded, per-wall friction), a periodic cell
        (:class:`~grainlab.engine.boundaries.periodic_boundary.PeriodicCell`), None (open space) or
        (points (W, 3) [m], normals (W, 3)) of fixed planes with normals pointing into the
        bodies' region (friction ``self.friction``)."""
        h = self.dt
        _check_finite_state(state)
        boundary = as_boundary(walls, self.friction)
        bounds = boundary.constraints(h, self.theta)
        predicted = self._predict(state, bounds)
        # largest approach within the step: two bodies (or a body and a wall) closing in
        phases = self._phases(library, h * (2.0 * predicted.speed + bounds.speed
                                            + float(np.linalg.norm(self.gravity)) * h))
        contacts, images = boundary.detect(predicted.state, library, phases, bounds)
        rows, bodies = self._contact_rows(state, predicted, contacts, images, bounds)
        wall_rows, cell = _boundary_rows(bounds)
        change_tolerance = self.tolerance if self.change_tolerance is None else \
            self.change_tolerance
        settings = SolveSettings(float(h), float(self.tolerance), float(change_tolerance),
                                 int(self.max_iterations))
        system = constraint_system(rows, bodies, wall_rows, cell, h, centres=predicted.x_m) \
            if self.keep_problem else None
        problem = None if system is None else system.problem(rows.mu)
        keys = contact_keys(contacts, state.n_bodies, library)
        impulses = h * np.einsum("cij,cj->ci", rows.frame, self._warm_start_forces(keys))
        if self.warm_start_extrapolation > 0.0:
            impulses = project_on_cones(impulses, rows.mu)
        images = rows.images
        crossing = np.any(images != 0.0, axis=1)
        motion, iterations, change, residual = self._solve(
            rows, bodies, wall_rows, cell, settings, impulses, predicted.x_m,
            crossing if bounds.has_free_cell else None, predicted.speed)
        forces = self._remember_forces(keys, rows.frame, impulses)
        relative = _closing_velocities(rows, wall_rows, motion)
        # end-of-step configuration
        state.velocities[:] = motion.velocities
        state.angular_velocities[:] = motion.spins
        state.positions[:] = predicted.x_m + self.theta * h * motion.velocities
        state.orientations[:] = rotate_quaternions(predicted.q_m, self.theta * h * motion.spins)
        boundary.finish_step(BoundaryMotion(
            dt=h, theta=self.theta, wall_speeds=motion.wall_speeds,
            wall_reactions=np.zeros(0), cell_dofs=motion.cell_dofs, cell_rate=motion.cell_rate,
            closed=ClosedContacts(contacts, images, impulses, forces)))
        n_contacts = contacts.n_contacts
        return StepReport(
            n_contacts=n_contacts, iterations=int(iterations),
            converged=bool(n_contacts == 0 or (change <= change_tolerance
                                               and residual <= self.tolerance)),
            change=change, residual=residual,
            max_overlap=float(max(0.0, -contacts.gap.min())) if n_contacts else 0.0,
            contacts=contacts, frames=rows.frame, impulses=impulses,
            relative_velocity=relative, images=images, problem=problem, system=system,
        )

    def _predict(self, state: BodyState, bounds) -> _Predicted:
        """The free motion (gravity, gyroscopic spins, a periodic cell's change of rate) and
        the detection configuration q_m = q + (1 - theta) h v of a step."""
        h, theta = self.dt, self.theta
        speed = float(np.sqrt(np.max(np.sum(state.velocities**2, axis=1)))) \
            if state.n_bodies else 0.0
        rotations = quat_to_matrices(state.orientations)
        free_v = np.ascontiguousarray(state.velocities + h * self.gravity[None, :])
        free_w = np.ascontiguousarray(self._free_spins(state, rotations))
        x_m = state.positions + (1.0 - theta) * h * state.velocities
        q_m = rotate_quaternions(state.orientations, (1.0 - theta) * h * state.angular_velocities)
        if np.any(bounds.affine_change != 0.0):  # a periodic cell whose rate changed
            centre = np.average(x_m, axis=0, weights=state.masses)
            free_v += (x_m - centre) @ bounds.affine_change.T
        return _Predicted(replace(state, positions=x_m, orientations=q_m), x_m, q_m,
                          free_v, free_w, speed)

    def _contact_rows(self, state: BodyState, predicted: _Predicted, contacts, images,
                      bounds) -> tuple[ContactRows, BodyRows]:
        """The kernels' rows of the detected ``contacts`` (local frames, arms from the
        centres at q_m, friction, gap terms) and of the bodies (inverse masses, world inverse
        inertia at q_m, free velocities)."""
        h, x_m = self.dt, predicted.x_m
        n_contacts = contacts.n_contacts
        images = np.ascontiguousarray(images, dtype=np.float64)
        frames = contact_frames(contacts.normal)
        arm_i = np.zeros((n_contacts, 3))
        inner = contacts.body_i >= 0
        arm_i[inner] = contacts.point[inner] - x_m[contacts.body_i[inner]]
        arm_j = np.ascontiguousarray(contacts.point - x_m[contacts.body_j])
        crossing = np.any(images != 0.0, axis=1)
        if np.any(crossing):  # the arm of j reaches from its image: x_j + h_m m_k
            arm_j[crossing] -= images[crossing] @ bounds.cell_matrix.T
        r_m = quat_to_matrices(predicted.q_m)
        inv_inertia = np.ascontiguousarray(
            np.einsum("nij,nj,nkj->nik", r_m, 1.0 / state.inertias, r_m))
        mu = np.full(n_contacts, self.friction)
        on_wall = ~inner
        if np.any(on_wall):
            mu[on_wall] = bounds.wall_friction[-1 - contacts.body_i[on_wall]]
        # gap term g* [m] of the law U_n + g*/h >= 0: max(0, g) + max(beta min(0, g), -v_r h)
        gap_term = np.maximum(contacts.gap, 0.0) + np.maximum(
            self.overlap_recovery * np.minimum(contacts.gap, 0.0),
            -self.overlap_recovery_speed * h)
        return (ContactRows(contacts.body_i, contacts.body_j, frames, np.ascontiguousarray(arm_i),
                            arm_j, images, mu, gap_term),
                BodyRows(1.0 / state.masses, inv_inertia, predicted.free_v, predicted.free_w))

    def _solve(self, rows: ContactRows, bodies: BodyRows, walls: WallRows, cell: CellRows,
               settings: SolveSettings, impulses: np.ndarray, x_m: np.ndarray, serial,
               speed: float) -> tuple[Motion, int, float, float]:
        """The NLGS solve of the step (``impulses`` in: warm start, out: solution), serial or
        coloured (``serial``: contacts the coloured sweep must visit one by one, None): the
        end-of-step motion, the sweeps done, the last relative change and residual; refuses
        non-finite results (:func:`_check_finite_solve`) and, when strict, no convergence."""
        n_bodies, n_contacts = bodies.inv_mass.shape[0], rows.body_i.shape[0]
        motion = Motion(np.empty((n_bodies, 3)), np.empty((n_bodies, 3)),
                        np.empty(walls.inv_mass.shape[0]), np.empty(cell.inv_mass.shape[0]),
                        np.empty((3, 3)))
        delassus = np.empty((n_contacts, 3, 3))
        residuals = np.zeros(2)
        if self.sweep == "serial":
            order = self._rng.permutation(n_contacts).astype(np.int64)

            def sweeps(limits):
                return nlgs_kernel(rows, bodies, walls, cell, limits, order, motion, impulses,
                                   delassus, residuals)
        else:
            groups = _sweep_groups(rows, walls, x_m, serial)

            def sweeps(limits):
                return nlgs_coloured_kernel(rows, bodies, walls, cell, limits, groups, motion,
                                            impulses, delassus, residuals)
        if self.correction == "subspace" and n_contacts and not np.any(rows.mu > 0.0):
            iterations = self._corrected_sweeps(sweeps, settings, rows, bodies, walls, cell,
                                                motion, impulses, residuals)
        else:
            iterations = sweeps(settings)
        change, residual = float(residuals[0]), float(residuals[1])
        _check_finite_solve(iterations, change, residual, impulses,
                            {"body velocities": motion.velocities,
                             "angular velocities": motion.spins,
                             "wall speeds": motion.wall_speeds, "cell rate": motion.cell_rate},
                            self.dt, speed)
        converged = n_contacts == 0 or (change <= settings.change_tolerance
                                        and residual <= self.tolerance)
        if not converged and self.strict:
            raise ConvergenceError(
                f"NLGS did not converge in {iterations} sweeps: relative change {change:.3e}, "
                f"residual {residual:.3e} (tolerance {self.tolerance:.3e}, "
                f"{n_contacts} contacts).")
        return motion, iterations, change, residual

    def _corrected_sweeps(self, sweeps, settings: SolveSettings, rows: ContactRows,
                          bodies: BodyRows, walls: WallRows, cell: CellRows, motion: Motion,
                          impulses: np.ndarray, residuals: np.ndarray) -> int:
        """Sweeps in runs of :data:`SWEEPS_BETWEEN`, a subspace minimisation of the normal
        impulses after each run that ends unconverged (frictionless steps,
        :mod:`~grainlab.engine.nscd.subspace_minimisation`); the sweeps done. The last run
        is a plain run of sweeps, so the stop test and the motion are the kernel's own.
        A step where a wall's or the cell's speed limit holds is not the plain problem the
        correction minimises (:mod:`~grainlab.engine.nscd.contact_problem`): its remaining
        sweeps run alone."""
        coupling = None
        done = 0
        while True:
            run = min(SWEEPS_BETWEEN, settings.max_iterations - done)
            ran = sweeps(settings._replace(max_iterations=run))
            done += ran
            converged = residuals[0] <= settings.change_tolerance \
                and residuals[1] <= settings.tolerance
            if converged or ran < run or done >= settings.max_iterations:
                return done
            if _brake_held(walls, cell, motion):
                return done + sweeps(settings._replace(
                    max_iterations=settings.max_iterations - done))
            if coupling is None:
                coupling = NormalCoupling.of(rows, bodies, walls, cell)
            velocity = _closing_velocities(rows, walls, motion)[:, 0] \
                + rows.gap / settings.dt
            normal, gain = subspace_correction(coupling, impulses[:, 0], velocity)
            self.correction_products += CG_ITERATIONS
            if gain < 0.0:
                impulses[:, 0] = normal
                impulses[:, 1:] = 0.0

    def _remember_forces(self, keys: np.ndarray, frames: np.ndarray,
                         impulses: np.ndarray) -> np.ndarray:
        """The world forces (C, 3) [N] of the step's ``impulses``, kept by contact key (sorted)
        for the warm start of the next step (the last step's moved to the step before)."""
        forces = np.einsum("cji,cj->ci", frames, impulses) / self.dt
        order_keys = np.argsort(keys, kind="stable")
        self._earlier_keys, self._earlier_forces = self._warm_keys, self._warm_forces
        self._warm_keys = keys[order_keys]
        self._warm_forces = forces[order_keys]
        return forces

    def _warm_start_forces(self, keys: np.ndarray) -> np.ndarray:
        """World forces (C, 3) [N] the contacts of ``keys`` (C,) start from (module docstring,
        "Warm start"): the last step's force f of the same key (zero for a new contact), plus
        lambda (f - f') for a key found in the step before too (f' its force there)."""
        forces = np.zeros((keys.size, 3))
        found, where = _find_keys(self._warm_keys, keys)
        forces[found] = self._warm_forces[where[found]]
        if self.warm_start_extrapolation > 0.0 and self._earlier_keys.size:
            earlier, at = _find_keys(self._earlier_keys, keys)
            both = found & earlier
            forces[both] += self.warm_start_extrapolation * (
                forces[both] - self._earlier_forces[at[both]])
        return forces

    def warm_start_arrays(self) -> dict[str, np.ndarray]:
        """The warm-start memory (contact keys and world forces [N] of the last two steps)
        for checkpoints."""
        return {"keys": self._warm_keys.copy(), "forces": self._warm_forces.copy(),
                "earlier_keys": self._earlier_keys.copy(),
                "earlier_forces": self._earlier_forces.copy()}

    def restore_warm_start(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore the memory saved by :meth:`warm_start_arrays` (a checkpoint without the
        step before the last: no extrapolation at the first step)."""
        self._warm_keys = np.asarray(arrays["keys"], dtype=np.int64)
        self._warm_forces = np.asarray(arrays["forces"], dtype=np.float64).reshape(-1, 3)
        self._earlier_keys = np.asarray(arrays.get("earlier_keys", np.zeros(0)),
                                        dtype=np.int64)
        self._earlier_forces = np.asarray(arrays.get("earlier_forces", np.zeros((0, 3))),
                                          dtype=np.float64).reshape(-1, 3)

    def alert_distance(self, library: ShapeLibrary) -> float:
        """The alert distance [m] the next detection uses (module docstring of
        :meth:`_phases`): bodies farther apart than this at a step's start have no row."""
        if self._detection is not None:
            return self._detection.alert
        return self.alert if self.alert is not None else 0.1 * _smallest_radius(library)

    @property
    def rng_state(self) -> dict:
        """State of the visiting-order generator (checkpoints)."""
        return self._rng.bit_generator.state

    @rng_state.setter
    def rng_state(self, value: dict) -> None:
        self._rng.bit_generator.state = value


def _check_finite_state(state: BodyState) -> None:
    """Refuse a state whose positions, orientations or velocities are not all finite
    (:class:`~grainlab.errors.InputError` naming the array and the first body)."""
    for name in ("positions", "orientations", "velocities", "angular_velocities"):
        array = getattr(state, name)
        bad = np.flatnonzero(~np.all(np.isfinite(array.reshape(len(array), -1)), axis=1))
        if bad.size:
            raise InputError(f"state.{name}[{int(bad[0])}]", array[bad[0]].tolist(),
                             "finite values at the start of a step")


def _brake_held(walls: WallRows, cell: CellRows, motion: Motion) -> bool:
    """Whether a mobile wall ends the sweeps at its speed limit or a free cell degree of
    freedom at a bound (:mod:`~grainlab.engine.nscd.speed_limits`)."""
    mobile = walls.inv_mass > 0.0
    if np.any(np.abs(motion.wall_speeds[mobile]) >= (1.0 - 1e-9) * walls.max_speeds[mobile]):
        return True
    free = cell.inv_mass > 0.0
    dofs = motion.cell_dofs[free]
    bounds = cell.bounds[free]
    return bool(np.any((dofs <= bounds[:, 0] + 1e-12 * np.abs(bounds[:, 0]))
                       | (dofs >= bounds[:, 1] - 1e-12 * np.abs(bounds[:, 1]))))


def _check_finite_solve(iterations: int, change: float, residual: float,
                        impulses: np.ndarray, outputs: dict, dt: float, speed: float) -> None:
    """Raise :class:`~grainlab.errors.SolverDivergence` when the sweeps ended on non-finite
    impulses, velocities (``outputs``: name -> array) or convergence measures (module
    docstring, "Convergence"), before the step touches the state; the message says where
    and the likely cause."""
    bad = [name for name, array in outputs.items() if not np.all(np.isfinite(array))]
    finite_impulses = bool(np.all(np.isfinite(impulses)))
    if finite_impulses and not bad and math.isfinite(change) and math.isfinite(residual):
        return
    if not finite_impulses:
        rows = np.flatnonzero(~np.all(np.isfinite(impulses), axis=1))
        bad.insert(0, f"impulses at contacts {rows[:5].tolist()}")
    what = f"non-finite {', '.join(bad)}" if bad else (
        f"its convergence measures overflowed (impulses up to {np.abs(impulses).max():.3g} "
        "N s)")
    raise SolverDivergence(
        f"the contact solve (NLGS) diverged at sweep {iterations}: {what}, beyond the range "
        f"of double precision; the step was not applied. Reduce the time step (dt = {dt:g} s) "
        f"if the speeds grew during the run (up to {speed:.3g} m/s at this step's start), "
        "else check the units of the densities, sizes and speeds.")


def _find_keys(sorted_keys: np.ndarray, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each of ``keys`` (C,): whether it is in ``sorted_keys`` (ascending) and where."""
    if sorted_keys.size == 0:
        return np.zeros(keys.size, dtype=bool), np.zeros(keys.size, dtype=np.int64)
    where = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[where] == keys, where




class _Predicted(NamedTuple):
    """A step's detection configuration (``state`` at positions ``x_m`` (N, 3) [m] and
    orientations ``q_m`` (N, 4)), free velocities ``free_v``, ``free_w`` (N, 3) [m/s],
    [rad/s], and the largest speed [m/s] at its start."""

    state: BodyState
    x_m: np.ndarray
    q_m: np.ndarray
    free_v: np.ndarray
    free_w: np.ndarray
    speed: float


def _boundary_rows(bounds) -> tuple[WallRows, CellRows]:
    """The kernels' rows of the walls and of the periodic cell of a step's ``bounds``
    (:mod:`grainlab.engine.boundaries.boundary`)."""
    def as_float(array):
        return np.ascontiguousarray(array, dtype=np.float64)

    return (WallRows(as_float(bounds.wall_normals), as_float(bounds.wall_inv_mass),
                     as_float(bounds.wall_free), as_float(bounds.wall_max)),
            CellRows(as_float(bounds.cell_fixed), as_float(bounds.cell_basis),
                     as_float(bounds.cell_inv_mass), as_float(bounds.cell_free),
                     as_float(bounds.cell_bounds)))


def _sweep_groups(rows: ContactRows, walls: WallRows, x_m: np.ndarray, serial) -> SweepGroups:
    """The coloured sweep's groups: colours (:func:`colour_contacts`), or slabs
    (:func:`slab_contacts`) when the colours are too small to be worth waking the threads
    for each (their count and order from the packing, whatever the number of threads)."""
    n_bodies, n_contacts = x_m.shape[0], rows.body_i.shape[0]
    colouring = colour_contacts(rows.body_i, rows.body_j, walls.inv_mass, n_bodies,
                                serial=serial)
    sizes = np.diff(colouring.offsets[: colouring.n_colours + 1])
    if n_contacts >= MIN_SLABS and (sizes.size == 0 or sizes.max() < MIN_COLOURS):
        groups = slab_contacts(rows.body_i, rows.body_j, x_m, walls.inv_mass, serial=serial,
                               n_slabs=slab_count(n_contacts))
        n_parallel = groups.n_colours if get_num_threads() > 1 else 0
        body_order = groups.body_order
    else:
        groups = colouring
        n_parallel = parallel_colours(colouring.offsets, colouring.n_colours,
                                      get_num_threads())
        body_order = spatial_order(x_m) if n_bodies >= SPATIAL_ORDER_BODIES else \
            np.arange(n_bodies, dtype=np.int64)
    return SweepGroups(groups.order, groups.offsets, groups.chains, body_order, int(n_parallel))


def _closing_velocities(rows: ContactRows, walls: WallRows, motion: Motion) -> np.ndarray:
    """End-of-step local relative velocities (C, 3) [m/s] of body j w.r.t. body i (or its
    wall), an image moving with the cell: the sweeps' compiled law
    (:func:`~grainlab.engine.nscd.contact_update.closing_velocities_kernel`)."""
    out = np.empty((rows.body_i.shape[0], 3))
    closing_velocities_kernel(rows, walls.normals, motion, out)
    return out


def closing_velocities_twin(rows: ContactRows, walls: WallRows, motion: Motion) -> np.ndarray:
    """:func:`_closing_velocities` in NumPy, written from the kinematics alone (the slow,
    obviously right twin the tests hold the kernel to, STYLE.md 12)."""
    bj, bi = rows.body_j, rows.body_i
    u = motion.velocities[bj] + np.cross(motion.spins[bj], rows.arm_j)
    u += rows.images @ motion.cell_rate.T  # an image moves with the cell: hdot m_k
    inner = bi >= 0
    u[inner] -= motion.velocities[bi[inner]] + np.cross(motion.spins[bi[inner]],
                                                        rows.arm_i[inner])
    wall = -1 - bi[~inner]
    u[~inner] -= motion.wall_speeds[wall, None] * walls.normals[wall]
    return np.einsum("cij,cj->ci", rows.frame, u)


def _smallest_radius(library: ShapeLibrary) -> float:
    """Smallest member-sphere radius or polyhedron inradius about the centre of mass [m]:
    half the time-step length d_min of the library's shape kinds
    (:func:`~grainlab.engine.shape_kinds.library_time_step_length`)."""
    return 0.5 * library_time_step_length(library)


