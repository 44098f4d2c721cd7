"""Benchmark: the solvers of the plain frictional contact problem on the same stored problems,
in time and iterations to a given natural-map error (Acary, Brémond & Huber 2018).

The problems are FCLib files given on the command line, or stored from a grainlab triaxial
test made here (``--n`` spheres, compaction then shear to ``--eps-q``, every ``--every``-th
step's problem kept with ``output.problems_every``). Each problem is solved from zero impulses
by every method of :mod:`grainlab.engine.nscd.plain_problem_methods` with the same cap; the script
prints,
per stage and method, how many problems reached each error level, the median iterations and
seconds to get there, the error at the cap, and how many problems the method diverged on
(:class:`~grainlab.errors.SolverDivergence`); then the error the engine's own step had reached
(the stored solution).

    .venv/bin/python benchmarks/benchmark_plain_problem_methods.py [--n 300] [--eps-q 0.01]
        [--every 50] [--cap 2000] [FCLIB_FILE ...]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from grainlab.engine.nscd.contact_problem import natural_map_error, read_fclib
from grainlab.engine.nscd.plain_problem_methods import METHODS, solve
from grainlab.errors import SolverDivergence
from grainlab.lab.discrete_run import PROBLEMS, start_run
from grainlab.lab.run_config import RunConfig

LEVELS = (1e-3, 1e-4, 1e-5, 1e-6)


def stored_problems(n: int, eps_q: float, every: int, folder: Path) -> list[Path]:
    config = RunConfig.model_validate({
        "sample": {"n_particles": n}, "test": {"kind": "triaxial", "eps_q_max": eps_q},
        "output": {"checkpoint_every": 0, "snapshot_every": 0, "problems_every": every}})
    run = start_run(folder, config, overwrite=True)
    result = run.run()
    print(f"grainlab triaxial, {n} spheres to eps_q = {eps_q}: "
          f"{result.metadata['outcome']['steps']} steps")
    return sorted((folder / PROBLEMS).glob("*.hdf5"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="*", type=Path)
    parser.add_argument("--n", type=int, default=300)
    parser.add_argument("--eps-q", type=float, default=0.01)
    parser.add_argument("--every", type=int, default=50)
    parser.add_argument("--cap", type=int, default=2000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        files = args.files or stored_problems(args.n, args.eps_q, args.every, Path(tmp) / "run")
        stored = [read_fclib(f) for f in files]
    # compile every kernel once on a small problem
    for method in METHODS:
        solve(stored[0].problem, method, max_iterations=2)
    groups: dict[str, list] = {}
    for item in stored:
        mu = item.problem.friction
        kind = "frictional" if mu.size and mu.max() > 0 else "frictionless"
        groups.setdefault(kind, []).append(item)
    for kind, items in groups.items():
        contacts = [i.problem.n_contacts for i in items]
        engine = [natural_map_error(i.problem, i.reactions) for i in items
                  if i.reactions is not None]
        print(f"\n{kind} problems: {len(items)} ({min(contacts)}-{max(contacts)} contacts); "
              f"the engine's stored solutions: natural-map error median "
              f"{np.median(engine):.2e}, max {np.max(engine):.2e}")
        header = "  ".join(f"to {level:.0e}: n / it / ms".ljust(26) for level in LEVELS)
        print(f"{'method':8s} {header}  error at cap {args.cap} (median)")
        for method in METHODS:
            reached = {level: [] for level in LEVELS}
            finals = []
            diverged = 0
            for item in items:
                try:
                    solution = solve(item.problem, method, tolerance=min(LEVELS),
                                     max_iterations=args.cap)
                except SolverDivergence:
                    diverged += 1
                    continue
                per_iteration = solution.seconds / max(solution.iterations, 1)
                for level in LEVELS:
                    hit = np.flatnonzero(solution.errors <= level)
                    if hit.size:
                        reached[level].append((hit[0] + 1, (hit[0] + 1) * per_iteration))
                finals.append(solution.error)
            cells = []
            for level in LEVELS:
                got = reached[level]
                if got:
                    its = np.median([g[0] for g in got])
                    ms = 1e3 * np.median([g[1] for g in got])
                    cells.append(f"{len(got):3d} / {its:6.0f} / {ms:7.1f}".ljust(26))
                else:
                    cells.append(f"{0:3d} / {'-':>6s} / {'-':>7s}".ljust(26))
            final = f"{np.median(finals):.2e}" if finals else "-"
            print(f"{method:8s} {'  '.join(cells)}  {final:>8s}  {diverged}")


if __name__ == "__main__":
    main()
