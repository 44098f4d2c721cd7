"""``grainlab compare KIND`` as a user runs it: both solvers on the same sample into OUT/cd and
OUT/dem (a run stopped half-way resumes), the overlay and the table with the numbers each run
folder holds; run again, it reuses the runs that ended without touching them; bad input is one
message naming the option, and nothing is written."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig
from grainlab.result.test_result import read_test_result

runner = CliRunner()

OPTIONS = ["-n", "30", "--seed", "3", "--kappa", "1e3", "--eps-q", "0.02", "--inertia",
           "0.01", "--sweep", "serial", "--no-progress"]
"""A triaxial test small enough for a test: 30 spheres, sheared to eps_q = 0.02 at I <= 0.01,
DEM at kappa = 1e3."""
ASKED = {"sample": {"n_particles": 30, "seed": 3},
         "test": {"kind": "triaxial", "eps_q_max": 0.02},
         "solver": {"sweep": "serial", "dem": {"kappa": 1e3}, "shear": {"inertia_number": 0.01}}}
"""The config those options ask for."""


def said(result) -> str:
    return " ".join(result.output.split())  # rich wraps long lines


def mtimes(folder) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    """A comparison whose contact-dynamics run was stopped at step 60 (checkpointed), then
    ``grainlab compare triaxial``."""
    out = tmp_path_factory.mktemp("compare") / "cmp"
    stopped = start_run(out / "cd", RunConfig.model_validate(ASKED))
    stopped.run(max_steps=60)
    stopped.checkpoint()
    result = runner.invoke(app, ["compare", "triaxial", *OPTIONS, "--out", str(out)])
    return out, result


def test_compare_runs_both_solvers_on_the_same_sample_and_overlays_them(compared):
    out, result = compared
    assert result.exit_code == 0, result.output
    text = said(result)
    assert f"cd (contact dynamics): resuming the run in {out / 'cd'} at step 60" in text
    assert f"dem (soft-contact DEM): starting the run in {out / 'dem'}" in text
    assert f"table: {out / 'compare.csv'}" in text and f"figure: {out / 'compare.png'}" in text
    assert (out / "compare.png").stat().st_size > 0
    cd, dem = (RunConfig.read(out / m / "config.toml").model_dump() for m in ("cd", "dem"))
    assert cd["solver"].pop("method") == "cd" and dem["solver"].pop("method") == "dem"
    assert cd == dem  # the same test on the same sample; [solver.dem] acts on DEM only
    results = {m: read_test_result(out / m / "results.h5") for m in ("cd", "dem")}
    assert results["cd"].metadata["specimen"] == results["dem"].metadata["specimen"]
    for r in results.values():
        assert r.metadata["outcome"]["finished"]
        assert list(dict.fromkeys(r.table["stage"])) == ["compaction", "shear"]


def test_the_table_holds_the_numbers_of_each_run_folder(compared):
    out, _ = compared
    table = pd.read_csv(out / "compare.csv").set_index("quantity")
    for method in ("cd", "dem"):
        result = read_test_result(out / method / "results.h5")
        rows, cost = result.table, result.metadata["cost"]
        shear = rows[rows["stage"] == "shear"]
        compaction = rows[rows["stage"] == "compaction"].iloc[-1]
        assert table.loc["peak_q_over_trace", method] == shear["q_over_trace"].max()
        assert table.loc["compaction_packing_fraction", method] == \
            compaction["packing_fraction"]
        assert table.loc["compaction_z", method] == compaction["z"]
        assert table.loc["steps", method] == result.metadata["outcome"]["steps"] \
            == rows["step"].iloc[-1] == cost["steps"]
        assert table.loc["wall_time", method] == cost["wall_time"] > 0.0
    assert cost["substeps"] > cost["steps"]  # DEM: every step cut into sub-steps
    assert table.loc["substeps", "dem"] == cost["substeps"]
    assert pd.isna(table.loc["substeps", "cd"])
    assert table.loc["peak_q_over_trace", "dem_over_cd"] == pytest.approx(
        table.loc["peak_q_over_trace", "dem"] / table.loc["peak_q_over_trace", "cd"])


def test_a_second_compare_reuses_the_runs_that_ended(compared):
    out, _ = compared
    runs = {m: mtimes(out / m) for m in ("cd", "dem")}
    table = (out / "compare.csv").read_text()
    again = runner.invoke(app, ["compare", "triaxial", *OPTIONS, "--out", str(out)])
    assert again.exit_code == 0, again.output
    text = said(again)
    for method in ("cd", "dem"):
        assert f"the run in {out / method} has ended" in text and "reused as it is" in text
        assert mtimes(out / method) == runs[method]  # not run again, not even rewritten
    assert "starting" not in text and "resuming" not in text
    assert (out / "compare.csv").read_text() == table


def test_a_folder_holding_runs_of_another_test_is_refused_untouched(compared):
    out, _ = compared
    before = mtimes(out)
    refused = runner.invoke(app, ["compare", "triaxial", *OPTIONS, "-n", "40",
                                  "--out", str(out)])
    assert refused.exit_code == 2, refused.output
    assert "-n/--n-particles = 40 is not allowed: expected 30, the value of the run already " \
           f"in {out / 'cd'}" in said(refused)
    assert "--overwrite" in said(refused)
    assert mtimes(out) == before


@pytest.mark.parametrize("arguments, words", [
    (["shear"], ("KIND = 'shear'", "one of compaction, triaxial, extension, oedometer")),
    (["triaxial", "--solver", "dem"], ("--solver = 'dem'", "both solvers")),
    (["triaxial", "--kappa", "-1"], ("--kappa = -1", "> 0")),
    (["simple_shear"], ("sample.boundary = 'walls'", "periodic")),
])
def test_bad_input_is_one_message_and_nothing_is_written(tmp_path, arguments, words):
    out = tmp_path / "cmp"
    result = runner.invoke(app, ["compare", *arguments, "--out", str(out), "--no-progress"])
    assert result.exit_code == 2, result.output
    for word in words:
        assert word in said(result), result.output
    assert "Traceback" not in result.output
    assert not out.exists()
