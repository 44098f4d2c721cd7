"""A series of discrete runs and the micro-element models of their packings: seed 001
chapter 3 (Figs. 3.3–3.6) by default, over seeds, friction angles, stiffness ratios and
confining pressures (``grainlab theory-series``).

The specimen is seed 001's §3.1: a periodic cell of discs, 12 of radius 0.21 mm and 13 of
0.105 mm (``n_particles`` other than 25 keeps the two radii and the share of small discs,
13/25), placed at random and isotropically compressed by the simulation to sigma0
(203 kPa) without friction (the same packing for every friction angle of a seed), soft-contact
DEM with Cundall & Strack's linear springs, k_n = 200 kN/m per disc and
k_s = (k_s/k_n) k_n. Discs are as thick as their mean diameter; the model's springs are the
run's per unit thickness (k / t: docs/validation/theory-vs-simulation.md, "Discs (2D)"). Then
each case loads with friction tan(phi_mu):

* ``oedometer`` (Fig. 3.3): the horizontal strain held, the vertical strain raised to
  ``axial_strain``; read K0 = sigma_h / sigma_v, its minimum over the loading (the report's
  "K0 decreases from 1 sharply to a value and stays nearly constant") and its end value.
* ``biaxial`` (Figs. 3.4–3.6): the horizontal stress held at sigma0, the vertical strain
  raised until eps_q = eps_1 - eps_3 reaches ``eps_q_max``; read the report's stress ratio
  q/p = (sigma_v - sigma_h) / (sigma_v + sigma_h) (its q and p are half the difference and
  half the sum: the sine of the mobilised angle), at the peak and at the end, and the
  volumetric strain (compression > 0) at the end.

Each case is one `grainlab theory-vs-sim` comparison (:class:`~grainlab.lab.theory_comparison.
TheoryComparison`) in its own folder under the series' folder; a case whose run has ended
is reused, one that was stopped goes on from its checkpoint. The oedometer cases take the
first stiffness ratio of the plan (the report gives K0 for k_s/k_n = 1), the biaxial cases
every one; every case every seed and confining pressure.

The report's numbers that carry values (:data:`REPORT_K0`): K0 0.27 -> 0.16 by the
simulation, 0.22 -> 0.14 by the model, for phi_mu 14 -> 25 degrees; the biaxial figures are
curves only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from grainlab._validate import in_range, positive
from grainlab._validate import seed as checked_seed
from grainlab.errors import InputError
from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_micro_element import check_distributions
from grainlab.lab.theory_comparison import INITIAL, SIMULATION, TheoryComparison

SERIES_TESTS = {"oedometer": "oedometer", "biaxial": "triaxial"}
"""The series' tests and the discrete lab's test kind that runs each (in 2D, ``triaxial`` is
the biaxial test: lateral stress held, vertical strain raised)."""

RADII = (0.21e-3, 0.105e-3)
"""The two disc radii of seed 001 §3.1 [m]."""
SMALL_SHARE = 13.0 / 25.0
"""The number share of small discs (13 of 25)."""
NORMAL_STIFFNESS = 2.0e5
"""k_n of seed 001 §3.1 [N/m] (200 kN/m, Cundall & Strack's linear springs)."""

SHEAR_INERTIA = 1e-5
"""The inertia number bound of the loading: quasi-static. At the lab's default (1e-3) the
periodic cell of 25 discs lags its stress target in the biaxial test (sigma_xx off by a
median 73 %); at 1e-4 it holds it within 17 % at worst, at 1e-5 within 11 %."""

REPORT_K0 = {SIMULATION: {14.0: 0.27, 25.0: 0.16}, "model": {14.0: 0.22, 25.0: 0.14}}
"""The report's K0 in one-dimensional compression, by side and phi_mu [deg] (§3.1)."""

MEASURES = ("K0_min", "K0_end", "ratio_peak", "ratio_end", "eps_vol_end", "eps_v_end")
"""The columns of :attr:`SeriesOutcome.table` read from each side's curve: K0's minimum and
end value (oedometer), the report's q/p at its peak and at the end and the volumetric strain
at the end (biaxial), and the vertical strain that side reached."""


@dataclass(frozen=True)
class SeriesCase:
    """One run of the series: a test, a seed, a friction angle [deg], k_s/k_n and sigma0
    [Pa]."""

    test: str
    seed: int
    phi_mu: float
    stiffness_ratio: float
    sigma0: float

    @property
    def folder_name(self) -> str:
        """The case's folder inside the series' folder."""
        return (f"{self.test}-phi{self.phi_mu:g}-ks{self.stiffness_ratio:g}-"
                f"{self.sigma0 / 1e3:g}kPa-seed{self.seed}")


def each(field_name: str, values: Sequence, check, *args) -> tuple:
    """``check(field_name, value, *args)`` of each of ``values`` (a
    :mod:`grainlab._validate` check), refusing an empty list naming ``field_name``."""
    values = tuple(values)
    if not values:
        raise InputError(field_name, "(none)", "one value or more")
    return tuple(check(field_name, value, *args) for value in values)


@dataclass(frozen=True)
class SeriesPlan:
    """What the series runs (module docstring); the defaults are seed 001 chapter 3's.

    Parameters
    ----------
    tests:
        Names of :data:`SERIES_TESTS`.
    seeds:
        The random packings (one sample seed each).
    k0_angles:
        phi_mu [deg] of the oedometer cases (Fig. 3.3).
    biaxial_angle:
        phi_mu [deg] of the biaxial cases (Figs. 3.4, 3.5).
    stiffness_ratios:
        k_s/k_n of the biaxial cases; the oedometer cases take the first.
    sigma0s:
        Confining pressures [Pa] (Fig. 3.6: several).
    n_particles:
        Discs in the periodic cell.
    axial_strain:
        The oedometer's final vertical strain [-].
    eps_q_max:
        The biaxial test's final eps_1 - eps_3 [-].
    distributions:
        The model's distribution laws.
    model_steps:
        About how many steps each model takes over its path.
    """

    tests: tuple[str, ...] = ("oedometer", "biaxial")
    seeds: tuple[int, ...] = (1, 2, 3)
    k0_angles: tuple[float, ...] = (14.0, 17.0, 20.0, 25.0)
    biaxial_angle: float = 25.0
    stiffness_ratios: tuple[float, ...] = (1.0, 0.3)
    sigma0s: tuple[float, ...] = (203e3,)
    n_particles: int = 25
    axial_strain: float = 0.005
    eps_q_max: float = 0.05
    distributions: tuple[str, ...] = ("homogeneous", "maxwellian-average",
                                      "maxwellian-first-order")
    model_steps: int = 100
    cases: tuple[SeriesCase, ...] = field(init=False)

    def __post_init__(self) -> None:
        tests = tuple(dict.fromkeys(self.tests))
        for test in tests or ("(none)",):
            if test not in SERIES_TESTS:
                raise InputError("--test", test, "one or more of " + ", ".join(SERIES_TESTS))
        seeds = tuple(dict.fromkeys(each("--seed", self.seeds, checked_seed)))
        angles = each("--phi-mu", self.k0_angles, in_range, 0.0, 90.0, "deg")
        biaxial = in_range("--biaxial-phi-mu", self.biaxial_angle, 0.0, 90.0, "deg")
        ratios = each("--stiffness-ratio", self.stiffness_ratios, positive)
        sigma0s = each("--sigma0", self.sigma0s, positive, "Pa")
        positive("--axial-strain", self.axial_strain)
        positive("--eps-q", self.eps_q_max)
        if isinstance(self.n_particles, bool) or not isinstance(self.n_particles, int) or \
                self.n_particles < 4:
            raise InputError("--particles", self.n_particles, "an integer >= 4")
        object.__setattr__(self, "distributions",
                           tuple(check_distributions(list(self.distributions))))
        cases = []
        for test in tests:
            for sigma0 in sigma0s:
                for seed in seeds:
                    if test == "oedometer":
                        cases += [SeriesCase(test, seed, a, ratios[0], sigma0) for a in angles]
                    else:
                        cases += [SeriesCase(test, seed, biaxial, r, sigma0) for r in ratios]
        object.__setattr__(self, "cases", tuple(cases))

    def config(self, case: SeriesCase) -> RunConfig:
        """The discrete run of one case (module docstring)."""
        kind = SERIES_TESTS[case.test]
        test = {"kind": kind, "sigma0": case.sigma0}
        test.update({"axial_strain": self.axial_strain} if kind == "oedometer" else
                    {"eps_q_max": self.eps_q_max})
        small = round(SMALL_SHARE * self.n_particles)
        return RunConfig.model_validate({
            "sample": {"shape": "disc", "boundary": "periodic",
                       "n_particles": self.n_particles, "d_min": RADII[1] * 2.0,
                       "size_ratio": RADII[0] / RADII[1], "sizes": "binary",
                       "fine_fraction": small / self.n_particles, "packing_fraction": 0.3,
                       "seed": case.seed},
            "test": test,
            "solver": {"method": "dem",
                       "dem": {"normal_stiffness": NORMAL_STIFFNESS,
                               "stiffness_ratio": case.stiffness_ratio},
                       "shear": {"friction": math.tan(math.radians(case.phi_mu)),
                                 "inertia_number": SHEAR_INERTIA}},
            "output": {"record_every": 1, "snapshot_every": 50, "checkpoint_every": 0},
        })


def side_measures(curve: pd.DataFrame) -> dict[str, float]:
    """:data:`MEASURES` of one side's own curve (the rows of
    :attr:`~grainlab.lab.theory_comparison.TheoryComparison.own_curves` of that side); a
    2D curve's q_over_p is (sigma_1 - sigma_3) / p with p the half sum, so the report's q/p
    is half of it."""
    loading = curve[curve["stage"] != INITIAL]
    if not len(loading):
        return dict.fromkeys(MEASURES, math.nan)
    ratio = 0.5 * loading["q_over_p"].to_numpy(dtype=float)
    k0 = loading["K0"].to_numpy(dtype=float)
    return {"K0_min": float(np.nanmin(k0)), "K0_end": float(k0[-1]),
            "ratio_peak": float(np.nanmax(ratio)), "ratio_end": float(ratio[-1]),
            "eps_vol_end": float(loading["eps_vol"].iloc[-1]),
            "eps_v_end": float(loading["eps_axial"].iloc[-1])}


@dataclass
class SeriesOutcome:
    """What a series wrote and measured.

    ``table``: one row per case and side (the run's side ``"simulation"``, a model's its
    distribution law) with the case's fields, :data:`MEASURES`, ``completed`` (the run
    ended as asked; the model followed the whole path) and ``run_as_asked`` (the case's run
    ended as asked); ``curves``: every side's own curve
    with the case's fields; ``problems``: a line per case whose run blew up or a model
    could not start."""

    table: pd.DataFrame
    curves: pd.DataFrame
    problems: list[str]

    def summary(self) -> pd.DataFrame:
        """The mean, smallest and largest of each measure over the seeds whose run was as
        asked (a run that did not hold its stress target or its inertia bound, as a burst of
        a small cell's collapse does, is in :attr:`table` and :attr:`problems`, not here),
        per test, angle, stiffness ratio, sigma0 and side; ``seeds``: how many."""
        keys = ["test", "phi_mu", "stiffness_ratio", "sigma0", "side"]
        table = self.table[self.table["run_as_asked"]]
        grouped = table.groupby(keys, sort=False)[list(MEASURES)]
        out = grouped.agg(["mean", "min", "max"])
        out.columns = [f"{measure}_{stat}" for measure, stat in out.columns]
        out["seeds"] = table.groupby(keys, sort=False)["seed"].nunique()
        return out.reset_index()


def run_series(plan: SeriesPlan, out: str | Path, *, overwrite: bool = False,
               report: Callable[[SeriesCase, str], None] | None = None) -> SeriesOutcome:
    """Run every case of ``plan`` into OUT/CASE (reusing ended runs unless ``overwrite``)
    and compare each with the models of its packing; ``report(case, words)`` is told what
    became of each case. Writes nothing but the runs and the models' comparisons."""
    from grainlab.engine.simulation import SimulationBlowUp
    from grainlab.lab.discrete_run import DiscreteRun
    from grainlab.lab.run_outcome import RunOutcome
    from grainlab.lab.solver_comparison import open_solver_run

    out = Path(out)
    rows, curves, problems = [], [], []
    for case in plan.cases:
        folder = out / case.folder_name
        fields = {"test": case.test, "seed": case.seed, "phi_mu": case.phi_mu,
                  "stiffness_ratio": case.stiffness_ratio, "sigma0": case.sigma0}
        opened = open_solver_run(folder, plan.config(case), overwrite=overwrite)
        reused = not isinstance(opened, DiscreteRun)
        if not reused:
            try:
                opened.run()
            except SimulationBlowUp as error:
                problems.append(f"{case.folder_name}: the run blew up ({error})")
                if report:
                    report(case, "blew up")
                continue
        comparison = TheoryComparison(plan.distributions, plan.model_steps).compute(folder)
        as_asked = RunOutcome.of_result(comparison.result).as_asked
        problems += [f"{case.folder_name}: {name} could not start ({why})"
                     for name, why in comparison.failures.items()]
        own = comparison.own_curves
        for side in dict.fromkeys(own["side"]):
            curve = own[own["side"] == side]
            if side == SIMULATION:
                completed = as_asked
            else:
                outcome = comparison.models[side].metadata.get("outcome", {})
                completed = outcome.get("status") == "completed"
            rows.append({**fields, "side": side, **side_measures(curve),
                         "completed": bool(completed), "run_as_asked": bool(as_asked)})
            curves.append(curve.assign(**fields))
        if not as_asked:
            problems.append(f"{case.folder_name}: the run's outcome is not as asked "
                            f"({folder / 'run.log'}); left out of the summary")
        if report:
            report(case, "reused" if reused else "ran")
    columns = ["test", "seed", "phi_mu", "stiffness_ratio", "sigma0", "side", *MEASURES,
               "completed", "run_as_asked"]
    table = pd.DataFrame(rows, columns=columns)
    return SeriesOutcome(table, pd.concat(curves, ignore_index=True) if curves else
                         pd.DataFrame(), problems)
