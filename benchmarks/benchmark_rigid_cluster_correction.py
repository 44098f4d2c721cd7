"""Benchmark: the two-level correction on rigid clusters against NLGS alone, on the shear
steps of a grainlab triaxial test (:mod:`grainlab.engine.nscd.rigid_clusters`).

A triaxial test of ``--n`` spheres is run to ``--eps-q``; every ``--every``-th step keeps
its constraint system (H, M^-1, q and the bodies' centres) and the frictional ones are
solved from zero impulses, with ``--work`` sweep-equivalents each, by NLGS alone and by
cycles of a coarse correction and smoothing sweeps for several groupings (cubes of a side
in mean nearest-neighbour distances, groups along sticking contacts) and variants (the
coarse change as solved, projected on the groups' motions, with the internal impulses that
keep the groups rigid). It prints, per problem and method, the natural-map error
||F(r)|| / ||q|| after a quarter, half and all of the work, and, for the cycles, the
smoothing sweeps in the whole work and NLGS's error after as many sweeps alone: what the
correction would buy if its coarse solve cost nothing.

    .venv/bin/python benchmarks/benchmark_rigid_cluster_correction.py [--n 1000]
        [--eps-q 0.05] [--every 20] [--work 800]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from grainlab.engine.nscd.plain_problem_methods import solve
from grainlab.engine.nscd.rigid_clusters import (
    ClusterSpace,
    grid_clusters,
    sticking_clusters,
    two_level_solve,
)
from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig


class SystemKeeper:
    """A run hook keeping every ``period``-th step's constraint system and friction."""

    name = "systems"

    def __init__(self, period: int) -> None:
        self.period = period
        self.kept: list = []

    @staticmethod
    def trigger(step_index: int) -> bool:
        return True

    def act(self, simulation) -> None:
        report = simulation.last_report
        if report is not None and getattr(report, "system", None) is not None \
                and report.n_contacts and report.problem.friction.max() > 0.0:
            self.kept.append((report.system, report.problem, report.contacts))
        simulation.solver.keep_problem = (simulation.step_index + 1) % self.period == 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--eps-q", type=float, default=0.05)
    parser.add_argument("--every", type=int, default=20)
    parser.add_argument("--work", type=float, default=800.0)
    parser.add_argument("--problems", type=int, default=2)
    args = parser.parse_args()
    config = RunConfig.model_validate({
        "sample": {"n_particles": args.n},
        "test": {"kind": "triaxial", "eps_q_max": args.eps_q},
        "output": {"checkpoint_every": 0, "snapshot_every": 0}})
    keeper = SystemKeeper(args.every)
    with tempfile.TemporaryDirectory() as tmp:
        run = start_run(Path(tmp) / "run", config)
        run.test.simulation.add(keeper)
        run.run()
    kept = keeper.kept[-args.problems:]
    print(f"grainlab triaxial, {args.n} spheres to eps_q = {args.eps_q}: "
          f"{len(keeper.kept)} frictional steps kept, the last {len(kept)} solved")
    marks = (args.work / 4, args.work / 2, args.work)
    print(f"{'problem':>8} {'method':44s} {'W_c/W':>6} "
          + " ".join(f"{f'{m:.0f} sw-eq':>11}" for m in marks)
          + "  smoothing sweeps / NLGS alone after as many")
    for index, (system, problem, contacts) in enumerate(kept):
        nlgs = solve(problem, "nlgs", tolerance=1e-14, max_iterations=int(args.work))
        print(f"{index:8d} {'NLGS alone':44s} {'':>6} "
              + " ".join(f"{nlgs.errors[int(m) - 1]:11.2e}" for m in marks), flush=True)
        spacing = float(np.mean(cKDTree(system.centres).query(system.centres, 2)[0][:, 1]))
        reference = solve(problem, "nlgs", tolerance=1e-14, max_iterations=400).reactions
        groupings = {
            "cubes of 2.5 d": grid_clusters(system.centres, 2.5 * spacing),
            "cubes of 4 d": grid_clusters(system.centres, 4.0 * spacing),
            "sticking, <= 8 bodies": sticking_clusters(
                contacts.body_i, contacts.body_j, reference, problem.friction,
                system.centres.shape[0], 8)}
        variants = {"as solved": (False, False), "projected": (True, False),
                    "projected + internal": (True, True)}
        for grouping, labels in groupings.items():
            ratio = ClusterSpace.of(system, problem, labels).work_ratio
            for variant, (project, internal) in variants.items():
                history = two_level_solve(system, problem, labels, work_limit=args.work,
                                          project=project, internal=internal)
                errors = [history.errors[np.searchsorted(history.work, m)]
                          if m <= history.work[-1] else history.errors[-1] for m in marks]
                fine = int(history.smoothing[-1])
                print(f"{index:8d} {grouping + ', ' + variant:44s} {ratio:6.2f} "
                      + " ".join(f"{e:11.2e}" for e in errors)
                      + f"  {fine:5d} / {nlgs.errors[min(fine, nlgs.errors.size) - 1]:.2e}",
                      flush=True)


if __name__ == "__main__":
    main()
