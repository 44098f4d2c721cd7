"""The figures of a study, against its shape parameter, as seeds 002 and 003 draw them: every
residual value with its standard deviation over the residual window as an error bar.

Each function takes the study's summary table (:mod:`grainlab.study.study_summary`: one row
per sample, columns ``X_initial``, ``X_residual``, ``X_residual_std``, ``q_over_trace_peak``
...) and the shape parameter's symbol, and returns a figure, or None when the table holds none
of its columns (a study without snapshots has no microstructure figures).

The walls of a small box order the particles next to them; the microstructure figures draw the
**core's** values (``X_core``, the particles at least a stated margin from every wall:
:mod:`grainlab.analysis.wall_layer`) wherever the summary has them, and say so in their
labels; the packing fraction and the connectivity draw the whole box beside the core.

The figures of the seeds each one draws are :data:`PAPER_FIGURES` (the report's headings
name them).

:func:`stress_dilatancy_figure` draws the peak state (the summary's ``M_at_peak``, from the
snapshot nearest the peak) beside the residual one where the summary has it. The friction
mobilisation index of seed 003 eq. 34 has no figure of its own in the paper.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from grainlab.report.curves import new_figure_axes

ANISOTROPIES = (
    ("a_c", "$a_c$"), ("a_c_branch", "$a'_c$"), ("a_ln", "$a_{ln}$"), ("a_lt", "$a_{lt}$"),
    ("a_ln_branch", "$a_{ln'}$"), ("a_fn", "$a_n$"), ("a_ft", "$a_t$"),
    ("a_fn_branch", "$a'_n$"), ("a_ft_branch", "$a'_t$"))
"""The anisotropies of seeds 002 (eqs. 16-26) and 003, summary column stem and label."""

STRESS_DILATANCY = (("q_over_trace_27a", "eq. 27a"), ("q_over_trace_27b", "eq. 27b"),
                    ("q_over_trace_B1", "eq. B1"))
"""q/p predicted from the anisotropies (seed 002 eqs. 27a, 27b, B1)."""

CONTACT_TYPE_ORDER = ("point", "fv", "ee", "fe", "ff", "s", "ds", "d", "t", "q", "m")
"""Contact types in the papers' order (002: fv, ee, fe, ff; 003: s, ds, d, t, q and m for
five or more)."""


def core_stem(table: pd.DataFrame, stem: str) -> tuple[str, str]:
    """``stem + "_core"`` and the label suffix " (core)" where the table holds the core's
    values of ``stem``, else ``stem`` and ""."""
    core = f"{stem}_core"
    if any(_has(table, f"{core}_{state}") for state in ("residual", "initial")):
        return core, " (core)"
    return stem, ""


def _x(table: pd.DataFrame) -> np.ndarray:
    return table["measured"].to_numpy(float)


def _has(table: pd.DataFrame, column: str) -> bool:
    return column in table and np.isfinite(table[column].to_numpy(float)).any()


def _errorbar(ax, table: pd.DataFrame, stem: str, label: str, marker: str = "o",
              state: str = "residual", core: bool = True) -> bool:
    """Plot ``stem_state`` (with ``stem_state_std`` as error bars where it exists) against
    the shape parameter, the core's values where the table has them (``core``); False when
    the column is missing."""
    if core:
        stem, suffix = core_stem(table, stem)
        label += suffix
    column = f"{stem}_{state}"
    if not _has(table, column):
        return False
    std = table.get(f"{column}_std")
    ax.errorbar(_x(table), table[column].to_numpy(float),
                yerr=None if std is None else std.to_numpy(float), marker=marker,
                capsize=3, label=label)
    return True


def _one_per_run(ax, table: pd.DataFrame, column: str, fmt: str, label: str, **style) -> None:
    """Plot ``column``, a value with one number per run (an initial state, a peak), against
    the shape parameter, with the spread over the packing seeds (``column_std`` of a pooled
    row: :func:`~grainlab.study.study_summary.pooled_replicas`) as error bars where a point
    has one; a point of one run has none."""
    std = table.get(f"{column}_std")
    yerr = None
    if std is not None and np.isfinite(std.to_numpy(float)).any():
        yerr = np.nan_to_num(std.to_numpy(float), nan=0.0)
    ax.errorbar(_x(table), table[column].to_numpy(float), yerr=yerr, fmt=fmt, capsize=3,
                label=label, **style)


def _finish(figure: Figure, axes: Sequence, symbol: str) -> Figure:
    for ax in axes:
        ax.set_xlabel(symbol)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    figure.tight_layout()
    return figure


EPS_VOL_SIGN = ("compression > 0: the opposite sign to seed 002 Fig. 7,\n"
                "whose $\\varepsilon_p$ = ln(V/V$_0$) grows as the sample dilates")
"""The note the volume-change panel carries."""


def curves_figure(curves: dict[str, pd.DataFrame], labels: dict[str, str]) -> Figure | None:
    """q/p, the volumetric strain eps_vol (compression > 0, the opposite sign to seed 002's
    eps_p: the panel says so, :data:`EPS_VOL_SIGN`) and the packing fraction against eps_q,
    one line per sample (seed 002 Figs. 5, 7; seed 003 Figs. 3, 5). ``curves``: each
    sample's shear rows (from the end of the compaction,
    :func:`~grainlab.report.run_curves.shear_from_its_start`)."""
    if not curves:
        return None
    figure, axes = new_figure_axes(1, 3, figsize=(13.0, 3.8))
    for name, table in curves.items():
        for ax, column in zip(axes, ("q_over_trace", "eps_vol", "packing_fraction"),
                              strict=True):
            if column in table:
                ax.plot(table["eps_q"], table[column], label=labels.get(name, name), lw=1)
    for ax, text in zip(axes, ("q/p", "$\\varepsilon_{vol}$ (compression > 0)",
                               "packing fraction"), strict=True):
        ax.set_xlabel("$\\varepsilon_q$")
        ax.set_ylabel(text)
        ax.grid(alpha=0.3)
    axes[1].set_title(EPS_VOL_SIGN, fontsize=8)
    axes[0].legend(fontsize=7, ncol=2)
    figure.tight_layout()
    return figure


def exponential_saturation(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float] | None:
    """Least-squares fit of seed 002 eq. 12, y = y0 + (y1 - y0)(1 - exp(-x / x_c)); returns
    (y0, y1, x_c) or None with fewer than four finite points or no convergence."""
    from scipy.optimize import curve_fit

    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size < 4 or np.ptp(x) <= 0.0:
        return None

    def model(x, y0, y1, xc):
        return y0 + (y1 - y0) * (1.0 - np.exp(-x / xc))

    try:
        params, _ = curve_fit(model, x, y, p0=(y[np.argmin(x)], y.max(), 0.4 * np.ptp(x)),
                              bounds=([-np.inf, -np.inf, 1e-6 * np.ptp(x)],
                                      [np.inf, np.inf, 1e3 * np.ptp(x)]), maxfev=5000)
    except (RuntimeError, ValueError):
        return None
    return float(params[0]), float(params[1]), float(params[2])


def strength_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """(q/p) at the peak and in the residual state; the friction angle phi* with seed 002 eq.
    12's exponential fit (seed 002 Fig. 6; seed 003 Fig. 4)."""
    if not _has(table, "q_over_trace_peak") and not _has(table, "q_over_trace_residual"):
        return None
    figure, (left, right) = new_figure_axes(1, 2, figsize=(10.0, 3.8))
    if _has(table, "q_over_trace_peak"):
        _one_per_run(left, table, "q_over_trace_peak", "s-", "peak $(q/p)^+$")
    _errorbar(left, table, "q_over_trace", "residual $(q/p)^*$", core=False)
    left.set_ylabel("q/p")
    if _has(table, "phi_residual"):
        phi = table["phi_residual"].to_numpy(float)
        q = table["q_over_trace_residual"].to_numpy(float)
        dq = table["q_over_trace_residual_std"].to_numpy(float)
        # d phi / d (q/p) = 6 / ((2 + q)^2 cos phi)  (eq. 11), for the error bar
        dphi = 6.0 / ((2.0 + q) ** 2 * np.cos(phi)) * dq
        right.errorbar(_x(table), phi, yerr=dphi, marker="o", capsize=3,
                       label="$\\varphi^*$ (eq. 11)")
        fit = exponential_saturation(_x(table), phi)
        if fit is not None:
            y0, y1, xc = fit
            xs = np.linspace(0.0, np.nanmax(_x(table)), 100)
            right.plot(xs, y0 + (y1 - y0) * (1 - np.exp(-xs / xc)), "--",
                       label=f"eq. 12: {y0:.3f} + ({y1:.3f} - {y0:.3f})"
                             f"(1 - exp(-x/{xc:.3g}))")
        right.set_ylabel("$\\varphi^*$ [rad]")
    return _finish(figure, (left, right), symbol)


def _initial_residual(table: pd.DataFrame, symbol: str, stems: Sequence[tuple[str, str]],
                      ylabel: str) -> Figure | None:
    """Initial and residual values of each (column stem, label), as the summary gives them
    (whole box or core: the stems say which; with no core value at all, as in a periodic
    cell, the whole sample's without the words "whole box")."""
    if not any(_has(table, f"{s}_initial") or _has(table, f"{s}_residual") for s, _ in stems):
        return None
    if not any(_has(table, f"{s}_initial") or _has(table, f"{s}_residual")
               for s, _ in stems if "core" in s):  # no core (a periodic cell): no "whole box"
        stems = [(s, label.replace("whole box", "").strip(", ")) for s, label in stems
                 if "core" not in s]
    figure, ax = new_figure_axes()
    markers = "osD^v<>"
    for k, (stem, label) in enumerate(stems):
        if _has(table, f"{stem}_initial"):
            _one_per_run(ax, table, f"{stem}_initial", markers[k % 7] + "--",
                         f"{label} initial".strip(), mfc="none")
        _errorbar(ax, table, stem, f"{label} residual".strip(), marker=markers[k % 7],
                  core=False)
    ax.set_ylabel(ylabel)
    return _finish(figure, (ax,), symbol)


def packing_fraction_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """Packing fraction after the isotropic compaction and in the residual state (seed 002
    Fig. 8: nu0, nu*; seed 003 Fig. 7: rho0, rho*)."""
    return _initial_residual(table, symbol, (("packing_fraction", "whole box"),
                                             ("packing_fraction_core", "core")),
                             "packing fraction")


def connectivity_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """Coordination z and connectivity z_c, initial and residual (seed 002 Fig. 10; seed 003
    Fig. 9); z counts neighbours, z_c contact points (eq. 14); the whole box (the results
    table's z, z_c) beside the core (the snapshots' ``coordination_number_core``,
    ``connectivity_number_core``)."""
    return _initial_residual(table, symbol, (
        ("z", "z, whole box"), ("z_c", "$z_c$, whole box"),
        ("coordination_number_core", "z, core"), ("connectivity_number_core", "$z_c$, core")),
        "z, $z_c$")


def contact_type_columns(table: pd.DataFrame) -> list[str]:
    """The contact types with a proportion ``k_TYPE_residual`` or ``k_TYPE_initial``, in the
    papers' order."""
    found = {c[2:].rsplit("_", 1)[0] for c in table.columns
             if c.startswith("k_") and c.endswith(("_residual", "_initial"))}
    found = {t.removesuffix("_core") for t in found}
    ordered = [t for t in CONTACT_TYPE_ORDER if t in found]
    return ordered + sorted(found - set(ordered))


def contact_types_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """Proportions of the contact types, initial (left) and residual (right) (seed 002 Fig.
    11: fv, ee, fe, ff; seed 003 Fig. 10: s, ds, d, t, q)."""
    types = contact_type_columns(table)
    if not types:
        return None
    figure, axes = new_figure_axes(1, 2, figsize=(10.0, 3.8), sharey=True)
    for ax, state in zip(axes, ("initial", "residual"), strict=True):
        for t in types:
            _errorbar(ax, table, f"k_{t}", t, state=state)
        ax.set_title(f"{state} state")
        ax.set_ylabel("proportion")
    return _finish(figure, axes, symbol)


def anisotropies_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """Fabric, branch-length and force anisotropies in the residual state (seed 002 Figs.
    15-17; seed 003 Figs. 12 (a_c, a'_c), 13 (a_ln, a_lt, a_ln'), 17 (a_n, a'_n), 22 (a_t,
    a'_t))."""
    groups = (ANISOTROPIES[:2], ANISOTROPIES[2:5], ANISOTROPIES[5:])
    if not any(_has(table, f"{s}_residual") for s, _ in ANISOTROPIES):
        return None
    figure, axes = new_figure_axes(1, 3, figsize=(13.0, 3.8))
    titles = ("fabric", "branch lengths", "forces")
    for ax, group, title in zip(axes, groups, titles, strict=True):
        for stem, label in group:
            _errorbar(ax, table, stem, label)
        ax.set_title(title)
    return _finish(figure, axes, symbol)


def sliding_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """Proportion of sliding contacts and the friction mobilisation index in the residual
    state (seed 002 Fig. 19; seed 003 Fig. 19 and eq. 34)."""
    stems = (("sliding_proportion", "sliding proportion"),
             ("mobilisation_index", "mobilisation index"))
    if not any(_has(table, f"{s}_residual") for s, _ in stems):
        return None
    figure, ax = new_figure_axes()
    for stem, label in stems:
        _errorbar(ax, table, stem, label)
    return _finish(figure, (ax,), symbol)


def stress_dilatancy_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """q/p measured and predicted from the anisotropies (seed 002 eqs. 27a, 27b, B1, Fig. 20;
    seed 003 eqs. 35a, 35b, Fig. 23: the same sums): the residual state with its error bars
    and, where the summary has it, the peak state (open markers, one snapshot: ``M_at_peak``).
    """
    if not any(_has(table, f"{s}_residual") for s, _ in STRESS_DILATANCY):
        return None
    figure, ax = new_figure_axes()
    markers = "s^v"
    _errorbar(ax, table, "q_over_trace", "measured $(q/p)^*$")  # the core's, as below
    for k, (stem, label) in enumerate(STRESS_DILATANCY):
        _errorbar(ax, table, stem, f"{label} residual", marker=markers[k])
    for k, (stem, label) in enumerate((("q_over_trace", "measured"), *STRESS_DILATANCY)):
        stem, suffix = core_stem(table, stem)
        column = f"{stem}_at_peak"
        if _has(table, column):
            _one_per_run(ax, table, column, ("o" + markers)[k] + ":", f"{label} peak{suffix}",
                         mfc="none")
    ax.set_ylabel("q/p: residual $(q/p)^*$, peak $(q/p)^+$")
    return _finish(figure, (ax,), symbol)


PARTIAL_ANISOTROPIES = (("a_c_branch", "$a'_c$"), ("a_fn_branch", "$a'_n$"),
                        ("a_ft_branch", "$a'_t$"))
"""The partial anisotropies by contact type in the branch frame (seed 002 eq. 30, Figs.
23-24): summary stem (``<stem>_<type>``) and label."""


def partial_anisotropies_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """Residual fabric, radial and orthoradial force anisotropies of each contact type in the
    branch frame (n', t'), normalised by the totals so that they sum over the types to the
    sample's (seed 002 eq. 30; Fig. 23: a'_c, Fig. 24: a'_n, a'_t)."""
    types = contact_type_columns(table)
    present = [(stem, label) for stem, label in PARTIAL_ANISOTROPIES
               if any(_has(table, f"{stem}_{t}_residual")
                      or _has(table, f"{stem}_{t}_core_residual") for t in types)]
    if not present:
        return None
    figure, axes = new_figure_axes(1, len(present), figsize=(4.4 * len(present), 3.8))
    axes = np.atleast_1d(axes)
    for ax, (stem, label) in zip(axes, present, strict=True):
        for t in types:
            _errorbar(ax, table, f"{stem}_{t}", t)
        ax.set_ylabel(f"partial {label}")
    return _finish(figure, axes, symbol)


def sliding_by_type_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """Residual proportion of sliding contacts of each contact type among all active contacts
    (they sum to the sliding proportion S; seed 003 Fig. 20)."""
    types = [t for t in contact_type_columns(table)
             if _has(table, f"sliding_proportion_{t}_residual")
             or _has(table, f"sliding_proportion_{t}_core_residual")]
    if not types:
        return None
    figure, ax = new_figure_axes()
    for t in types:
        _errorbar(ax, table, f"sliding_proportion_{t}", t)
    ax.set_ylabel("sliding contacts of the type / active contacts")
    return _finish(figure, (ax,), symbol)


def partial_strength_figure(table: pd.DataFrame, symbol: str) -> Figure | None:
    """Residual q/p carried by each contact type (partial stresses; seed 002 Fig. 22, seed
    003 Fig. 18)."""
    types = [t for t in contact_type_columns(table)
             if _has(table, f"q_over_trace_{t}_residual")
             or _has(table, f"q_over_trace_{t}_core_residual")]
    if not types:
        return None
    figure, ax = new_figure_axes()
    for t in types:
        _errorbar(ax, table, f"q_over_trace_{t}", t)
    ax.set_ylabel("partial $(q/p)^*$")
    return _finish(figure, (ax,), symbol)


def wall_profile_figure(profiles: dict[str, tuple[np.ndarray, np.ndarray]],
                        margin: float) -> Figure | None:
    """Packing fraction against the distance h to the nearest wall, in mean diameters, one
    line per sample (``profiles``: label -> (shell edges h / <d_v>, solid fraction of each
    shell), :func:`~grainlab.analysis.wall_layer.solid_profile`), with the core's ``margin``
    [<d_v>] marked: the core is meant to begin where the profiles reach their plateau. None
    without profiles."""
    if not profiles:
        return None
    figure, ax = new_figure_axes()
    for label, (edges, fraction) in profiles.items():
        ax.step(edges[:-1], fraction, where="post", lw=1, label=label)
    ax.axvline(margin, color="k", ls="--", lw=1, label=f"core margin {margin:g} $<d>$")
    ax.set_xlabel("distance to the nearest wall / $<d>$")
    ax.set_ylabel("solid fraction of the shell")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    figure.tight_layout()
    return figure


STUDY_FIGURES = (
    ("strength", strength_figure, "Shear strength"),
    ("packing_fraction", packing_fraction_figure, "Packing fraction"),
    ("connectivity", connectivity_figure, "Coordination and connectivity"),
    ("contact_types", contact_types_figure, "Contact types"),
    ("anisotropies", anisotropies_figure, "Anisotropies"),
    ("sliding", sliding_figure, "Friction mobilisation"),
    ("stress_dilatancy", stress_dilatancy_figure, "Strength from the anisotropies"),
    ("partial_strength", partial_strength_figure, "Strength by contact type"),
    ("partial_anisotropies", partial_anisotropies_figure, "Anisotropies by contact type"),
    ("sliding_by_type", sliding_by_type_figure, "Sliding by contact type"),
)
"""The figures against the shape parameter, in the report's order: (file stem, function,
title)."""


ANGULARITY, NONCONVEXITY = "mean_angularity", "eta"
"""The shape parameters of the seeds' series (seed 002, seed 003)."""

PAPER_FIGURES: dict[str, dict[str, str]] = {
    "curves": {ANGULARITY: "seed 002 Figs. 5, 7", NONCONVEXITY: "seed 003 Figs. 3, 5"},
    "strength": {ANGULARITY: "seed 002 Fig. 6, eq. 12's fit", NONCONVEXITY: "seed 003 Fig. 4"},
    "packing_fraction": {ANGULARITY: "seed 002 Fig. 8", NONCONVEXITY: "seed 003 Fig. 7"},
    "connectivity": {ANGULARITY: "seed 002 Fig. 10", NONCONVEXITY: "seed 003 Fig. 9"},
    "contact_types": {ANGULARITY: "seed 002 Fig. 11", NONCONVEXITY: "seed 003 Fig. 10"},
    "anisotropies": {ANGULARITY: "seed 002 Figs. 15-17",
                     NONCONVEXITY: "seed 003 Figs. 12, 13, 17, 22"},
    "sliding": {ANGULARITY: "seed 002 Fig. 19", NONCONVEXITY: "seed 003 Fig. 19"},
    "stress_dilatancy": {ANGULARITY: "seed 002 Fig. 20, eqs. 27a, 27b, B1",
                         NONCONVEXITY: "seed 003 Fig. 23, eqs. 35a, 35b"},
    "partial_strength": {ANGULARITY: "seed 002 Fig. 22", NONCONVEXITY: "seed 003 Fig. 18"},
    "partial_anisotropies": {ANGULARITY: "seed 002 Figs. 23-24"},
    "sliding_by_type": {NONCONVEXITY: "seed 003 Fig. 20"},
    "polar": {ANGULARITY: "seed 002 Fig. 14",
              NONCONVEXITY: "seed 003 insets of Figs. 12, 13, 17, 22"},
    "force_pdfs": {NONCONVEXITY: "seed 003 Figs. 14, 16"},
    "force_network": {ANGULARITY: "seed 002 Figs. 12, 21", NONCONVEXITY: "seed 003 Fig. 15"},
    "mobilised_network": {ANGULARITY: "seed 002 Fig. 18", NONCONVEXITY: "seed 003 Fig. 21"},
    "connectivity_map": {ANGULARITY: "seed 002 Fig. 9"},
}
"""The seeds' figures each report figure draws (file stem -> shape parameter -> figure),
read from the seeds' captions; a stem absent for a series has no counterpart in its paper
(the wall profile has none in either). Seed 002 draws no force PDFs and no sliding by contact
type; seed 003 no partial anisotropies by contact type and no map of the particles'
connectivity. Not drawn here: the papers' snapshots of the packings (002 Fig. 3, 003 Fig. 2)
and seed 003's map of particle velocities (Fig. 6), whose velocities the snapshots do not
keep."""


def seed_figure_words(stem: str, parameter: str) -> str:
    """`` (seed 00N Fig. K)`` for the report figure ``stem`` of a series of ``parameter``,
    or "" where the paper has none (or the study is not one of the seeds' series).

    >>> seed_figure_words("strength", "eta"), seed_figure_words("force_pdfs", "mean_angularity")
    (' (seed 003 Fig. 4)', '')
    """
    figure = PAPER_FIGURES.get(stem, {}).get(parameter)
    return f" ({figure})" if figure else ""


def finite(value: float) -> bool:
    """Whether a summary value can be printed as a number."""
    return value is not None and isinstance(value, int | float) and math.isfinite(value)
