"""Convex polyhedra in the soft-contact DEM solver
(:class:`~grainlab.engine.dem.soft_contact.SoftContactStep`): a soft law on the penetration
depth at each point of the contact manifold of contact dynamics (STYLE.md 3, 10; kernels in
:mod:`grainlab.engine.dem.soft_polyhedra_kernels`).

Geometry. Each sub-step recomputes, for every pair of the neighbour list, the pair's manifold
from the current configuration with the narrow phase of contact dynamics
(:mod:`grainlab.geometry.polyhedron_contact`, :mod:`grainlab.geometry.polyhedron_manifold`):
1 to K points (K = :data:`~grainlab.geometry.polyhedron_contact.DEFAULT_MAX_POINTS`), point r
with its gap g_r [m], unit normal n_r (from i to j; a wall's normal) and position x_r [m]
(mid-point between the two surfaces). The points that penetrate, delta_r = -g_r > 0, carry the
contact.

Normal force. With the weights w_r = delta_r / sum_s delta_s, point r pushes body j along n_r
(minus on i) with

    F_r = max(0, w_r (F_n(delta_r) - c_n(delta_r) U_n,r))                          [N]

F_n and c_n those of the law (:func:`~grainlab.contact.soft_contact_law.contact_law`: k_n delta
and 2 zeta sqrt(m* k_n), or Hertz's (4/3) E* sqrt(R*) delta^(3/2) and its damping) at the
point's own depth, U_n,r the normal relative velocity there. Then

* one point (a vertex on a face, two crossing edges) has the law itself;
* a flat contact (a face on a face or on a wall) at uniform depth delta has
  sum_r F_r = F_n(delta) - c_n U_n, the law of one contact at that depth whatever the number
  of points: a face at rest on a wall sinks by the law's static overlap (m g / k_n) and lands
  with the law's restitution;
* a point entering the manifold at delta = 0 has weight 0: the force is continuous in time;
* a tilted flat contact loads its deeper points more (w_r delta_r grows as delta_r^2) and
  resists the tilt.

Rules set aside: the pair's stiffness split equally over its points (k_n / K) makes the force
jump each time a point enters or leaves; a fixed stiffness per point makes a face contact K
times stiffer than a vertex one (and the stable step sqrt(K) shorter). The price of the rule
kept: the point forces derive from no potential. None can with positive point forces, the
same total for one point and for K points at one depth, and continuity: the energy of two
points at depths (delta_1, delta_2) would have to be the same at delta_2 = 0 and at
delta_2 = delta_1, so the second point would carry nothing between. A rocking contact
therefore need not return exactly the work done on it; measured: an elastic, frictionless cube
or n_f = 30 hull landing tilted by 0.02 or 0.2 rad keeps its kinetic energy within 4e-6
(1000 sub-steps per impact).

Tangential force. One spring per pair (Mindlin's incremental law with history as for spheres,
:mod:`grainlab.contact.soft_contact_law`) at the penetration-weighted mean point
x = sum_r w_r x_r about the mean normal n = sum_r w_r n_r / |.|: turned with n and the bodies'
mean spin about it, loaded by dF_e = -k_t U_T dt with U_T the tangential relative velocity at
x, k_t and c_t those of the law at the mean depth sum delta_r^2 / sum delta_r (delta for a flat
contact), capped by Coulomb at mu sum_r F_r. It is keyed per body pair
(:func:`~grainlab.engine.step_report.contact_keys` with members 0, a wall's -1), so it is
kept across rebuilds of the list and in checkpoints, and released when no point penetrates.

Equivalent radius and mass. Hertz needs R*: each polyhedron counts as the sphere of its volume,
r = (3 V / (4 pi))^(1/3), R* = r_i r_j / (r_i + r_j) (a wall: r_j); m* = m_i m_j / (m_i + m_j)
(a wall: m_j), as for spheres. The stiffness number keeps its meaning (k_n = kappa sigma0 <d>).

Why not YADE's volume law. YADE's polyhedra (Eliáš 2014, ``PolyhedraMat``) push with
F_n = k_V V along the normal of the intersection volume V, built each step as the intersection
polyhedron (CGAL): a stiffness per volume, so a face contact is stiffer by its area and a vertex
one soft as delta^3. Here the geometry is the one of contact dynamics, exact and tested against
its slow twins, and its cost is one manifold per listed pair per sub-step (no polyhedron
clipping, no new tolerance); both solvers see the same contacts, and k_n keeps the units and
meaning it has for spheres. What is given up: the stiffness of a face contact does not grow
with its area (the grains' stiffness is the pair's k_n, as for spheres).

Time step, skin, list. The law's stable step takes the lightest mass, counting the rotational
inertia about the bounding radius (I_min / R_bound^2), and the smallest inscribed radius
(:func:`~grainlab.engine.shape_kinds.library_time_step_length`); the skin is 0.1 x the
smallest inscribed diameter. The list holds the body pairs (and polyhedron-wall pairs) whose
narrow-phase gap is within the skin at the detection, one row per pair whatever its points.

Report. One row per penetrating point: its gap, normal, position, feature ids and the pair's
type (fv, ee, fe, ff), as contact dynamics reports them; its impulse is (F_r n_r + w_r F_T) x
dt, so the rows of a pair sum to the pair's force and moment (sum_r w_r x_r x F_T = x x F_T)
and the wall reactions, the stress and the fabric read them as they read those of contact
dynamics.

Not here: rolling resistance (``rolling_friction`` must be 0; faces resist rolling) and
polyhedra mixed with spheres or aggregates in one sample (both refused with a message).

Cost: one manifold per listed pair per sub-step, about 7 us per pair for n_f = 30 (5 of them
the manifold); 100 polyhedra (n_f = 30) resting in a box, 3 listed pairs per particle: 390-520
sub-steps per second on one thread (``benchmarks/benchmark_engine_soft_polyhedra.py``;
docs/explanations/soft-dem.md).

A cube of side 1 cm at rest on a face sinks by m g / k_n, each corner carrying a quarter:

>>> from grainlab.contact.soft_contact_law import SoftContactLaw
>>> from grainlab.engine.dem.soft_contact import SoftContactStep
>>> from grainlab.geometry.polyhedron import from_vertices
>>> cube = from_vertices([[x, y, z] for x in (0, 0.01) for y in (0, 0.01) for z in (0, 0.01)])
>>> library = ShapeLibrary.from_polyhedra([cube])
>>> state = BodyState.from_library(library, [0], [[0.0, 0.0, 0.005]], density=2600.0)
>>> law = SoftContactLaw.linear(1e4, restitution=0.3, local_damping=0.3)
>>> solver = SoftContactStep(law, dt=1e-3, gravity=(0.0, 0.0, -9.81))
>>> for _ in range(300):
...     report = solver.step(state, library, walls=([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]]))
>>> weight = float(state.masses[0]) * 9.81
>>> report.n_contacts, round(float(-report.contacts.gap.mean()) * 1e4 / weight, 6)
(4, 1.0)
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.boundaries.boundary import ClosedContacts
from grainlab.engine.dem import soft_polyhedra_kernels  # noqa: F401 (registers the pass)
from grainlab.engine.dem.soft_contact_kernels import body_rows
from grainlab.engine.dem.soft_stability import (
    BLOCK,
    LAW_COLUMNS,
    damped_limit,
    polyhedron_elements_kernel,
    stable_rates_kernel,
)
from grainlab.engine.dem.substep_arrays import PolyhedronPairArrays
from grainlab.engine.dem.substep_loop import substeps
from grainlab.engine.detect.narrow_phase import Contacts
from grainlab.engine.detect.polyhedron_narrow_phase import angle_tolerances
from grainlab.engine.shape_kinds import (
    MEMBER_SPHERES,
    POLYHEDRON_FEATURES,
    family_mask,
    library_time_step_length,
)
from grainlab.engine.state import BodyState, ReadOnlyArrays, ShapeLibrary
from grainlab.engine.step_report import StepReport, contact_frames, contact_keys
from grainlab.errors import InputError
from grainlab.geometry.polyhedron_contact import ANGLE_TOLERANCE, DEFAULT_MAX_POINTS


def has_polyhedra(library: ShapeLibrary, law: SoftContactLaw) -> bool:
    """Whether the library holds polyhedra (the sub-steps of this module); refuses what the
    soft-contact solver does not run with them (module docstring)."""
    polyhedra, spheres = _families(library)
    if not polyhedra:
        return False
    if spheres:
        raise InputError("shape", "polyhedra with spheres or aggregates",
                         "one family of shapes per sample with the soft-contact solver: "
                         "polyhedra alone, or spheres and aggregates")
    if law.rolling_friction > 0.0:
        raise InputError("rolling_friction", law.rolling_friction,
                         "0 with polyhedra (their faces resist rolling)")
    return True


@lru_cache(maxsize=16)
def _families(library: ShapeLibrary) -> tuple[bool, bool]:
    """Whether a library (frozen, hashed by identity) holds polyhedra, member spheres."""
    return (bool(np.any(family_mask(library.kind, POLYHEDRON_FEATURES))),
            bool(np.any(family_mask(library.kind, MEMBER_SPHERES))))


@lru_cache(maxsize=16)
def smallest_radius(library: ShapeLibrary) -> float:
    """Half the time-step length of the library's shapes [m]
    (:func:`~grainlab.engine.shape_kinds.library_time_step_length`): the smallest member
    radius or polyhedron inradius; the length of the stable sub-step and of the skin."""
    return 0.5 * library_time_step_length(library)


def equivalent_radii(state: BodyState, library: ShapeLibrary) -> np.ndarray:
    """(N,) radius [m] of the sphere of each body's volume, (3 V / (4 pi))^(1/3)."""
    return np.cbrt(0.75 / np.pi * library.volume[state.shape_ids])


class PolyhedronRows:
    """A neighbour list of polyhedra as the kernels take it (module docstring): one row per
    body pair or polyhedron-wall pair found at the detection, its spring and its outputs."""

    size_words = "inscribed radius"
    """What :attr:`smallest_radius` [m] is, in a diagnosis."""

    def __init__(self, contacts: Contacts, images, state: BodyState, library: ShapeLibrary,
                 bounds, friction: float) -> None:
        n = state.n_bodies
        code = (contacts.body_i.astype(np.int64) + 64) * (n + 64) + contacts.body_j
        first = np.sort(np.unique(code, return_index=True)[1])
        self.pair_i = np.ascontiguousarray(contacts.body_i[first], dtype=np.int64)
        self.pair_j = np.ascontiguousarray(contacts.body_j[first], dtype=np.int64)
        self.images = np.ascontiguousarray(np.asarray(images, dtype=np.float64)
                                           .reshape(-1, 3)[first])
        p = self.pair_j.shape[0]
        inner = self.pair_i >= 0
        self.mu = np.full(p, float(friction))
        self.mu[~inner] = bounds.wall_friction[-1 - self.pair_i[~inner]]
        radii = equivalent_radii(state, library)
        self.r_eff = radii[self.pair_j].copy()
        ri = radii[self.pair_i[inner]]
        self.r_eff[inner] = ri * self.r_eff[inner] / (ri + self.r_eff[inner])
        self.smallest_radius = smallest_radius(library)
        self.wall_rows = np.flatnonzero(~inner).astype(np.int64)
        self.adj_start, self.adj_entry = body_rows(self.pair_i, self.pair_j, n)
        self.keys = contact_keys(Contacts(
            body_i=self.pair_i, body_j=self.pair_j,
            member_i=np.where(inner, 0, -1).astype(np.int64), member_j=np.zeros(p, np.int64),
            point=np.zeros((p, 3)), normal=np.zeros((p, 3)), gap=np.zeros(p)), n, library)
        self.xi = np.zeros((p, 3))
        self.roll = np.zeros((p, 3))  # no rolling resistance: kept for the springs' history
        bvs, wv, bfs, wn, wo = _world_layout(state, library)
        lib = ReadOnlyArrays(library)
        self.bodies = (np.ascontiguousarray(state.shape_ids, dtype=np.int64), lib.vertex_start,
                       lib.vertices, lib.face_start, lib.face_normals, lib.face_offsets)
        self.library = (self.bodies[0], lib.face_start, lib.face_count, lib.face_vertex_start,
                        lib.face_vertices, lib.edge_start, lib.edge_count, lib.edges,
                        lib.edge_faces, lib.vertex_start, lib.vertex_count,
                        lib.vertex_neighbour_start, lib.vertex_neighbours)
        self.world = (bvs, wv, bfs, wn, wo)
        k = DEFAULT_MAX_POINTS
        self.tolerances = (*angle_tolerances(ANGLE_TOLERANCE), k)
        self.force, self.torque_i, self.torque_j = (np.zeros((p, 3)) for _ in range(3))
        self.normal, self.point, self.rel_vel = (np.zeros((p, 3)) for _ in range(3))
        self.stiffness = np.zeros(p)
        self.n_points = np.zeros(p, dtype=np.int64)
        self.point_gap = np.zeros((p, k))
        self.point_normal, self.point_position, self.point_force, self.point_velocity = (
            np.zeros((p, k, 3)) for _ in range(4))
        self.feature_i = np.zeros((p, k), dtype=np.int64)
        self.feature_j = np.zeros((p, k), dtype=np.int64)
        self.pair_type = np.zeros(p, dtype=np.int8)
        self.travel = np.zeros(n)
        self.approach = np.zeros(1)

    def arrays(self) -> PolyhedronPairArrays:
        """The pairs' arrays of the sub-steps."""
        return PolyhedronPairArrays(
            self.pair_i, self.pair_j, self.images, self.mu, self.r_eff, self.adj_start,
            self.adj_entry, self.wall_rows, self.xi, self.force, self.torque_i, self.torque_j,
            self.normal, self.point, self.stiffness, self.rel_vel, self.approach,
            self.n_points, self.point_gap, self.point_normal, self.point_position,
            self.point_force, self.point_velocity, self.feature_i, self.feature_j,
            self.pair_type, self.bodies, self.library, self.world, self.tolerances)

    def advance(self, run, solver, n_steps: int, h: float) -> int:
        """Up to ``n_steps`` sub-steps of ``h`` [s] (0: only the loads now) for the solver's
        step ``run`` (:class:`~grainlab.engine.dem.soft_contact.SoftContactStep`'s); returns those
        done."""
        law = solver.law
        return substeps(
            n_steps, h, float(solver.skin), (law.code, law.params, 0.0), law.local_damping,
            solver.gravity, self.arrays(), run.body_arrays(self.travel),
            run.wall_face(run.wall_disp.copy()), run.cell_face(solver, run.cell_h.copy()),
            run.virial, run.stats, False)

    def damped_substep(self, run, solver, horizon: float) -> float:
        """The dashpots' bound [s] on the sub-step for these pairs, their manifolds evaluated
        now (a step of no sub-step: the loads, as the step's own start then computes them
        again), each penetrating point at its overlap after ``horizon`` [s] of approach
        (:func:`~grainlab.engine.dem.soft_stability.polyhedron_elements_kernel`)."""
        self.advance(run, solver, 0, solver.spring_substep)
        law, state = solver.law, run.state
        p, k = self.point_gap.shape
        e = p * (k + 1)
        elem_i, elem_j = np.empty(e, dtype=np.int64), np.empty(e, dtype=np.int64)
        normal, arm_i, arm_j = np.empty((e, 3)), np.empty((e, 3)), np.empty((e, 3))
        elements = np.empty((e, LAW_COLUMNS))
        pairs = polyhedron_elements_kernel(
            float(horizon), law.code, law.params, self.pair_i, self.pair_j, self.images,
            self.r_eff, self.mu, run.inv_mass, run.inv_inertia, state.positions, run.cell_h,
            self.n_points,
            self.point_gap, self.point_normal, self.point_position, self.point_velocity,
            self.point, self.normal, self.rel_vel, elem_i, elem_j, normal, arm_i, arm_j,
            elements)
        n = state.n_bodies
        a, b, relaxation = stable_rates_kernel(
            elem_i, elem_j, normal, arm_i, arm_j, elements, run.inv_mass, run.inv_inertia,
            np.empty((n, 2)), np.empty((n, 2, BLOCK)))
        return damped_limit(a, b, max(relaxation, pairs))

    def closed_points(self) -> tuple:
        """The penetrating points of the last evaluation as contacts of
        :func:`~grainlab.engine.dem.soft_stability.zigzag_sums_kernel`: (body_i, body_j, images,
        closed (all true), points, normals, relative velocities)."""
        k = self.point_gap.shape[1]
        kept = np.arange(k)[None, :] < self.n_points[:, None]
        pair = np.repeat(np.arange(self.pair_j.shape[0]), self.n_points)
        return (self.pair_i[pair], self.pair_j[pair], self.images[pair],
                np.ones(pair.shape[0], dtype=np.bool_), self.point_position[kept],
                self.point_normal[kept], self.point_velocity[kept])

    def report(self, run, macro: float) -> tuple[StepReport, ClosedContacts]:
        """The penetrating points at the end of the step, as a step report (module
        docstring): impulses = (normal force + share of the pair's tangential force) x
        ``macro`` [s]; and as the boundary reads them, with those forces (C, 3) [N] in the
        world frame."""
        k = self.point_gap.shape[1]
        kept = np.arange(k)[None, :] < self.n_points[:, None]
        pair = np.repeat(np.arange(self.pair_j.shape[0]), self.n_points)
        normal = self.point_normal[kept]
        contacts = Contacts(
            body_i=self.pair_i[pair], body_j=self.pair_j[pair],
            member_i=self.feature_i[kept], member_j=self.feature_j[kept],
            point=self.point_position[kept], normal=normal, gap=self.point_gap[kept],
            contact_type=self.pair_type[pair].astype(np.int8))
        frames = contact_frames(normal)
        impulses = np.einsum("cij,cj->ci", frames, self.point_force[kept]) * macro
        relative = np.einsum("cij,cj->ci", frames, self.point_velocity[kept])
        report = StepReport(
            n_contacts=contacts.n_contacts, iterations=0, converged=True, change=0.0,
            residual=0.0, max_overlap=float(run.stats[0]), contacts=contacts, frames=frames,
            impulses=impulses, relative_velocity=relative, images=self.images[pair],
            explicit=True)
        return report, ClosedContacts(report.contacts, report.image_vectors, report.impulses,
                                      self.point_force[kept])


def _world_layout(state: BodyState, library: ShapeLibrary) -> tuple:
    """Rows of each body in the world-frame arrays of its polyhedron (body_vertex_start
    (N + 1,), world_vertices (V_w, 3), body_face_start (N + 1,), world_normals (F_w, 3),
    world_offsets (F_w,)), as :func:`~grainlab.engine.detect.polyhedron_narrow_phase.
    world_polyhedra` lays them out; the sub-steps fill them."""
    ids = state.shape_ids
    body_vertex_start = np.zeros(state.n_bodies + 1, dtype=np.int64)
    np.cumsum(library.vertex_count[ids], out=body_vertex_start[1:])
    body_face_start = np.zeros(state.n_bodies + 1, dtype=np.int64)
    np.cumsum(library.face_count[ids], out=body_face_start[1:])
    n_v, n_f = int(body_vertex_start[-1]), int(body_face_start[-1])
    return (body_vertex_start, np.zeros((n_v, 3)), body_face_start, np.zeros((n_f, 3)),
            np.zeros(n_f))
