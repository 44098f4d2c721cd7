"""The engine benchmarks of an earlier commit against the working tree, alternated in one run.

Speeds on a shared two-core machine drift by tens of percent from one minute to the next, so
a before/after pair is only evidence when both sides run in turn, in one script run. This
script checks the earlier commit ``REV`` out in a temporary worktree, runs each benchmark
below on it and on the working tree one after the other, ``--rounds`` times, each side with
its own sources first on ``PYTHONPATH`` (the same interpreter and packages), and prints every
round's figure, the medians, their ratio (working tree / REV; above 1 is faster) and the
spread of each side. A side whose benchmark fails (an earlier benchmark that no longer runs)
prints ``failed`` with the last line of its error. The first round of a side compiles its
kernels (cached for the next rounds): it is run once untimed first.

* ``dem_spheres``: :mod:`benchmark_engine_soft_contact` (1000 spheres, particle-steps/s);
* ``dem_polyhedra``: :mod:`benchmark_engine_soft_polyhedra` (100 polyhedra, n_f 30,
  sub-steps/s; compare the sub-step column too, it depends on the stability bound);
* ``cd_coloured``: :mod:`benchmark_engine_contact_dynamics` (1000 spheres, coloured sweeps,
  two threads, contact updates per second).

    .venv/bin/python benchmarks/benchmark_engine_before_after.py ce146a7 --rounds 4

A benchmark that was mended after ``REV`` (it read a private attribute that later went) runs
on ``REV`` with ``--mend COMMIT``: that commit's changes under ``benchmarks/`` are applied to
the earlier tree first (the engine's sources stay ``REV``'s), and the script says so::

    .venv/bin/python benchmarks/benchmark_engine_before_after.py 0977605 --mend 7c65376
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

BENCHMARKS = {
    "dem_spheres": (["benchmark_engine_soft_contact.py", "--sides", "10", "--steps", "20"],
                    lambda words: words[0] == "1000" and len(words) == 7, -2),
    "dem_polyhedra": (["benchmark_engine_soft_polyhedra.py", "--steps", "10"],
                      lambda words: words[:2] == ["100", "30"], -2),
    "cd_coloured": (["benchmark_engine_contact_dynamics.py", "1000"],
                    lambda words: words[:3] == ["1000", "coloured", "2"], 12),
}
"""name: (the benchmark and its arguments, the test picking its line, the figure's column)."""


def figure(tree: Path, name: str) -> float | str:
    """One run of benchmark ``name`` on the sources of ``tree``: its figure, or why not."""
    arguments, picked, column = BENCHMARKS[name]
    environ = dict(os.environ, PYTHONPATH=str(tree / "src"))
    done = subprocess.run([sys.executable, str(tree / "benchmarks" / arguments[0]),
                           *arguments[1:]], capture_output=True, text=True, env=environ,
                          cwd=tree, timeout=900)
    for line in done.stdout.splitlines():
        words = line.split()
        if words and picked(words):
            return float(words[column])
    last = (done.stderr.strip().splitlines() or ["no figure printed"])[-1]
    return f"failed ({last})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", help="the earlier commit (a name git knows)")
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--only", nargs="+", choices=sorted(BENCHMARKS), default=None)
    parser.add_argument("--mend", nargs="+", default=[], metavar="COMMIT",
                        help="later commits whose benchmarks/ changes the earlier tree takes")
    args = parser.parse_args()
    names = args.only or list(BENCHMARKS)
    with tempfile.TemporaryDirectory() as scratch:
        before = Path(scratch) / "before"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q",
                        str(before), args.rev], check=True)
        try:
            for commit in args.mend:
                patch = subprocess.run(["git", "-C", str(ROOT), "diff", f"{commit}^", commit,
                                        "--", "benchmarks"], check=True, capture_output=True,
                                       text=True).stdout
                subprocess.run(["git", "-C", str(before), "apply"], input=patch, text=True,
                               check=True)
                print(f"{args.rev} runs the benchmarks as mended by {commit}", flush=True)
            sides = {args.rev: before, "working tree": ROOT}
            for name in names:
                for tree in sides.values():  # compile, untimed
                    figure(tree, name)
                runs: dict[str, list] = {side: [] for side in sides}
                for k in range(args.rounds):
                    for side, tree in sides.items():
                        runs[side].append(figure(tree, name))
                        value = runs[side][-1]
                        shown = f"{value:.4g}" if isinstance(value, float) else value
                        print(f"{name:14s} round {k + 1} {side:>14s}: {shown}", flush=True)
                numbers = {side: [v for v in values if isinstance(v, float)]
                           for side, values in runs.items()}
                if all(numbers.values()):
                    medians = {side: statistics.median(v) for side, v in numbers.items()}
                    spread = "; ".join(f"{side} {min(v):.4g}..{max(v):.4g}"
                                       for side, v in numbers.items())
                    print(f"{name:14s} medians " + ", ".join(
                        f"{side} {m:.4g}" for side, m in medians.items())
                        + f"; ratio {medians['working tree'] / medians[args.rev]:.3f}"
                        + f" ({spread})", flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                            str(before)], check=False)


if __name__ == "__main__":
    main()
