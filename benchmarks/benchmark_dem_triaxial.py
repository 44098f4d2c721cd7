"""The 1000-sphere wall-box triaxial test (seed 002 protocol: frictionless compaction to
sigma0 = 10 kPa, then mu = 0.4, I <= 1e-3 to eps_q) with contact dynamics and with soft-contact
DEM at kappa = 1e3 and 1e4, in one script run: wall time, steps, particle-steps per second
(DEM), peak and residual q/p, packing fraction and z after compaction, how well the lateral
walls held sigma0, and the DEM / CD time ratio; with ``--yade``, YADE on the same test
(benchmarks/yade/triaxial_spheres.py: linear springs at each kappa, its
``TriaxialStressController`` and ``GlobalStiffnessTimeStepper``, on Numba's thread count)
and the YADE / grainlab DEM time ratio at each kappa.

Every run's compaction ends as YADE's does: the walls' stresses within 1 % of sigma0 and the
unbalanced force below 0.01 (``[test.quasi_static]`` with ``kinetic_energy = inf``;
``--kinetic-energy 1e-6`` for grainlab's default).

    python benchmarks/benchmark_dem_triaxial.py                 # N = 1000, eps_q = 0.5
    python benchmarks/benchmark_dem_triaxial.py --n 300 --eps-q 0.2 --methods dem
    python benchmarks/benchmark_dem_triaxial.py --methods dem --yade
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from benchmark_lab_triaxial import yade_run

from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig


def run(folder: Path, n: int, eps_q: float, method: str, kappa: float, seed: int,
        kinetic_energy: float) -> dict:
    config = RunConfig.model_validate({
        "sample": {"n_particles": n, "seed": seed},
        "test": {"kind": "triaxial", "sigma0": 1e4, "eps_q_max": eps_q,
                 "quasi_static": {"kinetic_energy": kinetic_energy}},
        "solver": {"method": method, "dem": {"kappa": kappa}},
        "output": {"record_every": 10, "snapshot_every": 0, "checkpoint_every": 0}})
    start = time.perf_counter()
    discrete_run = start_run(folder, config)
    result = discrete_run.run()
    elapsed = time.perf_counter() - start
    table = result.table
    compaction = table[table["stage"] == "compaction"].iloc[-1]
    shear = table[table["stage"] == "shear"]
    late = shear[shear["eps_q"] >= 0.6 * eps_q]
    lateral = np.concatenate([shear["wall_sigma_xx"], shear["wall_sigma_yy"]]) / 1e4
    solver = discrete_run.test.solver
    substeps = getattr(solver, "n_substeps", 0)
    return {"method": method if method == "cd" else f"dem kappa={kappa:g}",
            "seconds": elapsed, "steps": int(table["step"].iloc[-1]), "substeps": substeps,
            "particle_steps_per_s": n * substeps / elapsed if substeps else float("nan"),
            "phi0": float(compaction["packing_fraction"]), "z0": float(compaction["z"]),
            "peak": float(shear["q_over_trace"].max()),
            "residual": float(late["q_over_trace"].mean()),
            "lateral_error": float(np.median(np.abs(lateral[len(lateral) // 10:] - 1.0))),
            "as_asked": bool(result.metadata["outcome"]["as_asked"])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--eps-q", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--methods", nargs="+", default=["cd", "dem"])
    parser.add_argument("--kappas", type=float, nargs="+", default=[1e3, 1e4])
    parser.add_argument("--kinetic-energy", type=float, default=float("inf"),
                        help="the compaction's kinetic energy criterion (inf: not checked)")
    parser.add_argument("--yade", action="store_true", help="YADE at each kappa too")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="grainlab-dem-") as scratch:
        for method in args.methods:
            for kappa in (args.kappas if method == "dem" else [1e4]):
                rows.append(run(Path(scratch) / f"{method}{kappa:g}", args.n, args.eps_q,
                                method, kappa, args.seed, args.kinetic_energy))
                r = rows[-1]
                print(f"{r['method']:>16}: {r['seconds']:7.1f} s, {r['steps']} steps, "
                      f"{r['substeps']} sub-steps ({r['particle_steps_per_s']:.3g} "
                      f"particle-steps/s); phi0 {r['phi0']:.4f}, z0 {r['z0']:.2f}; q/p peak "
                      f"{r['peak']:.3f}, residual {r['residual']:.3f}; lateral walls' median "
                      f"error {100 * r['lateral_error']:.1f} %; as asked: {r['as_asked']}",
                      flush=True)
        yade = {kappa: yade_run(args.n, args.eps_q, Path(scratch), numba.get_num_threads(),
                                ("--kappa", f"{kappa:g}", "--timestepper", "gsts",
                                 "--seed", str(args.seed)))
                for kappa in (args.kappas if args.yade else [])}
    cd = [r for r in rows if r["method"] == "cd"]
    for r in rows:
        if cd and r is not cd[0]:
            print(f"{r['method']} / cd time ratio: {r['seconds'] / cd[0]['seconds']:.2f}")
    for kappa, theirs in yade.items():
        if theirs is None:
            print("YADE: not installed")
            break
        print(f"YADE kappa={kappa:g} (-j {numba.get_num_threads()}, GlobalStiffnessTimeStepper): "
              f"{theirs['wall time [s]']:.1f} s{theirs['summary']}")
        if "error" in theirs:
            print(f"  failed: {theirs['error']}")
        ours = [r for r in rows if r["method"] == f"dem kappa={kappa:g}"]
        if ours:  # YADE's own time (cloud and stepping), not its start-up
            print(f"YADE / grainlab DEM time ratio at kappa={kappa:g}: "
                  f"{theirs['stepping [s]'] / ours[0]['seconds']:.2f}")


if __name__ == "__main__":
    main()
