"""Each reading of seed 001's distribution law on the report's cubical tests and simple shear.

For each distribution law (homogeneous, eq. 2.30; Maxwellian with C_bar; Maxwellian with the
overall C, self-consistent; first-order C_bar: G^n = (V^n/V)(2I - C_bar^-1 C^n)) and seed of
the idealized material (seed 001 §4.2): the peak friction angle of cubical tests at constant
sigma_3 (Lade & Duncan's protocol, the report's comparison; b = 1 is its "extension") and/or
at constant p, for b = 0 ... 1; simple shear after K0 consolidation to 1.344 p (peak
tau/sigma_v, kappa of eq. 4.8, peak mobilised angle, tau/sigma_v at the end of the path); and,
for the first-order law, how far G^n is from positive definite (the share of increments with
a negative eigenvalue of (V/V^n) G^n before the peak, the largest fraction of micro-elements
with one, the lowest eigenvalue).

Run:  .venv/bin/python examples/04_micro_element_readings.py [OUTPUT_FOLDER]
          [--laws first-order] [--seeds 1] [--b 0,0.6,1] [--paths constant-sigma3]
          [--steps 600] [--no-simple-shear]

The defaults are a quick look (seconds). docs/validation/micro-element-report.md was made with

      ... OUTPUT_FOLDER --laws homogeneous,average,overall,first-order --seeds 1,2,3,4,5
          --b 0,0.2,0.4,0.6,0.8,1 --paths constant-sigma3,constant-p --steps 6000

(6000 steps over 30 eps_ref: 0.005 eps_ref per step; about 10 s per test on one core).
Writes OUTPUT_FOLDER/readings.json and readings.png (peak angle against b, per law and path,
mean over the seeds with their range, and the report's points).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from grainlab.errors import GrainlabError
from grainlab.lab.derived import fit_kappa, peak_friction_angle, principal_angles
from grainlab.lab.element_test import run_element_test
from grainlab.lab.micro_element_setup import build_model, build_structure, default_path_parameters
from grainlab.lab.presets import preset
from grainlab.report.curves import new_figure_axes, save_figure

LAWS = {
    "homogeneous": ("homogeneous", "overall"),
    "average": ("maxwellian", "average"),  # Table 2.1 with the full series
    "overall": ("maxwellian", "overall"),  # eq. 2.32 as printed, self-consistent
    "first-order": ("maxwellian-first-order", "overall"),  # Table 2.1, eq. 2.35 to order 1
}
PATHS = {"constant-sigma3": "cubical_constant_sigma3", "constant-p": "true_triaxial"}
REPORT_B = {0.0: 41.0, 0.6: 48.0, 1.0: 45.0}
"""Seed 001 §4.2.2: triaxial compression 41 deg, 'extension' 45 deg, maximum 48 deg at 0.6."""


def run(law: str, structure, name: str, n_steps: int, **parameters: Any):
    distribution, reference = LAWS[law]
    model = build_model(structure, distribution=distribution, maxwellian_reference=reference)
    values = default_path_parameters(name, model, n_steps=n_steps)
    values.update(parameters)
    return run_element_test(model, preset(name, **values))


def share_defect(table, last_row: int) -> dict[str, float]:
    """The first-order law's G^n up to ``last_row``: share of increments with a negative
    eigenvalue of (V/V^n) G^n, largest fraction of micro-elements with one, lowest one."""
    if "strain_share_negative_fraction" not in table:
        return {}
    rows = table.iloc[1:last_row + 1]
    fraction = rows["strain_share_negative_fraction"].to_numpy(dtype=float)
    return {"increments_with_negative_share": float(np.mean(fraction > 0.0)),
            "largest_fraction_negative": float(np.nanmax(fraction)),
            "lowest_eigenvalue": float(np.nanmin(rows["strain_share_lowest_eigenvalue"]))}


def cubical(law: str, structure, path: str, b: float, n_steps: int) -> dict[str, Any]:
    result = run(law, structure, PATHS[path], n_steps, b=b)
    phi, row = peak_friction_angle(result.table)
    return {"phi_deg": math.degrees(phi), "status": result.outcome["status"],
            **share_defect(result.table, row)}


def simple_shear(law: str, structure, n_steps: int) -> dict[str, Any]:
    result = run(law, structure, "simple_shear", n_steps)
    table = result.table
    shear = (table["stage"] == "shear").to_numpy()
    angles = principal_angles(table)[shear]
    ratio = angles["tau_over_sigma_v"].to_numpy(dtype=float)
    k = int(np.nanargmax(ratio))
    phi, _ = peak_friction_angle(table[shear])
    return {"peak_tau_over_sigma_v": float(ratio[k]),
            "end_tau_over_sigma_v": float(ratio[-1]),
            "kappa": fit_kappa(ratio[: k + 1], angles["psi"].to_numpy()[: k + 1]),
            "phi_deg": math.degrees(phi), "status": result.outcome["status"],
            "steps_done": int(result.outcome.get("steps_completed", 0)),
            **share_defect(table, int(np.flatnonzero(shear)[k]))}


def attempt(action) -> dict[str, Any]:
    try:
        return action()
    except GrainlabError as error:  # e.g. the self-consistent law fails in consolidation
        return {"error": str(error)[:100]}


def figure(rows: list[dict[str, Any]], b_values: list[float], out: Path) -> None:
    fig, ax = new_figure_axes(1, 1, figsize=(6.5, 4.6))
    groups = sorted({(r["law"], r["path"]) for r in rows if "path" in r})
    for law, path in groups:
        phi = np.array([[r["cubical"].get(f"{b:g}", {}).get("phi_deg", np.nan)
                         for b in b_values] for r in rows
                        if r.get("law") == law and r.get("path") == path])
        if not np.any(np.isfinite(phi)):
            continue
        style = "-" if path == "constant-sigma3" else "--"
        line, = ax.plot(b_values, np.nanmean(phi, axis=0), style + "o", ms=4,
                        label=f"{law}, {path}")
        ax.fill_between(b_values, np.nanmin(phi, axis=0), np.nanmax(phi, axis=0),
                        color=line.get_color(), alpha=0.15)
    ax.plot(list(REPORT_B), list(REPORT_B.values()), "ks", label="report (seed 001 §4.2.2)")
    ax.set_xlabel("b = (sigma_2 - sigma_3)/(sigma_1 - sigma_3)")
    ax.set_ylabel("peak friction angle [deg]")
    ax.set_ylim(0.0, 90.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    save_figure(fig, out / "readings.png")


def seed_rows(law: str, seed: int, paths: list[str], b_values: list[float], steps: int,
              with_simple_shear: bool) -> list[dict[str, Any]]:
    """The cubical tests along each path and the simple shear of one law on one seed."""
    structure = build_structure("idealized", seed=seed)
    rows: list[dict[str, Any]] = []
    for path in paths:
        rows.append({"law": law, "seed": seed, "path": path, "steps": steps, "cubical": {
            f"{b:g}": attempt(lambda b=b, path=path: cubical(law, structure, path, b, steps))
            for b in b_values}})
        print(json.dumps(rows[-1]), flush=True)
    if with_simple_shear:
        rows.append({"law": law, "seed": seed, "steps": steps, "simple_shear": attempt(
            lambda: simple_shear(law, structure, steps))})
        print(json.dumps(rows[-1]), flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default="micro-element-readings", type=Path)
    parser.add_argument("--laws", default="first-order")
    parser.add_argument("--seeds", default="1")
    parser.add_argument("--b", default="0,0.6,1")
    parser.add_argument("--paths", default="constant-sigma3")
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--no-simple-shear", action="store_true")
    args = parser.parse_args()
    laws, paths = args.laws.split(","), args.paths.split(",")
    for choice, allowed in ((laws, LAWS), (paths, PATHS)):
        for name in choice:
            if name not in allowed:
                parser.error(f"{name!r} is not one of {', '.join(allowed)}")
    b_values = [float(v) for v in args.b.split(",")]
    rows: list[dict[str, Any]] = []
    for law in laws:
        for seed in (int(s) for s in args.seeds.split(",")):
            rows.extend(seed_rows(law, seed, paths, b_values, args.steps,
                                  not args.no_simple_shear))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "readings.json").write_text(json.dumps(rows, indent=1))
    figure(rows, b_values, args.out)


if __name__ == "__main__":
    main()
