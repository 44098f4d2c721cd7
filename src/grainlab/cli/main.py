"""Entry point of the ``grainlab`` command."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.console import Console

from grainlab._version import __version__
from grainlab.cli import analyse, discrete, microelement, packing2d
from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import output_folder

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
app.command("resume")(discrete.resume_command)
app.command("vtk")(discrete.vtk_command)
console = Console()


@app.command()
@friendly_errors
def demo(
    out: Path = typer.Option(Path("grainlab-demo"), help="Folder for the demo's outputs."),
) -> None:
    """Run the built-in demo: Table 1 of Chang, Misra & Xue 1989 (regular packings of
    discs), then their packing C loaded at alpha = 30 deg from 17.24 kPa to failure with the
    paper's constants; writes a test result (CSV, HDF5) and figures into OUT."""
    output_folder("--out", out)
    out.mkdir(parents=True, exist_ok=True)
    packing2d.table_command(csv=out / "table1.csv", tolerance=1e-6)
    model = packing2d.RegularPackingModel(
        packing2d.named_packing("C"), packing2d.ModifiedHertzMindlin2D.seed000()
    )
    path = packing2d.RotatedStressPath(alpha=np.radians(30.0))
    result = packing2d.run_rotated_stress_path(model, path)
    packing2d.save_figure(packing2d.tessellation_figure(model.packing), out / "tessellation_C.png")
    packing2d.report_load(model, result, out)


@app.command()
def version() -> None:
    """Print grainlab's version."""
    console.print(__version__)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
