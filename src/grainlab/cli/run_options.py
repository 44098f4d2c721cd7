"""The options of the discrete-run commands, each declared once: its flags, the config key it
sets, its help, its default, its type and the commands that take it (:data:`RUN_OPTIONS`).

``grainlab triaxial``, ``compaction``, ``oedometer``, ``test KIND``, ``compare KIND`` and
``theory-vs-sim KIND`` are built from this table: :func:`takes_options` gives a command the
signature of its options (typer reads a command's options from :func:`inspect.signature`),
and the command receives them as keywords. An option that sets a config key has no default
of its own on the command line (None: the value of ``--config``'s file, or the config's one
default, which its help shows, read from :class:`~grainlab.lab.run_config.RunConfig`).

>>> [option.typed for option in options_of("compaction") if option.name == "tolerance"]
['--tolerance']
>>> option_named("test", "mu").key
'solver.shear.friction'
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import typer

from grainlab.lab.boundary_registry import boundary_help, shearing_names
from grainlab.lab.run_config import CHANGEABLE_STAGE_KEYS, PERIODIC_ONLY, TEST_KINDS, RunConfig
from grainlab.lab.solver_registry import solver_help, solver_options
from grainlab.prep.sample_shapes import SAMPLE_SHAPES

F = TypeVar("F", bound=Callable)

RUN_COMMANDS = ("triaxial", "compaction", "oedometer", "test")
"""The commands that start one run (of one solver)."""
THEORY = "theory-vs-sim"
"""The command that runs one discrete run and the micro-element model of its packing."""
COMMANDS = (*RUN_COMMANDS, "compare", THEORY)
"""Every command built from :data:`RUN_OPTIONS`."""
LOADING = ("triaxial", "oedometer", "test", "compare", THEORY)
"""The commands whose test has a loading after the compaction."""
ANY_KIND = ("test", "compare")
"""The commands that run any test (KIND)."""
ONE_RUN = (*RUN_COMMANDS, THEORY)
"""The commands whose discrete run is one run of one solver (--solver, the sample files)."""
SEVERAL_KINDS = (*ANY_KIND, THEORY)
"""The commands that take KIND."""


@dataclass(frozen=True)
class RunOption:
    """One option of the discrete-run commands.

    Attributes
    ----------
    name:
        The command function's parameter.
    flags:
        The names on the command line (``("-n", "--n-particles")``); :attr:`typed` joins
        them as an error message names the option.
    help:
        What it does (an option that sets a config key gets the key's default appended).
    type:
        The value's Python type (typer's converter).
    commands:
        The commands (of :data:`COMMANDS`) that take it.
    key:
        The config key it sets (``"solver.shear.friction"``); None for the options that are
        not config (the folder, ``--config``, switches, KIND).
    compaction_key:
        The key it sets instead when the test is a compaction (which has no loading).
    default:
        The command-line default of an option that is not config (``...``: required).
    argument:
        A positional argument (KIND), not an option.
    hidden:
        Left out of ``--help`` (an option a command takes only to refuse it).
    """

    name: str
    flags: tuple[str, ...]
    help: str
    type: type
    commands: tuple[str, ...]
    key: str | None = None
    compaction_key: str | None = None
    default: Any = None
    argument: bool = False
    hidden: bool = False

    @property
    def typed(self) -> str:
        """The option as an error message names it: ``"-n/--n-particles"``."""
        return "/".join(self.flags)

    @property
    def is_file(self) -> bool:
        """A file the run reads (checked to exist; it implies ``--preparation file``)."""
        return self.key is not None and self.type is Path

    def key_in(self, kind: str) -> str:
        """The config key it sets in a test of ``kind``."""
        if self.key is None:
            raise ValueError(f"{self.typed} sets no config key")
        return self.compaction_key if kind == "compaction" and self.compaction_key \
            else self.key

    def help_text(self) -> str:
        """The help, with the config key's default (``[default: 1000]``) for a config option
        read by value (not for a file, whose default is none)."""
        if self.key is None or self.is_file:
            return self.help
        return f"{self.help} {config_default_text(self.key)}"

    def parameter(self) -> inspect.Parameter:
        """The command function's parameter, its default typer's option or argument."""
        if self.argument:
            info = typer.Argument(self.default, help=self.help_text())
        else:
            info = typer.Option(self.default, *self.flags, help=self.help_text(),
                                hidden=self.hidden)
        return inspect.Parameter(self.name, inspect.Parameter.KEYWORD_ONLY, default=info,
                                 annotation=self.type)


def config_default_text(key: str) -> str:
    """``"[default: 1000]"`` for the config key ``"sample.n_particles"`` (its one default)."""
    model: Any = RunConfig
    for name in key.split("."):
        info = model.model_fields[name]
        model = info.annotation
    value = info.default
    shown = f"{value:g}" if isinstance(value, float) else str(value)
    return f"[default: {shown}]"


BOUNDARY_HELP = boundary_help()
"""The ``--boundary`` help: every registered boundary
(:data:`~grainlab.lab.boundary_registry.BOUNDARIES`) with its words."""

SHEARING_BOUNDARY = " or ".join(f"--boundary {name}" for name in shearing_names())
"""The ``--boundary`` values the shearing tests need."""

SOLVER_HELP = solver_help()
"""The ``--solver`` help: every registered solver
(:data:`~grainlab.lab.solver_registry.SOLVERS`) with what it is."""

SHAPE_HELP = "Particle shape: " + "; ".join(
    f"{name} ({shape.description})" for name, shape in SAMPLE_SHAPES.items()) + "."
"""The ``--shape`` help: every shape a sample can be made of
(:data:`~grainlab.prep.sample_shapes.SAMPLE_SHAPES`), with what its particles are."""

_TOLERANCE_TEXT = ("Convergence tolerance of the contact solver (NLGS, see --sweep) [-] {}: "
                   "the relative change of the contact forces between two sweeps, and the "
                   "relative residual, must fall below it each step; 1e-4 to 1e-3 is usual, "
                   "smaller is more accurate and slower.")

SET_HELP = (
    "Change a setting for the rest of the run (repeatable), e.g. --set "
    "solver.shear.tolerance=1e-5. Can change: test.eps_q_max, test.axial_strain, "
    "test.unload_strain (stages not ended yet), solver.dt, solver.max_stage_steps, "
    "solver.at_max_stage_steps, solver.compaction.KEY and solver.shear.KEY (the compaction's "
    f"and the loading's numerics) for KEY one of {', '.join(CHANGEABLE_STAGE_KEYS)}, "
    "output.*; the other keys (friction included) made what the run did and are refused. "
    "Keys edited in RUN/config.toml count the same.")
"""The help of ``grainlab resume --set``."""

PROGRESS_HELP = "Show a progress bar."

RUN_OPTIONS: tuple[RunOption, ...] = (
    RunOption("kind", ("KIND",), "The lab test: " + ", ".join(TEST_KINDS) + ". "
              + ", ".join(PERIODIC_ONLY) + f" need {SHEARING_BOUNDARY}.", str, ("test",),
              default=..., argument=True),
    RunOption("kind", ("KIND",), "The lab test: " + ", ".join(TEST_KINDS) + " ("
              + ", ".join(PERIODIC_ONLY) + f" need {SHEARING_BOUNDARY}).", str, ("compare",),
              default=..., argument=True),
    RunOption("kind", ("KIND",), "The lab test: triaxial, extension, oedometer, true_triaxial "
              "or cubical (the tests the micro-element model follows along the vertical "
              "strain).", str, (THEORY,),
              default=..., argument=True),
    RunOption("out", ("--out", "-o"), "Run folder (config.toml, results.csv, snapshots.h5, "
              "checkpoint.h5, run.log, figures).", Path, RUN_COMMANDS,
              default=Path("grainlab-run")),
    RunOption("out", ("--out", "-o"), "Comparison folder: OUT/cd and OUT/dem (a run folder "
              "each), compare.png and compare.csv.", Path, ("compare",),
              default=Path("grainlab-compare")),
    RunOption("out", ("--out", "-o"), "Comparison folder: OUT/run (the discrete run's "
              "folder), theory.csv (both sides on one strain grid), theory-differences.csv, "
              "theory.png and model-LAW.csv.", Path, (THEORY,),
              default=Path("grainlab-theory")),
    RunOption("boundary", ("--boundary",), BOUNDARY_HELP, str, COMMANDS, "sample.boundary"),
    RunOption("shape", ("--shape",), SHAPE_HELP, str, COMMANDS, "sample.shape"),
    RunOption("n", ("-n", "--n-particles"), "Number of particles.", int, COMMANDS,
              "sample.n_particles"),
    RunOption("d_min", ("--d-min",), "Smallest particle diameter (of the circumscribed "
              "sphere) [m].", float, COMMANDS, "sample.d_min"),
    RunOption("size_ratio", ("--size-ratio",), "d_max/d_min, >= 1; diameters uniform by "
              "volume in between (or two sizes: --sizes binary).", float, COMMANDS,
              "sample.size_ratio"),
    RunOption("sizes", ("--sizes",), "uniform_volume (diameters uniform by volume in "
              "[d_min, d_max]) or binary (two sizes, d_min and d_max, a number fraction "
              "--fine-fraction of d_min).", str, COMMANDS, "sample.sizes"),
    RunOption("fine_fraction", ("--fine-fraction",), "Number fraction of the particles of "
              "d_min with --sizes binary, in (0, 1).", float, COMMANDS,
              "sample.fine_fraction"),
    RunOption("eta", ("--eta",), "Non-convexity (R - R')/R of the aggregates, 0 to 0.828 "
              "(R: circumscribed radius, R': inscribed radius).", float, COMMANDS,
              "sample.eta"),
    RunOption("faces", ("--faces",), "Faces of each polyhedron: even, 8 to 1000; fewer "
              "faces, more angular (Table I of Azéma, Radjaï & Dubois 2013: 8, 20, 30, 46, "
              "96, 176, 596).", int, COMMANDS, "sample.n_faces"),
    RunOption("templates", ("--templates",), "Polyhedra: 0 = every particle its own random "
              "shape (as Azéma, Radjaï & Dubois 2013); K = K shapes reused in random "
              "orientations (faster to build).", int, COMMANDS, "sample.templates"),
    RunOption("density", ("--density",), "Particle density [kg/m^3].", float, COMMANDS,
              "sample.density"),
    RunOption("height_ratio", ("--height-ratio",), "Height / width of the loose start box (a "
              "taller periodic cell keeps room to compress along z).", float, SEVERAL_KINDS,
              "sample.height_ratio"),
    RunOption("mu", ("--mu",), "Friction coefficient between particles [-] while loading "
              "(solver.shear.friction; the compaction is frictionless unless "
              "solver.compaction.friction says otherwise in --config).", float, LOADING,
              "solver.shear.friction"),
    RunOption("sigma0", ("--sigma0",), "Confining stress [Pa]: the compaction pressure, then "
              "the lateral stress held while loading.", float, COMMANDS, "test.sigma0"),
    RunOption("inertia", ("--inertia",), "Largest inertia number I = (strain rate) x (mean "
              "diameter) x sqrt(density / p) [-] while loading (solver.shear.inertia_number); "
              "it sets the loading speed. I <= 1e-3 is quasi-static (a lab test); 1e-2 is 10 "
              "times faster and slightly rate dependent.", float, LOADING,
              "solver.shear.inertia_number"),
    RunOption("eps_q", ("--eps-q",), "Deviatoric strain eps_q = eps_1 - eps_3 at which the "
              "test ends [-].", float, ("triaxial", *SEVERAL_KINDS), "test.eps_q_max"),
    RunOption("axial_strain", ("--axial-strain",), "Vertical strain of loading [-].", float,
              ("oedometer", *SEVERAL_KINDS), "test.axial_strain"),
    RunOption("unload_strain", ("--unload-strain",), "Vertical strain of unloading [-] (0: "
              "no unloading).", float, ("oedometer", *SEVERAL_KINDS), "test.unload_strain"),
    RunOption("b", ("--b",), "true_triaxial, cubical: b = (sigma_2 - sigma_3) / (sigma_1 - "
              "sigma_3), held with p = SIGMA0 (true_triaxial) or sigma_3 = SIGMA0 (cubical); z "
              "major, x intermediate, y minor.", float, SEVERAL_KINDS,
              "test.b"),
    RunOption("gamma", ("--gamma",), "simple_shear: the shear strain gamma_xz at which the "
              "test ends [-].", float, ANY_KIND, "test.gamma_max"),
    RunOption("q_ratio", ("--q-ratio",), "circular: the deviator q = sqrt(3 J2) of the "
              "circle, over SIGMA0 [-].", float, ANY_KIND, "test.q_ratio"),
    RunOption("circle_points", ("--circle-points",), "circular: stress targets on the full "
              "turn.", int, ANY_KIND, "test.circle_points"),
    RunOption("amplitude", ("--amplitude",), "cyclic_shear: gamma_xz between +-AMPLITUDE "
              "[-].", float, ANY_KIND, "test.amplitude"),
    RunOption("cycles", ("--cycles",), "cyclic_shear: number of cycles.", int, ANY_KIND,
              "test.n_cycles"),
    RunOption("seed", ("--seed",), "Random seed of the sample (sizes, positions, "
              "orientations): an integer in [0, 4294967295]; the same seed gives the same "
              "sample.", int, COMMANDS, "sample.seed"),
    RunOption("dt", ("--dt",), "Time step [s]; 0 = chosen from the particle sizes and the "
              "loading speed.", float, COMMANDS, "solver.dt"),
    RunOption("tolerance", ("--tolerance",), _TOLERANCE_TEXT.format(
        "while loading (solver.shear.tolerance; the compaction's is "
        "solver.compaction.tolerance)"), float, LOADING, "solver.shear.tolerance",
        compaction_key="solver.compaction.tolerance"),
    RunOption("tolerance", ("--tolerance",), _TOLERANCE_TEXT.format(
        "(solver.compaction.tolerance)"), float, ("compaction",),
        "solver.compaction.tolerance"),
    RunOption("sweep", ("--sweep",), "How the contact solver visits the contacts. The solver "
              "is NLGS (non-linear Gauss-Seidel): each step it sweeps over the contacts, "
              "solving one contact at a time with the others held, until the forces settle. "
              "coloured: in parallel, by groups of contacts that share no particle; serial: "
              "one thread, in a random order.", str, COMMANDS, "solver.sweep"),
    RunOption("correction", ("--correction",), "What the contact solver does between its "
              "sweeps in steps without friction (the compaction): subspace (default): every "
              "10 sweeps, the loaded contacts' forces solved together by conjugate gradients, "
              "kept only where they lower the step's energy (the 1000-sphere test's "
              "compaction: 2.7x fewer sweeps, 1.8x faster); none: NLGS sweeps alone, the "
              "reference.", str,
              COMMANDS, "solver.correction"),
    RunOption("max_iterations", ("--max-iterations",), "Most NLGS sweeps per loading step "
              "(solver.shear.max_iterations; 100 to 1000 is usual); fewer is faster, with "
              "larger overlaps and unconverged steps flagged in the results "
              "(docs/explanations/walls-and-box-tests.md).", int, ("triaxial", *SEVERAL_KINDS),
              "solver.shear.max_iterations",
              compaction_key="solver.compaction.max_iterations"),
    RunOption("record_every", ("--record-every",), "Steps between results rows.", int,
              COMMANDS, "output.record_every"),
    RunOption("snapshot_every", ("--snapshot-every",), "Steps between contact-network "
              "snapshots (for `grainlab analyse`; 0: none).", int, COMMANDS,
              "output.snapshot_every"),
    RunOption("checkpoint_every", ("--checkpoint-every",), "Steps between checkpoints (0: "
              "only at the end of each stage and on Ctrl-C).", int, COMMANDS,
              "output.checkpoint_every"),
    RunOption("vtk_every", ("--vtk-every",), "Steps between ParaView frames (0: none).", int,
              COMMANDS, "output.vtk_every"),
    RunOption("solver", ("--solver",), SOLVER_HELP, str, ONE_RUN, "solver.method"),
    RunOption("solver", ("--solver",), "Refused: compare runs both solvers.", str,
              ("compare",), hidden=True),
    *(RunOption(option.name, option.flags, option.help, option.type, COMMANDS, option.key)
      for option in solver_options()),
    RunOption("preparation", ("--preparation",), "How the sample is made: loose (particles "
              "at random in a loose box, compacted), deposition (a dense sphere packing built "
              "layer by layer, each sphere the circumscribed sphere of a particle, as Azéma, "
              "Radjaï & Dubois 2013; walls only) or file (--skeleton-file or "
              "--particle-file).", str, ONE_RUN, "sample.preparation"),
    RunOption("skeleton_file", ("--skeleton-file",), "A .csv (x,y,z,radius) or .npz file of "
              "spheres: each the circumscribed sphere of a particle of --shape (implies "
              "--preparation file).", Path, ONE_RUN, "sample.skeleton_file"),
    RunOption("particle_file", ("--particle-file",), "A .csv (particle,kind,x,y,z,radius) or "
              ".npz file of the particles themselves: spheres, aggregates' member spheres or "
              "polyhedra's vertices, in world coordinates [m] "
              "(docs/explanations/sample-preparation.md; implies --preparation file; the "
              "shapes, sizes and box come from the file).",
              Path, ONE_RUN, "sample.particle_file"),
    RunOption("distributions", ("--distribution",), "The micro-element model's "
              "distribution law of strain (repeatable: one model each, on one figure): "
              "homogeneous (seed 001 eq. 2.30), maxwellian (eq. 2.32, the overall C), "
              "maxwellian-average (eq. 2.32 with C_bar) or maxwellian-first-order (eq. 2.35 "
              "to first order) [default: homogeneous].", list[str], (THEORY,)),
    RunOption("model_steps", ("--model-steps",), "About how many steps the model takes "
              "over the run's path after the compaction.", int, (THEORY,), default=200),
    RunOption("config", ("--config",), "A config.toml to start from (options given here "
              "override it).", Path, COMMANDS),
    RunOption("overwrite", ("--overwrite",), "Replace a run already in OUT.", bool, COMMANDS,
              default=False),
    RunOption("progress", ("--progress/--no-progress",), PROGRESS_HELP, bool, COMMANDS,
              default=True),
)
"""Every option of the discrete-run commands, in the order ``--help`` lists them."""


def options_of(command: str) -> tuple[RunOption, ...]:
    """The options ``command`` takes, in the table's order."""
    if command not in COMMANDS:
        raise ValueError(f"{command!r} is not a command of the table: one of {COMMANDS}")
    return tuple(option for option in RUN_OPTIONS if command in option.commands)


def option_named(command: str, name: str) -> RunOption:
    """The option ``name`` (a parameter) of ``command``."""
    for option in options_of(command):
        if option.name == name:
            return option
    raise KeyError(f"{command} takes no option {name!r}")


def command_signature(command: str) -> inspect.Signature:
    """The signature typer reads ``command``'s options from: one keyword parameter per
    option of the table, in its order."""
    return inspect.Signature([option.parameter() for option in options_of(command)],
                             return_annotation=None)


def takes_options(command: str) -> Callable[[F], F]:
    """Decorator: the function (taking ``**options``) gets the options of ``command`` as its
    signature, so that typer offers exactly them and passes them as keywords."""

    def decorate(function: F) -> F:
        function.__signature__ = command_signature(command)  # type: ignore[attr-defined]
        return function

    return decorate
