"""``grainlab study``: the shape series of seeds 002 and 003 (or any series a TOML file lists)
as one resumable study on Dask, with its summary table, figures and report."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from grainlab.cli.errors import friendly_errors
from grainlab.errors import InputError
from grainlab.study.series_presets import BOUNDARIES, LENGTHS, REPLICATED, series_spec
from grainlab.study.study_runner import SPEC, Study, StudyInterrupted
from grainlab.study.study_spec import StudySpec

console = Console()
app = typer.Typer(
    help=("Studies: a series of samples that differ by one shape parameter, prepared as the "
          "papers did (one sphere packing built layer by layer, every shape inscribed in "
          "it), each run as its own run folder on a Dask cluster (local by default), resumed "
          "where it stopped when the command is run again, then summarised in summary.csv "
          "and report/ (figures against the shape parameter, report.md)."),
    no_args_is_help=True)

_SCHEDULER = typer.Option(None, "--scheduler", help=(
    "Address of a running Dask scheduler (tcp://host:8786) to send the samples to; the study "
    "folder must be at the same path on every worker. Default: a local cluster."))
_WORKERS = typer.Option(None, "--workers", min=1, help=(
    "Local cluster: samples run at once (default: cores / threads)."))
_THREADS = typer.Option(1, "--threads", min=1, help="Numba threads per sample.")
_PROGRESS = typer.Option(True, "--progress/--no-progress", help="Show the study's display.")
_N = typer.Option(None, "--n-particles", "-n", min=2, help=(
    "Particles per sample (default: " + ", ".join(
        f"{length.particles} for --length {name}" for name, length in LENGTHS.items()) + "); "
    "in a periodic cell, a sample whose cell would get too thin for its largest particles "
    "gets more."))
_LENGTH = typer.Option("short", "--length", help="; ".join(
    f"{name}: {length.text}" for name, length in LENGTHS.items()) + ".")
_ONLY = typer.Option(None, "--only", help=(
    "Run only these samples (comma-separated names, e.g. S1,S8), in this order, those with a "
    "checkpoint first; the others are left as they are, and the report covers every sample "
    "that has ended."))
_BOUNDARY = typer.Option(None, "--boundary", help="; ".join(
    f"{name}: {words}" for name, words in BOUNDARIES.items()) + ". Default: the length's ("
    + ", ".join(f"{name}: {length.boundary}" for name, length in LENGTHS.items()) + ").")
_SEED = typer.Option(0, "--seed", min=0, help="Seed of the sphere packing shared by the "
                                              "samples, and of their shapes.")
_REPLICAS = typer.Option(1, "--replicas", min=1, help=(
    "Packings per repeated sample: the samples of --replicated run again with the seeds "
    "seed + 1, ..., seed + replicas - 1 (named like S4-seed1), and the report pools each "
    "with its repeats into one point whose error bars are the spread over the seeds."))
_REPLICATED = typer.Option(None, "--replicated", help=(
    "The samples --replicas repeats (comma-separated; default: "
    + "; ".join(f"{series}: {','.join(names)}" for series, names in REPLICATED.items())
    + ")."))


def _names(text: str | None) -> tuple[str, ...] | None:
    return tuple(n.strip() for n in text.split(",") if n.strip()) if text else None


def _run_study(study: Study, scheduler, workers, threads, progress, only) -> None:
    console.print(f"study {study.spec.study.name} in {study.folder}: "
                  f"{len(study.spec.samples)} samples ({study.spec.study.description})")
    names = list(_names(only) or ()) or None
    try:
        outcome = study.run(scheduler=scheduler, workers=workers, threads=threads,
                            progress=progress, only=names)
    except StudyInterrupted as error:
        console.print(str(error))
        raise typer.Exit(code=130) from None
    console.print(outcome.summary())
    ended = sum(state == "ended" for state in study.states().values())
    if ended < len(study.spec.samples):
        console.print(f"{ended} of {len(study.spec.samples)} samples have ended")
    _report(study)
    if not outcome.complete:
        console.print("the study is not complete: run the same command again to go on")
        raise typer.Exit(code=3)


def _report(study: Study) -> None:
    from grainlab.report.study_report import write_study_report
    from grainlab.study.study_summary import pooled_replicas, study_summary

    table = study_summary(study)
    if not len(table):
        console.print("no sample has ended yet: no summary or report")
        return
    path = write_study_report(study, pooled_replicas(table))
    console.print(f"summary: {study.folder / 'summary.csv'}\nreport: {path}")


def _preset(series: str, out: Path, n_particles, length, seed, scheduler, workers, threads,
            progress, only, **options) -> None:
    if length not in LENGTHS:
        raise InputError("--length", length, "one of " + ", ".join(LENGTHS))
    if options.get("boundary") not in (None, *BOUNDARIES):
        raise InputError("--boundary", options.get("boundary"), "one of " + ", ".join(BOUNDARIES))
    spec = series_spec(series, n_particles=n_particles, length=length, seed=seed, **options)
    _run_study(Study.create(out, spec), scheduler, workers, threads, progress, only)


@app.command("angularity")
@friendly_errors
def angularity_command(
    out: Path = typer.Option(Path("study-angularity"), "--out", "-o", help="Study folder."),
    n_particles: int = _N, length: str = _LENGTH, seed: int = _SEED,
    templates: int = typer.Option(None, "--templates", min=0, help=(
        "Polyhedra drawn once and reused in random orientations (0: every particle its own, "
        "as the paper; default 12 for short, 0 for full).")),
    boundary: str | None = _BOUNDARY, replicas: int = _REPLICAS, replicated: str = _REPLICATED,
    scheduler: str = _SCHEDULER, workers: int = _WORKERS, threads: int = _THREADS,
    only: str = _ONLY, progress: bool = _PROGRESS,
) -> None:
    """Seed 002's angularity series: spheres (S1) and polyhedra of 596, 176, 96, 46, 30, 20
    and 8 faces (S2 ... S8), inscribed in one sphere packing (walls) or each compacted from
    a loose packing of its own (a periodic cell, the full length's default); triaxial
    compression after a frictionless isotropic compaction. Run it again to resume."""
    _preset("angularity", out, n_particles, length, seed, scheduler, workers, threads,
            progress, only, templates=templates, boundary=boundary, replicas=replicas,
            replicated=_names(replicated))


@app.command("nonconvexity")
@friendly_errors
def nonconvexity_command(
    out: Path = typer.Option(Path("study-nonconvexity"), "--out", "-o", help="Study folder."),
    n_particles: int = _N, length: str = _LENGTH, seed: int = _SEED,
    boundary: str | None = _BOUNDARY, replicas: int = _REPLICAS, replicated: str = _REPLICATED,
    scheduler: str = _SCHEDULER, workers: int = _WORKERS, threads: int = _THREADS,
    only: str = _ONLY, progress: bool = _PROGRESS,
) -> None:
    """Seed 003's non-convexity series: aggregates of four spheres with eta = 0, 0.1, ...,
    0.7, inscribed in one sphere packing (walls) or each compacted from a loose packing of
    its own (a periodic cell, the full length's default); triaxial compression after a
    frictionless isotropic compaction. Run it again to resume."""
    _preset("nonconvexity", out, n_particles, length, seed, scheduler, workers, threads,
            progress, only, boundary=boundary, replicas=replicas,
            replicated=_names(replicated))


@app.command("run")
@friendly_errors
def run_command(
    source: Path = typer.Argument(..., help=(
        "A study TOML file (see the docs: [study], [base], [[samples]]) or a study folder to "
        "go on with.")),
    out: Path = typer.Option(None, "--out", "-o", help=(
        "Study folder for a TOML file (default: the file's name without .toml).")),
    scheduler: str = _SCHEDULER, workers: int = _WORKERS, threads: int = _THREADS,
    only: str = _ONLY, progress: bool = _PROGRESS,
) -> None:
    """Run (or go on with) any study: a TOML file listing samples, or a study folder."""
    if source.is_dir():
        study = Study.open(source)
    else:
        spec = StudySpec.read(source)
        study = Study.create(out or source.with_suffix(""), spec)
    _run_study(study, scheduler, workers, threads, progress, only)


@app.command("report")
@friendly_errors
def report_command(
    folder: Path = typer.Argument(..., help="A study folder."),
) -> None:
    """Write (again) the summary, figures and report of a study from its ended samples."""
    if not (folder / SPEC).exists():
        raise InputError("FOLDER", str(folder), f"a study folder with a {SPEC}")
    _report(Study.open(folder))


def _sizes(option: str, text: str | None) -> tuple[int, ...]:
    try:
        return tuple(int(part) for part in _names(text) or ())
    except ValueError:
        raise InputError(option, text, "comma-separated particle counts, e.g. 500,1000"
                         ) from None


@app.command("size-check")
@friendly_errors
def size_check_command(
    series: str = typer.Argument(..., help="The preset series: angularity or nonconvexity."),
    out: Path = typer.Option(None, "--out", "-o", help=(
        "Size-check folder, one study per boundary and size inside (default: "
        "size-check-<series>).")),
    samples: str = typer.Option(None, "--samples", help=(
        "Comma-separated sample names (default: S1,S5 for angularity; eta-0.0,eta-0.4 for "
        "nonconvexity).")),
    walls: str = typer.Option("500,1000,2000", "--walls", help=(
        "Particles per sample of the runs in a box of walls (comma-separated).")),
    periodic: str = typer.Option("1000", "--periodic", help=(
        "Particles per sample of the runs in a periodic cell (comma-separated): the bulk "
        "reference.")),
    length: str = typer.Option("full", "--length", help="; ".join(
        f"{name}: {spec.text}" for name, spec in LENGTHS.items()) + "."),
    seed: int = _SEED,
    cell_from: Path = typer.Option(None, "--cell-from", help=(
        "A study of the same series in a periodic cell (made with --boundary periodic and "
        "the same --length and --seed, e.g. studies/angularity-periodic-1000): its samples "
        "of the checked names are the check's cell, run and read there instead of a cell of "
        "the check's own; --periodic is then the series' size. Refused, naming the keys, "
        "where its settings differ.")),
    run: bool = typer.Option(True, "--run/--no-run", help=(
        "Run (or go on with) the studies; --no-run writes the table and report from the "
        "samples that have ended.")),
    scheduler: str = _SCHEDULER, workers: int = _WORKERS, threads: int = _THREADS,
    progress: bool = _PROGRESS,
) -> None:
    """The size check of a preset series: its samples in boxes of walls of several sizes
    and in a periodic cell, the core values (away from the walls) against the cell's as the
    box grows, and the cell's against the paper's; size_check.csv, size_check.md and a
    figure per sample, and the walls' cores after the compaction at other margins
    (size_check_margins.csv). Run it again to resume."""
    from grainlab.report.size_check_report import write_size_check_report
    from grainlab.study.size_check import (
        DEFAULT_SAMPLES,
        SizeCheckPlan,
        margin_table,
        run_size_check,
        size_check_table,
    )

    names = _names(samples) or DEFAULT_SAMPLES.get(series, ())
    plan = SizeCheckPlan(series, names, walls=_sizes("--walls", walls),
                         periodic=_sizes("--periodic", periodic), length=length, seed=seed,
                         cell_from=cell_from)
    folder = out or Path(f"size-check-{series}")
    complete = True
    if run:
        try:
            outcomes = run_size_check(
                folder, plan, scheduler=scheduler, workers=workers, threads=threads,
                progress=progress,
                on_end=lambda name, outcome: console.print(f"{name}: {outcome.summary()}"))
        except StudyInterrupted as error:
            console.print(str(error))
            raise typer.Exit(code=130) from None
        complete = len(outcomes) == len(plan.runs) and all(
            o.complete for o in outcomes.values())
    table = size_check_table(folder, plan)
    if not len(table):
        console.print("no sample has ended yet: no table or report")
    else:
        path = write_size_check_report(folder, plan, table, margin_table(folder, plan))
        console.print(f"table: {folder / 'size_check.csv'}\nreport: {path}")
    if not complete:
        console.print("the size check is not complete: run the same command again to go on")
        raise typer.Exit(code=3)


@app.command("compare")
@friendly_errors
def compare_command(
    folder: Path = typer.Argument(..., help="A study folder: the rerun."),
    reference: Path = typer.Option(..., "--reference", "-r", help=(
        "The study it should reproduce: a study folder or a published one (study.toml and "
        "summary.csv), e.g. docs/studies/nonconvexity-periodic-1000.")),
) -> None:
    """Whether a rerun reproduces a reference study: each sample's headline values (peak
    and residual strength, packing fraction, coordination and connectivity, anisotropy,
    sliding) against the reference's within their error bars (the residual window's
    standard deviation, or the spread over packing seeds measured on the reference's
    replicas), and the settings that differ; report/reproduction.md and .csv in the rerun's
    folder. Exit status 3 when a value lies outside its error bars, a sample is missing or
    the settings differ."""
    from rich.markup import escape
    from rich.table import Table

    from grainlab.study.reproduction import (
        counts_text,
        reproduction_counts,
        write_reproduction,
    )

    table, differences, path = write_reproduction(folder, reference)
    for name, keys in differences.items():
        console.print(f"[bold]settings differ[/bold] for {escape(name)}: "
                      + escape("; ".join(keys)))
    shown = Table(title=f"{folder} against {reference}", title_justify="left")
    for heading in ("sample", "quantity", "rerun", "reference", "reading"):
        shown.add_column(heading)
    for row in table.to_dict("records"):
        if row["quantity"] == "-":
            shown.add_row(escape(row["sample"]), "-", "-", "-", escape(row["verdict"]))
            continue
        shown.add_row(escape(row["sample"]), escape(row["quantity"]), f"{row['new']:.4g}",
                      f"{row['reference']:.4g}", escape(row["verdict"]))
    console.print(shown)
    counts = reproduction_counts(table)
    console.print(f"{counts_text(counts)}\nreport: {path}")
    if counts["disagree"] or counts["missing"] or differences:
        raise typer.Exit(code=3)


@app.command("publish")
@friendly_errors
def publish_command(
    folder: Path = typer.Argument(..., help="A study folder or a size-check folder."),
    to: Path = typer.Option(..., "--to", help=(
        "Destination folder (its files of the same names are replaced).")),
) -> None:
    """Copy a study's results, small enough to commit (study.toml, summary.csv, the report
    with its figures and its comparison with the paper, PROVENANCE.md with the versions, the
    machine and each run's cost), without the runs' checkpoints, snapshots and results; a
    size check with each of its studies."""
    from grainlab.study.publish import publish

    dest = publish(folder, to)
    size = sum(p.stat().st_size for p in dest.rglob("*") if p.is_file())
    console.print(f"published {folder} to {dest} ({size / 2**20:.1f} MiB)")


@app.command("slim")
@friendly_errors
def slim_command(
    folder: Path = typer.Argument(..., help="A study folder."),
) -> None:
    """Slim a study's ended samples: keep each one's summary row, its residual window's
    averaged distributions and the two snapshots the report draws (in samples/NAME/digest),
    remove its snapshots and checkpoints. The summary and report are written first and read
    the digests from then on, so the folder can be kept or moved to another machine and the
    study gone on with there (samples not ended are left to run)."""
    from grainlab.study.study_summary import slim_study

    study = Study.open(folder)
    _report(study)
    freed = slim_study(study)
    for name, size in freed.items():
        console.print(f"{name}: {size / 2**20:.1f} MiB freed")
    console.print(f"slimmed {len(freed)} sample(s) of {folder}, "
                  f"{sum(freed.values()) / 2**20:.1f} MiB freed")


RUNNING_WITHIN = 60.0
"""A sample whose progress was written this many seconds ago at most is running; an older
one has stopped (its state on disk says where)."""


def _status_rows(study: Study) -> list[tuple[str, ...]]:
    import json
    import time

    from grainlab.study.sample_task import PROGRESS, sample_state

    rows = []
    for name in study.spec.names:
        folder = study.sample_folder(name)
        state = sample_state(folder)
        stage = where = age = ""
        if state != "new" and (folder / PROGRESS).exists():
            try:
                progress = json.loads((folder / PROGRESS).read_text())
            except (OSError, ValueError):
                progress = {}
            stage = str(progress.get("stage", ""))
            fraction = progress.get("fraction")
            where = f"{fraction:.0%}" if isinstance(fraction, int | float) else ""
            written = progress.get("time")
            seconds = time.time() - written if isinstance(written, int | float) else None
            if seconds is not None:
                age = f"{max(0.0, seconds):.0f} s ago"
            if (progress.get("state") == "running" and state != "ended" and seconds is not None
                    and seconds < RUNNING_WITHIN):
                state = "running"
        rows.append((name, state, stage, where, age))
    return rows


def _study_folders(folder: Path) -> list[Path]:
    """``folder`` if it is a study folder, else the study folders in it (a size check)."""
    studies = [folder] if (folder / SPEC).exists() else \
        sorted(p for p in folder.iterdir() if (p / SPEC).exists()) if folder.is_dir() else []
    if not studies:
        raise InputError("FOLDER", str(folder), f"a study folder (with a {SPEC}) or a folder "
                         "of studies (a size check)")
    return studies


@app.command("status")
@friendly_errors
def status_command(
    folder: Path = typer.Argument(..., help="A study folder or a size-check folder."),
) -> None:
    """Where each sample of a study stands (new, started, partial: a checkpoint to resume
    from, running, ended), its stage, the share of its run done and when its progress was
    last written; every study of a size check."""
    from rich.table import Table

    studies = _study_folders(folder)
    for path in studies:
        study = Study.open(path)
        table = Table(title=f"{path} ({study.spec.study.description or study.spec.study.name})")
        for column in ("sample", "state", "stage", "done", "progress written"):
            table.add_column(column)
        rows = _status_rows(study)
        for row in rows:
            table.add_row(*row)
        console.print(table)
        ended = sum(row[1] == "ended" for row in rows)
        console.print(f"{ended} of {len(rows)} samples ended")


@app.command("stop")
@friendly_errors
def stop_command(
    folder: Path = typer.Argument(..., help="A study folder or a size-check folder."),
) -> None:
    """Ask a running study to stop as Ctrl-C does, from another shell (a study started in the
    background, under nohup or on a cluster): it writes the study's stop file, every running
    sample checkpoints and returns, and the study command ends, saying how to go on (the same
    command again). A study not running finds the file gone when it next starts."""
    from grainlab.study.sample_task import STOP_FILE

    studies = _study_folders(folder)
    for path in studies:
        (path / STOP_FILE).touch()
        console.print(f"{path}: asked its running samples to checkpoint and stop")
