"""``grainlab theory-b-sweep``: the 3D comparison of seed 001's model with the simulation of
its packing — one periodic packing of spheres through the cubical tests over b, at constant
sigma_3 and at constant p, and the micro-element model of each simulated packing under
every distribution law (:mod:`grainlab.lab.theory_b_sweep`,
:func:`grainlab.report.theory_series_figures.b_sweep_figure`).

Exit status: 0 when every run did what was asked; 3 when a run blew up or ended otherwise than
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


def sweep_table(table) -> Table:
    """The peak angles as a rich table: a row per path and b, a column per side."""
    sides = list(dict.fromkeys(table["side"]))
    shown = Table(title="peak mobilised angle [deg] (how the side ended)", title_justify="left")
    for name in ("path", "b", *sides):
        shown.add_column(escape(name), justify="left" if name == "path" else "right")
    for (path, b), rows in table.groupby(["path", "b"], sort=False):
        cells = []
        for side in sides:
            row = rows[rows["side"] == side]
            if not len(row):
                cells.append("-")
                continue
            angle, ended = row["peak_phi"].iloc[0], row["ended"].iloc[0]
            cells.append(("-" if not math.isfinite(angle) else f"{angle:.1f}")
                         + f" ({escape(ended)})")
        shown.add_row(escape(path), f"{b:g}", *cells)
    return shown


@friendly_errors
def theory_b_sweep_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="The sweep's folder.")] = Path(
        "theory-b-sweep"),
    paths: Annotated[list[str] | None, typer.Option(
        "--path", help="cubical (constant sigma_3, the report's) and/or true_triaxial "
                       "(constant p); repeat. Default: both.")] = None,
    b_values: Annotated[list[float] | None, typer.Option(
        "--b", help="b = (s2 - s3)/(s1 - s3) of a test; repeat. Default: 0 0.3 0.6 1.")
    ] = None,
    n_particles: Annotated[int, typer.Option("--n-particles", "-n",
                                             help="Spheres in the periodic cell.")] = 1000,
    size_ratio: Annotated[float, typer.Option("--size-ratio",
                                              help="d_max / d_min.")] = 1.5,
    seed: Annotated[int, typer.Option("--seed", help="The sample's seed.")] = 1,
    sigma0: Annotated[float, typer.Option(
        "--sigma0", help="sigma_3 (cubical) or p (true_triaxial) held, and the compaction's "
                         "pressure [Pa].")] = 1e5,
    mu: Annotated[float, typer.Option("--mu", help="The loading's friction coefficient.")
                  ] = 0.4,
    eps_q: Annotated[float, typer.Option("--eps-q", help="Each test ends at eps_1 - eps_3 "
                                                         "= EPS_Q.")] = 0.05,
    inertia: Annotated[float, typer.Option("--inertia", help="The loading's inertia-number "
                                                             "bound.")] = 0.01,
    solver: Annotated[str, typer.Option("--solver", help="cd (rigid grains) or dem.")
                      ] = "cd",
    distributions: Annotated[list[str] | None, typer.Option(
        "--distribution", help="A distribution law of the model; repeat. Default: all four.")
    ] = None,
    model_steps: Annotated[int, typer.Option(
        "--model-steps", help="About how many steps each model takes over its path.")
    ] = 1000,
    overwrite: Annotated[bool, typer.Option(
        "--overwrite", help="Run every test again (default: reuse the runs that ended).")
    ] = False,
) -> None:
    """One periodic packing of spheres through the cubical tests at each --b, at constant
    sigma_3 (--path cubical: Lade & Duncan's protocol, the report's) and at constant p
    (--path true_triaxial), each run by the discrete engine and predicted by seed 001's
    micro-element model of the simulated packing (its forces as the initial state) under
    each --distribution. Writes OUT/PATH-bB/ (each run and its models, as `grainlab
    theory-vs-sim`), OUT/b_sweep.csv (peak mobilised angle and how each side ended) and
    OUT/b_sweep.png (angle against b, the report's 41 / 48 / 45 deg marked). Run again, it
    reuses the runs that ended."""
    from grainlab.lab.run_outcome import EXIT_NOT_AS_ASKED
    from grainlab.lab.theory_b_sweep import ALL_LAWS, BSweepPlan, run_b_sweep
    from grainlab.report.curves import save_figure
    from grainlab.report.theory_series_figures import b_sweep_figure

    plan = BSweepPlan(paths=tuple(paths or ("cubical", "true_triaxial")),
                      b_values=tuple(b_values if b_values else (0.0, 0.3, 0.6, 1.0)),
                      n_particles=n_particles, size_ratio=size_ratio, seed=seed,
                      sigma0=sigma0, friction=mu, eps_q_max=eps_q, inertia_number=inertia,
                      solver=solver, distributions=tuple(distributions or ALL_LAWS),
                      model_steps=model_steps)
    for path, b in plan.cases[:1]:
        plan.config(path, b)  # the sample's and loading's values, checked before any run
    output_folder("--out", out)
    console.print(f"sweep folder [bold]{out}[/]: {len(plan.cases)} runs of {n_particles} "
                  f"spheres, each with the model of its packing "
                  f"({', '.join(plan.distributions)})")
    start = time.perf_counter()

    def told(path: str, b: float, words: str) -> None:
        console.print(f"  {path} b = {b:g}: {words} ({time.perf_counter() - start:.0f} s)",
                      highlight=False)

    table = run_b_sweep(plan, out, overwrite=overwrite, report=told)
    table.to_csv(out / "b_sweep.csv", index=False)
    title = (f"{n_particles} spheres, mu = {mu:g}, sigma0 = {sigma0:g} Pa, seed {seed}, "
             f"{solver}")
    figure = save_figure(b_sweep_figure(table, title), out / "b_sweep.png", dpi=120)
    print_wide(sweep_table(table), width=170)
    console.print(f"table: {out / 'b_sweep.csv'}")
    console.print(f"figure: {figure}")
    runs = table[table["side"] == "simulation"]
    if (runs["ended"] != "as asked").any():
        raise typer.Exit(code=EXIT_NOT_AS_ASKED)
