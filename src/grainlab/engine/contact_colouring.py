"""Greedy graph colouring of contacts for the parallel nonlinear Gauss-Seidel sweep
(Numba; research/cd_engines.md 6.3; STYLE.md 2, 8, 12).

Two contacts conflict when they share a body b >= 0: updating one changes the velocity of b,
which the other reads. A colouring gives every contact a colour such that no two contacts of
one colour conflict; the contacts of one colour can then be updated in parallel (their
scattered body updates touch disjoint bodies) and the colours one after another make one
Gauss-Seidel sweep in a fixed order.

Walls (side i, body_i = -1 - w) are not bodies of the conflict graph when they are driven
(``wall_inv_mass[w] == 0``): their speed never changes. A MOBILE wall (stress-controlled,
``wall_inv_mass[w] > 0``) is updated by every one of its contacts, so all of them conflict;
they go into one final SERIAL group, visited in a plain loop after the colours.

Greedy first fit, contacts in index order: contact k takes the smallest colour not yet used by
a contact of its bodies. Colours 0..62 are tracked by one int64 bit mask per body; the contacts
that find all 63 taken are deferred to a second round with fresh masks (colours 63..125), and
so on. This gives exactly the standard greedy colouring (a deferred contact has all lower
colours taken by earlier contacts of its bodies; in its round it sees exactly the colours of
the earlier deferred contacts), is deterministic (a serial loop: no dependence on the number
of threads), and costs O(C) per round plus O(N) to clear the masks. A body with degree D
needs at most 2 D - 1 colours, so dense sphere packings (D <= ~20) finish in the first round.

Output (:class:`ContactColouring`): ``order`` (C,) int64, a permutation of the contact indices
grouped by colour (ascending contact index inside a group); ``offsets`` (G + 2,) int64 with
colour c at rows ``offsets[c] .. offsets[c + 1] - 1`` of ``order`` for c < G = ``n_colours``,
and the serial group at rows ``offsets[G] .. offsets[G + 1] - 1`` (possibly empty).

>>> import numpy as np
>>> body_i = np.array([0, 1, 2, -1, -2])   # three pairs in a chain, a driven and a mobile wall
>>> body_j = np.array([1, 2, 3, 0, 3])
>>> c = colour_contacts(body_i, body_j, wall_inv_mass=np.array([0.0, 1.0]))
>>> c.n_colours, c.order.tolist(), c.offsets.tolist()
(2, [0, 2, 1, 3, 4], [0, 2, 4, 5])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

_MASK_BITS = 63  # colours per round: bits 0..62 of an int64 mask (no sign bit)
_FULL = (1 << _MASK_BITS) - 1
_SERIAL = -1  # colour code of a contact in the serial group


# --------------------------------------------------------------------------------------------
# Array kernel (outputs last)
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def colour_contacts_kernel(body_i, body_j, wall_inv_mass, serial, n_bodies, colour, order,
                           offsets):
    """Greedy colouring (module docstring) of contacts (``body_i``, ``body_j``) (C,) among
    ``n_bodies`` bodies; ``wall_inv_mass`` (W,) [1/kg] marks mobile walls (> 0); contacts
    with ``serial[k]`` (C,) bool go to the serial group too (those with an image in a
    periodic cell whose rate is solved with the contacts: they all share the cell).

    Outputs: ``colour`` (C,) int64, the colour of each contact (-1: serial group);
    ``order`` (C,) int64 and ``offsets`` (at least G + 2,) int64 (module docstring).
    Returns G, the number of parallel colours.
    """
    n_contacts = body_i.shape[0]
    used = np.zeros(n_bodies, dtype=np.int64)
    pending = np.empty(n_contacts, dtype=np.int64)
    n_pending = 0
    for k in range(n_contacts):
        i = body_i[k]
        if serial[k] or (i < 0 and wall_inv_mass[-1 - i] > 0.0):
            colour[k] = _SERIAL
        else:
            pending[n_pending] = k
            n_pending += 1
    base = 0
    n_colours = 0
    while n_pending > 0:
        if base > 0:
            used[:] = 0
        n_next = 0
        for m in range(n_pending):
            k = pending[m]
            i, j = body_i[k], body_j[k]
            mask = used[j]
            if i >= 0:
                mask |= used[i]
            if mask == _FULL:
                pending[n_next] = k  # n_next <= m: overwrite in place, order kept
                n_next += 1
                continue
            c = 0
            while (mask >> c) & 1:
                c += 1
            bit = np.int64(1) << c
            used[j] |= bit
            if i >= 0:
                used[i] |= bit
            colour[k] = base + c
            n_colours = max(n_colours, base + c + 1)
        n_pending = n_next
        base += _MASK_BITS
    # counting sort by colour, the serial group (colour -1) last; stable in k
    offsets[: n_colours + 2] = 0
    for k in range(n_contacts):
        c = colour[k] if colour[k] >= 0 else n_colours
        offsets[c + 1] += 1
    for c in range(n_colours + 1):
        offsets[c + 1] += offsets[c]
    fill = offsets[: n_colours + 1].copy()
    for k in range(n_contacts):
        c = colour[k] if colour[k] >= 0 else n_colours
        order[fill[c]] = k
        fill[c] += 1
    return n_colours


# --------------------------------------------------------------------------------------------
# Python launcher and slow twin
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ContactColouring:
    """Contacts grouped by colour (module docstring): ``order`` (C,), ``offsets`` (G + 2,),
    ``n_colours`` G and per-contact ``colour`` (C,) (-1: serial group)."""

    order: np.ndarray
    offsets: np.ndarray
    n_colours: int
    colour: np.ndarray

    @property
    def serial(self) -> np.ndarray:
        """Contact indices of the serial group (contacts of mobile walls)."""
        return self.order[self.offsets[self.n_colours]:self.offsets[self.n_colours + 1]]

    def group(self, c: int) -> np.ndarray:
        """Contact indices of colour ``c`` (0 <= c < G)."""
        return self.order[self.offsets[c]:self.offsets[c + 1]]


def colour_contacts(body_i, body_j, wall_inv_mass, n_bodies: int | None = None,
                    serial=None) -> ContactColouring:
    """Greedy colouring of the contacts (``body_i``, ``body_j``) (C,); ``wall_inv_mass`` (W,)
    [1/kg] (> 0: mobile wall, its contacts go to the serial group); ``n_bodies`` defaults to
    1 + the largest body index; ``serial`` (C,) bool (None: none) puts more contacts in the
    serial group."""
    bi = np.ascontiguousarray(body_i, dtype=np.int64)
    bj = np.ascontiguousarray(body_j, dtype=np.int64)
    walls = np.ascontiguousarray(wall_inv_mass, dtype=np.float64).reshape(-1)
    if n_bodies is None:
        n_bodies = int(max(bi.max(initial=-1), bj.max(initial=-1))) + 1
    n_contacts = bi.shape[0]
    serial = np.zeros(n_contacts, dtype=np.bool_) if serial is None else \
        np.ascontiguousarray(serial, dtype=np.bool_)
    colour = np.empty(n_contacts, dtype=np.int64)
    order = np.empty(n_contacts, dtype=np.int64)
    offsets = np.empty(n_contacts + 2, dtype=np.int64)  # G <= C
    n_colours = int(colour_contacts_kernel(bi, bj, walls, serial, int(n_bodies), colour,
                                           order, offsets))
    return ContactColouring(order=order, offsets=offsets[: n_colours + 2].copy(),
                            n_colours=n_colours, colour=colour)


def colour_contacts_slow(body_i, body_j, wall_inv_mass) -> np.ndarray:
    """Pure-Python twin (STYLE.md 12): the per-contact colour (-1: serial group) of the
    standard greedy first-fit colouring in contact order, one set of used colours per body."""
    used: dict[int, set[int]] = {}
    colour = np.empty(len(body_i), dtype=np.int64)
    for k, (i, j) in enumerate(zip(body_i, body_j, strict=True)):
        i, j = int(i), int(j)
        if i < 0 and wall_inv_mass[-1 - i] > 0.0:
            colour[k] = _SERIAL
            continue
        bodies = [j] if i < 0 else [i, j]
        taken = set().union(*(used.get(b, set()) for b in bodies))
        c = 0
        while c in taken:
            c += 1
        colour[k] = c
        for b in bodies:
            used.setdefault(b, set()).add(c)
    return colour
