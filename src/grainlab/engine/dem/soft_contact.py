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
h = dt / n no longer than the stable step: the shorter of the springs' rule (:meth:`~grainlab.
contact.soft_contact_law.SoftContactLaw.time_step`: a fraction of the Rayleigh time for Hertz,
of the collision time pi sqrt(m / (2 k)) for springs) and the dashpots' bound of the step's
contacts (:mod:`grainlab.engine.dem.soft_stability`: the dashpots act with the half-step velocity,
explicitly, and a damping rate beta needs h^2 w^2 + 2 h beta < 4), taken at the step's start
and again when a list is rebuilt within it (the rest of the step is then cut again if the new
contacts need it); ``substep`` reports it, ``spring_substep`` and ``damped_substep`` its two
limits, and ``velocity_zigzag`` how much the contacts' velocities changed in the step's last
half sub-step (about 1 where a sub-step was unstable). The sub-steps run in
compiled code (:mod:`grainlab.engine.dem.soft_contact_kernels`) on a neighbour list: the member
pairs within a ``skin`` [m] (default 0.1 x the smallest member diameter) found by the
boundary's own detection (every shape kind's broad and narrow phase, walls, the periodic
cell's images), rebuilt when two points may have closed the skin. The list lives from step to
step (the bodies' travel, the walls' and the cell's motion since it was built carried along),
and is rebuilt at once when the bodies, the walls or the cell were moved between two steps
by anything else than the solver (a re-mapped cell, a restored state).
Convex polyhedra go through their own list and sub-steps (:mod:`grainlab.engine.
soft_polyhedra`: a soft law on the penetration at each point of the contact-dynamics
manifold, recomputed every sub-step; their list is rebuilt at every step).

The boundary (:mod:`grainlab.engine.boundaries.boundary`) is asked for its constraints once per
step, as
by contact dynamics. A driven wall moves at its speed through the step. A servo wall starts
the step at the speed its servo gives from the step before (:func:`~grainlab.engine.
boundaries.wall_box_face.servo_kernel`: the wall's mean reaction over the last step, in the
overdamped servo of contact dynamics, same gains and bounds, taken backward in time with the
stiffness K of the wall's contacts), then its servo runs again after the forces of every
sub-step (:func:`~grainlab.engine.boundaries.wall_box_face.servo_walls`: the same servo on the
wall's load at that sub-step, correcting :data:`~grainlab.engine.boundaries.wall_box_face.
SUBSTEP_SERVO_FRACTION` of a stiff load's error per sub-step, as YADE's triaxial stress
controller does with its ``wallDamping``; K the largest the wall's contacts had in the step,
so that a wall that loses its last contact for a sub-step does not rush in at the loose
servo's speed; polyhedra alike, in their own sub-steps). An integral
part learns the speed a wall must keep while the sample is deformed (only in steps with a
driven wall), starting from the speeds that would keep the volume
(:func:`isochoric_wall_speeds`). The box is then told each wall's displacement over
the step (its mean speed). Once per step was not enough on stiff grains: a servo that reads
the mean load of the last step lagged the sample, and the lateral stresses of a 300-sphere
triaxial test at kappa = 1e4 swung from 0.4 to 2.2 sigma0 (39 % median error; 2.2 % at
every sub-step, 0.8 % at kappa = 1e3, 4.5 % at kappa = 1e5). The
periodic cell is servoed at every sub-step (:func:`~grainlab.engine.boundaries.
periodic_cell_face.cell_servo_kernel`: the stress of the contacts' springs over all the
contacts, low-passed over :data:`FILTER_SUBSTEPS` stable sub-steps, the stiffness of the
affine deformation of the contacts in the denominator), the bodies taking up each change of
its rate at once (YADE's homogeneous deformation); the cell's integral term (:mod:`grainlab.engine.
periodic_boundary`) then learns from the step's mean stress while a prescribed part of the
rate deforms the sample. A lateral stress of a sheared periodic sample holds its target
within about 1 % (median). The step's report holds the contacts closed at its end with
their forces (``impulses`` = force x dt, as a step of contact dynamics reports them); a
wall's reaction is its mean over the step, the cell's stress the springs' mean stress.

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

import numba
import numpy as np

from grainlab._numba_setup import threading_layer
from grainlab._validate import at_least
from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.boundaries.boundary import (
    BoundaryMotion,
    DetectionPhases,
    as_boundary,
)
from grainlab.engine.boundaries.periodic_cell_face import CellFace
from grainlab.engine.boundaries.wall_box_face import (
    SERVO_INTEGRAL,
    SUBSTEP_SERVO_FRACTION,
    WallFace,
    servo_kernel,
)
from grainlab.engine.dem.body_pass import isotropic_blocks
from grainlab.engine.dem.neighbour_rows import carry_springs_kernel
from grainlab.engine.dem.soft_polyhedra import PolyhedronRows, has_polyhedra, smallest_radius
from grainlab.engine.dem.soft_stability import (
    HORIZON_STEPS,
    zigzag_index,
    zigzag_sums_kernel,
)
from grainlab.engine.dem.sphere_row_list import SphereRows
from grainlab.engine.dem.substep_arrays import BodyArrays
from grainlab.engine.simulation import SimulationBlowUp
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import StepReport, contact_keys
from grainlab.errors import InputError

SKIN_FRACTION = 0.1
"""Default skin of the neighbour list: this fraction of the smallest member diameter."""
FILTER_SUBSTEPS = 20.0
"""The periodic cell's servo reads the contacts' stress low-passed over this many stable
sub-steps (four collisions: the law's stable step is 0.2 of a contact's half period)."""
PARALLEL_BODIES = {"tbb": 1000, "workqueue": 8000, "omp": 8000}
"""From this many bodies, per threading layer, the sub-steps share the rows and the bodies out
over Numba's threads (:func:`~grainlab.engine.dem.body_pass.bodies_parallel`; the same
results on any number of threads). Each sub-step then starts two parallel loops (three before
the bodies' end of a sub-step and start of the next became one pass), ~0.02 ms each with TBB
and ~0.17 ms with workqueue on the 2-core machine (measured), so that below this the threads
lose (benchmark_engine_soft_contact.py, 2 threads against 1: TBB 0.57x at 512 spheres, 1.4x
at 1000, 1.6x at 2197; workqueue 0.89x at 4096, 1.24x at 10 648; since the serial kernels
lost Numba's reference counts, TBB 1.18x at 1000, 1.34x at 2197, 1.49x at 4096)."""


def threads_pay(n_bodies: int) -> bool:
    """Whether the sub-steps of ``n_bodies`` bodies run on the threads (:data:`PARALLEL_BODIES`
    of the threading layer in use)."""
    if numba.get_num_threads() < 2:
        return False
    return n_bodies >= PARALLEL_BODIES.get(threading_layer(), min(PARALLEL_BODIES.values()))


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
        Sub-step [s] > 0, used as given; None: at every step the shorter of the springs'
        rule for the bodies and the dashpots' bound of the contacts.
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
        """The longest sub-step [s] of the last step: the fixed one, or the shorter of
        :attr:`spring_substep` and :attr:`damped_substep` at the step's start (a list rebuilt
        in the step may shorten it further); the step is cut into equal sub-steps no longer
        than it."""
        self.spring_substep = self.fixed_substep
        """The springs' rule [s] (:meth:`stable_substep`), or the fixed sub-step."""
        self.damped_substep = math.inf
        """The dashpots' bound [s] of the last step's contacts (:mod:`grainlab.engine.
        soft_stability`; inf without contacts or with a fixed sub-step)."""
        self.velocity_zigzag = 0.0
        """How much the contacts' relative velocities changed between the last step's last
        force evaluation and its end, over themselves (:func:`~grainlab.engine.
        soft_stability.zigzag_index`): small for a motion the sub-steps resolve, about 1 for
        one that flips sign at every sub-step (an unstable sub-step)."""
        self.theta = 1.0
        self.alert_growths = 0
        self.n_substeps = 0
        """Sub-steps done since the solver was made (or since its run started, when its
        warm start is restored from a checkpoint)."""
        self.n_detections = 0
        """Neighbour lists built since the solver was made."""
        self.last_substeps = 0
        self._springs = (np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3)))
        """The springs of the last list by key, keys in order: (keys (C,), tangential
        springs (C, 3) [N], rolling moments (C, 3) [N m])."""
        self._wall_load = np.zeros((0, 3))
        """Per wall: mean reaction over the last step [N], stiffness [N/m], servo memory
        [m/s]."""
        self._driven = False
        """Whether the last step had a driven (strain-controlled) part of the boundary."""
        self._carried = np.zeros((3, 3))
        """The velocity gradient L [1/s] the bodies' velocities carry (periodic cell)."""
        self._filtered = np.zeros((3, 3))
        """The springs' stress [Pa] low-passed over :attr:`filter_time` (the cell's servo)."""
        self._phases: DetectionPhases | None = None
        self._rows: SphereRows | None = None
        """The neighbour list, kept from step to step while it is valid."""
        self._end = (np.zeros((0, 3)), np.zeros((0, 4)))
        """The bodies' positions and orientations at the end of the last step."""
        self._bodies: _BodyConstants | None = None

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
        """The contacts' springs (keys, tangential force [N], rolling moment [N m]), the
        boundary's loads of the last step (the servos' input), the neighbour list (so that
        a resumed run goes on with the same list, bit for bit) and the count of sub-steps
        done (:attr:`n_substeps`: a resumed run goes on counting)."""
        if self._rows is not None:  # the live springs (the history is otherwise kept only
            self._remember(self._rows)  # when a list is replaced)
        keys, xi, roll = self._springs
        arrays = {"keys": keys.copy(), "history": np.hstack([xi, roll]),
                  "wall_load": self._wall_load.copy(),
                  "driven": np.array(int(self._driven)), "carried": self._carried.copy(),
                  "filtered": self._filtered.copy(),
                  "substeps": np.array(self.n_substeps, dtype=np.int64)}
        if isinstance(self._rows, SphereRows):  # (a polyhedra list is rebuilt at every step)
            arrays |= {f"list_{k}": v for k, v in self._rows.to_arrays().items()}
            arrays |= {"end_positions": self._end[0].copy(),
                       "end_orientations": self._end[1].copy()}
        return arrays

    def restore_warm_start(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore what :meth:`warm_start_arrays` saved."""
        history = np.asarray(arrays["history"], dtype=np.float64).reshape(-1, 6)
        self._springs = (np.asarray(arrays["keys"], dtype=np.int64),
                         np.ascontiguousarray(history[:, :3]),
                         np.ascontiguousarray(history[:, 3:]))
        self._wall_load = np.asarray(arrays["wall_load"], dtype=np.float64).reshape(-1, 3)
        self._driven = bool(int(arrays["driven"]))
        self._carried = np.asarray(arrays["carried"], dtype=np.float64).reshape(3, 3).copy()
        self._filtered = np.asarray(arrays.get("filtered", np.zeros((3, 3))),
                                    dtype=np.float64).reshape(3, 3).copy()
        if "substeps" in arrays:  # not in the checkpoints written before it was counted
            self.n_substeps = int(arrays["substeps"])
        self._rows = None
        if "list_body_i" in arrays:
            self._rows = SphereRows.from_arrays(
                {k[5:]: v for k, v in arrays.items() if k.startswith("list_")})
            self._end = (np.asarray(arrays["end_positions"], dtype=np.float64).copy(),
                         np.asarray(arrays["end_orientations"], dtype=np.float64).copy())

    @property
    def carried_gradient(self) -> np.ndarray:
        """(3, 3) [1/s] the periodic cell's velocity gradient L the bodies' velocities carry
        (updated in place by the sub-steps)."""
        return self._carried

    @property
    def filter_time(self) -> float:
        """Time [s] over which the periodic cell's servo low-passes the contacts' stress:
        :data:`FILTER_SUBSTEPS` sub-steps of the springs' rule (a few collisions: the law's
        stable step is 0.2 of a contact's half period)."""
        return FILTER_SUBSTEPS * float(self.spring_substep)

    # -- stepping ------------------------------------------------------------------------------
    def stable_substep(self, state: BodyState, library: ShapeLibrary) -> float:
        """The springs' rule for the sub-step [s] for these bodies (the lightest mass,
        counting the rotational inertia about a member's surface, and the smallest member
        radius or polyhedron inradius); each step also keeps within the dashpots' bound of
        its contacts (:attr:`damped_substep`)."""
        has_polyhedra(library, self.law)
        ids = state.shape_ids
        reach = library.bounding_radius[ids]
        rotational = np.min(state.inertias, axis=1) / np.maximum(reach, 1e-300) ** 2
        lightest = float(np.min(np.minimum(state.masses, rotational)))
        radius = smallest_radius(library)
        return self.law.time_step(lightest, radius, state.density)

    def whole_substeps(self, dt: float, state: BodyState, library: ShapeLibrary) -> float:
        """``dt`` [s] rounded down to a whole number (at least one) of sub-steps of full
        length: the fixed sub-step, or the springs' rule for these bodies. A step of ``dt``
        is cut into ceil(dt / sub-step) equal sub-steps, so a lab step of 10.3 stable
        sub-steps would run 11 of 0.94 of the stable length; rounded down it runs 10 of full
        length (the peers' test: 5 % fewer sub-steps). Where the dashpots' bound is the
        shorter (it changes with the contacts, step to step), the step is cut into
        ceil(dt / bound) equal sub-steps."""
        substep = self.fixed_substep or self.stable_substep(state, library)
        return max(1, math.floor(dt / substep * (1.0 + 1e-12))) * substep

    def step(self, state: BodyState, library: ShapeLibrary, walls=None) -> StepReport:
        """Advance ``state`` (and the boundary) by one step of ``dt`` (module docstring)."""
        macro = self.dt
        boundary = as_boundary(walls, self.friction)
        bounds = boundary.constraints(macro, 1.0)
        if not bounds.walls_overdamped and np.any(bounds.wall_inv_mass > 0.0):
            raise InputError("wall_servo", False, "servo walls (true) with the soft-contact "
                             "solver: walls with mass are a contact-dynamics option")
        bodies = self._body_constants(state, library)
        if self.fixed_substep is None:
            self.spring_substep = bodies.substep
        else:
            has_polyhedra(library, self.law)
            self.spring_substep = self.fixed_substep
        n_walls, n_dofs = bounds.n_walls, bounds.cell_inv_mass.shape[0]
        run = _Run(state, bodies, bounds, n_walls, n_dofs, macro)
        rows = self._kept_list(state, library, bounds, run)
        if rows is None:
            rows = self._build_list(state, library, boundary, bounds, run)
        if self._wall_load.shape[0] != n_walls:  # the loads now: the servos' first input
            run.advance(self, rows, 0, self.spring_substep)
            self._wall_load = np.column_stack([run.wall_force, run.wall_stiffness,
                                               np.zeros(n_walls)])
        run.was_driven = self._driven
        memory = run.servo(self._wall_load, macro)
        self._driven = run.driven
        self.substep = self._longest_substep(run, rows, macro)
        left = max(1, math.ceil(macro / self.substep * (1.0 - 1e-12)))
        h = macro / left
        done = 0
        while left > 0:
            if done:
                rows = self._build_list(state, library, boundary, bounds, run)
                longest = self._longest_substep(run, rows, h * left)
                if longest < h * (1.0 - 1e-12):  # the new list's contacts need shorter ones
                    self.substep = longest
                    rest = h * left
                    left = math.ceil(rest / longest * (1.0 - 1e-12))
                    h = rest / left
            did = run.advance(self, rows, left, h)
            done += did
            left -= did
        n_sub = done
        self.n_substeps += n_sub
        self.last_substeps = n_sub
        self._wall_load = np.column_stack([run.wall_impulse / macro, run.wall_stiffness,
                                           memory])
        report, closed = rows.report(run, macro)
        self.velocity_zigzag = run.zigzag(rows)
        boundary.finish_step(BoundaryMotion(
            dt=macro, theta=1.0, wall_speeds=run.mean_wall_speeds(),
            wall_reactions=run.wall_impulse / macro, cell_dofs=run.cell_dofs.copy(),
            cell_rate=(run.cell_h - bounds.cell_matrix) / macro, closed=closed,
            stress=run.stress_impulse / macro if n_walls == 0 else None))
        self._end = (state.positions.copy(), state.orientations.copy())
        return report

    def _longest_substep(self, run: _Run, rows, span: float) -> float:
        """The longest sub-step [s] for the next ``span`` [s] on ``rows``: the fixed one, or
        the springs' rule and the dashpots' bound of these contacts, whichever is shorter
        (:mod:`grainlab.engine.dem.soft_stability`; :attr:`damped_substep`)."""
        if self.fixed_substep is not None:
            return self.fixed_substep
        self.damped_substep = rows.damped_substep(run, self, HORIZON_STEPS * span)
        return min(self.spring_substep, self.damped_substep)

    def _body_constants(self, state: BodyState, library: ShapeLibrary) -> _BodyConstants:
        """The bodies' constants for the kernels, made again only for other bodies (other
        arrays of masses, inertias or shapes, or another library)."""
        kept = self._bodies
        if kept is None or not kept.describes(state, library):
            kept = self._bodies = _BodyConstants(state, library, self)
        return kept

    def _detection(self, library: ShapeLibrary) -> DetectionPhases:
        if self._phases is None:
            if self.skin is None:
                self.skin = 2.0 * SKIN_FRACTION * smallest_radius(library)
            self._phases = DetectionPhases.with_alert(self.skin, sphere_rows=True)
        return self._phases

    def _kept_list(self, state, library, bounds, run) -> SphereRows | None:
        """The list of the last step if it is still valid for this one (the same bodies where
        that step left them, the same walls, and no two points nearer to closing the skin
        than :func:`~grainlab.engine.dem.substep_loop.substeps_kernel` allows); None if
        it must be rebuilt."""
        rows = self._rows
        if (not isinstance(rows, SphereRows) or rows.travel.shape[0] != state.n_bodies
                or rows.wall_normals.shape != bounds.wall_normals.shape
                or not np.array_equal(rows.wall_normals, bounds.wall_normals)
                or not np.array_equal(self._end[0], state.positions)
                or not np.array_equal(self._end[1], state.orientations)):
            return None
        total = (2.0 * float(np.max(rows.travel, initial=0.0))
                 + float(np.max(np.abs(rows.built_wall_disp(bounds)), initial=0.0))
                 + math.sqrt(3.0 * float(np.sum((bounds.cell_matrix - rows.built_cell) ** 2))))
        if 2.0 * total - float(rows.approach[0]) > float(self.skin):
            return None
        rows.set_friction(bounds, self.friction)
        rows.renew_report_outputs()  # the last step's report keeps its own
        run.rows = rows
        return rows

    def _build_list(self, state, library, boundary, bounds, run) -> SphereRows:
        """The neighbour list at the current configuration, with the springs it carries."""
        phases = self._detection(library)
        now = replace(bounds, wall_points=bounds.wall_points
                      + run.wall_disp[:, None] * bounds.wall_normals,
                      cell_matrix=run.cell_h.copy())
        contacts, images = boundary.detect(state, library, phases, now)
        self.n_detections += 1
        if self._rows is not None:  # keep the springs of the list being replaced
            self._remember(self._rows)
        if has_polyhedra(library, self.law):  # one row per body pair (soft_polyhedra)
            rows = PolyhedronRows(contacts, images, state, library, bounds, self.friction)
        else:
            rows = SphereRows(contacts, np.ascontiguousarray(images, dtype=np.float64), state,
                         library, bounds, self.friction)
            rows.keys = contact_keys(contacts, state.n_bodies, library)
        rows.built_walls = np.array(now.wall_points, dtype=np.float64)
        rows.wall_normals = np.array(bounds.wall_normals, dtype=np.float64)
        rows.built_cell = np.array(now.cell_matrix, dtype=np.float64)
        if rows.keys.size:
            carry_springs_kernel(*self._springs, rows.keys, rows.xi, rows.roll)
        run.rows = rows
        self._rows = rows
        return rows

    def _remember(self, rows) -> None:
        """The springs of ``rows`` (a list about to be replaced, or saved) by key, in key
        order, for the next list (:func:`~grainlab.engine.dem.neighbour_rows.
        carry_springs_kernel`)."""
        keys = rows.keys
        if np.all(keys[1:] >= keys[:-1]):  # the usual order of a list (a stable sort keeps it)
            self._springs = (rows.keys, rows.xi, rows.roll)
            return
        order = np.argsort(rows.keys, kind="stable")
        self._springs = (rows.keys[order], rows.xi[order], rows.roll[order])


def isochoric_wall_speeds(bounds) -> np.ndarray:
    """The servo walls' speeds (W,) [m/s] that keep the volume while the driven walls move
    (the first guess of their integral terms when a deformation starts): the servo walls
    share the volume the driven walls take (each wall of a pair of planes normal to an axis,
    at distance L_a: a speed s changes the volume at -s / L_a per unit volume)."""
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
    return walls


def rotation_arms(library: ShapeLibrary, shape_ids: np.ndarray) -> np.ndarray:
    """(N,) [m] how far from its centre of mass a body's contacts are computed, which a turn
    of the body moves by |omega| h x that arm: the farthest member-sphere centre for shapes
    of member spheres (0 for a sphere at its centre of mass, whose turns move no contact),
    the bounding radius for polyhedra (their vertices). The neighbour list's travel counts
    it (:func:`~grainlab.engine.dem.substep_loop.substeps_kernel`)."""
    arms = np.array(library.bounding_radius, dtype=np.float64)
    count = library.vertex_count
    for s in range(arms.shape[0]):
        if count is None or count[s] == 0:
            lo = library.sphere_start[s]
            offsets = library.sphere_offsets[lo:lo + library.sphere_count[s]]
            arms[s] = float(np.sqrt(np.max(np.sum(offsets * offsets, axis=1), initial=0.0)))
    return np.ascontiguousarray(arms[shape_ids])


class _BodyConstants:
    """What the kernels read of the bodies and does not change while they are the same:
    inverse masses (N,) [1/kg] and masses, principal moments (N, 3) [kg m^2], whether they
    are equal (``isotropic`` (N,)), the inverse of the smallest (``inv_inertia`` (N,)
    [1/(kg m^2)]: the dashpots' bound), rotation arms (N,) [m] (:func:`rotation_arms`: the
    neighbour list's travel), and the law's stable sub-step [s]. Holds the arrays it was made
    from, so that :meth:`describes` is an identity test."""

    def __init__(self, state: BodyState, library: ShapeLibrary, solver: SoftContactStep):
        self._source = (state.masses, state.inertias, state.shape_ids, library)
        ids = state.shape_ids
        self.masses = np.ascontiguousarray(state.masses, dtype=np.float64)
        self.inv_mass = 1.0 / self.masses
        self.principal = np.ascontiguousarray(state.inertias, dtype=np.float64)
        self.isotropic = np.all(np.isclose(state.inertias, state.inertias[:, :1], rtol=1e-12,
                                           atol=0.0), axis=1)
        self.inv_inertia = 1.0 / np.min(self.principal, axis=1)
        self.arm = rotation_arms(library, ids)
        self.plain_bodies = isotropic_blocks(self.isotropic)
        self.substep = solver.stable_substep(state, library)

    def describes(self, state: BodyState, library: ShapeLibrary) -> bool:
        """Whether these are the constants of ``state``'s bodies (the same arrays)."""
        masses, inertias, shape_ids, kept = self._source
        return (masses is state.masses and inertias is state.inertias
                and shape_ids is state.shape_ids and kept is library)


class _Run:
    """What one step carries from sub-step to sub-step and list to list."""

    def __init__(self, state, bodies: _BodyConstants, bounds, n_walls, n_dofs, macro):
        self.state = state
        self.bounds = bounds
        self.rows: SphereRows | None = None
        self.masses = bodies.masses
        self.inv_mass = bodies.inv_mass
        self.principal = bodies.principal
        self.inv_inertia = bodies.inv_inertia
        self.isotropic = bodies.isotropic
        self.arm = bodies.arm
        self.plain_bodies = bodies.plain_bodies
        self.wall_disp = np.zeros(n_walls)
        self.wall_speed = np.array(bounds.wall_free, dtype=np.float64)
        self.cell_h = np.array(bounds.cell_matrix, dtype=np.float64)
        # the cell's servo (periodic_cell_face.cell_servo_kernel): L = L_0 + sum_d e_d G_d, e_d =
        # clip(free_d - scale_d c_d), as periodic_boundary's servo (scale = kappa_d V dt)
        inverse = np.linalg.inv(bounds.cell_matrix)
        self.cell_gradient = np.ascontiguousarray(bounds.cell_fixed @ inverse)
        self.cell_directions = np.ascontiguousarray(
            np.einsum("dab,bc->dac", bounds.cell_basis, inverse).reshape(n_dofs, 3, 3))
        self.cell_scale = np.ascontiguousarray(
            bounds.cell_inv_mass * float(np.linalg.det(bounds.cell_matrix)) * macro,
            dtype=np.float64)
        self.cell_dofs = np.array(bounds.cell_free, dtype=np.float64)
        self.cell_stiffness = np.zeros(n_dofs)
        self.cell_rate = np.zeros((3, 3))
        self.gradient = np.zeros((3, 3))
        self.virial = np.zeros((3, 3))
        self.stress_impulse = np.zeros((3, 3))
        self.wall_impulse = np.zeros(n_walls)
        self.was_driven = False
        self.driven = False
        self.body_force = np.zeros((state.n_bodies, 3))
        self.body_torque = np.zeros((state.n_bodies, 3))
        self.wall_force = np.zeros(n_walls)
        self.wall_stiffness = np.zeros(n_walls)
        self.stats = np.zeros(1)
        self.parallel = threads_pay(state.n_bodies)
        f64 = np.float64  # the walls' servos, at every sub-step (wall_box_face)
        self.macro = float(macro)
        self.servo_inv_mass = np.ascontiguousarray(bounds.wall_inv_mass, dtype=f64)
        self.servo_free = np.ascontiguousarray(bounds.wall_free, dtype=f64)
        self.servo_max = np.ascontiguousarray(bounds.wall_max, dtype=f64)
        self.wall_memory = np.zeros(n_walls)
        self.wall_floor = np.zeros(n_walls)
        self.integral = 0.0

    def mean_wall_speeds(self) -> np.ndarray:
        """(W,) [m/s] the walls' speeds over the step: a servo wall's changes from sub-step
        to sub-step, so its displacement over the step / the step; a driven wall's its own."""
        speeds = self.wall_speed.copy()
        servo = self.servo_inv_mass > 0.0
        speeds[servo] = self.wall_disp[servo] / self.macro
        return speeds

    def servo(self, wall_load: np.ndarray, macro: float) -> np.ndarray:
        """The walls' speeds at the start of the step (:func:`~grainlab.engine.
        wall_box_face.servo_kernel`) from the last step's mean loads and the servos'
        memories; returns the memories, which the sub-steps then update (their servo,
        :func:`~grainlab.engine.boundaries.wall_box_face.servo_walls`, starts from these
        memories, the stiffnesses of the last step's end and the integral gain set here).
        When a driven deformation starts, the memories start from
        :func:`isochoric_wall_speeds`. (The cell's servo runs at every sub-step, in the
        kernels.)"""
        b, f64 = self.bounds, np.float64
        wall_memory = np.ascontiguousarray(wall_load[:, 2], dtype=f64)
        driven = bool(np.any((b.wall_inv_mass == 0.0) & (b.wall_free != 0.0)))
        if driven and not self.was_driven:  # a deformation starts: guess the servos' speeds
            wall_memory[:] = isochoric_wall_speeds(b)
        self.integral = SERVO_INTEGRAL if driven else 0.0
        self.wall_floor = np.array(wall_load[:, 1], dtype=f64)
        self.wall_memory = wall_memory
        servo_kernel(macro, self.integral, self.servo_inv_mass, self.servo_free, self.servo_max,
                     np.ascontiguousarray(wall_load[:, 0]), self.wall_floor, wall_memory,
                     self.wall_speed)
        self.driven = driven
        return wall_memory

    def body_arrays(self, travel: np.ndarray) -> BodyArrays:
        """The bodies' arrays of the sub-steps, ``travel`` (N,) [m] the list's."""
        state = self.state
        return BodyArrays(self.inv_mass, self.masses, self.principal, self.isotropic, self.arm,
                          self.plain_bodies, state.positions, state.orientations,
                          state.velocities, state.angular_velocities, self.body_force,
                          self.body_torque, travel)

    def wall_face(self, disp_built: np.ndarray) -> WallFace:
        """The walls' face of the sub-steps (:mod:`grainlab.engine.boundaries.wall_box_face`),
        ``disp_built`` (W,) [m] their displacements when the list was built."""
        bounds, f64 = self.bounds, np.float64
        return WallFace(np.ascontiguousarray(bounds.wall_points, dtype=f64),
                        np.ascontiguousarray(bounds.wall_normals, dtype=f64), self.wall_disp,
                        self.wall_speed, disp_built, self.servo_inv_mass, self.servo_free,
                        self.servo_max, self.wall_memory, self.wall_floor, self.wall_force,
                        self.wall_stiffness, self.wall_impulse, self.macro, self.integral,
                        SUBSTEP_SERVO_FRACTION)

    def cell_face(self, solver: SoftContactStep, h_built: np.ndarray) -> CellFace:
        """The cell's face of the sub-steps (:mod:`grainlab.engine.boundaries.
        periodic_cell_face`), ``h_built`` (3, 3) [m] the cell when the list was built; that of
        a fixed cell in a wall box."""
        bounds, f64 = self.bounds, np.float64
        return CellFace(self.cell_h, h_built, self.cell_rate, self.cell_gradient,
                        self.cell_directions, self.cell_scale,
                        np.ascontiguousarray(bounds.cell_free, dtype=f64),
                        np.ascontiguousarray(bounds.cell_bounds, dtype=f64).reshape(-1, 2),
                        self.cell_stiffness, solver._filtered, self.cell_dofs, self.gradient,
                        solver.carried_gradient, self.stress_impulse, float(solver.filter_time),
                        self.wall_disp.shape[0] == 0)

    def advance(self, solver: SoftContactStep, rows, n_steps: int, h: float) -> int:
        """Up to ``n_steps`` sub-steps of ``h`` [s] on ``rows`` (0: only the loads now);
        returns those done. An overlap beyond :data:`OVERLAP_LIMIT` x the list's smallest
        length (``rows.smallest_radius``) stops the run with a diagnosis."""
        done = rows.advance(self, solver, n_steps, h)
        if self.stats[0] > OVERLAP_LIMIT * rows.smallest_radius:
            raise SimulationBlowUp(
                f"runaway overlap in the soft-contact step: {self.stats[0]:.3g} m, more than "
                f"{OVERLAP_LIMIT} x the smallest {rows.size_words} {rows.smallest_radius:.3g} "
                f"m; the contacts are too soft for the load ({solver.law.model}) or the "
                f"sub-step {h:.3g} s too long for their stiffness.")
        return int(done)

    def zigzag(self, rows) -> float:
        """:func:`~grainlab.engine.dem.soft_stability.zigzag_index` of the contacts between bodies
        closed at the end of the step."""
        state, sums = self.state, np.zeros(4)
        zigzag_sums_kernel(*rows.closed_points(), state.positions, state.velocities,
                           state.angular_velocities, self.cell_h, self.cell_rate, sums)
        return zigzag_index(sums)
