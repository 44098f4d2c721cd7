"""``grainlab theory-series``: seed 001 chapter 3 in one command — discrete runs of the
report's 25-disc periodic packing and the micro-element models of each simulated packing,
over seeds, friction angles, stiffness ratios and confining pressures
(:mod:`grainlab.lab.theory_series`, :mod:`grainlab.report.theory_series_figures`).

Exit status: 0 when every run did what was asked (a model that reached its strength before
the end of its path is a result, in the table); 3 when a run blew up or ended otherwise than
asked (the rest is still written); 2 on bad input, with one message.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from grainlab.cli.discrete import console, print_wide
from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import output_folder

SHOWN = {"oedometer": ("K0_min", "K0_end"), "biaxial": ("ratio_peak", "ratio_end",
                                                        "eps_vol_end")}
"""The measures the printed table shows per test."""


def _cell(row, measure: str) -> str:
    mean = row[f"{measure}_mean"]
    if not math.isfinite(mean):
        return "-"
    low, high = row[f"{measure}_min"], row[f"{measure}_max"]
    return f"{mean:.3f}" if row["seeds"] == 1 or low == high else \
        f"{mean:.3f} [{low:.3f}, {high:.3f}]"


def summary_table(summary, test: str) -> Table:
    """One test's summary as a rich table: the case, the side, the measures as mean [min,
    max] over the seeds."""
    from grainlab.lab.theory_series import REPORT_K0

    measures = SHOWN[test]
    shown = Table(title=escape(f"{test}: mean [min, max] over the seeds whose run was as "
                               "asked"), title_justify="left")
    for name in ("phi_mu", "k_s/k_n", "sigma0 [kPa]", "side", *measures):
        shown.add_column(name, justify="left" if name == "side" else "right")
    if test == "oedometer":
        shown.add_column("report (K0 minimum)", justify="right")
    for row in summary[summary["test"] == test].to_dict("records"):
        cells = [f"{row['phi_mu']:g}", f"{row['stiffness_ratio']:g}",
                 f"{row['sigma0'] / 1e3:g}", escape(row["side"]),
                 *(_cell(row, m) for m in measures)]
        if test == "oedometer":
            side = "simulation" if row["side"] == "simulation" else "model"
            value = REPORT_K0[side].get(row["phi_mu"])
            cells.append("-" if value is None else f"{value:g}")
        shown.add_row(*cells)
    return shown


@friendly_errors
def theory_series_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="The series' folder.")] = Path(
        "theory-series"),
    tests: Annotated[list[str] | None, typer.Option(
        "--test", help="oedometer (Fig. 3.3) and/or biaxial (Figs. 3.4-3.6); repeat. "
                       "Default: both.")] = None,
    seeds: Annotated[list[int] | None, typer.Option(
        "--seed", help="A random packing's sample seed; repeat. Default: 1 2 3.")] = None,
    angles: Annotated[list[float] | None, typer.Option(
        "--phi-mu", help="phi_mu [deg] of the oedometer cases; repeat. Default: 14 17 20 "
                         "25.")] = None,
    biaxial_angle: Annotated[float, typer.Option(
        "--biaxial-phi-mu", help="phi_mu [deg] of the biaxial cases.")] = 25.0,
    ratios: Annotated[list[float] | None, typer.Option(
        "--stiffness-ratio", help="k_s/k_n of the biaxial cases (the oedometer takes the "
                                  "first); repeat. Default: 1 0.3.")] = None,
    sigma0s: Annotated[list[float] | None, typer.Option(
        "--sigma0", help="Confining pressure [Pa]; repeat for Fig. 3.6. Default: 203e3.")
    ] = None,
    n_particles: Annotated[int, typer.Option(
        "--particles", "-n", help="Discs in the periodic cell (the report: 25; Fig. 3.6: "
                                  "250).")] = 25,
    axial_strain: Annotated[float, typer.Option(
        "--axial-strain", help="The oedometer's final vertical strain.")] = 0.005,
    eps_q_max: Annotated[float, typer.Option(
        "--eps-q", help="The biaxial test's final eps_1 - eps_3.")] = 0.05,
    distributions: Annotated[list[str] | None, typer.Option(
        "--distribution", help="A distribution law of the model; repeat. Default: "
                               "homogeneous, maxwellian-average, maxwellian-first-order.")
    ] = None,
    model_steps: Annotated[int, typer.Option(
        "--model-steps", help="About how many steps each model takes over its path.")] = 100,
    overwrite: Annotated[bool, typer.Option(
        "--overwrite", help="Run every case again (default: reuse the runs that ended).")
    ] = False,
) -> None:
    """Seed 001 chapter 3: the report's periodic packing of 25 discs (12 of radius 0.21 mm,
    13 of 0.105 mm, compressed by the simulation to 203 kPa, linear springs k_n = 200 kN/m)
    run by soft-contact DEM and predicted by the micro-element model of each simulated
    packing, per --distribution: one-dimensional compression at each --phi-mu (K0, Fig. 3.3)
    and biaxial compression at each --stiffness-ratio (q/p = (s_v - s_h)/(s_v + s_h) and the
    volumetric strain, Figs. 3.4-3.5; several --sigma0 and -n 250 for Fig. 3.6), each on
    every --seed. Writes OUT/CASE/ (each run and its models, as `grainlab theory-vs-sim`),
    OUT/series.csv (every case and side), OUT/series-summary.csv (mean, min, max over the
    seeds), OUT/series-curves.csv, OUT/packing.png (the first packing, Fig. 3.1), OUT/k0.png and
    OUT/biaxial-ksR.png. Run again, it reuses
    the runs that ended."""
    from grainlab.lab.run_outcome import EXIT_NOT_AS_ASKED
    from grainlab.lab.theory_series import SeriesPlan, run_series
    from grainlab.report.curves import save_figure
    from grainlab.report.theory_series_figures import biaxial_figure, k0_figure

    defaults = SeriesPlan.__dataclass_fields__
    plan = SeriesPlan(
        tests=tuple(tests or defaults["tests"].default),
        seeds=tuple(seeds if seeds is not None else defaults["seeds"].default),
        k0_angles=tuple(angles or defaults["k0_angles"].default),
        biaxial_angle=biaxial_angle,
        stiffness_ratios=tuple(ratios or defaults["stiffness_ratios"].default),
        sigma0s=tuple(sigma0s or defaults["sigma0s"].default),
        n_particles=n_particles, axial_strain=axial_strain, eps_q_max=eps_q_max,
        distributions=tuple(distributions or defaults["distributions"].default),
        model_steps=model_steps)
    output_folder("--out", out)
    console.print(f"series folder [bold]{out}[/]: {len(plan.cases)} runs of "
                  f"{plan.n_particles} discs, each with the model of its packing "
                  f"({', '.join(plan.distributions)})")
    start = time.perf_counter()

    def told(case, words: str) -> None:
        console.print(f"  {escape(case.folder_name)}: {words} "
                      f"({time.perf_counter() - start:.0f} s)", highlight=False)

    outcome = run_series(plan, out, overwrite=overwrite, report=told)
    if not len(outcome.table):
        console.print("[bold red]no case ran to a result[/]")
        raise typer.Exit(code=EXIT_NOT_AS_ASKED)
    summary = outcome.summary()
    outcome.table.to_csv(out / "series.csv", index=False)
    summary.to_csv(out / "series-summary.csv", index=False)
    outcome.curves.to_csv(out / "series-curves.csv", index=False)
    figures = [_packing(plan, out, save_figure)]
    if "oedometer" in set(outcome.curves["test"]):
        figures.append(save_figure(k0_figure(outcome.curves), out / "k0.png", dpi=120))
    biaxial = outcome.curves[outcome.curves["test"] == "biaxial"]
    for ratio in dict.fromkeys(biaxial["stiffness_ratio"]):
        figures.append(save_figure(biaxial_figure(outcome.curves, ratio),
                                   out / f"biaxial-ks{ratio:g}.png", dpi=120))
    for test in dict.fromkeys(summary["test"]):
        print_wide(summary_table(summary, test))
    for line in outcome.problems:
        console.print(f"[bold yellow]{escape(line)}[/]", soft_wrap=True)
    console.print(f"table: {out / 'series.csv'}, {out / 'series-summary.csv'}")
    for path in figures:
        console.print(f"figure: {path}")
    if any("blew up" in line or "not as asked" in line for line in outcome.problems):
        raise typer.Exit(code=EXIT_NOT_AS_ASKED)


def _packing(plan, out: Path, save_figure) -> Path:
    """OUT/packing.png: the first case's packing at the end of its compaction (Fig. 3.1)."""
    from grainlab.lab.run_micro_element import compaction_snapshot
    from grainlab.report.theory_series_figures import packing_figure

    case = plan.cases[0]
    network = compaction_snapshot(out / case.folder_name / "snapshots.h5")
    title = (f"seed {case.seed} at the end of its compaction to {case.sigma0 / 1e3:g} kPa: "
             f"{len(network.positions)} discs, {len(network.pair_particles)} contacts")
    return save_figure(packing_figure(network, title), out / "packing.png", dpi=120)
