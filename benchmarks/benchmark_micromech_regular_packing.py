"""Benchmark: seed 000's regular-packing theory — seconds per lab test and per alpha sweep.

Prints, for each named packing, the time of the power tessellation, of one rotated stress path
(isotropic loading + path to failure or to sigma_1/sigma_3 = 10, modified Hertz–Mindlin law),
its number of increments and Newton iterations, and the time of a 7-direction alpha sweep.

    .venv/bin/python benchmarks/benchmark_micromech_regular_packing.py
"""

from __future__ import annotations

import time

import numpy as np

from grainlab.contact import ModifiedHertzMindlin2D
from grainlab.geometry import power_tessellation
from grainlab.micromech import RegularPackingModel, RotatedStressPath, run_rotated_stress_path
from grainlab.micromech.regular_packing import run_alpha_sweep
from grainlab.prep.regular_packings import named_packing, packing_names


def best_of(repeats: int, function) -> tuple[float, object]:
    """Smallest wall time [s] of ``repeats`` calls, and the last return value."""
    best, value = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        value = function()
        best = min(best, time.perf_counter() - start)
    return best, value


def main() -> None:
    law = ModifiedHertzMindlin2D.seed000()
    # Warm-up (imports, any compilation) outside the timings.
    run_rotated_stress_path(
        RegularPackingModel(named_packing("C"), law), RotatedStressPath(alpha=0.3, max_ratio=1.2)
    )
    print(f"{'packing':>10} {'tessellation ms':>16} {'test s':>8} {'increments':>10} "
          f"{'iterations':>10} {'increments/s':>13} {'sweep (7 alphas) s':>19}")
    for name in packing_names():
        packing = named_packing(name)
        t_tess, _ = best_of(5, lambda p=packing: power_tessellation(p))
        model = RegularPackingModel(packing, law)
        path = RotatedStressPath(alpha=np.radians(30.0))
        t_test, result = best_of(3, lambda m=model, p=path: run_rotated_stress_path(m, p))
        increments = len(result.table) - 1
        iterations = int(result.table["iterations"].sum())
        t_sweep, _ = best_of(1, lambda m=model, p=path: run_alpha_sweep(
            m, np.radians(np.arange(0, 91, 15)), p))
        print(f"{name:>10} {1e3 * t_tess:16.2f} {t_test:8.3f} {increments:10d} {iterations:10d} "
              f"{increments / t_test:13.0f} {t_sweep:19.2f}")


if __name__ == "__main__":
    main()
