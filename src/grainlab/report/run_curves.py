"""The curves of a discrete run (``curves.png``): the shear response from its start, or the
compaction, with labels in units and a title that states the run.

Works on the test-result format: the columns of :mod:`grainlab.result.columns`, the run's
``stage`` column and its metadata (specimen and config).
"""

from __future__ import annotations

import pandas as pd
from matplotlib.figure import Figure

from grainlab.lab.run_config import current_layout
from grainlab.prep.sample_shapes import particles_text
from grainlab.report.curves import new_figure_axes
from grainlab.result.columns import unit_of
from grainlab.result.test_result import TestResult

LABELS = {
    "eps_q": r"$\varepsilon_q = \varepsilon_1 - \varepsilon_3$",
    "q_over_trace": r"$q/p = (\sigma_1 - \sigma_3)/\mathrm{tr}\,\sigma$",
    "eps_vol": r"$\varepsilon_\mathrm{vol}$ (compression > 0)",
    "packing_fraction": "packing fraction",
    "time": "time",
    "p": "p",
    "z_no_rattlers": "z without rattlers",
}
"""Axis labels of the columns drawn (the unit is added from the column registry)."""


def axis_text(column: str) -> str:
    """``label [unit]`` of a column (unit from the registry, ``-`` for a pure number)."""
    unit = unit_of(column) or "-"
    return f"{LABELS.get(column, column)} [{unit}]"


def run_title(result: TestResult) -> str:
    """One line stating the run: particles, test, stress, friction, inertia bound, seed."""
    meta = result.metadata
    specimen = meta.get("specimen", {})
    config, _ = current_layout(meta.get("parameters", {}).get("config", {}))
    test = config.get("test", {})
    shear = config.get("solver", {}).get("shear", {})
    shape = particles_text(specimen)
    parts = [f"{specimen.get('n_particles', '?')} {shape}".strip(),
             str(test.get("kind", meta.get("title", "")))]
    if "sigma0" in test:
        parts.append(rf"$\sigma_0$ = {test['sigma0'] / 1e3:g} kPa")
    if test.get("kind") == "compaction":
        shear = {}  # the shear's friction and inertia bound play no part
    if "friction" in shear:
        parts.append(rf"$\mu$ = {shear['friction']:g}")
    if "inertia_number" in shear:
        parts.append(f"I ≤ {shear['inertia_number']:g}")
    if "seed" in specimen:
        parts.append(f"seed {specimen['seed']}")
    return ", ".join(parts)


def shear_from_its_start(table: pd.DataFrame) -> pd.DataFrame:
    """The rows after the compaction, led by the compaction's last row as the state at zero
    strain (every ``eps_*`` and ``gamma_*`` column 0: the strains of the stages after the
    compaction are counted from its end)."""
    shear = table[table["stage"] != "compaction"]
    compaction = table[table["stage"] == "compaction"]
    if len(compaction) == 0 or len(shear) == 0:
        return shear.reset_index(drop=True)
    start = compaction.iloc[[-1]].copy()
    for column in start.columns:
        if str(column).startswith(("eps_", "gamma_")):
            start[column] = 0.0
    return pd.concat([start, shear], ignore_index=True)


def discrete_curves_figure(result: TestResult) -> Figure:
    """curves.png of a discrete run: q/p, eps_vol and the packing fraction against eps_q from
    the start of the shear, or (a compaction alone) the packing fraction, p and z against
    time; no legend (one curve per axes), the run stated in the title."""
    table = result.table
    has_stages = "stage" in table.columns
    shear = shear_from_its_start(table) if has_stages else table
    figure, axes = new_figure_axes(1, 3, figsize=(13.0, 4.0))
    if len(shear) > 1 and "eps_q" in shear.columns:
        x, columns, data = "eps_q", ("q_over_trace", "eps_vol", "packing_fraction"), shear
    else:
        x, columns, data = "time", ("packing_fraction", "p", "z_no_rattlers"), table
    for ax, column in zip(axes, columns, strict=True):
        if column in data.columns:
            ax.plot(data[x], data[column], color="C0")
        ax.set_xlabel(axis_text(x))
        ax.set_ylabel(axis_text(column))
        ax.grid(alpha=0.3)
    if x == "eps_q":
        for ax in axes:
            ax.set_xlim(left=0.0)
    figure.suptitle(run_title(result), fontsize="medium")
    figure.set_layout_engine("tight")
    return figure
