"""Window averages of several runs pooled into one: the distributions of independent packings
of one shape (a sample and its replicas) averaged over all their snapshots in the window.

Each run's :class:`~grainlab.analysis.window_average.WindowAverage` keeps, per bin and column
c, the mean ``c_mean``, the sample standard deviation ``c_std`` (ddof = 1) and the count
``c_n`` of its n_i snapshots holding a finite value. The pooled table is what one
WindowAverage over every run's snapshots would give (each snapshot weighing the same):

    N = sum_i n_i,
    M = sum_i n_i m_i / N,
    S^2 = ( sum_i (n_i - 1) s_i^2 + sum_i n_i (m_i - M)^2 ) / (N - 1),

NaN where N = 0 (M) or N < 2 (S). A run with n_i = 1 adds no spread of its own (its s_i is
NaN), only its deviation from M.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from grainlab.errors import InputError

_MOMENTS = ("_mean", "_std", "_n")
"""Suffixes of the three columns a window average keeps per averaged quantity."""


def _averaged_columns(table: pd.DataFrame) -> tuple[list[str], list[str]]:
    """The bin columns of ``table`` and the stems c of its averaged quantities (those with
    c_mean, c_std and c_n)."""
    stems = [c.removesuffix("_mean") for c in table.columns if c.endswith("_mean")
             and f"{c.removesuffix('_mean')}_std" in table
             and f"{c.removesuffix('_mean')}_n" in table]
    averaged = {f"{stem}{suffix}" for stem in stems for suffix in _MOMENTS}
    return [c for c in table.columns if c not in averaged], stems


def pooled_table(tables: Sequence[pd.DataFrame], name: str = "table") -> pd.DataFrame:
    """One window-average table (module docstring) from those of several runs over the same
    bins; raises :class:`InputError` (field ``name``) when their bins differ."""
    if not tables:
        raise InputError(name, "[]", "at least one window-average table to pool")
    first = tables[0]
    bins, stems = _averaged_columns(first)
    for other in tables[1:]:
        same = (list(other.columns) == list(first.columns) and len(other) == len(first)
                and np.allclose(other[bins].to_numpy(float), first[bins].to_numpy(float),
                                equal_nan=True))
        if not same:
            raise InputError(name, f"{len(other)} rows, columns {list(other.columns)[:4]}...",
                             f"the bins of the first run's table ({len(first)} rows, "
                             f"columns {list(first.columns)[:4]}...)")
    pooled = first[bins].copy()
    for stem in stems:
        n = np.stack([t[f"{stem}_n"].to_numpy(float) for t in tables])
        mean = np.stack([t[f"{stem}_mean"].to_numpy(float) for t in tables])
        std = np.stack([t[f"{stem}_std"].to_numpy(float) for t in tables])
        total = n.sum(axis=0)
        weighted = np.where(n > 0, n * np.nan_to_num(mean), 0.0).sum(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            grand = np.where(total > 0, weighted / np.maximum(total, 1), np.nan)
            within = np.where(n > 1, (n - 1) * np.nan_to_num(std) ** 2, 0.0).sum(axis=0)
            between = np.where(n > 0, n * (np.nan_to_num(mean) - grand) ** 2, 0.0).sum(axis=0)
            spread = np.where(total > 1, np.sqrt((within + between) / np.maximum(total - 1, 1)),
                              np.nan)
        pooled[f"{stem}_mean"] = grand
        pooled[f"{stem}_std"] = spread
        pooled[f"{stem}_n"] = total.astype(np.int64)
    return pooled


def pooled_distributions(parts: Sequence[Mapping[str, pd.DataFrame]]
                         ) -> dict[str, pd.DataFrame]:
    """The distributions (force PDFs and angular tables by name, as
    :attr:`WindowAverage.distributions` gives them) of several runs pooled name by name over
    the names every run holds."""
    if not parts:
        raise InputError("distributions", "[]", "at least one run's window average to pool")
    names = [name for name in parts[0] if all(name in part for part in parts[1:])]
    return {name: pooled_table([part[name] for part in parts], name) for name in names}
