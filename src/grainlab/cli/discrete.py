"""``grainlab triaxial | compaction | oedometer | resume | vtk``: lab tests on a discrete
sample (contact dynamics), run in a folder that can be resumed.

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
from grainlab.cli.inputs import input_file, output_folder
from grainlab.errors import InputError
from grainlab.lab.run_config import CHANGEABLE_STAGE_KEYS, PERIODIC_ONLY, TEST_KINDS, RunConfig
from grainlab.prep.sample_shapes import SAMPLE_SHAPES, particles_text

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
    time (compaction); and simple_shear.png for a simple shear (seed 001 Figs. 4.15-4.16)."""
    from grainlab.report.curves import save_figure

    if _test_config(result)["kind"] == "oedometer":
        from grainlab.report.element_test_figures import oedometer_stages_figure

        return [save_figure(oedometer_stages_figure(result), folder / "curves.png", dpi=120)]
    from grainlab.report.run_curves import discrete_curves_figure

    figures = [save_figure(discrete_curves_figure(result), folder / "curves.png", dpi=120)]
    if _test_config(result)["kind"] == "simple_shear":
        from grainlab.report.element_test_figures import simple_shear_figure

        # tau/sigma_v, Hill's proposition, eq. 4.8 and the angles of seed 001 Fig. 4.16
        figures.append(save_figure(simple_shear_figure(result), folder / "simple_shear.png",
                                   dpi=120))
    return figures


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
        from grainlab.lab.solver_comparison import RESIDUAL_SHARE, residual_rows

        peak = shear["q_over_trace"].max()
        late = residual_rows(shear)
        console.print(f"shear: peak q/p {peak:.4f}; over the last {100 * RESIDUAL_SHARE:g} % "
                      f"of eps_q: q/p "
                      f"{late['q_over_trace'].mean():.4f}, packing fraction "
                      f"{late['packing_fraction'].mean():.4f}, z {late['z'].mean():.3f}; "
                      f"max inertia number {shear['inertia_number'].max():.2e}"
                      f"{_type_fractions(late.mean(numeric_only=True))}")


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
        _summary(result)
        figures = _figures(folder, result)
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


def command_config(kind: str, config_file: Path | None, options: dict[str, Any]
                   ) -> tuple[RunConfig, dict[str, Any]]:
    """The config a command asks for: ``--config``'s file (or the defaults), the test
    ``kind`` and the options given (those not None, keyed as :data:`_OPTIONS`) over it; and
    the options given. A refused value is an :class:`InputError` naming the option as typed
    (:func:`as_typed`)."""
    if config_file is not None:
        input_file("--config", config_file)
        try:
            config = RunConfig.read(config_file)
        except InputError as error:
            raise as_typed(error, {}, config_file) from None
    else:
        config = RunConfig()
    given = {key: value for key, value in options.items() if value is not None}
    overrides: dict[str, dict[str, Any]] = {"test": {"kind": kind}}
    for key, value in given.items():
        *tables, name = _OPTIONS[key][1].split(".")
        table = overrides
        for part in tables:
            table = table.setdefault(part, {})
        table[name] = value
    try:
        return config.with_updates(overrides), given
    except InputError as error:
        raise as_typed(error, given, config_file) from None


def _sample_source(preparation: str | None, skeleton_file: Path | None,
                   particle_file: Path | None) -> dict[str, Any]:
    """The options of how the sample is made: a file given implies ``--preparation file``
    (a file that does not exist is refused by name)."""
    files = {"skeleton_file": ("--skeleton-file", skeleton_file),
             "particle_file": ("--particle-file", particle_file)}
    given = {key: str(input_file(option, path)) for key, (option, path) in files.items()
             if path is not None}
    if given and preparation is None:
        preparation = "file"
    return {"preparation": preparation, **given}


def _run(kind: str, out: Path, config_file: Path | None, options: dict[str, Any],
         overwrite: bool, progress: bool) -> None:
    """Check every option, then start the run: nothing is written before the input is
    accepted, and a rejected start leaves OUT as it was."""
    from grainlab.lab.discrete_run import start_run

    output_folder("--out", out)
    config, given = asked_config(kind, config_file, options)
    try:
        run = start_run(out, config, overwrite=overwrite)
    except InputError as error:
        raise as_typed(error, given, config_file) from None
    sample = run.test.sample
    shapes = particles_text(sample.description)
    console.print(f"run folder [bold]{out}[/] ({sample.state.n_bodies} {shapes}, {kind}); "
                  f"Ctrl-C checkpoints, "
                  f"`grainlab resume {out}` continues")
    finish_run(out, run, progress)


def asked_config(kind: str, config_file: Path | None, options: dict[str, Any]
                 ) -> tuple[RunConfig, dict[str, Any]]:
    """:func:`command_config` for a run of one solver, an option that would do nothing in it
    refused (:func:`refuse_inert_options`); ``--tolerance`` and ``--max-iterations`` of a
    compaction set the compaction's numerics (it has no loading)."""
    options = dict(options)
    if kind == "compaction":
        for option in ("tolerance", "max_iterations"):
            if options.get(option) is not None:
                options[f"compaction_{option}"] = options.pop(option)
    config, given = command_config(kind, config_file, options)
    for note in refuse_inert_options([config], given, config_file):
        console.print(f"[bold yellow]note:[/] {escape(note)}", soft_wrap=True)
    return config, given


def refuse_inert_options(configs: list[RunConfig], given: dict[str, Any],
                         config_file: Path | None) -> list[str]:
    """Refuse an option given that none of the runs of ``configs`` reads
    (:mod:`grainlab.lab.option_scope`): an :class:`InputError` naming it as typed, and why it
    would do nothing. A key of ``--config``'s file that differs from its default and that no
    run reads is not refused (a file may serve several commands): returned, in words, for a
    note."""
    from grainlab.lab.option_scope import inert_settings
    from grainlab.lab.run_config import flat_keys

    options = [_OPTIONS[key][1] for key in given]
    keys = list(options)
    if config_file is not None:
        written = flat_keys(RunConfig.read(config_file).model_dump())
        default = flat_keys(RunConfig().model_dump())
        keys += [key for key, value in written.items()
                 if value != default.get(key) and key not in keys]
    inert = [inert_settings(config, keys) for config in configs]
    notes = []
    for key in keys:
        if not all(key in each for each in inert):
            continue
        value: Any = configs[0]
        for name in key.split("."):
            value = getattr(value, name)
        if key in options:
            error = InputError(key, value, f"not given: it does nothing here ({inert[0][key]})")
            raise as_typed(error, given, config_file)
        notes.append(f"{key} = {value!r} (in {config_file}) does nothing here: {inert[0][key]}")
    return notes


def as_typed(error: InputError, given: dict[str, Any], config_file: Path | None
             ) -> InputError:
    """``error`` naming what the user typed: the option (``--mu``) when the value came from
    the command line, else the config key and its file (``solver.shear.friction (in
    c.toml)``)."""
    field = error.field
    if field == "config":
        return InputError("--config", error.value, error.allowed)
    for key in given:
        if _OPTIONS[key][1] == field:
            return InputError(_OPTIONS[key][0], error.value, error.allowed)
    if config_file is not None and field in _CONFIG_KEYS:
        field = f"{field} (in {config_file})"
    return InputError(field, error.value, error.allowed)


_OPTIONS = {
    "shape": ("--shape", "sample.shape"), "n": ("-n/--n-particles", "sample.n_particles"),
    "d_min": ("--d-min", "sample.d_min"), "size_ratio": ("--size-ratio", "sample.size_ratio"),
    "eta": ("--eta", "sample.eta"), "faces": ("--faces", "sample.n_faces"),
    "templates": ("--templates", "sample.templates"), "density": ("--density", "sample.density"),
    "seed": ("--seed", "sample.seed"), "sigma0": ("--sigma0", "test.sigma0"),
    "eps_q": ("--eps-q", "test.eps_q_max"),
    "axial_strain": ("--axial-strain", "test.axial_strain"),
    "unload_strain": ("--unload-strain", "test.unload_strain"),
    "mu": ("--mu", "solver.shear.friction"),
    "inertia": ("--inertia", "solver.shear.inertia_number"),
    "dt": ("--dt", "solver.dt"), "tolerance": ("--tolerance", "solver.shear.tolerance"),
    "compaction_tolerance": ("--tolerance", "solver.compaction.tolerance"),
    "sweep": ("--sweep", "solver.sweep"),
    "max_iterations": ("--max-iterations", "solver.shear.max_iterations"),
    "compaction_max_iterations": ("--max-iterations", "solver.compaction.max_iterations"),
    "record_every": ("--record-every", "output.record_every"),
    "snapshot_every": ("--snapshot-every", "output.snapshot_every"),
    "checkpoint_every": ("--checkpoint-every", "output.checkpoint_every"),
    "vtk_every": ("--vtk-every", "output.vtk_every"),
    "boundary": ("--boundary", "sample.boundary"),
    "solver": ("--solver", "solver.method"), "law": ("--law", "solver.dem.law"),
    "kappa": ("--kappa", "solver.dem.kappa"),
    "young_modulus": ("--young-modulus", "solver.dem.young_modulus"),
    "restitution": ("--restitution", "solver.dem.restitution"),
    "height_ratio": ("--height-ratio", "sample.height_ratio"),
    "preparation": ("--preparation", "sample.preparation"),
    "skeleton_file": ("--skeleton-file", "sample.skeleton_file"),
    "particle_file": ("--particle-file", "sample.particle_file"),
    "b": ("--b", "test.b"), "gamma": ("--gamma", "test.gamma_max"),
    "q_ratio": ("--q-ratio", "test.q_ratio"),
    "circle_points": ("--circle-points", "test.circle_points"),
    "amplitude": ("--amplitude", "test.amplitude"), "cycles": ("--cycles", "test.n_cycles"),
}
"""Each command-line option (parameter name) as typed and the config key it sets."""



def _config_keys(model: Any, prefix: str = "") -> set[str]:
    """Every key of a config model, ``"solver.shear.friction"`` for those of a sub-table."""
    keys = set()
    for name, info in model.model_fields.items():
        if hasattr(info.annotation, "model_fields"):
            keys |= _config_keys(info.annotation, f"{prefix}{name}.")
        else:
            keys.add(f"{prefix}{name}")
    return keys


_CONFIG_KEYS = _config_keys(RunConfig)


def _default(key: str) -> str:
    """``"[default: 1000]"`` for the config key ``"sample.n_particles"`` (its one default)."""
    model: Any = RunConfig
    for name in key.split("."):
        info = model.model_fields[name]
        model = info.annotation
    value = info.default
    shown = f"{value:g}" if isinstance(value, float) else str(value)
    return f"[default: {shown}]"


def _option(parameter: str, *names: str, help: str) -> Any:
    """A typer option for ``parameter`` of :data:`_OPTIONS` (None: the config file's value or
    the default, which the help shows)."""
    return typer.Option(None, *names, help=f"{help} {_default(_OPTIONS[parameter][1])}")


SHAPE_HELP = "Particle shape: " + "; ".join(
    f"{name} ({shape.description})" for name, shape in SAMPLE_SHAPES.items()) + "."
"""The ``--shape`` help: every shape a sample can be made of
(:data:`~grainlab.prep.sample_shapes.SAMPLE_SHAPES`), with what its particles are."""
_SHAPE = _option("shape", "--shape", help=SHAPE_HELP)
_N = _option("n", "-n", "--n-particles", help="Number of particles.")
_DMIN = _option("d_min", "--d-min", help="Smallest particle diameter (of the circumscribed "
                "sphere) [m].")
_RATIO = _option("size_ratio", "--size-ratio", help="d_max/d_min, >= 1; diameters uniform by "
                 "volume in between.")
_ETA = _option("eta", "--eta", help="Non-convexity (R - R')/R of the aggregates, 0 to 0.828 "
               "(R: circumscribed radius, R': inscribed radius).")
_FACES = _option("faces", "--faces", help="Faces of each polyhedron: even, 8 to 1000; fewer "
                 "faces, more angular (Table I of Azéma, Radjaï & Dubois 2013: 8, 20, 30, 46, "
                 "96, 176, 596).")
_TEMPLATES = _option("templates", "--templates", help="Polyhedra: 0 = every particle its own "
                     "random shape (as Azéma, Radjaï & Dubois 2013); K = K shapes reused in "
                     "random orientations (faster to build).")
_RHO = _option("density", "--density", help="Particle density [kg/m^3].")
_MU = _option("mu", "--mu", help="Friction coefficient between particles [-] while loading "
              "(solver.shear.friction; the compaction is frictionless unless "
              "solver.compaction.friction says otherwise in --config).")
_SIGMA0 = _option("sigma0", "--sigma0", help="Confining stress [Pa]: the compaction pressure, "
                  "then the lateral stress held while loading.")
_INERTIA = _option("inertia", "--inertia", help="Largest inertia number I = (strain rate) x "
                   "(mean diameter) x sqrt(density / p) [-] while loading "
                   "(solver.shear.inertia_number); it sets the loading speed. "
                   "I <= 1e-3 is quasi-static (a lab test); 1e-2 is 10 times faster and "
                   "slightly rate dependent.")
_SEED = _option("seed", "--seed", help="Random seed of the sample (sizes, positions, "
                "orientations): an integer in [0, 4294967295]; the same seed gives the same "
                "sample.")
_DT = _option("dt", "--dt", help="Time step [s]; 0 = chosen from the particle sizes and the "
              "loading speed.")
_TOLERANCE_TEXT = ("Convergence tolerance of the contact solver (NLGS, see --sweep) [-] {}: "
                   "the relative change of the contact forces between two sweeps, and the "
                   "relative residual, must fall below it each step; 1e-4 to 1e-3 is usual, "
                   "smaller is more accurate and slower.")
_TOL = _option("tolerance", "--tolerance", help=_TOLERANCE_TEXT.format(
    "while loading (solver.shear.tolerance; the compaction's is solver.compaction.tolerance)"))
_COMPACTION_TOL = _option("compaction_tolerance", "--tolerance", help=_TOLERANCE_TEXT.format(
    "(solver.compaction.tolerance)"))
_SWEEP = _option("sweep", "--sweep", help="How the contact solver visits the contacts. The "
                 "solver is NLGS (non-linear Gauss-Seidel): each step it sweeps over the "
                 "contacts, solving one contact at a time with the others held, until the "
                 "forces settle. coloured: in parallel, by groups of contacts that share no "
                 "particle; serial: one thread, in a random order.")
_ITER = _option("max_iterations", "--max-iterations", help="Most NLGS sweeps per loading step "
                "(solver.shear.max_iterations; 100 to 1000 is usual); fewer is faster, with "
                "larger overlaps and unconverged steps flagged in the results "
                "(docs/discrete_engine.md).")
_RECORD = _option("record_every", "--record-every", help="Steps between results rows.")
_SNAP = _option("snapshot_every", "--snapshot-every", help="Steps between contact-network "
                "snapshots (for `grainlab analyse`; 0: none).")
_CKPT = _option("checkpoint_every", "--checkpoint-every", help="Steps between checkpoints "
                "(0: only at the end of each stage and on Ctrl-C).")
_VTK = _option("vtk_every", "--vtk-every", help="Steps between ParaView frames (0: none).")
_EPS_Q = _option("eps_q", "--eps-q", help="Deviatoric strain eps_q = eps_1 - eps_3 at which "
                 "the test ends [-].")
_AXIAL = _option("axial_strain", "--axial-strain", help="Vertical strain of loading [-].")
_UNLOAD = _option("unload_strain", "--unload-strain", help="Vertical strain of unloading "
                  "[-] (0: no unloading).")
_BOUNDARY = _option("boundary", "--boundary", help="What holds the sample: walls (a box of "
                    "six walls, as the seeds) or periodic (a periodic deformable cell: no "
                    "walls, every stress and strain component controlled; needed to shear).")
_SOLVER = _option("solver", "--solver", help="The solver: cd (contact dynamics: rigid grains, "
                  "implicit) or dem (soft-contact DEM: elastic contacts, explicit).")
_LAW = _option("law", "--law", help="dem: contact law, linear (spring-dashpot, Cundall & "
               "Strack) or hertz_mindlin.")
_KAPPA = _option("kappa", "--kappa", help="dem: stiffness number kappa = k_n / (SIGMA0 <d>) "
                 "(linear) or (E / ((1 - nu^2) SIGMA0))^(2/3) (Hertz); >= 1e4 for "
                 "quasi-rigid grains.")
_YOUNG = _option("young_modulus", "--young-modulus", help="dem, hertz_mindlin: the grains' "
                 "Young's modulus E [Pa] (0: from --kappa).")
_RESTITUTION = _option("restitution", "--restitution", help="dem: coefficient of "
                       "restitution of a normal impact, in (0, 1].")
_HEIGHT = _option("height_ratio", "--height-ratio", help="Height / width of the loose "
                  "start box (a taller periodic cell keeps room to compress along z).")
_PREPARATION = _option("preparation", "--preparation", help="How the sample is made: loose "
                       "(particles at random in a loose box, compacted), deposition (a dense "
                       "sphere packing built layer by layer, each sphere the circumscribed "
                       "sphere of a particle, as Azéma, Radjaï & Dubois 2013; walls only) or "
                       "file (--skeleton-file or --particle-file).")
_SKELETON_FILE = typer.Option(None, "--skeleton-file", help="A .csv (x,y,z,radius) or .npz "
                              "file of spheres: each the circumscribed sphere of a particle "
                              "of --shape (implies --preparation file).")
_PARTICLE_FILE = typer.Option(None, "--particle-file", help="A .csv "
                              "(particle,kind,x,y,z,radius) or .npz file of the particles "
                              "themselves: spheres, aggregates' member spheres or polyhedra's "
                              "vertices, in world coordinates [m] (docs/discrete_engine.md; "
                              "implies --preparation file; the shapes, sizes and box come "
                              "from the file).")
_B = _option("b", "--b", help="true_triaxial: b = (sigma_2 - sigma_3) / (sigma_1 - sigma_3), "
             "held with p = SIGMA0 (z major, x intermediate, y minor).")
_GAMMA = _option("gamma", "--gamma", help="simple_shear: the shear strain gamma_xz at which "
                 "the test ends [-].")
_Q_RATIO = _option("q_ratio", "--q-ratio", help="circular: the deviator q = sqrt(3 J2) of "
                   "the circle, over SIGMA0 [-].")
_POINTS = _option("circle_points", "--circle-points", help="circular: stress targets on the "
                  "full turn.")
_AMPLITUDE = _option("amplitude", "--amplitude", help="cyclic_shear: gamma_xz between "
                     "+-AMPLITUDE [-].")
_CYCLES = _option("cycles", "--cycles", help="cyclic_shear: number of cycles.")
_CONFIG = typer.Option(None, "--config", help="A config.toml to start from (options given "
                                              "here override it).")
_SET_HELP = (
    "Change a setting for the rest of the run (repeatable), e.g. --set "
    "solver.shear.tolerance=1e-5. Can change: test.eps_q_max, test.axial_strain, "
    "test.unload_strain (stages not ended yet), solver.dt, solver.max_stage_steps, "
    "solver.at_max_stage_steps, solver.compaction.KEY and solver.shear.KEY (the compaction's "
    f"and the loading's numerics) for KEY one of {', '.join(CHANGEABLE_STAGE_KEYS)}, "
    "output.*; the other keys (friction included) made what the run did and are refused. "
    "Keys edited in RUN/config.toml count the same.")
_OVERWRITE = typer.Option(False, "--overwrite", help="Replace a run already in OUT.")
_PROGRESS = typer.Option(True, "--progress/--no-progress", help="Show a progress bar.")


@friendly_errors
def triaxial_command(
    out: Path = _OUT, shape: str = _SHAPE, n: int = _N, d_min: float = _DMIN,
    size_ratio: float = _RATIO, eta: float = _ETA, faces: int = _FACES,
    templates: int = _TEMPLATES, density: float = _RHO, mu: float = _MU,
    sigma0: float = _SIGMA0, inertia: float = _INERTIA, eps_q: float = _EPS_Q,
    seed: int = _SEED, dt: float = _DT, tolerance: float = _TOL, sweep: str = _SWEEP,
    max_iterations: int = _ITER,
    record_every: int = _RECORD, snapshot_every: int = _SNAP, checkpoint_every: int = _CKPT,
    vtk_every: int = _VTK, boundary: str = _BOUNDARY, solver: str = _SOLVER, law: str = _LAW,
    kappa: float = _KAPPA, young_modulus: float = _YOUNG,
    restitution: float = _RESTITUTION, preparation: str = _PREPARATION,
    skeleton_file: Path = _SKELETON_FILE, particle_file: Path = _PARTICLE_FILE,
    config: Path = _CONFIG,
    overwrite: bool = _OVERWRITE, progress: bool = _PROGRESS,
) -> None:
    """Triaxial compression of a discrete sample, as Azéma, Radjaï & Dubois 2013
    (polyhedra) and Azéma et al. 2013 (aggregates): a loose random sample, frictionless
    isotropic compaction to SIGMA0 until quasi-static, then the top wall at a constant strain
    rate (inertia number <= INERTIA), the lateral walls at SIGMA0, friction MU, until
    eps_q = eps_1 - eps_3 reaches EPS_Q."""
    _run("triaxial", out, config, dict(
        shape=shape, n=n, d_min=d_min, size_ratio=size_ratio, eta=eta, faces=faces,
        templates=templates, density=density, mu=mu, sigma0=sigma0, inertia=inertia,
        eps_q=eps_q, seed=seed, dt=dt, tolerance=tolerance, sweep=sweep,
        max_iterations=max_iterations, record_every=record_every,
        snapshot_every=snapshot_every, checkpoint_every=checkpoint_every,
        vtk_every=vtk_every, boundary=boundary, solver=solver, law=law, kappa=kappa,
        young_modulus=young_modulus, restitution=restitution,
        **_sample_source(preparation, skeleton_file, particle_file)), overwrite, progress)


@friendly_errors
def compaction_command(
    out: Path = _OUT, shape: str = _SHAPE, n: int = _N, d_min: float = _DMIN,
    size_ratio: float = _RATIO, eta: float = _ETA, faces: int = _FACES,
    templates: int = _TEMPLATES, density: float = _RHO,
    sigma0: float = _SIGMA0, seed: int = _SEED, dt: float = _DT,
    tolerance: float = _COMPACTION_TOL, sweep: str = _SWEEP, record_every: int = _RECORD,
    snapshot_every: int = _SNAP, checkpoint_every: int = _CKPT, vtk_every: int = _VTK,
    boundary: str = _BOUNDARY, solver: str = _SOLVER, law: str = _LAW,
    kappa: float = _KAPPA, young_modulus: float = _YOUNG,
    restitution: float = _RESTITUTION, preparation: str = _PREPARATION,
    skeleton_file: Path = _SKELETON_FILE, particle_file: Path = _PARTICLE_FILE,
    config: Path = _CONFIG, overwrite: bool = _OVERWRITE,
    progress: bool = _PROGRESS,
) -> None:
    """Isotropic compaction of a loose random sample to SIGMA0 (no gravity, no friction: the
    preparation of Azéma, Radjaï & Dubois 2013) until quasi-static; reports the packing
    fraction and the coordination number z."""
    _run("compaction", out, config, dict(
        shape=shape, n=n, d_min=d_min, size_ratio=size_ratio, eta=eta, faces=faces,
        templates=templates, density=density, sigma0=sigma0, seed=seed, dt=dt,
        compaction_tolerance=tolerance, sweep=sweep, record_every=record_every,
        snapshot_every=snapshot_every, checkpoint_every=checkpoint_every,
        vtk_every=vtk_every, boundary=boundary, solver=solver, law=law, kappa=kappa,
        young_modulus=young_modulus, restitution=restitution,
        **_sample_source(preparation, skeleton_file, particle_file)), overwrite, progress)


@friendly_errors
def oedometer_command(
    out: Path = _OUT, shape: str = _SHAPE, n: int = _N, d_min: float = _DMIN,
    size_ratio: float = _RATIO, eta: float = _ETA, faces: int = _FACES,
    templates: int = _TEMPLATES, density: float = _RHO, mu: float = _MU,
    sigma0: float = _SIGMA0, inertia: float = _INERTIA, axial_strain: float = _AXIAL,
    unload_strain: float = _UNLOAD,
    seed: int = _SEED, dt: float = _DT, tolerance: float = _TOL, sweep: str = _SWEEP,
    record_every: int = _RECORD, snapshot_every: int = _SNAP, checkpoint_every: int = _CKPT,
    vtk_every: int = _VTK, boundary: str = _BOUNDARY, solver: str = _SOLVER, law: str = _LAW,
    kappa: float = _KAPPA, young_modulus: float = _YOUNG,
    restitution: float = _RESTITUTION, preparation: str = _PREPARATION,
    skeleton_file: Path = _SKELETON_FILE, particle_file: Path = _PARTICLE_FILE,
    config: Path = _CONFIG,
    overwrite: bool = _OVERWRITE, progress: bool = _PROGRESS,
) -> None:
    """Oedometer (1-D compression, lateral walls fixed) of a discrete sample after
    isotropic compaction to SIGMA0: loading by AXIAL_STRAIN, then unloading by UNLOAD_STRAIN
    (each stage ends on its strain, whatever --record-every); K0 = (sigma_xx + sigma_yy) /
    (2 sigma_zz) in the results (column K0), the summary and curves.png (K0 and sigma_zz
    against eps_zz). On rigid grains the test is degenerate: the sample cannot compress
    beyond rearrangement, sigma_zz comes from the overlaps the solver leaves and from the
    loading rate, and K0 is not an elastic K0 (until deformable contacts exist)."""
    _run("oedometer", out, config, dict(
        shape=shape, n=n, d_min=d_min, size_ratio=size_ratio, eta=eta, faces=faces,
        templates=templates, density=density, mu=mu, sigma0=sigma0, inertia=inertia,
        axial_strain=axial_strain, unload_strain=unload_strain, seed=seed, dt=dt,
        tolerance=tolerance, sweep=sweep, record_every=record_every,
        snapshot_every=snapshot_every, checkpoint_every=checkpoint_every,
        vtk_every=vtk_every, boundary=boundary, solver=solver, law=law, kappa=kappa,
        young_modulus=young_modulus, restitution=restitution,
        **_sample_source(preparation, skeleton_file, particle_file)), overwrite, progress)


_KIND = typer.Argument(..., help="The lab test: " + ", ".join(TEST_KINDS) + ". "
                       + ", ".join(PERIODIC_ONLY) + " need --boundary periodic.")


@friendly_errors
def lab_test_command(
    kind: str = _KIND, out: Path = _OUT, boundary: str = _BOUNDARY,
    shape: str = _SHAPE, n: int = _N, d_min: float = _DMIN, size_ratio: float = _RATIO,
    eta: float = _ETA, faces: int = _FACES, templates: int = _TEMPLATES,
    density: float = _RHO, height_ratio: float = _HEIGHT, mu: float = _MU,
    sigma0: float = _SIGMA0, inertia: float = _INERTIA, eps_q: float = _EPS_Q,
    axial_strain: float = _AXIAL, unload_strain: float = _UNLOAD, b: float = _B,
    gamma: float = _GAMMA, q_ratio: float = _Q_RATIO, circle_points: int = _POINTS,
    amplitude: float = _AMPLITUDE, cycles: int = _CYCLES,
    seed: int = _SEED, dt: float = _DT, tolerance: float = _TOL, sweep: str = _SWEEP,
    max_iterations: int = _ITER, record_every: int = _RECORD, snapshot_every: int = _SNAP,
    checkpoint_every: int = _CKPT, vtk_every: int = _VTK, solver: str = _SOLVER,
    law: str = _LAW, kappa: float = _KAPPA, young_modulus: float = _YOUNG,
    restitution: float = _RESTITUTION, preparation: str = _PREPARATION,
    skeleton_file: Path = _SKELETON_FILE, particle_file: Path = _PARTICLE_FILE,
    config: Path = _CONFIG,
    overwrite: bool = _OVERWRITE, progress: bool = _PROGRESS,
) -> None:
    """Any lab test on a discrete sample: a loose random sample, frictionless isotropic
    compaction to SIGMA0 until quasi-static, then KIND: triaxial (compression to EPS_Q at
    lateral stress SIGMA0), extension, oedometer (in a periodic cell with --solver dem only:
    rigid grains cannot follow it there), true_triaxial (constant p and B to EPS_Q),
    simple_shear (gamma_xz to GAMMA, sigma_zz held, eps_xx = eps_yy = 0), circular (a full
    turn on the octahedral plane at q = Q_RATIO x SIGMA0), cyclic_shear (CYCLES of gamma_xz
    between +-AMPLITUDE), in a box of walls or (--boundary periodic) a periodic cell whose
    six components follow the test."""
    if kind not in TEST_KINDS:
        raise InputError("KIND", kind, "one of " + ", ".join(TEST_KINDS))
    _run(kind, out, config, dict(
        boundary=boundary, shape=shape, n=n, d_min=d_min, size_ratio=size_ratio, eta=eta,
        faces=faces, templates=templates, density=density, height_ratio=height_ratio, mu=mu,
        sigma0=sigma0, inertia=inertia, eps_q=eps_q, axial_strain=axial_strain,
        unload_strain=unload_strain, b=b, gamma=gamma, q_ratio=q_ratio,
        circle_points=circle_points, amplitude=amplitude, cycles=cycles, seed=seed, dt=dt,
        tolerance=tolerance, sweep=sweep, max_iterations=max_iterations,
        record_every=record_every, snapshot_every=snapshot_every,
        checkpoint_every=checkpoint_every, vtk_every=vtk_every, solver=solver, law=law,
        kappa=kappa, young_modulus=young_modulus, restitution=restitution,
        **_sample_source(preparation, skeleton_file, particle_file)), overwrite,
        progress)


@friendly_errors
def resume_command(
    run: Path = typer.Argument(..., help="The run folder to continue."),
    set_: list[str] = typer.Option(
        None, "--set", metavar="SECTION.KEY=VALUE",
        help=_SET_HELP),
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

