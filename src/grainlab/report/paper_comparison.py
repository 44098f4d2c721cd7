"""A study against its paper, quantity by quantity: what the paper reports, grainlab's values
over the whole box and over the core with their error bars, and a one-line verdict computed
from them (the study report's "Against the papers" table).

A paper's statement about a quantity along its series is one of four kinds, each read from
its text or figures (:data:`PAPER_CLAIMS`; the values are read off the figures by eye, hence a
tolerance per quantity):

* its value at the first sample of the series (spheres) and at the last (the most angular or
  most non-convex shape): ``first``, ``last``;
* its level over every sample but the first (the polyhedra, the aggregates): ``rest``;
* where along the series it peaks, and its value there: ``peak_at``, ``peak``;
* only the direction it moves along the series: ``trend`` ("rises" or "falls"), or that it
  rises to a maximum inside the series and falls after it (:data:`RISES_THEN_FALLS`).

Each is checked on grainlab's values of the same samples, in the study's order: a value
agrees when it lies within ``tolerance + 2 std`` of the paper's (std: the standard deviation
over the residual window, the error bar of the papers' figures; none for an initial state); a
trend agrees when the last sample's value differs from the first's by more than their error
bars in the paper's direction; a peak agrees when the sample of the largest value lies within
``peak_tolerance`` of the paper's location; a rise then fall agrees when the largest value
lies above both the first and the last by more than their error bars. A value without an
error bar of its own there (a peak of one packing seed) takes the root mean square of the
others' (the seeds' spread of the shapes run on several packings), so that one seed's peak
is not read as exact. The verdict names what agrees and, for what does
not, by how much and in which direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

RISES_THEN_FALLS = "rises, then falls"
"""The ``trend`` of a quantity that rises to a maximum inside the series, then falls."""


@dataclass(frozen=True)
class PaperClaim:
    """What a paper reports of one quantity along its series (module docstring).

    ``column``: the summary's whole-box column (``..._initial`` or ``..._residual``; its
    ``_std`` column gives the error bar where it exists); ``core_column``: the same over the
    core (None where the summary has none)."""

    quantity: str
    column: str
    core_column: str | None
    paper: str
    tolerance: float
    first: float | None = None
    last: float | None = None
    rest: float | None = None
    peak_at: float | None = None
    peak: float | None = None
    peak_tolerance: float = 0.15
    trend: str | None = None


ANGULARITY = (
    PaperClaim("(q/p)+", "q_over_trace_peak", None,
               "rises with <α> to a maximum, then falls for the most angular shapes", 0.0,
               trend=RISES_THEN_FALLS),
    PaperClaim("(q/p)*", "q_over_trace_residual", "q_over_trace_core_residual",
               "rises from about 0.2 (spheres) and saturates near 0.4", 0.03,
               first=0.2, last=0.4),
    PaperClaim("φ* [rad]", "phi_residual", None,
               "from about 0.3 (spheres), tending to about 0.5 (eq. 12's fit)", 0.03,
               first=0.3, last=0.5),
    PaperClaim("ν0", "packing_fraction_initial", "packing_fraction_core_initial",
               "peaks near <α> = 0.5, at about 0.75", 0.02, peak_at=0.5, peak=0.75),
    PaperClaim("ν*", "packing_fraction_residual", "packing_fraction_core_residual",
               "falls from 0.58 to 0.54", 0.01, first=0.58, last=0.54),
    PaperClaim("z0", "z_initial", "coordination_number_core_initial",
               "about 6 for spheres (isostatic), rising to a plateau near 8", 0.3, first=6.0,
               last=8.0),
    PaperClaim("z_c0", "z_c_initial", "connectivity_number_core_initial",
               "about 12 for the polyhedra", 0.5, rest=12.0),
    PaperClaim("z*", "z_residual", "coordination_number_core_residual",
               "rises from 4 to 5.5", 0.3, first=4.0, last=5.5),
    PaperClaim("z_c*", "z_c_residual", "connectivity_number_core_residual",
               "rises from 4 to 7", 0.4, first=4.0, last=7.0),
    PaperClaim("sliding proportion*", "sliding_proportion_residual",
               "sliding_proportion_core_residual", "rises to about 0.6", 0.05, last=0.6,
               trend="rises"),
)
"""Seed 002 (Azéma, Radjaï & Dubois 2013, 40 000 particles), against <α>."""

NONCONVEXITY = (
    PaperClaim("(q/p)+", "q_over_trace_peak", None, "rises with η", 0.0, trend="rises"),
    PaperClaim("(q/p)*", "q_over_trace_residual", "q_over_trace_core_residual",
               "rises with η at a decreasing rate", 0.02, trend="rises"),
    PaperClaim("ρ0", "packing_fraction_initial", "packing_fraction_core_initial",
               "peaks near η = 0.3, at about 0.70", 0.02, peak_at=0.3, peak=0.70),
    PaperClaim("ρ*", "packing_fraction_residual", "packing_fraction_core_residual",
               "falls to about 0.55 at η = 0.7", 0.015, last=0.55),
    PaperClaim("Z_c0", "z_c_initial", "connectivity_number_core_initial",
               "about 6 for spheres, about 12 for the aggregates", 0.5, first=6.0, rest=12.0),
    PaperClaim("Z_c*", "z_c_residual", "connectivity_number_core_residual",
               "rises from 3.5 to 5.5", 0.3, first=3.5, last=5.5),
    PaperClaim("a_c*", "a_c_residual", "a_c_core_residual",
               "rises from 0.2 to about 0.3", 0.03, first=0.2, last=0.3),
    PaperClaim("S*", "sliding_proportion_residual", "sliding_proportion_core_residual",
               "rises from 0.23 to 0.7", 0.05, first=0.23, last=0.7),
)
"""Seed 003 (Azéma, Radjaï, Saint-Cyr, Delenne & Sornay 2013, 12 000 aggregates), against
η."""

PAPER_CLAIMS = {"mean_angularity": ANGULARITY, "eta": NONCONVEXITY}
"""The claims of each preset series' paper, by the study's parameter."""


def _series(table: pd.DataFrame, column: str | None) -> tuple[np.ndarray, np.ndarray] | None:
    """(values, error bars) of a summary column in the table's order; None where absent."""
    if column is None or column not in table:
        return None
    values = pd.to_numeric(table[column], errors="coerce").to_numpy(dtype=float)
    if not np.isfinite(values).any():
        return None
    std_column = f"{column}_std"
    stds = pd.to_numeric(table[std_column], errors="coerce").to_numpy(dtype=float) \
        if std_column in table else np.zeros_like(values)
    return values, np.where(np.isfinite(stds), stds, 0.0)


def _against(value: float, std: float, paper: float, tolerance: float, where: str) -> str:
    """'first 0.26 ± 0.02 as 0.2' or 'first above 0.2 by 0.06'."""
    if not math.isfinite(value):
        return f"{where}: no value"
    gap = value - paper
    if abs(gap) <= tolerance + 2.0 * std:
        return f"{where} as the paper's {paper:g}"
    return f"{where} {'above' if gap > 0 else 'below'} the paper's {paper:g} by {abs(gap):.3g}"


ONE_SAMPLE = "one sample: the series is not judged yet"
"""The verdict's words where a study has one sample ended (a series still running)."""


def verdict(claim: PaperClaim, values: np.ndarray, stds: np.ndarray,
            parameter: np.ndarray) -> tuple[str, bool]:
    """(the one-line verdict on ``values`` (and their error bars ``stds``) of the samples at
    ``parameter``, whether every part of the claim agrees)."""
    if len(values) < 2 and claim.first is None:
        return ONE_SAMPLE, False
    parts, agree = [], True
    checks = []
    if len(values) < 2:  # the first sample only: the rest of the claim waits for the series
        check = _against(values[0], stds[0], claim.first, claim.tolerance, "first")
        return f"{check}; {ONE_SAMPLE}", False
    if claim.first is not None:
        checks.append(_against(values[0], stds[0], claim.first, claim.tolerance, "first"))
    if claim.last is not None:
        checks.append(_against(values[-1], stds[-1], claim.last, claim.tolerance, "last"))
    if claim.rest is not None and len(values) > 1:
        rest, rest_std = values[1:], stds[1:]
        finite = np.isfinite(rest)
        mean = float(np.mean(rest[finite])) if finite.any() else math.nan
        spread = float(np.max(rest_std[finite])) if finite.any() else 0.0
        checks.append(_against(mean, spread, claim.rest, claim.tolerance,
                               "the others (mean)"))
    for check in checks:
        agree &= " as the paper's " in check
    parts += checks
    if claim.trend == RISES_THEN_FALLS:
        text, follows = _rise_then_fall(values, stds, parameter)
        agree &= follows
        parts.append(text)
    elif claim.trend is not None:
        change = values[-1] - values[0]
        bar = stds[-1] + stds[0]
        sign = 1.0 if claim.trend == "rises" else -1.0
        follows = math.isfinite(change) and sign * change > bar
        agree &= follows
        parts.append(f"{claim.trend} as the paper's ({values[0]:.3g} → {values[-1]:.3g})"
                     if follows else f"does not {claim.trend[:-1]} beyond its error bars "
                                     f"({values[0]:.3g} → {values[-1]:.3g})")
    if claim.peak_at is not None:
        finite = np.isfinite(values)
        if finite.any():
            k = int(np.nanargmax(values))
            located = abs(parameter[k] - claim.peak_at) <= claim.peak_tolerance
            agree &= located
            parts.append(f"peaks at {parameter[k]:.2g}" + (
                " as the paper's" if located else f", not near the paper's {claim.peak_at:g}"))
            if claim.peak is not None:
                check = _against(values[k], stds[k], claim.peak, claim.tolerance, "its peak")
                agree &= " as the paper's " in check
                parts.append(check)
        else:
            agree = False
            parts.append("no value")
    return "; ".join(parts), agree


def _rise_then_fall(values: np.ndarray, stds: np.ndarray,
                    parameter: np.ndarray) -> tuple[str, bool]:
    """(words, whether the largest value lies inside the series above the first and the
    last by more than their error bars); a value without a bar of its own takes the root
    mean square of the others' (module docstring)."""
    finite = np.isfinite(values)
    if not finite.any():
        return "no value", False
    given = stds[np.isfinite(stds) & (stds > 0)]
    fill = float(np.sqrt(np.mean(given ** 2))) if given.size else 0.0
    bars = np.where(np.isfinite(stds) & (stds > 0), stds, fill)
    k = int(np.nanargmax(values))
    rises = k > 0 and values[k] - values[0] > bars[k] + bars[0]
    falls = k < len(values) - 1 and values[k] - values[-1] > bars[k] + bars[-1]
    top = f"largest at {parameter[k]:.2g} ({values[k]:.3g})"
    rise = "rises to it from" if rises else "not above, beyond the error bars,"
    fall = ("then falls to" if falls else
            "the last sample is its largest" if k == len(values) - 1 else
            "does not fall after it beyond the error bars, to")
    return (f"{top}: {rise} {values[0]:.3g}; {fall}"
            + ("" if k == len(values) - 1 and not falls else f" {values[-1]:.3g}")
            + (f" (error bars {bars[k]:.2g} at the top, {bars[-1]:.2g} at the last)"
               if not falls and k < len(values) - 1 else "")), rises and falls


def _shown(series: tuple[np.ndarray, np.ndarray] | None) -> str:
    """'first ± std → last ± std' of a series, for the table."""
    if series is None:
        return "-"
    values, stds = series

    def one(k: int) -> str:
        if not math.isfinite(values[k]):
            return "-"
        return f"{values[k]:.3g} ± {stds[k]:.2g}" if stds[k] > 0 else f"{values[k]:.3g}"

    return one(0) if len(values) == 1 else f"{one(0)} → {one(-1)}"


def paper_comparison(table: pd.DataFrame, parameter: str) -> pd.DataFrame:
    """The comparison of a study's summary ``table`` (its rows in the series' order) with the
    paper of its ``parameter`` (:data:`PAPER_CLAIMS`): one row per quantity with the paper's
    statement, grainlab's first → last values over the whole box and over the core (± the
    residual window's standard deviation), the verdict on each, and whether the core agrees.
    The core's series counts only where every sample has a core (``n_core_initial`` > 0) and
    a value; else its column reads "-". An empty table for a parameter no paper covers."""
    claims = PAPER_CLAIMS.get(parameter, ())
    column = "measured" if "measured" in table else "value"
    x = pd.to_numeric(table[column], errors="coerce").to_numpy(dtype=float) \
        if column in table else np.arange(len(table), dtype=float)
    rows = []
    core_held = "n_core_initial" not in table or bool(
        (pd.to_numeric(table["n_core_initial"], errors="coerce") > 0).all())
    for claim in claims:
        whole, core = _series(table, claim.column), _series(table, claim.core_column)
        if core is not None and not (core_held and np.isfinite(core[0]).all()):
            core = None  # a sample without a core: the core's series is not comparable
        row = {"quantity": claim.quantity, "paper": claim.paper,
               "whole_box": _shown(whole), "core": _shown(core)}
        for name, series in (("whole_box", whole), ("core", core)):
            if series is None:
                row[f"{name}_verdict"], row[f"{name}_agrees"] = "no value", False
            else:
                row[f"{name}_verdict"], row[f"{name}_agrees"] = verdict(claim, *series, x)
        rows.append(row)
    return pd.DataFrame(rows, columns=["quantity", "paper", "whole_box", "core",
                                       "whole_box_verdict", "whole_box_agrees",
                                       "core_verdict", "core_agrees"])


def comparison_markdown(comparison: pd.DataFrame, cell: bool = False) -> str:
    """The comparison as a Markdown table: quantity, paper, whole box, core, verdict (the
    core's, where the core has values: the bulk, free of the wall layer). A periodic
    ``cell`` has no walls and no core: quantity, paper, whole cell, verdict."""
    whole = "whole cell" if cell else "whole box"
    lines = ([f"| quantity | paper | grainlab, {whole} | verdict |", "|---|---|---|---|"]
             if cell else
             [f"| quantity | paper | grainlab, {whole} | grainlab, core | verdict |",
              "|---|---|---|---|---|"])
    for _, row in comparison.iterrows():
        use_core = row["core"] != "-" and not cell
        text = row["core_verdict"] if use_core else row["whole_box_verdict"]
        mark = "agrees" if (row["core_agrees"] if use_core else row["whole_box_agrees"]) \
            else "not judged" if ONE_SAMPLE in text else "differs"
        core = "" if cell else f"{row['core']} | "
        lines.append(f"| {row['quantity']} | {row['paper']} | {row['whole_box']} | {core}"
                     f"**{mark}** ({'core' if use_core else whole}): {text} |")
    return "\n".join(lines)
