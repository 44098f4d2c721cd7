"""The report of a discrete run: one Markdown page with its PNG figures, readable without
grainlab (``RUN/report/report.md``).

Contents, from the run folder (config.toml, results.csv, snapshots.h5):

* the sample and the test: particles, N, sizes, boundary, sigma0, the test's target, the
  friction, the solver; the outcome (status and summary), the wall time, the steps and the
  share of steps that ended at the solver's cap of sweeps;
* the macroscopic response (results table): q/p at its peak, and over the strain window the
  mean ± standard deviation of q/p, sin(phi), p, the packing fraction, z and z_c; the packing
  fraction at the start of the shear (end of the compaction) and eps_vol at the end;
  the curves (:func:`~grainlab.report.run_curves.discrete_curves_figure`);
* the microstructure over the same window
  (:class:`~grainlab.analysis.window_average.WindowAverage`): mean ± standard deviation of the
  coordination and connectivity numbers, the fabric and force anisotropies of both frames,
  q/p from the anisotropies (seed 002 eqs. 27a/b, B1), the sliding proportion and
  mobilisation; the force PDFs and the polar angular distributions with error bars (seed 003
  Figs. 14, 16; seed 002 Fig. 14); every descriptor in ``window_scalars.csv`` and every
  distribution in ``window_<name>.csv``. A run with no snapshot in the window gets the
  macroscopic part and a line saying why the microstructure is missing.

The window is on eps_q, counted from the end of the compaction (stage ``compaction`` left
out). Default: the last :data:`~grainlab.lab.solver_comparison.RESIDUAL_SHARE` (30 %) of the
eps_q reached, the residual state of the run's printed summary; seed 003 uses [0.5, 0.9],
which a run to the default eps_q_max = 0.5 reaches only at its last record. Standard
deviations are sample deviations (ddof = 1) over the records or snapshots in the window.
"""

from __future__ import annotations

import datetime
import math
import shutil
from pathlib import Path
from typing import Any

import pandas as pd

from grainlab._version import __version__
from grainlab.analysis.snapshot_files import SNAPSHOTS_FILE
from grainlab.analysis.window_average import StrainWindow, WindowAverage
from grainlab.errors import InputError
from grainlab.lab.run_config import RunConfig, current_layout
from grainlab.lab.solver_comparison import RESIDUAL_SHARE
from grainlab.lab.solver_registry import SOLVERS
from grainlab.prep.sample_shapes import particles_text
from grainlab.report.curves import save_figure
from grainlab.report.microstructure_figures import (
    averaged_force_pdf_figure,
    averaged_polar_figure,
)
from grainlab.report.run_curves import discrete_curves_figure, shear_from_its_start
from grainlab.result.test_result import TestResult, read_test_result

REPORT_FOLDER = "report"
"""Folder of the report inside a run folder."""
REPORT_FILE = "report.md"

MACRO_COLUMNS = (
    ("q_over_trace", "q/p = (s1 - s3)/tr(s)"), ("sin_phi", "sin(phi)"), ("p", "p [Pa]"),
    ("packing_fraction", "packing fraction"), ("z", "z"), ("z_no_rattlers", "z without rattlers"),
    ("z_c", "z_c"), ("eps_vol", "eps_vol"),
)
"""Columns of the results table averaged over the window, with their labels."""

MICRO_DESCRIPTORS = (
    ("packing_fraction", "packing fraction"), ("coordination_number", "z"),
    ("coordination_number_no_rattlers", "z without rattlers"),
    ("connectivity_number", "z_c"), ("connectivity_number_no_rattlers", "z_c without rattlers"),
    ("rattler_fraction", "rattler fraction"), ("q_over_trace", "q/p from the contact stress"),
    ("a_c", "a_c (contact orientations)"), ("a_ln", "a_ln (normal branch lengths)"),
    ("a_lt", "a_lt (tangential branch lengths)"), ("a_fn", "a_n (normal forces)"),
    ("a_ft", "a_t (tangential forces)"), ("a_c_branch", "a'_c (branch frame)"),
    ("a_fn_branch", "a'_n (radial forces)"), ("a_ft_branch", "a'_t (orthoradial forces)"),
    ("q_over_trace_27a", "q/p from anisotropies, eq. 27a"),
    ("q_over_trace_27b", "q/p from anisotropies, eq. 27b"),
    ("q_over_trace_B1", "q/p from anisotropies, eq. B1"),
    ("sliding_proportion", "sliding proportion S"), ("mobilisation_index", "mobilisation I_mu"),
    ("mobilisation_index_harmonic", "I_mu from a_t (eq. 28)"),
    ("fraction_normal_above_mean", "share of f_n above <f_n>"),
    ("pearson_length_force", "C_lf (branch length / force)"),
    ("mean_normal_force", "<f_n> [N]"),
)
"""Descriptors of the window average shown in the report (all are in window_scalars.csv)."""

TARGETS = {
    "triaxial": ("eps_q_max",), "extension": ("eps_q_max",), "true_triaxial": ("eps_q_max", "b"),
    "cubical": ("eps_q_max", "b"),
    "oedometer": ("axial_strain", "unload_strain"), "simple_shear": ("gamma_max",),
    "circular": ("q_ratio", "circle_points"), "cyclic_shear": ("amplitude", "n_cycles"),
}
"""The [test] keys that state each kind of test's target."""


def number(value: Any) -> str:
    """A number as the report prints it: 4 significant digits, ``—`` for NaN or None.

    >>> number(0.123456), number(float("nan")), number(12346.0)
    ('0.1235', '—', '1.235e+04')
    """
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "—"
    return f"{value:.4g}"


def mean_std(mean: float, std: float) -> str:
    """``mean ± std`` (``mean`` alone when std is NaN, one value)."""
    if not math.isfinite(std):
        return number(mean)
    return f"{number(mean)} ± {number(std)}"


def run_result(run_folder: Path) -> TestResult:
    """The run's results table and metadata (results.csv)."""
    path = Path(run_folder) / "results.csv"
    if not Path(run_folder).is_dir():
        raise InputError("RUN", str(run_folder), "a run folder")
    if not path.is_file():
        raise InputError("RUN", str(run_folder), "a run folder holding results.csv (a run "
                         "that recorded at least one row)")
    return read_test_result(path)


def run_config(run_folder: Path, result: TestResult) -> dict[str, Any]:
    """The run's config: config.toml when readable, else the one in the results metadata."""
    path = Path(run_folder) / "config.toml"
    if path.is_file():
        try:
            return RunConfig.read(path).model_dump()
        except InputError:
            pass
    config, _ = current_layout(result.metadata.get("parameters", {}).get("config", {}))
    return config


def shear_records(result: TestResult) -> pd.DataFrame:
    """The records after the compaction, led by the compaction's end at zero strain
    (:func:`~grainlab.report.run_curves.shear_from_its_start`); empty when the run has no
    stage after the compaction or no eps_q."""
    table = result.table
    if "stage" not in table.columns or "eps_q" not in table.columns:
        return table.iloc[0:0]
    if not (table["stage"] != "compaction").any():
        return table.iloc[0:0]
    return shear_from_its_start(table)


def report_window(shear: pd.DataFrame, window: tuple[float, float] | None
                  ) -> StrainWindow | None:
    """The window of the report: ``window`` (low, high) of eps_q, checked against the eps_q
    the run's shear reached; None gives the last RESIDUAL_SHARE of the eps_q reached (None
    when the run has no shear)."""
    if shear.empty:
        if window is not None:
            raise InputError("window", tuple(window), "no window: the run has no stage after "
                             "the compaction, hence no eps_q to average over")
        return None
    reached = float(shear["eps_q"].max())
    if window is None:
        if not reached > 0:
            return None
        return StrainWindow((1.0 - RESIDUAL_SHARE) * reached, reached)
    chosen = StrainWindow(float(window[0]), float(window[1]))
    start = float(shear["eps_q"].min())
    if chosen.low > reached or chosen.high < start:
        raise InputError("window", (chosen.low, chosen.high),
                         f"a window of eps_q that meets the run's shear, eps_q from "
                         f"{start:.4g} to {reached:.4g}")
    return chosen


def _sample_lines(config: dict[str, Any], result: TestResult) -> list[tuple[str, str]]:
    sample, test = config.get("sample", {}), config.get("test", {})
    solver = config.get("solver", {})
    specimen = result.metadata.get("specimen", {})
    n = specimen.get("n_particles", sample.get("n_particles", "?"))
    shape = particles_text({**sample, **specimen})
    lines = [("particles", f"{n} {shape}".strip())]
    if "d_min" in specimen or "d_min" in sample:
        d_min = specimen.get("d_min", sample.get("d_min"))
        d_max = specimen.get("d_max", d_min * sample.get("size_ratio", 1.0))
        lines.append(("diameters", f"{number(d_min * 1e3)} to {number(d_max * 1e3)} mm"))
    for key, label in (("density", "density [kg/m^3]"), ("boundary", "boundary"),
                       ("seed", "seed")):
        if key in sample:
            value = sample[key]
            lines.append((label, number(value) if isinstance(value, float) else str(value)))
    kind = test.get("kind", "?")
    targets = ", ".join(f"{key} = {test[key]:g}" for key in TARGETS.get(kind, ())
                        if key in test)
    lines.append(("test", kind + (f" ({targets})" if targets else "")))
    if "sigma0" in test:
        lines.append(("sigma0", f"{number(test['sigma0'] / 1e3)} kPa"))
    if kind != "compaction" and "friction" in solver.get("shear", {}):
        lines.append(("friction mu", number(solver["shear"]["friction"])))
    if "method" in solver:
        record = SOLVERS.get(solver["method"])
        lines.append(("solver", solver["method"] if record is None else record.words))
    return lines


def _outcome_lines(result: TestResult) -> list[tuple[str, str]]:
    outcome = result.metadata.get("outcome") or {}
    cost = result.metadata.get("cost") or {}
    lines = []
    if outcome:
        lines.append(("outcome", str(outcome.get("status", "?"))))
    if cost.get("wall_time") is not None:
        lines.append(("wall time", f"{number(cost['wall_time'])} s"))
    steps = cost.get("steps", outcome.get("steps"))
    if steps is not None:
        lines.append(("steps", str(steps)))
    for stage in outcome.get("stages", []):
        if stage.get("steps"):
            share = stage.get("capped_steps", 0) / stage["steps"]
            lines.append((f"capped steps, {stage['name']}",
                          f"{stage.get('capped_steps', 0)} of {stage['steps']} "
                          f"({100 * share:.3g} %) at {stage.get('max_iterations', '?')} "
                          "sweeps"))
    return lines


def _table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def macroscopic_rows(result: TestResult, shear: pd.DataFrame,
                     window: StrainWindow | None) -> list[tuple[str, str, str]]:
    """(quantity, value, note) of the results table: the peak of q/p, the state at the start
    of the shear and at its end, and each :data:`MACRO_COLUMNS` over the window."""
    table = result.table
    rows: list[tuple[str, str, str]] = []
    compaction = table[table["stage"] == "compaction"] if "stage" in table.columns else table
    if len(compaction):
        end = compaction.iloc[-1]
        for column, label in (("packing_fraction", "packing fraction"), ("z", "z"),
                              ("p", "p [Pa]")):
            if column in end.index:
                rows.append((f"{label}, end of compaction", number(float(end[column])),
                             f"step {int(end['step'])}" if "step" in end.index else ""))
    if shear.empty:
        return rows
    if "q_over_trace" in shear.columns:
        peak = shear["q_over_trace"].idxmax()
        rows.append(("q/p, peak", number(float(shear.loc[peak, "q_over_trace"])),
                     f"at eps_q = {number(float(shear.loc[peak, 'eps_q']))}"))
    last = shear.iloc[-1]
    for column, label in (("eps_q", "eps_q"), ("eps_vol", "eps_vol")):
        if column in last.index:
            rows.append((f"{label}, end", number(float(last[column])), ""))
    if window is None:
        return rows
    inside = shear[(shear["eps_q"] >= window.low) & (shear["eps_q"] <= window.high)]
    if inside.empty:
        rows.append(("window", "—", f"no record has {window}"))
        return rows
    for column, label in MACRO_COLUMNS:
        if column in inside.columns:
            values = inside[column].astype(float)
            rows.append((f"{label}, window", mean_std(values.mean(), values.std(ddof=1)),
                         f"{len(inside)} record{'s' if len(inside) != 1 else ''}"))
    return rows


def microstructure(run_folder: Path, window: StrainWindow | None
                   ) -> tuple[WindowAverage | None, str]:
    """The window average of the run's snapshots, or None and the reason it is missing."""
    if window is None:
        return None, ("no microstructure: the run has no shear, hence no strain window to "
                      "average over.")
    path = Path(run_folder) / SNAPSHOTS_FILE
    if not path.is_file():
        return None, (f"no microstructure: the run wrote no {SNAPSHOTS_FILE} "
                      "(output.snapshot_every = 0).")
    try:
        return WindowAverage(window).run(path), ""
    except InputError as error:
        if error.field != "window":
            raise
        known = error.allowed.split(": ", 1)[-1]
        return None, f"no microstructure: no snapshot has {window}; {known}."


def write_run_report(run_folder: str | Path, window: tuple[float, float] | None = None,
                     out: str | Path | None = None) -> Path:
    """Write the report of a discrete run (module docstring) to ``out/report.md`` (default
    ``RUN/report``), with its figures and CSV files beside it; returns the path of report.md.

    ``window`` is (low, high) of eps_q from the end of the compaction; None: the last 30 % of
    the eps_q reached. A window that does not meet the run's shear, or with low >= high, is an
    :class:`InputError` naming ``window``.
    """
    run_folder = Path(run_folder)
    result = run_result(run_folder)
    config = run_config(run_folder, result)
    shear = shear_records(result)
    chosen = report_window(shear, window)
    folder = Path(out) if out is not None else run_folder / REPORT_FOLDER
    folder.mkdir(parents=True, exist_ok=True)
    title = result.metadata.get("title") or "discrete run"
    text = [f"# {title}", "",
            f"Run folder `{run_folder.resolve().name}`; report written "
            f"{datetime.datetime.now().isoformat(timespec='seconds')} by grainlab "
            f"{__version__}.", "", "## Sample and test", ""]
    text += _table(("", ""), _sample_lines(config, result) + _outcome_lines(result))
    summary = (result.metadata.get("outcome") or {}).get("summary")
    if summary:
        text += ["", "```", summary.strip(), "```"]
    text += ["", "## Macroscopic response", ""]
    if len(result.table):
        drawn = run_folder / "curves.png"  # the command line's figure of the same results
        if drawn.is_file() and drawn.stat().st_mtime >= (run_folder / "results.csv").stat(
                ).st_mtime and drawn.resolve() != (folder / "curves.png").resolve():
            shutil.copy2(drawn, folder / "curves.png")
        else:
            kind = config.get("test", {}).get("kind")
            if kind == "oedometer":
                from grainlab.report.element_test_figures import oedometer_stages_figure

                figure = oedometer_stages_figure(result)
            else:
                figure = discrete_curves_figure(result)
            save_figure(figure, folder / "curves.png", dpi=110)
        text += ["![curves](curves.png)", ""]
    if chosen is not None:
        text += [f"Window: {chosen} (eps_q from the end of the compaction"
                 + ("; the last 30 % of the eps_q reached" if window is None else "")
                 + "); ± one sample standard deviation (ddof = 1) over the records in it.", ""]
    text += _table(("quantity", "value", "note"), macroscopic_rows(result, shear, chosen))
    text += ["", "## Microstructure over the window", ""]
    average, missing = microstructure(run_folder, chosen)
    if average is None:
        text.append(missing)
    else:
        text += _micro_section(average, folder)
    path = folder / REPORT_FILE
    path.write_text("\n".join(text) + "\n", encoding="utf-8")
    return path


def _micro_section(average: WindowAverage, folder: Path) -> list[str]:
    snapshots = average.snapshots
    strains = snapshots[average.window.variable]
    text = [f"{average.n_snapshots} snapshot(s) with {average.window} (steps "
            f"{', '.join(str(int(s)) for s in snapshots['step'])}; eps_q "
            f"{number(float(strains.min()))} to {number(float(strains.max()))}); mean ± one "
            "sample standard deviation (ddof = 1) over them, n the snapshots holding a value.",
            ""]
    scalars = average.scalars.set_index("descriptor")
    rows = []
    for key, label in MICRO_DESCRIPTORS:
        if key in scalars.index:
            row = scalars.loc[key]
            rows.append((label, f"`{key}`", number(float(row["mean"])),
                         number(float(row["std"])), str(int(row["n"])), str(row["unit"])))
    text += _table(("descriptor", "column", "mean", "std", "n", "unit"), rows)
    paths = average.write(folder)
    text += ["", "Every descriptor: [window_scalars.csv](window_scalars.csv); the distributions: "
             + ", ".join(f"[{p.name}]({p.name})" for p in paths[1:]) + ".", ""]
    save_figure(averaged_force_pdf_figure(average.distributions), folder / "force_pdfs.png",
                dpi=110)
    save_figure(averaged_polar_figure(average.distributions),
                folder / "angular_distributions.png", dpi=90)
    text += ["### Force PDFs", "",
             "P(f/<f>) of the normal forces f_n (contact points) and radial forces f_n' "
             "(pairs), on fixed bins, log-linear and log-log; error bars: standard deviation "
             "over the snapshots.", "", "![force PDFs](force_pdfs.png)", ""]
    outside = [(name, float(scalars.loc[f"pdf_binned_fraction_{name}", "mean"]))
               for name in ("normal_pdf_linear", "normal_pdf_log")
               if f"pdf_binned_fraction_{name}" in scalars.index]
    for name, inside in outside:
        if math.isfinite(inside) and inside < 0.999:
            text += [f"{100 * (1 - inside):.2g} % of the ratios fell outside the fixed bins of "
                     f"{name} (left out of its bins, kept in its normalisation).", ""]
    text += ["### Angular distributions", "",
             "Polar diagrams about the major principal stress direction (vertical): P(theta), "
             "<f_n>(theta), <f_t>(theta), <l_n>(theta) and <l_t>(theta) in the contact frame "
             "(top) and the branch frame (bottom); symbols: the mean over the snapshots with "
             "the standard deviation as error bars; lines: the harmonic approximation (seed "
             "002 eq. 26).", "", "![angular distributions](angular_distributions.png)"]
    return text
