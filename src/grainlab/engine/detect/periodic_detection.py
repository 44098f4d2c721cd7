"""Contact detection in a periodic, deformable, triclinic cell, for every shape of the engine
(spheres, aggregates, polyhedra), by a ghost layer around the cell and the engine's own
broad and narrow phases, unchanged (STYLE.md 7, 8, 12).

Conventions
-----------
The cell is a :class:`~grainlab.geometry.triclinic_cell.TriclinicCell` h (columns c1, c2, c3
[m]). Body positions x_i [m] are UNWRAPPED: continuous trajectories that may lie outside the
cell, several cells away. A contact k between bodies i and j carries an integer image vector
n_k: it is the contact between body i at x_i and the image of body j at x_j + h n_k, in
unwrapped coordinates. Its normal points from i to that image of j, its point lies near
x_i (on the unwrapped side of body i), its gap is the narrow phase's.

Algorithm
---------
1. **Wrap.** w_i = floor(h^-1 x_i) (int, per axis), x~_i = x_i - h w_i: every body in the cell
   (fractional coordinates s~_i in [0, 1)).
2. **Ghosts.** With the cut-off R_cut = 2 r_max + alert (r_max the largest bounding radius) and
   delta_a = R_cut / w_a (w_a the cell's widths: a displacement of length R_cut moves a
   fractional coordinate by at most delta_a), every body j gets a ghost at x~_j + h m for each
   m in {-1, 0, 1}^3 \\ {0} with s~_j + m in [-delta_a, 1 + delta_a] on every axis a (a
   1e-9 relative margin against round-off). A ghost carries its body's shape and orientation.
   Every image of a body within R_cut of some wrapped body is a primary or a ghost.
3. **Broad phase** (:class:`~grainlab.engine.detect.broad_phase.CellListBroadPhase`, non-periodic)
   over primaries (rows 0 .. N-1) and ghosts (rows N ..) in the bounding box of all of them,
   padded by r_max + alert, as :meth:`~grainlab.engine.nscd.contact_dynamics.ContactDynamicsStep.
   step` does. Kept: pairs (a, b) with a primary and b a primary (a < b) or a ghost whose
   body is > a. This keeps each physical pair once: (ghost of i with image m, primary j) is
   the pair (primary i, ghost of j with image -m), which exists too (the ghost slab is
   symmetric: if x~_j + h m is within R_cut of x~_i, x~_i - h m is within R_cut of x~_j);
   ghost-ghost pairs are copies of primary pairs; a body never meets its own ghost.
4. **Narrow phase** (:class:`~grainlab.engine.detect.narrow_phase.NarrowPhase`, no walls) on
   the kept pairs of the extended state; rows then map back: body_j of a ghost row is its body, the
   image vector is n = m + w_i - w_j (m = 0 for two primaries), and the point moves by
   + h w_i to lie near the unwrapped x_i (gap and normal do not change under a translation).

So every row has body_i < body_j; body_i is the primary a of its kept pair, body_j the other
body. Rows come in the narrow phase's order (module docstring there: sphere-based rows of the
pairs in broad-phase order, then the rows of pairs with a polyhedron), which does not depend
on the number of threads.

Asked for ``sphere_rows``, plain spheres (every shape one sphere at its centre of mass) take
a faster road to the same contacts, one compiled cell list without ghosts
(:mod:`grainlab.engine.detect.periodic_spheres`); their rows then come by body_i, then body_j.

**Restriction:** every width of the cell must be at least 3 R_cut (else
:class:`~grainlab.errors.InputError` naming "periodic cell width"). Then two images of a body
are more than 2 R_cut apart, so no pair touches through two images at once, no body touches
its own image, and only the images {-1, 0, 1}^3 of wrapped bodies can be within reach. A
cell sheared far loses width: re-map it with :meth:`TriclinicCell.reduced` first.

**Planar** (a 2D sample of discs, :mod:`grainlab.engine.planar`): the cell is periodic in x
and y only. Its third column is (0, 0, t), t the discs' thickness, which may be thinner than
a disc: no body is wrapped along z, no ghost has an image along z (m_z = 0), and only the
widths across the x and y faces are held to 3 R_cut. The plain spheres' road is not taken.

:func:`periodic_contacts_slow` is the slow twin: every pair, 125 images each, two bodies at a
time.

>>> import numpy as np
>>> from grainlab.engine.state import BodyState, ShapeLibrary
>>> from grainlab.geometry.triclinic_cell import TriclinicCell
>>> library = ShapeLibrary.from_spheres([0.5])
>>> state = BodyState.from_library(library, [0, 0], [[0.2, 2, 2], [11.25, 2, 2]], 1000.0)
>>> found = PeriodicDetection(alert=0.1).detect(state, library, TriclinicCell.cube(4.0))
>>> found.images.tolist(), round(float(found.contacts.gap[0]), 12)
([[-3, 0, 0]], -0.05)
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from grainlab.engine.detect.broad_phase import CellListBroadPhase
from grainlab.engine.detect.narrow_phase import Contacts, NarrowPhase
from grainlab.engine.detect.periodic_spheres import (
    bins_per_axis,
    periodic_sphere_contacts,
    plain_spheres,
)
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import CellTooThin, InputError
from grainlab.geometry.polyhedron_contact import ANGLE_TOLERANCE, DEFAULT_MAX_POINTS
from grainlab.geometry.triclinic_cell import TriclinicCell

GHOST_IMAGES = np.array([m for m in itertools.product((-1, 0, 1), repeat=3) if any(m)],
                        dtype=np.int64)
"""The 26 image vectors m in {-1, 0, 1}^3 \\ {0} a ghost may have, (26, 3) int64."""

_MARGIN = 1e-9  # relative widening of the ghost slab against round-off


@dataclass(frozen=True, eq=False)
class PeriodicContacts:
    """Contacts in a periodic cell (module docstring).

    Attributes
    ----------
    contacts:
        The contact points, :class:`~grainlab.engine.detect.narrow_phase.Contacts`: body_i < body_j
        on every row, normal from i to the image of j, point near the unwrapped x_i [m].
    images:
        (C, 3) int64: row k is the contact between body_i at x_i and the image of body_j at
        x_j + h @ images[k] (unwrapped positions).
    """

    contacts: Contacts
    images: np.ndarray

    @property
    def n_contacts(self) -> int:
        """Number of contact points C."""
        return self.contacts.n_contacts


def _empty_contacts() -> PeriodicContacts:
    ints = np.zeros(0, dtype=np.int64)
    contacts = Contacts(ints, ints.copy(), ints.copy(), ints.copy(), np.zeros((0, 3)),
                        np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int8))
    return PeriodicContacts(contacts, np.zeros((0, 3), dtype=np.int64))


def _checked(state, library, cell) -> None:
    if not isinstance(state, BodyState):
        raise InputError("state", type(state).__name__, "a BodyState")
    if not isinstance(library, ShapeLibrary):
        raise InputError("library", type(library).__name__, "a ShapeLibrary")
    if not isinstance(cell, TriclinicCell):
        raise InputError("cell", type(cell).__name__, "a TriclinicCell")


def checked_cutoff(cell: TriclinicCell, bounding_radii: np.ndarray, alert: float,
                   planar: bool = False) -> float:
    """R_cut = 2 r_max + alert [m], or :class:`~grainlab.errors.CellTooThin` (an
    :class:`InputError` naming "periodic cell width") when a width of ``cell`` (of a
    ``planar`` cell: across its x and y faces) is below 3 R_cut (module docstring)."""
    r_max = float(np.max(bounding_radii)) if bounding_radii.size else 0.0
    cutoff = 2.0 * r_max + alert
    widths = cell.widths[:2] if planar else cell.widths
    if widths.min() < 3.0 * cutoff:
        axis = int(np.argmin(widths))
        raise CellTooThin(
            "periodic cell width", float(widths[axis]),
            f"at least 3 (2 r_max + alert) = {3.0 * cutoff:g} m across every pair of faces "
            f"(axis {axis}; r_max = {r_max:g} m, alert = {alert:g} m), so that no pair "
            "touches through two images; enlarge the cell or re-map a sheared one "
            "(TriclinicCell.reduced)")
    return cutoff


def ghost_layer(cell: TriclinicCell, fractional, cutoff: float, planar: bool = False
                ) -> tuple[np.ndarray, np.ndarray]:
    """Ghosts of bodies at wrapped ``fractional`` coordinates (N, 3) (in [0, 1)): every image
    m in :data:`GHOST_IMAGES` with s + m in [-delta_a, 1 + delta_a] on every axis,
    delta_a = ``cutoff`` / w_a (module docstring, step 2); ``planar``: m_z = 0 only.

    Returns ``(body, image)``: the body (G,) int64 and image vector (G, 3) int64 of each
    ghost, by body then image.
    """
    s = np.asarray(fractional, dtype=np.float64).reshape(-1, 3)
    delta = cutoff / cell.widths * (1.0 + _MARGIN)
    # allowed[i, a, m + 1]: image m on axis a keeps body i within the slab
    allowed = np.stack([s >= 1.0 - delta, np.ones_like(s, dtype=bool), s <= delta], axis=2)
    keep = (allowed[:, 0, GHOST_IMAGES[:, 0] + 1] & allowed[:, 1, GHOST_IMAGES[:, 1] + 1]
            & allowed[:, 2, GHOST_IMAGES[:, 2] + 1])
    if planar:
        keep &= GHOST_IMAGES[None, :, 2] == 0
    body, which = np.nonzero(keep)
    return body.astype(np.int64), GHOST_IMAGES[which]


class PeriodicDetection:
    """Contacts of bodies in a periodic triclinic cell (module docstring).

    Parameters
    ----------
    alert:
        Alert distance [m] >= 0: pairs with gap <= alert are contacts (as
        :class:`~grainlab.engine.detect.narrow_phase.NarrowPhase`).
    capacity:
        Initial rows of the broad- and narrow-phase buffers (>= 1); they grow when needed.
    angle_tolerance, max_points:
        Polyhedron contact classification angle [rad] and most points per manifold, as
        :class:`~grainlab.engine.detect.narrow_phase.NarrowPhase`.

    The same object is meant to be called every step: its broad and narrow phases
    (:attr:`broad_phase`, :attr:`narrow_phase`) keep their buffers.
    """

    def __init__(self, alert: float, capacity: int = 1024,
                 angle_tolerance: float = ANGLE_TOLERANCE,
                 max_points: int = DEFAULT_MAX_POINTS, planar: bool = False) -> None:
        self.planar = bool(planar)
        self.narrow_phase = NarrowPhase(alert, capacity=capacity,
                                        angle_tolerance=angle_tolerance,
                                        max_points=max_points)
        self.alert = self.narrow_phase.alert
        self.broad_phase = CellListBroadPhase(alert=self.alert, capacity=capacity)
        self.sphere_scratch: dict = {}
        """The plain spheres' cell list's buffers (:func:`~grainlab.engine.detect.periodic_spheres.
        periodic_sphere_contacts`), kept from call to call."""

    def detect(self, state: BodyState, library: ShapeLibrary, cell: TriclinicCell,
               sphere_rows: bool = False) -> PeriodicContacts:
        """Contacts of the bodies of ``state`` (unwrapped positions) in the periodic ``cell``,
        each with its image vector (module docstring; ``sphere_rows``: plain spheres by the
        compiled cell list, rows by body_i then body_j)."""
        _checked(state, library, cell)
        n_bodies = state.n_bodies
        bounding = library.bounding_radius[state.shape_ids]
        cutoff = checked_cutoff(cell, bounding, self.alert, self.planar)
        if n_bodies == 0:
            return _empty_contacts()
        if sphere_rows and plain_spheres(library) and not self.planar:  # one cell list
            bins = bins_per_axis(cell.widths, cutoff, n_bodies)
            contacts, images = periodic_sphere_contacts(
                state.positions, bounding, cell.matrix, cell.inverse, bins,
                self.alert, self.sphere_scratch)
            return PeriodicContacts(contacts, images)
        h = cell.matrix
        s = cell.fractional(state.positions)
        counts = np.floor(s).astype(np.int64)
        if self.planar:
            counts[:, 2] = 0
        wrapped = state.positions - counts @ h.T
        ghost_body, ghost_image = ghost_layer(cell, s - counts, cutoff, self.planar)
        source = np.concatenate([np.arange(n_bodies, dtype=np.int64), ghost_body])
        image_of = np.concatenate([np.zeros((n_bodies, 3), dtype=np.int64), ghost_image])
        positions = np.concatenate([wrapped, wrapped[ghost_body] + ghost_image @ h.T])
        extended = replace(
            state, positions=positions, orientations=state.orientations[source],
            velocities=state.velocities[source],
            angular_velocities=state.angular_velocities[source],
            masses=state.masses[source], inertias=state.inertias[source],
            shape_ids=state.shape_ids[source],
        )
        radii = bounding[source]
        pad = float(bounding.max()) + self.alert + 1e-9
        lo, hi = positions.min(axis=0) - pad, positions.max(axis=0) + pad
        pairs = self.broad_phase.find_pairs(positions, radii, lo, hi)
        a, b = pairs[:, 0], pairs[:, 1]
        kept = pairs[(a < n_bodies) & ((b < n_bodies) | (source[b] > a))]
        found = self.narrow_phase.detect(extended, library, kept)
        body_i = found.body_i
        body_j = source[found.body_j]
        images = image_of[found.body_j] + counts[body_i] - counts[body_j]
        contacts = Contacts(
            body_i=body_i, body_j=body_j, member_i=found.member_i, member_j=found.member_j,
            point=found.point + counts[body_i] @ h.T, normal=found.normal, gap=found.gap,
            contact_type=found.contact_type,
        )
        return PeriodicContacts(contacts, images)


# --------------------------------------------------------------------------------------------
# Slow, obviously right twin (STYLE.md 12) -- for tests
# --------------------------------------------------------------------------------------------


def periodic_contacts_slow(state: BodyState, library: ShapeLibrary, cell: TriclinicCell,
                           alert: float, angle_tolerance: float = ANGLE_TOLERANCE,
                           max_points: int = DEFAULT_MAX_POINTS) -> PeriodicContacts:
    """Contacts by brute force, the twin of :meth:`PeriodicDetection.detect`: no wrapping, no
    ghosts, no broad phase. For every pair i < j and every image n = n_0 + k, n_0 the nearest
    integer to h^-1 (x_i - x_j) and k in {-2, ..., 2}^3 (complete when the cell is at least
    3 R_cut wide), the image of j at x_j + h n whose bounding sphere is within ``alert`` of
    body i's is put next to body i in a two-body state and given to the narrow phase alone.
    Rows are ordered by (i, j, n); same fields and conventions as the fast detection."""
    _checked(state, library, cell)
    narrow = NarrowPhase(alert, angle_tolerance=angle_tolerance, max_points=max_points)
    h = cell.matrix
    x = state.positions
    bounding = library.bounding_radius[state.shape_ids]
    shifts = np.array(list(itertools.product(range(-2, 3), repeat=3)), dtype=np.int64)
    parts: list[tuple[Contacts, np.ndarray]] = []
    for i in range(state.n_bodies):
        for j in range(i + 1, state.n_bodies):
            candidates = np.rint(cell.fractional(x[i] - x[j])).astype(np.int64) + shifts
            others = x[j] + candidates @ h.T
            near = np.linalg.norm(others - x[i], axis=1) <= bounding[i] + bounding[j] + alert
            for n, other in zip(candidates[near], others[near], strict=True):
                rows = [i, j]
                two = replace(
                    state, positions=np.stack([x[i], other]),
                    orientations=state.orientations[rows], velocities=state.velocities[rows],
                    angular_velocities=state.angular_velocities[rows],
                    masses=state.masses[rows], inertias=state.inertias[rows],
                    shape_ids=state.shape_ids[rows],
                )
                found = narrow.detect(two, library, np.array([[0, 1]]))
                if found.n_contacts:
                    parts.append((replace(found, body_i=np.full(found.n_contacts, i),
                                          body_j=np.full(found.n_contacts, j)),
                                  np.tile(n, (found.n_contacts, 1))))
    if not parts:
        return _empty_contacts()
    fields = ("body_i", "body_j", "member_i", "member_j", "point", "normal", "gap",
              "contact_type")
    contacts = Contacts(**{name: np.concatenate([getattr(c, name) for c, _ in parts])
                           for name in fields})
    return PeriodicContacts(contacts, np.concatenate([n for _, n in parts]))
