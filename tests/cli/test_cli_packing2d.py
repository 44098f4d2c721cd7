"""The ``grainlab`` command line as a user runs it: outputs written, bad input explained."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.prep.packing_files import write_packing
from grainlab.prep.regular_packings import named_packing
from grainlab.result.test_result import read_test_result

runner = CliRunner()


def invoke(*args: str):
    return runner.invoke(app, list(args), catch_exceptions=False)


def test_every_command_has_help():
    for command in ([], ["packing2d"], ["packing2d", "table"], ["packing2d", "show"],
                    ["packing2d", "load"], ["packing2d", "sweep"], ["demo"]):
        result = invoke(*command, "--help")
        assert result.exit_code == 0, command
        assert "Usage" in result.output


def test_table_prints_table1_and_writes_csv(tmp_path):
    result = invoke("packing2d", "table", "--csv", str(tmp_path / "t.csv"))
    assert result.exit_code == 0
    rows = {line.split(",")[0]: line.split(",") for line in
            (tmp_path / "t.csv").read_text().splitlines()[1:]}
    for name, (e_paper, cn_paper) in {"A": (0.1880, 5.0), "B": (0.4702, 4.0),
                                      "C": (0.1388, 5.0)}.items():
        assert float(rows[name][1]) == pytest.approx(e_paper, abs=1e-4)
        assert float(rows[name][3]) == pytest.approx(cn_paper, abs=0.01)


def test_load_writes_result_and_figures(tmp_path):
    out = tmp_path / "run"
    result = invoke("packing2d", "load", "--packing", "C", "--alpha", "45",
                    "--max-ratio", "1.5", "--ratio-step", "0.1", "--out", str(out))
    assert result.exit_code == 0, result.output
    for name in ("result.csv", "result.h5", "fig7_stress_ratio_strains.png",
                 "fig10_contact_forces.png"):
        assert (out / name).stat().st_size > 0
    loaded = read_test_result(out / "result.h5")
    assert loaded.load_path["alpha_deg"] == 45.0
    assert loaded.table["stress_ratio"].iloc[-1] == pytest.approx(1.5)


def test_load_reads_a_packing_file(tmp_path):
    path = write_packing(named_packing("hexagonal"), tmp_path / "hex.toml")
    result = invoke("packing2d", "load", "--packing", str(path), "--law", "linear", "--kn",
                    "1e8", "--ks", "5e7", "--max-ratio", "1.2", "--out", str(tmp_path / "o"))
    assert result.exit_code == 0, result.output
    table = read_test_result(tmp_path / "o" / "result.csv").table
    # Linear springs on the hexagonal packing: isotropic in the plane, so while no contact
    # slides the strain increments are coaxial with the stress.
    elastic = table[(table["n_sliding"] == 0) & (table["stage"] == "shear")]
    assert len(elastic) > 0
    assert np.allclose(elastic["noncoaxiality_deg"], 0.0, atol=1e-6)


def test_sweep_writes_summary_and_figures(tmp_path):
    out = tmp_path / "sweep"
    result = invoke("packing2d", "sweep", "--packing", "A", "--alphas", "-30,0,30",
                    "--max-ratio", "1.6", "--ratio-step", "0.1", "--out", str(out))
    assert result.exit_code == 0, result.output
    summary = read_test_result(out / "summary.csv").table
    assert summary["alpha_deg"].tolist() == pytest.approx([-30.0, 0.0, 30.0])
    # Packing A is mirror-symmetric about the Y axis: gamma_xy flips with alpha.
    assert summary["gamma_xy"].iloc[0] == pytest.approx(-summary["gamma_xy"].iloc[2], rel=1e-6)
    for name in ("fig7_stress_ratio_strains.png", "fig8_strain_ratios.png",
                 "fig9_noncoaxiality.png"):
        assert (out / name).exists()


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["packing2d", "load", "--packing", "Z"], "packing"),
        (["packing2d", "load", "--alpha", "120"], "alpha"),
        (["packing2d", "load", "--law", "linear"], "--kn"),
        (["packing2d", "load", "--friction-angle", "-5"], "--friction-angle"),
        (["packing2d", "load", "--sigma0", "0"], "--sigma0"),
        (["packing2d", "sweep", "--alphas", "0:abc"], "--alphas"),
        (["packing2d", "show", "missing.toml"], "packing file"),
    ],
)
def test_bad_input_is_named_without_traceback(args, named, tmp_path):
    result = runner.invoke(app, [*args], catch_exceptions=True)
    assert result.exit_code == 2
    assert named in result.output
    assert "Traceback" not in result.output


def test_overlapping_packing_file_names_the_discs(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(
        'lattice = [[0.02, 0.0], [0.0, 0.02]]\n'
        '[[particles]]\nx = 0.0\ny = 0.0\nradius = 0.005\nlabel = "first"\n'
        '[[particles]]\nx = 0.008\ny = 0.0\nradius = 0.005\nlabel = "second"\n'
    )
    result = runner.invoke(app, ["packing2d", "show", str(path)])
    assert result.exit_code == 2
    assert "first" in result.output and "second" in result.output
