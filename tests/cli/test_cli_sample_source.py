"""How the sample is made, from the command line: ``--particle-file`` (implies
``--preparation file``), ``--preparation``, and bad values named by their option."""

from __future__ import annotations

import tomllib

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.discrete_run import resume_run
from grainlab.prep.inscribed_sample import deposited_sample
from grainlab.prep.particle_files import write_particles

runner = CliRunner()


def test_a_compaction_runs_on_the_particles_of_a_file(tmp_path):
    made = deposited_sample(shape="aggregate", n_particles=24, seed=5, eta=0.4)
    path = write_particles(made, tmp_path / "grains.csv")
    out = tmp_path / "run"
    result = runner.invoke(app, ["compaction", "--particle-file", str(path), "--out", str(out),
                                 "--no-progress", "--sweep", "serial"])
    assert result.exit_code == 0, result.output
    assert "24 aggregates" in " ".join(result.output.split())
    sample = tomllib.loads((out / "config.toml").read_text())["sample"]
    assert (sample["preparation"], sample["particle_file"]) == ("file", str(path))
    run = resume_run(out)  # the sample is the file's, at the compacted state
    assert run.test.sample.state.n_bodies == 24
    assert run.test.sample.description["preparation"] == "file"


@pytest.mark.parametrize("args, option", [
    (["--preparation", "poured"], "--preparation"),
    (["--particle-file", "no/such.csv"], "--particle-file"),
    (["--skeleton-file", "no/such.csv"], "--skeleton-file"),
])
def test_bad_sample_sources_name_their_option(args, option, tmp_path):
    result = runner.invoke(app, ["compaction", "--out", str(tmp_path / "run"), *args])
    assert result.exit_code != 0
    assert option in result.output and "Traceback" not in result.output
    assert not (tmp_path / "run").exists()
