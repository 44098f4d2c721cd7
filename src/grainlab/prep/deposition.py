"""A dense sphere packing built by geometric sequential deposition on a floor (seeds 002 and
003, §II: "a layer-by-layer construction model based on simple geometrical rules ... each new
particle is supported by three particles"; "the particles are deposited sequentially on a
substrate").

The construction is the drop-and-roll of Visscher & Bolsterli (Nature 239, 504, 1972) and
Jodrey & Tory (Simulation 32, 1, 1979), in a box of four side walls and a floor, open at the
top. Spheres are deposited in the order of ``radii`` (drawn at random: the order is random).
Each is dropped at a uniformly random (x, y) and moves by steepest descent of its height
under its contacts: it falls vertically until it touches a sphere or the floor, rolls down on
one sphere until it touches a second (or falls again past the support's equator), rolls
down the circle of two supports until it touches a third (or leaves one of them), and stays
where the vertical through its centre passes inside the triangle of its three contact points
(the weight in the cone of the three contact normals). Walls are supports like spheres (a
plane); a sphere that touches the floor stays there. Details, events and the status of each
sphere: :mod:`grainlab.prep.deposition_kernels`.

This rule gives the stable position reached from the drop point by descent, a local minimum
of the height, not the lowest of all the three-support positions near the drop (seed 002's
words, "a position of lowest gravitational potential energy so that each new particle is
supported by three particles", fit both); it is the classic construction, whose bulk packing
fraction for equal spheres is ~0.58 (Visscher & Bolsterli: 0.582).

Measured (:func:`core_packing_fraction` of the box 2 d_max away from the walls, the floor
and the top; :func:`deposited_packing` with height_ratio 1, three seeds): equal spheres
0.586 +- 0.003 (10^3 spheres) and 0.575 +- 0.004 (10^4); seed 002's sizes (d uniform by
volume in [d_min, 2 d_min]) 0.587 +- 0.002 and 0.589 +- 0.002; seed 003's (R uniform by
volume in [R_min, 3 R_min]) 0.606 +- 0.006 and 0.605 +- 0.001. Over the whole box (walls and
the rough top included) 0.45-0.52. About 92-97 % of the spheres rest on three supports, the
others on the floor.

Cost. A cell grid over x, y, z (cells >= 2 r_max): each placement reads O(1) spheres, so the
deposition is linear in N (``checks``: distance evaluations per sphere: 283, 305 for 10^4,
10^5 spheres of seed 002's sizes); one thread, the same result for a seed on every machine.
Measured (2-core VM, compiled): 10^3 spheres 0.015 s, 10^4 0.14-0.18 s, 10^5 1.9 s; the
first call in a fresh install compiles the kernel (~15 s, then cached). The grid is sized
from the spheres' volume and, when a sphere rests above it, grown and the deposition redone
(STYLE.md 8).

>>> packing = deposit_spheres(np.full(50, 5e-4), 5e-3, 5e-3, np.random.default_rng(1))
>>> packing.centres.shape, bool(packing.side[2] > 0), int(packing.status.max()) <= 2
((50, 3), True, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grainlab._validate import at_least
from grainlab._validate import seed as check_seed
from grainlab.errors import InputError
from grainlab.prep.deposition_kernels import (
    OVERLAP,
    RESTED_ON_FLOOR,
    RESTED_ON_THREE,
    RESTED_ON_TWO,
    UNSETTLED,
    deposit_kernel,
)
from grainlab.prep.loose_sample import checked_sizes, diameters_uniform_by_volume
from grainlab.prep.sphere_skeleton import SphereSkeleton

MAX_MOVES = 200
"""Most moves (fall, roll on one, roll on two, a support dropped) a sphere may take; a sphere
that runs out keeps its position, without overlap (status UNSETTLED)."""

PACKING_GUESS = 0.58
"""Packing fraction that sizes the box of :func:`deposited_packing` (the deposition's, for
equal spheres)."""


@dataclass(frozen=True)
class DepositedPacking:
    """A deposited sphere packing in the box [0, side] (module docstring).

    Attributes
    ----------
    centres, radii:
        (N, 3) and (N,) [m], in the order of deposition.
    side:
        (3,) [m]: the box's width L_x, depth L_y and the packing's height max(z + r).
    supports:
        (N, 3) the supports each sphere rests on: a sphere index, or
        :data:`~grainlab.prep.deposition_kernels.FLOOR`, a wall code, ``NO_SUPPORT``.
    checks:
        (N,) distance evaluations of each placement (the cost, linear in N).
    status:
        (N,) how each sphere came to rest (:mod:`grainlab.prep.deposition_kernels`: 0 on three
        supports, 1 on the floor, 2 on two, 3 moves exhausted).
    """

    centres: np.ndarray
    radii: np.ndarray
    side: np.ndarray
    supports: np.ndarray
    checks: np.ndarray
    status: np.ndarray

    @property
    def skeleton(self) -> SphereSkeleton:
        """The spheres and their box as a :class:`~grainlab.prep.sphere_skeleton.
        SphereSkeleton`."""
        return SphereSkeleton(self.centres, self.radii, np.zeros(3), self.side.copy())

    @property
    def packing_fraction(self) -> float:
        """Sphere volume over the box's volume [-] (walls, floor and the rough top
        included: below the bulk value)."""
        return float(np.sum(4.0 / 3.0 * np.pi * self.radii**3) / np.prod(self.side))

    def status_counts(self) -> dict[str, int]:
        """How many spheres rest on three supports, the floor, two supports, or ran out of
        moves."""
        names = {RESTED_ON_THREE: "three", RESTED_ON_FLOOR: "floor", RESTED_ON_TWO: "two",
                 UNSETTLED: "unsettled"}
        return {name: int(np.count_nonzero(self.status == code))
                for code, name in names.items()}


def core_packing_fraction(centres: np.ndarray, radii: np.ndarray, lower: np.ndarray,
                          upper: np.ndarray, lattice: int = 16) -> float:
    """Solid fraction [-] of the box [lower, upper] (3,) [m]: the spheres' volume inside it,
    exact for the spheres wholly in or out, and from a cubic lattice of ``lattice`` ^ 3 points
    in the unit cube (those in the unit ball) for the spheres the box's faces cut (about
    1 % of such a sphere's volume)."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    inside = np.all(centres - radii[:, None] >= lower, axis=1) & \
        np.all(centres + radii[:, None] <= upper, axis=1)
    outside = np.any(centres + radii[:, None] <= lower, axis=1) | \
        np.any(centres - radii[:, None] >= upper, axis=1)
    volume = float(np.sum(4.0 / 3.0 * np.pi * radii[inside] ** 3))
    axis = (np.arange(lattice) + 0.5) / lattice * 2.0 - 1.0
    points = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    points = points[np.einsum("ij,ij->i", points, points) <= 1.0]
    cut = np.flatnonzero(~inside & ~outside)
    for start in range(0, cut.size, 256):
        rows = cut[start:start + 256]
        x = centres[rows, None, :] + radii[rows, None, None] * points[None]
        share = np.mean(np.all((x >= lower) & (x <= upper), axis=2), axis=1)
        volume += float(np.sum(share * 4.0 / 3.0 * np.pi * radii[rows] ** 3))
    return volume / float(np.prod(upper - lower))


def deposit_spheres(radii: np.ndarray, width: float, depth: float, rng: np.random.Generator,
                    max_moves: int = MAX_MOVES) -> DepositedPacking:
    """Deposit spheres of ``radii`` (N,) [m], in this order, in a box ``width`` x ``depth``
    [m] with a floor (module docstring); the drop points come from ``rng`` (2 N uniform
    numbers). Raises :class:`InputError` for a box narrower than the largest sphere and
    ``RuntimeError`` if a sphere ends overlapping another (a fault of the kernel)."""
    r = np.ascontiguousarray(radii, dtype=np.float64)
    if r.ndim != 1 or r.size == 0 or not np.all(np.isfinite(r)) or np.any(r <= 0.0):
        raise InputError("radii", "array", "a 1-D array of positive radii in m")
    lx = at_least("width", width)
    ly = at_least("depth", depth)
    r_max = float(r.max())
    for name, side in (("width", lx), ("depth", ly)):
        if side <= 2.0 * r_max * (1.0 + 1e-9):
            raise InputError(name, side, f"a box wider than the largest sphere "
                                         f"({2.0 * r_max:g} m)")
    drops = rng.random((r.size, 2))
    cell = 2.0 * r_max
    nx, ny = max(1, int(lx // cell)), max(1, int(ly // cell))
    widths = np.array([lx / nx, ly / ny, cell])
    height = float(np.sum(4.0 / 3.0 * np.pi * r**3)) / (lx * ly * 0.3) + 4.0 * cell
    nz = max(2, math.ceil(height / cell))
    centres = np.zeros((r.size, 3))
    supports = np.zeros((r.size, 3), dtype=np.int64)
    checks = np.zeros(r.size, dtype=np.int64)
    status = np.zeros(r.size, dtype=np.int64)
    nxt = np.zeros(r.size, dtype=np.int64)
    while True:
        shape = np.array([nx, ny, nz], dtype=np.int64)
        head = np.empty(nx * ny * nz, dtype=np.int64)
        top_layer = np.empty(nx * ny, dtype=np.int64)
        above = deposit_kernel(r, drops, lx, ly, widths, shape, int(max_moves), centres,
                               supports, checks, status, head, nxt, top_layer)
        if above < 0:
            break
        nz *= 2  # a sphere rested above the grid: grow it and deposit again
    if np.any(status == OVERLAP):
        raise RuntimeError(f"deposition: sphere {int(np.argmax(status == OVERLAP))} "
                           "overlaps a neighbour")
    side = np.array([lx, ly, float(np.max(centres[:, 2] + r))])
    return DepositedPacking(centres, r.copy(), side, supports, checks, status)


def deposited_packing(*, n_particles: int, d_min: float, size_ratio: float = 2.0,
                      height_ratio: float = 1.0, seed: int | np.random.Generator = 0
                      ) -> DepositedPacking:
    """``n_particles`` spheres of diameters uniform by volume in [d_min, size_ratio d_min]
    [m] (:func:`~grainlab.prep.loose_sample.diameters_uniform_by_volume`; seed 002:
    size_ratio 2, seed 003: 3), deposited in a square box whose width is chosen so that the
    packing's height is about ``height_ratio`` times it (at phi ~ :data:`PACKING_GUESS`), at
    least 2.5 d_max. ``seed``: an integer or the generator of the sizes, then the drops."""
    n_particles, d_min, ratio = checked_sizes(n_particles, d_min, size_ratio)
    aspect = at_least("height_ratio", height_ratio)
    rng = seed if isinstance(seed, np.random.Generator) else \
        np.random.default_rng(check_seed("seed", seed))
    radii = 0.5 * diameters_uniform_by_volume(int(n_particles), d_min, ratio * d_min, rng)
    volume = float(np.sum(4.0 / 3.0 * np.pi * radii**3)) / PACKING_GUESS
    width = max((volume / aspect) ** (1.0 / 3.0), 2.5 * ratio * d_min)
    return deposit_spheres(radii, width, width, rng)
