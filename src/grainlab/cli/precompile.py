"""``grainlab compile``: compile (and cache) the kernels before the first real run.

grainlab's kernels are compiled by Numba on their first call and cached on disk (``cache=True``)
for every later process; on two cores the first discrete run spends one to two minutes
compiling. This command runs tiny versions of every kind of work once, so that the compilation
happens now, with a message, instead of inside a user's first test, and can be split over
processes: ``--part discrete`` (contact dynamics of every kind of the member-sphere family,
spheres and aggregates, the deposition of dense samples, sample measures, snapshots,
microstructure analysis, ParaView export, the solvers of the plain contact problem),
``--part polyhedra`` (every kind of the polyhedron family: contact geometry and dynamics;
:data:`FAMILY_PARTS`), ``--part theories`` (the regular-packing and micro-element
models) and ``--part dem`` (the soft-contact solver, in a box of walls and in a periodic
cell, spheres and polyhedra); ``--part all`` runs them in turn. Nothing is kept but the
compiled code.

Each registered shape kind (:data:`~grainlab.engine.shape_kinds.SHAPE_KINDS`) gets the tiny
triaxial run of its narrow-phase family (:data:`FAMILY_TINY_RUNS`) in the part of its family
(:data:`FAMILY_PARTS`): a new kind of an existing family is compiled without an entry here.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.console import Console

from grainlab.cli.errors import friendly_errors
from grainlab.engine.shape_kinds import (
    MEMBER_SPHERES,
    POLYHEDRON,
    POLYHEDRON_FEATURES,
    SPHERE,
    ShapeKind,
    kinds_of_family,
)
from grainlab.errors import InputError

console = Console()

PARTS = ("discrete", "polyhedra", "theories", "dem")
"""The parts of the compilation (``--part``), each a set of tiny runs."""


FAMILY_TINY_RUNS: dict[str, dict[str, Any]] = {
    MEMBER_SPHERES: {"sample": {"n_particles": 24, "seed": 1},
                     "solver": {"max_stage_steps": 400,
                                "compaction": {"inertia_number": 0.05}}},
    POLYHEDRON_FEATURES: {"sample": {"n_particles": 8, "n_faces": 8, "templates": 2,
                                     "seed": 1},
                          "solver": {"max_stage_steps": 200,
                                     "compaction": {"inertia_number": 0.05,
                                                    "time_step_factor": 0.02}}},
}
"""The tiny triaxial run that compiles the kernels of every shape kind of each narrow-phase
family (:data:`~grainlab.engine.shape_kinds.NARROW_PHASE_FAMILIES`), as config updates of
:func:`_tiny_config` (a sample key the kind's maker does not take, such as ``n_faces``, is
not used)."""

FAMILY_PARTS = {MEMBER_SPHERES: "discrete", POLYHEDRON_FEATURES: "polyhedra"}
"""The part that compiles the kinds of each narrow-phase family."""


def _tiny_config(kind: ShapeKind, sweep: str = "serial"):
    from grainlab.lab.run_config import RunConfig

    return RunConfig.model_validate({
        "sample": {"shape": kind.name},
        "test": {"kind": "triaxial", "eps_q_max": 0.002},
        "solver": {"sweep": sweep, "at_max_stage_steps": "next_stage",
                   "shear": {"inertia_number": 0.01}},
        "output": {"record_every": 5, "snapshot_every": 50, "checkpoint_every": 0},
    }).with_updates(FAMILY_TINY_RUNS[kind.narrow_phase])


def _kinds_of(part: str) -> tuple[ShapeKind, ...]:
    """The registered 3D kinds whose family's runs are in ``part``, in code order (a 2D
    kind, discs, goes through its family's kernels with the same types: the spheres' runs
    compile them)."""
    return tuple(sorted((kind for family, where in FAMILY_PARTS.items() if where == part
                         for kind in kinds_of_family(family) if kind.dimension == 3),
                        key=lambda kind: kind.code))


def _discrete_runs(folder: Path) -> None:
    """Each member-sphere kind with the serial sweep, the first also with the coloured one;
    then the analyses and the ParaView export of the first; the sample deposition."""
    from grainlab.analysis.snapshot_files import read_snapshots
    from grainlab.analysis.trajectory import TrajectoryAnalysis
    from grainlab.lab.discrete_run import export_checkpoint_vtk, start_run
    from grainlab.prep.deposition import deposited_packing

    deposited_packing(n_particles=20, d_min=1e-3, seed=1)

    kinds = _kinds_of("discrete")
    runs = [(kind, "serial") for kind in kinds] + [(kinds[0], "coloured")]
    for kind, sweep in runs:
        start_run(folder / f"{kind.name}_{sweep}", _tiny_config(kind, sweep)).run()
    first = folder / f"{kinds[0].name}_serial"
    TrajectoryAnalysis().run(read_snapshots(first / "snapshots.h5"))
    export_checkpoint_vtk(first, folder / "vtk")
    # the solvers of the plain contact problem (engine/nscd/plain_problem_methods.py)
    from grainlab.engine.nscd.contact_problem import FrictionalContactProblem
    from grainlab.engine.nscd.plain_problem_methods import METHODS, solve

    problem = FrictionalContactProblem(np.eye(3), [-1.0, 0.5, 0.0], [0.4])
    for method in METHODS:
        solve(problem, method, max_iterations=2)


def _polyhedra_runs(folder: Path) -> None:
    """Each kind of the polyhedron family."""
    from grainlab.lab.discrete_run import start_run

    for kind in _kinds_of("polyhedra"):
        start_run(folder / kind.name, _tiny_config(kind)).run()


def _theory_runs(folder: Path) -> None:
    from grainlab.contact import ModifiedHertzMindlin2D
    from grainlab.contact.spring_contact import SpringContactLaw
    from grainlab.lab.element_test import run_element_test
    from grainlab.lab.presets import preset
    from grainlab.micromech import (
        RegularPackingModel,
        RotatedStressPath,
        run_rotated_stress_path,
    )
    from grainlab.micromech.micro_element import MicroElementModel
    from grainlab.micromech.micro_element.distribution_kernels import (
        distribute_parallel,
        series_parallel,
    )
    from grainlab.micromech.micro_element.kernels import condense_local_stiffness, stretch
    from grainlab.micromech.micro_element.structures import idealized_material
    from grainlab.micromech.micro_element.tensor_basis import bases
    from grainlab.prep.regular_packings import named_packing

    model = RegularPackingModel(named_packing("C"), ModifiedHertzMindlin2D.seed000())
    run_rotated_stress_path(model, RotatedStressPath(alpha=np.radians(30.0)))
    law = SpringContactLaw(normal_stiffness=1e5, shear_stiffness=1e5,
                           friction_angle=np.radians(25))
    for distribution in ("homogeneous", "maxwellian"):
        element = MicroElementModel(idealized_material(seed=1), law, distribution=distribution)
        element.consolidate_isotropically(100e3)
        run_element_test(element, preset("oedometer", strain_final=0.001, n_steps=5))
    # the threaded kernels of large structures (>= MIN_PARALLEL_ELEMENTS micro-elements), on
    # a few elements: the compiled code depends on the array types only
    n, eye = 3, np.eye(6)
    exp_v, term, total = np.empty((n, 6, 6)), np.empty(n), np.empty(n)
    coefficients = np.array([(-1.0) ** i / math.factorial(i) for i in range(9)])
    series_parallel(np.zeros((n, 6, 6)), coefficients, 3, 0.5, 1, exp_v, term, total)
    distribute_parallel(eye, exp_v, np.full(n, 1.0 / n), np.zeros((n, 6, 6)),
                        np.empty((n, 6, 6)), np.empty((1, 6, 6)))
    structure = idealized_material(seed=1)
    kn = np.ones(structure.mask.shape)
    t, _, spin_map, _ = condense_local_stiffness(structure.branches, structure.mask, kn, kn,
                                                 structure.volumes, True, "micro-element",
                                                 parallel=True)
    s, w, _, _ = bases(3)
    n_elements = structure.volumes.shape[0]
    stretch(np.zeros((n_elements, 6, 6)), np.zeros(6), np.full(n_elements, 1.0 / n_elements),
            spin_map, s, w, structure.branches, structure.mask, t, True, parallel=True)


def _dem_runs(folder: Path) -> None:
    """The soft-contact solver's kernels: a tiny triaxial test in each boundary that has
    kernels of its own (:attr:`~grainlab.lab.boundary_registry.BoundaryRecord.
    compile_sample`: a box of walls, a periodic cell), one of polyhedra in a box (their own
    sub-steps), and the damping of Hertz-Mindlin contacts."""
    from grainlab.contact.soft_contact_law import SoftContactLaw
    from grainlab.lab.boundary_registry import BOUNDARIES
    from grainlab.lab.discrete_run import start_run

    SoftContactLaw.hertz_mindlin(1e9, restitution=0.5)
    for boundary, record in BOUNDARIES.items():
        if record.compile_sample is None:  # its kernels are another boundary's
            continue
        config = _tiny_config(SPHERE).with_updates(
            {"sample": {"boundary": boundary, **record.compile_sample},
             "solver": {"method": "dem"}})
        start_run(folder / boundary, config).run()
    config = _tiny_config(POLYHEDRON).with_updates({"solver": {"method": "dem"}})
    start_run(folder / POLYHEDRON.name, config).run()


_WORK = {"discrete": _discrete_runs, "polyhedra": _polyhedra_runs, "theories": _theory_runs,
         "dem": _dem_runs}


def compile_kernels(part: str = "all") -> float:
    """Compile and cache the kernels of ``part`` (``"all"``, or parts of :data:`PARTS`
    separated by commas) by running tiny versions of that work in a scratch folder; returns
    the seconds it took."""
    names = PARTS if part == "all" else tuple(p.strip() for p in part.split(","))
    if not names or any(name not in PARTS for name in names):
        raise InputError("--part", part, "all, or some of " + ", ".join(PARTS) +
                         " separated by commas")
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="grainlab-compile-") as scratch:
        for name in names:
            _WORK[name](Path(scratch) / name)
    return time.perf_counter() - start


@friendly_errors
def compile_command(
    part: str = typer.Option("all", "--part",
                             help="all, or some of discrete, polyhedra, theories, dem separated "
                                  "by commas (two parts in two shells use two cores)."),
) -> None:
    """Compile grainlab's kernels now (about four minutes in one process; cached on disk for
    every later run), so that the first real test starts at once."""
    console.print(f"compiling the kernels ({part}) ...")
    seconds = compile_kernels(part)
    console.print(f"compiled and cached in {seconds:.0f} s")
