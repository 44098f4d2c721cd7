"""``grainlab theory-vs-sim KIND``: one discrete run and seed 001's micro-element model of its
own packing on the same load path, overlaid (:mod:`grainlab.lab.theory_comparison`,
:mod:`grainlab.report.theory_comparison`).

A verb of its own rather than ``compare --theory``: ``compare`` runs one test with both
solvers (OUT/cd, OUT/dem) and refuses ``--solver``; this runs it with one solver (``--solver``,
contact dynamics by default) into OUT/run and then the model, once per ``--distribution``.

Exit status as the other discrete commands: 0 when the run did what was asked (a model that
reached its strength before the end of the path is a result, stated in the table); 3 when
the run blew up or its outcome is not as asked (the comparison is still written when the
run has results); 2 on bad input, with one message.
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
from grainlab.cli.run_input import (
    as_typed,
    command_config,
    refuse_inert_options,
    sample_source,
)
from grainlab.cli.run_options import THEORY, takes_options
from grainlab.errors import InputError

RUN_FOLDER = "run"
"""The discrete run's folder inside OUT."""


def _shown(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.4g}"


def differences_table(table) -> Table:
    """The differences as a rich table: law, quantity, simulation, model, model - sim."""
    shown = Table(title="discrete run and micro-element model of its packing",
                  title_justify="left")
    for name in ("distribution", "quantity", "simulation", "model", "model - sim"):
        shown.add_column(name, justify="left" if name in ("distribution", "quantity")
                         else "right")
    for row in table.itertuples(index=False):
        shown.add_row(escape(row.distribution), escape(row.quantity), _shown(row.simulation),
                      _shown(row.model), _shown(row.model_minus_simulation))
    return shown


@friendly_errors
@takes_options(THEORY)
def theory_vs_sim_command(**options: Any) -> None:
    """Run a lab test on a discrete sample into OUT/run (the options of `grainlab test`;
    contact dynamics unless --solver dem), build seed 001's micro-element model from the
    contact-network snapshot at the end of its compaction (one micro-element per particle,
    the run's contact forces as its initial state, the run's springs and friction), drive it
    along the rest of the run's load path, once per --distribution, and overlay them
    (--law, --kappa, --young-modulus set the model's springs whatever the solver):
    OUT/theory.png (q/p and eps_vol against the vertical strain, or K0 and sigma_zz for an
    oedometer), OUT/theory.csv (both sides on the run's strain grid) and
    OUT/theory-differences.csv (peak q/p, q/p and eps_vol at the largest strain both reached,
    dilatancy rate, or K0 per stage; model - simulation). Run again with the same options, it
    reuses the run that ended and resumes one that was stopped; --overwrite starts over."""
    from grainlab.lab.discrete_run import DiscreteRun
    from grainlab.lab.run_micro_element import MODEL_KEYS, check_distributions
    from grainlab.lab.run_outcome import EXIT_NOT_AS_ASKED, RunOutcome
    from grainlab.lab.solver_comparison import open_solver_run
    from grainlab.lab.theory_comparison import TheoryComparison, check_theory_kind
    from grainlab.report.curves import save_figure
    from grainlab.report.theory_comparison import theory_comparison_figure

    kind, out = check_theory_kind(options["kind"]), options["out"]
    distributions = check_distributions(list(options["distributions"] or ["homogeneous"]))
    comparison = TheoryComparison(distributions, options["model_steps"])
    options = sample_source(THEORY, options)
    output_folder("--out", out)
    config, given = command_config(kind, options["config"], options, THEORY)
    read_by_the_model = {key: value for key, value in given.items() if key not in MODEL_KEYS}
    for note in refuse_inert_options([config], read_by_the_model, options["config"]):
        console.print(f"[bold yellow]note:[/] {escape(note)}", soft_wrap=True)
    if config.output.snapshot_every == 0:
        raise as_typed(InputError("output.snapshot_every", 0, (
            "> 0: the model is built from the snapshot at the end of the compaction (a run "
            "snapshots the state each stage ends in only when snapshot_every > 0)")),
            given, options["config"])
    folder = out / RUN_FOLDER
    try:
        opened = open_solver_run(folder, config, overwrite=options["overwrite"])
    except InputError as error:
        raise as_typed(error, given, options["config"]) from None
    if isinstance(opened, DiscreteRun):
        console.print(f"run folder [bold]{folder}[/] ({kind}, then the micro-element model "
                      f"of its packing: {', '.join(distributions)}); Ctrl-C checkpoints, the "
                      "same command again goes on")
        result, _, _ = complete_run(folder, opened, options["progress"])
        if result is None:
            console.print("[bold red]no comparison:[/] the run blew up (above)")
            raise typer.Exit(code=EXIT_NOT_AS_ASKED)
    else:
        console.print(f"the run in {folder} has ended: reused as it is")
    comparison.compute(folder)
    _write(comparison, out, save_figure, theory_comparison_figure)
    if not RunOutcome.of_result(comparison.result).as_asked:
        console.print(f"[bold red]run: outcome NOT as asked[/] ({folder / 'run.log'})",
                      highlight=False)
        raise typer.Exit(code=EXIT_NOT_AS_ASKED)


def _write(comparison, out, save_figure, figure_of) -> None:
    """Write and print the comparison's files and table."""
    for name, reason in comparison.failures.items():
        console.print(f"[bold yellow]{name}:[/] the model could not start the path "
                      f"({escape(reason)})", soft_wrap=True)
    for name, test in comparison.models.items():
        outcome = test.metadata.get("outcome", {})
        test.table.to_csv(out / f"model-{name}.csv", index=False)
        if outcome.get("status") != "completed":
            console.print(f"[bold yellow]{name}:[/] the model stopped in stage "
                          f"{outcome.get('stage')} ({escape(str(outcome.get('reason')))})",
                          soft_wrap=True)
    comparison.curves.to_csv(out / "theory.csv", index=False)
    comparison.differences.to_csv(out / "theory-differences.csv", index=False)
    figure = save_figure(figure_of(comparison), out / "theory.png", dpi=120)
    console.print(differences_table(comparison.differences))
    console.print(f"table: {out / 'theory.csv'}, {out / 'theory-differences.csv'}")
    console.print(f"figure: {figure}")
