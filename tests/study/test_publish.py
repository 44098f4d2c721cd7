"""Publishing a study: its definition, summary, report and provenance, never its runs'
checkpoints, snapshots or results; a size check with each of its studies."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.errors import InputError
from grainlab.study.publish import publish
from grainlab.study.study_runner import Study
from grainlab.study.study_spec import StudySpec


def ended_study(folder):
    """A study folder as a finished study leaves it: runs with their heavy files, a summary
    and a report."""
    spec = StudySpec.model_validate({
        "study": {"name": "two", "parameter": "eta", "window": [0.05, 0.1]},
        "base": {"sample": {"n_particles": 30}},
        "samples": [{"name": n, "value": 0.1 * k, "set": {"sample": {"seed": k}}}
                    for k, n in enumerate(("a", "b"))]})
    study = Study.create(folder, spec)
    for name in spec.names:
        run = study.sample_folder(name)
        run.mkdir(parents=True)
        for heavy in ("checkpoint.h5", "snapshots.h5", "results.h5", "results.csv"):
            (run / heavy).write_bytes(b"\0" * 1000)
    pd.DataFrame({"name": ["a", "b"], "seed": [0, 1], "status": ["ended", "ended"],
                  "wall_time": [120.0, 340.0], "steps": [1000, 2000],
                  "capped_share": [0.001, 0.015]}).to_csv(folder / "summary.csv", index=False)
    report = folder / "report"
    report.mkdir()
    for name in ("report.md", "report.html", "strength.png", "against_the_paper.csv"):
        (report / name).write_text(name)
    (report / "scratch.tmp").write_text("not a report file")
    return study


def test_a_study_publishes_its_results_and_provenance_not_its_runs(tmp_path):
    ended_study(tmp_path / "study")
    dest = publish(tmp_path / "study", tmp_path / "docs" / "study")
    files = {p.relative_to(dest).as_posix() for p in dest.rglob("*") if p.is_file()}
    assert files == {"study.toml", "summary.csv", "PROVENANCE.md", "report/report.md",
                     "report/report.html", "report/strength.png",
                     "report/against_the_paper.csv"}
    assert StudySpec.read(dest / "study.toml").names == ["a", "b"]
    provenance = (dest / "PROVENANCE.md").read_text()
    assert "| a | 0 | ended | 120 | 1000 | 0.10% |" in provenance
    assert "| b | 1 | ended | 340 | 2000 | 1.50% |" in provenance
    assert "460 s in all" in provenance and "source commit" in provenance
    # published again: the same files, replaced
    publish(tmp_path / "study", dest)
    assert {p.relative_to(dest).as_posix() for p in dest.rglob("*") if p.is_file()} == files


def test_a_size_check_publishes_its_table_and_each_study(tmp_path):
    check = tmp_path / "check"
    for run in ("walls-500", "periodic-1000"):
        ended_study(check / run)
    for name in ("size_check.csv", "size_check.md", "size_check-a.png"):
        (check / name).write_text(name)
    dest = publish(check, tmp_path / "out")
    assert {p.name for p in dest.iterdir()} == {
        "size_check.csv", "size_check.md", "size_check-a.png", "walls-500", "periodic-1000"}
    assert (dest / "walls-500" / "report" / "report.md").exists()
    assert not list(dest.rglob("*.h5"))


def test_publishing_refuses_what_it_cannot_publish(tmp_path):
    ended_study(tmp_path / "study")
    with pytest.raises(InputError) as error:
        publish(tmp_path / "study", tmp_path / "study" / "published")
    assert error.value.field == "dest"
    (tmp_path / "empty").mkdir()
    result = CliRunner().invoke(app, ["study", "publish", str(tmp_path / "empty"), "--to",
                                      str(tmp_path / "out")])
    assert result.exit_code != 0 and "study.toml" in result.output


def test_the_source_commit_is_marked_changed_by_the_package_only(tmp_path):
    """Provenance: an edited study log or doc elsewhere in the checkout leaves the commit as
    it is; an edited module of the package marks it "+changes"."""
    import shutil
    import subprocess

    from grainlab.study.publish import source_commit

    if shutil.which("git") is None:
        pytest.skip("git is not installed")
    module = tmp_path / "src" / "grainlab" / "study"
    module.mkdir(parents=True)
    (module / "publish.py").write_text("x = 1\n")
    (tmp_path / "studies").mkdir()
    (tmp_path / "studies" / "study.log").write_text("one\n")

    def git(*arguments):
        subprocess.run(["git", "-C", str(tmp_path), *arguments], check=True,
                       capture_output=True)

    git("init", "-q")
    git("add", "-A")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "one")
    commit = source_commit(module)
    assert len(commit) == 40 and not commit.endswith("+changes")
    (tmp_path / "studies" / "study.log").write_text("two\n")
    assert source_commit(module) == commit
    (module / "publish.py").write_text("x = 2\n")
    assert source_commit(module) == commit + "+changes"
    assert source_commit(tmp_path.parent / "nowhere") == "unknown"
