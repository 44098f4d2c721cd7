"""Benchmark: a preset study (seed 002's angularity or seed 003's non-convexity series) run,
or resumed, in a folder; prints each sample's wall time and steps, the study's total, and the
residual values next to the papers' trends (the study's summary.csv).

    .venv/bin/python benchmarks/benchmark_study.py SERIES FOLDER [-n N] [--length short|full]
        [--workers K]

A study resumes across interruptions, so a long one may span several runs of this script:
each run prints the whole study as it stands.
"""

from __future__ import annotations

import argparse
import math
import time

from grainlab.report.study_report import PAPERS, write_study_report
from grainlab.study.series_presets import series_spec
from grainlab.study.study_runner import Study
from grainlab.study.study_summary import study_summary

SHOWN = (("q_over_trace_peak", "(q/p)+"), ("q_over_trace_residual", "(q/p)*"),
         ("packing_fraction_initial", "nu0"), ("packing_fraction_residual", "nu*"),
         ("z_initial", "z0"), ("z_c_initial", "z_c0"), ("z_residual", "z*"),
         ("z_c_residual", "z_c*"), ("sliding_proportion_residual", "S*"),
         ("a_c_residual", "a_c*"))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("series", choices=("angularity", "nonconvexity"))
    parser.add_argument("folder")
    parser.add_argument("-n", type=int, default=None)
    parser.add_argument("--length", default="short")
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args()
    spec = series_spec(args.series, n_particles=args.n, length=args.length)
    study = Study.create(args.folder, spec)
    start = time.perf_counter()
    try:
        outcome = study.run(workers=args.workers, progress=True)
        print(outcome.summary())
    except KeyboardInterrupt:
        print("interrupted: run this script again to go on")
    print(f"this run of the script: {time.perf_counter() - start:.0f} s")
    table = study_summary(study)
    if not len(table):
        return
    write_study_report(study, table)
    print(f"\n{'sample':8s} {spec.symbol:>8s} {'wall s':>8s} {'steps':>7s} {'capped':>7s} "
          + " ".join(f"{label:>7s}" for _, label in SHOWN))
    for _, row in table.iterrows():
        values = " ".join(f"{row.get(c, math.nan):7.3f}" for c, _ in SHOWN)
        print(f"{row['name']:8s} {row['measured']:8.3f} {row['wall_time']:8.0f} "
              f"{row['steps']!s:>7} {row['capped_share']:7.0%} {values}")
    print(f"total wall time of the samples: {table['wall_time'].sum():.0f} s "
          f"({len(table)} of {len(spec.samples)} samples ended)")
    print("\nthe papers: " + PAPERS[spec.study.parameter])


if __name__ == "__main__":
    main()
