"""A study run again against a reference run of it (the committed tables of a series, or a
colleague's study folder): sample by sample and quantity by quantity, does the rerun reproduce
the reference within their error bars?

A rerun on another processor, thread count or library version does not follow the reference's
trajectory: the chaotic dynamics of a packing amplify round-off from the first steps. So a
rerun reproduces a study when its values lie within the error bars of the reference's, not
when they are equal. The error bars are the ones the study's tables give:

* the **spread of independent packings** of one shape, measured on the reference's replicas
  (the samples ``replica_of`` another: the same shape with other packing seeds): the
  standard deviation ``s`` over the seeds of each replicated shape, pooled over the shapes
  (root mean square; the rerun's replicas where the reference has none). An **initial** or
  **peak** value (one number per run: the state after the compaction, the smoothed maximum
  of q/p) has only this error bar: the two values agree when
  ``|new - reference| <= 2 (s + s)``, each error bar two standard deviations (the size
  check's rule, :func:`grainlab.report.size_check_report._within`). Without replicas on
  either side these values have no error bar, and they are compared only for equality;
* a **residual** value (a mean over the residual window, ``X_residual``) also carries the
  standard deviation of the signal over that window (``X_residual_std``): the two agree when
  ``|new - reference| <= 2 (std_new + std_reference)``, or within the seeds' ``2 (s + s)``
  where that is wider (the residual packing fraction fluctuates less over a window than
  from one packing to another).

Equal values (a rerun on the same machine and code, or of a seed-exact path) read
"identical". The settings of each sample (its run configuration from the two ``study.toml``)
are compared first: a sample run with other settings (another boundary, size or length) is a
different experiment, and the reading says which keys differ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from grainlab.errors import InputError

REPRODUCTION = "reproduction"
"""The files the comparison writes in the study's ``report/`` folder (``.md`` and ``.csv``)."""


@dataclass(frozen=True)
class Compared:
    """One quantity of the comparison: the summary's ``column``, its ``label`` in the
    tables, and its ``kind``: "residual" (a window mean with a window standard deviation) or
    "initial" (one number per run, the error bar from the spread over seeds)."""

    column: str
    label: str
    kind: str


QUANTITIES = (
    Compared("q_over_trace_peak", "(q/p)+", "initial"),
    Compared("q_over_trace_residual", "(q/p)*", "residual"),
    Compared("packing_fraction_initial", "packing fraction 0", "initial"),
    Compared("packing_fraction_residual", "packing fraction *", "residual"),
    Compared("packing_fraction_core_initial", "packing fraction 0 (core)", "initial"),
    Compared("packing_fraction_core_residual", "packing fraction * (core)", "residual"),
    Compared("z_initial", "z0", "initial"),
    Compared("z_residual", "z*", "residual"),
    Compared("z_c_initial", "z_c0", "initial"),
    Compared("z_c_residual", "z_c*", "residual"),
    Compared("connectivity_number_core_initial", "z_c0 (core)", "initial"),
    Compared("connectivity_number_core_residual", "z_c* (core)", "residual"),
    Compared("a_c_residual", "a_c*", "residual"),
    Compared("sliding_proportion_residual", "sliding proportion *", "residual"),
)
"""The study's headline quantities, those of its tables (whole box, and core where the
summary has one)."""

IDENTICAL = 1e-12
"""Relative difference below which two values are the same number (a seed-exact rerun)."""


def _finite(value: Any) -> bool:
    try:
        return math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


def seed_spread(reference: pd.DataFrame, column: str) -> tuple[float, int]:
    """The spread of ``column`` over independent packings of one shape in ``reference``
    (one row per run, ``replica_of`` naming the run a replica repeats): the sample standard
    deviation (ddof = 1) over the seeds of each shape with at least two ended runs, pooled as
    the root mean square over those shapes; and the number of shapes it comes from (0, and a
    nan spread, where there is none).

    >>> table = pd.DataFrame({"name": ["a", "a-seed1", "b", "b-seed1"],
    ...                       "replica_of": ["", "a", "", "b"], "x": [1.0, 3.0, 5.0, 5.0]})
    >>> spread, shapes = seed_spread(table, "x")
    >>> round(spread, 6), shapes
    (1.0, 2)
    """
    if column not in reference or "replica_of" not in reference:
        return math.nan, 0
    base = reference["replica_of"].fillna("").astype(str)
    shape = base.where(base != "", reference["name"])
    variances = []
    for _, group in reference.groupby(shape, sort=False):
        values = group[column].to_numpy(float)
        values = values[np.isfinite(values)]
        if values.size >= 2:
            variances.append(float(np.var(values, ddof=1)))
    if not variances:
        return math.nan, 0
    return math.sqrt(float(np.mean(variances))), len(variances)


def _verdict(new: float, ref: float, bar: float) -> tuple[str, bool | None]:
    """One value's reading (text, and whether it agrees: None where it cannot be judged)."""
    if not (_finite(new) and _finite(ref)):
        return "no value", None
    difference = new - ref
    if abs(difference) <= IDENTICAL * max(1.0, abs(ref)):
        return "identical", True
    if not _finite(bar):
        return f"differs by {difference:+.3g}; no error bar to judge it", None
    if abs(difference) <= bar:
        return f"within the error bars ({difference:+.3g}, bars {bar:.3g})", True
    return (f"outside the error bars by {abs(difference) - bar:.3g} "
            f"({difference:+.3g}, bars {bar:.3g})"), False


def reproduction_table(new: pd.DataFrame, reference: pd.DataFrame,
                       quantities: tuple[Compared, ...] = QUANTITIES) -> pd.DataFrame:
    """Sample by sample (the reference's order) and quantity by quantity, the rerun's value
    against the reference's (module docstring): columns ``sample``, ``quantity``,
    ``column``, ``new``, ``new_std``, ``reference``, ``reference_std``, ``difference``,
    ``bar`` (the half-width the difference must stay within), ``bar_from`` ("window" or
    "seeds (n shapes)"), ``agrees`` (True, False, or None where it cannot be judged) and
    ``verdict``. A sample of the reference missing from the rerun (not run, not ended) gets
    one row with quantity "-" and verdict "not in the rerun". Quantities absent from both
    summaries (a periodic cell's core) are left out.

    >>> ref = pd.DataFrame({"name": ["a"], "replica_of": [""], "q_over_trace_residual": [0.30],
    ...                     "q_over_trace_residual_std": [0.01]})
    >>> new = ref.assign(q_over_trace_residual=[0.33])
    >>> row = reproduction_table(new, ref).iloc[0]
    >>> bool(row["agrees"]), round(float(row["bar"]), 3)
    (True, 0.04)
    """
    rows: list[dict[str, Any]] = []
    present = [q for q in quantities if q.column in reference or q.column in new]
    spreads = {}
    for q in present:  # the reference's replicas, else the rerun's
        spreads[q.column] = seed_spread(reference, q.column)
        if not spreads[q.column][1]:
            spreads[q.column] = seed_spread(new, q.column)
    by_name = {str(n): r for n, r in zip(new["name"], new.to_dict("records"), strict=True)}
    for ref_row in reference.to_dict("records"):
        name = str(ref_row["name"])
        new_row = by_name.get(name)
        if new_row is None:
            rows.append({"sample": name, "quantity": "-", "column": "", "agrees": None,
                         "verdict": "not in the rerun (not run, or not ended)"})
            continue
        for q in present:
            value, ref = new_row.get(q.column, math.nan), ref_row.get(q.column, math.nan)
            if not (_finite(value) or _finite(ref)):
                continue
            std = new_row.get(f"{q.column}_std", math.nan)
            ref_std = ref_row.get(f"{q.column}_std", math.nan)
            spread, shapes = spreads[q.column]
            bar, bar_from = 4.0 * spread, (f"seeds ({shapes} shape{'s' * (shapes > 1)})"
                                           if shapes else "none")
            if q.kind == "residual" and _finite(std) and _finite(ref_std):
                window = 2.0 * (float(std) + float(ref_std))
                if not _finite(bar) or window >= bar:
                    bar, bar_from = window, "window"
            text, agrees = _verdict(float(value), float(ref), bar)
            rows.append({"sample": name, "quantity": q.label, "column": q.column,
                         "new": float(value), "new_std": float(std) if _finite(std)
                         else math.nan, "reference": float(ref),
                         "reference_std": float(ref_std) if _finite(ref_std) else math.nan,
                         "difference": float(value) - float(ref), "bar": bar,
                         "bar_from": bar_from, "agrees": agrees, "verdict": text})
    return pd.DataFrame(rows)


def settings_differences(new_spec, reference_spec, names=None) -> dict[str, list[str]]:
    """For each sample both study specifications hold (of ``names`` only, where given), the
    dotted keys of its run configuration (``StudySpec.sample_config``) whose values differ,
    as "key: new vs reference"; samples run alike are left out. The study's header (window,
    core margin, peak window) is compared too, under "study"."""
    out: dict[str, list[str]] = {}
    header = _differences(new_spec.study.model_dump(mode="json"),
                          reference_spec.study.model_dump(mode="json"),
                          skip=("description",))
    if header:
        out["study"] = header
    names = [n for n in reference_spec.names if n in new_spec.names
             and (names is None or n in names)]
    for name in names:
        keys = _differences(new_spec.sample_config(name).model_dump(mode="json"),
                            reference_spec.sample_config(name).model_dump(mode="json"))
        if keys:
            out[name] = keys
    return out


def _differences(new: Any, ref: Any, prefix: str = "", skip: tuple[str, ...] = ()
                 ) -> list[str]:
    if isinstance(new, dict) and isinstance(ref, dict):
        found = []
        for key in sorted(set(new) | set(ref)):
            if key in skip:
                continue
            found += _differences(new.get(key), ref.get(key), f"{prefix}{key}.")
        return found
    if new != ref:
        return [f"{prefix.rstrip('.')}: {new!r} vs {ref!r}"]
    return []


def _number(value: float, std: float = math.nan) -> str:
    if not _finite(value):
        return "-"
    return f"{value:.4g} ± {std:.2g}" if _finite(std) else f"{value:.4g}"


def reproduction_counts(table: pd.DataFrame) -> dict[str, int]:
    """How many values agree, disagree and cannot be judged, and how many of the
    reference's samples the rerun lacks."""
    judged = table[table["quantity"] != "-"] if len(table) else table
    return {"agree": int((judged["agrees"] == True).sum()) if len(judged) else 0,  # noqa: E712
            "disagree": int((judged["agrees"] == False).sum()) if len(judged) else 0,  # noqa: E712
            "unjudged": int(judged["agrees"].isna().sum()) if len(judged) else 0,
            "missing": int((table["quantity"] == "-").sum()) if len(table) else 0}


def counts_text(counts: dict[str, int]) -> str:
    """The counts of :func:`reproduction_counts` as one sentence."""
    return (f"{counts['agree']} values agree, {counts['disagree']} do not, "
            f"{counts['unjudged']} cannot be judged; {counts['missing']} of the "
            "reference's samples are not in the rerun")


def reproduction_markdown(table: pd.DataFrame, differences: dict[str, list[str]],
                          new_folder: str, reference_folder: str) -> str:
    """The comparison as Markdown: what was compared, the settings that differ, the counts,
    then one table row per sample and quantity."""
    counts = reproduction_counts(table)
    lines = [f"# `{new_folder}` against `{reference_folder}`", "",
             "Each value of the rerun against the reference's: a residual value within "
             "2 (std + std) of the window standard deviations, an initial or peak value "
             "within 2 (s + s) of the reference's spread over packing seeds "
             "(grainlab.study.reproduction).", ""]
    if differences:
        lines += ["**Settings differ** (a different experiment where they do):", ""]
        lines += [f"- {name}: " + "; ".join(keys) for name, keys in differences.items()]
        lines.append("")
    lines += [counts_text(counts) + ".", "",
              "| sample | quantity | rerun | reference | reading |", "|---|---|---|---|---|"]
    for row in table.to_dict("records"):
        if row["quantity"] == "-":
            lines.append(f"| {row['sample']} | - | - | - | {row['verdict']} |")
            continue
        lines.append(f"| {row['sample']} | {row['quantity']} | "
                     f"{_number(row['new'], row['new_std'])} | "
                     f"{_number(row['reference'], row['reference_std'])} | "
                     f"{row['verdict']} |")
    return "\n".join(lines) + "\n"


def read_study_results(folder: str | Path, what: str):
    """A study folder's (or a published study's) specification and summary table; a clear
    error naming ``what`` where the folder holds neither."""
    from grainlab.study.study_runner import SPEC
    from grainlab.study.study_spec import StudySpec
    from grainlab.study.study_summary import SUMMARY

    folder = Path(folder)
    if not (folder / SPEC).is_file() or not (folder / SUMMARY).is_file():
        raise InputError(what, str(folder), f"a study folder (or a published study) with "
                                            f"{SPEC} and {SUMMARY}")
    return StudySpec.read(folder / SPEC), pd.read_csv(folder / SUMMARY)


def write_reproduction(folder: str | Path, reference: str | Path
                       ) -> tuple[pd.DataFrame, dict[str, list[str]], Path]:
    """Compare study ``folder`` with ``reference`` and write
    ``folder/report/reproduction.md`` and ``.csv``; return the table, the settings that
    differ and the Markdown's path."""
    folder, reference = Path(folder), Path(reference)
    new_spec, new = read_study_results(folder, "FOLDER")
    ref_spec, ref = read_study_results(reference, "--reference")
    table = reproduction_table(new, ref)
    differences = settings_differences(new_spec, ref_spec)
    out = folder / "report"
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / f"{REPRODUCTION}.csv", index=False)
    path = out / f"{REPRODUCTION}.md"
    path.write_text(reproduction_markdown(table, differences, str(folder), str(reference)),
                    encoding="utf-8")
    return table, differences, path
