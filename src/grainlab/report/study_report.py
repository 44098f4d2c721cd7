"""The report of a study: ``report/report.md`` in the study folder with its figures as PNG
files beside it, readable without grainlab (any Markdown viewer, or as plain text), and the
same as one HTML file with the figures inline (``report/report.html``).

It holds: what the study is (series, protocol, window), a table of every sample (its outcome
and cost, the peak and residual values with their standard deviations over the window), the
papers' values for the same series where the study is one of the presets (a table, quantity
by quantity, with a verdict: :mod:`grainlab.report.paper_comparison`), the figures of
:mod:`grainlab.report.study_figures`, the packing fraction against the distance to the walls,
and for the first, middle and last sample: the polar diagrams of the angular distributions
with their harmonic fits (seed 002 Fig. 14) and the PDFs of normal and radial forces (seed 003
Figs. 14, 16), both averaged over the residual window's snapshots for the core's contacts,
and the radial-force networks at the end of their runs (seed 002 Figs. 12, 18, 21; seed 003
Fig. 15).
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from functools import partial
from pathlib import Path

import pandas as pd

from grainlab.report.curves import save_figure
from grainlab.report.study_figures import STUDY_FIGURES, curves_figure, finite, seed_figure_words

REPORT = "report"

PAPERS = {
    "mean_angularity": (
        "Azéma, Radjaï & Dubois 2013 (seed 002), 40 000 particles: (q/p)* rises from about "
        "0.2 (spheres) and saturates near 0.4; (q/p)+ at the peak rises with <alpha> to a "
        "maximum, then falls for the most angular shapes; phi* follows eq. 12 with "
        "alpha_c ~ 0.4; nu0 peaks near "
        "<alpha> = 0.5, nu* falls from 0.58 to 0.54; z0 about 6 for spheres and z_c0 about 12 "
        "for polyhedra; residual z from 4 to 5.5 and z_c from 4 to 7; sliding proportion up "
        "to 0.6."),
    "eta": (
        "Azéma, Radjaï, Saint-Cyr, Delenne & Sornay 2013 (seed 003), 12 000 aggregates: "
        "(q/p)* and sin phi* rise with eta at a decreasing rate; rho0 peaks near eta = 0.3 "
        "(about 0.70); rho* falls to about 0.55 at eta = 0.7; Z_c0 jumps from 6 (spheres) to "
        "about 12; residual Z_c from 3.5 to 5.5; a_c from 0.2 to about 0.3 and a'_c to 0.36 "
        "beyond eta = 0.4; the sliding proportion S from 0.23 to 0.7."),
}
"""What the papers report for the preset series (keyed by the study's parameter)."""

COLUMNS = (
    ("value", "parameter", "{:.3g}"), ("measured", "measured", "{:.3g}"),
    ("n_seeds", "seeds", "{:.0f}"),
    ("status", "outcome", "{}"), ("wall_time", "wall time [s]", "{:.0f}"),
    ("capped_share", "capped steps", "{:.2%}"),
    ("q_over_trace_peak", "(q/p)+", "pm"), ("q_over_trace_residual", "(q/p)*", "pm"),
    ("phi_residual", "phi* [rad]", "{:.3f}"), ("sin_phi_star", "sin phi* (eq. 11)", "{:.3f}"),
    ("packing_fraction_initial", "nu0", "pm"), ("packing_fraction_residual", "nu*", "pm"),
    ("n_core_initial", "N core", "{:.0f}"),
    ("packing_fraction_core_initial", "nu0 core", "pm"),
    ("packing_fraction_core_residual", "nu* core", "pm"),
    ("z_initial", "z0", "pm"), ("z_residual", "z*", "pm"),
    ("coordination_number_core_initial", "z0 core", "pm"),
    ("coordination_number_core_residual", "z* core", "pm"),
    ("z_c_initial", "z_c0", "pm"), ("z_c_residual", "z_c*", "pm"),
    ("connectivity_number_core_initial", "z_c0 core", "pm"),
    ("connectivity_number_core_residual", "z_c* core", "pm"),
    ("a_c_residual", "a_c*", "pm"), ("a_c_core_residual", "a_c* core", "pm"),
    ("sliding_proportion_residual", "sliding*", "pm"),
    ("sliding_proportion_core_residual", "sliding* core", "pm"),
)
"""The report's table: summary column, heading, format ("pm": mean ± std)."""


def _cell(row: pd.Series, column: str, fmt: str) -> str:
    if column not in row or row[column] is None:
        return "-"
    value = row[column]
    if fmt == "{}":
        return str(value)
    if not finite(float(value)):
        return "-"
    if fmt == "pm":
        std = row.get(f"{column}_std", math.nan)
        return f"{value:.3f} ± {std:.3f}" if finite(float(std)) else f"{value:.3f}"
    return fmt.format(value)


def summary_markdown(table: pd.DataFrame) -> str:
    """The report's table of samples (Markdown)."""
    columns = [c for c in COLUMNS if c[0] in table]
    lines = ["| sample | " + " | ".join(h for _, h, _ in columns) + " |",
             "|---" * (len(columns) + 1) + "|"]
    for _, row in table.iterrows():
        cells = [_cell(row, c, f) for c, _, f in columns]
        lines.append(f"| {row['name']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_study_report(study, table: pd.DataFrame) -> Path:
    """Write the study's figures and ``report/report.md`` (module docstring) from its summary
    table (:func:`~grainlab.study.study_summary.study_summary`, its replicas pooled by
    :func:`~grainlab.study.study_summary.pooled_replicas`: ``n_seeds`` > 1 marks a sample
    whose error bars are over its seeds); returns the report's path."""
    from grainlab.lab.discrete_run import RESULTS_H5
    from grainlab.report.run_curves import shear_from_its_start
    from grainlab.result.test_result import read_test_result
    spec = study.spec
    cell = periodic_study(study, table)
    replicated = "n_seeds" in table and bool((table["n_seeds"] > 1).any())
    if "n_seeds" in table and not replicated:
        table = table.drop(columns="n_seeds")
    out = study.folder / REPORT
    out.mkdir(exist_ok=True)
    for stale in out.glob("*.png"):  # a figure an earlier report drew, not drawn now
        stale.unlink()
    symbol, parameter = spec.symbol, spec.study.parameter
    labels = {r["name"]: f"{r['name']} ({symbol} = {r['measured']:.3g})"
              for _, r in table.iterrows()}
    curves = {}
    for name in table["name"]:
        result = read_test_result(study.sample_folder(name) / RESULTS_H5)
        curves[name] = shear_from_its_start(result.table)
    figures: list[tuple[str, str]] = []
    figure = curves_figure(curves, labels)
    if figure is not None:
        save_figure(figure, out / "curves.png")
        figures.append(("Stress, volume change and packing fraction against eps_q"
                        + seed_figure_words("curves", parameter), "curves.png"))
    for stem, make, title in STUDY_FIGURES:
        figure = make(table, symbol)
        if figure is not None:
            save_figure(figure, out / f"{stem}.png")
            figures.append((title + seed_figure_words(stem, parameter), f"{stem}.png"))
    profile = _wall_profiles(study, table, out, labels, spec.study.core_margin)
    if profile is not None:
        figures.append(profile)
    networks = _window_distributions(study, table, out, "whole cell" if cell else "whole box") \
        + _force_networks(study, table, out)
    lo, hi = spec.study.window
    total = float(pd.to_numeric(table["wall_time"], errors="coerce").sum())
    text = [
        f"# Study: {spec.study.name}", "",
        spec.study.description or "", "",
        f"- samples: {len(spec.samples)} ({len(table)} ended"
        + (f", pooled from {int(table['n_seeds'].sum())} runs with their seeds"
           if replicated else "")
        + ")",
        f"- shape parameter: {symbol} (`{spec.study.parameter}`)",
        f"- residual window: eps_q in [{lo:g}, {hi:g}]; residual values are the mean ± the "
        "sample standard deviation of the recorded rows, or of the snapshots for the "
        "microstructure, in the window",
        *(["- independent samples: a sample repeated with other packing seeds (n_seeds > "
            "1) is one point, the mean over its seeds, and its error bars are the standard "
            "deviation over the seeds (for the initial state too), not over the window; "
            "its wall time is the seeds' sum and its capped steps the largest share of "
            "its seeds' runs; each seed's own row is in summary.csv"] if replicated else []),
        f"- peak (q/p)+: the largest running mean of q/p over eps_q windows of width "
        f"{spec.study.peak_window:g} (the largest single row, biased up by the rows' "
        "fluctuations, is `q_over_trace_peak_raw` in summary.csv)",
        "- periodic cell: no walls, so no wall layer and no core; every value is over the "
        "whole cell (for z and z_c, the rattlers included)" if cell else
        f"- core: the particles at least {spec.study.core_margin:g} mean diameters from every "
        "wall (columns and labels marked core; the others are over the whole box, the wall "
        "layer and, for z and z_c, the rattlers included); see the wall profile below",
        f"- wall time of the runs: {total:.0f} s in all",
        f"- written {datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')}", "",
        "## Samples", "", summary_markdown(table), "",
    ]
    notes = [f"- {r['name']}: {r['note']}" for _, r in table.iterrows() if r.get("note")]
    late = [f"- {r['name']}: outcome {r['status']}" for _, r in table.iterrows()
            if not r.get("as_asked", True)]
    if notes or late:
        text += ["Samples to read with care:", "", *notes, *late, ""]
    if spec.study.parameter in PAPERS:
        from grainlab.report.paper_comparison import comparison_markdown, paper_comparison

        n = int(table["n_particles"].max())
        comparison = paper_comparison(table, spec.study.parameter)
        comparison.to_csv(out / "against_the_paper.csv", index=False)
        where = ("over the whole cell (± the standard deviation over the residual window, or "
                 "over the seeds where a sample is pooled; none for a single initial state), "
                 "and a verdict on them" if cell else
                 "over the whole box and over the core (± the standard deviation over the "
                 "residual window; none for the initial state), and a verdict on the core's "
                 "values (the whole box's where the core has none)")
        size = (f"The samples here hold {n} particles at most, in a periodic cell about "
                f"{n ** (1 / 3):.0f} particles wide, where the papers' held 12 000 to 40 000: "
                "there is no wall layer, but the residual values fluctuate more (the error "
                "bars), so trends are to be compared, not values to the second decimal."
                if cell else
                f"The samples here hold {n} particles at most, in a box of walls about "
                f"{n ** (1 / 3):.0f} particles wide, where the papers' held 12 000 to "
                "40 000: the walls order the particles next to them (the whole-box packing "
                "fraction and z include that layer; the core's values leave it out, over "
                "fewer particles), and the residual values fluctuate more (the error bars), "
                "so trends are to be compared, not values to the second decimal.")
        text += ["## Against the paper", "",
                 "Each quantity the paper reports along its series, grainlab's first and last "
                 f"sample {where}: a value agrees within the stated tolerance plus two "
                 "standard deviations (`grainlab.report.paper_comparison`; the verdicts are in "
                 "`against_the_paper.csv`).", "", comparison_markdown(comparison, cell), "",
                 "## The papers' values", "", PAPERS[spec.study.parameter], "", size, ""]
    text += ["## Figures", ""]
    for title, name in figures + networks:
        text += [f"### {title}", "", f"![{title}]({name})", ""]
    text += ["The full table (every column, with standard deviations) is `summary.csv` in the "
             "study folder; each sample's run folder is `samples/NAME/` (results.csv, "
             "snapshots.h5, run.log).", ""]
    path = out / "report.md"
    path.write_text("\n".join(text), encoding="utf-8")
    from grainlab.report.html_report import write_html_report

    write_html_report(path, f"Study: {spec.study.name}")
    return path


def _picked(table: pd.DataFrame) -> list[str]:
    """The first, middle and last sample."""
    names = list(table["name"])
    return list(dict.fromkeys([names[0], names[len(names) // 2], names[-1]]))


def periodic_study(study, table: pd.DataFrame) -> bool:
    """Whether every ended sample of ``study`` (the rows of ``table``) ran in a periodic cell
    (no walls: no wall layer, no core)."""
    names = list(table["name"]) or list(study.spec.names)
    return all(study.spec.sample_config(name).sample.boundary == "periodic" for name in names)


def _seeds_of(study, name: str) -> list[str]:
    """The ended samples of the point ``name``: its shape's sample and that sample's replicas
    (other packing seeds), the point's own first."""
    samples = {s.name: s for s in study.spec.samples}
    base = samples[name].replica_of or name if name in samples else name
    states = study.states()
    group = [s.name for s in study.spec.samples
             if (s.name == base or s.replica_of == base) and states.get(s.name) == "ended"]
    return [name] + [n for n in group if n != name]


def _sample_window(study, name: str, window: tuple[float, float], whole: str):
    """The window average of one ended sample: (distributions, snapshots, where), from its
    snapshots, else from its digest (a slimmed sample); None without a snapshot in the
    window."""
    from grainlab.analysis.window_average import WindowAverage
    from grainlab.errors import InputError
    from grainlab.lab.discrete_run import SNAPSHOTS
    from grainlab.lab.run_digest import read_window

    folder = study.sample_folder(name)
    if (folder / SNAPSHOTS).exists():
        try:
            average = WindowAverage(window, distributions="core",
                                    core_margin=study.spec.study.core_margin
                                    ).run(folder / SNAPSHOTS)
        except InputError:  # no snapshot in the window
            return None
        where = "core" if average.last is not None and average.last.core_parts else whole
        return average.distributions, average.n_snapshots, where
    kept = read_window(folder, window, study.spec.study.core_margin)
    if kept is None:
        return None
    distributions, n_snapshots, where = kept
    return distributions, n_snapshots, (whole if where == "whole box" else where)


def _window_distributions(study, table: pd.DataFrame, out: Path,
                          whole: str = "whole box") -> list[tuple[str, str]]:
    """Polar diagrams and force PDFs of the first, middle and last point, averaged over the
    snapshots in the residual window of every packing seed of the point
    (:mod:`grainlab.analysis.pooled_windows`; the core's contacts where the sample has a box;
    else ``whole``: "whole box", or "whole cell" for a periodic one)."""
    from grainlab.analysis.pooled_windows import pooled_distributions
    from grainlab.report.microstructure_figures import (
        averaged_force_pdf_figure,
        averaged_polar_figure,
    )

    lo, hi = study.spec.study.window
    figures = []
    for name in _picked(table):
        kept = [average for seed in _seeds_of(study, name)
                if (average := _sample_window(study, seed, (lo, hi), whole)) is not None]
        if not kept:
            continue
        distributions = pooled_distributions([average[0] for average in kept])
        n_snapshots = sum(average[1] for average in kept)
        where = ", ".join(dict.fromkeys(average[2] for average in kept))
        seeds = f"{len(kept)} packing seeds, " if len(kept) > 1 else ""
        span = f"{seeds}{n_snapshots} snapshots, eps_q in [{lo:g}, {hi:g}], {where}"
        for stem, make, title in (("polar", averaged_polar_figure, "Angular distributions"),
                                  ("force_pdfs", averaged_force_pdf_figure, "Force PDFs")):
            file = f"{stem}_{name}.png"
            save_figure(make(distributions), out / file)
            figures.append((f"{title}, {name} ({span})"
                            + seed_figure_words(stem, study.spec.study.parameter), file))
    return figures


def _force_networks(study, table: pd.DataFrame, out: Path) -> list[tuple[str, str]]:
    """The last snapshot of the first, middle and last sample: its radial-force network
    coloured by contact type and by friction mobilisation, and its particles shaded by their
    contact neighbours."""
    from grainlab.analysis.snapshot_files import count_snapshots, read_snapshots
    from grainlab.lab.run_digest import snapshots_for_report
    from grainlab.report.microstructure_figures import (
        connectivity_map_figure,
        force_network_figure,
        pair_mobilisation,
    )

    figures = []
    for name in _picked(table):
        path = snapshots_for_report(study.sample_folder(name))
        if path is None or count_snapshots(path) == 0:
            continue
        last = None
        for network in read_snapshots(path):
            last = network
        if last is None or last.n_pairs == 0:
            continue
        parameter = study.spec.study.parameter
        eps = last.state.get("eps_q", math.nan)
        drawn = [("force_network", f"Radial forces by contact type, {name}, eps_q = {eps:.2f}",
                  partial(force_network_figure, last, color_by="type"))]
        mobilisation = pair_mobilisation(last)
        if mobilisation is not None:
            drawn.append(("mobilised_network",
                          f"Radial forces by friction mobilisation (red: |f_t| = mu f_n), "
                          f"{name}, eps_q = {eps:.2f}",
                          partial(force_network_figure, last, color_by="sliding",
                                  mobilisation=mobilisation)))
        drawn.append(("connectivity_map", f"Contact neighbours of each particle, {name}, "
                      f"eps_q = {eps:.2f}", partial(connectivity_map_figure, last)))
        for stem, title, make in drawn:
            file = f"{stem}_{name}.png"
            save_figure(make(), out / file)
            figures.append((title + seed_figure_words(stem, parameter), file))
    return figures


def _wall_profiles(study, table: pd.DataFrame, out: Path, labels: dict[str, str],
                   margin: float) -> tuple[str, str] | None:
    """The packing fraction against the distance to the nearest wall of every sample at the
    end of its compaction (its last compaction snapshot), with the core's margin."""
    from grainlab.analysis.wall_layer import mean_diameter, solid_profile
    from grainlab.lab.run_digest import compacted_snapshot
    from grainlab.report.study_figures import wall_profile_figure

    profiles = {}
    for name in table["name"]:
        initial = compacted_snapshot(study.sample_folder(name))
        if initial is None or not initial.has_box:
            continue
        d = mean_diameter(initial)
        edges, fraction = solid_profile(initial, PROFILE_BIN * d)
        profiles[labels.get(name, name)] = (edges / d, fraction)
    figure = wall_profile_figure(profiles, margin)
    if figure is None:
        return None
    save_figure(figure, out / "wall_profile.png")
    return ("Packing fraction against the distance to the walls, end of the compaction",
            "wall_profile.png")


PROFILE_BIN = 0.25
"""Shell width of the report's packing-fraction profiles, in mean diameters <d_v>."""
