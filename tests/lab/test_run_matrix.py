"""The discrete lab across its whole matrix: every solver (contact dynamics ``cd``, soft-contact
DEM ``dem``) x boundary (wall box ``walls``, periodic cell ``periodic``) x particle shape (every
kind of the shape registry: spheres, sphere aggregates, convex polyhedra, and discs, whose 2D
test is a biaxial one with the vertical axis y) runs a short triaxial test -- an isotropic
compaction to sigma0, then a compression at constant lateral stress --
through the run-folder API a user calls (:class:`~grainlab.lab.run_config.RunConfig`,
:func:`~grainlab.lab.discrete_run.start_run`, :func:`~grainlab.lab.discrete_run.resume_run`,
:func:`~grainlab.lab.discrete_run.export_checkpoint_vtk`), and on every case:

1. a run interrupted in its shear (as Ctrl-C does: the step finishes, a checkpoint is written)
   and resumed ends bit for bit as the run made straight through: bodies, boundary, results
   table, contact snapshots;
2. ``grainlab vtk``'s export of the last checkpoint is a valid VTK UnstructuredGrid holding
   every particle once, each drawn around its own centre with its own velocity, and (a
   snapshot taken at that step) one line per recorded contact;
3. the physics holds: a finite state, overlaps small against the grains (rigid grains: the
   contact-dynamics step's bound; soft grains: a few p / (kappa sigma0) <d>), the mean stress
   of the contacts positive and near sigma0 where the compaction ends, the deviator (q and
   q / tr sigma) grown by the shear with eps_q rising at every record, and the contact
   forces compressive and inside their Coulomb cone, |f_t| <= mu f_n, at every point of the
   last step and in every snapshot.

Kept small (a few tens of steps per stage, a few seconds a case): 30 particles in a box (12
polyhedra), 110 spheres of size ratio 1.2 in a cell, two 30-faced polyhedron templates,
aggregates of eta = 0.2; a coarse compaction with overlap recovery that ends when the sample
has settled to looser criteria than a real run's or at its step budget, and a short, faster
shear. Three cases take tens of seconds (``long``): soft polyhedra in a box and aggregates in
a cell. Polyhedra in a periodic cell need about 250 particles (minutes): the matrix checks
that the lab refuses a cell of too few, naming ``sample.n_particles``, and that soft
polyhedra refuse rolling resistance.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pandas as pd
import pytest

from grainlab.analysis.snapshot_files import read_snapshots
from grainlab.engine.shape_kinds import SHAPE_KIND_NAMES
from grainlab.errors import InputError
from grainlab.lab.discrete_run import (
    CHECKPOINT,
    SNAPSHOTS,
    DiscreteRun,
    RunInterrupted,
    export_checkpoint_vtk,
    resume_run,
    start_run,
)
from grainlab.lab.run_checkpoint import STATE_FIELDS
from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_outcome import BOX_TOO_THIN
from grainlab.result.test_result import TestResult

SOLVERS = ("cd", "dem")
BOUNDARIES = ("walls", "periodic")
CASES = [(solver, boundary, shape) for solver in SOLVERS for boundary in BOUNDARIES
         for shape in SHAPE_KIND_NAMES]

SIGMA0 = 1e4
"""Confining stress [Pa]."""
KAPPA = 1e3
"""Stiffness number of the soft grains, k_n / (sigma0 <d>) [-]: overlaps of order 1e-3 <d>."""
FRICTION = 0.4
"""Interparticle friction of the shear [-] (the compaction is frictionless)."""
PARTICLES = {("walls", "sphere"): 30, ("walls", "aggregate"): 30, ("walls", "polyhedron"): 12,
             ("walls", "disc"): 30, ("periodic", "sphere"): 110, ("periodic", "aggregate"): 160,
             ("periodic", "polyhedron"): 60, ("periodic", "disc"): 60}
"""Particles of each boundary and shape: a box holds a few across; a periodic cell at least
about four interaction ranges across once compacted (its detection stops a compaction that
leaves it narrower than three ranges plus alert distances: 80 spheres of size ratio 1.2 stop
at 3.9 diameters). 60 polyhedra are too few for a cell (below)."""
SIZE_RATIO = {"walls": 2.0, "periodic": 1.2}
COARSE_STEP = 0.05
"""The rigid grains' compaction time step factor [-] in a box (the walls move this many d_min
a step): coarse, with overlap recovery; 0.1 for the loose polyhedra (a packing fraction of
0.13 at the start: the loose sample places their circumscribed spheres). A periodic cell
takes 0.02: the alert distance of the detection grows with a step's travel, and three
interaction ranges plus alert distances must fit across the cell. Soft grains take 0.1."""
COMPACTION_STEPS = 80
"""The compaction's step budget [-]: it ends settled (looser criteria than a real run's) or
there, and the shear starts; soft polyhedra take 250 (their own spin shortens the step),
rigid ones 100, aggregates in a cell 200 (the loosest start: a packing fraction of 0.18),
discs 800 (a 2D box of as many grains is about twice as wide: the step, d_min over the walls'
speed eps_dot L, is half as long for the same strain; rigid discs in a cell, at a step factor
of 0.05, settle in about 370)."""


def compaction_numerics(solver: str, boundary: str, shape: str) -> tuple[dict, int]:
    """``[solver.compaction]`` of a case and its step budget (:data:`COARSE_STEP`,
    :data:`COMPACTION_STEPS`); soft polyhedra compact at an inertia number of 0.3 (the
    sub-steps follow physical time: a faster compaction is fewer of them)."""
    step = 0.1  # the soft grains' sub-steps do not depend on it
    if solver == "cd":
        step = 0.02 if boundary == "periodic" else 0.1 if shape == "polyhedron" else COARSE_STEP
        if (boundary, shape) == ("periodic", "disc"):
            step = 0.05  # 60 discs leave a cell 8-9 diameters wide: room for the alert
    inertia, budget = 0.1, COMPACTION_STEPS
    if shape == "polyhedron":
        inertia, budget = (0.3, 250) if solver == "dem" else (0.1, 100)
    if (boundary, shape) == ("periodic", "aggregate"):
        budget = 200
    if shape == "disc":  # a 2D box of as many grains is wider: its walls' step is shorter
        budget = 800
    return {"inertia_number": inertia, "time_step_factor": step, "overlap_recovery": 0.5}, \
        budget


LONG_CASES = {("dem", "walls", "polyhedron"), ("cd", "periodic", "aggregate"),
              ("dem", "periodic", "aggregate")}
"""Cases of tens of seconds (``pytest.mark.long``)."""
THIN_CELL_CASES = {(solver, "periodic", "polyhedron") for solver in SOLVERS}
"""Cases the lab refuses at the matrix's size (:data:`PARTICLES`): a periodic cell of
polyhedra needs about 250 of n_f = 30 to stay four interaction ranges across, minutes of
running; 60 are refused before anything runs, naming ``sample.n_particles``."""
EPS_Q = 0.03
"""The shear's target deviatoric strain eps_q [-]: about a dozen steps."""

RIGID_OVERLAP = 0.01
"""Largest overlap over <d> [-] of rigid grains (contact dynamics) through the shear and where
the compaction ends: twice the step's own bound (0.5 %, ``solver.*.overlap_bound``, which one
step may pass before the next shortens)."""
COARSE_RIGID_OVERLAP = 0.03
"""... and anywhere in the compaction, whose coarse steps (:data:`COARSE_STEP`) let a
first contact overlap up to 2-3 % of <d> before the overlap recovery takes it back: a bound
that a runaway (overlaps growing step after step) passes."""
SOFT_OVERLAP = 20.0
"""Largest overlap over <d> of soft grains (DEM), in units of p / (kappa sigma0) [-], p the
largest mean stress of the run (at least sigma0): a contact force f ~ 2 p <d>^2 on a normal
stiffness kappa sigma0 <d> overlaps 2 p / (kappa sigma0) <d> on average; the strongest
contacts carry a few times the mean."""
STRESS_WINDOW = (0.5, 2.0)
"""The mean contact stress p over sigma0 [-] where the compaction ends (settled, or at its step
budget with the boundary's servo at sigma0): p, from the contacts alone, is near sigma0; a
sample not yet loaded, or overloaded, falls outside."""


def matrix_config(solver: str, boundary: str, shape: str) -> RunConfig:
    """The run of one case of the matrix (module docstring)."""
    sample = {"shape": shape, "n_particles": PARTICLES[boundary, shape], "seed": 3,
              "size_ratio": SIZE_RATIO[boundary], "boundary": boundary}
    if shape == "polyhedron":
        sample.update(n_faces=30, templates=2, packing_fraction=0.25)
    if shape == "aggregate":
        sample.update(eta=0.2)
    if shape == "disc":  # discs compact to an area fraction near 0.8: start less loose
        sample.update(packing_fraction=0.35)
    compaction, budget = compaction_numerics(solver, boundary, shape)
    settings = {"method": solver, "sweep": "serial", "max_stage_steps": budget,
                "at_max_stage_steps": "next_stage", "compaction": compaction,
                "shear": {"friction": FRICTION, "inertia_number": 0.02,
                          "time_step_factor": 0.005}}
    if solver == "dem":
        settings["dem"] = {"kappa": KAPPA}
    settled = {"stress_tolerance": 0.05, "unbalanced_force": 0.05,
               "kinetic_energy": float("inf")}
    return RunConfig.model_validate({
        "sample": sample,
        "test": {"kind": "triaxial", "sigma0": SIGMA0, "eps_q_max": EPS_Q,
                 "quasi_static": settled},
        "solver": settings,
        "output": {"record_every": 1, "snapshot_every": 5, "checkpoint_every": 0,
                   "vtk_every": 0},
    })


def case_id(case: tuple[str, str, str]) -> str:
    return "-".join(case)


# -- the three checks --------------------------------------------------------------------------
def interrupted_and_resumed(folder, config: RunConfig, stop_step: int
                            ) -> tuple[DiscreteRun, TestResult]:
    """The run of ``config`` interrupted at the record of step ``stop_step`` (as Ctrl-C: the
    step finishes, a checkpoint is written, :class:`RunInterrupted` raised), then resumed from
    its folder and run to its end."""
    run = start_run(folder, config)

    def interrupt(test, row):
        if row["step"] == stop_step:
            run.request_interrupt()

    run.test.on_record = interrupt
    with pytest.raises(RunInterrupted, match=f"interrupted at step {stop_step}"):
        run.run()
    resumed = resume_run(folder)
    assert resumed.test.simulation.step_index == stop_step
    return resumed, resumed.run()


def assert_same_run(straight: DiscreteRun, result: TestResult, resumed: DiscreteRun,
                    resumed_result: TestResult) -> None:
    """Bit for bit: every body array, the boundary, the results table and the snapshots."""
    state, again = straight.test.sample.state, resumed.test.sample.state
    for name in STATE_FIELDS:
        assert np.array_equal(getattr(again, name), getattr(state, name)), name
    boundary = straight.test.sample.boundary.to_arrays()
    for name, value in resumed.test.sample.boundary.to_arrays().items():
        assert np.array_equal(value, boundary[name]), f"boundary {name}"
    pd.testing.assert_frame_equal(resumed_result.table, result.table, check_exact=True)
    snapshots = list(read_snapshots(straight.folder / SNAPSHOTS))
    again_snapshots = list(read_snapshots(resumed.folder / SNAPSHOTS))
    assert len(again_snapshots) == len(snapshots) > 0
    for net, net_again in zip(snapshots, again_snapshots, strict=True):
        assert net_again.state == net.state
        for name in ("pair_particles", "point_pairs", "point_normals", "point_forces"):
            assert np.array_equal(getattr(net_again, name), getattr(net, name)), name


def assert_paraview_frame(run: DiscreteRun) -> None:
    """The particles (and contacts) that ``grainlab vtk`` writes for the run's last
    checkpoint (module docstring, check 2)."""
    paths = {path.name.split("_")[0]: path for path in export_checkpoint_vtk(run.folder)}
    state, library = run.test.sample.state, run.test.sample.library
    particles = paths["particles"]
    root = ET.parse(particles).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "UnstructuredGrid"
    piece = root.find("UnstructuredGrid/Piece")
    mesh = meshio.read(particles)
    assert int(piece.get("NumberOfPoints")) == len(mesh.points) > 0
    assert int(piece.get("NumberOfCells")) == sum(len(block) for block in mesh.cells) > 0
    owner = mesh.point_data["particle_id"]
    assert np.array_equal(np.unique(owner), np.arange(state.n_bodies))  # each particle once
    assert np.array_equal(mesh.point_data["velocity"], state.velocities[owner])
    reach = np.linalg.norm(mesh.points - state.positions[owner], axis=1)
    assert np.all(reach <= library.bounding_radius[state.shape_ids[owner]] * (1 + 1e-9))
    assert np.all(reach > 0.0)  # a surface around the centre, not the centre
    assert ("walls" in paths) == (not run.test.sample.periodic)
    net = list(read_snapshots(run.folder / SNAPSHOTS))[-1]  # the state the run ended in
    lines = meshio.read(paths["contacts"]).cells_dict["line"]
    assert len(lines) == len(net.point_forces) > 0


def assert_physics(run: DiscreteRun, result: TestResult, solver: str) -> None:
    """Check 3 of the module docstring on a run made straight through."""
    outcome = result.metadata["outcome"]
    assert outcome["finished"], outcome["summary"]
    state = run.test.sample.state
    for name in ("positions", "orientations", "velocities", "angular_velocities"):
        assert np.all(np.isfinite(getattr(state, name))), name
    table = result.table
    for column in ("p", "q", "eps_q", "packing_fraction", "max_overlap_over_d"):
        assert np.all(np.isfinite(table[column])), column
    compaction = table[table["stage"] == "compaction"]
    shear = table[table["stage"] == "shear"]
    assert len(compaction) >= 5 and len(shear) >= 5
    overlaps = table["max_overlap_over_d"]
    if solver == "cd":
        assert overlaps.max() < COARSE_RIGID_OVERLAP
        assert compaction["max_overlap_over_d"].iloc[-1] < RIGID_OVERLAP
        assert shear["max_overlap_over_d"].max() < RIGID_OVERLAP
    else:
        assert overlaps.max() < SOFT_OVERLAP * max(table["p"].max(), SIGMA0) / (KAPPA * SIGMA0)
    assert np.all(compaction["p"] >= 0.0)  # contacts only push
    settled = compaction.iloc[-1]
    low, high = STRESS_WINDOW
    assert low * SIGMA0 < settled["p"] < high * SIGMA0
    assert np.all(np.diff(shear["eps_q"]) > 0.0)  # strain-controlled: eps_q rises
    assert shear["eps_q"].iloc[-1] >= EPS_Q
    end = shear.iloc[-1]
    assert end["q"] > settled["q"] and end["q_over_trace"] > settled["q_over_trace"]
    assert_coulomb(run, soft=solver == "dem")


def assert_coulomb(run: DiscreteRun, soft: bool) -> None:
    """Every contact force compressive and inside its Coulomb cone, |f_t| <= mu f_n, to
    round-off: at every contact point of the last step (the shear's mu, :data:`FRICTION`),
    and in every snapshot (its own mu: 0 in the compaction, :data:`FRICTION` in the shear)
    that stores contact points; one that stores each pair's resultant (polyhedra: points of
    several normals summed) has only its resultants compressive. Soft polyhedra (``soft``
    and a library of polyhedra) hold Coulomb per pair, on the pair's one tangential spring
    (|F_t| <= mu sum f_n), and their points report shares of F_t by depth beside normal
    forces damped point by point: their points are checked compressive only."""
    report = run.test.simulation.last_report
    impulses = report.impulses  # local (P_n, P_t, P_s) of each point
    assert report.n_contacts > 0
    tangential = np.hypot(impulses[:, 1], impulses[:, 2])
    scale = 1e-9 * float(np.abs(impulses).max())
    assert np.all(impulses[:, 0] >= -scale), "the last step: a tensile impulse"
    if not (soft and run.test.sample.library.vertices.shape[0]):
        assert np.all(tangential <= FRICTION * impulses[:, 0] + scale), \
            "the last step: an impulse outside its Coulomb cone"
    snapshots = list(read_snapshots(run.folder / SNAPSHOTS))
    assert {net.friction_coefficient for net in snapshots} == {0.0, FRICTION}
    for net in snapshots:
        forces, normals = net.point_forces, net.point_normals
        f_n = np.einsum("ij,ij->i", forces, normals)
        f_t = np.linalg.norm(forces - f_n[:, None] * normals, axis=1)
        scale = 1e-9 * max(float(np.abs(forces).max(initial=0.0)), 1e-300)
        step = net.state.get("step")
        assert np.all(f_n >= -scale), f"step {step}: a tensile force"
        if not len(net.type_points):
            assert np.all(f_t <= net.friction_coefficient * f_n + scale), \
                f"step {step}: a force outside its Coulomb cone"


RUN_CASES = [pytest.param(*case, id=case_id(case),
                         marks=[pytest.mark.long] if case in LONG_CASES else [])
             for case in CASES if case not in THIN_CELL_CASES]


@pytest.mark.parametrize(("solver", "boundary", "shape"), RUN_CASES)
def test_every_solver_boundary_and_shape_runs_resumes_and_draws(solver, boundary, shape,
                                                                 tmp_path):
    config = matrix_config(solver, boundary, shape)
    straight = start_run(tmp_path / "straight", config)
    result = straight.run()
    assert_physics(straight, result, solver)
    assert_paraview_frame(straight)
    table = result.table
    shear_steps = table.loc[table["stage"] == "shear", "step"].to_numpy()
    stop = int(shear_steps[len(shear_steps) // 2])  # in the shear, its stage under way
    resumed, resumed_result = interrupted_and_resumed(tmp_path / "resumed", config, stop)
    assert_same_run(straight, result, resumed, resumed_result)


@pytest.mark.parametrize(("solver", "boundary", "shape"), sorted(THIN_CELL_CASES),
                         ids=map(case_id, sorted(THIN_CELL_CASES)))
def test_a_periodic_cell_of_too_few_polyhedra_is_refused_before_it_runs(solver, boundary,
                                                                        shape, tmp_path):
    """Compacted, 60 polyhedra would leave the cell thinner than three interaction ranges:
    refused naming ``sample.n_particles``, with the number it needs, before the folder is
    made."""
    with pytest.raises(InputError) as error:
        start_run(tmp_path / "run", matrix_config(solver, boundary, shape))
    assert error.value.field == "sample.n_particles"
    assert error.value.value == PARTICLES[boundary, shape]
    assert "at least about" in str(error.value) and "periodic cell" in str(error.value)
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(("solver", "boundary", "shape"), CASES, ids=map(case_id, CASES))
def test_rolling_resistance_is_refused_where_the_solver_has_none(solver, boundary, shape,
                                                                 tmp_path):
    """Rolling resistance (``solver.dem.rolling_friction``) is a soft-contact model of spheres
    and aggregates: soft polyhedra refuse it, naming the key, before the run folder is made;
    every other case of the matrix takes it (contact dynamics does not read it)."""
    config = matrix_config(solver, boundary, shape).with_updates(
        {"solver": {"dem": {"rolling_friction": 0.1}}})
    if solver == "dem" and shape == "polyhedron":
        with pytest.raises(InputError) as error:
            start_run(tmp_path / "run", config)
        assert error.value.field == "solver.dem.rolling_friction"
        assert "polyhedra" in str(error.value)
        assert not (tmp_path / "run").exists()
    else:
        config.check_solver()


def test_a_coarse_compaction_in_a_cell_stops_its_stage_when_the_cell_gets_thin(tmp_path):
    """Rigid spheres compacted in a cell with steps of 0.1 d_min: the detection's alert
    distance grows with the steps' travel, and the cell, shrinking, gets narrower than three
    interaction ranges plus alert distances. The stage should stop there with the diagnosis
    (as it does when the particles alone make the cell too thin), its checkpoint kept."""
    config = matrix_config("cd", "periodic", "sphere").with_updates(
        {"solver": {"compaction": {"time_step_factor": 0.1}}})
    run = start_run(tmp_path / "run", config)
    result = run.run()
    stage = result.metadata["outcome"]["stages"][0]
    assert stage["ended"] == BOX_TOO_THIN
    assert "periodic cell" in str(stage)
    assert np.isfinite(result.table[["p", "eps_q"]].to_numpy(dtype=float)).all()
    assert (tmp_path / "run" / CHECKPOINT).exists()
