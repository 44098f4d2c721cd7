"""Benchmark: the cost of the sphere triaxial test per particle-step as the sample grows
(``grainlab triaxial`` defaults, contact dynamics), and where its growth comes from.

The same test as ``benchmark_lab_triaxial.py`` (seed 002's protocol: frictionless isotropic
compaction to sigma0 = 10 kPa, ended on YADE's criterion, then mu = 0.4 to the eps_q
target) on each sample size, one after the other on the same thread count. For each size and
stage it prints the wall time, the steps, the cost per particle-step [us] (wall time / (steps x
N)), the sweeps a step, the contact rows per particle and the time per contact update [ns];
then each size's ratios to the first size. The cost per particle-step is the product of the
three: sweeps a step x rows per particle x time per update (plus the detection and the
step's other passes), so the ratios say which of them grows.

Target printed: the whole test's cost per particle-step on the largest sample within 1.5
times the first's; the script exits with status 1 when it is missed.

    .venv/bin/python benchmarks/benchmark_lab_triaxial_scaling.py [--sizes 1000 10000]
        [--eps-q 0.05] [--threads 2]

10 000 spheres take ~35 min to eps_q = 0.05 on a 2-core machine (2 threads).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numba
from benchmark_lab_triaxial import stage_costs, timed_run

WARM_UP_SPHERES = 100
"""A short test on this many spheres runs first: the kernels are then loaded (or compiled)
before any measured run."""
TARGET_RATIO = 1.5
"""The largest ratio of the largest sample's cost per particle-step to the first's."""


def measure(n: int, eps_q: float, folder: Path) -> dict:
    """Per stage and for the whole test: seconds, steps, us per particle-step, sweeps a
    step, rows per particle, ns per contact update; and the run's mechanics."""
    result, total, compaction_time = timed_run(n, eps_q, folder, float("inf"))
    costs = stage_costs(result, total, compaction_time)
    for cost in costs.values():
        cost["us per particle-step"] = 1e6 * cost["seconds"] / (cost["steps"] * n)
        cost["rows per particle"] = cost["contacts"] / n
        cost["ns per update"] = 1e9 / cost["updates per second"]
    steps = sum(cost["steps"] for cost in costs.values())
    costs["whole test"] = {"seconds": total, "steps": steps,
                           "us per particle-step": 1e6 * total / (steps * n)}
    stages = result.metadata["outcome"]["stages"]
    table = result.table
    mechanics = {
        "capped share (compaction, shear)": ", ".join(
            f"{stage['capped_steps'] / max(stage['steps'], 1):.1%}" for stage in stages),
        "packing fraction after compaction":
            f"{table[table['stage'] == 'compaction']['packing_fraction'].iloc[-1]:.4f}",
        "peak q/p": f"{table[table['stage'] != 'compaction']['q_over_trace'].max():.3f}",
        "max overlap / <d>": f"{table['max_overlap_over_d'].max():.4f}",
    }
    return {"costs": costs, "mechanics": mechanics}


def show(n: int, measured: dict) -> None:
    print(f"{n} spheres:")
    for name, cost in measured["costs"].items():
        line = (f"  {name}: {cost['seconds']:.1f} s, {cost['steps']} steps, "
                f"{cost['us per particle-step']:.2f} us per particle-step")
        if "sweeps" in cost:
            line += (f", {cost['sweeps']:.0f} sweeps a step, {cost['rows per particle']:.2f} "
                     f"rows per particle, {cost['ns per update']:.1f} ns per update")
        print(line, flush=True)
    for key, value in measured["mechanics"].items():
        print(f"  {key}: {value}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--eps-q", type=float, default=0.05, help="eps_q target [0.05]")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    numba.set_num_threads(args.threads)
    print(f"triaxial test to eps_q = {args.eps_q}, sizes {args.sizes}, numba threads "
          f"{args.threads} ({numba.threading_layer()})", flush=True)
    measured = {}
    with tempfile.TemporaryDirectory() as tmp:
        # the kernels loaded (or compiled) first, so that no size pays for them
        timed_run(WARM_UP_SPHERES, 0.01, Path(tmp) / "warm-up", float("inf"))
        for n in args.sizes:
            measured[n] = measure(n, args.eps_q, Path(tmp) / f"n{n}")
            show(n, measured[n])
    first = args.sizes[0]
    base = measured[first]["costs"]
    for n in args.sizes[1:]:
        print(f"{n} / {first} spheres, ratios:")
        for name, cost in measured[n]["costs"].items():
            parts = []
            for key in ("us per particle-step", "sweeps", "rows per particle", "ns per update"):
                if key in cost:
                    parts.append(f"{key.removeprefix('us ')} {cost[key] / base[name][key]:.2f}")
            print(f"  {name}: " + ", ".join(parts), flush=True)
    last = args.sizes[-1]
    ratio = (measured[last]["costs"]["whole test"]["us per particle-step"]
             / base["whole test"]["us per particle-step"])
    verdict = "met" if ratio <= TARGET_RATIO else "missed"
    print(f"target, {last} spheres: cost per particle-step within {TARGET_RATIO:g} x "
          f"the {first}-sphere run's: {verdict} ({ratio:.2f})")
    if verdict == "missed":  # a missed target is not a passed benchmark
        raise SystemExit("1 of 1 targets missed")


if __name__ == "__main__":
    main()
