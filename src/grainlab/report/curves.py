"""Standard curves from test results: any column against any other, several results overlaid.

Works on the test-result format only, so a theory and a simulation of the same test can be
drawn on the same axes.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from matplotlib.axes import Axes
from matplotlib.figure import Figure

from grainlab.result.test_result import TestResult


def new_figure_axes(nrows: int = 1, ncols: int = 1, figsize=(5.0, 3.8), **subplot_kw):
    """A figure and its axes, made without pyplot (no global state, no GUI backend)."""
    figure = Figure(figsize=figsize)
    return figure, figure.subplots(nrows, ncols, **subplot_kw)


def axis_label(result: TestResult, column: str) -> str:
    """``column [unit]`` using the result's units."""
    unit = result.units.get(column, "")
    return f"{column} [{unit}]" if unit and unit != "-" else column


def plot_curves(
    results: TestResult | Sequence[TestResult],
    x: str,
    y: str,
    ax: Axes | None = None,
    labels: Sequence[str] | None = None,
    **style,
) -> Axes:
    """Plot column ``y`` against column ``x`` for one or several results.

    >>> import pandas as pd
    >>> r = TestResult.create(pd.DataFrame({"eps_yy": [0, 1e-3], "q": [0, 5e3]}),
    ...                       specimen={}, load_path={})
    >>> plot_curves(r, "eps_yy", "q").get_ylabel()
    'q [Pa]'
    """
    if isinstance(results, TestResult):
        results = [results]
    if ax is None:
        _, ax = new_figure_axes(figsize=(5.0, 3.8))
    for k, result in enumerate(results):
        label = labels[k] if labels is not None else (result.metadata.get("title") or None)
        ax.plot(result.column(x), result.column(y), label=label, **style)
    ax.set_xlabel(axis_label(results[0], x))
    ax.set_ylabel(axis_label(results[0], y))
    if any(line.get_label() and not line.get_label().startswith("_") for line in ax.lines):
        ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    return ax


def save_figure(figure: Figure, path: str | Path, dpi: int = 150) -> Path:
    """Save a figure (format from the extension: .png, .pdf, .svg)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=dpi, bbox_inches="tight")
    return path
