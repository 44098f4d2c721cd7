"""Entry point of the ``grainlab`` command."""

from __future__ import annotations

import typer
from rich.console import Console

from grainlab._version import __version__
from grainlab.cli import (
    analyse,
    compare,
    demo,
    discrete,
    microelement,
    packing2d,
    precompile,
    report,
    study,
    theory_b_sweep,
    theory_series,
    theory_vs_sim,
)

app = typer.Typer(
    help=(
        "grainlab — a virtual laboratory for granular materials. Describe particles, run the "
        "tests a soil or powder lab runs, on a micromechanical theory or a discrete "
        "simulation (contact dynamics) of the packing, and read the answer as a test result "
        "(CSV/HDF5) with figures. Start with `grainlab demo`."
    ),
    no_args_is_help=True,
    rich_markup_mode="markdown",
    pretty_exceptions_enable=False,
)
app.add_typer(packing2d.app, name="packing2d")
app.command("analyse")(analyse.analyse_command)
app.add_typer(microelement.app, name="microelement")
app.command("triaxial")(discrete.triaxial_command)
app.command("compaction")(discrete.compaction_command)
app.command("oedometer")(discrete.oedometer_command)
app.command("test")(discrete.lab_test_command)
app.command("compare")(compare.compare_command)
app.command("theory-vs-sim")(theory_vs_sim.theory_vs_sim_command)
app.command("theory-series")(theory_series.theory_series_command)
app.command("theory-b-sweep")(theory_b_sweep.theory_b_sweep_command)
app.command("resume")(discrete.resume_command)
app.command("vtk")(discrete.vtk_command)
app.command("report")(report.report_command)
app.command("demo")(demo.demo)
app.command("compile")(precompile.compile_command)
app.add_typer(study.app, name="study")
console = Console()


@app.command()
def version() -> None:
    """Print grainlab's version."""
    console.print(__version__)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
