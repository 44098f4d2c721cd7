"""A discrete run and seed 001's micro-element model of its own packing, on the same load
path and the same strain grid (ARCHITECTURE.md, "One laboratory": a theory and a simulation
read as the same test result).

The model is built from the run's snapshot at the end of its compaction, with the run's
forces as its initial state and the run's contact law (:mod:`grainlab.lab.run_micro_element`),
and driven by the run's recorded load path from the first stage after the compaction on
(:func:`~grainlab.lab.run_micro_element.model_path`), once per distribution law asked.

Both sides are tabulated with the same columns (:data:`CURVE_COLUMNS`): ``eps_axial``, the
vertical strain (eps_zz; eps_yy of a 2D run of discs) counted from the end of the compaction
(compression > 0); ``eps_q`` (eps_1 - eps_3); ``q_over_p`` = (sigma_1 - sigma_3) / p,
p = trace/3 (2D: trace/2); ``eps_vol`` (trace of the strain, compression > 0); ``K0`` =
(sigma_xx + sigma_yy) / (2 sigma_zz) (2D: sigma_xx / sigma_yy); ``sigma_v`` the vertical
stress (sigma_zz; 2D: sigma_yy); ``phi_mob`` the mobilised friction angle
asin((sigma_1 - sigma_3) / (sigma_1 + sigma_3)) [deg], which compares tests of any b (the
cubical paths). Each stage is
on the simulation's grid: the vertical strains of the run's rows in that stage, inside the
range the model reached in it, the model's values interpolated linearly in eps_axial (the
vertical strain is monotonic within a stage of the tests compared: :data:`THEORY_KINDS`).
Row 0 of each side is the state at the end of the compaction (stage ``"initial"``).

:attr:`TheoryComparison.differences` says by how much the model and the run differ: per
distribution law the peak q/p, the q/p and eps_vol at the largest strain both reached, and
the dilatancy rate -d eps_vol / d|eps_axial| (> 0 dilating) fitted over the last
:data:`DILATANCY_SHARE` of that strain range (triaxial, extension); for an oedometer K0
and sigma_v at the end of each stage; the mean stress p at the start (the model's is the
snapshot's contact-force stress, the run's its boundary's); and, each side over its own
rows (a model that stops early, or a run recorded sparsely, leaves little on the common
grid), the strain each reached and its peak q/p.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from grainlab.analysis.compute import Compute
from grainlab.errors import GrainlabError, InputError
from grainlab.lab.element_test import run_element_test
from grainlab.lab.run_micro_element import (
    COMPACTION,
    check_distributions,
    compaction_snapshot,
    model_path,
    run_micro_element_model,
)
from grainlab.lab.solver_comparison import read_run_result, run_config
from grainlab.result.test_result import TestResult

THEORY_KINDS = ("triaxial", "extension", "oedometer", "true_triaxial", "cubical")
"""The lab tests the model follows after a run: those driven along the vertical strain
(a monotonic eps_zz per stage: lateral stress or lateral strain held; the cubical tests at
constant p or constant sigma_3, z major)."""

SIMULATION = "simulation"
"""The ``side`` of the run's rows (a model's side is its distribution law)."""

CURVE_COLUMNS = ("side", "stage", "eps_axial", "eps_q", "q_over_p", "eps_vol", "K0",
                 "sigma_v", "p", "phi_mob")
"""The columns of :attr:`TheoryComparison.curves` (module docstring; sigma_v and p in Pa,
phi_mob in degrees)."""

DILATANCY_SHARE = 0.3
"""The dilatancy rate is fitted over the last 30 % of the common strain range."""

INITIAL = "initial"

GRID_SLACK = 1e-6
"""A run's row counts as inside the model's strain range within this fraction of the largest
strain [-]: a stage's end strain, reached by both, differs by the run's integration of its
cell's strain rate (1e-8 of it in a DEM oedometer, where 1e-9 dropped the run's last
loading row and with it the whole unloading); beyond the model's range its value is its
end value (np.interp), off by the slope times this slack at most."""


def check_theory_kind(kind: str, field: str = "KIND") -> str:
    """``kind`` if the model can follow it (:data:`THEORY_KINDS`)."""
    if kind not in THEORY_KINDS:
        raise InputError(field, kind, "one of " + ", ".join(THEORY_KINDS) + " (the tests "
                         "the micro-element model follows along the vertical strain)")
    return kind


def _curves(table: pd.DataFrame, side: str) -> pd.DataFrame:
    """The columns of :data:`CURVE_COLUMNS` of a results table whose first row is the state
    the path starts from and whose strains are counted from it."""
    planar = "sigma_zz" not in table.columns  # a 2D run's: vertical axis y
    vertical = "yy" if planar else "zz"
    sigma_v = table[f"sigma_{vertical}"].to_numpy(dtype=float)
    lateral = table["sigma_xx"].to_numpy(dtype=float) if planar else 0.5 * (
        table["sigma_xx"].to_numpy(dtype=float) + table["sigma_yy"].to_numpy(dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        k0 = lateral / sigma_v
        p = table["p"].to_numpy(dtype=float)
        ratio = table["q"].to_numpy(dtype=float) / p
    phi = np.degrees(np.arcsin(np.clip(table["sin_phi"].to_numpy(dtype=float), -1.0, 1.0)))
    return pd.DataFrame({
        "side": side, "stage": table["stage"].astype(str).to_numpy(),
        "eps_axial": table[f"eps_{vertical}"].to_numpy(dtype=float),
        "eps_q": table["eps_q"].to_numpy(dtype=float), "q_over_p": ratio,
        "eps_vol": table["eps_vol"].to_numpy(dtype=float), "K0": k0, "sigma_v": sigma_v,
        "p": p, "phi_mob": phi})


def model_curves(test: TestResult, side: str) -> pd.DataFrame:
    """A model's element test as curves, without the row of the step that failed: the
    driver records the specimen as that step left it (:mod:`grainlab.lab.element_test`),
    which is not a state the path reached (its stress targets unmet, the strain of a
    diverging correction: eps_vol -16.6 in one biaxial test of discs)."""
    table = test.table
    outcome = test.metadata.get("outcome", {})
    if outcome.get("status") == "failure" and len(table) > 1 and \
            not bool(table["converged"].iloc[-1]):
        table = table.iloc[:-1]
    return _curves(table, side)


def simulation_curves(result: TestResult) -> pd.DataFrame:
    """The run's rows after its compaction, led by the compaction's last row (stage
    ``"initial"``, strains 0): the strains of the later stages are counted from it, as the
    run records them."""
    table = result.table
    after = table[table["stage"] != COMPACTION]
    before = table[table["stage"] == COMPACTION]
    if not len(before) or not len(after):
        raise InputError("run", result.metadata.get("title", "?"), "a run with a compaction "
                         "and a stage after it")
    start = before.iloc[[-1]].copy()
    for column in start.columns:
        if str(column).startswith(("eps_", "gamma_")):
            start[column] = 0.0
    start["stage"] = INITIAL
    return _curves(pd.concat([start, after], ignore_index=True), SIMULATION)


def on_simulation_grid(simulation: pd.DataFrame, model: pd.DataFrame) -> pd.DataFrame:
    """``model``'s curves at the vertical strains of ``simulation``'s rows, stage by stage
    (module docstring), and the simulation's rows kept: both sides on one grid."""
    sides = []
    for stage in dict.fromkeys(simulation["stage"]):
        sim = simulation[simulation["stage"] == stage]
        mod = model[model["stage"] == stage]
        if stage == INITIAL:
            sides.append((sim, mod.iloc[:1]))
            continue
        if len(mod) == 0:
            break
        # the model's stage starts where its previous stage ended (its last row before)
        before = model[model.index < mod.index[0]].iloc[-1:]
        mod = pd.concat([before, mod])
        x = mod["eps_axial"].to_numpy()
        order = np.argsort(x, kind="stable")
        slack = GRID_SLACK * max(float(np.abs(x).max()), 1e-12)
        low, high = x.min() - slack, x.max() + slack
        kept = sim[(sim["eps_axial"] >= low) & (sim["eps_axial"] <= high)]
        if not len(kept):
            break
        grid = kept["eps_axial"].to_numpy()
        values = {column: np.interp(grid, x[order], mod[column].to_numpy()[order])
                  for column in CURVE_COLUMNS[3:]}
        sides.append((kept, pd.DataFrame({"side": mod["side"].iloc[0], "stage": stage,
                                          "eps_axial": grid, **values})))
        if len(kept) < len(sim):
            break  # the model stopped in this stage
    sim = pd.concat([s for s, _ in sides], ignore_index=True)
    mod = pd.concat([m for _, m in sides], ignore_index=True)
    return pd.concat([sim, mod], ignore_index=True)[list(CURVE_COLUMNS)]


class TheoryComparison(Compute):
    """A run and the micro-element models of its packing on the same path (module
    docstring; the compute-object pattern: :meth:`compute`, then the properties).

    Parameters
    ----------
    distributions:
        The distribution laws of strain, each a name of
        :data:`~grainlab.lab.run_micro_element.DISTRIBUTION_READINGS`.
    model_steps:
        About how many steps the model takes over the path (each step of the run's path
        cut into as many as it takes).
    """

    def __init__(self, distributions: Sequence[str] = ("homogeneous",),
                 model_steps: int = 200) -> None:
        super().__init__()
        self.distributions = check_distributions(list(distributions))
        if isinstance(model_steps, bool) or not isinstance(model_steps, int) or \
                model_steps < 1:
            raise InputError("--model-steps", model_steps, "an integer >= 1")
        self.model_steps = model_steps

    def compute(self, run: str | Path | TestResult, snapshots: str | Path | None = None
                ) -> TheoryComparison:
        """Compare the run (a run folder, its results file or its result) with the models
        of its snapshot at the end of the compaction (``snapshots``: default
        RUN/snapshots.h5 of a run folder). Returns self."""
        result = read_run_result(run)
        kind = check_theory_kind(run_config(result).get("test", {}).get("kind", ""),
                                 "run test.kind")
        if snapshots is None:
            if isinstance(run, TestResult) or not Path(run).is_dir():
                raise InputError("snapshots", None, "the run's snapshots.h5 (given with a "
                                 "run's result rather than its folder)")
            snapshots = Path(run) / "snapshots.h5"
        network = compaction_snapshot(snapshots)
        path = model_path(result, self.model_steps)
        simulation = simulation_curves(result)
        models, failures, curves, pairs = {}, {}, [simulation], {}
        for name in self.distributions:
            model = run_micro_element_model(result, network, name)
            try:
                models[name] = run_element_test(model, path)
            except GrainlabError as failure:  # a model that cannot start the path
                failures[name] = str(failure)
                continue
            table = on_simulation_grid(simulation, model_curves(models[name], name))
            pairs[name] = (table[table["side"] == SIMULATION], table[table["side"] == name])
            curves.append(pairs[name][1])
        self._results = {}
        own = [simulation, *(model_curves(test, name) for name, test in models.items())]
        self._store(kind=kind, result=result, models=models, failures=failures,
                    curves=pd.concat(curves, ignore_index=True),
                    own_curves=pd.concat(own, ignore_index=True),
                    differences=_differences(kind, pairs, simulation, models))
        return self

    @property
    def kind(self) -> str:
        """The lab test (``test.kind`` of the run)."""
        return self._get("kind")

    @property
    def result(self) -> TestResult:
        """The run's result."""
        return self._get("result")

    @property
    def models(self) -> dict[str, TestResult]:
        """The model's element test, by distribution law (those that could start)."""
        return self._get("models")

    @property
    def failures(self) -> dict[str, str]:
        """Why a model could not start the path, by distribution law."""
        return self._get("failures")

    @property
    def curves(self) -> pd.DataFrame:
        """Both sides on the simulation's grid (:data:`CURVE_COLUMNS`; the run's rows with
        ``side`` "simulation", a model's with its distribution law)."""
        return self._get("curves")

    @property
    def own_curves(self) -> pd.DataFrame:
        """Each side on its own rows (the columns of :data:`CURVE_COLUMNS`): the run's as
        recorded, a model's at each of its steps (what the figure draws)."""
        return self._get("own_curves")

    @property
    def differences(self) -> pd.DataFrame:
        """By how much each model differs from the run (module docstring): columns
        ``distribution``, ``quantity``, ``meaning``, ``simulation``, ``model``,
        ``model_minus_simulation``, ``model_over_simulation``."""
        return self._get("differences")


def _dilatancy(curves: pd.DataFrame) -> float:
    """-d eps_vol / d|eps_axial| (> 0: dilating, in compression or extension), least squares
    over the last DILATANCY_SHARE of the strains."""
    x, y = np.abs(curves["eps_axial"].to_numpy()), curves["eps_vol"].to_numpy()
    top = np.nanmax(x) if len(x) else 0.0
    late = x >= (1.0 - DILATANCY_SHARE) * top
    if top <= 0.0 or np.count_nonzero(late) < 2:
        return math.nan
    return -float(np.polyfit(x[late], y[late], 1)[0])


def _measures(kind: str, curves: pd.DataFrame) -> list[tuple[str, str, float]]:
    """(quantity, meaning, value) of one side's curves on the common grid."""
    start = curves.iloc[0]
    out = [("p_start", "mean stress p at the start of the path [Pa]", float(start["p"]))]
    loading = curves[curves["stage"] != INITIAL]
    if not len(loading):
        return out
    end = loading.iloc[-1]
    if kind == "oedometer":
        for stage in dict.fromkeys(loading["stage"]):
            last = loading[loading["stage"] == stage].iloc[-1]
            out += [(f"{stage}_eps_axial", f"vertical strain at the end of {stage} "
                     "(common grid)", float(last["eps_axial"])),
                    (f"{stage}_K0", f"K0 at the end of {stage}", float(last["K0"])),
                    (f"{stage}_sigma_v", f"vertical stress at the end of {stage} [Pa]",
                     float(last["sigma_v"]))]
        return out
    return [
        *out,
        ("peak_q_over_p", "peak q/p", float(np.nanmax(loading["q_over_p"]))),
        ("peak_phi", "peak mobilised angle asin((s1 - s3)/(s1 + s3)) [deg]",
         float(np.nanmax(loading["phi_mob"]))),
        ("end_eps_axial", "largest vertical |strain| both reached", float(end["eps_axial"])),
        ("end_q_over_p", "q/p at the largest vertical |strain| both reached",
         float(end["q_over_p"])),
        ("end_eps_vol", "eps_vol there (compression > 0)", float(end["eps_vol"])),
        ("dilatancy", f"dilatancy rate -d eps_vol / d|eps_axial| over the last "
                      f"{100 * DILATANCY_SHARE:g} %", _dilatancy(loading)),
    ]


def _whole_path(curves: pd.DataFrame) -> list[tuple[str, str, float]]:
    """(quantity, meaning, value) of one side over all its own rows (not the common grid)."""
    loading = curves[curves["stage"] != INITIAL]
    if not len(loading):
        return []
    return [("reached_eps_axial", "vertical strain at the end of its own path (each side)",
             float(loading["eps_axial"].iloc[-1])),
            ("own_peak_q_over_p", "peak q/p over its own path (each side)",
             float(np.nanmax(loading["q_over_p"]))),
            ("own_peak_phi", "peak mobilised angle over its own path (each side) [deg]",
             float(np.nanmax(loading["phi_mob"])))]


def _differences(kind: str, pairs: dict[str, tuple[pd.DataFrame, pd.DataFrame]],
                 simulation: pd.DataFrame, results: dict[str, TestResult]) -> pd.DataFrame:
    """The rows of :attr:`TheoryComparison.differences`; ``pairs``: per distribution law the
    simulation's rows and the model's on the same grid; ``simulation``: all the run's rows
    (the model's own are in ``results``)."""
    rows = []
    whole = dict(((q, m), v) for q, m, v in _whole_path(simulation))
    for name, (sim, curves) in pairs.items():
        measured = dict(((q, m), v) for q, m, v in _measures(kind, curves))
        for (quantity, meaning), reference in (((q, m), v) for q, m, v in
                                               _measures(kind, sim)):
            model = measured.get((quantity, meaning), math.nan)
            rows.append((name, quantity, meaning, reference, model))
        own = _whole_path(model_curves(results[name], name))
        rows += [(name, q, m, whole.get((q, m), math.nan), v) for q, m, v in own]
        outcome = results[name].metadata.get("outcome", {})
        rows.append((name, "model_completed", "the model followed the whole path (1) or "
                     "stopped (0: its outcome in model-LAW.csv's metadata and the log)",
                     math.nan, 1.0 if outcome.get("status") == "completed" else 0.0))
    table = pd.DataFrame(rows, columns=["distribution", "quantity", "meaning", "simulation",
                                        "model"])
    with np.errstate(divide="ignore", invalid="ignore"):
        table["model_minus_simulation"] = table["model"] - table["simulation"]
        table["model_over_simulation"] = np.where(table["simulation"] != 0.0,
                                                  table["model"] / table["simulation"],
                                                  math.nan)
    return table
