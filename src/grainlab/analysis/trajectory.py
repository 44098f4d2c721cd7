"""The analysis of a whole run: every snapshot's descriptors in one table, and the averages
over a strain window (the residual state of seeds 002/003).

Follows the prepare / per-snapshot / conclude pattern (MDAnalysis ``AnalysisBase``): a run's
snapshots stream through one at a time, so memory holds a single snapshot.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from numbers import Number
from typing import Any

import numpy as np
import pandas as pd

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.snapshot_analysis import SnapshotAnalysis
from grainlab.errors import InputError
from grainlab.result.columns import unit_of
from grainlab.result.test_result import TestResult


def descriptor_unit(name: str) -> str:
    """Unit of a descriptor column: that of :mod:`grainlab.result.columns` for a standard
    column, else Pa for stresses, N for forces, m for lengths, deg for angles."""
    standard = unit_of(name)
    if standard:
        return standard
    if name.startswith("sigma_"):
        return "Pa"
    if name.startswith("mean_") and "force" in name:
        return "N"
    if name.startswith("mean_") and ("length" in name or "branch" in name):
        return "m"
    if name.endswith("_deg"):
        return "deg"
    return "-"


class TrajectoryAnalysis:
    """Turn a run's snapshots into a per-snapshot table of every descriptor.

    Parameters are those of :class:`SnapshotAnalysis`.

    >>> from grainlab.analysis.synthetic import synthetic_network
    >>> nets = [synthetic_network(500, a_c=a, seed=k) for k, a in enumerate((0.0, 0.1, 0.2))]
    >>> for k, net in enumerate(nets):
    ...     net.state["eps_q"] = 0.1 * k
    >>> table = TrajectoryAnalysis().run(nets).table
    >>> len(table), "a_c" in table.columns
    (3, True)
    """

    def __init__(self, **snapshot_options: Any) -> None:
        self.snapshot_options = snapshot_options
        SnapshotAnalysis(**snapshot_options)  # validate the options now, not mid-run
        self._table: pd.DataFrame | None = None
        self.last: SnapshotAnalysis | None = None

    # -- the three stages ---------------------------------------------------------------------
    def _prepare(self) -> None:
        self._rows: list[dict[str, Any]] = []

    def _single_snapshot(self, index: int, network: ContactNetwork) -> None:
        analysis = SnapshotAnalysis(**self.snapshot_options).compute(network)
        row: dict[str, Any] = {"snapshot": index}
        descriptors = analysis.descriptors
        for key, value in network.state.items():  # state entries never hide a descriptor
            if isinstance(value, Number | str):
                row[f"state_{key}" if key in descriptors else key] = value
        row.update(descriptors)
        self._rows.append(row)
        self.last = analysis

    def _conclude(self) -> None:
        self._table = pd.DataFrame(self._rows)

    def run(
        self,
        snapshots: Iterable[ContactNetwork],
        progress: Callable[[int], None] | None = None,
    ) -> TrajectoryAnalysis:
        """Analyse every snapshot in order; ``progress`` is called after each."""
        analyse_in_order(self, snapshots, progress)
        return self

    # -- results ------------------------------------------------------------------------------
    @property
    def table(self) -> pd.DataFrame:
        """One row per snapshot: its state (step, time, strains) and every descriptor."""
        if self._table is None:
            from grainlab.analysis.compute import NotComputedError

            raise NotComputedError("TrajectoryAnalysis.table is not available: call run() first.")
        return self._table

    def residual_state(
        self, strain: str = "eps_q", window: tuple[float, float] = (0.5, 0.9)
    ) -> pd.DataFrame:
        """Mean and standard deviation of every numeric descriptor over the snapshots whose
        ``strain`` lies in ``window`` (inclusive); seeds 002/003 use eps_q in [0.5, 0.9]."""
        table = self.table
        if strain not in table.columns:
            known = ", ".join(map(str, table.columns[:8]))
            raise InputError("strain", strain, f"a column of the snapshots' state ({known}...)")
        low, high = window
        if not low <= high:
            raise InputError("window", window, "(low, high) with low <= high")
        inside = table[(table[strain] >= low) & (table[strain] <= high)]
        if inside.empty:
            raise InputError("window", window,
                             f"a strain window containing snapshots ({strain} spans "
                             f"{table[strain].min():.3g} to {table[strain].max():.3g})")
        numeric = inside.select_dtypes(include=[np.number]).drop(columns=["snapshot"],
                                                                  errors="ignore")
        return pd.DataFrame({
            "descriptor": numeric.columns,
            "mean": numeric.mean().to_numpy(),
            "std": numeric.std(ddof=1).fillna(0.0).to_numpy(),
            "n_snapshots": len(inside),
        })

    def to_test_result(self, source: str = "", strain: str | None = None):
        """The table as a :class:`~grainlab.result.TestResult` (metadata: source, options)."""
        dimension = 3
        if self.last is not None:
            dimension = self.last.network.dimension
        return TestResult.create(
            self.table,
            specimen={"kind": "contact-network snapshots", "source": source},
            load_path={"name": "as recorded in the run", "strain_column": strain},
            parameters={"analysis": self.snapshot_options},
            units={c: descriptor_unit(str(c)) for c in self.table.columns},
            dimension=dimension,
            title=f"microstructure of {source}" if source else "microstructure",
        )


def analyse_in_order(analysis, snapshots: Iterable[ContactNetwork],
                     progress: Callable[[int], None] | None = None) -> None:
    """One pass of ``analysis`` over ``snapshots`` in order: its ``_prepare()``, then
    ``_single_snapshot(index, network)`` for each (``progress(k)`` after the k-th), then
    ``_conclude()`` (the pass shared by :class:`TrajectoryAnalysis` and
    :class:`~grainlab.analysis.window_average.WindowAverage`)."""
    analysis._prepare()
    for index, network in enumerate(snapshots):
        analysis._single_snapshot(index, network)
        if progress is not None:
            progress(index + 1)
    analysis._conclude()
