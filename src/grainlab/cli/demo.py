"""``grainlab demo``: the laboratory on built-in defaults, theory then simulation.

Part 1 (seconds): the regular-packing theory of Chang, Misra & Xue (1989): their Table 1 and
packing C loaded at alpha = 30 deg from 17.24 kPa to failure. Part 2 (about two minutes on two
cores, most of it the one-time compilation of the kernels): a triaxial test on a discrete
sample of a few hundred rigid spheres (contact dynamics, Azéma, Radjaï & Dubois 2013's
protocol): frictionless isotropic compaction to 10 kPa, then axial compression at
inertia number <= 1e-3 with friction 0.4, its curves, the microstructure of its contact
networks and ParaView files of its last state. Every file is listed at the end.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from grainlab.cli import analyse, discrete, packing2d
from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import output_folder
from grainlab.errors import InputError

console = Console()

DEMO_PARTICLES = 300
"""Spheres of the demo's discrete sample."""
DEMO_EPS_Q = 0.2
"""Deviatoric strain eps_q [-] the demo's triaxial test is taken to (past its peak)."""
DEMO_SNAPSHOTS = 20
"""Contact networks recorded over the demo's shear, for the microstructure figures."""


@friendly_errors
def demo(
    out: Path = typer.Option(Path("grainlab-demo"), help="Folder for the demo's outputs."),
    particles: int = typer.Option(DEMO_PARTICLES, "--particles",
                                  help="Spheres of the discrete triaxial test (0: theory "
                                       "only)."),
    eps_q: float = typer.Option(DEMO_EPS_Q, "--eps-q",
                                help="Deviatoric strain eps_q [-] of the discrete test."),
) -> None:
    """Run the built-in demo. Part 1, theory: Table 1 of Chang, Misra & Xue 1989 (regular
    packings of discs), then their packing C loaded at alpha = 30 deg from 17.24 kPa to
    failure with the paper's constants. Part 2, simulation: a triaxial test on PARTICLES
    rigid spheres (contact dynamics; compaction to 10 kPa, then shear to EPS_Q), with its
    curves, the microstructure of its contact networks and ParaView files. Every file
    written into OUT is listed at the end."""
    output_folder("--out", out)
    if particles != 0 and particles < 20:
        raise InputError("--particles", particles, "0 (theory only) or at least 20 spheres")
    if not 0.0 < eps_q <= 0.5:
        raise InputError("--eps-q", eps_q, "a deviatoric strain in (0, 0.5]")
    out.mkdir(parents=True, exist_ok=True)
    files: list[tuple[Path, str]] = []
    console.rule("[bold]Part 1 — theory: regular packings of discs (Chang, Misra & Xue 1989)")
    files += _theory(out)
    if particles:
        console.rule(f"[bold]Part 2 — simulation: triaxial test on {particles} spheres "
                     "(contact dynamics)")
        files += _simulation(out / "triaxial", particles, eps_q)
    _list_files(out, files)


def _theory(out: Path) -> list[tuple[Path, str]]:
    """Table 1 and packing C at 30 deg; the files written with what each holds."""
    packing2d.table_command(csv=out / "table1.csv", tolerance=1e-6)
    model = packing2d.RegularPackingModel(
        packing2d.named_packing("C"), packing2d.ModifiedHertzMindlin2D.seed000()
    )
    path = packing2d.RotatedStressPath(alpha=np.radians(30.0))
    result = packing2d.run_rotated_stress_path(model, path)
    packing2d.save_figure(packing2d.tessellation_figure(model.packing), out / "tessellation_C.png")
    packing2d.report_load(model, result, out)
    return [
        (out / "table1.csv", "void ratio and coordination number of packings A-D (Table 1)"),
        (out / "result.csv", "packing C at 30 deg: stresses, strains per load increment"),
        (out / "result.h5", "the same test result with its metadata (HDF5)"),
        (out / "fig7_stress_ratio_strains.png", "stress ratio against strains (Fig. 7)"),
        (out / "fig10_contact_forces.png", "contact forces in the tessellation (Fig. 10)"),
        (out / "tessellation_C.png", "packing C: discs, contacts and radical-plane cells"),
    ]


def _simulation(folder: Path, particles: int, eps_q: float) -> list[tuple[Path, str]]:
    """The discrete triaxial test, its analysis and ParaView files (list as above)."""
    from grainlab.lab.discrete_run import export_checkpoint_vtk, start_run
    from grainlab.lab.run_config import RunConfig

    # about 1700 steps per unit of eps_q at I = 1e-3 on 300 spheres (measured: 347 steps to
    # eps_q = 0.2): a snapshot every 1/DEMO_SNAPSHOTS of the shear
    snapshot_every = max(10, int(1700 * eps_q / DEMO_SNAPSHOTS))
    config = RunConfig.model_validate({
        "sample": {"shape": "sphere", "n_particles": particles, "seed": 1},
        "test": {"kind": "triaxial", "sigma0": 1e4, "eps_q_max": eps_q},
        "solver": {"shear": {"friction": 0.4, "inertia_number": 1e-3}},
        "output": {"record_every": 10, "snapshot_every": snapshot_every, "vtk_every": 0},
    })
    run = start_run(folder, config, overwrite=True)
    console.print(f"run folder [bold]{folder}[/]: {particles} spheres, d in [1, 2] mm, "
                  "compaction to sigma0 = 10 kPa, then shear at I <= 1e-3 with mu = 0.4 "
                  f"to eps_q = {eps_q:g}")
    console.print("The first discrete run on this machine compiles the contact-dynamics "
                  "kernels (about a minute on two cores; they are cached for later runs).")
    _, figures = discrete.finish_run(folder, run, progress=True)
    files = [(folder / "config.toml", "the run's input (edit it and pass it with --config)"),
             (folder / "results.csv", "one row per record: stresses, strains, packing "
                                      "fraction, coordination, inertia number, solver"),
             (folder / "results.h5", "the same table with the run's metadata (HDF5)"),
             (folder / "snapshots.h5", "contact networks (forces, normals, branches)"),
             (folder / "checkpoint.h5", "the last state, to resume or export"),
             (folder / "run.log", "the run's log")]
    for path in figures:
        files.append((path, "q/p, volumetric strain and packing fraction against eps_q"))
    console.print("analysing the recorded contact networks ...")
    analysis = folder / "analysis"
    analyse.analyse_run(folder, analysis, window=(0.5 * eps_q, eps_q))
    files += [(analysis / "analysis.csv", "microstructure per snapshot: anisotropies, z, "
                                          "friction mobilisation"),
              (analysis / "anisotropies.png", "fabric and force anisotropies against eps_q"),
              (analysis / "force_network.png", "force chains of the last snapshot"),
              (analysis / "polar_distributions.png", "angular distributions of contacts "
                                                     "and forces"),
              (analysis / "force_pdfs.png", "normal and tangential force distributions")]
    for path in export_checkpoint_vtk(folder):
        files.append((path, "ParaView: particles, walls, contact forces of the last state"))
    return files


def _list_files(out: Path, files: list[tuple[Path, str]]) -> None:
    """Print every file written (that exists) with what it holds."""
    table = Table(title=f"files written in {out}/", show_lines=False)
    table.add_column("file")
    table.add_column("what it holds")
    for path, meaning in files:
        if path.exists():
            table.add_row(str(path.relative_to(out)), meaning)
    console.print(table)
