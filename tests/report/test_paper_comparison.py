"""A study against its paper (grainlab.report.paper_comparison) and the report as one HTML
file (grainlab.report.html_report)."""

from __future__ import annotations

import base64

import matplotlib
import numpy as np
import pandas as pd
import pytest

from grainlab.report.html_report import markdown_html
from grainlab.report.paper_comparison import (
    ANGULARITY,
    NONCONVEXITY,
    RISES_THEN_FALLS,
    PaperClaim,
    comparison_markdown,
    paper_comparison,
    verdict,
)

ETA = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7])


def _as_the_paper(claims, x) -> pd.DataFrame:
    """A summary table whose values are exactly what each claim says (a straight line from
    the first to the last value, a tent peaking where the paper's peak is)."""
    table = {"name": [f"s{k}" for k in range(len(x))], "value": x, "measured": x}
    for claim in claims:
        if claim.peak_at is not None:
            values = claim.peak - 0.05 * np.abs(x - claim.peak_at)
        elif claim.trend == RISES_THEN_FALLS:
            values = 0.5 - 0.1 * np.abs(x - x[len(x) // 2]) / (x[-1] - x[0])
        elif claim.trend is not None and claim.first is None and claim.last is None:
            values = 0.3 + 0.1 * (x - x[0]) / (x[-1] - x[0])
        else:
            ends = [v for v in (claim.first, claim.rest, claim.last) if v is not None]
            first = claim.first if claim.first is not None else ends[0]
            last = claim.last if claim.last is not None else ends[-1]
            if claim.trend == "rises" and claim.first is None:
                first = last - 0.1
            values = np.linspace(first, last, len(x))
            if claim.rest is not None:
                values[1:] = claim.rest
        for column in (claim.column, claim.core_column):
            if column is not None:
                table[column] = values
    return pd.DataFrame(table)


@pytest.mark.parametrize("claims, parameter", [(NONCONVEXITY, "eta"),
                                               (ANGULARITY, "mean_angularity")])
def test_values_as_the_paper_agree_everywhere(claims, parameter):
    table = _as_the_paper(claims, ETA if parameter == "eta" else np.linspace(0, 1.27, 8))
    comparison = paper_comparison(table, parameter)
    assert list(comparison["quantity"]) == [c.quantity for c in claims]
    cored = np.array([c.core_column is not None for c in claims])
    assert comparison["core_agrees"][cored].all() and comparison["whole_box_agrees"].all(), \
        comparison[["quantity", "whole_box_verdict", "core_verdict"]]
    assert (comparison["core_verdict"][~cored] == "no value").all()  # a peak, an angle
    assert "**agrees** (core)" in comparison_markdown(comparison)


def test_a_value_off_by_more_than_its_bars_is_named_with_its_gap_and_direction():
    claim = PaperClaim("z*", "z_residual", None, "rises from 4 to 5.5", 0.3,
                       first=4.0, last=5.5)
    values, stds = np.array([3.4, 4.2, 5.5]), np.array([0.1, 0.1, 0.1])
    text, agrees = verdict(claim, values, stds, np.array([0.0, 0.5, 1.0]))
    assert not agrees
    assert "first below the paper's 4 by 0.6" in text and "last as the paper's 5.5" in text
    # the same gap inside the error bars agrees: 0.6 <= 0.3 + 2 x 0.16
    text, agrees = verdict(claim, values, np.array([0.16, 0.1, 0.1]), np.array([0, 0.5, 1]))
    assert agrees and "first as the paper's 4" in text


def test_a_trend_must_exceed_the_error_bars_of_its_ends():
    claim = PaperClaim("(q/p)*", "q", None, "rises", 0.02, trend="rises")
    x = np.array([0.0, 0.35, 0.7])
    assert verdict(claim, np.array([0.30, 0.33, 0.40]), np.array([0.02, 0.02, 0.02]), x)[1]
    text, agrees = verdict(claim, np.array([0.30, 0.33, 0.33]), np.array([0.02, 0.02, 0.02]),
                           x)
    assert not agrees and "does not rise beyond its error bars" in text
    falling = PaperClaim("nu*", "n", None, "falls", 0.01, trend="falls")
    assert verdict(falling, np.array([0.58, 0.56, 0.54]), np.zeros(3), x)[1]


def test_a_rise_then_fall_needs_an_inner_maximum_above_both_ends_beyond_their_bars():
    """Seed 002's (q/p)+: it rises with <alpha> to a maximum, then falls for the most angular
    shapes."""
    claim = next(c for c in ANGULARITY if c.quantity == "(q/p)+")
    assert claim.trend == RISES_THEN_FALLS
    x = np.array([0.0, 0.34, 0.5, 0.77, 1.27])
    bars = np.full(5, 0.005)
    text, agrees = verdict(claim, np.array([0.34, 0.50, 0.53, 0.51, 0.48]), bars, x)
    assert agrees and "largest at 0.5 (0.53): rises to it from 0.34; then falls to 0.48" in text
    # the fall within the error bars: 0.53 - 0.525 < 0.005 + 0.005
    text, agrees = verdict(claim, np.array([0.34, 0.50, 0.53, 0.51, 0.525]), bars, x)
    assert not agrees and "does not fall after it beyond the error bars" in text
    # the largest at the last sample: a rise, no maximum inside the series
    text, agrees = verdict(claim, np.array([0.34, 0.50, 0.51, 0.52, 0.53]), bars, x)
    assert not agrees and "the last sample is its largest" in text
    # a top without an error bar of its own (one packing seed) takes the others' root mean
    # square (0.01 here), not zero: a fall of 0.015 is not beyond 0.01 + 0.005
    stds = np.array([0.014, 0.01, 0.0, 0.0, 0.005])
    text, agrees = verdict(claim, np.array([0.341, 0.521, 0.527, 0.528, 0.513]), stds, x)
    assert not agrees and "error bars 0.01 at the top" in text


def test_a_peak_away_from_the_papers_location_differs():
    claim = PaperClaim("rho0", "p", None, "peaks near 0.3 at 0.70", 0.02, peak_at=0.3,
                       peak=0.70)
    values = 0.70 - 0.05 * np.abs(ETA - 0.6)
    text, agrees = verdict(claim, values, np.zeros_like(values), ETA)
    assert not agrees and "peaks at 0.6, not near the paper's 0.3" in text


def test_the_samples_order_is_the_series_order_not_sorted_by_value():
    """The first and last samples are the table's first and last rows (the study's order)."""
    claim = NONCONVEXITY[-1]  # S*: 0.23 -> 0.7
    table = pd.DataFrame({"name": ["a", "b"], "value": [0.0, 0.7], "measured": [0.0, 0.7],
                          claim.column: [0.23, 0.70]})
    comparison = paper_comparison(table, "eta")
    row = comparison[comparison["quantity"] == "S*"].iloc[0]
    assert row["whole_box_agrees"] and row["whole_box"] == "0.23 → 0.7"
    assert row["core"] == "-" and row["core_verdict"] == "no value"


def test_a_parameter_no_paper_covers_gives_an_empty_comparison():
    table = pd.DataFrame({"name": ["a"], "value": [1.0]})
    assert paper_comparison(table, "size_ratio").empty


def test_the_html_report_renders_tables_and_embeds_its_figures(tmp_path):
    matplotlib.use("Agg")
    from matplotlib import pyplot

    figure, axes = pyplot.subplots()
    axes.plot([0, 1], [0, 1])
    figure.savefig(tmp_path / "curves.png")
    pyplot.close(figure)
    text = "# Study\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n![curves](curves.png)\n\n" \
           "![gone](missing.png)\n"
    page = markdown_html(text, tmp_path, "Study <x>")
    assert "<title>Study &lt;x&gt;</title>" in page and "<table>" in page
    assert "<td>1</td>" in page
    embedded = page.split('src="data:image/png;base64,')[1].split('"')[0]
    assert base64.b64decode(embedded) == (tmp_path / "curves.png").read_bytes()
    assert 'src="missing.png"' in page  # a missing figure stays a link


def test_a_core_missing_in_one_sample_is_not_compared():
    """A small box whose first sample has no core: the core's series reads '-' and the
    verdict is the whole box's."""
    claim = NONCONVEXITY[-1]
    table = pd.DataFrame({"name": ["a", "b"], "value": [0.0, 0.7], "measured": [0.0, 0.7],
                          "n_core_initial": [0, 12], claim.column: [0.23, 0.70],
                          claim.core_column: [np.nan, 0.2]})
    comparison = paper_comparison(table, "eta")
    row = comparison[comparison["quantity"] == "S*"].iloc[0]
    assert row["core"] == "-" and row["whole_box_agrees"]
    assert "**agrees** (whole box)" in comparison_markdown(comparison)


def test_one_sample_is_not_judged_along_the_series_and_a_cell_has_no_core_column():
    """A study with its first sample ended: the first value is read against the paper's, the
    series' claims are 'not judged' (never 'agrees' on nothing); a periodic cell's table has
    no core column and names the whole cell."""
    table = _as_the_paper(NONCONVEXITY, ETA)[:1]
    comparison = paper_comparison(table, "eta")
    assert not comparison["whole_box_agrees"].any()
    by_quantity = dict(zip(comparison["quantity"], comparison["whole_box_verdict"],
                           strict=True))
    assert by_quantity["Z_c0"].startswith("first as the paper's 6")  # spheres: read
    assert "not judged" in by_quantity["Z_c0"] and "not judged" in by_quantity["S*"]
    box = comparison_markdown(comparison)
    cell = comparison_markdown(comparison, cell=True)
    assert "**agrees**" not in box and "**not judged** (core)" in box
    assert cell.splitlines()[0] == "| quantity | paper | grainlab, whole cell | verdict |"
    assert all(line.count("|") == 5 for line in cell.splitlines())
    assert "**not judged** (whole cell)" in cell and "core" not in cell
