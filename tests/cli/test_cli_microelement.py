"""``grainlab microelement`` as a user runs it: every command writes its files with small
settings; bad input is explained in one message and exit status 2."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from grainlab.analysis.snapshot_files import write_snapshots
from grainlab.analysis.synthetic import synthetic_network
from grainlab.cli.microelement import app, parse_list, parse_sets
from grainlab.errors import InputError
from grainlab.lab.presets import preset_names
from grainlab.prep.packing_files import write_packing
from grainlab.prep.regular_packings import named_packing
from grainlab.result.test_result import read_test_result

runner = CliRunner()


def invoke(*args: str):
    return runner.invoke(app, [str(a) for a in args])


def ok(*args: str):
    result = invoke(*args)
    assert result.exit_code == 0, result.output
    return result


def refused(field: str, *args: str):
    """The command exits with status 2, names ``field`` and prints no traceback."""
    result = invoke(*args)
    assert result.exit_code == 2, result.output
    assert field in result.output, result.output
    assert "Traceback" not in result.output
    return result


def test_every_command_has_help():
    for command in ([], ["presets"], ["run"], ["sweep-b"], ["circular"], ["cyclic"]):
        result = invoke(*command, "--help")
        assert result.exit_code == 0, command
        assert "Usage" in result.output


def test_presets_lists_every_preset():
    output = ok("presets").output
    for name in preset_names():
        assert name in output


def test_run_triaxial_writes_result_derived_and_figure(tmp_path):
    result = ok("run", "--path", "triaxial_compression", "--set", "n_steps=12", "--out",
                tmp_path)
    assert "peak mobilised friction angle" in result.output
    test = read_test_result(tmp_path / "result.csv")
    assert len(test.table) == 13
    assert test.metadata["setup"]["model"]["normal_stiffness_N_per_m"] == 1e5
    # drained: the lateral stresses stay at sigma0 = 100 kPa on converged rows
    converged = test.table[test.table["converged"]]
    # driver tolerance: 1e-4 of the norm of the whole stress (sigma_zz grows to ~3 sigma_xx)
    np.testing.assert_allclose(converged["sigma_xx"], 1e5, rtol=2e-3)
    derived = read_test_result(tmp_path / "derived.h5").table
    assert {"phi_mobilised", "eta", "oct_x", "lode_angle"} <= set(derived.columns)
    assert (tmp_path / "result.h5").stat().st_size > 0
    assert (tmp_path / "triaxial.png").stat().st_size > 0


def test_run_oedometer_reports_k0_rising_on_unloading(tmp_path):
    result = ok("run", "--path", "oedometer", "--steps", "16", "--out", tmp_path)
    assert "K0 at the end of loading" in result.output
    assert "K0 at the end of unloading" in result.output
    derived = read_test_result(tmp_path / "derived.csv").table
    loading = derived[derived["stage"] == "loading"]
    unloading = derived[derived["stage"] == "unloading"]
    assert loading["K0"].iloc[-1] < 1.0  # the lateral stress lags the vertical one
    assert unloading["K0"].iloc[-1] > loading["K0"].iloc[-1]  # locked-in lateral stress
    assert unloading["OCR"].iloc[-1] > 1.0
    assert (tmp_path / "k0.png").stat().st_size > 0


def test_run_simple_shear_writes_angles(tmp_path):
    result = ok("run", "--path", "simple_shear", "--steps", "10", "--set",
                "k0_consolidation_steps=3", "--out", tmp_path)
    assert "kappa" in result.output
    derived = read_test_result(tmp_path / "derived.csv").table
    assert {"psi", "beta", "omega", "chi", "xi", "tau_over_sigma_v"} <= set(derived.columns)
    assert (tmp_path / "simple_shear.png").stat().st_size > 0


def test_run_biaxial_on_a_packing_file(tmp_path):
    packing = write_packing(named_packing("C"), tmp_path / "c.toml")
    ok("run", "--structure", packing, "--path", "biaxial", "--steps", "10", "--out",
       tmp_path / "out")
    test = read_test_result(tmp_path / "out" / "result.csv")
    assert "sigma_zz" not in test.table.columns and test.metadata["dimension"] == 2
    assert test.metadata["setup"]["model"]["thickness_m"] > 0
    assert (tmp_path / "out" / "biaxial.png").stat().st_size > 0


def test_run_isotropic_compression_on_a_snapshot_file(tmp_path):
    snapshots = write_snapshots(tmp_path / "snapshots.h5",
                                [synthetic_network(60, dimension=3, seed=1)])
    ok("run", "--structure", snapshots, "--consolidate", "--path", "isotropic_compression",
       "--steps", "8", "--out", tmp_path / "out")
    table = read_test_result(tmp_path / "out" / "result.h5").table
    # p_final = 2 sigma0, to the driver's default stress tolerance (1e-4 of |sigma|): this
    # network has micro-elements of 2-3 contacts whose non-affine move cancels the approach,
    # so round-off decides whether they touch, and the last correction lands anywhere within it
    assert table["p"].iloc[-1] == pytest.approx(2e5, rel=1e-4)


def test_run_starts_from_the_forces_of_a_snapshot(tmp_path):
    """A regular packing's isotropic state as a snapshot: the path starts at its stress (no
    consolidation) and its defaults scale with it (p_final = 2 p)."""
    from grainlab.contact import LinearSpring2D
    from grainlab.micromech.regular_packing import (
        RegularPackingModel,
        consolidate_isotropically,
    )

    theory = RegularPackingModel(named_packing("hexagonal"), LinearSpring2D(3e8, 1.1e8))
    network = theory.contact_network(consolidate_isotropically(theory, 17.24e3, steps=2))
    snapshots = write_snapshots(tmp_path / "snapshots.h5", [network])
    ok("run", "--structure", snapshots, "--path", "isotropic_compression", "--steps", "8",
       "--kn", "3e8", "--ks", "1.1e8", "--thickness", "1", "--out", tmp_path / "out")
    table = read_test_result(tmp_path / "out" / "result.h5").table
    assert table["p"].iloc[0] == pytest.approx(17.24e3, rel=1e-12)
    assert table["p"].iloc[-1] == pytest.approx(2 * 17.24e3, rel=1e-4)
    setup = read_test_result(tmp_path / "out" / "result.h5").metadata["setup"]["model"]
    assert setup["sigma0_Pa"] is None and "snapshot" in setup["initial_state"]
    refused("--sigma0", "run", "--structure", snapshots, "--sigma0", "1e5", "--out",
            tmp_path / "x")
    # the hexagonal cell's one disc touches only its own images: nothing left when dropped
    refused("periodic", "run", "--structure", snapshots, "--periodic-contacts", "drop",
            "--out", tmp_path / "y")
    refused("--wall-contacts", "run", "--wall-contacts", "balance", "--out", tmp_path / "z")


def test_run_cyclic_path_on_binary_units(tmp_path):
    result = ok("run", "--structure", "binary", "--path", "cyclic_shear", "--set",
                "n_cycles=1", "--set", "steps_per_quarter=2", "--out", tmp_path)
    assert "G_s" in result.output
    assert (tmp_path / "hysteresis.png").stat().st_size > 0


def test_sweep_b_summary_has_one_row_per_b(tmp_path):
    ok("sweep-b", "--path", "constant-p", "--b", "0,0.5,1", "--steps", "12", "--out",
       tmp_path)
    summary = read_test_result(tmp_path / "summary.csv").table
    assert summary["b"].tolist() == [0.0, 0.5, 1.0]
    # b is stress-controlled: the failure point has the b asked for
    np.testing.assert_allclose(summary["b_at_failure"], summary["b"], atol=2e-3)
    phi = summary["phi_peak"].to_numpy()
    assert np.all(phi[1:] >= phi[0] - 1e-9)  # compression (b = 0) is the weakest
    # b = 0 is a triaxial compression: sigma_2 = sigma_3 where the driver converged
    table = read_test_result(tmp_path / "b0.csv").table
    converged = table[table["converged"] & (table["step"] > 0)]
    assert len(converged) >= 1
    # within the driver's stress tolerance (1e-4 of |sigma|, run_element_test), not tighter
    size = np.sqrt(converged["sigma_1"] ** 2 + converged["sigma_2"] ** 2
                   + converged["sigma_3"] ** 2).to_numpy()
    assert np.all(np.abs(converged["sigma_2"] - converged["sigma_3"]).to_numpy()
                  <= 2e-4 * size)
    np.testing.assert_allclose(converged["p"], 1e5, rtol=2e-4)  # constant mean stress
    for name in ("b0.5.h5", "b1.csv", "summary.h5", "b_sweep.png", "stress_strain.png"):
        assert (tmp_path / name).stat().st_size > 0


@pytest.mark.parametrize("choice", ["maxwellian-first-order", "homogeneous"])
def test_sweep_b_at_constant_sigma3_holds_sigma3_and_b(tmp_path, choice):
    """The default sweep holds sigma_3 = sigma0 (Lade & Duncan's cubical tests, the report's
    comparison): on every converged row of every test sigma_yy = sigma_3 = 100 kPa and
    sigma_xx - sigma_3 = b (sigma_zz - sigma_3); the law named on the command line is the
    model's."""
    result = ok("sweep-b", "--b", "0,0.6,1", "--steps", "12", "--distribution", choice,
                "--out", tmp_path)
    assert "constant-sigma3" in result.output
    summary = read_test_result(tmp_path / "summary.csv")
    assert summary.load_path["preset"] == "cubical_constant_sigma3"
    assert summary.table["b"].tolist() == [0.0, 0.6, 1.0]
    for b in (0.0, 0.6, 1.0):
        test = read_test_result(tmp_path / f"b{b:g}.csv")
        assert test.metadata["setup"]["model"]["distribution"] == choice
        rows = test.table[test.table["converged"] & (test.table["step"] > 0)]
        assert len(rows) >= 3
        size = np.sqrt(rows["sigma_1"] ** 2 + rows["sigma_2"] ** 2
                       + rows["sigma_3"] ** 2).to_numpy()
        assert np.all(np.abs(rows["sigma_yy"] - 1e5).to_numpy() <= 2e-4 * size)
        assert np.all(np.abs(rows["sigma_xx"] - rows["sigma_yy"] - b * (
            rows["sigma_zz"] - rows["sigma_yy"])).to_numpy() <= 2e-4 * size)
        assert rows["p"].iloc[-1] > 1e5  # sigma_3 held: the mean stress grows
    assert (tmp_path / "b_sweep.png").stat().st_size > 0


def test_circular_keeps_the_radius(tmp_path):
    ok("circular", "--alphas", "0,60", "--radius", "0.4", "--steps", "12", "--set",
       "approach_steps=3", "--out", tmp_path)
    summary = read_test_result(tmp_path / "summary.csv").table
    assert summary["alpha0_deg"].tolist() == [0.0, 60.0]
    table = read_test_result(tmp_path / "alpha60_r0.4.csv").table
    circle = table[(table["stage"] == "circle") & table["converged"]]
    assert len(circle) > 0
    q = np.sqrt(0.5 * ((circle["sigma_xx"] - circle["sigma_yy"]) ** 2
                       + (circle["sigma_yy"] - circle["sigma_zz"]) ** 2
                       + (circle["sigma_zz"] - circle["sigma_xx"]) ** 2))
    np.testing.assert_allclose(q, 0.4e5, rtol=1e-4)
    assert (tmp_path / "circular_path.png").stat().st_size > 0


def test_cyclic_modulus_degrades_with_amplitude(tmp_path):
    result = ok("cyclic", "--amplitudes", "1e-5,1e-3", "--cycles", "1",
                "--steps-per-quarter", "3", "--out", tmp_path)
    assert "G_max" in result.output
    summary = read_test_result(tmp_path / "summary.csv").table
    assert len(summary) == 2
    ratio = summary["modulus_ratio"].to_numpy()
    assert ratio[1] < ratio[0] <= 1.0 + 1e-6
    assert np.all(summary["damping_ratio"] >= 0.0)
    assert (tmp_path / "cyclic.png").stat().st_size > 0
    assert (tmp_path / "gamma0.001.h5").stat().st_size > 0


def test_bad_inputs_are_named(tmp_path):
    refused("--path", "run", "--path", "triaxial", "--out", tmp_path)
    refused("n_steps", "run", "--set", "n_steps=abc", "--out", tmp_path)
    refused("--set", "run", "--set", "n_steps", "--out", tmp_path)
    refused("wrong_key", "run", "--set", "wrong_key=1", "--out", tmp_path)
    refused("--structure", "run", "--structure", tmp_path / "missing.toml", "--out", tmp_path)
    refused("--structure", "run", "--structure", "gravel", "--out", tmp_path)
    refused("--spin", "run", "--structure", "binary", "--spin", "none", "--out", tmp_path)
    refused("--distribution", "run", "--structure", "binary", "--distribution", "maxwellian",
            "--out", tmp_path)
    refused("--kn", "run", "--law", "hertz", "--kn", "1e5", "--out", tmp_path)
    refused("--friction-angle", "run", "--friction-angle", "95", "--out", tmp_path)
    refused("--b", "sweep-b", "--b", "0,2", "--out", tmp_path)
    refused("--set b", "sweep-b", "--set", "b=0.3", "--out", tmp_path)
    bad_path = refused("--path", "sweep-b", "--path", "constant-q", "--out", tmp_path)
    assert "constant-sigma3" in bad_path.output and "constant-p" in bad_path.output
    refused("--distribution", "run", "--distribution", "first-order", "--out", tmp_path)
    refused("--amplitudes", "cyclic", "--amplitudes", "small", "--out", tmp_path)
    refused("--cycles", "cyclic", "--cycles", "0", "--out", tmp_path)
    refused("--steps", "run", "--steps", "3", "--out", tmp_path)
    packing = write_packing(named_packing("C"), tmp_path / "c.toml")
    refused("--path", "run", "--structure", packing, "--path", "true_triaxial", "--out",
            tmp_path)
    refused("--structure", "sweep-b", "--structure", packing, "--out", tmp_path)
    assert not (tmp_path / "result.csv").exists()


def test_parsers():
    assert parse_sets(["n_steps=5", "drained=false", "constant=height", "x=none"]) == {
        "n_steps": 5, "drained": False, "constant": "height", "x": None}
    assert parse_list("--b", "0,0.25, 1") == [0.0, 0.25, 1.0]
    with pytest.raises(InputError, match="--b"):
        parse_list("--b", "0:1:0")


def test_run_maxwellian_references_reach_the_model(tmp_path):
    """--distribution maxwellian uses eq. 2.32 as printed (overall C), maxwellian-average the
    average stiffness; the metadata says which, and the two laws give different responses."""
    peaks = {}
    for choice, reference in (("maxwellian", "overall"), ("maxwellian-average", "average")):
        out = tmp_path / choice
        ok("run", "--path", "triaxial_compression", "--distribution", choice, "--set",
           "n_steps=8", "--out", out)
        test = read_test_result(out / "result.csv")
        model = test.metadata["setup"]["model"]
        assert model["distribution"] == "maxwellian"
        assert model["maxwellian_reference"] == reference
        peaks[choice] = float(test.table["sigma_zz"].iloc[-1])
    assert peaks["maxwellian"] != pytest.approx(peaks["maxwellian-average"], rel=1e-6)
