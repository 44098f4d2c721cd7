"""The reading and report of a size check (:mod:`grainlab.study.size_check`): the walls'
values against the periodic cell's, quantity by quantity (:func:`convergence_verdicts`), and
``size_check.md`` in the check's folder: one table per sample with every quantity at every
size (whole box / core in the walls, the periodic cell, the paper), a verdict per quantity,
and a figure per sample (``size_check-<sample>.png``): each quantity against the particles
per sample, the walls' whole box and core with their error bars, the cell's value as a band
and the paper's as a dashed line.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from grainlab.report.curves import new_figure_axes, save_figure

REPORT = "size_check.md"

CAPPED_BOUND = 0.02
"""The share of a run's steps that may end at the solver's sweep cap before the report says
its values come from unsolved steps."""


def _bar(std: float) -> float:
    return std if math.isfinite(std) else 0.0


def _within(value: float, std: float, ref: float, ref_std: float) -> bool:
    """Whether ``value`` lies within the two error bars of ``ref`` (each two standard
    deviations; a value without one, an initial state, by its own at 0)."""
    return abs(value - ref) <= 2.0 * (_bar(std) + _bar(ref_std))


def convergence_verdicts(table: pd.DataFrame, tolerance: dict[str, float] | None = None,
                         ) -> pd.DataFrame:
    """Quantity by quantity and sample by sample, the walls' values against the cell's (the
    largest cell of the table): ``core_gaps`` and ``whole_gaps``, value minus the cell's at
    each box size (smallest first); ``basis``, "core", or "whole" for a quantity without a
    core value (the peak, read from the walls' stress); ``reaches``, the smallest box size
    whose value on that basis lies within the error bars of the cell (or, for a value
    without error bars, an initial state's, within ``tolerance[quantity]``) and stays there at
    every larger size (0 where none does); ``cell`` and ``cell_std``; ``paper`` and
    ``cell_vs_paper``, the cell's value minus the paper's."""
    tolerance = tolerance or {}
    rows = []
    for (sample, quantity), group in table.groupby(["sample", "quantity"], sort=False):
        cells = group[group["boundary"] == "periodic"].sort_values("n")
        walls = group[group["boundary"] == "walls"].sort_values("n")
        if not len(cells):
            continue
        cell = cells.iloc[-1]
        ref, ref_std = float(cell["whole"]), float(cell["whole_std"])
        slack = tolerance.get(quantity, 0.0)
        core_gaps = (walls["core"] - ref).to_numpy(float)
        whole_gaps = (walls["whole"] - ref).to_numpy(float)
        basis = "core" if np.isfinite(core_gaps).any() else "whole"
        gaps = core_gaps if basis == "core" else whole_gaps
        close = [math.isfinite(gap) and (_within(value, std, ref, ref_std) or (
            abs(gap) <= slack and not (math.isfinite(std) or math.isfinite(ref_std))))
            for gap, value, std in zip(gaps, walls[basis], walls[f"{basis}_std"],
                                       strict=True)]
        reaches = 0
        for k in range(len(close)):
            if all(close[k:]):
                reaches = int(walls["n"].iloc[k])
                break
        paper = float(cell["paper"])
        rows.append({"sample": sample, "quantity": quantity,
                     "sizes": list(walls["n"].astype(int)), "basis": basis,
                     "core_gaps": core_gaps, "whole_gaps": whole_gaps,
                     "reaches": reaches, "cell": ref, "cell_std": ref_std,
                     "cell_n": int(cell["n"]), "paper": paper,
                     "cell_vs_paper": ref - paper if math.isfinite(paper) else math.nan})
    return pd.DataFrame(rows)


def shrinking(gaps: np.ndarray) -> bool:
    """Whether the box's distance from the cell shrinks as the box grows (its largest size
    closer than its smallest)."""
    gaps = np.abs(np.asarray(gaps, float))
    gaps = gaps[np.isfinite(gaps)]
    return gaps.size >= 2 and gaps[-1] < gaps[0]


def trend_words(gaps: np.ndarray) -> str:
    """How the box's distance from the cell goes as the box grows: "shrinking" (at every
    size), "smaller at the largest size, not at every step", or "not shrinking"."""
    distance = np.abs(np.asarray(gaps, float))
    distance = distance[np.isfinite(distance)]
    if not shrinking(distance):
        return "not shrinking"
    if np.all(np.diff(distance) < 0):
        return "shrinking"
    return "smaller at the largest size, not at every step"


def _pm(value: float, std: float) -> str:
    if not math.isfinite(value):
        return "-"
    return f"{value:.3g} ± {std:.2g}" if math.isfinite(std) and std > 0 else f"{value:.3g}"


def _gaps(gaps) -> str:
    return " → ".join("-" if not math.isfinite(g) else f"{g:+.3g}"
                      for g in np.asarray(gaps, float))


def verdict_text(row: pd.Series) -> str:
    """The one-line reading of a :func:`convergence_verdicts` row."""
    sizes = row["sizes"]
    basis = "core" if row["basis"] == "core" else "whole box (no core value)"
    if not sizes:
        parts = ["no box of walls"]
    elif row["reaches"]:
        parts = [f"{basis} within the cell's error bars from N = {row['reaches']}"]
    else:
        gaps = row["core_gaps"] if row["basis"] == "core" else row["whole_gaps"]
        trend = trend_words(gaps) if len(sizes) > 1 else "one size: no trend"
        parts = [f"{basis} off the cell by {_gaps(gaps)} (N = "
                 f"{', '.join(str(n) for n in sizes)}: {trend})"]
    if sizes and row["basis"] == "core":
        parts.append(f"whole box off by {_gaps(row['whole_gaps'])}")
    if math.isfinite(row["paper"]):
        parts.append(f"cell {row['cell_vs_paper']:+.3g} from the paper's {row['paper']:g}")
    return "; ".join(parts)


def size_check_markdown(table: pd.DataFrame, plan: Any) -> str:
    """The check's tables and verdicts (module docstring) as Markdown; ``plan`` a
    :class:`~grainlab.study.size_check.SizeCheckPlan` (its samples, runs and tolerances)."""
    verdicts = convergence_verdicts(table, plan.tolerances)
    runs = [run for run in plan.runs
            if ((table["boundary"] == run.boundary) & (table["n"] == run.n)).any()]
    lines = []
    if getattr(plan, "cell_from", None) is not None:
        lines += [f"The cell's values are those of the series `{plan.cell_from}` (its samples "
                  "of these names, run with the settings the check gives its own cell).", ""]
    for sample in plan.samples:
        part = table[table["sample"] == sample]
        if not len(part):
            lines += [f"## {sample}", "", "No run of this sample has ended yet.", ""]
            continue
        header = ["quantity"] + [f"walls {r.n}: whole / core" if r.boundary == "walls"
                                 else f"cell {r.n}" for r in runs] + ["paper", "reading"]
        lines += [f"## {sample}", "", "| " + " | ".join(header) + " |",
                  "|" + "---|" * len(header)]
        for quantity, group in part.groupby("quantity", sort=False):
            cells = [quantity]
            for run in runs:
                at = group[(group["boundary"] == run.boundary) & (group["n"] == run.n)]
                if not len(at):
                    cells.append("-")
                    continue
                one = at.iloc[0]
                whole = _pm(one["whole"], one["whole_std"])
                cells.append(f"{whole} / {_pm(one['core'], one['core_std'])}"
                             if run.boundary == "walls" else whole)
            paper = group["paper"].dropna()
            cells.append(f"{paper.iloc[0]:g}" if len(paper) else "-")
            found = verdicts[(verdicts["sample"] == sample)
                             & (verdicts["quantity"] == quantity)] if len(verdicts) else []
            cells.append(verdict_text(found.iloc[0]) if len(found) else "no cell yet")
            lines.append("| " + " | ".join(cells) + " |")
        costs = part.drop_duplicates(["boundary", "n"])
        lines += ["", "Cost per run: " + "; ".join(
            f"{row.boundary} {row.n}: {row.wall_time:.0f} s, {row.capped_share:.1%} of the "
            "steps capped" + (f" (above {CAPPED_BOUND:.0%}: steps not solved to the "
                              "tolerance)" if row.capped_share > CAPPED_BOUND else "")
            for row in costs.itertuples()) + ".", ""]
    return "\n".join(lines)


def size_check_figure(table: pd.DataFrame, sample: str) -> Figure | None:
    """Each quantity of ``sample`` against the particles per sample (module docstring); None
    without a row."""
    part = table[table["sample"] == sample]
    quantities = list(dict.fromkeys(part["quantity"]))
    if not quantities:
        return None
    sizes = sorted(set(int(n) for n in part["n"]))
    ncols = min(4, len(quantities))
    nrows = math.ceil(len(quantities) / ncols)
    figure, axes = new_figure_axes(nrows, ncols, figsize=(3.2 * ncols, 2.7 * nrows),
                                   squeeze=False)
    for ax, quantity in zip(axes.ravel(), quantities, strict=False):
        group = part[part["quantity"] == quantity]
        walls = group[group["boundary"] == "walls"].sort_values("n")
        cells = group[group["boundary"] == "periodic"].sort_values("n")
        if len(walls):
            ax.errorbar(walls["n"], walls["whole"], yerr=walls["whole_std"].fillna(0.0),
                        fmt="o", mfc="none", color="C0", capsize=2, label="walls, whole box")
            ax.errorbar(walls["n"], walls["core"], yerr=walls["core_std"].fillna(0.0),
                        fmt="s", color="C1", capsize=2, label="walls, core")
        if len(cells):
            cell = cells.iloc[-1]
            bar = 2.0 * (cell["whole_std"] if math.isfinite(cell["whole_std"]) else 0.0)
            ax.axhspan(cell["whole"] - bar, cell["whole"] + bar, color="C2", alpha=0.25)
            ax.axhline(cell["whole"], color="C2", label=f"periodic cell, N = {cell['n']}")
        paper = group["paper"].dropna()
        if len(paper):
            ax.axhline(paper.iloc[0], color="k", ls="--", lw=1, label="paper")
        ax.set_xscale("log")
        ax.set_xticks(sizes, [str(n) for n in sizes])
        ax.set_xticks([], minor=True)
        ax.set_xlim(min(sizes) / 1.3, max(sizes) * 1.3)
        ax.set_title(quantity, fontsize=9)
        ax.set_xlabel("particles per sample", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in axes.ravel()[len(quantities):]:
        ax.set_visible(False)
    legend = {}
    for ax in axes.ravel()[:len(quantities)]:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    handles, labels = list(legend.values()), list(legend)
    figure.legend(handles, labels, loc="lower center", ncol=4, fontsize=8,
                  bbox_to_anchor=(0.5, -0.02))
    figure.suptitle(f"{sample}: the box's values against the periodic cell's "
                    "(error bars: std over the residual window)", fontsize=10)
    figure.tight_layout(rect=(0, 0.05, 1, 0.97))
    return figure


_MARGIN_COLUMNS = (("packing_fraction", "packing fraction", ("packing_fraction_initial",)),
                   ("coordination_number", "z", ("z_initial",)),
                   ("connectivity_number", "z_c", ("z_c_initial",)))
"""The core's values after the compaction read at several margins, and the summary columns
whose cell value they compare with."""


def margin_markdown(margins: pd.DataFrame, table: pd.DataFrame, sample: str) -> list[str]:
    """The lines of ``sample``'s table of the walls' cores after the compaction at several
    margins (:func:`~grainlab.study.size_check.margin_table`), with the cell's value; none
    without a row."""
    part = margins[margins["sample"] == sample] if len(margins) else margins
    if not len(part):
        return []
    values = sorted(set(float(m) for m in part["margin"]))
    lines = [f"### {sample}: the core after the compaction at other margins", "",
             "The packing fraction is the solid inside the core's box (each particle's "
             "volume-equivalent sphere cut by its faces); z and z_c count the core "
             "particles' contacts (centres at least the margin from every wall). A core "
             "whose edge cuts through the wall layer (the first layer within about the "
             "largest diameter of a wall) departs from the bulk; past the layer the values "
             "settle. In brackets: the particles in the core.", "",
             "| walls | quantity | " + " | ".join(f"{m:g} <d>" for m in values)
             + " | cell |", "|" + "---|" * (len(values) + 3)]
    cells = table[(table["sample"] == sample) & (table["boundary"] == "periodic")]
    for n, run in part.groupby("n", sort=True):
        run = run.set_index("margin")
        spheres = np.allclose(run["connectivity_number"], run["coordination_number"],
                              equal_nan=True)
        for column, words, sources in _MARGIN_COLUMNS:
            if column == "connectivity_number" and spheres:
                continue  # spheres: z_c is z, one row
            if column == "coordination_number" and spheres:
                words, sources = "z = z_c", ("z_initial", "z_c_initial")
            row = [f"{n}", words]
            for m in values:
                value = run.loc[m, column] if m in run.index else math.nan
                count = f" ({int(run.loc[m, 'n_core'])})" if column == "packing_fraction" \
                    and m in run.index else ""
                row.append(f"{value:.3g}{count}" if math.isfinite(value) else f"-{count}")
            cell = cells[cells["column"].isin(sources)]
            row.append(f"{float(cell['whole'].iloc[0]):.3g}" if len(cell) else "-")
            lines.append("| " + " | ".join(row) + " |")
    return [*lines, ""]


def write_size_check_report(folder: str | Path, plan: Any,
                            table: pd.DataFrame, margins: pd.DataFrame | None = None) -> Path:
    """``size_check.md`` and the figures in ``folder``, with the cores at other margins
    where ``margins`` (:func:`~grainlab.study.size_check.margin_table`) is given; returns the
    report's path."""
    folder = Path(folder)
    sizes = ", ".join(f"{r.boundary} {r.n}" for r in plan.runs)
    lines = [f"# Size check: {plan.series}", "",
             f"Samples {', '.join(plan.samples)}; runs {sizes}; length {plan.length}, seed "
             f"{plan.seed}. Written {datetime.now(UTC):%Y-%m-%d %H:%M} UTC.", "",
             "Core: the particles at least the study's core margin from every wall. In the "
             "periodic cell the whole packing is bulk. ± the standard deviation over the "
             "residual window (none for an initial state, whose slack against the cell is the "
             "paper's reading tolerance).", ""]
    lines.append(size_check_markdown(table, plan))
    for sample in plan.samples:
        figure = size_check_figure(table, sample)
        if figure is not None:
            name = f"size_check-{sample}.png"
            save_figure(figure, folder / name)
            lines += [f"![{sample}]({name})", ""]
        if margins is not None:
            lines += margin_markdown(margins, table, sample)
    path = folder / REPORT
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
