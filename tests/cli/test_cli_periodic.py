"""``grainlab test KIND --boundary periodic`` as a user runs it: a lab path on a discrete
sample in a periodic cell, the refusals of what a boundary cannot do, ParaView export."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.run_config import RunConfig
from grainlab.result.test_result import read_test_result

runner = CliRunner()
SMALL = ["-n", "150", "--size-ratio", "1.2", "--seed", "2", "--inertia", "0.01",
         "--no-progress", "--record-every", "10"]


SETTLED = {"test": {"quasi_static": {"stress_tolerance": 0.02, "unbalanced_force": 0.02,
                                     "kinetic_energy": float("inf")}}}
"""The compaction settled at 2 % on the stresses and the unbalanced force, the kinetic-energy
criterion off (YADE's end of a compaction): the shear is what is checked."""


@pytest.mark.long
def test_simple_shear_in_a_periodic_cell(tmp_path):
    out = tmp_path / "shear"
    RunConfig.model_validate(SETTLED).write(tmp_path / "settled.toml")
    result = runner.invoke(app, ["test", "simple_shear", "--boundary", "periodic", "--gamma",
                                 "0.03", "--out", str(out), "--config",
                                 str(tmp_path / "settled.toml"), *SMALL])
    assert result.exit_code == 0, result.output
    table = read_test_result(out / "results.csv").table
    assert list(dict.fromkeys(table["stage"])) == ["compaction", "shear"]
    shear = table[table["stage"] == "shear"]
    assert shear["gamma_xz"].abs().iloc[-1] >= 0.029
    assert shear["cell_sigma_zz"].iloc[-1] == pytest.approx(1e4, rel=0.05)
    assert (out / "curves.png").stat().st_size > 0
    assert (out / "simple_shear.png").stat().st_size > 0  # seed 001 Figs. 4.15-4.16
    exported = runner.invoke(app, ["vtk", str(out), "--out", str(tmp_path / "vtk")])
    assert exported.exit_code == 0, exported.output
    assert (tmp_path / "vtk" / "particles_000000.vtu").exists()


@pytest.mark.parametrize(("arguments", "words"), [
    (["test", "simple_shear"], "sample.boundary"),
    (["test", "circular", "--boundary", "walls"], "cannot shear"),
    (["test", "cubical", "--boundary", "walls", "--b", "0.5"], "cannot shear"),
    (["test", "oedometer", "--boundary", "periodic"], "deformable contacts"),
    (["oedometer", "--boundary", "periodic"], "deformable contacts"),
    (["test", "torsion"], "KIND"),
    (["test", "triaxial", "--boundary", "cylinder"], "boundary"),
])
def test_what_a_boundary_cannot_run_is_refused_before_anything_is_written(
        tmp_path, arguments, words):
    out = tmp_path / "refused"
    result = runner.invoke(app, [*arguments, "--out", str(out), "-n", "30", "--no-progress"])
    assert result.exit_code == 2, result.output
    assert words in " ".join(result.output.split())
    assert not (out / "checkpoint.h5").exists()
