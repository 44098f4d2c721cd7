"""Micro-elements of a simulated packing, taken with the simulation's contact forces.

A snapshot of a discrete run (:class:`~grainlab.analysis.ContactNetwork`, 2D or 3D, wall box or
periodic cell) gives one micro-element per particle that carries a contact (seed 001 §2.2:
the particle and the neighbours it touches). Each interaction (i, j) with branch l (from i to
j) and resultant force f (i on j) gives particle i the contact (+l, +f) and particle j the
contact (-l, -f): the model's convention is "the force the centre exerts on the neighbour"
along "the branch from the centre to the neighbour", so f (x) l is the same dyad in both
micro-elements. The forces become the model's initial state
(:func:`spring_state_from_forces`): no re-consolidation from zero force, and the model's
stress at the start of a load path is the snapshot's contact-force stress

    sigma = (1/V) sum_c f^c (x) l^c      (seed 002 eq. 3; seed 001 eqs. 2.16, 2.20)

to round-off, because sum_n V^n = V and every contact is counted once in each of its two
micro-elements (eq. 2.16's factor 1/2). The force is split along the model's normal
n = l/|l| (spheres and discs: the contact normal) into f_n = f . n and f_r = f - f_n n, so
the split loses nothing.

Periodic-image contacts (``periodic``). In a periodic cell an interaction may reach a
neighbour through the cell's image: the snapshot's branch l is then x_j + h m - x_i, not
x_j - x_i. ``"keep"`` (default) keeps it with its branch through the image: the periodic
packing is then complete (every particle has all its contacts) and its stress is that of the
whole cell. ``"drop"`` leaves it out, as a model built from the particles' stored positions
alone would: the particles near the cell's faces lose coordination and the stress falls by
the dropped contacts' share (a diagnostic; it is not a consistent specimen).

Wall contacts (``walls``). Snapshots record particle-particle interactions only; a particle
pressed by a wall of the box is therefore out of balance by the wall's force. ``"drop"``
(default) leaves walls out: the model is the assembly of grains, its stress
(1/V) sum over particle contacts, which in a box is lower than the stress on the walls by the
boundary layer's share (in a periodic cell there is no wall and nothing is dropped).
``"balance"`` gives each particle the contacts with the walls that balance it. The box's
walls are planes normal to the coordinate axes (the engine's wall box): for every axis a on
which the particle contacts leave a force r_ia on particle i larger than ``wall_threshold``
times the mean interaction force, the particle presses a wall of normal e_a with the force
r_ia e_a (it exerts +r_ia e_a, the wall pushes back with -r_ia e_a). The contact's branch
vector is L = 2 R_i sign(r_ia) e_a, to the particle's mirror image through the wall, so that
its share of the stress (1/2V) f (x) L = (1/V) |r_ia| R_i e_a (x) e_a is the wall contact's
term of the Love-Weber sum over particles, and the model's stress is the stress on the box's
walls. The fixed body moves with the overall strain like every neighbour; along L the
mirror image approaches twice as fast as the plane would (a stated simplification of the
wall contact's kinematics); wall friction, if any, is not separated from the other walls'
forces. Interior particles of a quasi-static sample are balanced far better than the
threshold.

Particles of several contact points per pair (polyhedra) keep the pair's resultant force;
the model treats every particle as a sphere (disc) of the same volume.
"""

from __future__ import annotations

import numpy as np

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.contact.spring_contact import SpringContactLaw, SpringState
from grainlab.errors import InputError
from grainlab.micromech.micro_element.structure import MicroElementStructure
from grainlab.micromech.micro_element.structures import _assemble, radius_from_volume

PERIODIC_CONTACTS = ("keep", "drop")
"""Choices for the periodic-image contacts of a snapshot (module docstring)."""
WALL_CONTACTS = ("drop", "balance")
"""Choices for the wall contacts of a snapshot (module docstring)."""
VOLUME_SHARES = ("particle", "uniform")
"""V^n proportional to the particle volume, or V/E; either way sum V^n = V."""
DEFAULT_WALL_THRESHOLD = 0.05
"""Unbalanced force, relative to the mean interaction force, above which ``walls="balance"``
gives a particle a contact with a fixed body [-]. Interior particles of a quasi-static
sample are balanced to far better than this; particles against a wall carry of the order of
one contact force from it."""
IMAGE_FRACTION = 0.5
"""A pair is a periodic-image contact when its branch differs from x_j - x_i by more than
this fraction of the branch's length [-] (an image shift is a whole cell vector)."""


def periodic_image_pairs(network: ContactNetwork) -> np.ndarray:
    """(P,) True where an interaction reaches its second particle through a periodic image:
    |l - (x_j - x_i)| > ``IMAGE_FRACTION`` |l|."""
    pairs = network.pair_particles
    direct = network.positions[pairs[:, 1]] - network.positions[pairs[:, 0]]
    gap = np.linalg.norm(network.pair_branches - direct, axis=1)
    return gap > IMAGE_FRACTION * np.linalg.norm(network.pair_branches, axis=1)


def unbalanced_forces(network: ContactNetwork, selected: np.ndarray) -> np.ndarray:
    """(N, d) sum of the forces the ``selected`` interactions exert on each particle [N]
    (the force a wall must exert, with the opposite sign, for the particle to balance)."""
    pairs, forces = network.pair_particles[selected], network.pair_forces[selected]
    n, d = network.n_particles, network.dimension
    total = np.zeros((n, d))
    for axis in range(d):
        total[:, axis] = (np.bincount(pairs[:, 1], forces[:, axis], minlength=n)
                          - np.bincount(pairs[:, 0], forces[:, axis], minlength=n))
    return total


def _choice(field: str, value: str, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise InputError(field, value, " or ".join(repr(a) for a in allowed))
    return value


def _wall_contacts(network: ContactNetwork, selected: np.ndarray, radii: np.ndarray,
                   threshold: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contacts with the box's walls (module docstring, ``walls="balance"``): for every
    particle i and axis a where the particle contacts leave |r_ia| above ``threshold`` times
    the mean interaction force, the owner i, the force r_ia e_a it exerts on the wall and the
    branch 2 R_i sign(r_ia) e_a to its mirror image."""
    residual = unbalanced_forces(network, selected)
    mean_force = float(np.mean(np.linalg.norm(network.pair_forces[selected], axis=1)))
    owners, axes = np.nonzero(np.abs(residual) > threshold * mean_force)
    unit = np.eye(network.dimension)[axes]
    # the force on i from its particle contacts is r_i: the wall pushes with -r_ia e_a, so the
    # particle exerts +r_ia e_a on the wall, which lies on the side sign(r_ia) e_a
    value = residual[owners, axes]
    return owners, value[:, None] * unit, 2.0 * radii[owners, None] * np.sign(value)[:, None] \
        * unit


def micro_elements_from_snapshot(
    network: ContactNetwork,
    periodic: str = "keep",
    walls: str = "drop",
    volumes: str = "particle",
    wall_threshold: float = DEFAULT_WALL_THRESHOLD,
) -> MicroElementStructure:
    """One micro-element per particle of a snapshot, with the snapshot's contact forces as
    ``initial_forces`` (module docstring).

    Parameters
    ----------
    network:
        The snapshot (2D or 3D; loaded interactions).
    periodic:
        ``"keep"`` (default) or ``"drop"`` the interactions through a periodic image.
    walls:
        ``"drop"`` (default) or ``"balance"``: contacts with a fixed body carrying each
        particle's unbalanced force.
    volumes:
        ``"particle"`` (default): V^n proportional to the particle volume; ``"uniform"``:
        V/E. The V^n add up to the sample volume ``network.volume`` either way.
    wall_threshold:
        Relative unbalanced force that makes a wall contact (``walls="balance"``) [-].

    Raises
    ------
    InputError
        An unknown option, or no interaction left.
    """
    if not isinstance(network, ContactNetwork):
        raise InputError("network", type(network).__name__, "a ContactNetwork")
    _choice("periodic", periodic, PERIODIC_CONTACTS)
    _choice("walls", walls, WALL_CONTACTS)
    _choice("volumes", volumes, VOLUME_SHARES)
    if not (np.isfinite(wall_threshold) and wall_threshold > 0.0):
        raise InputError("wall_threshold", wall_threshold, "a positive number (relative force)")
    images = periodic_image_pairs(network)
    selected = network.active_pairs() & (~images if periodic == "drop" else True)
    if not np.any(selected):
        raise InputError("network", f"{network.n_pairs} interactions, none kept "
                         f"(periodic={periodic!r})", "a snapshot with loaded interactions")
    d = network.dimension
    pairs = network.pair_particles[selected]
    branch, force = network.pair_branches[selected], network.pair_forces[selected]
    radii = radius_from_volume(network.volumes, d)
    owners = np.concatenate([pairs[:, 0], pairs[:, 1]])
    others_radii = radii[np.concatenate([pairs[:, 1], pairs[:, 0]])]
    branches, forces = np.concatenate([branch, -branch]), np.concatenate([force, -force])
    n_wall = 0
    if walls == "balance":
        wall_owners, wall_forces, wall_branches = _wall_contacts(network, selected, radii,
                                                                 wall_threshold)
        n_wall = int(wall_owners.size)
        owners = np.concatenate([owners, wall_owners])
        others_radii = np.concatenate([others_radii, radii[wall_owners]])  # the mirror image
        branches = np.concatenate([branches, wall_branches])
        forces = np.concatenate([forces, wall_forces])
    particles, padded, mask, centre, neighbour = _assemble(
        owners, np.concatenate([branches, forces], axis=1), others_radii, radii)
    padded_branches, padded_forces = padded[..., :d], padded[..., d:]
    share = network.volumes[particles] if volumes == "particle" else np.ones(particles.size)
    element_volumes = share * network.volume / share.sum()
    return MicroElementStructure(
        padded_branches, mask, element_volumes, centre, neighbour,
        name="micro-elements of a simulated packing",
        description={
            "generator": "micro_elements_from_snapshot", "periodic": periodic, "walls": walls,
            "volumes": volumes, "wall_threshold": float(wall_threshold),
            "n_interactions": int(selected.sum()),
            "n_periodic_image_interactions": int(np.count_nonzero(images & selected)),
            "n_periodic_dropped": int(np.count_nonzero(images & ~selected)),
            "n_wall_contacts": n_wall, "particles": particles.tolist(),
            "n_rattlers": int(network.n_particles - particles.size),
            "snapshot_state": {k: v for k, v in network.state.items()
                               if isinstance(v, (int, float, str, bool))},
        },
        initial_forces=padded_forces,
    )


def spring_state_from_forces(law: SpringContactLaw, forces: np.ndarray, branches: np.ndarray,
                             mask: np.ndarray, radius: np.ndarray) -> SpringState:
    """The contact state that carries the force vectors ``forces`` (E, M, d) [N] (the centre
    on neighbour m) on the branches (E, M, d) [m]: f_n = f . n and f_r = f - f_n n with
    n = L/|L|, the normal approach that gives f_n under ``law`` (k_n delta_n = f_n for linear
    springs; Hertz's inverse, with the equivalent radius ``radius`` (E, M) [m]), sliding
    where |f_r| >= mu f_n, bonded if the law is cemented.

    Raises
    ------
    InputError
        A contact in tension (f_n <= 0) where ``mask`` is True.
    """
    forces = np.where(mask[..., None], np.asarray(forces, dtype=float), 0.0)
    lengths = np.linalg.norm(branches, axis=-1, keepdims=True)
    normals = np.divide(branches, lengths, out=np.zeros_like(branches), where=lengths > 0)
    fn = np.einsum("emi,emi->em", forces, normals)
    if np.any(mask & ~(fn > 0.0)):
        bad = tuple(int(k) for k in np.argwhere(mask & ~(fn > 0.0))[0])
        raise InputError(f"initial_forces[{bad[0]}, {bad[1]}]", float(fn[bad]),
                         "a compressive normal force f . L/|L| > 0 (contacts in tension "
                         "cannot start a spring model)")
    fn = np.where(mask, fn, 0.0)
    shear = np.where(mask[..., None], forces - fn[..., None] * normals, 0.0)
    approach = np.where(mask, law.approach_of_normal_force(fn, radius), 0.0)
    sliding = mask & (np.linalg.norm(shear, axis=-1) >= law.friction_coefficient * fn)
    return SpringState(approach, fn, shear, sliding, np.full(mask.shape, law.cemented))
