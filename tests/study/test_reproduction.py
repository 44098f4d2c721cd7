"""A rerun of a study against its reference: values within the error bars agree, values
outside them do not, a missing sample and changed settings are said, and the committed
series tell a different shape from a rerun of the same one."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.errors import InputError
from grainlab.study.reproduction import (
    read_study_results,
    reproduction_counts,
    reproduction_table,
    seed_spread,
    settings_differences,
    write_reproduction,
)
from grainlab.study.study_spec import StudySpec

PUBLISHED = Path(__file__).resolve().parents[2] / "docs" / "studies" / \
    "nonconvexity-periodic-1000"


def agrees(table: pd.DataFrame, sample: str, quantity: str) -> bool | None:
    """One value's reading as a plain True, False or None (not judged)."""
    value = table.loc[(sample, quantity), "agrees"]
    return None if value is None or value != value else bool(value)


def reference_table() -> pd.DataFrame:
    """Two shapes, the first with two replicas: seed spread 0.01 of the peak (a: 0.50,
    0.51, 0.52) and 0.005 of the residual strength; the second shape one run."""
    return pd.DataFrame({
        "name": ["a", "b", "a-seed1", "a-seed2"], "replica_of": ["", "", "a", "a"],
        "q_over_trace_peak": [0.50, 0.60, 0.51, 0.52],
        "q_over_trace_residual": [0.30, 0.40, 0.305, 0.295],
        "q_over_trace_residual_std": [0.01, 0.01, 0.01, 0.01],
        "packing_fraction_initial": [0.60, 0.65, 0.60, 0.60]})


def test_the_seed_spread_is_the_pooled_standard_deviation_over_replicated_shapes():
    spread, shapes = seed_spread(reference_table(), "q_over_trace_peak")
    assert shapes == 1 and spread == pytest.approx(0.01)
    # two shapes of variances 1 and 4 pool to sqrt(2.5)
    table = pd.DataFrame({"name": ["a", "a-seed1", "b", "b-seed1"],
                          "replica_of": ["", "a", "", "b"], "x": [0.0, 2 ** 0.5, 0.0,
                                                                  2 * 2 ** 0.5]})
    assert seed_spread(table, "x")[0] == pytest.approx(math.sqrt(2.5))
    assert math.isnan(seed_spread(table.assign(replica_of=""), "x")[0])


def test_an_unchanged_rerun_reads_identical_everywhere():
    ref = reference_table()
    table = reproduction_table(ref.copy(), ref)
    assert set(table["verdict"]) == {"identical"}
    assert reproduction_counts(table) == {"agree": len(table), "disagree": 0, "unjudged": 0,
                                          "missing": 0}


def test_values_agree_within_the_error_bars_and_not_beyond():
    ref = reference_table()
    # the peak's bar is 2 (s + s) = 0.04 from the replicas' spread 0.01
    new = ref.assign(q_over_trace_peak=[0.535, 0.645, 0.51, 0.52])
    table = reproduction_table(new, ref).set_index(["sample", "quantity"])
    assert table.loc[("a", "(q/p)+"), "bar"] == pytest.approx(0.04)
    assert agrees(table, "a", "(q/p)+") is True          # +0.035 < 0.04
    assert agrees(table, "b", "(q/p)+") is False         # +0.045 > 0.04
    assert "outside the error bars by 0.005" in table.loc[("b", "(q/p)+"), "verdict"]
    # a residual value: 2 (0.01 + 0.01) from the windows, wider than the seeds' 2 (s + s)
    new = ref.assign(q_over_trace_residual=[0.339, 0.441, 0.31, 0.29])
    table = reproduction_table(new, ref).set_index(["sample", "quantity"])
    assert table.loc[("a", "(q/p)*"), "bar_from"] == "window"
    assert agrees(table, "a", "(q/p)*") is True           # +0.039 < 0.04
    assert agrees(table, "b", "(q/p)*") is False          # +0.041 > 0.04


def test_a_value_without_an_error_bar_is_not_judged_unless_equal():
    ref = reference_table().iloc[:2].assign(replica_of="")   # no replicas: no seed spread
    new = ref.assign(packing_fraction_initial=[0.60, 0.66])
    table = reproduction_table(new, ref).set_index(["sample", "quantity"])
    assert table.loc[("a", "packing fraction 0"), "verdict"] == "identical"
    assert agrees(table, "b", "packing fraction 0") is None
    assert "no error bar" in table.loc[("b", "packing fraction 0"), "verdict"]
    # the rerun's replicas give the spread where the reference has none
    new = pd.concat([new, pd.DataFrame({"name": ["a-seed1"], "replica_of": ["a"],
                                        "packing_fraction_initial": [0.61]})])
    table = reproduction_table(new, ref).set_index(["sample", "quantity"])
    assert table.loc[("b", "packing fraction 0"), "bar"] == pytest.approx(4 * 0.01 / 2 ** 0.5)
    assert agrees(table, "b", "packing fraction 0") is True  # 0.01 off, bars 0.028


def test_a_sample_missing_from_the_rerun_is_said():
    ref = reference_table()
    table = reproduction_table(ref[ref["name"] != "b"], ref)
    missing = table[table["quantity"] == "-"]
    assert list(missing["sample"]) == ["b"]
    assert reproduction_counts(table)["missing"] == 1


def spec(boundary: str = "walls", n_particles: int = 30) -> StudySpec:
    return StudySpec.model_validate({
        "study": {"name": "two", "parameter": "eta", "window": [0.05, 0.1]},
        "base": {"sample": {"n_particles": n_particles, "boundary": boundary}},
        "samples": [{"name": n, "value": 0.1 * k} for k, n in enumerate(("a", "b"))]})


def test_settings_that_differ_are_named_key_by_key():
    assert settings_differences(spec(), spec()) == {}
    differences = settings_differences(spec("periodic", 40), spec())
    assert set(differences) == {"a", "b"}
    assert any(key.startswith("sample.boundary: 'periodic' vs 'walls'")
               for key in differences["a"])
    assert any(key.startswith("sample.n_particles: 40 vs 30") for key in differences["a"])


def test_the_committed_series_tells_another_shape_from_a_rerun():
    """The published non-convexity series: its seed-1 replicas read as reruns of the seed-0
    samples agree within the error bars (independent packings of the same shapes); the
    spheres read as a rerun of the most non-convex aggregates do not."""
    _, ref = read_study_results(PUBLISHED, "reference")
    rerun = pd.concat([ref[ref["name"] == f"{name}-seed1"] for name in
                       ("eta-0.0", "eta-0.3", "eta-0.7")])
    rerun = rerun.assign(name=["eta-0.0", "eta-0.3", "eta-0.7"])
    table = reproduction_table(rerun, ref)
    judged = table[table["sample"].isin(["eta-0.0", "eta-0.3", "eta-0.7"])]
    assert (judged["agrees"] == True).all()  # noqa: E712
    swapped = rerun.assign(name=["eta-0.7", "eta-0.3", "eta-0.0"])
    table = reproduction_table(swapped, ref).set_index(["sample", "quantity"])
    for quantity in ("(q/p)*", "z_c0", "z_c*", "sliding proportion *"):
        assert agrees(table, "eta-0.7", quantity) is False, quantity
    # the resolution of single samples: eta = 0.4 passes for a rerun of eta = 0.3
    neighbour = ref[ref["name"] == "eta-0.4"].assign(name="eta-0.3")
    table = reproduction_table(neighbour, ref)
    assert (table.loc[table["sample"] == "eta-0.3", "agrees"] == True).all()  # noqa: E712


def test_the_command_writes_the_comparison_and_says_when_it_fails(tmp_path):
    rerun = tmp_path / "rerun"
    shutil.copytree(PUBLISHED, rerun)
    result = CliRunner().invoke(app, ["study", "compare", str(rerun), "--reference",
                                      str(PUBLISHED)])
    assert result.exit_code == 0, result.output
    assert "0 do not" in result.output
    text = (rerun / "report" / "reproduction.md").read_text()
    assert "| eta-0.4 | (q/p)* |" in text and "identical" in text
    # one residual strength far off: exit status 3 and the sample named
    table = pd.read_csv(rerun / "summary.csv")
    table.loc[table["name"] == "eta-0.4", "q_over_trace_residual"] += 0.2
    table.to_csv(rerun / "summary.csv", index=False)
    result = CliRunner().invoke(app, ["study", "compare", str(rerun), "-r", str(PUBLISHED)])
    assert result.exit_code == 3
    frame, _, _ = write_reproduction(rerun, PUBLISHED)
    off = frame[frame["agrees"] == False]  # noqa: E712
    assert list(zip(off["sample"], off["quantity"], strict=True)) == [("eta-0.4", "(q/p)*")]


def test_a_folder_that_is_no_study_gets_one_message(tmp_path):
    with pytest.raises(InputError, match="--reference"):
        read_study_results(tmp_path, "--reference")
    result = CliRunner().invoke(app, ["study", "compare", str(tmp_path), "-r",
                                      str(PUBLISHED)])
    assert result.exit_code == 2
    assert "FOLDER" in result.output and "Traceback" not in result.output
