"""``grainlab demo`` at a small size: the theory part, then a discrete triaxial test with its
curves, microstructure figures and ParaView files, every file listed."""

from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.result.test_result import read_test_result


def test_demo_runs_theory_then_a_discrete_triaxial_test_and_lists_its_files(tmp_path):
    out = tmp_path / "demo"
    result = CliRunner().invoke(app, ["demo", "--out", str(out), "--particles", "30",
                                      "--eps-q", "0.02"])
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    # the theory's end is the specimen's strength, not a fault of the program
    assert "specimen failure (strength reached at sigma_1/sigma_3 = 7.157)" in text
    assert "no equilibrium" in text and "failure —" not in text
    assert "compiles the contact-dynamics kernels" in text
    for name in ("table1.csv", "fig7_stress_ratio_strains.png", "triaxial/curves.png",
                 "triaxial/results.csv", "triaxial/snapshots.h5",
                 "triaxial/analysis/anisotropies.png", "triaxial/analysis/force_network.png"):
        assert (out / name).exists(), name
        assert name in text, name
    vtk = {p.name.split("_")[0].split(".")[0]
           for p in (out / "triaxial" / "vtk-checkpoint").iterdir()}
    assert vtk == {"contacts", "particles", "walls"}
    table = read_test_result(out / "triaxial" / "results.csv").table
    assert table["eps_q"].iloc[-1] >= 0.02 and set(table["stage"]) == {"compaction", "shear"}


def test_demo_theory_only(tmp_path):
    result = CliRunner().invoke(app, ["demo", "--out", str(tmp_path), "--particles", "0"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "result.h5").exists() and not (tmp_path / "triaxial").exists()


def test_demo_names_a_bad_size():
    result = CliRunner().invoke(app, ["demo", "--particles", "5"])
    assert result.exit_code == 2
    assert "--particles" in result.output and "at least 20" in result.output
