"""The overlay of one lab test run with both discrete solvers (``compare.png``): the test's
main curves, contact dynamics and soft-contact DEM on the same axes with a legend naming each
solver (and the DEM's law and stiffness), the run stated in the title.

What is drawn is data, one entry per test kind (:data:`PANELS`): the x column and the three
y columns. The stages after the compaction are drawn from the compaction's end, at zero
strain (:func:`~grainlab.report.run_curves.shear_from_its_start`); a time axis is counted
from there too (each solver's compaction took its own time).
"""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd
from matplotlib.figure import Figure

from grainlab.lab.solver_comparison import SolverComparison, solver_label
from grainlab.lab.solver_registry import solver_record
from grainlab.report.curves import new_figure_axes
from grainlab.report.run_curves import LABELS, run_title, shear_from_its_start
from grainlab.result.columns import in_dimension, unit_of
from grainlab.result.test_result import TestResult

PANELS: dict[str, tuple[str, tuple[str, str, str]]] = {
    "compaction": ("time", ("packing_fraction", "z", "p")),
    "oedometer": ("eps_zz", ("sigma_zz", "K0", "z")),
    "simple_shear": ("gamma_xz", ("q_over_trace", "eps_vol", "z")),
    "cyclic_shear": ("gamma_xz", ("q_over_trace", "eps_vol", "z")),
    "circular": ("time", ("q_over_trace", "eps_vol", "z")),
}
"""Per test kind: (x column, y columns) of the overlay; the kinds not listed (triaxial,
extension, true_triaxial) draw :data:`SHEAR_PANELS`."""
SHEAR_PANELS = ("eps_q", ("q_over_trace", "eps_vol", "z"))

COMPARISON_LABELS = {**LABELS, "z": "coordination number z", "sigma_zz": r"$\sigma_{zz}$",
                     "sigma_yy": r"$\sigma_{yy}$",
                     "eps_yy": r"$\varepsilon_{yy}$ (compression > 0)",
                     "gamma_xy": r"$\gamma_{xy}$",
                     "K0": r"$K_0 = (\sigma_{xx} + \sigma_{yy}) / (2\sigma_{zz})$",
                     "eps_zz": r"$\varepsilon_{zz}$ (compression > 0)",
                     "gamma_xz": r"$\gamma_{xz}$", "time": "time"}


def _curve_rows(table: pd.DataFrame, kind: str, x: str) -> pd.DataFrame:
    """The rows drawn: the whole compaction, or the stages after it from its end."""
    if kind == "compaction" or "stage" not in table.columns:
        return table
    rows = shear_from_its_start(table)
    if x == "time" and len(rows):
        rows = rows.assign(time=rows["time"] - rows["time"].iloc[0])
    return rows


def _text(column: str) -> str:
    """``label [unit]`` of a column drawn."""
    return f"{COMPARISON_LABELS.get(column, column)} [{unit_of(column) or '-'}]"


def solver_comparison_figure(
        comparison: SolverComparison | Mapping[str, TestResult]) -> Figure:
    """compare.png (module docstring) of a computed :class:`SolverComparison`, or of the
    results ``{"cd": ..., "dem": ...}``: three axes side by side, one line per solver on
    each, a legend on the first. A column a run did not record leaves its line out."""
    if not isinstance(comparison, SolverComparison):
        comparison = SolverComparison().compute(comparison)
    results = comparison.results
    x, columns = PANELS.get(comparison.kind, SHEAR_PANELS)
    names = results[comparison.pair[0]].table.columns  # a 2D run's: vertical y
    x, columns = in_dimension(x, names), tuple(in_dimension(c, names) for c in columns)
    figure, axes = new_figure_axes(1, len(columns), figsize=(13.0, 4.0))
    for method, colour in zip(comparison.pair, ("C0", "C3"), strict=True):
        rows = _curve_rows(results[method].table, comparison.kind, x)
        for ax, column in zip(axes, columns, strict=True):
            if x in rows.columns and column in rows.columns:
                ax.plot(rows[x], rows[column], color=colour, marker=".", ms=3, lw=1.2,
                        label=solver_label(results[method]))
    for ax, column in zip(axes, columns, strict=True):
        ax.set_xlabel(_text(x))
        ax.set_ylabel(_text(column))
        ax.grid(alpha=0.3)
    if axes[0].lines:
        axes[0].legend(fontsize="small")
    titles = " and ".join(solver_record(m).title for m in comparison.pair)
    figure.suptitle(f"{run_title(results[comparison.pair[0]])}: {titles}", fontsize="medium")
    figure.set_layout_engine("tight")
    return figure
