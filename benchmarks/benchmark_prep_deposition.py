"""Benchmark: the layer-by-layer (drop-and-roll) deposition of seeds 002 and 003 at 10^3 to
10^5 spheres; prints seconds, spheres per second, distance checks per sphere (flat when the
cost is linear in N), how the spheres came to rest and the core packing fraction.

    .venv/bin/python benchmarks/benchmark_prep_deposition.py [N ...]
"""

from __future__ import annotations

import sys
import time

import numpy as np

from grainlab.prep.deposition import core_packing_fraction, deposited_packing

SIZES = {"seed 002 (d in [d_min, 2 d_min])": 2.0, "seed 003 (R in [R_min, 3 R_min])": 3.0}


def main() -> None:
    counts = [int(a) for a in sys.argv[1:]] or [1000, 10_000, 100_000]
    deposited_packing(n_particles=50, d_min=1e-3, seed=0)  # compile (cached after)
    print(f"{'sizes':34s} {'N':>7s} {'s':>7s} {'spheres/s':>10s} {'checks/sphere':>13s} "
          f"{'core fraction':>13s}  rest on (three/floor/two/unsettled)")
    for label, ratio in SIZES.items():
        for n in counts:
            start = time.perf_counter()
            packing = deposited_packing(n_particles=n, d_min=1e-3, size_ratio=ratio, seed=1)
            seconds = time.perf_counter() - start
            d_max = 2.0 * float(packing.radii.max())
            lower, upper = np.full(3, 2 * d_max), packing.side - 2 * d_max
            core = core_packing_fraction(packing.centres, packing.radii, lower, upper) \
                if np.all(upper > lower) else float("nan")
            rest = packing.status_counts()
            print(f"{label:34s} {n:7d} {seconds:7.3f} {n / seconds:10.3g} "
                  f"{packing.checks.mean():13.0f} {core:13.3f}  {rest['three']}/"
                  f"{rest['floor']}/{rest['two']}/{rest['unsettled']}")
    print("memory: centres, radii, supports, checks and status: "
          f"{(3 * 8 + 8 + 3 * 8 + 8 + 1)} bytes per sphere, plus the cell grid")


if __name__ == "__main__":
    main()
