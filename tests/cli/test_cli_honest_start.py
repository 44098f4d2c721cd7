"""A start refused leaves nothing behind and names the setting in the user's words; a run
that would not end is refused with its estimate; the periodic oedometer runs on soft-contact
DEM, as the README says."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig
from grainlab.result.test_result import read_test_result

runner = CliRunner()


def _words(result) -> str:
    return " ".join(result.output.split())


def test_a_cell_too_thin_for_its_particles_is_refused_before_the_folder_exists(tmp_path):
    out = tmp_path / "X"
    result = runner.invoke(app, ["test", "simple_shear", "--boundary", "periodic", "-n", "30",
                                 "--gamma", "0.05", "--out", str(out), "--no-progress"])
    assert result.exit_code == 2, result.output
    words = _words(result)
    assert "-n/--n-particles = 30" in words and "at least about" in words, words
    assert "Traceback" not in result.output
    assert not out.exists()
    # the retry with more particles is not blocked by what the refusal left
    config = RunConfig.model_validate({"sample": {"n_particles": 200, "boundary": "periodic"},
                                       "test": {"kind": "simple_shear", "gamma_max": 0.05}})
    run = start_run(out, config)
    assert run.test.sample.state.n_bodies == 200 and (out / "config.toml").exists()


def test_a_soft_run_estimated_at_too_many_sub_steps_is_refused_with_its_estimate(tmp_path):
    out = tmp_path / "stiff"
    result = runner.invoke(app, ["triaxial", "--solver", "dem", "--kappa", "1e12", "-n", "30",
                                 "--eps-q", "0.01", "--out", str(out), "--no-progress"])
    assert result.exit_code == 2, result.output
    words = _words(result)
    assert "--kappa = 1000000000000" in words and "sub-steps" in words, words
    assert not out.exists()


def test_a_contact_dynamics_step_too_short_to_end_is_refused(tmp_path):
    out = tmp_path / "short"
    result = runner.invoke(app, ["triaxial", "--dt", "1e-9", "-n", "30", "--eps-q", "0.01",
                                 "--out", str(out), "--no-progress"])
    assert result.exit_code == 2, result.output
    assert "--dt = 1e-09" in _words(result) and "steps" in _words(result)
    assert not out.exists()


def test_the_periodic_oedometer_runs_on_soft_contacts(tmp_path):
    out = tmp_path / "oedo"
    result = runner.invoke(app, [
        "test", "oedometer", "--boundary", "periodic", "--solver", "dem", "--kappa", "1e3",
        "-n", "80", "--size-ratio", "1.2", "--seed", "2", "--axial-strain", "0.01",
        "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, result.output
    table = read_test_result(out / "results.csv").table
    loading = table[table["stage"] == "loading"]
    end = loading.iloc[-1]
    # one-dimensional: no lateral strain, the axial strain asked
    assert (loading["eps_xx"] == 0.0).all() and (loading["eps_yy"] == 0.0).all()
    assert end["eps_zz"] == pytest.approx(0.01, rel=1e-6)  # the stage ends on its strain
    # the springs take the strain: sigma_zz grows from sigma0, the lateral stresses less
    assert end["sigma_zz"] > 2.0 * 1e4
    assert 0.0 < end["K0"] < 1.0
    assert end["K0"] == pytest.approx((end["sigma_xx"] + end["sigma_yy"]) / (2.0 * end["sigma_zz"]),
                                      rel=1e-12)
