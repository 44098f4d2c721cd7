"""The report of a tiny real run: its tables hold the numbers of the window average and of the
results table, its figures exist, a window without snapshots still gives the macroscopic part."""

from __future__ import annotations

import itertools
import re
import shutil

import numpy as np
import pytest

from grainlab.analysis.snapshot_files import read_snapshots
from grainlab.analysis.window_average import StrainWindow, WindowAverage
from grainlab.errors import InputError
from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig
from grainlab.report.run_report import REPORT_FOLDER, write_run_report
from grainlab.result.test_result import read_test_result

TINY = {
    "sample": {"n_particles": 30, "seed": 3},
    "test": {"kind": "triaxial", "eps_q_max": 0.02},
    "solver": {"sweep": "serial", "shear": {"inertia_number": 0.01}},
    "output": {"record_every": 1, "snapshot_every": 3},
}


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("run") / "triaxial"
    start_run(folder, RunConfig.model_validate(TINY)).run()
    return folder


def table_rows(text: str) -> dict[str, list[str]]:
    """Markdown table rows by their first cell (cells stripped)."""
    rows = {}
    for line in text.splitlines():
        if line.startswith("| ") and not line.startswith("|---"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            rows[cells[0]] = cells[1:]
    return rows


def shear_table(folder):
    table = read_test_result(folder / "results.csv").table
    return table[table["stage"] != "compaction"]


def test_the_report_holds_the_window_averages_and_links_existing_figures(run_folder):
    window = (0.005, 0.02)
    path = write_run_report(run_folder, window=window)
    assert path == run_folder / REPORT_FOLDER / "report.md"
    text = path.read_text(encoding="utf-8")
    rows = table_rows(text)
    average = WindowAverage(StrainWindow(*window)).run(run_folder)
    assert average.n_snapshots >= 2
    by_column = {cells[0].strip("`"): cells for cells in rows.values() if len(cells) == 5}
    for name in ("a_c", "coordination_number", "connectivity_number", "sliding_proportion"):
        mean, std, n = average.scalar(name)
        cells = by_column[name]
        assert float(cells[1]) == pytest.approx(mean, rel=1e-3, abs=1e-12)
        assert float(cells[2]) == pytest.approx(std, rel=1e-3, abs=1e-12)
        assert int(cells[3]) == n == average.n_snapshots
    shear = shear_table(run_folder)
    inside = shear[(shear["eps_q"] >= window[0]) & (shear["eps_q"] <= window[1])]
    mean, std = rows["q/p = (s1 - s3)/tr(s), window"][0].split(" ± ")
    assert float(mean) == pytest.approx(inside["q_over_trace"].mean(), rel=1e-3)
    assert float(std) == pytest.approx(inside["q_over_trace"].std(ddof=1), rel=1e-3)
    assert float(rows["q/p, peak"][0]) == pytest.approx(shear["q_over_trace"].max(), rel=1e-3)
    outcome = read_test_result(run_folder / "results.h5").metadata["outcome"]
    # 30 spheres sheared fast (I = 0.01): the walls' stresses lag their target by a few
    # tens of percent, which the outcome judges; the report says what the outcome says
    assert rows["particles"][0] == "30 spheres" and rows["outcome"][0] == outcome["status"]
    assert "capped steps, shear" in rows
    links = re.findall(r"\]\(([^)]+)\)", text)
    assert {"curves.png", "force_pdfs.png", "angular_distributions.png",
            "window_scalars.csv"} <= set(links)
    for link in links:
        assert (path.parent / link).stat().st_size > 0, link


def test_a_window_without_snapshots_keeps_the_macroscopic_part(run_folder, tmp_path):
    records = shear_table(run_folder).set_index("step")["eps_q"]
    snapshots = [n.state for n in read_snapshots(run_folder / "snapshots.h5")
                 if n.state["stage"] == "shear"]
    # the records strictly between two snapshots snapshot_every steps apart
    every = TINY["output"]["snapshot_every"]
    first = next(a["step"] for a, b in itertools.pairwise(snapshots)
                 if b["step"] - a["step"] == every)
    low, high = float(records[first + 1]), float(records[first + every - 1])
    assert not any(low <= s["eps_q"] <= high for s in snapshots)
    text = write_run_report(run_folder, window=(low, high), out=tmp_path / "r").read_text()
    assert "no microstructure: no snapshot has eps_q in" in text
    assert "eps_q from" in text  # the range the snapshots have
    assert "q/p = (s1 - s3)/tr(s), window" in text
    assert not (tmp_path / "r" / "force_pdfs.png").exists()


def test_a_run_without_snapshots_says_so(run_folder, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(run_folder, copy, ignore=shutil.ignore_patterns("snapshots.h5", "report"))
    text = write_run_report(copy).read_text()
    assert "wrote no snapshots.h5" in text
    assert (copy / REPORT_FOLDER / "curves.png").exists()


def test_the_default_window_is_the_last_30_percent_of_the_shear(run_folder, tmp_path):
    text = write_run_report(run_folder, out=tmp_path / "d").read_text()
    reached = shear_table(run_folder)["eps_q"].max()
    assert f"eps_q in [{0.7 * reached:g}, {reached:g}]" in text
    assert "the last 30 % of the eps_q reached" in text


@pytest.mark.parametrize("window", [(0.02, 0.01), (0.5, 0.9), (np.nan, 0.1)])
def test_a_bad_window_is_refused_naming_it(run_folder, tmp_path, window):
    with pytest.raises(InputError, match="window"):
        write_run_report(run_folder, window=window, out=tmp_path / "bad")
