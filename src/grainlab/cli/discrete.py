"""``grainlab triaxial | compaction | oedometer | resume | vtk``: lab tests on a discrete
sample (contact dynamics), run in a folder that can be resumed.

Exit status: 0 when the run did what was asked; 3 when it ran but its outcome is not what was
asked (a stage not reached, the inertia bound exceeded, a blow-up: the summary and run.log say
why; :mod:`grainlab.lab.run_outcome`); 2 on bad input or when a run cannot go on (no
checkpoint, damaged checkpoints, a full disk), with one message.
"""

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


RIGID_OEDOMETER = (
    "rigid grains: the sample cannot compress beyond rearrangement, so the oedometer is "
    "degenerate: sigma_zz comes from the overlaps the solver leaves and from the loading "
    "rate, and K0 is not an elastic K0 (until deformable contacts exist)")
"""What the summary of an oedometer run says about its meaning."""


def _test_config(result) -> dict:
    """The [test] table of the run's config (kind, sigma0, targets)."""
    return result.metadata["parameters"]["config"]["test"]


def _figures(folder: Path, result) -> list[Path]:
    """curves.png: K0 and sigma_zz against eps_zz by stage (oedometer), q/p, volumetric
    strain and packing fraction against eps_q (shear stages) or the packing fraction against
    time (compaction)."""
    if _test_config(result)["kind"] == "oedometer":
        from grainlab.report.curves import save_figure
        from grainlab.report.element_test_figures import oedometer_stages_figure

        return [save_figure(oedometer_stages_figure(result), folder / "curves.png", dpi=120)]
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
        plot_curves(sub, "eps_q", "q_over_p", ax=axes[0])
        plot_curves(sub, "eps_q", "eps_p", ax=axes[1])
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


def _oedometer_summary(result) -> None:
    """Loading and unloading: strains reached against those asked, sigma_zz and K0 at the
    end of each, and what they mean on rigid grains."""
    table, asked = result.table, _test_config(result)
    steps = {s["name"]: s["steps"] for s in result.metadata["outcome"]["stages"]}
    loading = table[table["stage"] == "loading"]
    unloading = table[table["stage"] == "unloading"]
    if len(loading):
        end = loading.iloc[-1]
        console.print(f"loading: to eps_zz {end['eps_zz']:.6g} (asked {asked['axial_strain']:g})"
                      f" in {steps.get('loading', '?')} steps; at the end of loading sigma_zz "
                      f"{end['sigma_zz']:.4g} Pa, K0 {end['K0']:.4f}")
    if len(unloading) and len(loading):
        end, top = unloading.iloc[-1], loading.iloc[-1]
        console.print(f"unloading: by {top['eps_zz'] - end['eps_zz']:.6g} (asked "
                      f"{asked['unload_strain']:g}) to eps_zz {end['eps_zz']:.6g} in "
                      f"{steps.get('unloading', '?')} steps; at the end of unloading sigma_zz "
                      f"{end['sigma_zz']:.4g} Pa, K0 {end['K0']:.4f}")
    console.print(f"note: {RIGID_OEDOMETER}")


def _summary(result) -> None:
    table = result.table
    last = table.iloc[-1]
    console.print(f"[bold]{result.metadata['title']}[/]: {len(table)} rows, "
                  f"{int(last['step'])} steps")
    shear = table[table["stage"] != "compaction"]
    compaction = table[table["stage"] == "compaction"]
    if len(compaction):
        c = compaction.iloc[-1]
        console.print(f"end of compaction: packing fraction {c['packing_fraction']:.4f}, "
                      f"z {c['z']:.3f} (no rattlers {c['z_no_rattlers']:.3f}), "
                      f"z_c {c['z_c']:.3f}, p {c['p']:.4g} Pa{_type_fractions(c)}")
    if _test_config(result)["kind"] == "oedometer":
        _oedometer_summary(result)
    elif len(shear) > 2:
        peak = shear["q_over_p"].max()
        late = shear[shear["eps_q"] >= 0.7 * shear["eps_q"].max()]
        console.print(f"shear: peak q/p {peak:.4f}; over the last 30 % of eps_q: q/p "
                      f"{late['q_over_p'].mean():.4f}, packing fraction "
                      f"{late['packing_fraction'].mean():.4f}, z {late['z'].mean():.3f}; "
                      f"max inertia number {shear['inertia_number'].max():.2e}"
                      f"{_type_fractions(late.mean(numeric_only=True))}")


def _finish(folder: Path, run, progress: bool) -> None:
    """Run to the end, print the summary, the outcome in words and the figures; exit 3 when
    the outcome is not as asked or the run blew up."""
    from grainlab.engine.simulation import SimulationBlowUp
    from grainlab.lab.run_outcome import EXIT_NOT_AS_ASKED, RunOutcome

    for note in run.notes:
        console.print(f"[bold yellow]note:[/] {note}")
    try:
        result = run.run(progress=progress)
    except SimulationBlowUp as error:
        console.print(f"[bold red]blow-up:[/] {error}")
        raise typer.Exit(code=EXIT_NOT_AS_ASKED) from None
    outcome = RunOutcome.of_result(result)
    if len(result.table):
        _summary(result)
        for path in _figures(folder, result):
            console.print(f"figure: {path}")
    words = outcome.summary().replace("grainlab resume RUN", f"grainlab resume {folder}")
    head, *lines = words.splitlines()
    console.print(f"[bold {'green' if outcome.as_asked else 'red'}]{head}[/]",
                  highlight=False)
    for line in lines:
        console.print(line, highlight=False)
    if not outcome.as_asked:
        raise typer.Exit(code=EXIT_NOT_AS_ASKED)


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
    _finish(out, run, progress)


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
    isotropic compaction to SIGMA0: loading by AXIAL_STRAIN, then unloading by UNLOAD_STRAIN
    (each stage ends on its strain, whatever --record-every); K0 = (sigma_xx + sigma_yy) /
    (2 sigma_zz) in the results (column K0), the summary and curves.png (K0 and sigma_zz
    against eps_zz). On rigid grains the test is degenerate: the sample cannot compress
    beyond rearrangement, sigma_zz comes from the overlaps the solver leaves and from the
    loading rate, and K0 is not an elastic K0 (until deformable contacts exist)."""
    overrides = _options(shape, n, d_min, size_ratio, eta, density, mu, sigma0, inertia, seed,
                         dt, tolerance, sweep, record_every, snapshot_every, checkpoint_every,
                         vtk_every, faces=faces, templates=templates)
    overrides["test"].update({"axial_strain": axial_strain, "unload_strain": unload_strain})
    _run("oedometer", out, config, overrides, overwrite, progress)


@friendly_errors
def resume_command(
    run: Path = typer.Argument(..., help="The run folder to continue."),
    set_: list[str] = typer.Option(
        None, "--set", metavar="SECTION.KEY=VALUE",
        help="Change a setting for the rest of the run (repeatable), e.g. --set "
             "solver.tolerance=1e-5. Can change: test.eps_q_max, test.axial_strain, "
             "test.unload_strain (stages not ended yet), solver.inertia_number, "
             "solver.compaction_inertia_number, solver.dt, solver.time_step_factor, "
             "solver.compaction_time_step_factor, solver.tolerance, solver.max_iterations, "
             "solver.compaction_tolerance, solver.compaction_max_iterations, "
             "solver.overlap_recovery, solver.max_stage_steps, solver.at_max_stage_steps, "
             "output.*; the other keys made what the run did and are refused. Keys edited "
             "in RUN/config.toml count the same."),
    restart: bool = typer.Option(
        False, "--restart",
        help="Start the run over from step 0 with its config.toml (and --set, any key), "
             "after moving its results, snapshots, log and checkpoints to RUN/previous-N."),
    progress: bool = _PROGRESS,
) -> None:
    """Continue a run from its last checkpoint (after Ctrl-C, SIGTERM, kill -9, a crash, a
    blow-up or a stage stopped at max_stage_steps): results and snapshots are cut back to the
    checkpoint and the run goes on. If checkpoint.h5 is damaged, from checkpoint.prev.h5 (the
    one before). Without a usable checkpoint it stops and touches nothing (see --restart)."""
    from grainlab.lab.discrete_run import resume_run

    discrete = resume_run(run, list(set_ or []), restart=restart)
    console.print(f"{'restarting' if restart else 'resuming'} [bold]{run}[/] at step "
                  f"{discrete.test.simulation.step_index}")
    _finish(run, discrete, progress)


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
