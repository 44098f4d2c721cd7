"""Discrete lab tests in run folders: wall stages, records, checkpoints, resume after kill -9,
bad input, VTK export."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from grainlab.engine.nscd.contact_problem import read_fclib
from grainlab.engine.nscd.plain_problem_methods import solve
from grainlab.errors import InputError
from grainlab.lab.discrete_run import (
    CHECKPOINT,
    PROBLEMS,
    RESULTS,
    SNAPSHOTS,
    export_checkpoint_vtk,
    resume_run,
    start_run,
)
from grainlab.lab.presets import simple_shear, triaxial_compression
from grainlab.lab.run_config import RunConfig
from grainlab.lab.wall_stages import wall_stages
from grainlab.result.test_result import read_test_result

SMALL = {
    "sample": {"n_particles": 40, "seed": 4},
    "test": {"kind": "triaxial", "eps_q_max": 0.02},
    # no overlap recovery and a compaction solved as tightly as the shear: on 40 particles the
    # recovery's push makes the lateral walls' reactions fluctuate by ~10 % from record to
    # record (1 % without), which the wall-stress checks below would confuse with control
    # the warm start, the shear's sweep cap, NLGS alone and the fixed steps of the recorded
    # run (tests/lab/data)
    "solver": {"sweep": "serial", "warm_start_extrapolation": 0.0, "correction": "none",
               "compaction": {"inertia_number": 0.05, "max_iterations": 400,
                              "time_step_growth": 1.0},
               "shear": {"inertia_number": 0.01, "overlap_recovery": 0.0,
                         "max_iterations": 400, "time_step_growth": 1.0}},
    "output": {"record_every": 20, "checkpoint_every": 100, "snapshot_every": 100},
}


def small_config(**updates) -> RunConfig:
    return RunConfig.model_validate(SMALL).with_updates(updates)


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("run") / "triaxial"
    run = start_run(folder, small_config(output={"problems_every": 100}))
    result = run.run()
    return folder, result


def test_the_contact_problems_of_steps_are_stored_for_the_solvers(finished_run):
    folder, result = finished_run
    files = sorted((folder / PROBLEMS).glob("step-*.hdf5"))
    steps = int(result.metadata["outcome"]["steps"])
    assert [f.name for f in files] == [f"step-{k:08d}.hdf5" for k in range(100, steps + 1, 100)]
    for path in files:
        stored = read_fclib(path)
        problem = stored.problem
        assert problem.n_contacts > 20 and stored.reactions.size == 3 * problem.n_contacts
        np.testing.assert_allclose(problem.velocity(stored.reactions), stored.velocities)
        solution = solve(problem, "nlgs", tolerance=1e-6, max_iterations=5000)
        assert solution.converged, (path.name, solution.error)


def test_wall_stages_of_the_presets():
    stages = wall_stages(triaxial_compression(confining=5e3, axial_strain=0.2, n_steps=4))
    assert [s.name for s in stages] == ["consolidation", "shear"]
    assert stages[0].modes == ("stress", "stress", "stress")
    assert stages[1].modes == ("stress", "stress", "strain")
    assert stages[1].targets == (5e3, 5e3, pytest.approx(0.2))
    with pytest.raises(InputError, match="does not shear"):
        wall_stages(simple_shear(vertical_stress=1e4, gamma_final=0.1, n_steps=3))


def test_triaxial_run_records_every_column_and_agrees_with_walls(finished_run):
    folder, result = finished_run
    table = result.table
    assert list(table["stage"].unique()) == ["compaction", "triaxial_compression"] or \
        set(table["stage"].unique()) == {"compaction", "shear"}
    for column in ("p", "q", "q_over_trace", "sin_phi", "eps_q", "eps_vol", "packing_fraction",
                   "z", "z_c", "z_no_rattlers", "inertia_number", "solver_iterations",
                   "wall_sigma_xx", "unbalanced_force_ratio"):
        assert column in table and np.isfinite(table[column].iloc[-1]), column
    compaction = table[table["stage"] == "compaction"].iloc[-1]
    # quasi-static end of compaction: walls at sigma0, contacts agree with walls
    sigma0 = 1e4
    for axis in ("xx", "yy", "zz"):
        assert compaction[f"wall_sigma_{axis}"] == pytest.approx(sigma0, rel=0.011)
    assert compaction["p"] == pytest.approx(sigma0, rel=0.02)
    shear = table[table["stage"] != "compaction"]
    assert shear["eps_q"].iloc[-1] >= 0.02
    assert shear["inertia_number"].max() <= 0.011  # the user's bound (0.01) holds
    # lateral walls stay near sigma0 during shear (40 particles: the walls' reactions
    # fluctuate by several % from record to record)
    np.testing.assert_allclose(shear["wall_sigma_xx"], sigma0, rtol=0.1)
    assert shear["wall_sigma_xx"].mean() == pytest.approx(sigma0, rel=0.05)
    assert result.metadata["outcome"]["finished"]
    for name in (RESULTS, CHECKPOINT, SNAPSHOTS, "config.toml", "run.log", "results.h5"):
        assert (folder / name).exists(), name
    again = read_test_result(folder / RESULTS)
    np.testing.assert_allclose(again.table["q_over_trace"], table["q_over_trace"])


@pytest.fixture(scope="module")
def baseline_run(tmp_path_factory):
    """SMALL run by the CLI in a child process, which inherits the suite's baseline numerics
    (tests/conftest.py, BASELINE_NUMERICS: with AVX-512 NumPy's loops round otherwise, and 40
    spheres amplify the last bits into another compaction length)."""
    folder = tmp_path_factory.mktemp("baseline")
    small_config().write(folder / "input.toml")
    done = subprocess.run(
        [sys.executable, "-m", "grainlab.cli.main", "triaxial", "--out", str(folder / "run"),
         "--config", str(folder / "input.toml"), "--no-progress"],
        capture_output=True, text=True, timeout=600)
    # 40 spheres at 400 sweeps leave 12 of their 20 loading steps unsolved: the run says so
    # (exit 3, the capped share alone); the record is of its numerics
    assert done.returncode == 3, done.stderr[-2000:]
    why = " ".join(done.stdout.split()).split("why: ")[1:]
    assert len(why) == 1 and "solver.shear.capped_share_limit" in why[0], done.stdout
    return read_test_result(folder / "run" / RESULTS)


@pytest.mark.recorded_trajectory
def test_the_wall_box_gives_the_results_it_gave_before(baseline_run):
    """Regression on a recorded run: the rows of SMALL recorded before the engine took a
    pluggable boundary (tests/lab/data; the same on a generic processor,
    NUMBA_CPU_NAME=generic, bit for bit, and on any x86-64 processor with NumPy's baseline
    loops). The last row alone differs in its last digits: the shear's last step, cut to end
    on eps_q, is now stretched rather than followed by a sliver (discrete_test.
    SHORTEST_CUT)."""
    recorded = pd.read_csv(Path(__file__).parent / "data" / "wall_box_triaxial_40_spheres.csv")
    table = baseline_run.table
    assert list(table["stage"]) == list(recorded["stage"])
    assert list(table["step"]) == list(recorded["step"])
    for column in recorded.columns:
        if column == "stage":
            continue
        np.testing.assert_allclose(table[column].to_numpy(dtype=float)[:-1],
                                   recorded[column].to_numpy(dtype=float)[:-1], rtol=1e-9,
                                   atol=1e-12 * float(np.nanmax(np.abs(recorded[column]))),
                                   err_msg=column)
    last, before = table.iloc[-1], recorded.iloc[-1]
    assert last["p"] == pytest.approx(before["p"], rel=0.05)
    assert last["eps_q"] == pytest.approx(before["eps_q"], rel=1e-3)


def test_snapshots_feed_the_analysis_layer(finished_run):
    from grainlab.analysis import SnapshotAnalysis
    from grainlab.analysis.snapshot_files import read_snapshots

    folder, _ = finished_run
    networks = list(read_snapshots(folder / SNAPSHOTS))
    assert networks and "eps_q" in networks[-1].state
    descriptors = SnapshotAnalysis().compute(networks[-1]).descriptors
    assert descriptors["coordination_number"] > 0


def test_snapshot_stress_holds_the_wall_contacts(finished_run):
    """The snapshots carry the wall contacts: the stress of particle and wall contacts is the
    results row's contact stress (walls included) of the same step, and within the sample's
    imbalance the wall reactions over the box's faces; the pairs alone fall short of it."""
    from grainlab.analysis.contact_stress import (
        StressState,
        stress_from_network,
        wall_reaction_stress,
    )
    from grainlab.analysis.snapshot_files import read_snapshots

    folder, result = finished_run
    rows = result.table.set_index("step")
    checked = 0
    for network in read_snapshots(folder / SNAPSHOTS):
        step = network.state.get("step")
        if step not in rows.index or network.state.get("stage") != "shear":
            continue
        row = rows.loc[step]
        assert network.has_box and network.n_wall_points > 0
        full = stress_from_network(network)
        sym = 0.5 * (full + full.T)
        recorded = np.array([row["sigma_xx"], row["sigma_yy"], row["sigma_zz"]])
        np.testing.assert_allclose(np.diag(sym), recorded, rtol=1e-9)
        reaction = np.diag(wall_reaction_stress(network))
        np.testing.assert_allclose(np.diag(sym), reaction, rtol=0.05)
        walls = np.array([row["wall_sigma_xx"], row["wall_sigma_yy"], row["wall_sigma_zz"]])
        np.testing.assert_allclose(reaction, walls, rtol=0.05)
        share = StressState().compute(network).descriptors()["wall_share_of_p"]
        assert 0.0 < share < 0.5  # the walls' share of p: what the pairs alone miss
        checked += 1
    assert checked


def test_vtk_export_of_a_checkpoint(finished_run, tmp_path):
    import meshio

    folder, _ = finished_run
    paths = export_checkpoint_vtk(folder, tmp_path / "vtk")
    names = {p.name for p in paths}
    assert {"particles_000000.vtu", "walls_000000.vtu"} <= names
    walls = meshio.read(tmp_path / "vtk" / "walls_000000.vtu")
    assert sum(len(c.data) for c in walls.cells) == 6


def test_unknown_key_and_bad_values_name_the_field(tmp_path):
    (tmp_path / "bad.toml").write_text("[sample]\nn_particle = 10\n")
    with pytest.raises(InputError, match=r"sample\.n_particle"):
        RunConfig.read(tmp_path / "bad.toml")
    with pytest.raises(InputError, match=r"solver\.shear\.friction"):
        RunConfig.model_validate({"solver": {"shear": {"friction": -0.1}}})
    with pytest.raises(InputError, match=r"sample\.d_min"):
        RunConfig.model_validate({"sample": {"d_min": -1e-3}})


def test_a_run_folder_is_not_overwritten_by_accident(finished_run):
    folder, _ = finished_run
    with pytest.raises(InputError, match="resume"):
        start_run(folder, small_config())


def _wait_for(path: Path, timeout: float) -> None:
    end = time.time() + timeout
    while not path.exists():
        if time.time() > end:
            raise AssertionError(f"{path} did not appear in {timeout} s")
        time.sleep(0.05)


@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGTERM])
def test_resume_after_kill_loses_only_the_steps_since_the_checkpoint(tmp_path, finished_run,
                                                                      how):
    _, reference = finished_run
    folder = tmp_path / "killed"
    config = small_config()
    folder.mkdir()
    config.write(tmp_path / "input.toml")
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen(
        [sys.executable, "-m", "grainlab.cli.main", "triaxial", "--out", str(folder),
         "--config", str(tmp_path / "input.toml"), "--no-progress"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        _wait_for(folder / CHECKPOINT, 120)
        time.sleep(0.3)
        process.send_signal(how)
        process.wait(60)
    finally:
        if process.poll() is None:
            process.kill()
    assert (folder / CHECKPOINT).exists()
    run = resume_run(folder)
    assert run.test.simulation.step_index > 0
    result = run.run()
    table, expected = result.table, reference.table
    assert len(table) == len(expected)
    np.testing.assert_allclose(table["step"], expected["step"])
    np.testing.assert_allclose(table["q_over_trace"], expected["q_over_trace"], rtol=1e-6,
                               atol=1e-9)
    np.testing.assert_allclose(table["packing_fraction"], expected["packing_fraction"],
                               rtol=1e-9)


@pytest.mark.long
def test_aggregate_triaxial_runs_and_classifies_contacts(tmp_path):
    from grainlab.analysis.snapshot_files import read_snapshots

    # seed 6: a sample whose frictionless compaction settles in ~1300 steps (30 aggregates of
    # size ratio 3 creep for 2000-6000 steps at other seeds before they meet the criteria)
    config = small_config(sample={"shape": "aggregate", "eta": 0.4, "n_particles": 30,
                                  "size_ratio": 3.0, "seed": 6},
                          output={"snapshot_every": 20, "checkpoint_every": 0})
    result = start_run(tmp_path / "agg", config).run()
    assert result.metadata["outcome"]["finished"]
    assert result.metadata["specimen"]["shape"] == "aggregate"
    shear = result.table[result.table["stage"] != "compaction"]
    assert shear["eps_q"].iloc[-1] >= 0.02
    network = list(read_snapshots(tmp_path / "agg" / SNAPSHOTS))[-1]
    assert network.type_names[:3] == ("s", "ds", "d")
    assert network.pair_types is not None and len(network.pair_types) == network.n_pairs
