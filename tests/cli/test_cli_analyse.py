"""``grainlab analyse`` as a user runs it."""

from __future__ import annotations

import pandas as pd
from typer.testing import CliRunner

from grainlab.analysis.snapshot_files import write_snapshots
from grainlab.analysis.synthetic import synthetic_network
from grainlab.cli.main import app
from grainlab.result.test_result import read_test_result

runner = CliRunner()


def test_analyse_a_run_folder(tmp_path):
    run = tmp_path / "run"
    nets = []
    for k, strain in enumerate((0.0, 0.3, 0.6, 0.8)):
        net = synthetic_network(3000, a_c=0.2 * strain, seed=k)
        net.state["eps_q"] = strain
        nets.append(net)
    run.mkdir()
    write_snapshots(run / "snapshots.h5", nets)
    out = tmp_path / "out"
    result = runner.invoke(app, ["analyse", str(run), "--out", str(out), "--window", "0.5:0.9",
                                 "--color-by", "sliding"])
    assert result.exit_code == 0, result.output
    table = read_test_result(out / "analysis.csv").table
    assert len(table) == 4
    residual = pd.read_csv(out / "residual_state.csv")
    assert residual["n_snapshots"].iloc[0] == 2
    for name in ("polar_distributions.png", "force_pdfs.png", "force_network.png",
                 "anisotropies.png"):
        assert (out / name).stat().st_size > 0


def test_analyse_synthetic(tmp_path):
    result = runner.invoke(app, ["analyse", "--synthetic", "2000", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "a_c" in result.output


def test_analyse_bad_input(tmp_path):
    result = runner.invoke(app, ["analyse", str(tmp_path / "missing")])
    assert result.exit_code == 2 and "RUN|SNAPSHOT" in result.output
    result = runner.invoke(app, ["analyse", "--synthetic", "500", "--out", str(tmp_path),
                                 "--window", "0.9"])
    assert result.exit_code == 2 and "--window" in result.output
