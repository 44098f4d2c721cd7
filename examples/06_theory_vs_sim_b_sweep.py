"""The 3D counterpart of seed 001's comparison: a periodic packing of spheres run by the
discrete engine through the cubical tests, b = 0 ... 1, at constant sigma_3 (Lade &
Duncan's protocol, the report's; ``grainlab test cubical``) and at constant p
(``grainlab test true_triaxial``), and the micro-element model of each simulated packing
under every distribution law, on one figure: the peak mobilised angle
asin((sigma_1 - sigma_3)/(sigma_1 + sigma_3)) against b.

Each (path, b) is one ``grainlab theory-vs-sim`` comparison through the Python API, in
OUT/PATH-bB (a run that ended is reused, one stopped goes on): the same sample (same seed),
compacted frictionless to sigma0 by contact dynamics (rigid grains), loaded with friction
``--mu`` to eps_q = ``--eps-q``; the model takes the run's snapshot at the end of the
compaction with its forces (periodic images kept) and the springs the soft DEM would give
the run (k_n = 1e4 sigma0 <d>, k_s = k_n / 2), and the run's own path. A model's angle is its
peak where it reached its strength (``failed``), else the largest it reached
(``hardening`` to the end of the path, or ``stopped`` where the driver could no longer hold
the stresses); none where it ``failed at the start`` (no strength state from the packing's
own: the self-consistent law on these packings).

Writes OUT/b_sweep.csv (path, b, side, peak angle, how each side ended) and
OUT/b_sweep.png, and prints the table beside the report's cubical strengths (41 deg at
b = 0, 48 at b = 0.6, 45 at b = 1)::

    .venv/bin/python examples/06_theory_vs_sim_b_sweep.py OUT --particles 1000 \\
        --b 0 0.3 0.6 1 [--paths cubical true_triaxial] [--eps-q 0.05] [--mu 0.4]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import pandas as pd

from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_outcome import RunOutcome
from grainlab.lab.solver_comparison import open_solver_run
from grainlab.lab.theory_comparison import SIMULATION, TheoryComparison
from grainlab.report.curves import new_figure_axes, save_figure

LAWS = ("homogeneous", "maxwellian-average", "maxwellian-first-order", "maxwellian")
PATH_WORDS = {"cubical": "constant sigma_3", "true_triaxial": "constant p"}
REPORT = {0.0: 41.0, 0.6: 48.0, 1.0: 45.0}
"""The report's cubical strengths [deg] at b (seed 001 §4.2.2, constant sigma_3)."""


def config(path: str, b: float, args) -> RunConfig:
    """The run of one path and b (module docstring)."""
    return RunConfig.model_validate({
        "sample": {"shape": "sphere", "boundary": "periodic", "n_particles": args.particles,
                   "size_ratio": 1.5, "seed": args.seed},
        "test": {"kind": path, "sigma0": args.sigma0, "b": b, "eps_q_max": args.eps_q},
        "solver": {"method": "cd", "shear": {"friction": args.mu,
                                             "inertia_number": args.inertia}},
        "output": {"record_every": 2, "snapshot_every": 100000},
    })


def case_rows(path: str, b: float, folder: Path, args) -> list[dict]:
    """Run (or reuse) one case and compare it: a row per side."""
    opened = open_solver_run(folder, config(path, b, args))
    result = opened if not hasattr(opened, "run") else opened.run()
    comparison = TheoryComparison(args.laws, args.model_steps).compute(folder)
    rows = [{"path": path, "b": b, "side": SIMULATION,
             "peak_phi": float(comparison.own_curves.query("side == @SIMULATION")
                               ["phi_mob"].max()),
             "ended": "as asked" if RunOutcome.of_result(result).as_asked else
             "NOT as asked"}]
    for law, test in comparison.models.items():
        outcome = test.metadata.get("outcome", {})
        own = comparison.own_curves.query("side == @law")
        ended = "hardening" if outcome.get("status") == "completed" else (
            "failed" if "strength" in str(outcome.get("reason", "")) else "stopped")
        if len(own) < 2:  # no step taken: the law has no strength state at the start
            ended = "failed at the start"
        rows.append({"path": path, "b": b, "side": law, "ended": ended,
                     "peak_phi": float(own["phi_mob"].max()) if len(own) > 1 else
                     float("nan")})
    rows += [{"path": path, "b": b, "side": law, "peak_phi": float("nan"),
              "ended": "could not start"} for law in comparison.failures]
    return rows


def figure(table: pd.DataFrame, out: Path) -> Path:
    """Peak angle against b, the run black, a colour per law, solid at constant sigma_3 and
    dashed at constant p; hollow markers where the model did not fail."""
    fig, ax = new_figure_axes(1, 1, figsize=(10.0, 4.8))
    sides = [side for side in dict.fromkeys(table["side"])
             if table.loc[table["side"] == side, "peak_phi"].notna().any()]
    for index, side in enumerate(sides):
        colour = "k" if side == SIMULATION else f"C{index - 1}"
        for path in dict.fromkeys(table["path"]):
            rows = table[(table["side"] == side) & (table["path"] == path)].sort_values("b")
            ax.plot(rows["b"], rows["peak_phi"], color=colour,
                    ls="-" if path == "cubical" else "--", lw=1.3,
                    label=f"{'discrete run' if side == SIMULATION else side}, "
                          f"{PATH_WORDS[path]}")
            failed = rows["ended"].isin(["failed", "as asked"]).to_numpy()
            ax.plot(rows["b"][failed], rows["peak_phi"][failed], "o", color=colour, ms=5)
            ax.plot(rows["b"][~failed], rows["peak_phi"][~failed], "o", color=colour, ms=5,
                    mfc="none")
    ax.plot(list(REPORT), list(REPORT.values()), "*", color="0.5", ms=11,
            label="the report (model, constant sigma_3)")
    ax.set_xlabel("b = (sigma_2 - sigma_3) / (sigma_1 - sigma_3) [-]")
    ax.set_ylabel("peak mobilised angle [deg]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.set_layout_engine("tight")
    return save_figure(fig, out / "b_sweep.png", dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--particles", type=int, default=200)
    parser.add_argument("--b", type=float, nargs="+", default=[0.0, 0.3, 0.6, 1.0])
    parser.add_argument("--paths", nargs="+", default=["cubical", "true_triaxial"],
                        choices=list(PATH_WORDS))
    parser.add_argument("--laws", nargs="+", default=list(LAWS))
    parser.add_argument("--eps-q", type=float, default=0.05)
    parser.add_argument("--mu", type=float, default=0.4)
    parser.add_argument("--sigma0", type=float, default=1e5)
    parser.add_argument("--inertia", type=float, default=0.01)
    parser.add_argument("--model-steps", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rows, start = [], time.perf_counter()
    for path in args.paths:
        for b in args.b:
            rows += case_rows(path, b, args.out / f"{path}-b{b:g}", args)
            print(f"{path} b = {b:g}: {time.perf_counter() - start:.0f} s", flush=True)
    table = pd.DataFrame(rows)
    table.to_csv(args.out / "b_sweep.csv", index=False)
    shown = table.pivot_table(index=["path", "b"], columns="side", values="peak_phi",
                              sort=False)
    print(f"peak mobilised angle [deg], {args.particles} spheres, mu = {args.mu:g} "
          f"(report, constant sigma_3: 41 / 48 / 45 deg at b = 0 / 0.6 / 1):")
    print(shown.round(1).to_string())
    print("how the models ended:")
    print(table.pivot_table(index=["path", "b"], columns="side", values="ended",
                            aggfunc="first", sort=False).to_string())
    print(f"figure: {figure(table, args.out)}")


if __name__ == "__main__":
    main()
