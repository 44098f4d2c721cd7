"""Benchmark: simple shear of N spheres in the periodic cell (``grainlab test simple_shear
--boundary periodic``) to gamma_xz = gamma (1.0 by default) at sigma_zz held; prints the wall
time, tau/sigma_v = sigma_xz/sigma_zz and the dilatancy against gamma, and the inclinations of
seed 001 Fig. 4.16 (psi, beta, omega, chi, xi) from the simulation, at a few values of gamma.

Protocol: as ``benchmark_periodic_triaxial.py`` (d uniform by volume in [1, 2] mm, density
2600 kg/m^3, frictionless isotropic compaction to sigma0 = 10 kPa, then mu = 0.4, I <= 1e-3),
then ``[test] kind = "simple_shear"``: gamma_xz driven to gamma_max, eps_xx = eps_yy =
gamma_yz = gamma_xy = 0, sigma_zz held at sigma0 (the height of the cell is free).

Angles (seed 001 §4.2.4, eq. 4.8): :func:`grainlab.lab.derived.principal_angles` on the
discrete table, which holds every column it reads (sigma_xx, sigma_zz, sigma_xz, eps_xx,
eps_zz, gamma_xz). The increment angles chi (stress) and xi (strain) take differences between
consecutive rows; between records a few steps apart the contact stress's fluctuations swamp
its increment, so the rows are first averaged in windows of gamma (``--window``, 0.02 by
default: every column the mean of the rows whose gamma_xz falls in the window) and the angles
computed on the averaged rows. Angles are inclinations from the horizontal plane in degrees,
positive as gamma_xz, in [-90, 90).

Strains are the cell's natural strains (its step strains summed, compression positive:
``grainlab.engine.boundaries.periodic_boundary``): in a simple shear eps_xx = eps_yy = gamma_yz =
gamma_xy = 0 exactly, gamma_xz = int gammadot dt and eps_zz the (dilatant) height change; the
kinematics check prints the largest |eps_xx|, |eps_yy|, |gamma_yz|, |gamma_xy| in the shear,
and the increments of the recorded columns are the true strain increments the angle xi
needs.

With ``--out``: ``simple_shear.png`` (tau/sigma_v, eps_vol and the angles against gamma),
``simple_shear_seed001.png`` (:func:`grainlab.report.element_test_figures.simple_shear_figure`
on the averaged rows: Figs. 4.15-4.16 of seed 001), and the rows (``simple_shear.csv``) and
the averaged rows with their angles (``simple_shear_windows.csv``).

    PYTHONPATH=src .venv/bin/python benchmarks/benchmark_simple_shear.py \
        [--n 1000] [--gamma 1.0] [--window 0.02] [--seed 0] [--out FOLDER]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numba
import numpy as np
import pandas as pd
from benchmark_periodic_triaxial import shear_rows, timed_test

from grainlab.lab.derived import fit_kappa, principal_angles
from grainlab.lab.run_config import RunConfig
from grainlab.report.curves import new_figure_axes, save_figure
from grainlab.report.element_test_figures import simple_shear_figure
from grainlab.result.test_result import TestResult

ANGLES = ("psi", "beta", "omega", "chi", "xi")


def simple_shear_config(n: int, gamma: float, seed: int) -> RunConfig:
    """The run config of this benchmark (module docstring)."""
    return RunConfig.model_validate({
        "sample": {"n_particles": n, "d_min": 1e-3, "size_ratio": 2.0, "seed": seed,
                   "boundary": "periodic"},
        "test": {"kind": "simple_shear", "gamma_max": gamma},
        "solver": {"shear": {"friction": 0.4, "inertia_number": 1e-3}},
        "output": {"checkpoint_every": 0, "snapshot_every": 0}})


def shear_kinematics(rows: pd.DataFrame) -> pd.Series:
    """The largest departures from a simple shear in the shear rows: |eps_xx|, |eps_yy|,
    |gamma_yz|, |gamma_xy| (zero for the cell's natural strains; module docstring)."""
    return rows[["eps_xx", "eps_yy", "gamma_yz", "gamma_xy"]].abs().max()


def windowed(rows: pd.DataFrame, window: float) -> pd.DataFrame:
    """The numeric columns of ``rows`` averaged in windows of gamma_xz of width ``window``
    (the first row, the state the shear starts from, kept on its own); ``stage`` is
    "shear" on every averaged row."""
    numeric = rows.select_dtypes("number")
    gamma = numeric["gamma_xz"].to_numpy()
    bins = np.floor((gamma - gamma[0]) / window).astype(int) + 1
    bins[0] = 0
    averaged = numeric.groupby(bins).mean().reset_index(drop=True)
    averaged.insert(0, "stage", ["compaction"] + ["shear"] * (len(averaged) - 1))
    return averaged


def angles_in_degrees(table: pd.DataFrame) -> pd.DataFrame:
    """:func:`principal_angles` of ``table``, the five angles in degrees in [-90, 90) (the
    inclination of a plane is defined modulo 180 deg; a branch continuous along the rows
    would start from the isotropic state before the shear, where the directions are those of
    the packing's small anisotropy, and wander with the noise of the increment angles)."""
    angles = principal_angles(table)
    for name in ANGLES:
        angles[name] = (np.degrees(angles[name]) + 90.0) % 180.0 - 90.0
    return angles


def report_rows(averaged: pd.DataFrame, sigma0: float, at: list[float]) -> pd.DataFrame:
    """At each gamma of ``at``, the averaged row nearest to it and its angles."""
    angles = angles_in_degrees(averaged)
    gamma = averaged["gamma_xz"].to_numpy()
    records = []
    for target in at:
        k = int(np.abs(gamma - target).argmin())
        row = averaged.iloc[k]
        records.append({
            "gamma_xz": row["gamma_xz"], "tau/sigma_v": row["sigma_xz"] / row["sigma_zz"],
            "sigma_zz/sigma0": row["sigma_zz"] / sigma0,
            "sigma_xx/sigma_zz": row["sigma_xx"] / row["sigma_zz"], "eps_vol": row["eps_vol"],
            "phi_m [deg]": np.degrees(angles["phi_m"].iloc[k]),
            **{f"{name} [deg]": angles[name].iloc[k] for name in ANGLES},
        })
    return pd.DataFrame(records)


def figure(averaged: pd.DataFrame, raw: pd.DataFrame, path: Path) -> Path:
    """tau/sigma_v, eps_vol and the five angles against gamma (angles from the first window
    of the shear on)."""
    angles = angles_in_degrees(averaged).iloc[1:]
    fig, (ax_t, ax_v, ax_a) = new_figure_axes(1, 3, figsize=(15, 4))
    ax_t.plot(raw["gamma_xz"], raw["sigma_xz"] / raw["sigma_zz"], lw=0.6, alpha=0.5,
              label="rows")
    ax_t.plot(averaged["gamma_xz"], averaged["sigma_xz"] / averaged["sigma_zz"],
              label="window means")
    ax_t.set_ylabel("tau/sigma_v = sigma_xz/sigma_zz [-]")
    ax_v.plot(raw["gamma_xz"], raw["eps_vol"], lw=0.6, alpha=0.5, label="rows")
    ax_v.plot(averaged["gamma_xz"], averaged["eps_vol"], label="window means")
    ax_v.set_ylabel("eps_vol [-], compression > 0")
    for name in ANGLES:
        ax_a.plot(averaged["gamma_xz"].iloc[1:], angles[name], marker=".", label=name)
    ax_a.set_ylabel("inclination from the horizontal [deg]")
    for ax in (ax_t, ax_v, ax_a):
        ax.set_xlabel("gamma_xz [-]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
    return save_figure(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000, help="number of spheres [1000]")
    parser.add_argument("--gamma", type=float, default=1.0, help="gamma_xz to reach [1.0]")
    parser.add_argument("--window", type=float, default=0.02,
                        help="width in gamma of the windows rows are averaged in [0.02]")
    parser.add_argument("--at", type=str, default="",
                        help="values of gamma of the table, comma-separated [10 steps]")
    parser.add_argument("--seed", type=int, default=0, help="seed of the loose sample [0]")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for the figures and the rows (default: none written)")
    args = parser.parse_args()
    print(f"simple shear, {args.n} spheres (d in [1, 2] mm, mu = 0.4, I <= 1e-3) in the "
          f"periodic cell to gamma_xz = {args.gamma} at sigma_zz = 10 kPa, seed {args.seed}; "
          f"numba threads {numba.get_num_threads()}", flush=True)
    config = simple_shear_config(args.n, args.gamma, args.seed)
    run = timed_test(config)
    table, outcome = run["table"], run["outcome"]
    stages = outcome["stages"]
    steps = [int(s["steps"]) for s in stages]
    capped = [int(s.get("capped_steps", 0)) for s in stages]
    stage_times = ", ".join(f"{s:.1f}" for s in run["stage_seconds"])
    capped_share = [round(100 * c / s, 1) if s else None
                    for c, s in zip(capped, steps, strict=True)]
    cost = 1e6 * run["seconds"] / (run["n"] * sum(steps))
    print(f"wall time {run['seconds']:.1f} s (stages {stage_times}), steps {steps}, at the "
          f"iteration cap {capped_share} %, cost per particle-step {cost:.1f} us; "
          f"{outcome['status']}")
    if outcome["problems"]:
        print(outcome["summary"])
    raw = shear_rows(table).reset_index(drop=True)
    if len(raw) < 3:
        print("no shear rows to report")
        return
    sigma0 = config.test.sigma0
    compaction = table[table["stage"] == "compaction"].iloc[-1]
    shear = raw.iloc[1:]
    sigma_zz = shear["sigma_zz"] / sigma0
    print(f"after compaction: packing fraction {compaction['packing_fraction']:.4f}, "
          f"z {compaction['z']:.3f}; in shear: sigma_zz/sigma0 mean {sigma_zz.mean():.4f} "
          f"(min {sigma_zz.min():.4f}, max {sigma_zz.max():.4f}), max inertia number "
          f"{shear['inertia_number'].max():.3g}, max overlap/<d> "
          f"{table['max_overlap_over_d'].max():.3g}")
    departures = shear_kinematics(shear)
    print(f"kinematics: at the end gamma_xz {raw['gamma_xz'].iloc[-1]:.4f}, eps_zz "
          f"{raw['eps_zz'].iloc[-1]:.4f}; in shear the largest "
          + ", ".join(f"|{k}| {v:.2e}" for k, v in departures.items()))
    averaged = windowed(raw, args.window)
    reached = float(raw["gamma_xz"].iloc[-1])
    at = [float(v) for v in args.at.split(",")] if args.at else \
        [round(reached * k / 10, 4) for k in range(1, 11)]
    view = report_rows(averaged, sigma0, at)
    with pd.option_context("display.width", 250, "display.max_columns", 30):
        print(view.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    ratio = (shear["sigma_xz"] / shear["sigma_zz"]).to_numpy()
    peak = int(ratio.argmax())
    angles = principal_angles(averaged)
    kappa = fit_kappa(angles["tau_over_sigma_v"], angles["psi"])
    print(f"peak tau/sigma_v (rows) {ratio[peak]:.4f} at gamma "
          f"{shear['gamma_xz'].iloc[peak]:.4f}; kappa of tau/sigma_v = kappa tan psi (seed 001 "
          f"eq. 4.8, window means) {kappa:.3f}")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        table.to_csv(args.out / "simple_shear.csv", index=False)
        pd.concat([averaged, angles_in_degrees(averaged).add_suffix("_deg")], axis=1).to_csv(
            args.out / "simple_shear_windows.csv", index=False)
        figure(averaged, raw, args.out / "simple_shear.png")
        # without the state before the shear: the angles' branches start in the shear
        result = TestResult.create(averaged.iloc[1:].reset_index(drop=True), specimen={},
                                   load_path={"name": "simple_shear"}, dimension=3,
                                   title="simple shear, window means")
        save_figure(simple_shear_figure(result), args.out / "simple_shear_seed001.png")
        print(f"wrote simple_shear.png, simple_shear_seed001.png, simple_shear.csv and "
              f"simple_shear_windows.csv in {args.out}/")


if __name__ == "__main__":
    main()
