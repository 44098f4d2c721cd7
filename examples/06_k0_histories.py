"""Seed 001 §4.2.1's one-dimensional compressions by the micro-element model of the idealized
material, under each distribution law: K0 after isotropic consolidation at phi_mu = 17 deg
(the comparison with Lade's Napa Basalt, Fig. 4.7: "K0 nearly constant during loading,
rising during unloading") and after anisotropic consolidation to sigma_h / sigma_v = 0.5,
1.0 and 1.5 at phi_mu = 15 deg (Okochi & Tatsuoka's Toyoura sand, Fig. 4.8: "the K0 values
... converge to an identical value at large axial stress").

The report's figures are curves against experiments whose values it does not print; what it
states in numbers is the friction angles, the three initial ratios and the two claims above,
which this script measures:

* Napa Basalt: K0 at the end of the loading (15 eps_ref of vertical strain from 100 kPa),
  its spread over the second half of the loading (max - min: "nearly constant"), and K0 at
  the end of the unloading back to sigma_v = 100 kPa with its OCR.
* Toyoura: from the isotropic 100 kPa, the stresses are taken to sigma_v = 100 kPa and
  sigma_h = R sigma_v (R = 0.5, 1, 1.5; 40 steps), then eps_h = 0 and the vertical strain
  raised by 60 eps_ref; K0 at sigma_v = 2, 4 and 8 times its start and at the end, and the
  spread of K0 over the three ratios at the end (converged: small against the spread at the
  start, 1.0).

Idealized material (30 micro-elements, k_n = k_s = 1e5 N/m), seeds ``--seeds``, laws
``--laws``; writes OUT/k0_histories.csv and OUT/k0_histories.png::

    .venv/bin/python examples/06_k0_histories.py OUT [--seeds 1 2 3 4 5]
        [--laws homogeneous first-order average]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from grainlab.errors import GrainlabError
from grainlab.lab.element_test import run_element_test
from grainlab.lab.load_path import LoadPath, LoadStage
from grainlab.lab.micro_element_setup import (
    build_model,
    build_structure,
    default_path_parameters,
    reference_strain,
)
from grainlab.lab.presets import preset
from grainlab.report.curves import new_figure_axes, save_figure

LAWS = {"homogeneous": ("homogeneous", "overall"),
        "average": ("maxwellian", "average"),
        "first-order": ("maxwellian-first-order", "overall")}
RATIOS = (0.5, 1.0, 1.5)
SHEARS = {"yz": 0.0, "xz": 0.0, "xy": 0.0}


def model_of(law: str, seed: int, phi_mu: float):
    distribution, reference = LAWS[law]
    return build_model(build_structure("idealized", seed=seed), friction_angle_deg=phi_mu,
                       distribution=distribution, maxwellian_reference=reference)


def k0(table: pd.DataFrame) -> np.ndarray:
    return (0.5 * (table["sigma_xx"] + table["sigma_yy"]) / table["sigma_zz"]).to_numpy()


def napa(law: str, seed: int, steps: int) -> dict:
    model = model_of(law, seed, 17.0)
    result = run_element_test(model, preset("oedometer", **default_path_parameters(
        "oedometer", model, n_steps=steps)))
    table = result.table
    loading = table[table["stage"] == "loading"]
    unloading = table[table["stage"] == "unloading"]
    ratio = k0(loading)
    row = {"test": "napa", "law": law, "seed": seed, "status": result.outcome["status"],
           "K0_loading_end": float(ratio[-1]) if len(ratio) else np.nan,
           "K0_loading_spread": float(np.ptp(ratio[len(ratio) // 2:])) if len(ratio) else
           np.nan}
    if len(unloading):
        row["K0_unloading_end"] = float(k0(unloading)[-1])
        row["OCR"] = float(loading["sigma_zz"].max() / unloading["sigma_zz"].iloc[-1])
    return row


def toyoura(law: str, seed: int, ratio: float, steps: int) -> tuple[dict, pd.DataFrame]:
    model = model_of(law, seed, 15.0)
    sigma = float(model.stress()[2])
    eps = reference_strain(model)
    consolidation = LoadStage.from_components(
        "consolidation", 40, 3, stress={"xx": ratio * sigma, "yy": ratio * sigma, "zz": sigma,
                                        **SHEARS}, stress_mode="target")
    loading = LoadStage.from_components(
        "loading", steps, 3, strain={"xx": 0.0, "yy": 0.0, "zz": 60.0 * eps / steps,
                                     **SHEARS})
    path = LoadPath("anisotropic_then_k0", 3, (consolidation, loading),
                    f"sigma_h / sigma_v = {ratio:g} at sigma_v = {sigma:g} Pa, then eps_h = 0")
    result = run_element_test(model, path)
    table = result.table[result.table["stage"] == "loading"]
    row = {"test": "toyoura", "law": law, "seed": seed, "ratio": ratio,
           "status": result.outcome["status"]}
    if len(table):
        values = k0(table)
        sigma_v = table["sigma_zz"].to_numpy()
        for factor in (2, 4, 8):
            reached = sigma_v >= factor * sigma
            row[f"K0_at_{factor}x"] = float(values[reached][0]) if reached.any() else np.nan
        row["K0_end"] = float(values[-1])
        row["sigma_v_end_over_start"] = float(sigma_v[-1] / sigma)
    curve = pd.DataFrame({"law": law, "seed": seed, "ratio": ratio,
                          "sigma_v": table["sigma_zz"].to_numpy(), "K0": k0(table)})
    return row, curve


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--laws", nargs="+", default=list(LAWS), choices=list(LAWS))
    parser.add_argument("--steps", type=int, default=400)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows, curves = [], []
    for law in args.laws:
        for seed in args.seeds:
            try:
                rows.append(napa(law, seed, args.steps))
            except GrainlabError as error:
                rows.append({"test": "napa", "law": law, "seed": seed,
                             "status": f"could not start: {error}"})
            for ratio in RATIOS:
                try:
                    row, curve = toyoura(law, seed, ratio, args.steps)
                    rows.append(row)
                    if len(curve):
                        curves.append(curve)
                except GrainlabError as error:
                    rows.append({"test": "toyoura", "law": law, "seed": seed, "ratio": ratio,
                                 "status": f"could not start: {error}"})
    table = pd.DataFrame(rows)
    table.to_csv(args.out / "k0_histories.csv", index=False)
    pd.set_option("display.width", 200)
    napa_rows = table[table["test"] == "napa"].dropna(axis=1, how="all")
    print("Napa Basalt (phi_mu 17 deg): K0 at the end of loading, its spread over the second "
          "half, K0 after unloading")
    print(napa_rows.groupby("law")[[c for c in ("K0_loading_end", "K0_loading_spread",
                                                 "K0_unloading_end", "OCR")
                                    if c in napa_rows]].agg(["mean", "min", "max"])
          .round(3).to_string())
    toy = table[table["test"] == "toyoura"]
    print("Toyoura (phi_mu 15 deg): K0 against sigma_v / sigma_v0, mean over the seeds")
    columns = [c for c in ("K0_at_2x", "K0_at_4x", "K0_at_8x", "K0_end",
                           "sigma_v_end_over_start") if c in toy]
    print(toy.groupby(["law", "ratio"])[columns].mean().round(3).to_string())
    spread = toy.groupby(["law", "seed"])["K0_end"].agg(np.ptp).groupby("law").agg(
        ["mean", "max"])
    print("spread of the end K0 over the three initial ratios (start: 1.0), per seed:")
    print(spread.round(3).to_string())
    print("how the tests ended:")
    print(table.groupby(["test", "law"])["status"].value_counts().to_string())
    figure, axes = new_figure_axes(1, len(args.laws), figsize=(4.5 * len(args.laws), 3.8))
    axes = np.atleast_1d(axes)
    for ax, law in zip(axes, args.laws, strict=True):
        for colour, ratio in enumerate(RATIOS):
            for curve in (c for c in curves if c["law"].iloc[0] == law and
                          c["ratio"].iloc[0] == ratio):
                first = curve["seed"].iloc[0] == args.seeds[0]
                ax.plot(curve["sigma_v"] / 1e3, curve["K0"], color=f"C{colour}",
                        lw=1.5 if first else 0.6,
                        label=f"sigma_h/sigma_v = {ratio:g} at the start" if first else None)
        ax.set_xscale("log")
        ax.set_xlabel("sigma_v [kPa]")
        ax.set_title(law, fontsize="medium")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("K0 = sigma_h / sigma_v [-]")
    axes[0].legend(fontsize="x-small")
    print(f"figure: {save_figure(figure, args.out / 'k0_histories.png', dpi=120)}")


if __name__ == "__main__":
    main()
