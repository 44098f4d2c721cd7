"""Seed 001 chapter 3, one-dimensional compression: K0 of the report's 25-disc periodic
packing against the interparticle friction angle, from the discrete simulation (soft-contact
DEM, Cundall & Strack's linear springs) and from the micro-element model of each simulated
packing, beside the report's values (model 0.22 -> 0.14, DEM 0.27 -> 0.16 for
phi_mu 14 -> 25 degrees).

The specimen (seed 001 §3.1): 12 discs of radius 0.21 mm and 13 of 0.105 mm, random, in a
periodic cell (``sizes = "binary"``, ``fine_fraction = 0.52``), isotropically compressed by
the simulation to sigma0 = 203 kPa (frictionless: the same packing for every angle of a
seed), k_n = 200 kN/m per disc, k_s/k_n = 1 (``--stiffness-ratio``), discs as thick as
their mean diameter (the model's springs are per unit thickness, k / t). Then the
horizontal strain is held and the vertical strain grows to ``--strain``; each angle's
loading friction is tan phi_mu. Every (seed, angle) is one `grainlab theory-vs-sim
oedometer` run through the Python API (folders under ``--out``), each distribution law of
``--distribution`` on its packing.

Prints, per angle, K0 at the end of the loading (the run's last row and each model on the
run's strain grid): the mean and the spread over the seeds, and writes ``k0.csv`` (every
seed) and ``k0.png`` (K0 against the vertical strain, the run solid and the models dashed,
one colour per angle, the first seed)::

    .venv/bin/python benchmarks/benchmark_chang_ch3.py --seeds 1 2 3 --out /tmp/ch3
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig
from grainlab.lab.theory_comparison import SIMULATION, TheoryComparison
from grainlab.report.curves import new_figure_axes, save_figure

ANGLES = (14.0, 17.0, 20.0, 25.0)
"""phi_mu [deg] of the report's Fig. 3.3."""
REPORT = {"model": (0.22, 0.14), "DEM": (0.27, 0.16)}
"""The report's K0 at phi_mu = 14 and 25 degrees."""


def chapter_3_config(seed: int, angle: float, strain: float, ratio: float) -> RunConfig:
    """The run of one seed and friction angle (module docstring)."""
    return RunConfig.model_validate({
        "sample": {"shape": "disc", "boundary": "periodic", "n_particles": 25,
                   "d_min": 0.21e-3, "size_ratio": 2.0, "sizes": "binary",
                   "fine_fraction": 0.52, "packing_fraction": 0.3, "seed": seed},
        "test": {"kind": "oedometer", "sigma0": 203e3, "axial_strain": strain},
        "solver": {"method": "dem", "dem": {"normal_stiffness": 2e5, "stiffness_ratio": ratio},
                   "shear": {"friction": math.tan(math.radians(angle))}},
        "output": {"record_every": 2, "snapshot_every": 50, "checkpoint_every": 0},
    })


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--angles", type=float, nargs="+", default=list(ANGLES))
    parser.add_argument("--strain", type=float, default=0.005)
    parser.add_argument("--stiffness-ratio", type=float, default=1.0)
    parser.add_argument("--distribution", nargs="+",
                        default=["homogeneous", "maxwellian-first-order"])
    parser.add_argument("--out", type=Path, default=Path("chang-ch3"))
    args = parser.parse_args()
    rows, curves = [], {}
    start = time.perf_counter()
    for seed in args.seeds:
        for angle in args.angles:
            folder = args.out / f"seed{seed}-phi{angle:g}"
            run = start_run(folder, chapter_3_config(seed, angle, args.strain,
                                                     args.stiffness_ratio), overwrite=True)
            run.run()
            comparison = TheoryComparison(args.distribution, 60).compute(folder)
            own = comparison.own_curves
            for side in dict.fromkeys(own["side"]):
                end = own[(own["side"] == side) & (own["stage"] == "loading")]
                rows.append({"seed": seed, "phi_mu": angle, "side": side,
                             "eps_v": float(end["eps_axial"].iloc[-1]) if len(end) else np.nan,
                             "K0": float(end["K0"].iloc[-1]) if len(end) else np.nan})
            if seed == args.seeds[0]:
                curves[angle] = own
    table = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "k0.csv", index=False)
    print(f"{len(args.seeds)} seed(s) x {len(args.angles)} angle(s) in "
          f"{time.perf_counter() - start:.0f} s; K0 at the end of the loading "
          f"(eps_v = {args.strain:g}), mean [min, max] over the seeds")
    sides = list(dict.fromkeys(table["side"]))
    print("phi_mu  " + "  ".join(f"{side:>28s}" for side in sides))
    for angle in args.angles:
        cells = []
        for side in sides:
            k0 = table[(table["phi_mu"] == angle) & (table["side"] == side)]["K0"]
            cells.append(f"{k0.mean():.3f} [{k0.min():.3f}, {k0.max():.3f}]".rjust(28))
        print(f"{angle:6g}  " + "  ".join(cells))
    print(f"report (phi_mu 14 -> 25): model {REPORT['model'][0]} -> {REPORT['model'][1]}, "
          f"DEM {REPORT['DEM'][0]} -> {REPORT['DEM'][1]}")
    figure, ax = new_figure_axes(1, 1, figsize=(6.5, 4.5))
    for index, (angle, own) in enumerate(curves.items()):
        for side in dict.fromkeys(own["side"]):
            part = own[own["side"] == side]
            ax.plot(part["eps_axial"], part["K0"], color=f"C{index}",
                    ls="-" if side == SIMULATION else "--", lw=1.2,
                    label=f"phi_mu {angle:g}: {'DEM' if side == SIMULATION else side}")
    ax.set_xlabel("vertical strain eps_yy from the end of the compaction [-]")
    ax.set_ylabel("K0 = sigma_xx / sigma_yy [-]")
    ax.set_ylim(0.0, 1.1)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small", ncols=2)
    print(f"figure: {save_figure(figure, args.out / 'k0.png', dpi=120)}")


if __name__ == "__main__":
    main()
