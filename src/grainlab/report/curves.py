"""Standard curves from test results: any column against any other, several results overlaid.

Works on the test-result format only, so a theory and a simulation of the same test can be
drawn on the same axes.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from grainlab.lab.test_result import TestResult  # noqa: E402


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
        _, ax = plt.subplots(figsize=(5.0, 3.8))
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
    """Save a figure (format from the extension: .png, .pdf, .svg) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(figure)
    return path
