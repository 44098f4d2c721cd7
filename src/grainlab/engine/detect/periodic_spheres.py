"""Contacts of plain spheres in a periodic triclinic cell by one compiled cell list: the fast
path of :class:`~grainlab.engine.detect.periodic_detection.PeriodicDetection` when every shape is a
single sphere at its centre of mass (STYLE.md 2, 8, 12).

The same contacts as the general detection (ghost layer, broad and narrow phases), found
without ghosts or intermediate pairs:

1. **Wrap.** w_i = floor(h^-1 x_i), x~_i = x_i - h w_i in the cell.
2. **Bins.** The cell is cut into n_a bins along each cell vector, n_a = floor(w_a / R_cut)
   (w_a the width across the faces, R_cut = 2 r_max + alert; at most about 4 N bins in
   all): two points within R_cut then lie in the same or neighbouring bins, counted through
   the cell's faces, since their fractional coordinates differ by at most R_cut / w_a <=
   1 / n_a. The cell must be at least 3 R_cut wide (as the general detection requires), so
   that the 27 neighbours of a bin are 27 different (bin, image) couples.
3. **Pairs.** For each body i, each neighbouring bin (image m of its bodies: -1, 0 or 1 per
   axis, from crossing the faces) and each body j > i in it: gap g = |x~_j + h m - x~_i| -
   r_i - r_j; a contact when g <= alert, with image vector n = m + w_i - w_j (unwrapped
   positions), normal from i to that image of j, point x_i + (r_i + g / 2) n.

Rows come by body_i, then body_j (a canonical order, independent of the binning and of the
number of threads), as the general detection's every row has body_i < body_j.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from grainlab.engine.detect.narrow_phase import Contacts
from grainlab.engine.state import ShapeLibrary


def plain_spheres(library: ShapeLibrary) -> bool:
    """Whether every shape of ``library`` is one sphere at its centre of mass."""
    return bool(library.sphere_count.size and np.all(library.sphere_count == 1)
                and not np.any(library.sphere_offsets[library.sphere_start]))


def bins_per_axis(widths: np.ndarray, cutoff: float, n_bodies: int) -> np.ndarray:
    """(3,) int64 n_a = floor(w_a / R_cut) >= 3, scaled down together to at most about
    4 N bins in all (wider bins keep the list complete)."""
    n = np.maximum(np.floor(widths / cutoff), 3.0)
    most = max(27.0, 4.0 * n_bodies)
    if np.prod(n) > most:
        n = np.maximum(np.floor(n * (most / np.prod(n)) ** (1.0 / 3.0)), 3.0)
    return n.astype(np.int64)


PARALLEL_SPHERES = 2000
"""From this many spheres, with more than one Numba thread, the pairs are found by the bodies'
chunks in parallel (:func:`_sphere_pairs_parallel`; the same rows in the same order)."""
_CHUNKS_PER_THREAD = 16


def periodic_sphere_contacts(positions: np.ndarray, radii: np.ndarray, matrix: np.ndarray,
                             inverse: np.ndarray, bins: np.ndarray, alert: float,
                             scratch: dict | None = None) -> tuple[Contacts, np.ndarray]:
    """Contacts (g <= ``alert`` [m]) of spheres of ``radii`` (N,) [m] at unwrapped
    ``positions`` (N, 3) [m] in the cell ``matrix`` h (3, 3) [m] (``inverse`` h^-1, ``bins``
    (3,) from :func:`bins_per_axis`): (contacts, images (C, 3) int64) as
    :class:`~grainlab.engine.detect.periodic_detection.PeriodicContacts` holds them (module
    docstring). From :data:`PARALLEL_SPHERES` spheres the bodies are shared out over the
    threads in chunks, each writing its rows to its own part of the outputs, then packed in
    chunk order: the same rows in the same order as one thread. ``scratch``: a dict the caller
    keeps from call to call, where the chunks' buffers stay (memory written for the first time
    costs its page faults: fresh buffers at every call made the threads slower than one)."""
    n = positions.shape[0]
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    h = np.ascontiguousarray(matrix, dtype=np.float64)
    h_inv = np.ascontiguousarray(inverse, dtype=np.float64)
    bins = np.ascontiguousarray(bins, dtype=np.int64)
    n_bins = int(np.prod(bins))
    binned = (np.empty((n, 3)), np.empty((n, 3), dtype=np.int64),
              np.empty((n, 3), dtype=np.int64), np.zeros(n_bins + 1, dtype=np.int64),
              np.empty(n, dtype=np.int64))
    _bin_spheres_kernel(positions, h, h_inv, bins, *binned, np.empty(n, dtype=np.int64),
                        np.empty(n_bins, dtype=np.int64))
    threads = numba.get_num_threads()
    per_body = 8  # rows of output per body (a chunk's share)
    while True:
        capacity = max(64, per_body * n)
        out = (np.empty(capacity, dtype=np.int64), np.empty(capacity, dtype=np.int64),
               np.empty((capacity, 3)), np.empty((capacity, 3)), np.empty(capacity),
               np.empty((capacity, 3), dtype=np.int64))
        if threads > 1 and n >= PARALLEL_SPHERES:
            n_chunks = min(n, _CHUNKS_PER_THREAD * threads)
            kept = {} if scratch is None else scratch
            if "rows" not in kept or kept["rows"][0].shape[0] != capacity:
                kept["rows"] = tuple(np.empty_like(a) for a in out)
            # body i has rows with the bodies j > i only: about (1 - i / N) of its
            # neighbours, so the chunks' shares of the scratch are the integral of that
            x = (np.arange(n_chunks + 1) * n // n_chunks) / n
            starts = np.floor(capacity * (2.0 * x - x * x)).astype(np.int64)
            starts[-1] = capacity
            found_per_chunk = np.zeros(n_chunks, dtype=np.int64)
            found = _sphere_pairs_parallel(positions, radii, h, bins, float(alert), *binned,
                                           starts, found_per_chunk, *out, *kept["rows"])
            if found < 0:  # a chunk's share was too small: more rows per body
                share = np.diff(starts)
                per_body = int(np.ceil(per_body * np.max(found_per_chunk / share))) + 1
                continue
        else:
            found = _sphere_pairs_kernel(positions, radii, h, bins, float(alert), *binned,
                                         *out)
        if found <= capacity:
            break
        per_body = -(-found // max(n, 1)) + 1
    body_i, body_j, point, normal, gap, images = (a[:found] for a in out)
    zeros = np.zeros(found, dtype=np.int64)
    contacts = Contacts(body_i=body_i, body_j=body_j, member_i=zeros, member_j=zeros.copy(),
                        point=point, normal=normal, gap=gap,
                        contact_type=np.zeros(found, dtype=np.int8))
    return contacts, images


@njit(cache=True, _nrt=False)
def _bin_spheres_kernel(positions, h, h_inv, bins, wrapped, counts, cell_of, bin_start,
                        members, home, fill):
    """Steps 1-2 of the module docstring: ``wrapped`` (N, 3) positions in the cell,
    ``counts`` (N, 3) the cell vectors taken off, ``cell_of`` (N, 3) each body's bin, and
    the bins' bodies in increasing order, bin b's at ``members[bin_start[b] ..
    bin_start[b + 1] - 1]`` (``bin_start`` (B + 1,) zeros on entry; scratch ``home`` (N,),
    ``fill`` (B,))."""
    n = positions.shape[0]
    n1, n2 = bins[1], bins[2]
    for i in range(n):
        x, y, z = positions[i, 0], positions[i, 1], positions[i, 2]
        for a in range(3):
            s = h_inv[a, 0] * x + h_inv[a, 1] * y + h_inv[a, 2] * z
            c = math.floor(s)
            counts[i, a] = c
            cell_of[i, a] = min(int((s - c) * bins[a]), bins[a] - 1)
        c0, c1, c2 = counts[i, 0], counts[i, 1], counts[i, 2]
        for a in range(3):
            wrapped[i, a] = positions[i, a] - (h[a, 0] * c0 + h[a, 1] * c1 + h[a, 2] * c2)
        home[i] = (cell_of[i, 0] * n1 + cell_of[i, 1]) * n2 + cell_of[i, 2]
        bin_start[home[i] + 1] += 1
    for b in range(fill.shape[0]):
        bin_start[b + 1] += bin_start[b]
    for b in range(fill.shape[0]):
        fill[b] = bin_start[b]
    for i in range(n):  # bodies in increasing order within each bin
        members[fill[home[i]]] = i
        fill[home[i]] += 1


@njit(inline="always")
def _body_pairs(i, row, limit, positions, radii, h, bins, alert, wrapped, counts, cell_of,
                bin_start, members, body_i, body_j, point, normal, gap, images):
    """Step 3 of the module docstring for body i: its rows (bodies j > i) written from
    ``row`` on, by body_j, while below ``limit`` (rows beyond are counted, not written);
    returns the row after its last."""
    n0, n1, n2 = bins[0], bins[1], bins[2]
    first = row
    xi, yi, zi, ri = wrapped[i, 0], wrapped[i, 1], wrapped[i, 2], radii[i]
    for o0 in range(-1, 2):
        b0, m0 = _neighbour_bin(cell_of[i, 0] + o0, n0)
        for o1 in range(-1, 2):
            b1, m1 = _neighbour_bin(cell_of[i, 1] + o1, n1)
            for o2 in range(-1, 2):
                b2, m2 = _neighbour_bin(cell_of[i, 2] + o2, n2)
                sx = h[0, 0] * m0 + h[0, 1] * m1 + h[0, 2] * m2
                sy = h[1, 0] * m0 + h[1, 1] * m1 + h[1, 2] * m2
                sz = h[2, 0] * m0 + h[2, 1] * m1 + h[2, 2] * m2
                b = (b0 * n1 + b1) * n2 + b2
                for e in range(bin_start[b + 1] - 1, bin_start[b] - 1, -1):
                    j = members[e]  # a bin's bodies in increasing order: those
                    if j <= i:  # after i, from the last, without a branch per body
                        break
                    dx = wrapped[j, 0] + sx - xi
                    dy = wrapped[j, 1] + sy - yi
                    dz = wrapped[j, 2] + sz - zi
                    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
                    g = dist - ri - radii[j]
                    if g > alert:
                        continue
                    if row < limit:
                        if dist > 0.0:
                            nx, ny, nz = dx / dist, dy / dist, dz / dist
                        else:
                            nx, ny, nz = 0.0, 0.0, 1.0
                        reach = ri + 0.5 * g
                        body_i[row], body_j[row] = i, j
                        normal[row, 0], normal[row, 1], normal[row, 2] = nx, ny, nz
                        point[row, 0] = positions[i, 0] + reach * nx
                        point[row, 1] = positions[i, 1] + reach * ny
                        point[row, 2] = positions[i, 2] + reach * nz
                        gap[row] = g
                        images[row, 0] = m0 + counts[i, 0] - counts[j, 0]
                        images[row, 1] = m1 + counts[i, 1] - counts[j, 1]
                        images[row, 2] = m2 + counts[i, 2] - counts[j, 2]
                    row += 1
    if row <= limit:  # body i's rows by body_j (insertion sort: a few rows)
        for r in range(first + 1, row):
            k = r
            while k > first and body_j[k - 1] > body_j[k]:
                _swap_rows(k - 1, k, body_j, point, normal, gap, images)
                k -= 1
    return row


@njit(cache=True, _nrt=False)  # no reference counts on the arrays in the loops
def _sphere_pairs_kernel(positions, radii, h, bins, alert, wrapped, counts, cell_of,
                         bin_start, members, body_i, body_j, point, normal, gap, images):
    """Step 3 of the module docstring for every body, one after the other; returns the number
    of contacts (rows beyond the outputs' length are counted, not written)."""
    row = 0
    limit = body_i.shape[0]
    for i in range(positions.shape[0]):
        row = _body_pairs(i, row, limit, positions, radii, h, bins, alert, wrapped, counts,
                          cell_of, bin_start, members, body_i, body_j, point, normal, gap,
                          images)
    return row


@njit(_nrt=False)  # a call per chunk: compiled once, outside the threads' loop
def _chunk_pairs(lo, hi, start, limit, positions, radii, h, bins, alert, wrapped, counts,
                 cell_of, bin_start, members, body_i, body_j, point, normal, gap, images):
    """The rows of bodies lo .. hi - 1 from row ``start`` on, written below row ``limit``
    (counted beyond); returns how many they are."""
    row = start
    for i in range(lo, hi):
        row = _body_pairs(i, row, limit, positions, radii, h, bins, alert, wrapped, counts,
                          cell_of, bin_start, members, body_i, body_j, point, normal, gap,
                          images)
    return row - start


@njit(cache=True, parallel=True, _nrt=False)
def _sphere_pairs_parallel(positions, radii, h, bins, alert, wrapped, counts, cell_of,
                           bin_start, members, starts, found, body_i, body_j, point, normal,
                           gap, images, s_body_i, s_body_j, s_point, s_normal, s_gap,
                           s_images):
    """Step 3 by K chunks of consecutive bodies on the threads: chunk c's rows into the
    scratch ``s_*``, rows ``starts[c] .. starts[c + 1] - 1`` (``found`` (K,) its rows),
    then packed into the outputs in chunk order. Returns the number of contacts, or -1 when
    a chunk had more rows than its share (nothing packed)."""
    n = positions.shape[0]
    n_chunks = found.shape[0]
    for c in prange(n_chunks):
        lo, hi = c * n // n_chunks, (c + 1) * n // n_chunks
        found[c] = _chunk_pairs(lo, hi, starts[c], starts[c + 1], positions, radii, h, bins,
                                alert, wrapped, counts, cell_of, bin_start, members, s_body_i,
                                s_body_j, s_point, s_normal, s_gap, s_images)
    total = 0
    full = False
    for c in range(n_chunks):
        total += found[c]
        full = full or found[c] > starts[c + 1] - starts[c]
    if full:
        return -1
    for c in prange(n_chunks):
        to = 0
        for d in range(c):
            to += found[d]
        start = starts[c]
        for r in range(found[c]):
            a, b = start + r, to + r
            body_i[b], body_j[b], gap[b] = s_body_i[a], s_body_j[a], s_gap[a]
            for e in range(3):
                point[b, e] = s_point[a, e]
                normal[b, e] = s_normal[a, e]
                images[b, e] = s_images[a, e]
    return total


@njit(inline="always")
def _neighbour_bin(b, n):
    """Bin ``b`` in -1 .. n of an axis of ``n`` bins wrapped into 0 .. n - 1, and the image
    (-1, 0 or 1) of the bodies in it as seen from the bin next to it."""
    if b < 0:
        return b + n, -1
    if b >= n:
        return b - n, 1
    return b, 0


@njit(inline="always")
def _swap_rows(a, b, body_j, point, normal, gap, images):
    body_j[a], body_j[b] = body_j[b], body_j[a]
    gap[a], gap[b] = gap[b], gap[a]
    for c in range(3):
        point[a, c], point[b, c] = point[b, c], point[a, c]
        normal[a, c], normal[b, c] = normal[b, c], normal[a, c]
        images[a, c], images[b, c] = images[b, c], images[a, c]
