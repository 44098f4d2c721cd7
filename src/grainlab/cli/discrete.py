"""``grainlab triaxial | compaction | oedometer | resume | vtk``: lab tests on a discrete
sample (contact dynamics), run in a folder that can be resumed."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from grainlab.cli.errors import friendly_errors
from grainlab.errors import InputError

console = Console()

_OUT = typer.Option(Path("grainlab-run"), "--out", "-o",
                    help="Run folder (config.toml, results.csv, snapshots.h5, checkpoint.h5, "
                         "run.log, figures).")


def _figures(folder: Path, result) -> list[Path]:
    """q/p, volumetric strain and packing fraction against eps_q (shear stages) or the
    packing fraction against time (compaction)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from grainlab.report.curves import plot_curves

    table = result.table
    shear = table[table["stage"] != "compaction"] if "stage" in table else table
    paths = []
    fig, axes = plt.subplots(1, 3, figsize=(13.0, 3.8), layout="constrained")
    if len(shear) > 1:
        sub = type(result)(shear.reset_index(drop=True), result.metadata)
        plot_curves(sub, "eps_q", "q_over_trace", ax=axes[0])
        plot_curves(sub, "eps_q", "eps_vol", ax=axes[1])
        plot_curves(sub, "eps_q", "packing_fraction", ax=axes[2])
    else:
        plot_curves(result, "time", "packing_fraction", ax=axes[0])
        plot_curves(result, "time", "p", ax=axes[1])
        plot_curves(result, "time", "z_no_rattlers", ax=axes[2])
    path = folder / "curves.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    paths.append(path)
    return paths


def _type_fractions(row) -> str:
    """", contact types fv 0.12 ee ..." from the fraction_<type> columns (polyhedra)."""
    names = [k for k in row.index if str(k).startswith("fraction_")]
    if not names:
        return ""
    return ", contact types " + " ".join(f"{k[len('fraction_'):]} {row[k]:.3f}"
                                         for k in names)


def _summary(result) -> None:
    table = result.table
    last = table.iloc[-1]
    console.print(f"[bold]{result.metadata['title']}[/]: {len(table)} rows, "
                  f"{int(last['step'])} steps, outcome {result.metadata['outcome']['stages']}")
    shear = table[table["stage"] != "compaction"]
    compaction = table[table["stage"] == "compaction"]
    if len(compaction):
        c = compaction.iloc[-1]
        console.print(f"end of compaction: packing fraction {c['packing_fraction']:.4f}, "
                      f"z {c['z']:.3f} (no rattlers {c['z_no_rattlers']:.3f}), "
                      f"z_c {c['z_c']:.3f}, p {c['p']:.4g} Pa{_type_fractions(c)}")
    if len(shear) > 2:
        peak = shear["q_over_trace"].max()
        late = shear[shear["eps_q"] >= 0.7 * shear["eps_q"].max()]
        console.print(f"shear: peak q/p {peak:.4f}; over the last 30 % of eps_q: q/p "
                      f"{late['q_over_trace'].mean():.4f}, packing fraction "
                      f"{late['packing_fraction'].mean():.4f}, z {late['z'].mean():.3f}; "
                      f"max inertia number {shear['inertia_number'].max():.2e}"
                      f"{_type_fractions(late.mean(numeric_only=True))}")


def _run(kind: str, out: Path, config_file: Path | None, overrides: dict, overwrite: bool,
         progress: bool) -> None:
    from grainlab.lab.discrete_run import start_run
    from grainlab.lab.run_config import RunConfig

    config = RunConfig.read(config_file) if config_file else RunConfig()
    overrides = {section: {k: v for k, v in values.items() if v is not None}
                 for section, values in overrides.items()}
    overrides["test"]["kind"] = kind
    config = config.with_updates(overrides)
    run = start_run(out, config, overwrite=overwrite)
    sample = config.sample
    shapes = {"sphere": "spheres", "aggregate": "aggregates",
              "polyhedron": f"polyhedra of {sample.n_faces} faces"}[sample.shape]
    console.print(f"run folder [bold]{out}[/] ({sample.n_particles} {shapes}, {kind}); "
                  f"Ctrl-C checkpoints, "
                  f"`grainlab resume {out}` continues")
    result = run.run(progress=progress)
    _summary(result)
    for path in _figures(out, result):
        console.print(f"figure: {path}")


def _options(shape, n, d_min, size_ratio, eta, density, mu, sigma0, inertia, seed, dt,
             tolerance, sweep, record_every, snapshot_every, checkpoint_every, vtk_every,
             max_iterations=None, faces=None, templates=None):
    if shape not in (None, "sphere", "aggregate", "polyhedron"):
        raise InputError("--shape", shape, "sphere, aggregate or polyhedron")
    if faces is not None and (faces < 8 or faces % 2):
        raise InputError("--faces", faces, "an even number of faces >= 8 (seed 002 Table I: "
                                           "8, 20, 30, 46, 96, 176, 596)")
    if templates is not None and templates < 0:
        raise InputError("--templates", templates,
                         "an integer >= 0 (0: every polyhedron its own)")
    return {
        "sample": {"shape": shape, "n_particles": n, "d_min": d_min, "size_ratio": size_ratio,
                   "eta": eta, "n_faces": faces, "templates": templates, "density": density,
                   "seed": seed},
        "test": {"sigma0": sigma0},
        "solver": {"friction": mu, "inertia_number": inertia, "dt": dt,
                   "tolerance": tolerance, "sweep": sweep, "max_iterations": max_iterations},
        "output": {"record_every": record_every, "snapshot_every": snapshot_every,
                   "checkpoint_every": checkpoint_every, "vtk_every": vtk_every},
    }


# Shared options (None: the config file's or the default value).
_SHAPE = typer.Option(None, "--shape", help="sphere | aggregate (seed 003 tetrahedral) | "
                                             "polyhedron (seed 002 random convex).")
_N = typer.Option(None, "-n", "--n-particles", help="Number of particles [default 1000].")
_DMIN = typer.Option(None, "--d-min", help="Smallest diameter [m] [default 1e-3].")
_RATIO = typer.Option(None, "--size-ratio", help="d_max/d_min, uniform by volume [2].")
_ETA = typer.Option(None, "--eta", help="Aggregate non-convexity (R-R')/R [0.4].")
_FACES = typer.Option(None, "--faces", help="Faces of each polyhedron, even, >= 8 (seed 002: "
                                            "8, 20, 30, 46, 96, 176, 596) [30].")
_TEMPLATES = typer.Option(None, "--templates",
                          help="Polyhedra: 0 = every particle its own random shape (seed 002); "
                               "K = K shapes reused in random orientations (faster) [0].")
_RHO = typer.Option(None, "--density", help="Particle density [kg/m^3] [2600].")
_MU = typer.Option(None, "--mu", help="Interparticle friction in shear [0.4].")
_SIGMA0 = typer.Option(None, "--sigma0", help="Confining stress [Pa] [1e4].")
_INERTIA = typer.Option(None, "--inertia", help="Bound on the inertia number [1e-3].")
_SEED = typer.Option(None, "--seed", help="Seed of the sample [0].")
_DT = typer.Option(None, "--dt", help="Time step [s] (0: automatic).")
_TOL = typer.Option(None, "--tolerance", help="NLGS tolerance [1.666e-4].")
_SWEEP = typer.Option(None, "--sweep", help="coloured (parallel) | serial NLGS.")
_ITER = typer.Option(None, "--max-iterations",
                     help="NLGS sweep cap per shearing step [400]; lower is faster, with larger "
                          "overlaps (docs/discrete_engine.md).")
_RECORD = typer.Option(None, "--record-every", help="Steps between results rows [10].")
_SNAP = typer.Option(None, "--snapshot-every", help="Steps between contact snapshots [0].")
_CKPT = typer.Option(None, "--checkpoint-every", help="Steps between checkpoints [500].")
_VTK = typer.Option(None, "--vtk-every", help="Steps between ParaView frames [0].")
_CONFIG = typer.Option(None, "--config", help="A config.toml to start from (options "
                                              "given here override it).")
_OVERWRITE = typer.Option(False, "--overwrite", help="Replace a run already in OUT.")
_PROGRESS = typer.Option(True, "--progress/--no-progress", help="Show a progress bar.")


@friendly_errors
def triaxial_command(
    out: Path = _OUT, shape: str = _SHAPE, n: int = _N, d_min: float = _DMIN,
    size_ratio: float = _RATIO, eta: float = _ETA, faces: int = _FACES,
    templates: int = _TEMPLATES, density: float = _RHO, mu: float = _MU,
    sigma0: float = _SIGMA0, inertia: float = _INERTIA,
    eps_q: float = typer.Option(None, "--eps-q", help="Deviatoric strain to reach [0.5]."),
    seed: int = _SEED, dt: float = _DT, tolerance: float = _TOL, sweep: str = _SWEEP,
    max_iterations: int = _ITER,
    record_every: int = _RECORD, snapshot_every: int = _SNAP, checkpoint_every: int = _CKPT,
    vtk_every: int = _VTK, config: Path = _CONFIG, overwrite: bool = _OVERWRITE,
    progress: bool = _PROGRESS,
) -> None:
    """Triaxial compression of a discrete sample (seed 002/003): loose random sample,
    frictionless isotropic compaction to SIGMA0 until quasi-static, then the top wall at a
    constant strain rate (inertia number <= INERTIA), lateral walls at SIGMA0, friction MU,
    until eps_q = eps_1 - eps_3 reaches EPS_Q."""
    overrides = _options(shape, n, d_min, size_ratio, eta, density, mu, sigma0, inertia, seed,
                         dt, tolerance, sweep, record_every, snapshot_every, checkpoint_every,
                         vtk_every, max_iterations, faces, templates)
    overrides["test"]["eps_q_max"] = eps_q
    _run("triaxial", out, config, overrides, overwrite, progress)


@friendly_errors
def compaction_command(
    out: Path = _OUT, shape: str = _SHAPE, n: int = _N, d_min: float = _DMIN,
    size_ratio: float = _RATIO, eta: float = _ETA, faces: int = _FACES,
    templates: int = _TEMPLATES, density: float = _RHO,
    sigma0: float = _SIGMA0, seed: int = _SEED, dt: float = _DT, tolerance: float = _TOL,
    sweep: str = _SWEEP, record_every: int = _RECORD, snapshot_every: int = _SNAP,
    checkpoint_every: int = _CKPT, vtk_every: int = _VTK, config: Path = _CONFIG,
    overwrite: bool = _OVERWRITE, progress: bool = _PROGRESS,
) -> None:
    """Isotropic compaction of a loose random sample to SIGMA0 (no gravity, no friction:
    seed 002's preparation) until quasi-static; reports packing fraction and z."""
    overrides = _options(shape, n, d_min, size_ratio, eta, density, None, sigma0, None, seed,
                         dt, tolerance, sweep, record_every, snapshot_every, checkpoint_every,
                         vtk_every, faces=faces, templates=templates)
    _run("compaction", out, config, overrides, overwrite, progress)


@friendly_errors
def oedometer_command(
    out: Path = _OUT, shape: str = _SHAPE, n: int = _N, d_min: float = _DMIN,
    size_ratio: float = _RATIO, eta: float = _ETA, faces: int = _FACES,
    templates: int = _TEMPLATES, density: float = _RHO, mu: float = _MU,
    sigma0: float = _SIGMA0, inertia: float = _INERTIA,
    axial_strain: float = typer.Option(None, "--axial-strain",
                                       help="Vertical strain of loading [0.05]."),
    unload_strain: float = typer.Option(None, "--unload-strain",
                                        help="Vertical strain of unloading [0: none]."),
    seed: int = _SEED, dt: float = _DT, tolerance: float = _TOL, sweep: str = _SWEEP,
    record_every: int = _RECORD, snapshot_every: int = _SNAP, checkpoint_every: int = _CKPT,
    vtk_every: int = _VTK, config: Path = _CONFIG, overwrite: bool = _OVERWRITE,
    progress: bool = _PROGRESS,
) -> None:
    """Oedometer (1-D compression, lateral walls fixed) of a discrete sample after
    isotropic compaction to SIGMA0; K0 = sigma_xx / sigma_zz in the results."""
    overrides = _options(shape, n, d_min, size_ratio, eta, density, mu, sigma0, inertia, seed,
                         dt, tolerance, sweep, record_every, snapshot_every, checkpoint_every,
                         vtk_every, faces=faces, templates=templates)
    overrides["test"].update({"axial_strain": axial_strain, "unload_strain": unload_strain})
    _run("oedometer", out, config, overrides, overwrite, progress)


@friendly_errors
def resume_command(
    run: Path = typer.Argument(..., help="The run folder to continue."),
    progress: bool = _PROGRESS,
) -> None:
    """Continue a run from its last checkpoint (after Ctrl-C, SIGTERM, kill -9 or a crash):
    results and snapshots are cut back to the checkpoint and the run goes on."""
    from grainlab.lab.discrete_run import resume_run

    discrete = resume_run(run)
    console.print(f"resuming [bold]{run}[/] at step {discrete.test.simulation.step_index}")
    result = discrete.run(progress=progress)
    _summary(result)
    for path in _figures(run, result):
        console.print(f"figure: {path}")


@friendly_errors
def vtk_command(
    run: Path = typer.Argument(..., help="A run folder."),
    out: Path = typer.Option(None, "--out", help="Folder for the files [RUN/vtk-checkpoint]."),
) -> None:
    """Write the run's last checkpoint as ParaView files: particles as their true shapes,
    the walls, and the contacts of the last snapshot (lines carrying force) if any."""
    from grainlab.lab.discrete_run import export_checkpoint_vtk

    paths = export_checkpoint_vtk(run, out)
    for path in paths:
        console.print(f"wrote {path}")
