"""``grainlab compare KIND``: one lab test run with contact dynamics and with soft-contact DEM
on the same sample, the two runs overlaid (:mod:`grainlab.lab.solver_comparison`,
:mod:`grainlab.report.solver_comparison`).

Exit status as the other discrete commands: 0 when both runs did what was asked; 3 when a run
blew up or its outcome is not as asked (the comparison is still written when both have
results); 2 on bad input, with one message.
"""

from __future__ import annotations

import math
from typing import Any

import typer
from rich.markup import escape
from rich.table import Table

from grainlab.cli.discrete import complete_run, console
from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import output_folder
from grainlab.cli.run_input import Given, as_typed, command_config, refuse_inert_options
from grainlab.cli.run_options import takes_options
from grainlab.errors import InputError
from grainlab.lab.run_config import TEST_KINDS
from grainlab.lab.solver_registry import COMPARED, solver_record
from grainlab.prep.sample_shapes import particles_text

COMPARE_KINDS = TEST_KINDS
"""The lab tests ``grainlab compare`` runs: every test of a discrete run."""


def _shown(value: float, unit: str) -> str:
    if not math.isfinite(value):
        return "-"
    if unit == "s":
        return f"{value:.1f}"
    if float(value).is_integer() and abs(value) >= 1:
        return f"{int(value)}"
    return f"{value:.4g}"


def comparison_table(table, pair: tuple[str, str] = COMPARED) -> Table:
    """The comparison as a rich table: quantity (unit), each solver of ``pair`` (reference,
    other), other - reference, other / reference."""
    from grainlab.lab.solver_comparison import difference_columns

    reference, other = pair
    minus, over = difference_columns(pair)
    shown = Table(title=" and ".join(f"{solver_record(m).title} ({m})" for m in pair),
                  title_justify="left")
    for name in ("quantity", reference, other, f"{other} - {reference}",
                 f"{other} / {reference}"):
        shown.add_column(name, justify="left" if name == "quantity" else "right")
    for row in table.to_dict("records"):
        unit = "" if row["unit"] == "-" else f" [{row['unit']}]"
        ratio = row[over]
        shown.add_row(escape(f"{row['meaning']}{unit}"), _shown(row[reference], row["unit"]),
                      _shown(row[other], row["unit"]), _shown(row[minus], row["unit"]),
                      "-" if not math.isfinite(ratio) else f"{ratio:.3g}")
    return shown


@friendly_errors
@takes_options("compare")
def compare_command(**options: Any) -> None:
    """Run one lab test twice on the same sample (same seed, same preparation): with contact
    dynamics into OUT/cd and with soft-contact DEM into OUT/dem, then overlay them:
    OUT/compare.png (the test's main curves, both solvers on the same axes) and
    OUT/compare.csv (per solver the peak and residual q/p, or the state at the end of each
    stage, packing fraction, z, K0, wall time, steps, DEM sub-steps; DEM - CD and DEM / CD).
    KIND and the options are those of `grainlab test` (--tolerance and --max-iterations set
    the compaction's when KIND is compaction); the DEM options (--law, --kappa, --young-modulus,
    --restitution, [solver.dem]) act on the DEM run, --sweep, --tolerance and
    --max-iterations on the CD run. Run again with the same options, it reuses a run that
    ended and resumes one that was stopped (Ctrl-C checkpoints); --overwrite starts both
    over."""
    from grainlab.lab.run_outcome import EXIT_NOT_AS_ASKED, RunOutcome
    from grainlab.lab.solver_comparison import (
        SOLVERS,
        SolverComparison,
        check_solver_run,
        solver_configs,
    )
    from grainlab.report.curves import save_figure
    from grainlab.report.solver_comparison import solver_comparison_figure

    kind, out, config = options["kind"], options["out"], options["config"]
    if kind not in COMPARE_KINDS:
        raise InputError("KIND", kind, "one of " + ", ".join(COMPARE_KINDS))
    if options["solver"] is not None:
        raise InputError("--solver", options["solver"], (
            "no --solver: compare runs the test with both solvers, "
            + " and ".join(f"{m} into OUT/{m}" for m in SOLVERS)
            + " (each solver's own settings: its options and [solver.KEY] table)"))
    output_folder("--out", out)
    asked, given = command_config(kind, config, options, "compare")
    configs = solver_configs(asked)
    for note in refuse_inert_options([configs[method] for method in SOLVERS], given, config):
        console.print(f"[bold yellow]note:[/] {escape(note)}", soft_wrap=True)
    try:
        for method in SOLVERS:  # both refused or accepted before either is written
            check_solver_run(out / method, configs[method], overwrite=options["overwrite"])
    except InputError as error:
        raise as_typed(error, given, config) from None
    sample = asked.sample
    where = ", ".join(f"{solver_record(m).title} in {out / m}" for m in SOLVERS)
    console.print(f"comparison folder [bold]{out}[/] ({sample.n_particles} "
                  f"{particles_text(sample.model_dump())}, {kind}): {where}; Ctrl-C "
                  "checkpoints, the same command again goes on")
    has_result = _run_both(configs, given, options)
    if not all(has_result.values()):
        failed = " and ".join(m for m, done in has_result.items() if not done)
        console.print(f"[bold red]no comparison:[/] the {failed} run blew up (above); "
                      "resume it with other settings (`grainlab resume RUN --set ...`), then "
                      "run this command again")
        raise typer.Exit(code=EXIT_NOT_AS_ASKED)
    comparison = SolverComparison().compute({method: out / method for method in SOLVERS})
    table_path = out / "compare.csv"
    comparison.table.to_csv(table_path, index=False)
    figure = save_figure(solver_comparison_figure(comparison), out / "compare.png", dpi=120)
    console.print(comparison_table(comparison.table))
    console.print(f"table: {table_path}")
    console.print(f"figure: {figure}")
    missed = [m for m in SOLVERS
              if not RunOutcome.of_result(comparison.results[m]).as_asked]
    for method in missed:
        console.print(f"[bold red]{method}: outcome NOT as asked[/] (its summary above, or "
                      f"{out / method / 'run.log'})", highlight=False)
    if missed:
        raise typer.Exit(code=EXIT_NOT_AS_ASKED)


def _run_both(configs: dict[str, Any], given: Given, options: dict[str, Any]
              ) -> dict[str, bool]:
    """Run (start, resume or reuse) the test with each solver of the pair into OUT/<solver>
    (both checked already); whether each has a result (False: it blew up)."""
    from grainlab.lab.discrete_run import DiscreteRun
    from grainlab.lab.run_outcome import RunCost, RunOutcome
    from grainlab.lab.solver_comparison import SOLVER_NAMES, SOLVERS, open_solver_run

    out, config, overwrite = options["out"], options["config"], options["overwrite"]
    has_result: dict[str, bool] = {}
    for method in SOLVERS:
        folder = out / method
        try:
            opened = open_solver_run(folder, configs[method], overwrite=overwrite)
        except InputError as error:
            raise as_typed(error, given, config) from None
        name = f"[bold]{method}[/] ({SOLVER_NAMES[method]})"
        if not isinstance(opened, DiscreteRun):
            outcome, cost = RunOutcome.of_result(opened), RunCost.of_result(opened)
            console.print(f"{name}: the run in {folder} has ended ({cost.steps} steps, "
                          f"outcome {outcome.status}): reused as it is")
            has_result[method] = True
            continue
        step = opened.test.simulation.step_index
        console.print(f"{name}: {'resuming' if opened.resumed else 'starting'} the run in "
                      f"{folder}" + (f" at step {step}" if opened.resumed else ""))
        result, _, _ = complete_run(folder, opened, options["progress"])
        has_result[method] = result is not None
    return has_result
