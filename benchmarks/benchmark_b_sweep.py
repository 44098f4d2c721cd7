"""Benchmark: true triaxial tests at constant p on N spheres in the periodic cell, one per b
(0, 0.2, ..., 1 by default), to eps_q past the peak; prints the peak friction angle
phi = asin((sigma_1 - sigma_3)/(sigma_1 + sigma_3)) against b beside the micro-element
model's (seed 001 §4.2.2, Fig. 4.11) for the same interparticle friction, and draws both.

Discrete tests (``grainlab test true_triaxial --boundary periodic``): d uniform by volume in
[1, 2] mm, density 2600 kg/m^3, one loose sample compacted once (frictionless, isotropic,
to sigma0 = 10 kPa) and copied for every b, then mu = 0.4, I <= 1e-3, p = sigma0 and b held
(z major, x intermediate, y minor), the strain along the deviator direction driven until
eps_q = eps_1 - eps_3 reaches ``--eps-q`` (0.15 by default). Per b: the peak angle of the
rows (:func:`grainlab.lab.derived.failure_point` on the rows after the compaction, through
:func:`grainlab.cli.microelement.b_sweep_summary`, the summary of ``grainlab microelement
sweep-b``), the peak of the angle averaged over ``--smooth`` of eps_q (0.01 by default: the
rows' peak picks the top of the fluctuations of a small sample), b and eps_q there, the
mean p/sigma0 and b in the shear (the stress-controlled components), wall time and outcome.

Micro-element model (``grainlab microelement sweep-b --friction-angle`` atan(mu) in degrees,
the other options at their defaults: the idealized material of seed 001, linear springs
k_n = k_s = 1e5 N/m, homogeneous strain, p = 100 kPa, ``--steps`` increments per test of 30
reference strains along the deviator direction), b from 0 to 1 by 0.1; its peak angles
through the same :func:`~grainlab.cli.microelement.b_sweep_summary`, with sigma_3/p at the
peak and its least value over the test (a peak of 90 deg is sigma_3 reaching zero).

With ``--out``: ``b_sweep.png`` (peak phi against b, both) and ``b_sweep.csv`` (the
discrete summary), ``b_sweep_model.csv``, and the rows of each discrete test
(``b<value>.csv``).

    PYTHONPATH=src .venv/bin/python benchmarks/benchmark_b_sweep.py \
        [--n 1000] [--eps-q 0.15] [--b 0,0.2,0.4,0.6,0.8,1] [--mu 0.4] [--smooth 0.01] \
        [--steps 100] [--seed 0] [--out FOLDER]
"""

from __future__ import annotations

import argparse
import copy
import math
import time
import warnings
from pathlib import Path

import numba
import numpy as np
import pandas as pd
from benchmark_periodic_triaxial import shear_rows

from grainlab.cli.microelement import b_sweep_summary
from grainlab.cli.microelement_options import ModelOptions
from grainlab.lab.derived import mobilised_friction_angle
from grainlab.lab.discrete_run import build_sample, test_for
from grainlab.lab.element_test import run_element_test
from grainlab.lab.micro_element_setup import build_structure, default_path_parameters
from grainlab.lab.presets import preset
from grainlab.lab.run_config import RunConfig
from grainlab.report.curves import new_figure_axes, save_figure
from grainlab.result.test_result import TestResult

MODEL_B = tuple(round(0.1 * k, 1) for k in range(11))


def true_triaxial_config(n: int, eps_q: float, b: float, mu: float, seed: int) -> RunConfig:
    """The run config of one discrete test (module docstring)."""
    return RunConfig.model_validate({
        "sample": {"n_particles": n, "d_min": 1e-3, "size_ratio": 2.0, "seed": seed,
                   "boundary": "periodic"},
        "test": {"kind": "true_triaxial", "b": b, "eps_q_max": eps_q},
        "solver": {"shear": {"friction": mu, "inertia_number": 1e-3}},
        "output": {"checkpoint_every": 0, "snapshot_every": 0}})


def smoothed_peak(rows: pd.DataFrame, width: float) -> tuple[float, float]:
    """(peak [rad], eps_q there) of the mobilised angle averaged over windows of eps_q of
    ``width`` (each row's angle the mean over the rows within width/2 of its eps_q)."""
    phi = mobilised_friction_angle(rows["sigma_1"], rows["sigma_3"])
    eps = rows["eps_q"].to_numpy()
    means = np.array([phi[np.abs(eps - e) <= 0.5 * width].mean() for e in eps])
    k = int(np.nanargmax(means))
    return float(means[k]), float(eps[k])


def compacted_sample(config: RunConfig):
    """The loose sample of ``config`` compacted once (its compaction stage alone): every b
    starts from this same packing (a copy), whose compaction stage then only confirms it is
    quasi-static."""
    start = time.perf_counter()
    compaction = config.with_updates({"test": {"kind": "compaction"}})
    test = test_for(build_sample(compaction), compaction)
    while not test.finished and not test.halted:
        test.run()
    print(f"  compaction: {time.perf_counter() - start:.1f} s, "
          f"{test.simulation.step_index} steps", flush=True)
    return test.sample


def timed_on(sample, config: RunConfig) -> dict:
    """:func:`timed_test` on a copy of an already made ``sample``."""
    start = time.perf_counter()
    test = test_for(copy.deepcopy(sample), config)
    while not test.finished and not test.halted:
        test.run()
    return {"table": pd.DataFrame(test.rows), "outcome": test.run_outcome().to_dict(),
            "seconds": time.perf_counter() - start}


def discrete_sweep(args) -> tuple[pd.DataFrame, dict[float, pd.DataFrame]]:
    """One discrete test per b, all from one compacted packing: the printed figures and the
    rows of each test."""
    results, records, tables = [], [], {}
    packing = compacted_sample(true_triaxial_config(args.n, args.eps_q, 0.0, args.mu,
                                                    args.seed))
    for b in args.b:
        config = true_triaxial_config(args.n, args.eps_q, b, args.mu, args.seed)
        run = timed_on(packing, config)
        table, outcome = run["table"], run["outcome"]
        tables[b] = table
        rows = shear_rows(table).iloc[1:]
        if len(rows) < 2:
            raise SystemExit(f"b = {b:g}: no shear rows ({outcome['summary']})")
        results.append(TestResult.create(rows.reset_index(drop=True), specimen={},
                                         load_path={"name": "true_triaxial", "b": b},
                                         outcome={"status": outcome["status"]}, dimension=3))
        phi_s, eps_s = smoothed_peak(rows, args.smooth)
        q = rows["sigma_1"] - rows["sigma_3"]
        b_rows = ((rows["sigma_2"] - rows["sigma_3"]) / q.where(q > 0)).to_numpy()
        late = rows["eps_q"] >= 0.2 * rows["eps_q"].max()  # b is 0/0 at the isotropic start
        steps = [int(s["steps"]) for s in outcome["stages"]]
        capped = sum(int(s.get("capped_steps", 0)) for s in outcome["stages"])
        records.append({
            "smoothed peak phi [deg]": math.degrees(phi_s), "eps_q at it": eps_s,
            "p/sigma0 (mean)": float(rows["p"].mean() / config.test.sigma0),
            "b (mean, eps_q > 20 %)": float(np.nanmean(b_rows[late.to_numpy()])),
            "eps_q reached": float(rows["eps_q"].iloc[-1]),
            "capped steps [%]": 100.0 * capped / sum(steps),
            "wall time [s]": run["seconds"], "outcome": outcome["status"],
        })
        print(f"  b = {b:g}: {run['seconds']:.1f} s, {outcome['status']}", flush=True)
        if outcome["problems"]:
            print("    " + outcome["summary"].replace("\n", "\n    "))
    summary = b_sweep_summary(args.b, results)
    figures = pd.DataFrame(records)
    figures.insert(0, "b", args.b)
    figures.insert(1, "peak phi [deg]", np.degrees(summary.table["phi_peak"].to_numpy()))
    figures.insert(2, "b at peak", summary.table["b_at_failure"].to_numpy())
    figures.insert(3, "eps_q at peak", [float(r.table["eps_q"].iloc[int(k)]) for r, k in zip(
        results, summary.table["failure_row"], strict=True)])
    return figures, tables


def model_sweep(mu: float, steps: int) -> tuple[pd.DataFrame, list[str]]:
    """The micro-element model's true triaxial tests at :data:`MODEL_B` (``grainlab
    microelement sweep-b --friction-angle atan(mu)``, the structure's other defaults): per b
    the peak angle, b and sigma_3/p there and the test's outcome; and the driver's warnings."""
    options = ModelOptions(friction_angle_deg=math.degrees(math.atan(mu)))
    structure = build_structure("idealized", 1)
    results = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for b in MODEL_B:
            model = options.build(structure)
            parameters = {**default_path_parameters("true_triaxial", model, steps), "b": b}
            results.append(run_element_test(model, preset("true_triaxial", **parameters)))
    summary = b_sweep_summary(MODEL_B, results).table
    rows = [r.table.iloc[int(k)] for r, k in zip(results, summary["failure_row"], strict=True)]
    figures = pd.DataFrame({
        "b": MODEL_B, "peak phi [deg]": np.degrees(summary["phi_peak"]),
        "b at peak": summary["b_at_failure"],
        "sigma_3/p at peak": [float(r["sigma_3"] / r["p"]) for r in rows],
        "min sigma_3/p": [float((r.table["sigma_3"] / r.table["p"]).min()) for r in results],
        "p [Pa]": [float(r["p"]) for r in rows], "outcome": summary["status"]})
    return figures, [str(w.message) for w in caught]


def figure(discrete: pd.DataFrame, model: pd.DataFrame, n: int, mu: float, path: Path) -> Path:
    """Peak phi against b: the discrete tests (rows' and smoothed peaks) and the model."""
    fig, ax = new_figure_axes(figsize=(6, 4.2))
    ax.plot(model["b"], model["peak phi [deg]"], "-", color="k",
            label=f"micro-element model (idealized, phi_mu = atan {mu:g})")
    ax.plot(discrete["b"], discrete["peak phi [deg]"], "o", label=f"{n} spheres, peak of rows")
    ax.plot(discrete["b"], discrete["smoothed peak phi [deg]"], "s", mfc="none",
            label=f"{n} spheres, peak of the smoothed curve")
    ax.set_xlabel("b = (sigma_2 - sigma_3)/(sigma_1 - sigma_3)")
    ax.set_ylabel("peak phi = asin((s1 - s3)/(s1 + s3)) [deg]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    return save_figure(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000, help="number of spheres [1000]")
    parser.add_argument("--eps-q", type=float, default=0.15, help="eps_q to reach [0.15]")
    parser.add_argument("--b", type=lambda text: [float(v) for v in text.split(",")],
                        default=[0.0, 0.2, 0.4, 0.6, 0.8, 1.0],
                        help="values of b, comma-separated [0,0.2,0.4,0.6,0.8,1]")
    parser.add_argument("--mu", type=float, default=0.4, help="interparticle friction [0.4]")
    parser.add_argument("--smooth", type=float, default=0.01,
                        help="eps_q window of the smoothed peak [0.01]")
    parser.add_argument("--steps", type=int, default=100,
                        help="increments of each micro-element test [100]")
    parser.add_argument("--seed", type=int, default=0, help="seed of the loose sample [0]")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for the figure and the tables (default: none written)")
    args = parser.parse_args()
    sigma0 = RunConfig().test.sigma0
    print(f"true triaxial at p = {sigma0:g} Pa, b in {args.b}, {args.n} spheres (d in [1, 2] "
          f"mm, mu = {args.mu:g}, I <= 1e-3) in the periodic cell to eps_q = {args.eps_q}, "
          f"seed {args.seed}; numba threads {numba.get_num_threads()}", flush=True)
    discrete, tables = discrete_sweep(args)
    model, notes = model_sweep(args.mu, args.steps)
    float_format = "{:.4g}".format
    with pd.option_context("display.width", 250, "display.max_columns", 30):
        print(f"discrete ({args.n} spheres):")
        print(discrete.to_string(index=False, float_format=float_format))
        print(f"micro-element model (idealized material, phi_mu = atan({args.mu:g}) = "
              f"{math.degrees(math.atan(args.mu)):.2f} deg, {args.steps} increments):")
        print(model.to_string(index=False, float_format=float_format))
    if notes:
        print(f"micro-element driver: {len(notes)} warnings, the first: {notes[0]}")
    tension = model[model["min sigma_3/p"] <= 0.0]
    if len(tension):
        print("micro-element model: sigma_3 reached zero or tension (phi = 90 deg is the "
              f"clipped asin of (s1 - s3)/(s1 + s3) >= 1) at b = "
              f"{', '.join(f'{b:g}' for b in tension['b'])}")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        discrete.to_csv(args.out / "b_sweep.csv", index=False)
        model.to_csv(args.out / "b_sweep_model.csv", index=False)
        for b, table in tables.items():
            table.to_csv(args.out / f"b{b:g}.csv", index=False)
        print(f"wrote {figure(discrete, model, args.n, args.mu, args.out / 'b_sweep.png')}, "
              f"b_sweep.csv, b_sweep_model.csv and the rows of each test")


if __name__ == "__main__":
    main()
