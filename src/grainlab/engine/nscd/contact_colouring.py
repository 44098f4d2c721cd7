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

Slabs (:func:`slab_contacts`), for packings too small for parallel colours (a colour of a
few hundred contacts is less work than waking the threads): the bodies are cut into S slabs
along the longest extent of the packing, and each group holds *chains* swept one contact after
another, the chains of a group in parallel: the contacts inside each slab (S chains: no two
slabs share a body), then those between slabs 0-1, 2-3, ..., then 1-2, 3-4, ..., then the
serial group. One sweep wakes the threads twice or three times, each for a whole slab's work.
A colouring is the special case of one contact per chain (:attr:`ContactColouring.chains`).

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
    def chains(self) -> np.ndarray:
        """Chain offsets (C + 1,): one contact per chain (module docstring, "Slabs")."""
        return np.arange(self.order.shape[0] + 1, dtype=np.int64)

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


# --------------------------------------------------------------------------------------------
# Slabs
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ContactSlabs:
    """Contacts in chains (module docstring, "Slabs"): ``order`` (C,) the contact indices,
    chain c at rows ``chains[c] .. chains[c + 1] - 1``; group g the chains ``offsets[g] ..
    offsets[g + 1] - 1``: 0 the slabs' insides, 1 and 2 the interfaces, 3 the serial group
    (one chain); ``body_order`` (N,) the bodies sorted along the slabs' axis (the kernel's
    memory order: :func:`~grainlab.engine.nscd.nlgs_parallel.nlgs_coloured_kernel`);
    ``n_colours`` = 3, the groups whose chains may run in parallel."""

    order: np.ndarray
    offsets: np.ndarray
    chains: np.ndarray
    body_order: np.ndarray
    n_colours: int = 3


@njit(cache=True)
def slab_contacts_kernel(body_i, body_j, slab, wall_inv_mass, serial, n_slabs, order, chains):
    """Chains of :class:`ContactSlabs` for contacts (``body_i``, ``body_j``) (C,) of bodies in
    slabs ``slab`` (N,) int64 in 0 .. S - 1 (``n_slabs``); mobile walls (``wall_inv_mass`` >
    0), ``serial`` (C,) contacts and contacts between slabs more than one apart go to the
    serial chain. Outputs ``order`` (C,), ``chains`` (2 S + 1,) (chains: S insides, S - 1
    interfaces in the order 0-1, 2-3, ..., 1-2, 3-4, ..., then the serial one)."""
    n_contacts = body_i.shape[0]
    n_chains = 2 * n_slabs
    chain_of = np.empty(n_contacts, dtype=np.int64)
    for k in range(n_contacts):
        i, j = body_i[k], body_j[k]
        sj = slab[j]
        if serial[k] or (i < 0 and wall_inv_mass[-1 - i] > 0.0):
            chain_of[k] = n_chains - 1
            continue
        si = sj if i < 0 else slab[i]
        low = min(si, sj)
        if si == sj:
            chain_of[k] = si
        elif max(si, sj) - low == 1:
            # interfaces low-(low+1): even ones first, then odd ones
            chain_of[k] = n_slabs + (low // 2 if low % 2 == 0 else (n_slabs // 2) + low // 2)
        else:
            chain_of[k] = n_chains - 1
    counts = np.zeros(n_chains + 1, dtype=np.int64)
    for k in range(n_contacts):
        counts[chain_of[k] + 1] += 1
    for c in range(n_chains):
        counts[c + 1] += counts[c]
    chains[:] = counts
    fill = counts[:n_chains].copy()
    for k in range(n_contacts):
        c = chain_of[k]
        order[fill[c]] = k
        fill[c] += 1


def power_of_two_below(n: int) -> int:
    """The largest power of two <= n (n >= 1): a slab count the threads share evenly."""
    return 1 << (int(n).bit_length() - 1)


def slab_contacts(body_i, body_j, positions, wall_inv_mass, serial=None,
                  n_slabs: int = 2) -> ContactSlabs:
    """Contacts in chains of at most ``n_slabs`` slabs (>= 2) of the bodies at ``positions``
    (N, 3) [m], cut evenly along their longest extent (module docstring, "Slabs"): fewer (a
    power of two, never below 2) where a slab would be thinner than the longest branch
    between two bodies in contact along that axis, whose contacts would otherwise skip a slab
    and go to the serial chain (branches longer than half the extent are a periodic cell's
    contacts across its boundary: serial or between slabs 0 and 1 whatever the cut);
    ``serial`` (C,) bool as in :func:`colour_contacts`."""
    x = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    bi = np.ascontiguousarray(body_i, dtype=np.int64)
    bj = np.ascontiguousarray(body_j, dtype=np.int64)
    n_contacts = bi.shape[0]
    if x.shape[0]:
        extent = x.max(axis=0) - x.min(axis=0)
        axis = int(np.argmax(extent))
        low, width = float(x[:, axis].min()), float(extent[axis])
        pairs = (bi >= 0) & (bj >= 0)
        if n_slabs > 2 and pairs.any():
            spans = np.abs(x[bi[pairs], axis] - x[bj[pairs], axis])
            spans = spans[spans <= 0.5 * width]  # not a periodic cell's wrapped contacts
            span = float(spans.max()) if spans.size else 0.0
            if span > 0.0 and width / span < n_slabs:
                n_slabs = power_of_two_below(max(2, int(width / span)))
        slab = np.floor((x[:, axis] - low) / max(width, 1e-300) * n_slabs).astype(np.int64)
        slab = np.clip(slab, 0, n_slabs - 1)
        body_order = np.argsort(x[:, axis], kind="stable").astype(np.int64)
    else:
        slab = np.zeros(0, dtype=np.int64)
        body_order = np.zeros(0, dtype=np.int64)
    serial = np.zeros(n_contacts, dtype=np.bool_) if serial is None else \
        np.ascontiguousarray(serial, dtype=np.bool_)
    order = np.empty(n_contacts, dtype=np.int64)
    chains = np.empty(2 * n_slabs + 1, dtype=np.int64)
    slab_contacts_kernel(bi, bj, slab, np.ascontiguousarray(wall_inv_mass, dtype=np.float64)
                         .reshape(-1), serial, int(n_slabs), order, chains)
    even = n_slabs // 2  # interfaces 0-1, 2-3, ...: (n_slabs) // 2 of them
    odd = (n_slabs - 1) // 2
    offsets = np.array([0, n_slabs, n_slabs + even, n_slabs + even + odd, 2 * n_slabs],
                       dtype=np.int64)
    return ContactSlabs(order=order, offsets=offsets, chains=chains, body_order=body_order)
