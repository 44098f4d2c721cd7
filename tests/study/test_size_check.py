"""The size check of a preset series: its plan, the paper's value per sample, the table read
from each run's study summary, the verdict of the walls' core against the periodic cell, and
the command's report."""

from __future__ import annotations

import math
from itertools import pairwise
from typing import ClassVar

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import grainlab.study.size_check as size_check
from grainlab.cli.main import app
from grainlab.errors import InputError
from grainlab.report.paper_comparison import ANGULARITY, NONCONVEXITY
from grainlab.report.size_check_report import (
    convergence_verdicts,
    size_check_markdown,
    verdict_text,
    write_size_check_report,
)
from grainlab.study.size_check import SizeCheckPlan, paper_value, size_check_table


def test_plan_runs_every_boundary_and_size_in_its_own_folder():
    plan = SizeCheckPlan("nonconvexity", ("eta-0.0", "eta-0.4"), walls=(500, 2000),
                         periodic=(800, 1000))
    assert [r.folder_name for r in plan.runs] == [
        "walls-500", "walls-2000", "periodic-800", "periodic-1000"]


@pytest.mark.parametrize("field, options", [
    ("series", {"series": "roundness"}),
    ("samples", {"samples": ("S1", "S9")}),
    ("samples", {"samples": ()}),
    ("walls", {"walls": (500, 1)}),
    ("periodic", {"periodic": ()}),
    ("length", {"length": "long"}),
])
def test_plan_refuses_bad_input_by_name(field, options):
    arguments = {"series": "angularity", "samples": ("S1",), **options}
    with pytest.raises(InputError) as error:
        SizeCheckPlan(**arguments)
    assert error.value.field == field


def test_the_papers_value_of_each_sample():
    by_name = {claim.quantity: claim for claim in ANGULARITY}
    # (q/p)*: 0.2 for the spheres, 0.4 for the most angular, nothing in between
    assert paper_value(by_name["(q/p)*"], 0, 8, 0.0) == 0.2
    assert paper_value(by_name["(q/p)*"], 7, 8, 1.27) == 0.4
    assert math.isnan(paper_value(by_name["(q/p)*"], 4, 8, 0.5))
    # nu0 peaks near <alpha> = 0.5 at 0.75: S5 (0.501) gets it, S8 (1.27) does not
    assert paper_value(by_name["ν0"], 4, 8, 0.501) == 0.75
    assert math.isnan(paper_value(by_name["ν0"], 7, 8, 1.27))
    # z_c0 about 12 for every polyhedron, no value for the spheres
    assert paper_value(by_name["z_c0"], 3, 8, 0.34) == 12.0
    assert math.isnan(paper_value(by_name["z_c0"], 0, 8, 0.0))
    eta = {claim.quantity: claim for claim in NONCONVEXITY}
    assert paper_value(eta["Z_c0"], 0, 8, 0.0) == 6.0
    assert paper_value(eta["Z_c0"], 4, 8, 0.4) == 12.0


def rows(quantity, walls, cell, paper=math.nan, sample="S1"):
    """Table rows: ``walls`` {n: (whole, whole_std, core, core_std)}, ``cell`` (n, value,
    std)."""
    out = [{"sample": sample, "quantity": quantity, "column": "c", "boundary": "walls",
            "n": n, "whole": w, "whole_std": ws, "core": c, "core_std": cs, "paper": paper,
            "capped_share": 0.01, "wall_time": 10.0 * n}
           for n, (w, ws, c, cs) in walls.items()]
    n, value, std = cell
    out.append({"sample": sample, "quantity": quantity, "column": "c",
                "boundary": "periodic", "n": n, "whole": value, "whole_std": std,
                "core": value, "core_std": std, "paper": paper, "capped_share": 0.0,
                "wall_time": 10.0 * n})
    return out


def test_core_reaching_the_cell_and_staying_there_is_found():
    table = pd.DataFrame(
        rows("z*", {500: (3.4, 0.05, 3.7, 0.05), 1000: (3.6, 0.05, 3.95, 0.04),
                    2000: (3.75, 0.04, 4.0, 0.03)}, (1000, 4.02, 0.03), paper=4.0)
        # the core touches the cell at 1000, leaves it at 2000: no size reaches it
        + rows("z_c*", {500: (3.4, 0.05, 3.8, 0.02), 1000: (3.6, 0.05, 4.0, 0.02),
                        2000: (3.75, 0.04, 3.7, 0.02)}, (1000, 4.02, 0.02)))
    verdicts = convergence_verdicts(table).set_index("quantity")
    assert verdicts.loc["z*", "reaches"] == 1000
    assert verdicts.loc["z*", "basis"] == "core"
    np.testing.assert_allclose(verdicts.loc["z*", "core_gaps"], [-0.32, -0.07, -0.02])
    np.testing.assert_allclose(verdicts.loc["z*", "whole_gaps"], [-0.62, -0.42, -0.27])
    assert verdicts.loc["z*", "cell_vs_paper"] == pytest.approx(0.02)
    assert verdicts.loc["z_c*", "reaches"] == 0
    assert math.isnan(verdicts.loc["z_c*", "cell_vs_paper"])
    text = verdict_text(verdicts.reset_index().iloc[1])
    assert "off the cell by -0.22 → -0.02 → -0.32" in text and "not shrinking" in text


def test_a_distance_that_shrinks_only_overall_is_said_so():
    from grainlab.report.size_check_report import trend_words

    assert trend_words(np.array([-0.05, -0.02, -0.01])) == "shrinking"
    assert trend_words(np.array([-0.051, -0.019, -0.033])) == \
        "smaller at the largest size, not at every step"
    assert trend_words(np.array([-0.02, -0.03, -0.04])) == "not shrinking"
    assert trend_words(np.array([+0.03, -0.02])) == "shrinking"  # distances, not signs


def test_one_box_size_is_read_without_a_trend():
    table = pd.DataFrame(rows("z*", {500: (3.4, 0.05, 3.7, 0.05)}, (1000, 4.02, 0.03)))
    text = verdict_text(convergence_verdicts(table).iloc[0])
    assert "off the cell by -0.32 (N = 500: one size: no trend)" in text
    assert "shrinking" not in text


def test_initial_states_use_the_tolerance_and_a_quantity_without_core_the_whole_box():
    table = pd.DataFrame(
        rows("ν0", {500: (0.60, math.nan, 0.625, math.nan),
                    1000: (0.61, math.nan, 0.638, math.nan)}, (1000, 0.645, math.nan))
        + rows("(q/p)+", {500: (0.28, math.nan, math.nan, math.nan),
                          1000: (0.30, math.nan, math.nan, math.nan)},
               (1000, 0.31, math.nan)))
    strict = convergence_verdicts(table).set_index("quantity")
    assert strict.loc["ν0", "reaches"] == 0  # no error bar, no slack: never within
    loose = convergence_verdicts(table, {"ν0": 0.01, "(q/p)+": 0.015}).set_index("quantity")
    assert loose.loc["ν0", "reaches"] == 1000  # 0.638 within 0.01 of 0.645; 0.625 is not
    assert loose.loc["(q/p)+", "basis"] == "whole"
    assert loose.loc["(q/p)+", "reaches"] == 1000
    assert "whole box (no core value)" in verdict_text(loose.reset_index().iloc[1])


def summary_row(name, n, core_offset, walls=True):
    """A study summary row of spheres: in walls z* = 4 - 10 / N^(1/3) over the whole box and
    the core ``core_offset`` below the bulk's 4; in the cell 4."""
    return {"name": name, "measured": 0.0, "capped_share": 0.004, "wall_time": float(n),
            "q_over_trace_peak": 0.3, "q_over_trace_residual": 0.24,
            "q_over_trace_residual_std": 0.01,
            "z_residual": 4.0 - 10.0 / n ** (1 / 3) if walls else 4.0,
            "z_residual_std": 0.02, "coordination_number_core_residual": 4.0 - core_offset,
            "coordination_number_core_residual_std": 0.02}


def fake_runs(tmp_path, monkeypatch, plan, offsets):
    """Study folders of ``plan`` whose samples have ended with the summary rows above."""
    summaries = {}
    for run in plan.runs:
        study = plan.study(tmp_path, run)
        offset = offsets.get(run.n, 0.0) if run.boundary == "walls" else 0.0
        summaries[str(study.folder)] = pd.DataFrame(
            [summary_row(name, run.n, offset, run.boundary == "walls")
             for name in plan.samples])

    def summary(study, microstructure=True):
        return summaries[str(study.folder)]

    monkeypatch.setattr("grainlab.study.study_summary.study_summary", summary)
    monkeypatch.setattr(size_check, "sample_state", lambda folder: "ended")


def test_table_reads_every_run_and_writes_its_csv(tmp_path, monkeypatch):
    plan = SizeCheckPlan("angularity", ("S1",), walls=(500, 2000), periodic=(1000,))
    fake_runs(tmp_path, monkeypatch, plan, {500: 0.3, 2000: 0.01})
    held = tmp_path / "walls-500" / "study.toml"  # made when the core margin was 1
    held.write_text(held.read_text().replace("core_margin = 1.5", "core_margin = 1.0"))
    table = size_check_table(tmp_path, plan)
    assert (tmp_path / "size_check.csv").exists()
    assert "core_margin = 1.5" in held.read_text()  # read with the preset's margin
    z = table[table["quantity"] == "z*"].set_index(["boundary", "n"])
    assert z.loc[("walls", 500), "core"] == pytest.approx(3.7)
    # the cell's core is its whole packing
    assert z.loc[("periodic", 1000), "core"] == z.loc[("periodic", 1000), "whole"]
    assert z.loc[("walls", 500), "paper"] == 4.0  # S1 is the first sample: z about 4
    assert set(table["quantity"]) >= {"(q/p)+", "(q/p)*", "z*"}
    verdicts = convergence_verdicts(table).set_index("quantity")
    assert verdicts.loc["z*", "reaches"] == 2000


def test_command_writes_the_report_from_ended_runs(tmp_path, monkeypatch):
    plan = SizeCheckPlan("angularity", ("S1", "S5"), walls=(500, 1000), periodic=(1000,))
    fake_runs(tmp_path, monkeypatch, plan, {500: 0.3, 1000: 0.01})
    result = CliRunner().invoke(app, [
        "study", "size-check", "angularity", "-o", str(tmp_path), "--walls", "500,1000",
        "--periodic", "1000", "--no-run"])
    assert result.exit_code == 0, result.output
    report = (tmp_path / "size_check.md").read_text()
    assert "## S1" in report and "## S5" in report
    assert "core within the cell's error bars from N = 1000" in report
    assert (tmp_path / "size_check-S1.png").stat().st_size > 0
    table = pd.read_csv(tmp_path / "size_check.csv")
    assert "| z* |" in size_check_markdown(table, plan)


def test_the_walls_cores_after_the_compaction_are_read_at_other_margins(tmp_path,
                                                                       monkeypatch):
    """Each walls run's last compaction snapshot, here a 5 x 5 x 5 lattice of spheres of
    diameter 2 in a box 10 wide: its core holds pi/6 where the margin ends it between two
    layers (1, 2 diameters) or through the first layer's centres (half a diameter), and
    reads low at 0.75 (per axis 3 spheres and two caps of 5/32 over 7); the report gives the
    table with the cell's value."""
    from grainlab.analysis.snapshot_files import write_snapshots
    from grainlab.analysis.synthetic import cubic_lattice
    from grainlab.study.size_check import margin_table

    plan = SizeCheckPlan("angularity", ("S1",), walls=(500,), periodic=(1000,))
    fake_runs(tmp_path, monkeypatch, plan, {500: 0.3})
    lattice = cubic_lattice(5, 1.0)
    lattice.state.update(stage="compaction", eps_q=0.0)
    sheared = cubic_lattice(5, 1.0)
    sheared.state.update(stage="shear", eps_q=0.5)
    run = plan.study(tmp_path, plan.runs[0]).sample_folder("S1")
    run.mkdir(parents=True, exist_ok=True)
    write_snapshots(run / "snapshots.h5", [lattice, sheared])
    margins = margin_table(tmp_path, plan, (0.5, 0.75, 1.0, 2.0))
    assert (tmp_path / "size_check_margins.csv").exists()
    assert list(margins["n"]) == [500] * 4 and list(margins["n_core"]) == [125, 27, 27, 1]
    sphere = 4.0 / 3.0 * np.pi
    np.testing.assert_allclose(margins["packing_fraction"],
                               [np.pi / 6, sphere * (3 + 2 * 5 / 32) ** 3 / 343, np.pi / 6,
                                np.pi / 6])
    table = size_check_table(tmp_path, plan)
    report = write_size_check_report(tmp_path, plan, table, margins).read_text()
    assert "### S1: the core after the compaction at other margins" in report
    sixth = f"{np.pi / 6:.3g}"
    assert f"| 500 | packing fraction | {sixth} (125) | 0.444 (27) | {sixth} (27) |" in report
    assert "| 500 | z = z_c | 4.8 | 6 | 6 | 6 |" in report  # spheres: z_c is z, one row


def test_command_refuses_bad_sizes_by_name(tmp_path):
    result = CliRunner().invoke(app, ["study", "size-check", "angularity", "-o",
                                      str(tmp_path), "--walls", "500,many", "--no-run"])
    assert result.exit_code != 0
    assert "--walls" in result.output and "many" in result.output


def test_a_run_with_too_many_capped_steps_is_flagged():
    table = pd.DataFrame(rows("z*", {500: (3.4, 0.05, 3.7, 0.05)}, (1000, 4.02, 0.03)))
    table.loc[table["boundary"] == "periodic", "capped_share"] = 0.12
    plan = SizeCheckPlan("angularity", ("S1",), walls=(500,), periodic=(1000,))
    text = size_check_markdown(table, plan)
    assert "walls 500: 5000 s, 1.0% of the steps capped;" in text
    assert "periodic 1000: 10000 s, 12.0% of the steps capped (above 2%" in text


class FakeCluster:
    """Stands in for the local Dask cluster: its address, and whether it was closed."""

    made: ClassVar[list[FakeCluster]] = []

    def __init__(self, n_workers, threads):
        self.n_workers, self.closed = n_workers, False
        self.cluster = type("C", (), {"scheduler_address": "tcp://fake:1"})()
        FakeCluster.made.append(self)

    def close(self):
        self.closed = True


def fake_study_runs(monkeypatch, seconds=0.3, stop_after=None):
    """Study.run replaced by a wait of ``seconds`` (or, with ``stop_after``, until the study's
    stop file appears): each call's folder, scheduler and start and end times."""
    import threading
    import time

    from grainlab.study.sample_task import STOP_FILE
    from grainlab.study.study_runner import Study, StudyOutcome

    calls, lock = [], threading.Lock()

    def run(self, *, scheduler=None, workers=None, threads=1, progress=True, only=None,
            on_update=None):
        start = time.monotonic()
        outcome = StudyOutcome(ran=list(only))
        if stop_after is not None and self.folder.name != stop_after:
            while not (self.folder / STOP_FILE).exists():
                time.sleep(0.01)
            outcome = StudyOutcome(interrupted=list(only))
        else:
            time.sleep(seconds)
        with lock:
            calls.append((self.folder.name, scheduler, start, time.monotonic()))
        return outcome

    FakeCluster.made.clear()
    monkeypatch.setattr(Study, "run", run)
    monkeypatch.setattr(size_check, "LocalSampleCluster", FakeCluster)
    return calls


def overlapping(calls) -> bool:
    spans = sorted((start, end) for _, _, start, end in calls)
    return any(b[0] < a[1] for a, b in pairwise(spans))


def test_with_several_workers_the_studies_run_at_once_on_one_cluster(tmp_path, monkeypatch):
    plan = SizeCheckPlan("angularity", ("S1", "S5"), walls=(500, 1000), periodic=(1000,))
    calls = fake_study_runs(monkeypatch)
    ended = []
    outcomes = size_check.run_size_check(tmp_path, plan, workers=4, progress=False,
                                         on_end=lambda name, outcome: ended.append(name))
    assert sorted(outcomes) == sorted(ended) == ["periodic-1000", "walls-1000", "walls-500"]
    assert all(o.complete for o in outcomes.values())
    assert {scheduler for _, scheduler, _, _ in calls} == {"tcp://fake:1"}
    assert overlapping(calls)
    (cluster,) = FakeCluster.made
    assert cluster.n_workers == 4 and cluster.closed  # 6 samples, 4 workers asked


def test_on_one_worker_the_studies_run_one_after_another(tmp_path, monkeypatch):
    plan = SizeCheckPlan("angularity", ("S1",), walls=(500, 1000), periodic=(1000,))
    calls = fake_study_runs(monkeypatch, seconds=0.05)
    size_check.run_size_check(tmp_path, plan, workers=1, progress=False)
    assert [name for name, *_ in calls] == ["walls-500", "periodic-1000", "walls-1000"]
    assert not overlapping(calls) and not FakeCluster.made
    assert {scheduler for _, scheduler, _, _ in calls} == {None}


def test_interrupting_the_running_studies_asks_each_to_checkpoint(tmp_path, monkeypatch):
    from grainlab.study.study_runner import StudyInterrupted

    plan = SizeCheckPlan("angularity", ("S1",), walls=(500, 1000), periodic=(1000,))
    calls = fake_study_runs(monkeypatch, stop_after="walls-500")

    def interrupt(name, outcome):  # Ctrl-C as the first study ends
        raise KeyboardInterrupt

    with pytest.raises(StudyInterrupted):
        size_check.run_size_check(tmp_path, plan, workers=2, progress=False, on_end=interrupt)
    assert sorted(name for name, *_ in calls) == ["periodic-1000", "walls-1000", "walls-500"]
    assert FakeCluster.made[0].closed


def series_in_a_cell(folder, n=1000, **options):
    """A study of the angularity series in a periodic cell, as `grainlab study angularity
    --length full --boundary periodic` creates it (no sample run)."""
    from grainlab.study.series_presets import series_spec
    from grainlab.study.study_runner import Study

    spec = series_spec("angularity", n_particles=n, length="full", seed=0,
                       boundary="periodic", **options)
    return Study.create(folder, spec)


def test_the_cell_can_be_a_series_run_with_the_checks_settings(tmp_path, monkeypatch):
    series = series_in_a_cell(tmp_path / "series", replicas=3)
    plan = SizeCheckPlan("angularity", ("S1", "S5"), walls=(500,), periodic=(2000,),
                         cell_from=series.folder)
    assert plan.periodic == (1000,)  # the series' size, not the check's own
    # summarised with another core margin: a cell has no core, it is still the check's cell
    toml = series.folder / "study.toml"
    toml.write_text(toml.read_text().replace("core_margin = 1.5", "core_margin = 1.0"))
    assert SizeCheckPlan("angularity", ("S1",), walls=(500,),
                         cell_from=series.folder).periodic == (1000,)
    toml.write_text(toml.read_text().replace("window = [\n    0.6,", "window = [\n    0.5,"))
    with pytest.raises(InputError, match="window"):
        SizeCheckPlan("angularity", ("S1",), walls=(500,), cell_from=series.folder)
    toml.write_text(toml.read_text().replace("window = [\n    0.5,", "window = [\n    0.6,"))
    cell = plan.runs[-1]
    assert plan.study_folder(tmp_path / "check", cell) == series.folder
    assert plan.study(tmp_path / "check", cell).folder == series.folder
    assert not (tmp_path / "check" / "periodic-1000").exists()
    fake_runs(tmp_path / "check", monkeypatch, plan, {500: 0.3})
    table = size_check_table(tmp_path / "check", plan)
    z = table[table["quantity"] == "z*"].set_index(["sample", "boundary", "n"])
    assert z.loc[("S5", "periodic", 1000), "whole"] == 4.0
    assert "of the series" in size_check_markdown(table, plan)


def test_a_cell_series_with_other_settings_is_refused_naming_them(tmp_path):
    walls = series_in_a_cell(tmp_path / "short")
    (walls.folder / "study.toml").write_text(
        (walls.folder / "study.toml").read_text().replace('boundary = "periodic"',
                                                          'boundary = "walls"'))
    with pytest.raises(InputError) as error:
        SizeCheckPlan("angularity", ("S1",), walls=(500,), cell_from=walls.folder)
    assert error.value.field == "cell_from"
    assert "sample.boundary: 'walls' vs 'periodic'" in str(error.value)
    with pytest.raises(InputError, match=r"lacks eta-0\.0"):
        SizeCheckPlan("nonconvexity", ("eta-0.0",), walls=(500,), cell_from=walls.folder)
    with pytest.raises(InputError, match="a study folder"):
        SizeCheckPlan("angularity", ("S1",), walls=(500,), cell_from=tmp_path / "none")
    result = CliRunner().invoke(app, ["study", "size-check", "angularity", "-o",
                                      str(tmp_path / "check"), "--cell-from",
                                      str(walls.folder), "--no-run"])
    assert result.exit_code == 2
    assert "cell_from" in result.output and "Traceback" not in result.output
