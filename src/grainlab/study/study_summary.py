"""One row per sample of a study: the shape parameter, the initial (isotropic) state, the peak
and the residual state averaged over the study's window with its standard deviation (seeds
002 and 003 draw these as error bars).

Columns (SI, dimensionless unless stated):

* ``name``, ``value`` (the shape parameter as the study gives it), ``measured`` (the sample's
  measured parameter where its description has one: the mean angularity <alpha> [rad] of
  polyhedra; else ``value``), ``shape``, ``n_particles``;
* ``status``, ``as_asked``, ``wall_time`` [s], ``steps``, ``capped_share`` (steps ended at
  the solver's cap / steps), ``eps_q_end`` (the largest eps_q reached);
* the macroscopic state: for X in q_over_trace (the papers' q/p, q = (sigma_1 - sigma_3)/3
  and p the mean stress: :mod:`grainlab.result.columns`), sin_phi, packing_fraction, z, z_c,
  z_core, z_c_core, eps_vol (packing_fraction, z and z_c over the whole box, rattlers and
  the particles along the walls included; z_core, z_c_core over the particles at least a
  mean bounding diameter from every wall, as the results table records them):
  ``X_initial`` (end of the isotropic compaction), ``X_residual`` and ``X_residual_std``
  (mean and sample standard deviation, ddof = 1, of the recorded rows with eps_q in the
  window, as :mod:`grainlab.analysis.window_average` for the snapshots; where the snapshot
  analysis has a descriptor of the same name -- q_over_trace, sin_phi, packing_fraction --
  the rows' values stand: a row every ``record_every`` steps, against a snapshot every
  ``snapshot_every``, so that (q/p)*, sin phi* and nu* do not depend on where the snapshots
  fall, and sin phi* (eq. 11) is that of the (q/p)* beside it),
  and the peak: ``q_over_trace_peak`` the largest running mean of q/p over the rows within
  ``peak_window`` (a width of eps_q, centred: :func:`smoothed_peak`) and ``eps_q_peak`` its
  centre, with ``peak_window`` itself; ``q_over_trace_peak_raw``, the largest recorded
  row, is biased upward by the rows' fluctuations and kept for comparison only;
* ``phi_residual`` [rad] and ``sin_phi_star``: the internal angle of friction of seed 002
  eq. 11 (seed 003 eq. 12), sin phi* = 3 (q/p)* / (2 + (q/p)*), applied to the residual mean
  (q/p)* = ``q_over_trace_residual`` -- the papers' sin phi*. (``sin_phi_residual`` is another
  quantity: the window mean of the rows' (sigma_1 - sigma_3)/(sigma_1 + sigma_3).)
* the microstructure (:mod:`grainlab.analysis.window_average`): ``M_initial`` from the
  snapshot taken at the end of the compaction and ``M_residual``, ``M_residual_std`` over the
  shear's snapshots in the window, for every scalar descriptor M of the snapshot analysis:
  over the whole box (M: ``packing_fraction``, ``coordination_number``, ``a_c``, ``p`` with
  the wall contacts, ...) and over the core (``M_core``: the particles at least
  ``core_margin`` [m] from every wall, :mod:`grainlab.analysis.wall_layer`); and ``M_at_peak``
  from the shear's snapshot nearest ``eps_q_peak`` (one snapshot: the peak state of seed 002
  Fig. 20 and seed 003 Fig. 23), with its strain as ``eps_q_peak_snapshot``.

A row is written for an ended sample only; a sample whose run did not reach the window has
NaN residual values and says so in ``note``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from grainlab.analysis.wall_layer import CORE_MARGIN
from grainlab.errors import InputError
from grainlab.lab.discrete_run import RESULTS_H5, SNAPSHOTS
from grainlab.lab.run_digest import read_row, row_settings, slim_sample, write_row
from grainlab.report.run_curves import shear_from_its_start
from grainlab.result.test_result import read_test_result
from grainlab.study.sample_task import sample_state

MACRO = ("q_over_trace", "sin_phi", "packing_fraction", "z", "z_c", "z_core", "z_c_core",
         "eps_vol")
"""The results-table columns of the summary's macroscopic state."""

SUMMARY = "summary.csv"


def friction_angle(q_over_p: float) -> float:
    """Internal angle of friction phi [rad] of a triaxial test from the papers' q/p (q =
    (sigma_1 - sigma_3)/3; seed 002 eq. 11): sin phi = 3 (q/p) / (2 + q/p)."""
    s = 3.0 * q_over_p / (2.0 + q_over_p)
    return math.asin(s) if -1.0 <= s <= 1.0 else math.nan


def smoothed_peak(eps_q: np.ndarray, values: np.ndarray, width: float) -> tuple[float, float]:
    """The peak of a noisy curve: the largest running mean of ``values`` over the rows whose
    ``eps_q`` lies within width / 2 of a row's, and that row's eps_q [-]. ``width`` = 0 gives
    the largest row. (NaN, NaN) without finite rows.

    >>> eps = np.arange(0.0, 0.1, 0.001)
    >>> q = 0.5 - 50.0 * (eps - 0.04) ** 2 + 0.01 * np.cos(2 * np.pi * np.arange(100) / 11)
    >>> [round(v, 6) for v in smoothed_peak(eps, q, 0.0105)]  # 11 rows: the noise averages out
    [0.4995, 0.04]
    """
    if not (np.isfinite(width) and width >= 0.0):
        raise InputError("peak_window", width, "a width of eps_q >= 0")
    eps_q, values = np.asarray(eps_q, float), np.asarray(values, float)
    ok = np.isfinite(eps_q) & np.isfinite(values)
    eps_q, values = eps_q[ok], values[ok]
    if not eps_q.size:
        return math.nan, math.nan
    order = np.argsort(eps_q, kind="stable")
    eps_q, values = eps_q[order], values[order]
    sums = np.concatenate([[0.0], np.cumsum(values)])
    lo = np.searchsorted(eps_q, eps_q - 0.5 * width, side="left")
    hi = np.searchsorted(eps_q, eps_q + 0.5 * width, side="right")
    means = (sums[hi] - sums[lo]) / (hi - lo)
    k = int(np.argmax(means))
    return float(means[k]), float(eps_q[k])


def sample_row(folder: str | Path, window: tuple[float, float], value: float,
               microstructure: bool = True, core_margin: float = CORE_MARGIN,
               peak_window: float = 0.01) -> dict[str, Any]:
    """The summary row of the ended run in ``folder`` (module docstring); ``core_margin``:
    the core's distance from every wall in mean diameters (``core_margin_diameters``);
    ``peak_window``: the eps_q width of the running mean of the peak. The recorded rows'
    values (:func:`recorded_row`) stand where the snapshots' descriptors share their names."""
    folder = Path(folder)
    row = recorded_row(folder, window, value, core_margin, peak_window)
    if microstructure and (folder / SNAPSHOTS).exists():
        micro = _microstructure(folder / SNAPSHOTS, window, core_margin, row["eps_q_peak"])
        row.update({key: item for key, item in micro.items() if key not in row})
    return row


def recorded_row(folder: str | Path, window: tuple[float, float], value: float,
                 core_margin: float = CORE_MARGIN, peak_window: float = 0.01
                 ) -> dict[str, Any]:
    """The part of a sample's summary row read from its run's results table (kept when the
    sample is slimmed): the run's outcome and cost, the macroscopic state (``MACRO``) at the
    end of the compaction and over the window, the smoothed peak, phi* and sin phi* (seed
    002 eq. 11)."""
    folder = Path(folder)
    result = read_test_result(folder / RESULTS_H5)
    specimen, outcome = result.specimen, result.outcome
    cost = result.metadata.get("cost", {})
    table = shear_from_its_start(result.table)
    lo, hi = window
    row: dict[str, Any] = {
        "name": folder.name, "value": value,
        "measured": float(specimen.get("mean_angularity", value)),
        "shape": specimen.get("shape", ""), "n_particles": specimen.get("n_particles"),
        "status": outcome.get("status", ""), "as_asked": bool(outcome.get("as_asked")),
        "wall_time": cost.get("wall_time", math.nan), "steps": outcome.get("steps"),
        "capped_share": _capped_share(outcome),
        "eps_q_end": float(table["eps_q"].max()) if len(table) else math.nan, "note": "",
        "core_margin_diameters": core_margin}
    in_window = table[(table["eps_q"] >= lo) & (table["eps_q"] <= hi)] if len(table) else table
    for column in MACRO:
        values = table[column].to_numpy(float) if column in table else np.array([])
        row[f"{column}_initial"] = float(values[0]) if values.size else math.nan
        window_values = in_window[column].to_numpy(float) if column in in_window else values[:0]
        row[f"{column}_residual"] = float(np.mean(window_values)) if window_values.size \
            else math.nan
        row[f"{column}_residual_std"] = float(np.std(window_values, ddof=1)) \
            if window_values.size > 1 else math.nan
    row["peak_window"] = peak_window
    if len(table):
        q = table["q_over_trace"].to_numpy(float)
        row["q_over_trace_peak"], row["eps_q_peak"] = smoothed_peak(
            table["eps_q"].to_numpy(float), q, peak_window)
        row["q_over_trace_peak_raw"] = float(np.nanmax(q))
    else:
        row["q_over_trace_peak"] = row["eps_q_peak"] = row["q_over_trace_peak_raw"] = math.nan
    row["phi_residual"] = friction_angle(row["q_over_trace_residual"])
    row["sin_phi_star"] = math.sin(row["phi_residual"])
    if not len(in_window):
        row["note"] = (f"the run reached eps_q = {row['eps_q_end']:.3g}, not the window "
                       f"[{lo:g}, {hi:g}]")
    return row


def _capped_share(outcome: dict[str, Any]) -> float:
    steps = sum(s.get("steps", 0) for s in outcome.get("stages", []))
    capped = sum(s.get("capped_steps", 0) or 0 for s in outcome.get("stages", []))
    return capped / steps if steps else math.nan


def _microstructure(snapshots: Path, window: tuple[float, float], core_margin: float,
                    eps_q_peak: float = math.nan) -> dict[str, float]:
    """``M_initial``, ``M_residual`` and ``M_residual_std`` of every scalar descriptor (module
    docstring); the residual part is left out when no snapshot lies in the window."""
    from grainlab.analysis.snapshot_analysis import SnapshotAnalysis
    from grainlab.analysis.snapshot_files import read_snapshots
    from grainlab.analysis.window_average import WindowAverage

    out: dict[str, float] = {}
    initial = peak = None
    distance = math.inf
    for network in read_snapshots(snapshots):  # the compaction's last: its end
        stage = network.state.get("stage")
        if stage == "compaction":
            initial = network
        elif stage is not None and math.isfinite(eps_q_peak):
            gap = abs(float(network.state.get("eps_q", math.nan)) - eps_q_peak)
            if gap < distance:
                peak, distance = network, gap
    for state, network in (("initial", initial), ("at_peak", peak)):
        if network is None:
            continue
        analysis = SnapshotAnalysis(core_margin=core_margin).compute(network)
        for name, value in analysis.descriptors.items():
            if isinstance(value, int | float) and not isinstance(value, bool):
                out[f"{name}_{state}"] = float(value)
    if peak is not None:
        out["eps_q_peak_snapshot"] = float(peak.state["eps_q"])
    try:
        averages = WindowAverage(window, core_margin=core_margin).run(snapshots)
    except InputError:
        return out
    for _, row in averages.scalars.iterrows():
        out[f"{row['descriptor']}_residual"] = float(row["mean"])
        out[f"{row['descriptor']}_residual_std"] = float(row["std"])
    return out


def study_summary(study, microstructure: bool = True) -> pd.DataFrame:
    """The summary table of a :class:`~grainlab.study.study_runner.Study`: a row per ended
    sample, in the study's order; written to ``summary.csv`` in the study folder."""
    rows = []
    for sample in study.spec.samples:
        folder = study.sample_folder(sample.name)
        if sample_state(folder) != "ended":
            continue
        row = _row(folder, study, sample.value, microstructure)
        row["replica_of"] = sample.replica_of
        row["seed"] = study.spec.sample_config(sample.name).sample.seed
        rows.append(row)
    table = pd.DataFrame(rows)
    table.to_csv(study.folder / SUMMARY, index=False)
    return table


def _row(folder: Path, study, value: float, microstructure: bool) -> dict[str, Any]:
    """The summary row of an ended sample: computed from its run folder (and kept in its
    digest), or, once slimmed (no snapshots left), the row kept for the same settings
    (:mod:`~grainlab.lab.run_digest`), its recorded part (:func:`recorded_row`) read again
    from the kept results table. A cell has no walls and no core, so its kept row holds for
    any core margin (and names the study's); a box's kept row asked at another margin keeps
    its whole-box values and loses its core ones from the snapshots (``*_core*``: NaN, with a
    note), which need the run again."""
    header = study.spec.study
    settings = row_settings(header.window, header.core_margin, header.peak_window,
                            microstructure)
    cell = study.spec.sample_config(folder.name).sample.boundary == "periodic"
    if microstructure and not (folder / SNAPSHOTS).exists():
        kept = read_row(folder, settings, ignore=("core_margin",))
        if kept is not None:
            recorded = recorded_row(folder, header.window, value, header.core_margin,
                                    header.peak_window)  # the results table is kept
        if kept is not None and (cell or math.isclose(
                float(kept.get("core_margin_diameters", math.nan)), header.core_margin)):
            return {**kept, **recorded}
        if kept is not None:
            row = {key: (math.nan if "_core" in key and not isinstance(item, str) else item)
                   for key, item in kept.items()}
            row.update(recorded)
            row["note"] = " ".join(filter(None, (str(recorded.get("note") or ""), (
                f"slimmed with another core margin ({kept.get('core_margin_diameters')} "
                "<d>): no core values until the sample is run again"))))
            return row
    row = sample_row(folder, header.window, value, microstructure,
                     core_margin=header.core_margin, peak_window=header.peak_window)
    if (folder / SNAPSHOTS).exists():
        write_row(folder, row, settings)
    return row


def slim_study(study) -> dict[str, int]:
    """Slim every ended sample of ``study`` that still has its snapshots
    (:func:`~grainlab.lab.run_digest.slim_sample`: its summary row, window average and report
    snapshots kept, its snapshots and checkpoints removed); the bytes freed per sample. The
    summary and report of the study read the digests from then on; a sample not ended is left
    as it is, to be run on."""
    header = study.spec.study
    freed = {}
    for sample in study.spec.samples:
        folder = study.sample_folder(sample.name)
        if sample_state(folder) != "ended" or not (folder / SNAPSHOTS).exists():
            continue
        row = _row(folder, study, sample.value, True)
        settings = row_settings(header.window, header.core_margin, header.peak_window, True)
        freed[sample.name] = slim_sample(folder, row, settings, header.window,
                                         header.core_margin)
    return freed


POOLED_OTHERWISE = {"wall_time": np.nansum, "steps": np.nansum, "capped_share": np.nanmax}
"""The columns a pooled point does not average over its seeds' runs, and how it pools them
(:func:`pooled_replicas`): the cost summed, the capped share the largest."""


def pooled_replicas(table: pd.DataFrame) -> pd.DataFrame:
    """One row per sample of its own, its replicas (``replica_of``: the same shape with
    other packing seeds) pooled into it, in the table's order of those samples. A pooled row
    holds the mean over its ``n_seeds`` samples of every number, and as ``X_std`` the sample
    standard deviation over the seeds (ddof = 1) of every number X that is not itself a
    standard deviation: the error bar from independent samples, for the initial state too;
    the window's standard deviation it replaces, averaged over the seeds, stays as
    ``X_window_std``. ``wall_time`` and ``steps`` are the seeds' sums, the point's cost;
    ``capped_share`` the largest of the seeds' (the bound on steps at the sweep cap holds run
    by run). A row without
    replicas stays as it is, with ``n_seeds`` = 1. Replicas whose own sample has not ended
    (a study run ``--only`` on them) make their point on their own, under the first one's
    name, with ``seeds`` saying which. A table without ``replica_of`` is returned as it is.

    >>> table = pd.DataFrame({"name": ["a", "b", "a-seed1"], "replica_of": ["", "", "a"],
    ...                       "x_residual": [1.0, 5.0, 3.0], "x_residual_std": [0.1, 0.2, 0.3],
    ...                       "wall_time": [10.0, 20.0, 30.0],
    ...                       "capped_share": [0.004, 0.001, 0.009]})
    >>> pooled = pooled_replicas(table)
    >>> pooled[["name", "n_seeds", "x_residual", "wall_time", "capped_share"]].values.tolist()
    [['a', 2, 2.0, 40.0, 0.009], ['b', 1, 5.0, 20.0, 0.001]]
    >>> [round(float(pooled.loc[0, c]), 4) for c in ("x_residual_std", "x_residual_window_std")]
    [1.4142, 0.2]
    """
    if "replica_of" not in table or not len(table):
        return table
    base = table["replica_of"].fillna("").astype(str)
    groups = base.where(base != "", table["name"])
    numeric = [c for c in table.columns if pd.api.types.is_numeric_dtype(table[c])
               and c not in ("seed",)]
    ended = set(table["name"])
    points = list(dict.fromkeys(key for key, own in zip(groups, base, strict=True)
                                if own == "" or own not in ended))
    rows = []
    for name in points:
        group = pd.concat([table[table["name"] == name],  # the sample itself first
                           table[(groups == name) & (table["name"] != name)]])
        row = group.iloc[0].to_dict()
        row["n_seeds"] = len(group)
        if name not in ended and "seed" in group:  # replicas without their own sample
            row["seeds"] = ",".join(str(int(v)) for v in group["seed"])
        if len(group) > 1:
            for column in numeric:
                values = group[column].to_numpy(float)
                if column in POOLED_OTHERWISE:
                    row[column] = float(POOLED_OTHERWISE[column](values))
                    continue
                row[column] = float(np.nanmean(values)) if np.isfinite(values).any() \
                    else math.nan
                if column.endswith("_std"):
                    row[column.removesuffix("_std") + "_window_std"] = row[column]
            for column in numeric:
                if column.endswith("_std") or column in POOLED_OTHERWISE:
                    continue
                values = group[column].to_numpy(float)
                finite = values[np.isfinite(values)]
                row[f"{column}_std"] = float(np.std(finite, ddof=1)) if finite.size > 1 \
                    else math.nan
            row["seeds"] = ",".join(str(int(v)) for v in group["seed"]) if "seed" in group \
                else ""
        rows.append(row)
    return pd.DataFrame(rows)
