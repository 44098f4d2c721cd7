"""Benchmark: the cell-list broad phase on N = 10^3, 10^4, 10^5 polydisperse spheres.

Radii are uniform in [r, 2 r] (r = 1 mm), centres uniform in a cube sized so that the packing
fraction (sum of sphere volumes / box volume) is 0.6 (overlaps allowed), alert distance 0.1 r,
walled box. Prints, per N, the median time of one ``find_pairs`` call (the output buffer is
already grown: the steady state of a run), the candidate pairs, the pairs per body and the
bodies per second; the time per body should stay near constant (linear growth).

    .venv/bin/python benchmarks/benchmark_engine_broad_phase.py [N ...]
"""

from __future__ import annotations

import statistics
import sys
import time

import numba
import numpy as np

from grainlab.engine.detect.broad_phase import CellListBroadPhase

PACKING_FRACTION = 0.6
R_MIN = 1e-3  # m


def spheres(n: int, seed: int = 0):
    """Centres (n, 3), radii (n,) and box corners of n random spheres at the packing fraction."""
    rng = np.random.default_rng(seed)
    radii = rng.uniform(R_MIN, 2.0 * R_MIN, n)
    side = (4.0 / 3.0 * np.pi * np.sum(radii**3) / PACKING_FRACTION) ** (1.0 / 3.0)
    centres = rng.random((n, 3)) * side
    return centres, radii, np.zeros(3), np.full(3, side)


def main(sizes: list[int]) -> None:
    broad_phase = CellListBroadPhase(alert=0.1 * R_MIN)
    broad_phase.find_pairs(*spheres(10))  # compile (or load the cache) outside the timing
    print(f"cell-list broad phase, {numba.get_num_threads()} threads "
          f"({numba.threading_layer()} layer), packing fraction {PACKING_FRACTION}, "
          f"radii U[r, 2r], alert 0.1 r")
    print(f"{'N':>8} {'cells':>8} {'ms/call':>9} {'pairs':>9} {'pairs/body':>10} "
          f"{'bodies/s':>10} {'ns/body':>8}")
    for n in sizes:
        centres, radii, lo, hi = spheres(n)
        pairs = broad_phase.find_pairs(centres, radii, lo, hi)  # grow the buffer once
        repeats = max(5, int(2e6 // n))
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            broad_phase.find_pairs(centres, radii, lo, hi)
            times.append(time.perf_counter() - start)
        t = statistics.median(times)
        print(f"{n:>8} {broad_phase.statistics.n_cells:>8} {1e3 * t:>9.3f} {len(pairs):>9} "
              f"{len(pairs) / n:>10.2f} {n / t:>10.3g} {1e9 * t / n:>8.0f}")


if __name__ == "__main__":
    main([int(float(a)) for a in sys.argv[1:]] or [1_000, 10_000, 100_000])
