"""The peers' test (benchmarks/peers/README.md) with grainlab's soft-contact DEM solver and
with LIGGGHTS and YADE, in one script run: wall time, particle-steps per second, peak and
residual q/p, packing fraction and z after the compaction, how well the lateral stresses were
held, and the ratio of each peer's rate to grainlab's.

The test: N spheres, diameters uniform by volume fraction in [1, 2] mm, density 2600 kg/m^3,
periodic cell, Hertz-Mindlin E = 1 GPa, nu = 0.25, restitution 0.5, sub-step 0.2 x the
Rayleigh time of the smallest sphere, frictionless isotropic compaction to sigma0 = 100 kPa,
then mu = 0.4 and axial compression at I = 1e-3 with the lateral stresses at sigma0. grainlab
stops on eps_q (``--eps-q``, default 1.7 x eps1, which takes eps_1 a little past ``--eps1``):
its peak is read up to eps_1 = ``--eps1`` and its residual over eps_1 in [0.6, 1] x eps1 (the
peers' window, 0.18-0.30 at 0.3). Its loose sample starts at packing fraction 0.3 (the
peers' at 0.1). Its compaction ends on the peers' criterion: the stresses within 1 % and the
unbalanced force below 0.01 (``[test.quasi_static]`` with ``kinetic_energy = inf``; the
peers check every 1000 steps, grainlab at a record, every 70 lab steps: 700-1000 sub-steps
in compaction, ~2700 in shear, about the peers' rows). Rates are those of the whole run
(compaction and shear) for every code; grainlab's wall time includes the lab's recording,
not the compilation (``grainlab compile`` first). Two ratios per peer: of the rates
(particle-steps per second) and of the wall times of the same test (the peer's over
grainlab's: above 1, grainlab finished first).

    python benchmarks/benchmark_dem_peers.py --n 4000                       # grainlab only
    python benchmarks/benchmark_dem_peers.py --n 4000 --peers liggghts yade --threads 1 2
    python benchmarks/benchmark_dem_peers.py --n 500 --eps1 0.05 --eps-q 0.08  # a quick look
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from grainlab.engine.dem.soft_contact import threads_pay
from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig

sys.path.insert(0, str(Path(__file__).resolve().parent / "peers"))
import run_peers

SIGMA0 = 1e5
TARGET_RATE = 1e7
"""The speed target [particle-steps/s]: at least this, and faster than every peer run."""


def run_grainlab(folder: Path, n: int, eps1: float, eps_q: float, seed: int) -> dict:
    """The peers' test in a grainlab run folder; the figures as the peers' driver gives them."""
    config = RunConfig.model_validate({
        "sample": {"n_particles": n, "seed": seed, "boundary": "periodic", "d_min": 1e-3,
                   "size_ratio": 2.0, "density": 2600.0},
        "test": {"kind": "triaxial", "sigma0": SIGMA0, "eps_q_max": eps_q,
                 "quasi_static": {"kinetic_energy": float("inf")}},
        "solver": {"method": "dem",
                   "dem": {"law": "hertz_mindlin", "young_modulus": 1e9,
                           "poisson_ratio": 0.25, "restitution": 0.5},
                   "shear": {"friction": 0.4, "inertia_number": 1e-3}},
        "output": {"record_every": 70, "snapshot_every": 0, "checkpoint_every": 0}})
    discrete_run = start_run(folder, config)
    start = time.perf_counter()
    result = discrete_run.run()
    elapsed = time.perf_counter() - start
    solver = discrete_run.test.solver
    table = result.table
    compaction = table[table["stage"] == "compaction"].iloc[-1]
    shear = table[table["stage"] == "shear"]
    within = shear[shear["eps_zz"] <= eps1]
    late = within[within["eps_zz"] >= 0.6 * eps1]
    lateral = np.concatenate([shear["cell_sigma_xx"], shear["cell_sigma_yy"]]) / SIGMA0
    threads = numba.get_num_threads() if threads_pay(n) else 1
    return {"peer": "grainlab", "threads": threads, "n": n, "wall_s": elapsed,
            "steps": solver.n_substeps, "particle_steps_per_s": n * solver.n_substeps / elapsed,
            "peak_q_over_p": float(within["q_over_trace"].max()),
            "residual_q_over_p": float(late["q_over_trace"].mean()),
            "phi": float(compaction["packing_fraction"]), "z": float(compaction["z"]),
            "lateral_error": float(np.median(np.abs(lateral[len(lateral) // 10:] - 1.0))),
            "as_asked": bool(result.metadata["outcome"]["as_asked"])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=4000)
    parser.add_argument("--eps1", type=float, default=0.3, help="axial strain of the peers")
    parser.add_argument("--eps-q", type=float, default=None,
                        help="grainlab's stop (default 1.7 x eps1)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--peers", nargs="*", default=[], choices=["liggghts", "yade"])
    parser.add_argument("--threads", type=int, nargs="+", default=[1],
                        help="the peers' thread counts (grainlab runs on Numba's threads "
                             "from soft_contact.PARALLEL_BODIES bodies: NUMBA_NUM_THREADS)")
    parser.add_argument("--timeout", type=float, default=3600.0)
    args = parser.parse_args()
    eps_q = 1.7 * args.eps1 if args.eps_q is None else args.eps_q
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        rows.append(run_grainlab(Path(tmp) / "run", args.n, args.eps1, eps_q, args.seed))
    for peer in args.peers:
        for threads in args.threads:
            run = run_peers.run_liggghts if peer == "liggghts" else run_peers.run_yade
            res = run(n=args.n, threads=threads, eps1=args.eps1, timeout=args.timeout)
            if res is not None:
                rows.append(res)
    ours = rows[0]["particle_steps_per_s"]
    print(f"{'code':>10} {'thr':>4} {'wall [s]':>9} {'steps':>8} {'part-steps/s':>13} "
          f"{'peer/ours':>10} {'time ratio':>10} {'q/p peak':>9} {'q/p res':>8} {'phi0':>6} "
          f"{'z0':>5} {'lateral err':>12}")  # grainlab: median |error|; peers: |mean - 1|
    for r in rows:
        lateral = r.get("lateral_error")
        if lateral is None and "lateral_stress_over_sigma0" in r:
            lateral = abs(float(r["lateral_stress_over_sigma0"]["mean"]) - 1.0)
        print(f"{r['peer']:>10} {r['threads']:>4d} {r['wall_s']:9.1f} {r['steps']:8d} "
              f"{r['particle_steps_per_s']:13.3e} {r['particle_steps_per_s'] / ours:10.2f} "
              f"{r['wall_s'] / rows[0]['wall_s']:10.2f} "
              f"{r['peak_q_over_p']:9.3f} {r['residual_q_over_p']:8.3f} {r['phi']:6.3f} "
              f"{r['z']:5.2f} {'' if lateral is None else f'{lateral:12.3%}'}")
    print(f"grainlab as asked: {rows[0]['as_asked']}")
    if len(rows) > 1:
        quickest = min(r["wall_s"] for r in rows[1:])
        print(f"the same test: grainlab {rows[0]['wall_s']:.1f} s, quickest peer run "
              f"{quickest:.1f} s")
    fastest = max((r["particle_steps_per_s"] for r in rows[1:]), default=0.0)
    met = ours >= TARGET_RATE and ours > fastest
    print(f"speed target (>= {TARGET_RATE:.0e} particle-steps/s and faster than every peer "
          f"run): {'met' if met else 'missed'} ({ours:.3g}; fastest peer {fastest:.3g})")


if __name__ == "__main__":
    main()
