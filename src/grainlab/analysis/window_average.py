"""Averages of every microstructure descriptor over a window of a run (the residual state of
seeds 002 and 003).

Seed 003 averages each descriptor over the snapshots whose deviatoric strain lies in
eps_q in [0.5, 0.9] (seed 002 from about 0.6) and draws the standard deviation as error bars;
the force PDFs and the angular distributions P(theta), <f_n>(theta), <f_t>(theta),
<l_n>(theta) are averaged over the same snapshots, bin by bin. For a quantity x_k of the n
snapshots k in the window:

    mean  <x> = (1/n) sum_k x_k,
    std   s   = sqrt( sum_k (x_k - <x>)^2 / (n - 1) )   (sample standard deviation, ddof = 1),

each snapshot weighing the same (a per-bin mean such as <f_n>(theta) is the mean of the
snapshots' bin means, not a mean over the pooled contacts). s is NaN for n = 1. A value that
is NaN in a snapshot (an empty angular bin, C_lf over fewer than two pairs) is left out of
that quantity only; ``n`` says how many snapshots each mean holds.

Bins. The angular bins depend on the number of bins alone. The force PDFs of
:class:`~grainlab.analysis.force_statistics.ForceStatistics` are binned over each snapshot's
own range of f / <f>, which differs from snapshot to snapshot; here they are binned on fixed
edges (:data:`LINEAR_RATIO_RANGE`, :data:`LOG_RATIO_RANGE` unless given). Ratios outside the
edges are left out of the counts but not of the normalisation, and the share inside is averaged
as the scalar ``pdf_binned_fraction_<pdf>`` (1 when no ratio fell outside).

Snapshots stream through one at a time (memory holds one), as in
:class:`~grainlab.analysis.trajectory.TrajectoryAnalysis`: prepare / per snapshot / conclude.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from numbers import Number
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.snapshot_analysis import SnapshotAnalysis
from grainlab.analysis.snapshot_files import read_snapshots, resolve_snapshot_file
from grainlab.analysis.trajectory import analyse_in_order, descriptor_unit
from grainlab.errors import InputError

LINEAR_RATIO_RANGE = (0.0, 8.0)
"""Fixed range of f / <f> [-] of the linear bins of the averaged force PDFs."""
LOG_RATIO_RANGE = (1e-3, 10.0)
"""Fixed range of f / <f> [-] of the logarithmic bins of the averaged force PDFs."""

PDF_NAMES = ("normal_pdf_linear", "normal_pdf_log", "radial_pdf_linear", "radial_pdf_log")
"""The force PDFs averaged (properties of ForceStatistics)."""
ANGULAR_NAMES = ("contact_frame", "branch_frame")
"""The angular tables averaged (properties of AngularDistributions)."""
_BIN_COLUMNS = ("theta_deg", "theta_lo_deg", "theta_hi_deg", "solid_angle")
"""Columns of an angular table that define its bins (the same in every snapshot)."""


@dataclass(frozen=True)
class StrainWindow:
    """The snapshots whose state ``variable`` lies in [low, high] (both included), outside the
    stages named in ``skip_stages``.

    ``variable`` is a key of the snapshots' ``state`` (the discrete engine records step, time,
    stage, eps_q, eps_vol, the strains and the stresses of the results row). The compaction
    is skipped by default: its eps_q measures the box's distortion from the loose start, not
    the shear's strain, which counts from the end of the compaction. A snapshot without a
    ``stage`` is never skipped.

    >>> StrainWindow(0.5, 0.9).contains({"eps_q": 0.6, "stage": "shear"})
    True
    >>> StrainWindow(0.5, 0.9).contains({"eps_q": 0.6, "stage": "compaction"})
    False
    """

    low: float = 0.5
    high: float = 0.9
    variable: str = "eps_q"
    skip_stages: tuple[str, ...] = ("compaction",)

    def __post_init__(self) -> None:
        try:
            ordered = math.isfinite(self.low) and math.isfinite(self.high) and \
                self.low < self.high
        except TypeError:
            ordered = False
        if not ordered:
            raise InputError("window", (self.low, self.high),
                             "(low, high) two finite numbers with low < high")

    def considered(self, state: dict[str, Any]) -> bool:
        """True when the snapshot is outside the skipped stages and has the variable."""
        if state.get("stage") in self.skip_stages:
            return False
        value = state.get(self.variable)
        return isinstance(value, Number) and math.isfinite(float(value))

    def contains(self, state: dict[str, Any]) -> bool:
        """True when the snapshot of this ``state`` is in the window."""
        return self.considered(state) and self.low <= float(state[self.variable]) <= self.high

    def __str__(self) -> str:
        return f"{self.variable} in [{self.low:g}, {self.high:g}]"


class _Moments:
    """Running mean and sum of squared deviations of an array (Welford), NaN left out per
    element."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.n = np.zeros(shape, dtype=np.int64)
        self._mean = np.zeros(shape)
        self._m2 = np.zeros(shape)

    def add(self, values: np.ndarray) -> None:
        values = np.asarray(values, dtype=float)
        if values.shape != self.n.shape:
            raise InputError("snapshot bins", values.shape,
                             f"the bins of the window's first snapshot, {self.n.shape}")
        ok = np.isfinite(values)
        self.n[ok] += 1
        delta = np.where(ok, values - self._mean, 0.0)
        self._mean[ok] += delta[ok] / self.n[ok]
        self._m2[ok] += delta[ok] * (values[ok] - self._mean[ok])

    @property
    def mean(self) -> np.ndarray:
        return np.where(self.n > 0, self._mean, np.nan)

    @property
    def std(self) -> np.ndarray:
        """Sample standard deviation (ddof = 1); NaN below two values."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.n > 1, np.sqrt(self._m2 / np.maximum(self.n - 1, 1)), np.nan)


class WindowAverage:
    """Mean and standard deviation over a window of a run's snapshots of every scalar
    descriptor of :class:`SnapshotAnalysis`, of the force PDFs and of the angular
    distributions (module docstring).

    Parameters
    ----------
    window:
        A :class:`StrainWindow`, or (low, high) of eps_q (compaction skipped); default
        ``StrainWindow()``, eps_q in [0.5, 0.9] (seed 003).
    linear_edges, log_edges:
        Fixed (n_force_bins + 1,) bin edges of f / <f> [-]; default: ``n_force_bins`` equal
        bins over :data:`LINEAR_RATIO_RANGE`, equal in log over :data:`LOG_RATIO_RANGE`.
    distributions:
        ``"box"`` (default): the force PDFs and angular tables of the whole network;
        ``"core"``: those of the core's claimed contacts
        (:func:`~grainlab.analysis.wall_layer.core_network`) where the snapshot has a box and a
        core, else the whole network's.
    snapshot_options:
        Those of :class:`SnapshotAnalysis` (min_contacts, frame_level, friction_tolerance,
        n_force_bins, n_angle_bins, core_margin).

    Results after :meth:`run` (properties; :class:`NotComputedError` before):

    * ``scalars``: DataFrame, one row per descriptor: ``descriptor``, ``mean``, ``std``
      (sample, ddof = 1), ``n`` (snapshots holding a finite value), ``unit``;
    * ``distributions``: dict of DataFrames, one per force PDF (:data:`PDF_NAMES`: columns
      ``force_ratio`` (bin centre), ``ratio_lo``, ``ratio_hi``, ``density_mean``,
      ``density_std``, ``density_n``) and per angular frame (:data:`ANGULAR_NAMES`: the bin
      columns ``theta_deg``, ``theta_lo_deg``, ``theta_hi_deg``, ``solid_angle``, then
      ``<c>_mean``, ``<c>_std``, ``<c>_n`` for every other column c of
      :class:`~grainlab.analysis.angular_distributions.AngularDistributions`' tables);
    * ``snapshots``: DataFrame of the snapshots averaged: ``index`` (position in the run),
      ``step``, ``stage`` and the window's variable;
    * ``n_snapshots``; ``last``: the :class:`SnapshotAnalysis` of the last snapshot averaged.

    >>> from grainlab.analysis.synthetic import synthetic_network
    >>> nets = [synthetic_network(400, a_c=0.1, seed=k) for k in range(4)]
    >>> for k, net in enumerate(nets):
    ...     net.state["eps_q"] = k / 4
    >>> average = WindowAverage((0.5, 0.9)).run(nets)
    >>> average.n_snapshots, list(average.snapshots["eps_q"])
    (2, [0.5, 0.75])
    """

    def __init__(
        self,
        window: StrainWindow | tuple[float, float] | None = None,
        *,
        linear_edges: np.ndarray | None = None,
        log_edges: np.ndarray | None = None,
        distributions: str = "box",
        **snapshot_options: Any,
    ) -> None:
        if distributions not in ("box", "core"):
            raise InputError("distributions", distributions, '"box" or "core"')
        self.distributions_region = distributions
        if window is None:
            window = StrainWindow()
        elif not isinstance(window, StrainWindow):
            try:
                low, high = window
            except (TypeError, ValueError):
                raise InputError("window", window, "(low, high) or a StrainWindow") from None
            window = StrainWindow(float(low), float(high))
        self.window = window
        n_bins = SnapshotAnalysis(**snapshot_options).n_force_bins  # a wrong keyword fails now
        if linear_edges is None:
            linear_edges = np.linspace(*LINEAR_RATIO_RANGE, n_bins + 1)
        if log_edges is None:
            log_edges = np.geomspace(*LOG_RATIO_RANGE, n_bins + 1)
        self.snapshot_options = {**snapshot_options, "force_linear_edges": linear_edges,
                                 "force_log_edges": log_edges}
        self._done = False

    # -- the three stages ---------------------------------------------------------------------
    def _prepare(self) -> None:
        self._scalars: dict[str, _Moments] = {}
        self._tables: dict[str, tuple[pd.DataFrame, _Moments, list[str]]] = {}
        self._chosen: list[dict[str, Any]] = []
        self._span: list[float] = []
        self._seen = 0
        self.last: SnapshotAnalysis | None = None

    def _single_snapshot(self, index: int, network: ContactNetwork) -> None:
        self._seen += 1
        state = network.state
        if self.window.considered(state):
            self._span.append(float(state[self.window.variable]))
        if not self.window.contains(state):
            return
        analysis = SnapshotAnalysis(**self.snapshot_options).compute(network)
        self._chosen.append({"index": index, "step": state.get("step", np.nan),
                             "stage": state.get("stage", ""),
                             self.window.variable: float(state[self.window.variable])})
        values = {k: float(v) for k, v in analysis.descriptors.items()
                  if isinstance(v, Number) and not isinstance(v, bool)}
        forces, angular = analysis.forces, analysis.angular
        if self.distributions_region == "core" and analysis.core_parts is not None:
            forces, angular = analysis.core_parts["forces"], analysis.core_parts["angular"]
        for name in PDF_NAMES:
            pdf = getattr(forces, name)
            widths = np.diff(pdf.attrs["bin_edges"])
            values[f"pdf_binned_fraction_{name}"] = float(np.sum(pdf["density"] * widths)) \
                if np.all(np.isfinite(pdf["density"])) else float("nan")
            self._add_table(name, pdf, ["density"])
        for name in ANGULAR_NAMES:
            table = getattr(angular, name)
            self._add_table(name, table, [c for c in table.columns if c not in _BIN_COLUMNS])
        for key, value in values.items():
            self._scalars.setdefault(key, _Moments(())).add(np.asarray(value))
        self.last = analysis

    def _add_table(self, name: str, table: pd.DataFrame, columns: list[str]) -> None:
        values = table[columns].to_numpy(dtype=float)
        if name not in self._tables:
            if name in PDF_NAMES:
                edges = table.attrs["bin_edges"]
                bins = pd.DataFrame({"force_ratio": table["force_ratio"].to_numpy(),
                                     "ratio_lo": edges[:-1], "ratio_hi": edges[1:]})
            else:
                bins = table[list(_BIN_COLUMNS)].reset_index(drop=True)
            self._tables[name] = (bins, _Moments(values.shape), columns)
        self._tables[name][1].add(values)

    def _conclude(self) -> None:
        if not self._chosen:
            skipped = ", ".join(self.window.skip_stages)
            left_out = f" (stage {skipped} left out)" if skipped else ""
            if not self._span:
                known = (f"none of the run's {self._seen} snapshot(s){left_out} has "
                         f"{self.window.variable!r} in its state")
            else:
                known = (f"the run's {len(self._span)} snapshot(s){left_out} have "
                         f"{self.window.variable} from {min(self._span):.4g} to "
                         f"{max(self._span):.4g}")
            raise InputError("window", str(self.window),
                             f"a window holding at least one snapshot: {known}")
        rows = []
        for key, moments in self._scalars.items():
            rows.append({"descriptor": key, "mean": float(moments.mean),
                         "std": float(moments.std), "n": int(moments.n),
                         "unit": descriptor_unit(key)})
        self._scalar_table = pd.DataFrame(rows, columns=["descriptor", "mean", "std", "n",
                                                         "unit"])
        self._distributions = {}
        for name, (bins, moments, columns) in self._tables.items():
            table = bins.copy()
            mean, std = moments.mean, moments.std
            for k, column in enumerate(columns):
                table[f"{column}_mean"] = mean[:, k]
                table[f"{column}_std"] = std[:, k]
                table[f"{column}_n"] = moments.n[:, k]
            self._distributions[name] = table
        self._snapshot_table = pd.DataFrame(self._chosen)
        self._done = True

    def run(
        self,
        snapshots: str | Path | Iterable[ContactNetwork],
        progress: Callable[[int], None] | None = None,
    ) -> WindowAverage:
        """Average over the snapshots in the window: ``snapshots`` is a snapshot file, a run
        folder (its snapshots.h5) or an iterable of networks in the run's order;
        ``progress(k)`` is called after the k-th snapshot read. An empty window raises an
        :class:`InputError` naming the window and the range of the variable the run has."""
        if isinstance(snapshots, str | Path):
            snapshots = read_snapshots(resolve_snapshot_file(snapshots))
        self._done = False
        analyse_in_order(self, snapshots, progress)
        return self

    # -- results ------------------------------------------------------------------------------
    def _check(self, name: str) -> None:
        if not self._done:
            raise NotComputedError(f"WindowAverage.{name} is not available: call run() first.")

    @property
    def scalars(self) -> pd.DataFrame:
        """descriptor, mean, std (ddof = 1), n, unit: one row per scalar descriptor."""
        self._check("scalars")
        return self._scalar_table

    @property
    def distributions(self) -> dict[str, pd.DataFrame]:
        """The averaged force PDFs and angular tables by name (class docstring)."""
        self._check("distributions")
        return self._distributions

    @property
    def snapshots(self) -> pd.DataFrame:
        """The snapshots averaged: index, step, stage and the window's variable."""
        self._check("snapshots")
        return self._snapshot_table

    @property
    def n_snapshots(self) -> int:
        """Number of snapshots in the window."""
        self._check("n_snapshots")
        return len(self._snapshot_table)

    def scalar(self, name: str) -> tuple[float, float, int]:
        """(mean, std, n) of one descriptor."""
        table = self.scalars
        row = table[table["descriptor"] == name]
        if row.empty:
            raise InputError("descriptor", name, "a descriptor of the window average ("
                             + ", ".join(table["descriptor"][:6]) + ", ...)")
        return float(row["mean"].iloc[0]), float(row["std"].iloc[0]), int(row["n"].iloc[0])

    # -- output -------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON-ready but for NaN): window, snapshots, scalars by name,
        distributions as column lists."""
        w = self.window
        return {
            "window": {"variable": w.variable, "low": w.low, "high": w.high,
                       "skip_stages": list(w.skip_stages)},
            "std": "sample standard deviation (ddof = 1) over the snapshots",
            "n_snapshots": self.n_snapshots,
            "snapshots": self.snapshots.to_dict(orient="list"),
            "scalars": {row.descriptor: {"mean": row.mean, "std": row.std, "n": int(row.n),
                                         "unit": row.unit}
                        for row in self.scalars.itertuples(index=False)},
            "distributions": {name: table.to_dict(orient="list")
                              for name, table in self.distributions.items()},
        }

    def write(self, folder: str | Path, prefix: str = "window") -> list[Path]:
        """Write ``<prefix>_scalars.csv`` (descriptor, mean, std, n, unit) and one
        ``<prefix>_<distribution>.csv`` per distribution into ``folder``; returns the paths."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        paths = [folder / f"{prefix}_scalars.csv"]
        self.scalars.to_csv(paths[0], index=False, float_format="%.10g")
        for name, table in self.distributions.items():
            paths.append(folder / f"{prefix}_{name}.csv")
            table.to_csv(paths[-1], index=False, float_format="%.10g")
        return paths
