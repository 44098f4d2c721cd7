"""``grainlab report`` and the report written at the end of ``grainlab triaxial``."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from grainlab.cli import discrete
from grainlab.cli.main import app

runner = CliRunner()


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    """A 30-sphere triaxial test to eps_q = 0.04 with a snapshot at every step: at the lab's
    inertia number a shear step is a few thousandths of strain, so every window 0.01 wide
    in the shear holds snapshots, whatever path the jammed packing takes."""
    out = tmp_path_factory.mktemp("cli") / "triaxial"
    result = runner.invoke(app, [
        "triaxial", "--out", str(out), "-n", "30", "--seed", "3", "--eps-q", "0.04",
        "--inertia", "0.01", "--sweep", "serial", "--no-progress", "--record-every", "1",
        "--snapshot-every", "1"])
    assert result.exit_code == 0, result.output
    return out, " ".join(result.output.split())


def test_every_shear_step_is_a_small_strain(run_folder):
    """What makes the window below hold snapshots on every processor."""
    from grainlab.result.test_result import read_test_result

    table = read_test_result(run_folder[0] / "results.csv").table
    shear = table[table["stage"] != "compaction"]["eps_q"].to_numpy()
    assert shear.max() >= 0.04 and np.max(np.diff(shear)) < 0.005


def test_a_finished_run_gets_its_report(run_folder):
    out, said = run_folder
    assert (out / "report" / "report.md").is_file()
    assert "report:" in said
    text = (out / "report" / "report.md").read_text(encoding="utf-8")
    assert "## Microstructure over the window" in text and "a_c" in text


def test_report_command_writes_where_asked(run_folder, tmp_path):
    out, _ = run_folder
    result = runner.invoke(app, ["report", str(out), "--window", "0.01", "0.02", "--out",
                                 str(tmp_path / "r")])
    assert result.exit_code == 0, result.output
    text = (tmp_path / "r" / "report.md").read_text(encoding="utf-8")
    assert "eps_q in [0.01, 0.02]" in text
    assert (tmp_path / "r" / "force_pdfs.png").stat().st_size > 0


@pytest.mark.parametrize(("window", "expected"), [
    (["0.02", "0.01"], "low < high"),
    (["0.5", "0.9"], "meets the run's shear"),
])
def test_a_bad_window_is_one_message_naming_the_option(run_folder, tmp_path, window, expected):
    out, _ = run_folder
    result = runner.invoke(app, ["report", str(out), "--window", *window, "--out",
                                 str(tmp_path / "r")])
    assert result.exit_code == 2
    said = " ".join(result.output.split())
    assert "--window" in said and expected in said
    assert "Traceback" not in said


def test_a_report_that_fails_only_warns(tmp_path, monkeypatch, capsys):
    def broken(folder):
        raise RuntimeError("no figures today")

    monkeypatch.setattr("grainlab.report.run_report.write_run_report", broken)
    discrete._report(tmp_path)  # returns: the run is not failed by its report
    said = " ".join(capsys.readouterr().out.split())
    assert "warning:" in said and "no figures today" in said and "grainlab report" in said
