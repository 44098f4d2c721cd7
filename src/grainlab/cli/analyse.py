"""``grainlab analyse``: the microstructure of a run's contact networks, table and figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from grainlab.analysis.snapshot_files import (
    count_snapshots,
    read_snapshots,
    resolve_snapshot_file,
    write_snapshots,
)
from grainlab.analysis.synthetic import synthetic_network
from grainlab.analysis.trajectory import TrajectoryAnalysis
from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import output_folder
from grainlab.errors import InputError
from grainlab.report.curves import save_figure
from grainlab.report.microstructure_figures import (
    anisotropy_evolution_figure,
    force_network_figure,
    force_pdf_figure,
    pair_mobilisation,
    polar_distributions_figure,
)

console = Console()

SUMMARY = (
    ("packing_fraction", "packing fraction"), ("coordination_number", "z"),
    ("connectivity_number", "z_c"), ("coordination_number_no_rattlers", "z (no rattlers)"),
    ("p", "p [Pa]"), ("q_over_trace", "q/p (q = (s1-s3)/3)"), ("sin_phi", "sin(phi)"),
    ("a_c", "a_c"), ("a_fn", "a_fn"), ("a_ft", "a_ft"), ("a_c_branch", "a'_c"),
    ("q_over_trace_27a", "q/p eq. 27a"), ("q_over_trace_27b", "q/p eq. 27b"),
    ("q_over_trace_B1", "q/p eq. B1"), ("sliding_proportion", "sliding proportion S"),
    ("mobilisation_index", "mobilisation I_mu"),
    ("mobilisation_index_harmonic", "I_mu from a_ft (eq. 28)"),
    ("mobilisation_index_branch", "mobilisation I' (branch frame)"),
    ("pearson_length_force", "C_lf"),
)


def parse_window(text: str) -> tuple[float, float]:
    """'0.5:0.9' -> (0.5, 0.9)."""
    try:
        low, high = (float(v) for v in text.split(":"))
    except ValueError:
        raise InputError("--window", text, "two strains as LOW:HIGH, e.g. 0.5:0.9") from None
    if low > high:
        raise InputError("--window", text, "LOW <= HIGH")
    return low, high


SYNTHETIC_SNAPSHOTS = 6
"""Snapshots of the series that ``--synthetic`` analyses."""


def synthetic_series(path: Path, n_points: int,
                     n_snapshots: int = SYNTHETIC_SNAPSHOTS) -> Path:
    """A snapshot file whose anisotropies grow with a fictitious eps_q (for trying things)."""
    networks = []
    for k, strain in enumerate(np.linspace(0.0, 1.0, n_snapshots)):
        growth = min(strain / 0.3, 1.0)
        net = synthetic_network(n_points, a_c=0.25 * growth, a_fn=0.35 * growth,
                                a_ft=0.12 * growth, seed=k)
        net.state.update({"step": k, "eps_q": float(strain)})
        networks.append(net)
    return write_snapshots(path, networks)


def analyse_command(
    path: Path | None = typer.Argument(
        None, help="A run folder (holding snapshots.h5) or a snapshot file (.h5)."
    ),
    out: Path = typer.Option(Path("analysis"), help="Folder for the table and figures."),
    snapshot: int = typer.Option(-1, help="Snapshot drawn in the figures (-1: the last)."),
    strain: str = typer.Option("eps_q", help="State column used as strain axis and window."),
    window: str = typer.Option("0.5:0.9", help="Strain window LOW:HIGH of the residual state."),
    min_contacts: int = typer.Option(2, help="Rattlers: fewer active neighbours, removed "
                                     "recursively."),
    frame_level: str = typer.Option("points", help="Contact frame from contact 'points' or "
                                    "from pair resultants ('pairs')."),
    angle_bins: int = typer.Option(18, help="Bins of the angular distributions."),
    force_bins: int = typer.Option(40, help="Bins of the force PDFs."),
    color_by: str = typer.Option("type", help="Force network colours: type, sliding or none."),
    synthetic: int | None = typer.Option(None, help="Analyse a synthetic series of this many "
                                         "contacts per snapshot (>= 1) instead of PATH (to "
                                         "try the command)."),
) -> None:
    """Analyse the contact networks of a run: stress (both forms), packing fraction, z and z_c
    with and without rattlers, contact types, fabric and force anisotropies in the contact and
    branch frames, q/p from anisotropies (eqs. 27a/b, B1), angular distributions, force PDFs,
    friction mobilisation and partial stresses. Writes analysis.csv/.h5 (one row per snapshot),
    residual_state.csv (mean and std over the strain window) and figures."""
    _analyse(path, out, snapshot, strain, window, min_contacts, frame_level, angle_bins,
             force_bins, color_by, synthetic)


def analyse_run(path: Path, out: Path, window: tuple[float, float],
                strain: str = "eps_q") -> None:
    """The analysis of ``grainlab analyse PATH --out OUT`` with its default options and the
    residual state over ``window`` (low, high) of ``strain``."""
    _analyse(path, out, -1, strain, f"{window[0]!r}:{window[1]!r}", 2, "points", 18, 40,
             "type", None)


@friendly_errors
def _analyse(path, out, snapshot, strain, window, min_contacts, frame_level, angle_bins,
             force_bins, color_by, synthetic) -> None:
    if color_by not in ("type", "sliding", "none"):
        raise InputError("--color-by", color_by, "type, sliding or none")
    if frame_level not in ("points", "pairs"):
        raise InputError("--frame-level", frame_level, "points or pairs")
    low_high = parse_window(window)
    # every input checked before the output folder is made: a refused command leaves nothing
    if synthetic is not None:
        if synthetic < 1:
            raise InputError("--synthetic", synthetic, "an integer >= 1: the contacts per "
                                                       "snapshot of a synthetic series")
        source, total = None, SYNTHETIC_SNAPSHOTS
    elif path is None:
        raise InputError("RUN|SNAPSHOT", None, "a run folder or snapshot file, or --synthetic N")
    else:
        source = resolve_snapshot_file(path)
        total = count_snapshots(source)
        if total == 0:
            raise InputError("RUN|SNAPSHOT", str(source), "a file holding at least one snapshot")
    chosen = snapshot % total if -total <= snapshot < total else None
    if chosen is None:
        raise InputError("--snapshot", snapshot, f"an index in [-{total}, {total - 1}]")
    output_folder("--out", out)
    out.mkdir(parents=True, exist_ok=True)
    if source is None:
        source = synthetic_series(out / "synthetic_snapshots.h5", synthetic, total)
    trajectory = TrajectoryAnalysis(min_contacts=min_contacts, frame_level=frame_level,
                                    n_angle_bins=angle_bins, n_force_bins=force_bins)
    drawn = {}

    def keep_chosen(done: int) -> None:
        if done - 1 == chosen:
            drawn["analysis"] = trajectory.last

    with Progress(console=console, transient=True) as bar:
        task = bar.add_task(f"analysing {total} snapshot(s)", total=total)
        trajectory.run(read_snapshots(source),
                       progress=lambda done: (keep_chosen(done), bar.update(task, completed=done)))
    result = trajectory.to_test_result(source=str(source), strain=strain)
    result.save(out, "analysis")
    table = trajectory.table
    if strain in table.columns and ((table[strain] >= low_high[0]) &
                                    (table[strain] <= low_high[1])).any():
        residual = trajectory.residual_state(strain, low_high)
        residual.to_csv(out / "residual_state.csv", index=False, float_format="%.10g")
        console.print(f"residual state: {residual['n_snapshots'].iloc[0]} snapshot(s) with "
                      f"{strain} in [{low_high[0]:g}, {low_high[1]:g}] -> residual_state.csv")
    elif strain in table.columns:
        console.print(f"[yellow]no residual state:[/] no snapshot has {strain} in the window "
                      f"[{low_high[0]:g}, {low_high[1]:g}] (the snapshots span {strain} "
                      f"{table[strain].min():.4g} to {table[strain].max():.4g}); "
                      "residual_state.csv not written: choose --window within that span")
    else:
        console.print(f"[yellow]no residual state:[/] the snapshots have no {strain} "
                      "(--strain); residual_state.csv not written")
    analysis = drawn["analysis"]
    save_figure(polar_distributions_figure(analysis.angular), out / "polar_distributions.png")
    save_figure(force_pdf_figure(analysis.forces), out / "force_pdfs.png")
    mobilisation = None
    if color_by == "sliding":
        mobilisation = pair_mobilisation(analysis.network)
    save_figure(force_network_figure(analysis.network, color_by=color_by,
                                     mobilisation=mobilisation), out / "force_network.png")
    if total > 1:
        save_figure(anisotropy_evolution_figure(table, strain), out / "anisotropies.png")
    summary = Table(title=f"snapshot {chosen} of {source.name}")
    summary.add_column("descriptor")
    summary.add_column("value", justify="right")
    row = table.iloc[chosen]
    for key, label in SUMMARY:
        if key in table.columns:
            summary.add_row(label, f"{row[key]:.4g}")
    console.print(summary)
    console.print(f"wrote analysis.csv, analysis.h5 and figures in {out}/")
