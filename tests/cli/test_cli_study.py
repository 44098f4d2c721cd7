"""``grainlab study`` as a user runs it: bad input (a study run from its folder by the command
line, with its report: tests/study/test_study_runner.py; the preset commands: the README's)."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app

runner = CliRunner()

TINY = """
[study]
name = "tiny"
parameter = "eta"
window = [0.1, 0.2]

[base.sample]
n_particles = 30
size_ratio = 3.0
[base.test]
eps_q_max = 0.2
[base.output]
snapshot_every = 25

[[samples]]
name = "sphere"
value = 0.0

[[samples]]
name = "eta-0.4"
value = 0.4
set = { sample = { shape = "aggregate", eta = 0.4 } }
"""


@pytest.mark.parametrize(("args", "words"), [
    (["study", "angularity", "--length", "long"], "--length"),
    (["study", "report", "nowhere"], "FOLDER"),
])
def test_bad_input_is_one_line(tmp_path, args, words):
    result = runner.invoke(app, [*args[:2], *(["--out", str(tmp_path / "o")]
                                              if args[1] == "angularity" else []), *args[2:]])
    assert result.exit_code == 2
    assert words in result.output


def test_a_bad_key_in_a_study_file_is_named(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(TINY.replace("eta = 0.4 }", "eta = 4.0 }"))
    result = runner.invoke(app, ["study", "run", str(path), "--no-progress"])
    assert result.exit_code == 2
    assert "samples[1].set.sample.eta" in result.output
    assert not (tmp_path / "bad").exists()
