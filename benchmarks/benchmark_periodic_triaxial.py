"""Benchmark: the same triaxial test on the same spheres in a periodic cell and in a box of
walls, in one run of this script; prints the wall time and the cost per particle-step of each
and their ratio, and the mechanics side by side.

Protocol (``grainlab triaxial`` defaults, seed 002): N spheres, diameters uniform by volume in
[1, 2] mm (d_min = 1 mm, size ratio 2), density 2600 kg/m^3, loose random start from the same
seed, frictionless isotropic compaction to sigma0 = 10 kPa until quasi-static, then mu = 0.4,
lateral stress sigma0 held, axial strain rate from I <= 1e-3, to eps_q = eps_1 - eps_3 (0.5 by
default); contact dynamics with the defaults of ``[solver.compaction]`` and
``[solver.shear]``. The boundary is the only difference: ``[sample] boundary = "periodic"``
(the deformable cell, no walls) or ``"walls"``.

Printed per boundary: wall time (compaction, shear), steps, cost per particle-step = wall
time / (N x steps) [us], share of steps that ended at the NLGS iteration cap, packing
fraction and coordination number z after compaction and at the end, peak q/p (the results'
``q_over_trace`` = (sigma_1 - sigma_3)/(3 p)) and the eps_q where it occurs, residual q/p =
mean (+- standard deviation) over the rows with eps_q in the last 40 % of the strain, the
mean lateral stress relative to sigma0 in shear (the stress-controlled components), the
largest inertia number and overlap, and p of the last row (the state the test ends in, after
a last step cut to land on eps_q) over p of the row before. Then the cost ratio periodic /
walls. With ``--out``: a figure of q/p and eps_vol against eps_q, both boundaries
(``periodic_triaxial.png``), and the rows of each run (``periodic.csv``, ``walls.csv``).

The tests are built from their run configs (:class:`grainlab.lab.run_config.RunConfig`) and
run in memory (:func:`grainlab.lab.discrete_run.test_for`): no run folder, checkpoints or
snapshots, so that the times are those of the simulation and its records.

    PYTHONPATH=src .venv/bin/python benchmarks/benchmark_periodic_triaxial.py \
        [--n 1000] [--eps-q 0.5] [--seed 0] [--only periodic|walls] [--out FOLDER]
"""

from __future__ import annotations

import argparse
import itertools
import math
import time
from pathlib import Path
from typing import Any

import numba
import numpy as np
import pandas as pd

from grainlab.lab.discrete_run import build_sample, test_for
from grainlab.lab.run_config import RunConfig
from grainlab.report.curves import new_figure_axes, save_figure

BOUNDARIES = ("periodic", "walls")
RESIDUAL_SHARE = 0.4
"""Residual values: the rows with eps_q in the last 40 % of the strain reached."""


def timed_test(config: RunConfig) -> dict[str, Any]:
    """Build the sample and the test of ``config``, run it to its end in memory; returns
    ``table`` (the results rows, a DataFrame), ``outcome`` (the run outcome as plain data),
    ``seconds`` (wall time of the test, the sample's making excluded), ``stage_seconds``
    (per stage, in order) and ``build_seconds``."""
    start = time.perf_counter()
    test = test_for(build_sample(config), config)
    built = time.perf_counter()
    ends: list[float] = []
    test.on_stage_end = lambda _test: ends.append(time.perf_counter())
    while not test.finished and not test.halted:
        test.run()
    done = time.perf_counter()
    marks = [built, *ends, done]
    return {"table": pd.DataFrame(test.rows), "outcome": test.run_outcome().to_dict(),
            "seconds": done - built, "build_seconds": built - start,
            "stage_seconds": [b - a for a, b in itertools.pairwise(marks)],
            "n": test.sample.state.n_bodies}


def triaxial_config(n: int, eps_q: float, boundary: str, seed: int) -> RunConfig:
    """The ``grainlab triaxial`` run config of this benchmark (module docstring)."""
    return RunConfig.model_validate({
        "sample": {"n_particles": n, "d_min": 1e-3, "size_ratio": 2.0, "seed": seed,
                   "boundary": boundary},
        "test": {"kind": "triaxial", "eps_q_max": eps_q},
        "solver": {"shear": {"friction": 0.4, "inertia_number": 1e-3}},
        "output": {"checkpoint_every": 0, "snapshot_every": 0}})


def shear_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The rows after the compaction, with the compaction's last row first: the state the
    shear starts from, its strains set to zero (it is their reference: the strains of the
    compaction rows are measured from the loose start)."""
    shearing = np.array(table["stage"] != "compaction", dtype=bool)
    if not shearing.any():
        return table.iloc[:0]
    start = max(int(shearing.argmax()) - 1, 0)
    shearing[start] = True
    rows = table[shearing].copy()
    strains = [c for c in rows.columns if c.startswith(("eps_", "gamma_"))]
    rows.loc[rows.index[0], strains] = 0.0
    return rows


def residual_rows(shear: pd.DataFrame, column: str = "eps_q") -> pd.DataFrame:
    """The rows of ``shear`` in the last :data:`RESIDUAL_SHARE` of ``column``'s range."""
    reached = float(shear[column].max())
    return shear[shear[column] >= (1.0 - RESIDUAL_SHARE) * reached]


def summary(run: dict[str, Any], sigma0: float) -> dict[str, Any]:
    """The figures printed for one boundary (module docstring)."""
    table, outcome, n = run["table"], run["outcome"], run["n"]
    compaction = table[table["stage"] == "compaction"]
    shear = table[table["stage"] != "compaction"]
    stages = outcome["stages"]
    steps = [int(s["steps"]) for s in stages]
    capped = [int(s.get("capped_steps", 0)) for s in stages]
    seconds = run["stage_seconds"] + [math.nan] * (len(steps) - len(run["stage_seconds"]))
    out: dict[str, Any] = {
        "status": outcome["status"],
        "wall time [s]": run["seconds"],
        "  compaction, shear [s]": tuple(round(s, 1) for s in seconds[:2]),
        "steps (compaction, shear)": tuple(steps),
        "cost per particle-step, all [us]": 1e6 * run["seconds"] / (n * sum(steps)),
        "cost per particle-step, shear [us]": 1e6 * seconds[1] / (n * steps[1])
        if len(steps) > 1 and steps[1] else math.nan,
        "steps at the iteration cap (compaction, shear) [%]": tuple(
            round(100.0 * c / s, 2) if s else math.nan for c, s in zip(capped, steps,
                                                                      strict=True)),
        "packing fraction after compaction": compaction["packing_fraction"].iloc[-1],
        "z after compaction": compaction["z"].iloc[-1],
    }
    if len(shear):
        late = residual_rows(shear)
        peak = int(shear["q_over_trace"].to_numpy().argmax())
        lateral = 0.5 * (shear["sigma_xx"] + shear["sigma_yy"]) / sigma0
        out.update({
            "packing fraction at the end": shear["packing_fraction"].iloc[-1],
            "z at the end": shear["z"].iloc[-1],
            "eps_q reached": shear["eps_q"].iloc[-1],
            "peak q/p (at eps_q)": (round(float(shear["q_over_trace"].iloc[peak]), 4),
                                    round(float(shear["eps_q"].iloc[peak]), 4)),
            "residual q/p (mean, std)": (round(float(late["q_over_trace"].mean()), 4),
                                         round(float(late["q_over_trace"].std()), 4)),
            "residual packing fraction, z": (round(float(late["packing_fraction"].mean()), 4),
                                             round(float(late["z"].mean()), 3)),
            "lateral stress / sigma0 in shear (mean, min, max)": (
                round(float(lateral.mean()), 4), round(float(lateral.min()), 4),
                round(float(lateral.max()), 4)),
            "max inertia number in shear": shear["inertia_number"].max(),
            "p of the last row / p of the row before": (
                shear["p"].iloc[-1] / shear["p"].iloc[-2] if len(shear) > 1 else math.nan),
        })
    out["max overlap / <d>"] = table["max_overlap_over_d"].max()
    return out


def figure(runs: dict[str, dict[str, Any]], path: Path) -> Path:
    """q/p and eps_vol against eps_q, one curve per boundary."""
    fig, (ax_q, ax_v) = new_figure_axes(1, 2, figsize=(10, 3.8))
    fig.subplots_adjust(wspace=0.3)
    for name, run in runs.items():
        shear = shear_rows(run["table"])
        ax_q.plot(shear["eps_q"], shear["q_over_trace"], label=name)
        ax_v.plot(shear["eps_q"], shear["eps_vol"], label=name)
    ax_q.set_ylabel("q/p = (sigma_1 - sigma_3)/(3p) [-]")
    ax_v.set_ylabel("eps_vol [-], compression > 0")
    for ax in (ax_q, ax_v):
        ax.set_xlabel("eps_q = eps_1 - eps_3")
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
    return save_figure(fig, path)


def print_table(summaries: dict[str, dict[str, Any]]) -> None:
    """One line per figure, one column per boundary."""
    names = list(summaries)
    keys = list(dict.fromkeys(k for s in summaries.values() for k in s))
    width = max(len(k) for k in keys) + 2
    print(f"{'':{width}}" + "".join(f"{name:>26}" for name in names))
    for key in keys:
        cells = []
        for name in names:
            value = summaries[name].get(key, "")
            text = f"{value:.4g}" if isinstance(value, float) else str(value)
            cells.append(f"{text:>26}")
        print(f"{key:{width}}" + "".join(cells))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000, help="number of spheres [1000]")
    parser.add_argument("--eps-q", type=float, default=0.5, help="eps_q to reach [0.5]")
    parser.add_argument("--seed", type=int, default=0, help="seed of the loose sample [0]")
    parser.add_argument("--only", choices=BOUNDARIES, help="run one boundary only")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for the figure and the rows (default: none written)")
    args = parser.parse_args()
    threads = numba.get_num_threads()
    print(f"triaxial test, {args.n} spheres (d in [1, 2] mm, mu = 0.4, I <= 1e-3) to eps_q = "
          f"{args.eps_q}, seed {args.seed}; numba threads {threads}", flush=True)
    runs: dict[str, dict[str, Any]] = {}
    summaries: dict[str, dict[str, Any]] = {}
    for boundary in [args.only] if args.only else BOUNDARIES:
        config = triaxial_config(args.n, args.eps_q, boundary, args.seed)
        runs[boundary] = timed_test(config)
        summaries[boundary] = summary(runs[boundary], config.test.sigma0)
        print(f"  {boundary}: {runs[boundary]['seconds']:.1f} s, "
              f"{summaries[boundary]['status']}", flush=True)
    print_table(summaries)
    if len(runs) == 2:
        for key in ("cost per particle-step, all [us]", "cost per particle-step, shear [us]",
                    "wall time [s]"):
            ratio = summaries["periodic"][key] / summaries["walls"][key]
            print(f"{key.replace(' [us]', '').replace(' [s]', '')}: periodic / walls = "
                  f"{ratio:.3f}")
    for name, run in runs.items():
        if run["outcome"]["problems"]:
            print(f"{name}: {run['outcome']['summary']}")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        for name, run in runs.items():
            run["table"].to_csv(args.out / f"{name}.csv", index=False)
        print(f"wrote {figure(runs, args.out / 'periodic_triaxial.png')} and the rows "
              f"({', '.join(f'{name}.csv' for name in runs)})")


if __name__ == "__main__":
    main()
