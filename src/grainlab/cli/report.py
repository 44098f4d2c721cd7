"""``grainlab report RUN``: the report of a discrete run, one Markdown page with figures."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import output_folder
from grainlab.errors import InputError

console = Console()


@friendly_errors
def report_command(
    run: Path = typer.Argument(..., help="A run folder (config.toml, results.csv, "
                               "snapshots.h5)."),
    window: tuple[float, float] | None = typer.Option(
        None, "--window", metavar="LO HI",
        help="Strain window of eps_q (from the end of the compaction) for the residual "
             "state, e.g. --window 0.5 0.9 (seed 003) [default: the last 30 % of the eps_q "
             "reached]."),
    out: Path | None = typer.Option(None, "--out", help="Folder for report.md and its "
                                    "figures [RUN/report]."),
) -> None:
    """Write RUN/report/report.md: the sample and the test, the outcome, the wall time; q/p
    at its peak and, over the window, the mean ± standard deviation of q/p, the packing
    fraction, z and z_c; the microstructure averaged over the snapshots in the window
    (coordination, anisotropies, sliding, force PDFs and angular distributions with error
    bars), with PNG figures and CSV tables beside it."""
    from grainlab.report.run_report import write_run_report

    if out is not None:
        output_folder("--out", out)
    try:
        path = write_run_report(run, window=window, out=out)
    except InputError as error:
        if error.field != "window":
            raise
        raise InputError("--window", error.value, error.allowed) from None
    console.print(f"wrote {path}")
