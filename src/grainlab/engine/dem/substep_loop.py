"""The one sub-step loop of the explicit soft-contact DEM (Numba; STYLE.md 2, 8): velocity
Verlet on any contact list, given the list's force pass and the boundary's faces.

A sub-step of ``dt`` [s]: half kick and drift of the bodies
(:mod:`grainlab.engine.dem.body_pass`), the boundary moves
(:func:`~grainlab.engine.boundaries.wall_box_face.walls_move`,
:func:`~grainlab.engine.boundaries.periodic_cell_face.cell_move`), the list's force pass
(:func:`force_pass`), the boundary settles (the walls' servos and loads,
:func:`~grainlab.engine.boundaries.wall_box_face.walls_settle`; the cell's servo,
:func:`~grainlab.engine.boundaries.periodic_cell_face.cell_settle`), and the bodies gather the
list's loads and take the second half kick. The loop holds no contact law, no geometry and no
boundary code.

The force pass. Each kind of contact list is a NamedTuple of arrays
(:class:`~grainlab.engine.dem.substep_arrays.SphereRowArrays`: member spheres, one row per
member pair; :class:`~grainlab.engine.dem.substep_arrays.PolyhedronPairArrays`: polyhedra, one
row per body pair and its manifold) and registers its compiled pass with
:func:`register_force_pass`. A pass ``(parallel, step, record, law, rows, bodies, walls, cell,
virial, stats)`` writes, for each row k, the force on body j ``rows.force[k]`` [N] (minus on
body i), the moments ``rows.torque_i[k]``, ``rows.torque_j[k]`` [N m], its normal stiffness,
normal and contact point (the cell's servo reads them), the walls' loads into the wall face,
the stress the cell's servo reads as ``virial`` (3, 3) [N m], and the largest overlap met into
``stats[0]`` [m]; ``step`` [s] is the time since the last evaluation (0: the force of the
current springs, nothing carried forward), ``record`` whether the step report reads this
evaluation, ``law`` the soft-contact law (code, parameters (2, P), rolling coefficient) of
:mod:`grainlab.contact.soft_contact_law`. The pass is picked by the type of the list when the
loop is compiled (an ``overload``), so each list compiles its own loop, cached on disk.

Rows as the loop reads them: ``body_i`` (C,) (-1 - w for wall w), ``body_j``, ``images``
(C, 3), the CSR list of each body's rows ``adj_start``, ``adj_entry``
(:func:`~grainlab.engine.dem.soft_contact_kernels.body_rows`), the outputs above, and
``approach`` (1,) [m], the early stop's bound carried from call to call while the list lives.
"""

from __future__ import annotations

from collections.abc import Callable

from numba import njit
from numba.extending import overload

from grainlab.engine.boundaries.periodic_cell_face import (
    cell_move,
    cell_settle,
    cell_shift,
    cell_start,
    centre_of_mass,
    gradient_changed,
    take_up,
)
from grainlab.engine.boundaries.wall_box_face import walls_move, walls_moved, walls_settle
from grainlab.engine.dem.body_pass import _body_side, gather_kernel

FORCE_PASSES: dict[type, Callable] = {}
"""The compiled force pass of each kind of contact list, by its NamedTuple type."""
ALLOCATING: set[type] = set()
"""The kinds of contact list whose force pass allocates (Numba's runtime)."""


def register_force_pass(rows_type: type, allocates: bool = False) -> Callable:
    """Decorator: the compiled function it decorates is the force pass of the contact lists
    of type ``rows_type`` (module docstring); ``allocates``: whether it makes arrays (its loop
    is then compiled with Numba's runtime, :func:`substeps`)."""
    def register(function: Callable) -> Callable:
        FORCE_PASSES[rows_type] = function
        if allocates:
            ALLOCATING.add(rows_type)
        return function
    return register


def force_pass(parallel, step, record, law, rows, bodies, walls, cell, virial, stats):
    """The force pass of the list ``rows`` (module docstring); compiled code only."""
    raise TypeError("force_pass is called from compiled code (substeps_kernel)")


@overload(force_pass, jit_options={"cache": True})
def _force_pass_of(parallel, step, record, law, rows, bodies, walls, cell, virial, stats):
    compute = FORCE_PASSES.get(getattr(rows, "instance_class", None))
    if compute is None:  # no pass for this type: Numba's typing error names it
        return None

    def impl(parallel, step, record, law, rows, bodies, walls, cell, virial, stats):
        compute(parallel, step, record, law, rows, bodies, walls, cell, virial, stats)
    return impl


def substeps(n_steps, dt, skin, law, local_damping, gravity, rows, bodies, walls, cell, virial,
             stats, parallel) -> int:
    """:func:`substeps_kernel` for the list ``rows``, compiled without Numba's reference
    counts on the arrays (~5 % of a sub-step) unless its force pass allocates
    (:data:`ALLOCATING`: the polyhedra's manifolds)."""
    loop = substeps_counted if type(rows) in ALLOCATING else substeps_kernel
    return loop(n_steps, dt, skin, law, local_damping, gravity, rows, bodies, walls, cell,
                virial, stats, parallel)


def _substeps(n_steps, dt, skin, law, local_damping, gravity, rows, bodies, walls, cell,
              virial, stats, parallel):
    """Up to ``n_steps`` velocity-Verlet sub-steps of ``dt`` [s] on the current list ``rows``
    (module docstring) for the ``bodies``
    (:class:`~grainlab.engine.dem.substep_arrays.BodyArrays`), the boundary given by its faces
    ``walls`` (:class:`~grainlab.engine.boundaries.wall_box_face.WallFace`) and ``cell``
    (:class:`~grainlab.engine.boundaries.periodic_cell_face.CellFace`), the contacts' ``law``
    (code, parameters, rolling coefficient), ``local_damping`` alpha [-] and ``gravity`` (3,)
    [m/s^2]; ``n_steps`` = 0: only the loads now. Between the forces and the second half kick
    the boundary's faces settle (the walls' servos and loads summed into their impulses; the
    cell's servo sets L from the contacts' stress ``virial`` (3, 3) [N m], and the stress
    summed over time), and the bodies take up a change of L with the kick. Stops early, after a
    complete sub-step, when two points may have approached by more than ``skin`` [m] since the
    list was built (2 max travel + the walls' and the cell's own motion, with the next
    sub-step's increment taken as the last one's), so that no contact is missed;
    ``bodies.travel`` (N,) [m] and ``rows.approach`` (1,) [m] (that bound after the last
    sub-step) carry over from call to call while the list lives. Returns the sub-steps done;
    ``stats[0]`` becomes the largest overlap [m] met in them. With ``parallel`` the bodies
    (and the rows, where the list's pass can) are shared out over the threads (the same
    results: :func:`~grainlab.engine.dem.body_pass.bodies_parallel`)."""
    half = 0.5 * dt
    met = stats[0]  # the overlaps met in the sub-steps, not those at the start
    # flags as typed booleans, not literals: a literal True or False at one call and a flag
    # at another would compile the callee twice (~17 s of a cold compilation)
    yes = n_steps >= 0  # True
    no = not yes
    force_pass(parallel, 0.0, yes, law, rows, bodies, walls, cell, virial, stats)
    stats[0] = met
    gather_kernel(rows.adj_start, rows.adj_entry, rows.force, rows.torque_i, rows.torque_j,
                  bodies.masses, gravity, bodies.force, bodies.torque)
    cell_start(cell, virial, rows.body_i, rows.body_j, rows.images, rows.stiffness,
               rows.normal, bodies.masses, bodies.positions, bodies.velocities)
    done = 0
    previous = rows.approach[0]
    # the first sub-step's half kick and drift; each later one's come with the end of the
    # sub-step before, in one pass over the bodies (one parallel loop less per sub-step)
    if n_steps > 0:
        _body_side(parallel, no, no, yes, half, dt, rows, bodies, gravity, local_damping, cell,
                   0.0, 0.0, 0.0)
    for _ in range(n_steps):
        walls_move(walls, dt)
        cell_move(cell, dt)
        last = _ == n_steps - 1  # the report reads its normals, points and velocities
        force_pass(parallel, dt, last, law, rows, bodies, walls, cell, virial, stats)
        walls_settle(walls, dt)
        cell_settle(cell, dt, virial)
        done += 1
        reach = 0.0
        for b in range(bodies.travel.shape[0]):
            reach = max(reach, bodies.travel[b])
        reach *= 2.0
        total = reach + walls_moved(walls) + cell_shift(cell)
        rows.approach[0] = total
        # the next sub-step might go past the skin: stop after this one
        stop = 2.0 * total - previous > skin or last
        previous = total
        change = cell.periodic and gradient_changed(cell.gradient, cell.carried)
        cx = cy = cz = 0.0
        if change:
            cx, cy, cz = centre_of_mass(bodies.masses, bodies.positions)
        _body_side(parallel, yes, change, not stop, half, dt, rows, bodies, gravity,
                   local_damping, cell, cx, cy, cz)
        if cell.periodic:  # hdot = L h follows the cell
            take_up(change, cell.gradient, cell.carried, cell.h, cell.rate)
        if stop:
            break
    return done


substeps_kernel = njit(cache=True, _nrt=False)(_substeps)
"""The sub-step loop compiled without Numba's runtime (lists whose pass allocates nothing)."""
substeps_counted = njit(cache=True)(_substeps)
"""The sub-step loop compiled with Numba's runtime (lists whose pass allocates)."""
