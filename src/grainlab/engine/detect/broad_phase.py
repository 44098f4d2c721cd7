"""Cell-list broad phase: candidate pairs of bodies whose bounding spheres come within an alert
distance (Numba; STYLE.md 2, 8 and 12).

Bodies are given by their centres x_i [m], shape (N, 3), and bounding radii r_i [m], shape
(N,), in an axis-aligned box [lo, hi] [m]. The candidate pairs are

    P = {(i, j) : i < j,  |x_i - x_j| <= r_i + r_j + alert},

with |.| the minimum-image distance along periodic axes. ``alert`` [m] >= 0 is the alert
distance of contact dynamics: pairs a little apart are kept so that the narrow phase sees them
before they touch.

Algorithm
---------
1. **Grid.** The target cell size is s = 2 r_max + alert, the largest cut-off of any pair. On
   each axis of length L the grid has n = floor(L / s) cells (at least 1) of width w = L / n >= s,
   so two bodies of a candidate pair lie in the same or in adjacent cells (s carries a 1e-9
   relative margin against round-off in the binning). If that would make more than
   ``max(27, 4 N)`` cells (tiny bodies in a large box), s is enlarged until it does not: cells
   are then wider than needed, which costs time but never misses a pair.
2. **Binning.** Each body gets the cell of its centre; on a walled (non-periodic) axis a centre
   outside [lo, hi] is clamped to the edge cell (clamping keeps neighbours adjacent, so bodies
   may sit slightly -- or far -- outside the box); on a periodic axis the centre is wrapped
   into [lo, hi) first. A stable counting sort orders the bodies by cell (linear in N) and
   copies centres and radii into that order for locality.
3. **Pairs, count then fill.** A parallel loop over bodies (in cell order) visits the 27 cells
   around the body's cell and keeps the neighbours j > i within the cut-off: the first pass
   only counts them per body, an exclusive prefix sum gives each body its first output row,
   and the second pass writes the pairs of body i into its own rows (a gather: no two
   iterations write the same row; it stops once the counted pairs are found) and sorts them by
   j. The output is therefore sorted lexicographically and does not depend on the number of
   threads. Cost: about 27 x (bodies per cell) distance tests per body and pass, i.e. linear
   in N at a fixed packing fraction.
4. **Capacity.** The output array is allocated by the Python launcher. The kernel returns the
   number of rows it needed; when that exceeds the capacity it writes nothing, and the
   launcher grows the array (to 1.25 x the need) and runs it again -- it never truncates.

Periodic axes use the minimum image. **Restriction:** a periodic axis must be at least three
cells long, L >= 3 s = 3 (2 r_max + alert), so that the 27 neighbour cells are distinct and the
minimum image is unique (the cut-off is then at most L / 3 < L / 2); a shorter periodic box
raises :class:`~grainlab.errors.InputError`.

Example
-------
>>> import numpy as np
>>> broad_phase = CellListBroadPhase(alert=0.1)
>>> centres = np.array([[0.0, 0.0, 0.0], [1.05, 0.0, 0.0], [3.0, 0.0, 0.0]])
>>> broad_phase.find_pairs(centres, np.full(3, 0.5), lo=[-1.0] * 3, hi=[4.0] * 3)
array([[0, 1]])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from grainlab.errors import GrainlabError, InputError

_GROWTH = 1.25  # a regrown output holds this many times the rows last needed


# --------------------------------------------------------------------------------------------
# Scalar laws
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def _cell_coordinate(x, lo, length, width, n, periodic):
    """Cell index (0 .. n-1) along one axis of a centre coordinate ``x`` [m]: wrapped into
    [lo, lo + length) on a periodic axis, clamped to the edge cells on a walled one."""
    if periodic:
        x = x - length * np.floor((x - lo) / length)
    f = np.floor((x - lo) / width)
    if f < 0.0:
        return 0
    if f >= n:
        return n - 1
    return int(f)


@njit(inline="always")
def _min_image(d, length, periodic):
    """Displacement ``d`` [m] along one axis, mapped to its minimum image when periodic."""
    if periodic:
        return d - length * np.rint(d / length)
    return d


@njit(inline="always")
def _is_candidate(xi, yi, zi, ri, xj, yj, zj, rj, alert, lx, ly, lz, px, py, pz):
    """True when |x_j - x_i| <= r_i + r_j + alert [m], with the minimum image along the axes
    flagged periodic (px, py, pz) of lengths (lx, ly, lz) [m]."""
    dx = _min_image(xj - xi, lx, px)
    dy = _min_image(yj - yi, ly, py)
    dz = _min_image(zj - zi, lz, pz)
    cut = ri + rj + alert
    return dx * dx + dy * dy + dz * dz <= cut * cut


@njit(inline="always")
def _neighbour_cell(c, d, n, periodic):
    """Index of the cell ``c + d`` (d in -1, 0, 1) along one axis; -1 when it falls off a walled
    axis, wrapped on a periodic one."""
    k = c + d
    if k < 0:
        return n - 1 if periodic else -1
    if k >= n:
        return 0 if periodic else -1
    return k


# --------------------------------------------------------------------------------------------
# Array kernels (outputs last)
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def bin_bodies_kernel(
    centres, radii, lo, length, width, shape, periodic,
    cell_of, cell_start, order, sorted_centres, sorted_radii,
):
    """Stable counting sort of N bodies into the cells of a grid of ``shape`` (3,) cells.

    Inputs: ``centres`` (N, 3) [m], ``radii`` (N,) [m], ``lo``, ``length``, ``width`` (3,) [m],
    ``shape`` (3,) int, ``periodic`` (3,) bool. Outputs: ``cell_of`` (N,) the cell of each body
    (id = (cz * ny + cy) * nx + cx); ``cell_start`` (n_cells + 1,) the first sorted slot of each
    cell; ``order`` (N,) the body in each sorted slot (ascending within a cell);
    ``sorted_centres`` (N, 3) and ``sorted_radii`` (N,) the inputs in slot order.
    """
    n_bodies = centres.shape[0]
    nx, ny, nz = shape[0], shape[1], shape[2]
    n_cells = nx * ny * nz
    for c in range(n_cells + 1):
        cell_start[c] = 0
    for i in range(n_bodies):
        cx = _cell_coordinate(centres[i, 0], lo[0], length[0], width[0], nx, periodic[0])
        cy = _cell_coordinate(centres[i, 1], lo[1], length[1], width[1], ny, periodic[1])
        cz = _cell_coordinate(centres[i, 2], lo[2], length[2], width[2], nz, periodic[2])
        c = (cz * ny + cy) * nx + cx
        cell_of[i] = c
        cell_start[c + 1] += 1
    for c in range(n_cells):
        cell_start[c + 1] += cell_start[c]
    fill = cell_start[:n_cells].copy()
    for i in range(n_bodies):
        slot = fill[cell_of[i]]
        fill[cell_of[i]] = slot + 1
        order[slot] = i
        sorted_centres[slot, 0] = centres[i, 0]
        sorted_centres[slot, 1] = centres[i, 1]
        sorted_centres[slot, 2] = centres[i, 2]
        sorted_radii[slot] = radii[i]


@njit(inline="always")
def _count_candidates(
    k, sorted_centres, sorted_radii, order, cell_of, cell_start, shape, length, periodic, alert,
):
    """Number of candidates j > i of body i = order[k] (sorted slot ``k``) in the 27 cells
    around its cell."""
    i = order[k]
    nx, ny, nz = shape[0], shape[1], shape[2]
    lx, ly, lz = length[0], length[1], length[2]
    px, py, pz = periodic[0], periodic[1], periodic[2]
    c = cell_of[i]
    cx, cy, cz = c % nx, (c // nx) % ny, c // (nx * ny)
    xi, yi, zi = sorted_centres[k, 0], sorted_centres[k, 1], sorted_centres[k, 2]
    ri = sorted_radii[k]
    count = 0
    for dz in range(-1, 2):
        kz = _neighbour_cell(cz, dz, nz, pz)
        if kz < 0:
            continue
        for dy in range(-1, 2):
            ky = _neighbour_cell(cy, dy, ny, py)
            if ky < 0:
                continue
            for dx in range(-1, 2):
                kx = _neighbour_cell(cx, dx, nx, px)
                if kx < 0:
                    continue
                cell = (kz * ny + ky) * nx + kx
                for m in range(cell_start[cell], cell_start[cell + 1]):
                    # `&` and an integer add, no branch: j > i is a coin toss that a branch
                    # predictor would miss half the time
                    count += (order[m] > i) & _is_candidate(
                        xi, yi, zi, ri, sorted_centres[m, 0], sorted_centres[m, 1],
                        sorted_centres[m, 2], sorted_radii[m], alert, lx, ly, lz, px, py, pz,
                    )
    return count


@njit(inline="always")
def _write_candidates(
    k, sorted_centres, sorted_radii, order, cell_of, cell_start, shape, length, periodic, alert,
    pairs, first, expected,
):
    """Write the ``expected`` candidates j > i of body i = order[k] as rows (i, j) of
    ``pairs`` from row ``first`` on (same visit as :func:`_count_candidates`, which gave
    ``expected``); stops as soon as they are all found."""
    i = order[k]
    nx, ny, nz = shape[0], shape[1], shape[2]
    lx, ly, lz = length[0], length[1], length[2]
    px, py, pz = periodic[0], periodic[1], periodic[2]
    c = cell_of[i]
    cx, cy, cz = c % nx, (c // nx) % ny, c // (nx * ny)
    xi, yi, zi = sorted_centres[k, 0], sorted_centres[k, 1], sorted_centres[k, 2]
    ri = sorted_radii[k]
    count = 0
    for dz in range(-1, 2):
        kz = _neighbour_cell(cz, dz, nz, pz)
        if kz < 0:
            continue
        for dy in range(-1, 2):
            ky = _neighbour_cell(cy, dy, ny, py)
            if ky < 0:
                continue
            for dx in range(-1, 2):
                kx = _neighbour_cell(cx, dx, nx, px)
                if kx < 0:
                    continue
                cell = (kz * ny + ky) * nx + kx
                for m in range(cell_start[cell], cell_start[cell + 1]):
                    j = order[m]
                    if (j > i) & _is_candidate(
                        xi, yi, zi, ri, sorted_centres[m, 0], sorted_centres[m, 1],
                        sorted_centres[m, 2], sorted_radii[m], alert, lx, ly, lz, px, py, pz,
                    ):
                        pairs[first + count, 0] = i
                        pairs[first + count, 1] = j
                        count += 1
                        if count == expected:
                            return


@njit(cache=True, parallel=True)
def candidate_pairs_kernel(
    sorted_centres, sorted_radii, order, cell_of, cell_start, shape, length, periodic, alert,
    counts, pairs,
):
    """Candidate pairs (i < j, |x_i - x_j| <= r_i + r_j + alert) of bodies binned by
    :func:`bin_bodies_kernel`; returns the number of pairs P.

    Scratch: ``counts`` (N + 1,) int. Output: ``pairs`` (capacity, 2) int, rows 0 .. P-1 sorted
    lexicographically, filled only when P <= capacity; otherwise nothing is written and the
    caller must grow ``pairs`` to at least P rows and call again.
    """
    n_bodies = order.shape[0]
    for k in prange(n_bodies):  # pass 1: count per body (each i is written by one iteration)
        counts[order[k] + 1] = _count_candidates(
            k, sorted_centres, sorted_radii, order, cell_of, cell_start, shape, length,
            periodic, alert,
        )
    counts[0] = 0
    for i in range(n_bodies):  # exclusive prefix sum: counts[i] = first row of body i
        counts[i + 1] += counts[i]
    n_pairs = counts[n_bodies]
    if n_pairs > pairs.shape[0]:
        return n_pairs
    for k in prange(n_bodies):  # pass 2: body i fills its own rows, then sorts them by j
        i = order[k]
        first = counts[i]
        n_own = counts[i + 1] - first
        if n_own == 0:
            continue
        _write_candidates(
            k, sorted_centres, sorted_radii, order, cell_of, cell_start, shape, length,
            periodic, alert, pairs, first, n_own,
        )
        for a in range(first + 1, first + n_own):
            j = pairs[a, 1]
            b = a - 1
            while b >= first and pairs[b, 1] > j:
                pairs[b + 1, 1] = pairs[b, 1]
                b -= 1
            pairs[b + 1, 1] = j
    return n_pairs


# --------------------------------------------------------------------------------------------
# Python launcher
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BroadPhaseStatistics:
    """What the last :meth:`CellListBroadPhase.find_pairs` call did.

    Attributes
    ----------
    cell_shape:
        Cells per axis (nx, ny, nz).
    cell_width:
        Cell widths [m] per axis, each >= 2 r_max + alert unless the axis has one cell.
    n_cells:
        nx * ny * nz.
    n_bodies, n_pairs:
        Bodies in and candidate pairs out.
    capacity:
        Rows of the output buffer after the call.
    n_regrowths:
        Times the output buffer was grown, over the life of the broad phase.
    n_calls:
        Calls of ``find_pairs`` so far.
    """

    cell_shape: tuple[int, int, int]
    cell_width: tuple[float, float, float]
    n_cells: int
    n_bodies: int
    n_pairs: int
    capacity: int
    n_regrowths: int
    n_calls: int


def _validated(centres, radii, lo, hi):
    """Arrays of the inputs as float64, or :class:`InputError` naming the bad field."""
    centres_arr = np.asarray(centres, dtype=np.float64)
    if centres_arr.ndim != 2 or centres_arr.shape[1] != 3:
        raise InputError("centres", f"array of shape {centres_arr.shape}", "shape (N, 3) in m")
    n_bodies = centres_arr.shape[0]
    bad = ~np.isfinite(centres_arr).all(axis=1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"centres[{k}]", centres_arr[k].tolist(), "finite coordinates in m")
    radii_arr = np.asarray(radii, dtype=np.float64)
    if radii_arr.shape != (n_bodies,):
        raise InputError("radii", f"array of shape {radii_arr.shape}",
                         f"shape ({n_bodies},), one radius per centre")
    bad = ~(np.isfinite(radii_arr) & (radii_arr >= 0.0))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"radii[{k}]", float(radii_arr[k]), "a finite radius >= 0 in m")
    lo_arr = np.asarray(lo, dtype=np.float64)
    hi_arr = np.asarray(hi, dtype=np.float64)
    for name, value in (("lo", lo_arr), ("hi", hi_arr)):
        if value.shape != (3,) or not np.isfinite(value).all():
            raise InputError(name, value.tolist(), "three finite coordinates in m")
    for axis in range(3):
        if not hi_arr[axis] > lo_arr[axis]:
            raise InputError(f"hi[{axis}]", float(hi_arr[axis]),
                             f"a coordinate greater than lo[{axis}] = {lo_arr[axis]:g} m")
    return centres_arr, radii_arr, lo_arr, hi_arr


def _validated_periodic(periodic) -> tuple[bool, bool, bool]:
    flags = tuple(periodic)
    if len(flags) != 3 or not all(isinstance(f, bool | np.bool_) for f in flags):
        raise InputError("periodic", periodic, "three booleans, one per axis")
    return (bool(flags[0]), bool(flags[1]), bool(flags[2]))


def _validated_alert(alert) -> float:
    try:
        value = float(alert)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and value >= 0.0):
        raise InputError("alert", alert, "a finite distance >= 0 in m")
    return value


def cell_grid(
    length: np.ndarray, cut_off: float, periodic: tuple[bool, bool, bool], n_bodies: int
) -> np.ndarray:
    """Cells per axis (3,) for a box of edge lengths ``length`` [m] and the largest pair
    cut-off ``cut_off`` = 2 r_max + alert [m]; see the module docstring, step 1.

    Raises :class:`InputError` when a periodic axis is shorter than 3 cut-offs.
    """
    for axis in range(3):
        if periodic[axis] and not length[axis] >= 3.0 * cut_off:
            raise InputError(
                f"hi[{axis}]", f"a periodic box {length[axis]:g} m long",
                f"a periodic axis at least 3 cells long, 3 (2 r_max + alert) = "
                f"{3.0 * cut_off:g} m",
            )
    floor_cells = np.array([3 if p else 1 for p in periodic])
    max_cells = max(27, 4 * n_bodies)
    # 1e-9 of slack: a centre rounded into the next cell still finds its partners
    size = cut_off * (1.0 + 1e-9) if cut_off > 0.0 else float(length.max())
    while True:
        shape = np.maximum(np.floor(length / size), floor_cells).astype(np.int64)
        if int(np.prod(shape)) <= max_cells:
            return shape
        size *= 1.01 * (float(np.prod(shape)) / max_cells) ** (1.0 / 3.0)


class CellListBroadPhase:
    """Cell-list broad phase with an alert distance (module docstring: algorithm, restriction).

    Parameters
    ----------
    alert:
        Alert distance [m], >= 0: pairs with |x_i - x_j| <= r_i + r_j + alert are candidates.
    periodic:
        One bool per axis; periodic axes use the minimum image and must be at least
        3 (2 r_max + alert) long.
    capacity:
        Initial rows of the output buffer (>= 1); it grows when a call needs more.

    The same object is meant to be called every step: its output buffer is kept, so it grows
    only a few times over a run (:attr:`n_regrowths`).
    """

    def __init__(
        self,
        alert: float,
        periodic: tuple[bool, bool, bool] = (False, False, False),
        capacity: int = 1024,
    ) -> None:
        self.alert = _validated_alert(alert)
        self.periodic = _validated_periodic(periodic)
        if isinstance(capacity, bool) or not isinstance(capacity, int | np.integer) \
                or capacity < 1:
            raise InputError("capacity", capacity, "an integer >= 1 (rows)")
        self._pairs = np.empty((int(capacity), 2), dtype=np.int64)
        self._n_regrowths = 0
        self._statistics: BroadPhaseStatistics | None = None

    @property
    def capacity(self) -> int:
        """Rows of the output buffer now."""
        return int(self._pairs.shape[0])

    @property
    def n_regrowths(self) -> int:
        """Times the output buffer was grown since construction."""
        return self._n_regrowths

    @property
    def statistics(self) -> BroadPhaseStatistics:
        """Grid, counts and buffer of the last :meth:`find_pairs` call."""
        if self._statistics is None:
            raise GrainlabError(
                "CellListBroadPhase.statistics is not available: call find_pairs first."
            )
        return self._statistics

    def find_pairs(self, centres, radii, lo, hi) -> np.ndarray:
        """Candidate pairs, shape (P, 2) int64, i < j in each row, rows sorted lexicographically.

        Parameters
        ----------
        centres:
            Body centres [m], shape (N, 3), finite; they may lie outside [lo, hi].
        radii:
            Bounding radii [m], shape (N,), >= 0.
        lo, hi:
            Box corners [m], shape (3,), hi > lo on every axis.
        """
        centres, radii, lo, hi = _validated(centres, radii, lo, hi)
        n_bodies = centres.shape[0]
        length = hi - lo
        r_max = float(radii.max()) if n_bodies else 0.0
        shape = cell_grid(length, 2.0 * r_max + self.alert, self.periodic, n_bodies)
        width = length / shape
        periodic = np.array(self.periodic, dtype=np.bool_)
        n_pairs = 0
        if n_bodies > 1:
            n_cells = int(np.prod(shape))
            cell_of = np.empty(n_bodies, dtype=np.int64)
            cell_start = np.empty(n_cells + 1, dtype=np.int64)
            order = np.empty(n_bodies, dtype=np.int64)
            sorted_centres = np.empty((n_bodies, 3), dtype=np.float64)
            sorted_radii = np.empty(n_bodies, dtype=np.float64)
            bin_bodies_kernel(
                centres, radii, lo, length, width, shape, periodic,
                cell_of, cell_start, order, sorted_centres, sorted_radii,
            )
            counts = np.empty(n_bodies + 1, dtype=np.int64)
            while True:
                n_pairs = candidate_pairs_kernel(
                    sorted_centres, sorted_radii, order, cell_of, cell_start, shape, length,
                    periodic, self.alert, counts, self._pairs,
                )
                if n_pairs <= self.capacity:
                    break
                self._pairs = np.empty((math.ceil(_GROWTH * n_pairs), 2), dtype=np.int64)
                self._n_regrowths += 1
        calls = 1 if self._statistics is None else self._statistics.n_calls + 1
        self._statistics = BroadPhaseStatistics(
            cell_shape=(int(shape[0]), int(shape[1]), int(shape[2])),
            cell_width=(float(width[0]), float(width[1]), float(width[2])),
            n_cells=int(np.prod(shape)), n_bodies=n_bodies, n_pairs=int(n_pairs),
            capacity=self.capacity, n_regrowths=self._n_regrowths, n_calls=calls,
        )
        return self._pairs[:n_pairs].copy()


# --------------------------------------------------------------------------------------------
# Slow, obviously right twin (STYLE.md 12) -- for tests
# --------------------------------------------------------------------------------------------


def all_pairs(centres, radii, alert, lo, hi, periodic=(False, False, False)) -> np.ndarray:
    """Candidate pairs by testing every pair, O(N^2) in NumPy: the twin of
    :meth:`CellListBroadPhase.find_pairs` (same arguments, same sorted (P, 2) output)."""
    centres, radii, lo, hi = _validated(centres, radii, lo, hi)
    alert = _validated_alert(alert)
    flags = np.array(_validated_periodic(periodic))
    length = hi - lo
    rows = []
    for i in range(centres.shape[0] - 1):
        d = centres[i + 1:] - centres[i]
        d = np.where(flags, d - length * np.rint(d / length), d)
        cut = radii[i] + radii[i + 1:] + alert
        js = i + 1 + np.flatnonzero(
            d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2] <= cut * cut)
        rows.append(np.column_stack((np.full(js.size, i), js)))
    if not rows:
        return np.empty((0, 2), dtype=np.int64)
    return np.concatenate(rows).astype(np.int64)
