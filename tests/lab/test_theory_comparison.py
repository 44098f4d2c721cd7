"""A discrete run and seed 001's micro-element model of its own packing: the model starts from
the run's stress at the end of the compaction, follows the rest of the run's path, and both
sides land on the run's strain grid; the interpolation onto that grid and the dilatancy rate
are checked on curves known in closed form; a kind the model cannot follow and an unknown
distribution law are refused naming the field, before anything is written."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from grainlab.analysis.contact_stress import stress_from_network
from grainlab.cli.main import app
from grainlab.errors import InputError
from grainlab.lab.run_micro_element import (
    check_distributions,
    compaction_snapshot,
    mean_diameter,
    model_path,
    run_contact_law,
    run_micro_element_model,
)
from grainlab.lab.solver_comparison import read_run_result
from grainlab.lab.theory_comparison import (
    CURVE_COLUMNS,
    SIMULATION,
    TheoryComparison,
    _dilatancy,
    check_theory_kind,
    model_curves,
    on_simulation_grid,
)
from grainlab.result.test_result import TestResult

runner = CliRunner()

SMALL_TRIAXIAL = ["theory-vs-sim", "triaxial", "-n", "40", "--eps-q", "0.03", "--sigma0",
                  "1e5", "--mu", "0.4", "--inertia", "0.01", "--record-every", "2", "--seed",
                  "1", "--distribution", "homogeneous", "--distribution",
                  "maxwellian-average", "--model-steps", "60", "--no-progress"]
"""40 rigid spheres in a box, contact dynamics, to eps_q = 0.03: a few seconds once compiled."""

WALL_BALANCE = 1e-3
"""In a box the model's stress is the particle contacts' plus the walls' that balance each
particle (from_snapshot, walls="balance"): it equals the run's stress on the walls up to the
particles' residual imbalance, which the quasi-static end of the compaction keeps below
1e-3 of p [-]."""


@pytest.fixture(scope="module")
def comparison_folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("theory") / "cmp"
    result = runner.invoke(app, [*SMALL_TRIAXIAL, "--out", str(out)])
    return out, result


@pytest.mark.long
def test_the_command_writes_its_files_and_exits_0(comparison_folder):
    out, result = comparison_folder
    assert result.exit_code == 0, result.output
    for name in ("run/results.h5", "run/snapshots.h5", "theory.csv", "theory-differences.csv",
                 "theory.png", "model-homogeneous.csv", "model-maxwellian-average.csv"):
        assert (out / name).is_file(), name
    differences = pd.read_csv(out / "theory-differences.csv")
    assert set(differences["distribution"]) == {"homogeneous", "maxwellian-average"}
    assert {"peak_q_over_p", "end_q_over_p", "dilatancy", "reached_eps_axial",
            "own_peak_q_over_p"} <= set(differences["quantity"])
    rows = differences.dropna(subset=["simulation", "model"])
    assert np.allclose(rows["model_minus_simulation"], rows["model"] - rows["simulation"])


def test_the_model_starts_from_the_runs_stress(comparison_folder):
    out, _ = comparison_folder
    result = read_run_result(out / "run")
    network = compaction_snapshot(out / "run" / "snapshots.h5")
    end = result.table[result.table["stage"] == "compaction"].iloc[-1]
    run_stress = np.array([[end["sigma_xx"], end["sigma_xy"], end["sigma_xz"]],
                           [end["sigma_xy"], end["sigma_yy"], end["sigma_yz"]],
                           [end["sigma_xz"], end["sigma_yz"], end["sigma_zz"]]])
    # the snapshot taken at the end of the compaction is the run's last compaction row (whose
    # stress is the symmetric part of the contacts' (1/V) sum f (x) l)
    assert network.state["step"] == end["step"]
    snapshot = stress_from_network(network)
    np.testing.assert_allclose(0.5 * (snapshot + snapshot.T), run_stress, rtol=0,
                               atol=1e-12 * end["p"])
    for name in ("homogeneous", "maxwellian", "maxwellian-average"):
        model = run_micro_element_model(result, network, name)
        np.testing.assert_allclose(model.stress_tensor(), run_stress, rtol=0,
                                   atol=WALL_BALANCE * end["p"])
    # and the path it follows is the run's loading: the same axial strain increment in all
    path = model_path(result, 60)
    assert [stage.name for stage in path.stages] == ["shear"]
    stage = path.stages[0]
    assert stage.control[:3] == ("stress", "stress", "strain")
    assert stage.values[0] == stage.values[1] == pytest.approx(1e5)


def test_the_model_takes_the_springs_the_dem_would_give_the_run(comparison_folder):
    """Rigid grains (contact dynamics): k_n = kappa sigma0 <d> with the DEM's default
    kappa = 1e4, k_s = 0.5 k_n, and the loading's friction mu = 0.4 = tan phi_mu."""
    out, _ = comparison_folder
    result = read_run_result(out / "run")
    network = compaction_snapshot(out / "run" / "snapshots.h5")
    law = run_contact_law(result, network)
    diameters = (6.0 * np.asarray(network.volumes) / np.pi) ** (1.0 / 3.0)
    assert mean_diameter(network) == pytest.approx(diameters.mean(), rel=1e-12)
    assert law.normal_stiffness == pytest.approx(1e4 * 1e5 * diameters.mean(), rel=1e-12)
    assert law.shear_stiffness == pytest.approx(0.5 * law.normal_stiffness, rel=1e-12)
    assert law.friction_coefficient == pytest.approx(0.4, rel=1e-12)


def test_both_sides_are_on_the_runs_strain_grid(comparison_folder):
    out, _ = comparison_folder
    curves = pd.read_csv(out / "theory.csv")
    simulation = curves[curves["side"] == SIMULATION].reset_index(drop=True)
    assert simulation["eps_axial"].iloc[0] == 0.0
    assert (np.diff(simulation["eps_axial"]) > 0).all()  # triaxial: eps_zz grows
    for name in ("homogeneous", "maxwellian-average"):
        model = curves[curves["side"] == name].reset_index(drop=True)
        assert 2 <= len(model) <= len(simulation)
        np.testing.assert_array_equal(model["eps_axial"],
                                      simulation["eps_axial"].iloc[:len(model)])
        assert list(model["stage"]) == list(simulation["stage"].iloc[:len(model)])
        # the same state at the start: the run's stress, to the wall balance
        assert model["p"].iloc[0] == pytest.approx(simulation["p"].iloc[0], rel=WALL_BALANCE)
        assert model["q_over_p"].iloc[0] == pytest.approx(simulation["q_over_p"].iloc[0],
                                                          abs=10 * WALL_BALANCE)


def test_the_comparison_computed_again_is_the_same(comparison_folder):
    out, _ = comparison_folder
    again = TheoryComparison(["homogeneous", "maxwellian-average"], 60).compute(out / "run")
    written = pd.read_csv(out / "theory.csv")
    np.testing.assert_allclose(again.curves["q_over_p"].to_numpy(),
                               written["q_over_p"].to_numpy(), rtol=1e-12)


def _curves(side, stages, eps, q_over_p, eps_vol):
    n = len(eps)
    return pd.DataFrame({"side": side, "stage": stages, "eps_axial": eps, "eps_q": eps,
                         "q_over_p": q_over_p, "eps_vol": eps_vol, "K0": np.ones(n),
                         "sigma_v": np.ones(n), "p": np.ones(n),
                         "phi_mob": np.degrees(np.arcsin(np.clip(q_over_p, 0.0, 1.0)))})


def test_a_model_on_the_runs_grid_is_interpolated_linearly_and_cut_where_it_stopped():
    """A model linear in the strain (q/p = 2 eps + 0.1) on a finer grid than the run's,
    through a loading and an unloading stage: on the run's strains its values are exact; a
    model that stopped half-way through the unloading keeps the run's rows it reached."""
    sim_eps = np.array([0.0, 0.003, 0.0065, 0.01, 0.008, 0.0055])
    stages = ["initial", "loading", "loading", "loading", "unloading", "unloading"]
    simulation = _curves(SIMULATION, stages, sim_eps, np.zeros(6), np.zeros(6))
    loading = np.linspace(0.0, 0.01, 41)
    unloading = np.linspace(0.01, 0.0065, 15)[1:]
    eps = np.concatenate([loading, unloading])
    model_stages = ["initial"] + ["loading"] * 40 + ["unloading"] * 14
    model = _curves("m", model_stages, eps, 2 * eps + 0.1, -0.5 * eps)
    table = on_simulation_grid(simulation, model)
    mod = table[table["side"] == "m"]
    sim = table[table["side"] == SIMULATION]
    np.testing.assert_array_equal(mod["eps_axial"], sim_eps[:5])
    np.testing.assert_allclose(mod["q_over_p"], 2 * sim_eps[:5] + 0.1, rtol=1e-12)
    np.testing.assert_allclose(mod["eps_vol"], -0.5 * sim_eps[:5], rtol=1e-12)
    assert list(mod["stage"]) == stages[:5]
    assert list(table.columns) == list(CURVE_COLUMNS)  # every column kept, phi_mob too
    assert len(sim) == len(mod)


def test_a_run_that_ends_its_stage_a_hair_beyond_the_target_keeps_its_next_stage():
    """The run's cell reaches a stage's strain target within its integration (1e-8 of it in
    a DEM oedometer), the model to round-off: the run's last loading row is on the common
    grid (the model's end value there) and the unloading that follows is compared too."""
    sim_eps = np.array([0.0, 0.005, 0.01 * (1.0 + 1e-8), 0.006, 0.002])
    stages = ["initial", "loading", "loading", "unloading", "unloading"]
    simulation = _curves(SIMULATION, stages, sim_eps, np.zeros(5), np.zeros(5))
    eps = np.concatenate([np.linspace(0.0, 0.01, 21), np.linspace(0.01, 0.002, 17)[1:]])
    model = _curves("m", ["initial"] + ["loading"] * 20 + ["unloading"] * 16, eps,
                    2 * eps + 0.1, -0.5 * eps)
    table = on_simulation_grid(simulation, model)
    mod = table[table["side"] == "m"]
    assert list(mod["stage"]) == stages
    np.testing.assert_allclose(mod["q_over_p"], 2 * sim_eps + 0.1, rtol=1e-7)


def _element_table(converged: list[bool], eps_xx_last: float) -> pd.DataFrame:
    n = len(converged)
    eps_yy = np.linspace(0.0, 0.001 * (n - 1), n)
    eps_xx = -0.5 * eps_yy
    eps_xx[-1] = eps_xx_last
    sigma_yy = 1e5 * (1.0 + 10.0 * eps_yy)
    return pd.DataFrame({
        "stage": ["initial"] + ["shear"] * (n - 1), "sigma_xx": 1e5, "sigma_yy": sigma_yy,
        "eps_xx": eps_xx, "eps_yy": eps_yy, "eps_vol": eps_xx + eps_yy,
        "eps_q": eps_yy - eps_xx, "p": 0.5 * (1e5 + sigma_yy), "q": sigma_yy - 1e5,
        "sin_phi": (sigma_yy - 1e5) / (sigma_yy + 1e5), "converged": converged})


@pytest.mark.parametrize(("status", "converged", "kept"), [
    ("failure", [True, True, True, False], 3),   # the failed step's row: not a state reached
    ("failure", [True, True, True, True], 4),    # a step that failed after converging: kept
    ("completed", [True, True, False, False], 4),  # unconverged but carried on: kept
])
def test_the_row_of_the_step_that_failed_is_not_a_state_of_the_model(status, converged, kept):
    table = _element_table(converged, eps_xx_last=-16.6)
    test = TestResult.create(table, specimen={"kind": "micro_element"},
                             load_path={"name": "biaxial"}, outcome={"status": status})
    curves = model_curves(test, "homogeneous")
    assert len(curves) == kept
    assert (curves["eps_vol"] > -1.0).all() == (kept == 3)


def test_the_dilatancy_rate_is_the_slope_over_the_last_part_of_the_strain():
    eps = np.linspace(0.0, 0.05, 51)
    eps_vol = np.where(eps < 0.01, 0.2 * eps, 0.002 - 0.4 * (eps - 0.01))
    curves = _curves(SIMULATION, "shear", eps, eps, eps_vol)
    assert _dilatancy(curves) == pytest.approx(0.4, rel=1e-10)
    # in extension eps_zz falls: the same dilation per unit |eps_zz| has the same rate
    stretched = _curves(SIMULATION, "shear", -eps, eps, eps_vol)
    assert _dilatancy(stretched) == pytest.approx(0.4, rel=1e-10)


def test_what_the_model_cannot_do_is_refused_by_name(tmp_path):
    with pytest.raises(InputError, match="KIND"):
        check_theory_kind("simple_shear")
    with pytest.raises(InputError, match="--distribution"):
        check_distributions(["voigt"])
    with pytest.raises(InputError, match="--model-steps"):
        TheoryComparison(["homogeneous"], 0)
    for arguments, named in ((["simple_shear"], "KIND"),
                             (["compaction"], "KIND"),
                             (["triaxial", "--distribution", "voigt"], "--distribution"),
                             (["triaxial", "--snapshot-every", "0"], "--snapshot-every")):
        out = tmp_path / "never"
        result = runner.invoke(app, ["theory-vs-sim", *arguments, "-n", "40", "--out",
                                     str(out)])
        assert result.exit_code == 2, result.output
        assert named in result.output, result.output
        assert not (out / "run").exists()
    # the springs' options are the model's even when the run's grains are rigid: --kappa is
    # accepted with contact dynamics (the refusal that follows is --snapshot-every's)
    result = runner.invoke(app, ["theory-vs-sim", "triaxial", "--kappa", "1e3",
                                 "--snapshot-every", "0", "--out", str(tmp_path / "never")])
    assert result.exit_code == 2 and "--snapshot-every" in result.output, result.output
    result = runner.invoke(app, ["theory-vs-sim", "triaxial", "--restitution", "0.3",
                                 "--out", str(tmp_path / "never")])
    assert result.exit_code == 2 and "--restitution" in result.output, result.output


DISC_TRIAXIAL = ["theory-vs-sim", "triaxial", "--shape", "disc", "--boundary", "periodic",
                 "-n", "60", "--size-ratio", "1.5", "--eps-q", "0.02", "--sigma0", "1e5",
                 "--mu", "0.4", "--inertia", "0.01", "--record-every", "2", "--seed", "2",
                 "--distribution", "homogeneous", "--model-steps", "40", "--no-progress"]
"""60 rigid discs in a planar periodic cell: a biaxial test and the 2D model of its packing."""


@pytest.mark.long
def test_a_run_of_discs_and_its_2d_model_start_from_the_same_stress(tmp_path):
    """The 2D side: the snapshot's network lies in the plane (areas, forces per unit
    thickness), the model's springs are the run's per unit thickness (k / t), and the model
    starts from the run's in-plane stress to round-off (a periodic cell: no wall)."""
    out = tmp_path / "discs"
    done = runner.invoke(app, [*DISC_TRIAXIAL, "--out", str(out)])
    assert done.exit_code == 0, done.output
    result = read_run_result(out / "run")
    network = compaction_snapshot(out / "run" / "snapshots.h5")
    assert network.dimension == 2
    end = result.table[result.table["stage"] == "compaction"].iloc[-1]
    run_stress = np.array([[end["sigma_xx"], end["sigma_xy"]],
                           [end["sigma_xy"], end["sigma_yy"]]])
    snapshot = 0.5 * (stress_from_network(network) + stress_from_network(network).T)
    # the cell's row adds the particles' kinetic stress (1/V) sum m v' (x) v', at most
    # 2 E_k / V, to the contacts' (the snapshot's)
    thickness = result.metadata["specimen"]["thickness"]
    kinetic = 2.0 * end["kinetic_energy"] / (network.volume * thickness)
    assert np.max(np.abs(snapshot - run_stress)) <= kinetic + 1e-12 * end["p"]
    law = run_contact_law(result, network)
    areas = np.asarray(network.volumes)
    d_mean = float(np.mean(np.sqrt(4.0 * areas / np.pi)))
    assert law.normal_stiffness == pytest.approx(1e4 * 1e5 * d_mean / thickness, rel=1e-12)
    model = run_micro_element_model(result, network, "homogeneous")
    np.testing.assert_allclose(model.stress_tensor(), stress_from_network(network), rtol=0,
                               atol=1e-9 * end["p"])  # the full tensor: the skew part too
    curves = pd.read_csv(out / "theory.csv")
    assert {"sigma_v", "K0", "q_over_p"} <= set(curves.columns)
    assert set(curves["side"]) == {SIMULATION, "homogeneous"}


CUBICAL = ["theory-b-sweep", "--path", "cubical", "--b", "0.5", "-n", "150", "--size-ratio",
           "1.5", "--eps-q", "0.02", "--sigma0", "1e5", "--mu", "0.4", "--inertia", "0.01",
           "--seed", "1", "--distribution", "homogeneous", "--model-steps", "60"]
"""150 rigid spheres in a periodic cell, the cubical test at sigma_3 = sigma0 and b = 0.5,
through ``grainlab theory-b-sweep`` (one case of the sweep)."""


@pytest.mark.long
def test_the_cubical_test_and_its_model_hold_sigma_3_and_b(tmp_path):
    """The cubical test at constant sigma_3 (Lade & Duncan's, the report's path): the run and
    the model of its packing start from the same stress, both hold sigma_yy = sigma0 and b
    while sigma_zz grows, and the mobilised angle is asin((s1 - s3)/(s1 + s3)) of each
    side's own stresses, as the sweep's table says."""
    out = tmp_path / "sweep"
    done = runner.invoke(app, [*CUBICAL, "--out", str(out)])
    assert done.exit_code == 0, done.output
    assert (out / "b_sweep.png").stat().st_size > 0
    sweep = pd.read_csv(out / "b_sweep.csv").set_index("side")
    assert sweep.loc[SIMULATION, "ended"] == "as asked"
    run = read_run_result(out / "cubical-b0.5").table
    comparison = TheoryComparison(["homogeneous"], 60).compute(out / "cubical-b0.5")
    model = comparison.models["homogeneous"].table
    # the model's steps whose stress targets the driver met (its 'converged' column); the
    # homogeneous model loses the lateral stress once its stiff contacts near z carry it
    held = model.iloc[1:][model["converged"].iloc[1:].astype(bool)]
    # how long it holds depends on the packing (4-5 of 13 increments on this one, with the
    # round-off of the processor): the driver must hold from the first increment on
    assert held["increment"].iloc[:3].tolist() == [1, 2, 3]
    # the run's cell within 10 % of sigma0 (150 grains at I = 1e-2); the model's driver
    # within its tolerance, relative to |sigma| (mostly sigma_zz)
    for table, tolerance, relative in ((run[run["stage"] == "shear"], 0.1, False),
                                       (held, 1e-3, True)):
        late = table.iloc[len(table) // 2:]
        scale = late["sigma_zz"] if relative else 1e5
        assert (np.abs(late["sigma_yy"] - 1e5) <= tolerance * scale).all()
        b = (late["sigma_xx"] - late["sigma_yy"]) / (late["sigma_zz"] - late["sigma_yy"])
        assert b.mean() == pytest.approx(0.5, abs=tolerance)
        assert (late["sigma_zz"] > late["sigma_xx"]).all()
    shear = run[run["stage"] == "shear"]
    expected = np.degrees(np.arcsin((shear["sigma_1"] - shear["sigma_3"])
                                    / (shear["sigma_1"] + shear["sigma_3"])))
    assert sweep.loc[SIMULATION, "peak_phi"] == pytest.approx(expected.max(), rel=1e-9)
    start = comparison.curves[comparison.curves["stage"] == "initial"]
    assert start["p"].iloc[1] == pytest.approx(start["p"].iloc[0], rel=1e-6)
    own = comparison.own_curves
    assert sweep.loc["homogeneous", "peak_phi"] == pytest.approx(
        own[own["side"] == "homogeneous"]["phi_mob"].max(), rel=1e-9)
