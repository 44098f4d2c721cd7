"""``grainlab compile``: compile (and cache) the kernels before the first real run.

grainlab's kernels are compiled by Numba on their first call and cached on disk (``cache=True``)
for every later process; on two cores the first discrete run spends one to two minutes
compiling. This command runs tiny versions of every kind of work once, so that the compilation
happens now, with a message, instead of inside a user's first test, and can be split over
processes: ``--part discrete`` (contact dynamics of spheres and aggregates, sample measures,
snapshots, microstructure analysis, ParaView export), ``--part polyhedra`` (polyhedra
contact geometry and dynamics) and ``--part theories`` (the regular-packing and micro-element
models); ``--part all`` runs the three in turn. Nothing is kept but the compiled code.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np
import typer
from rich.console import Console

from grainlab.cli.errors import friendly_errors
from grainlab.errors import InputError

console = Console()

PARTS = ("discrete", "polyhedra", "theories")
"""The parts of the compilation (``--part``), each a set of tiny runs."""


def _discrete_runs(folder: Path) -> None:
    from grainlab.analysis.snapshot_files import read_snapshots
    from grainlab.analysis.trajectory import TrajectoryAnalysis
    from grainlab.lab.discrete_run import export_checkpoint_vtk, start_run
    from grainlab.lab.run_config import RunConfig

    for k, (shape, sweep) in enumerate((("sphere", "serial"), ("sphere", "coloured"),
                                        ("aggregate", "serial"))):
        config = RunConfig.model_validate({
            "sample": {"shape": shape, "n_particles": 24, "seed": 1},
            "test": {"kind": "triaxial", "eps_q_max": 0.002},
            "solver": {"sweep": sweep, "max_stage_steps": 400,
                       "at_max_stage_steps": "next_stage",
                       "compaction": {"inertia_number": 0.05},
                       "shear": {"inertia_number": 0.01}},
            "output": {"record_every": 5, "snapshot_every": 50, "checkpoint_every": 0}})
        run = start_run(folder / f"run{k}", config)
        run.run()
    TrajectoryAnalysis().run(read_snapshots(folder / "run0" / "snapshots.h5"))
    export_checkpoint_vtk(folder / "run0", folder / "vtk")


def _polyhedra_runs(folder: Path) -> None:
    from grainlab.lab.discrete_run import start_run
    from grainlab.lab.run_config import RunConfig

    config = RunConfig.model_validate({
        "sample": {"shape": "polyhedron", "n_particles": 8, "n_faces": 8, "templates": 2,
                   "seed": 1},
        "test": {"kind": "triaxial", "eps_q_max": 0.002},
        "solver": {"sweep": "serial", "max_stage_steps": 200,
                   "at_max_stage_steps": "next_stage",
                   "compaction": {"inertia_number": 0.05, "time_step_factor": 0.02},
                   "shear": {"inertia_number": 0.01}},
        "output": {"record_every": 5, "snapshot_every": 50, "checkpoint_every": 0}})
    start_run(folder / "poly", config).run()


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
    from grainlab.micromech.micro_element.structures import idealized_material
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


_WORK = {"discrete": _discrete_runs, "polyhedra": _polyhedra_runs, "theories": _theory_runs}


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
                             help="all, or some of discrete, polyhedra, theories separated by "
                                  "commas (two parts in two shells use two cores)."),
) -> None:
    """Compile grainlab's kernels now (a minute or two on two cores; cached on disk for every
    later run), so that the first real test starts at once."""
    console.print(f"compiling the kernels ({part}) ...")
    seconds = compile_kernels(part)
    console.print(f"compiled and cached in {seconds:.0f} s")
