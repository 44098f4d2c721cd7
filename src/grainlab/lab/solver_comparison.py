"""One lab test run with two discrete solvers on the same specimen, and the two runs side by
side (ARCHITECTURE.md, "One laboratory": comparisons work on the test-result format only).

The pair is :data:`~grainlab.lab.solver_registry.COMPARED` unless told otherwise (``pair``),
the reference first. A comparison is a folder holding two ordinary run folders
(:mod:`grainlab.lab.discrete_run`), one per solver, named after it: by default ``cd/``
(contact dynamics: rigid grains, implicit) and ``dem/`` (soft-contact DEM: elastic contacts,
explicit), whose configs differ only in ``[solver] method``
(:func:`solver_configs`): the same ``[sample]`` (seed included, hence the same loose
particles), the same preparation, load path, numerics of the stages and output. The
``[solver.dem]`` keys act on the DEM run only; the keys of the contact-dynamics solve
(``sweep``, ``tolerance``, ``max_iterations``, ``theta``, ``overlap_recovery``) on the CD
run only.

Each run folder is opened by :func:`open_solver_run`: a run that ended (``results.h5``
written: finished, or stopped in a stage) is reused as it is, untouched; a run with a
checkpoint resumes from it (:func:`~grainlab.lab.discrete_run.resume_run`); a new folder, or
one whose run never reached a checkpoint, starts. A folder holding a run of another config is
refused (:func:`check_solver_run`) naming the first key that differs, except the keys of
how a run is solved and written (:data:`KEPT_FROM_THE_FOLDER`: those a resumed run may change,
the test's targets apart), which stay as the folder's run has them, so that a run resumed by
hand (``grainlab resume DIR/dem --set solver.max_stage_steps=400000``) is reused.

:class:`SolverComparison` reads the two results (or run folders) and tabulates, per solver,
the measures of :func:`run_measures` (the numbers each run's summary prints) and the cost
(:class:`~grainlab.lab.run_outcome.RunCost`), with the second minus the first and the
second over the first per row (:func:`difference_columns`: ``dem_minus_cd``,
``dem_over_cd``).

>>> configs = solver_configs(RunConfig.model_validate({"sample": {"n_particles": 40}}))
>>> {method: config.solver.method for method, config in configs.items()}
{'cd': 'cd', 'dem': 'dem'}
>>> configs["cd"].sample == configs["dem"].sample
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from grainlab.analysis.compute import Compute
from grainlab.errors import InputError
from grainlab.lab import solver_registry
from grainlab.lab.discrete_run import (
    CHECKPOINT,
    CONFIG,
    PREVIOUS_CHECKPOINT,
    RESULTS,
    RESULTS_H5,
    DiscreteRun,
    resume_run,
    start_run,
)
from grainlab.lab.run_config import (
    CHANGEABLE_ON_RESUME,
    RunConfig,
    current_layout,
    flat_keys,
)
from grainlab.lab.run_outcome import RunCost, RunOutcome
from grainlab.result.test_result import TestResult, read_test_result

SOLVERS = solver_registry.COMPARED
"""The two solvers compared by default, the reference first; also the names of the run
folders."""

SOLVER_NAMES = {name: record.title for name, record in solver_registry.SOLVERS.items()}

RESIDUAL_SHARE = 0.3
"""The residual state of a shear test: the mean over the records whose eps_q is in the last
30 % of the largest eps_q reached (as each run's summary says)."""

OEDOMETER_STAGES = ("loading", "unloading")

KEPT_FROM_THE_FOLDER = tuple(key for key in CHANGEABLE_ON_RESUME if not key.startswith("test."))
"""Keys in which a run folder's config may differ from the one asked and be reused: how its
run is solved and written. A test's targets must match (a run that ended at another target
cannot be extended)."""


@dataclass(frozen=True)
class Measure:
    """One row of the comparison: ``name`` (the CSV's key), what it is in words, its unit."""

    name: str
    meaning: str
    unit: str = "-"


def solver_configs(config: RunConfig, pair: tuple[str, str] = SOLVERS
                   ) -> dict[str, RunConfig]:
    """``config`` once per solver of ``pair``, with only ``[solver] method`` set."""
    return {method: config.with_updates({"solver": {"method": method}})
            for method in _checked_pair(pair)}


def _checked_pair(pair: tuple[str, str]) -> tuple[str, str]:
    """``pair`` if it is two registered solvers, else an :class:`InputError` naming it."""
    if not isinstance(pair, tuple) or len(pair) != 2 or pair[0] == pair[1] \
            or any(name not in solver_registry.SOLVERS for name in pair):
        raise InputError("pair", pair, "two different solvers of "
                         + ", ".join(repr(m) for m in solver_registry.SOLVERS))
    return pair


def difference_columns(pair: tuple[str, str] = SOLVERS) -> tuple[str, str]:
    """The columns of the comparison's differences for ``pair`` = (reference, other):
    ``("dem_minus_cd", "dem_over_cd")`` for the default pair.

    >>> difference_columns(("cd", "dem"))
    ('dem_minus_cd', 'dem_over_cd')
    """
    reference, other = pair
    return f"{other}_minus_{reference}", f"{other}_over_{reference}"


def run_state(folder: str | Path) -> str:
    """What a run folder holds: ``"ended"`` (results.h5 written), ``"checkpointed"`` (a
    checkpoint to resume from), ``"started"`` (a config, no checkpoint yet) or ``"none"``."""
    folder = Path(folder)
    if not (folder / CONFIG).exists():
        return "none"
    if (folder / RESULTS_H5).exists():
        return "ended"
    if (folder / CHECKPOINT).exists() or (folder / PREVIOUS_CHECKPOINT).exists():
        return "checkpointed"
    return "started"


def check_solver_run(folder: str | Path, config: RunConfig, *, overwrite: bool = False
                     ) -> None:
    """Refuse, before anything is written, a config the solver cannot run
    (:meth:`~grainlab.lab.run_config.RunConfig.check_solver`) and a run folder that holds a
    run of another config (module docstring): an :class:`InputError` naming the config key,
    the value asked and the folder's."""
    config.check_solver()
    config.load_path()
    folder = Path(folder)
    if overwrite or run_state(folder) in ("none", "started"):
        return  # nothing run yet: started over with this config
    held = RunConfig.read(folder / CONFIG, saved=True)
    asked, kept = flat_keys(config.model_dump()), flat_keys(held.model_dump())
    for key, value in asked.items():
        if kept.get(key) != value and key not in KEPT_FROM_THE_FOLDER:
            raise InputError(key, value, (
                f"{kept.get(key)!r}, the value of the run already in {folder} (start both "
                "runs over with overwrite / --overwrite, or use another folder)"))


def open_solver_run(folder: str | Path, config: RunConfig, *, overwrite: bool = False
                    ) -> DiscreteRun | TestResult:
    """The run of ``config`` in ``folder`` (module docstring): the result of a run that ended
    (reused, nothing written), or the run to go on with (resumed from its checkpoint, or
    started; call its :meth:`~grainlab.lab.discrete_run.DiscreteRun.run`). ``overwrite``
    starts over whatever the folder holds."""
    check_solver_run(folder, config, overwrite=overwrite)
    state = "none" if overwrite else run_state(folder)
    if state == "ended":
        return read_run_result(folder)
    if state == "checkpointed":
        return resume_run(folder)
    return start_run(folder, config, overwrite=state != "none" or overwrite)


def read_run_result(run: str | Path | TestResult) -> TestResult:
    """The result of a run folder (its results.h5, else the results.csv of its last
    checkpoint), of a results file, or ``run`` itself if it is one."""
    if isinstance(run, TestResult):
        return run
    path = Path(run)
    if path.is_dir():
        for name in (RESULTS_H5, RESULTS):
            if (path / name).exists():
                return read_test_result(path / name)
        raise InputError("run folder", str(path), f"a run folder with results ({RESULTS_H5} "
                                                   f"or {RESULTS})")
    return read_test_result(path)


def run_config(result: TestResult) -> dict[str, Any]:
    """The config of a discrete run's result, as plain data in the current layout."""
    config = result.metadata.get("parameters", {}).get("config")
    if not isinstance(config, dict):
        raise InputError("result", result.metadata.get("title", "?"),
                         "the result of a discrete run (its config in metadata)")
    return current_layout(config)[0]


def solver_label(result: TestResult) -> str:
    """The solver of a run in words: ``"contact dynamics (cd)"``, ``"soft-contact DEM (dem):
    linear, kappa = 1000"``."""
    return solver_registry.solver_label(run_config(result).get("solver", {}))


def residual_rows(shear: pd.DataFrame) -> pd.DataFrame:
    """The records of a shear in its residual state (:data:`RESIDUAL_SHARE`)."""
    return shear[shear["eps_q"] >= (1.0 - RESIDUAL_SHARE) * shear["eps_q"].max()]


def run_measures(result: TestResult) -> tuple[tuple[Measure, float], ...]:
    """The measures of one discrete run, from its results table (the numbers its summary
    prints): at the end of the compaction the packing fraction, z (with and without
    rattlers) and p; then, for an oedometer, eps_zz, sigma_zz, K0, the packing fraction and
    z at the end of each of its stages; for the other tests, the peak q/p after the
    compaction, and over its residual state (:data:`RESIDUAL_SHARE`) the mean q/p, packing
    fraction and z, and eps_vol at the end."""
    table = result.table
    kind = run_config(result).get("test", {}).get("kind", "")
    out: list[tuple[Measure, float]] = []
    compaction = table[table["stage"] == "compaction"]
    if len(compaction):
        end = compaction.iloc[-1]
        for column, words, unit in (
                ("packing_fraction", "packing fraction", "-"), ("z", "coordination number z",
                                                                "-"),
                ("z_no_rattlers", "z without rattlers", "-"), ("p", "mean stress p", "Pa")):
            out.append((Measure(f"compaction_{column}", f"{words} at the end of compaction",
                                unit), _value(end, column)))
    later = table[table["stage"] != "compaction"]
    if kind == "oedometer":
        for stage in OEDOMETER_STAGES:
            rows = later[later["stage"] == stage]
            if not len(rows):
                continue
            end = rows.iloc[-1]
            for column, words, unit in (
                    ("eps_zz", "eps_zz", "-"), ("sigma_zz", "sigma_zz", "Pa"),
                    ("K0", "K0 = (sigma_xx + sigma_yy) / (2 sigma_zz)", "-"),
                    ("packing_fraction", "packing fraction", "-"),
                    ("z", "coordination number z", "-")):
                out.append((Measure(f"{stage}_{column}", f"{words} at the end of {stage}",
                                    unit), _value(end, column)))
    elif len(later):
        late = residual_rows(later)
        window = f"over the last {100 * RESIDUAL_SHARE:g} % of eps_q"
        out += [
            (Measure("peak_q_over_trace", "peak q/p"), float(later["q_over_trace"].max())),
            (Measure("residual_q_over_trace", f"q/p {window}"),
             float(late["q_over_trace"].mean())),
            (Measure("residual_packing_fraction", f"packing fraction {window}"),
             float(late["packing_fraction"].mean())),
            (Measure("residual_z", f"coordination number z {window}"),
             float(late["z"].mean())),
            (Measure("final_eps_vol", "eps_vol at the end (compression > 0)"),
             _value(later.iloc[-1], "eps_vol")),
        ]
    return tuple(out)


def _value(row: pd.Series, column: str) -> float:
    return float(row[column]) if column in row.index else math.nan


COST_MEASURES = (
    Measure("wall_time", "wall time", "s"),
    Measure("steps", "steps"),
    Measure("substeps", "sub-steps (explicit solver)"),
    Measure("as_asked", "outcome as asked (1 yes, 0 no)"),
)
"""The rows after the measures: what each run took, and its verdict."""


def _cost_values(result: TestResult) -> list[float]:
    cost = RunCost.of_result(result)
    return [cost.wall_time, float(cost.steps),
            math.nan if cost.substeps is None else float(cost.substeps),
            1.0 if RunOutcome.of_result(result).as_asked else 0.0]


class SolverComparison(Compute):
    """The two runs of one test side by side (module docstring; the compute-object pattern:
    :meth:`compute`, then the properties); ``pair`` (reference, other) the solvers compared
    (default :data:`SOLVERS`).

    :attr:`table` has one row per measure (:func:`run_measures`, then wall time, steps,
    sub-steps and the verdict) and the columns ``quantity``, ``meaning``, ``unit``, one per
    solver of the pair (``cd``, ``dem``), and the other minus and over the reference
    (:func:`difference_columns`: ``dem_minus_cd`` and ``dem_over_cd``; NaN where the
    quantity has no value for a solver, e.g. contact dynamics' sub-steps, or for the
    verdict).
    """

    def __init__(self, pair: tuple[str, str] = SOLVERS) -> None:
        super().__init__()
        self.pair = _checked_pair(pair)

    def compute(self, runs: Mapping[str, str | Path | TestResult]) -> SolverComparison:
        """Compare ``runs`` = ``{"cd": ..., "dem": ...}`` (a key per solver of the pair),
        each a run folder, a results file or a :class:`~grainlab.result.test_result.
        TestResult`: runs of the same test on the same sample (the ``[sample]`` and
        ``[test]`` of their configs equal), each with the solver it is named after. Returns
        self."""
        if not isinstance(runs, Mapping) or set(runs) != set(self.pair):
            shown = sorted(runs) if isinstance(runs, Mapping) else type(runs).__name__
            raise InputError("runs", shown, "a mapping with the keys "
                             + " and ".join(repr(m) for m in self.pair))
        results = {method: read_run_result(runs[method]) for method in self.pair}
        _check_same_test(results, self.pair)
        self._results = {}
        self._store(results=results,
                    kind=run_config(results[self.pair[0]])["test"].get("kind", ""),
                    table=_comparison_table(results, self.pair))
        return self

    @property
    def results(self) -> dict[str, TestResult]:
        """The two results, by solver."""
        return self._get("results")

    @property
    def kind(self) -> str:
        """The lab test compared (``test.kind`` of the configs)."""
        return self._get("kind")

    @property
    def table(self) -> pd.DataFrame:
        """The comparison (class docstring)."""
        return self._get("table")


def _check_same_test(results: dict[str, TestResult], pair: tuple[str, str]) -> None:
    configs = {method: run_config(result) for method, result in results.items()}
    for method, config in configs.items():
        solver = config.get("solver", {}).get("method", solver_registry.DEFAULT_SOLVER)
        if solver != method:
            raise InputError(f"runs[{method!r}]", solver, f"a run with solver.method = "
                             f"{method!r}")
    reference, other = pair
    for section in ("sample", "test"):
        first, second = (flat_keys(configs[m].get(section, {}), f"{section}.") for m in pair)
        for key in sorted(set(first) | set(second)):
            if first.get(key) != second.get(key):
                raise InputError(f"runs[{other!r}] {key}", second.get(key), (
                    f"{first.get(key)!r} as in the {reference} run: the two runs must be the "
                    "same test on the same sample ([sample] and [test] of their configs "
                    "equal)"))


def _comparison_table(results: dict[str, TestResult], pair: tuple[str, str]
                      ) -> pd.DataFrame:
    reference, other = pair
    measured = {method: run_measures(result) for method, result in results.items()}
    names = dict.fromkeys(m for method in pair for m, _ in measured[method])
    values = {method: {m.name: v for m, v in measured[method]} for method in pair}
    rows = [(m, values[reference].get(m.name, math.nan), values[other].get(m.name, math.nan))
            for m in names]
    costs = {method: _cost_values(result) for method, result in results.items()}
    rows += [(m, a, b) for m, a, b in zip(COST_MEASURES, costs[reference], costs[other],
                                           strict=True)]
    table = pd.DataFrame({
        "quantity": [m.name for m, _, _ in rows], "meaning": [m.meaning for m, _, _ in rows],
        "unit": [m.unit for m, _, _ in rows],
        reference: np.array([a for _, a, _ in rows], dtype=float),
        other: np.array([b for _, _, b in rows], dtype=float)})
    minus, over = difference_columns(pair)
    with np.errstate(divide="ignore", invalid="ignore"):
        table[minus] = table[other] - table[reference]
        table[over] = np.where(table[reference] != 0.0, table[other] / table[reference],
                               math.nan)
    verdict = table["quantity"] == "as_asked"
    table.loc[verdict, [minus, over]] = math.nan
    return table
