"""The 3D counterpart of seed 001's comparison (``grainlab theory-b-sweep``): one periodic
packing of spheres run by the discrete engine through the cubical tests, b = 0 ... 1, at
constant sigma_3 (``cubical``: Lade & Duncan's protocol, the report's, b = 0 being triaxial
compression) and at constant p (``true_triaxial``), and the micro-element model of each
simulated packing under every distribution law: the peak mobilised angle
asin((sigma_1 - sigma_3)/(sigma_1 + sigma_3)) of each side against b.

Each (path, b) is one `grainlab theory-vs-sim` comparison (:class:`~grainlab.lab.
theory_comparison.TheoryComparison`) in OUT/PATH-bB: the same sample (one seed), compacted
frictionless to sigma0, loaded with the friction ``friction`` to eps_q = ``eps_q_max``; the
model takes the run's snapshot at the end of the compaction with its forces (periodic images
kept) and the run's contact law (contact dynamics: the springs the soft DEM would give the
run, k_n = 1e4 sigma0 <d>, k_s = k_n / 2), and the run's own path cut into ``model_steps``.
A run that ended is reused; one that was stopped goes on from its checkpoint.

How each side ended (:data:`ENDINGS`): the run ``as asked`` or not; a model ``failed`` (its
strength: a tangent that is not positive definite; the angle is its peak), ``stopped`` (the
driver could no longer hold the stresses; the largest angle it reached), ``hardening``
(still rising at the end of the path) or ``failed at the start`` (no strength state from the
packing's own: no angle).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from grainlab._validate import at_least, in_range, positive
from grainlab.errors import InputError
from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_micro_element import check_distributions
from grainlab.lab.theory_comparison import SIMULATION, TheoryComparison
from grainlab.lab.theory_series import each

PATHS = {"cubical": "constant sigma_3", "true_triaxial": "constant p"}
"""The cubical paths (the discrete lab's test kinds) and what each holds besides b."""

ENDINGS = ("as asked", "NOT as asked", "failed", "stopped", "hardening",
           "failed at the start", "blew up")
"""How a side ended (module docstring)."""

REPORT_ANGLES = {0.0: 41.0, 0.6: 48.0, 1.0: 45.0}
"""The report's cubical strengths [deg] at b (seed 001 §4.2.2, the model, constant
sigma_3)."""

ALL_LAWS = ("homogeneous", "maxwellian-average", "maxwellian-first-order", "maxwellian")


@dataclass(frozen=True)
class BSweepPlan:
    """What the sweep runs (module docstring).

    Parameters
    ----------
    paths:
        Names of :data:`PATHS`.
    b_values:
        b = (sigma_2 - sigma_3)/(sigma_1 - sigma_3) of each test, in [0, 1].
    n_particles, size_ratio, seed:
        The sample of spheres (one packing for every test).
    sigma0:
        sigma_3 (cubical) or p (true_triaxial) held [Pa], and the compaction's pressure.
    friction:
        The loading's Coulomb coefficient mu.
    eps_q_max:
        Each test ends at eps_1 - eps_3 = eps_q_max.
    inertia_number:
        The loading's inertia-number bound.
    solver:
        ``"cd"`` (rigid grains) or ``"dem"``.
    distributions:
        The model's distribution laws.
    model_steps:
        About how many steps each model takes over its path.
    """

    paths: tuple[str, ...] = ("cubical", "true_triaxial")
    b_values: tuple[float, ...] = (0.0, 0.3, 0.6, 1.0)
    n_particles: int = 1000
    size_ratio: float = 1.5
    seed: int = 1
    sigma0: float = 1e5
    friction: float = 0.4
    eps_q_max: float = 0.05
    inertia_number: float = 0.01
    solver: str = "cd"
    distributions: tuple[str, ...] = ALL_LAWS
    model_steps: int = 1000
    cases: tuple[tuple[str, float], ...] = field(init=False)

    def __post_init__(self) -> None:
        paths = tuple(dict.fromkeys(self.paths))
        for path in paths or ("(none)",):
            if path not in PATHS:
                raise InputError("--path", path, "one or more of " + ", ".join(PATHS))
        b_values = tuple(dict.fromkeys(each("--b", self.b_values, in_range, 0.0, 1.0, "",
                                            "[]")))
        positive("--sigma0", self.sigma0, "Pa")
        at_least("--mu", self.friction, 0.0, False)
        if self.solver not in ("cd", "dem"):
            raise InputError("--solver", self.solver, "cd or dem")
        if isinstance(self.model_steps, bool) or not isinstance(self.model_steps, int) or \
                self.model_steps < 1:
            raise InputError("--model-steps", self.model_steps, "an integer >= 1")
        object.__setattr__(self, "distributions",
                           tuple(check_distributions(list(self.distributions))))
        object.__setattr__(self, "cases", tuple((p, b) for p in paths for b in b_values))

    def config(self, path: str, b: float) -> RunConfig:
        """The run of one path and b; bad sample or loading values are refused here, naming
        their key."""
        return RunConfig.model_validate({
            "sample": {"shape": "sphere", "boundary": "periodic",
                       "n_particles": self.n_particles, "size_ratio": self.size_ratio,
                       "seed": self.seed},
            "test": {"kind": path, "sigma0": self.sigma0, "b": b,
                     "eps_q_max": self.eps_q_max},
            "solver": {"method": self.solver,
                       "shear": {"friction": self.friction,
                                 "inertia_number": self.inertia_number}},
            "output": {"record_every": 2, "snapshot_every": 100000},
        })


def folder_name(path: str, b: float) -> str:
    """A case's folder inside the sweep's folder."""
    return f"{path}-b{b:g}"


def _model_row(path: str, b: float, law: str, comparison: TheoryComparison) -> dict:
    outcome = comparison.models[law].metadata.get("outcome", {})
    own = comparison.own_curves[comparison.own_curves["side"] == law]
    if len(own) < 2:  # no step taken: no strength state from the packing's own
        ended, angle = "failed at the start", math.nan
    else:
        angle = float(own["phi_mob"].max())
        ended = "hardening" if outcome.get("status") == "completed" else (
            "failed" if "strength" in str(outcome.get("reason", "")) else "stopped")
    return {"path": path, "b": b, "side": law, "peak_phi": angle, "ended": ended,
            "reached_eps_zz": float(own["eps_axial"].iloc[-1]) if len(own) else math.nan}


def run_b_sweep(plan: BSweepPlan, out: str | Path, *, overwrite: bool = False,
                report: Callable[[str, float, str], None] | None = None) -> pd.DataFrame:
    """Run every (path, b) of ``plan`` into OUT/PATH-bB and compare each with the models of
    its packing: a row per case and side (``path``, ``b``, ``side``, ``peak_phi`` [deg],
    ``ended`` (:data:`ENDINGS`), ``reached_eps_zz``). ``report(path, b, words)`` is told
    what became of each case."""
    from grainlab.engine.simulation import SimulationBlowUp
    from grainlab.lab.discrete_run import DiscreteRun
    from grainlab.lab.run_outcome import RunOutcome
    from grainlab.lab.solver_comparison import open_solver_run

    out = Path(out)
    rows = []
    for path, b in plan.cases:
        folder = out / folder_name(path, b)
        opened = open_solver_run(folder, plan.config(path, b), overwrite=overwrite)
        reused = not isinstance(opened, DiscreteRun)
        if not reused:
            try:
                opened.run()
            except SimulationBlowUp:
                rows.append({"path": path, "b": b, "side": SIMULATION,
                             "peak_phi": math.nan, "ended": "blew up",
                             "reached_eps_zz": math.nan})
                if report:
                    report(path, b, "blew up")
                continue
        comparison = TheoryComparison(plan.distributions, plan.model_steps).compute(folder)
        run = comparison.own_curves[comparison.own_curves["side"] == SIMULATION]
        rows.append({"path": path, "b": b, "side": SIMULATION,
                     "peak_phi": float(run["phi_mob"].max()),
                     "ended": "as asked" if RunOutcome.of_result(comparison.result).as_asked
                     else "NOT as asked",
                     "reached_eps_zz": float(run["eps_axial"].iloc[-1])})
        rows += [_model_row(path, b, law, comparison) for law in comparison.models]
        rows += [{"path": path, "b": b, "side": law, "peak_phi": math.nan,
                  "ended": "failed at the start", "reached_eps_zz": math.nan}
                 for law in comparison.failures]
        if report:
            report(path, b, "reused" if reused else "ran")
    return pd.DataFrame(rows, columns=["path", "b", "side", "peak_phi", "ended",
                                       "reached_eps_zz"])
