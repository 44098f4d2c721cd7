"""``grainlab triaxial | compaction | oedometer | test KIND | resume | vtk``: lab tests on a
discrete sample (contact dynamics or soft-contact DEM), run in a folder that can be resumed.

The commands' options are declared once, in :mod:`grainlab.cli.run_options`; what they ask
for is read in :mod:`grainlab.cli.run_input`; the summary and figures of a run that ended are
the report layer's (:mod:`grainlab.report.run_summary`).

Exit status: 0 when the run did what was asked; 3 when it ran but its outcome is not what was
asked (a stage not reached, the inertia bound exceeded, a blow-up: the summary and run.log say
why; :mod:`grainlab.lab.run_outcome`); 2 on bad input or when a run cannot go on (no
checkpoint, damaged checkpoints, a full disk), with one message.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape

from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import output_folder
from grainlab.cli.run_input import as_typed, asked_config, sample_source
from grainlab.cli.run_options import PROGRESS_HELP, SET_HELP, takes_options
from grainlab.errors import InputError
from grainlab.lab.run_config import TEST_KINDS
from grainlab.prep.sample_shapes import particles_text

console = Console()


def print_wide(renderable, width: int = 140) -> None:
    """Print a wide table unbroken when the output is a pipe or a file (80 columns there
    by default); on a terminal, at the terminal's width."""
    (console if console.is_terminal else Console(width=max(console.width, width))).print(
        renderable)


def _report(folder: Path) -> None:
    """Write the run's report (:func:`~grainlab.report.run_report.write_run_report`); a
    failure is a warning, never the run's failure: the results are already on disk and
    `grainlab report RUN` writes it again."""
    from grainlab.report.run_report import write_run_report

    try:
        path = write_run_report(folder)
    except Exception as error:  # the run's files are written: a report that fails warns
        console.print(f"[bold yellow]warning:[/] the report was not written ({error}); "
                      f"try `grainlab report {folder}`")
        return
    console.print(f"report: {path}")


def complete_run(folder: Path, run, progress: bool) -> tuple[Any, list[Path], Any]:
    """Run to the end, print the summary, the outcome in words and the figures, and write
    the report (RUN/report/report.md) of a run that finished. Returns the
    result, the figures and the :class:`~grainlab.lab.run_outcome.RunOutcome`; a blow-up is
    printed and returns (None, [], None)."""
    from grainlab.engine.simulation import SimulationBlowUp
    from grainlab.lab.run_outcome import RunOutcome
    from grainlab.report.run_summary import run_summary, write_run_figures

    for note in run.notes:
        console.print(f"[bold yellow]note:[/] {note}")
    try:
        result = run.run(progress=progress)
    except SimulationBlowUp as error:
        console.print(f"[bold red]blow-up:[/] {escape(str(error))}", soft_wrap=True)
        return None, [], None
    outcome = RunOutcome.of_result(result)
    figures = []
    if len(result.table):
        title, *lines = run_summary(result)
        console.print(f"[bold]{escape(title)}[/]")
        for line in lines:
            console.print(escape(line))
        figures = write_run_figures(folder, result)
        for path in figures:
            console.print(f"figure: {path}")
    if outcome.finished:
        _report(folder)
    words = outcome.summary().replace("grainlab resume RUN", f"grainlab resume {folder}")
    head, *lines = words.splitlines()
    console.print(f"[bold {'green' if outcome.as_asked else 'red'}]{head}[/]",
                  highlight=False)
    for line in lines:
        console.print(line, highlight=False)
    return result, figures, outcome


def finish_run(folder: Path, run, progress: bool) -> tuple[Any, list[Path]]:
    """:func:`complete_run`, then exit 3 when the run blew up or its outcome is not as asked.
    Returns the result and the figures."""
    from grainlab.lab.run_outcome import EXIT_NOT_AS_ASKED

    result, figures, outcome = complete_run(folder, run, progress)
    if outcome is None or not outcome.as_asked:
        raise typer.Exit(code=EXIT_NOT_AS_ASKED)
    return result, figures


def _run(command: str, kind: str, options: dict[str, Any]) -> None:
    """Check every option of ``command`` (:mod:`grainlab.cli.run_input`), then start the run
    of test ``kind``: nothing is written before the input is accepted, and a rejected start
    leaves OUT as it was."""
    from grainlab.lab.discrete_run import start_run

    options = sample_source(command, options)
    out, config_file = options["out"], options["config"]
    output_folder("--out", out)
    config, given = asked_config(kind, config_file, options, command)
    try:
        run = start_run(out, config, overwrite=options["overwrite"])
    except InputError as error:
        raise as_typed(error, given, config_file) from None
    sample = run.test.sample
    shapes = particles_text(sample.description)
    console.print(f"run folder [bold]{out}[/] ({sample.state.n_bodies} {shapes}, {kind}); "
                  f"Ctrl-C checkpoints, "
                  f"`grainlab resume {out}` continues")
    finish_run(out, run, options["progress"])


@friendly_errors
@takes_options("triaxial")
def triaxial_command(**options: Any) -> None:
    """Triaxial compression of a discrete sample, as Azéma, Radjaï & Dubois 2013
    (polyhedra) and Azéma et al. 2013 (aggregates): a loose random sample, frictionless
    isotropic compaction to SIGMA0 until quasi-static, then the top wall at a constant strain
    rate (inertia number <= INERTIA), the lateral walls at SIGMA0, friction MU, until
    eps_q = eps_1 - eps_3 reaches EPS_Q."""
    _run("triaxial", "triaxial", options)


@friendly_errors
@takes_options("compaction")
def compaction_command(**options: Any) -> None:
    """Isotropic compaction of a loose random sample to SIGMA0 (no gravity, no friction: the
    preparation of Azéma, Radjaï & Dubois 2013) until quasi-static; reports the packing
    fraction and the coordination number z."""
    _run("compaction", "compaction", options)


@friendly_errors
@takes_options("oedometer")
def oedometer_command(**options: Any) -> None:
    """Oedometer (1-D compression, lateral walls fixed) of a discrete sample after
    isotropic compaction to SIGMA0: loading by AXIAL_STRAIN, then unloading by UNLOAD_STRAIN
    (each stage ends on its strain, whatever --record-every); K0 = (sigma_xx + sigma_yy) /
    (2 sigma_zz) in the results (column K0), the summary and curves.png (K0 and sigma_zz
    against eps_zz). On rigid grains the test is degenerate: the sample cannot compress
    beyond rearrangement, sigma_zz comes from the overlaps the solver leaves and from the
    loading rate, and K0 is not an elastic K0 (until deformable contacts exist)."""
    _run("oedometer", "oedometer", options)


@friendly_errors
@takes_options("test")
def lab_test_command(**options: Any) -> None:
    """Any lab test on a discrete sample: a loose random sample, frictionless isotropic
    compaction to SIGMA0 until quasi-static, then KIND: triaxial (compression to EPS_Q at
    lateral stress SIGMA0), extension, oedometer (in a periodic cell with --solver dem only:
    rigid grains cannot follow it there), true_triaxial (constant p and B to EPS_Q),
    cubical (Lade & Duncan's: constant sigma_3 = SIGMA0 and B to EPS_Q), simple_shear
    (gamma_xz to GAMMA, sigma_zz held, eps_xx = eps_yy = 0), circular (a full
    turn on the octahedral plane at q = Q_RATIO x SIGMA0), cyclic_shear (CYCLES of gamma_xz
    between +-AMPLITUDE), in a box of walls or (--boundary periodic) a periodic cell whose
    six components follow the test."""
    kind = options["kind"]
    if kind not in TEST_KINDS:
        raise InputError("KIND", kind, "one of " + ", ".join(TEST_KINDS))
    _run("test", kind, options)


@friendly_errors
def resume_command(
    run: Path = typer.Argument(..., help="The run folder to continue."),
    set_: list[str] = typer.Option(
        None, "--set", metavar="SECTION.KEY=VALUE",
        help=SET_HELP),
    restart: bool = typer.Option(
        False, "--restart",
        help="Start the run over from step 0 with its config.toml (and --set, any key), "
             "after moving its results, snapshots, log and checkpoints to RUN/previous-N."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help=PROGRESS_HELP),
) -> None:
    """Continue a run from its last checkpoint (after Ctrl-C, SIGTERM, kill -9, a crash, a
    blow-up or a stage stopped at max_stage_steps): results and snapshots are cut back to the
    checkpoint and the run goes on. If checkpoint.h5 is damaged, from checkpoint.prev.h5 (the
    one before). Without a usable checkpoint it stops and touches nothing (see --restart)."""
    from grainlab.lab.discrete_run import resume_run

    discrete = resume_run(run, list(set_ or []), restart=restart)
    console.print(f"{'restarting' if restart else 'resuming'} [bold]{run}[/] at step "
                  f"{discrete.test.simulation.step_index}")
    finish_run(run, discrete, progress)


@friendly_errors
def vtk_command(
    run: Path = typer.Argument(..., help="A run folder."),
    out: Path = typer.Option(None, "--out", help="Folder for the files [RUN/vtk-checkpoint]."),
) -> None:
    """Write the run's last checkpoint as ParaView files: particles as their true shapes,
    the walls, and the contacts (lines carrying force) of the snapshot taken at the
    checkpoint's step, if any. A damaged last checkpoint is refused, with how to recover."""
    from grainlab.lab.discrete_run import export_checkpoint_vtk

    if out is not None:
        output_folder("--out", out)
    paths = export_checkpoint_vtk(run, out)
    for path in paths:
        console.print(f"wrote {path}")
    if not any(path.name.startswith("contacts_") for path in paths):
        console.print("no contacts drawn: no snapshot was taken at the checkpoint's step "
                      "(output.snapshot_every)")

