"""What a discrete run did, judged against what was asked, in words and as data, and what it
cost (:class:`RunCost`: wall time, steps, sub-steps).

A run is *as asked* when it finished every stage of its load path and each stage

* reached its end: a stage without a strain-controlled axis (compaction) settled
  (quasi-static); a stage with one reached its strain target or stop criterion, not
  ``max_stage_steps``, and not a box too thin for its particles
  (:data:`~grainlab.lab.discrete_test.BOX_MIN_DIAMETERS`);
* held the bound on the inertia number (stages with a strain-controlled axis only: a
  compaction starts from a loose gas, whose end the quasi-static criteria judge). The bound
  sets the strain rate; the recorded I is that of the fastest wall, and the stress-controlled
  walls may move outwards at 4 times the bound's speed, so single records above the bound are
  not a loading faster than asked. The bound is *exceeded* when the median of I over the
  stage's records is above :data:`INERTIA_MEDIAN_FACTOR` (2) times the bound, or their 90th
  percentile above :data:`INERTIA_QUANTILE_FACTOR` (4) times it. Measured: 30 spheres at a
  bound of 1e-3, median 1.7e-3 and 90th percentile 2.5e-3 (held); at a bound of 1, median 3.7
  (exceeded: p fell from 1e4 to ~1.5e3 Pa, the sample flew apart);
* kept a contact network: median coordination z >= :data:`MIN_COORDINATION` (1) over its
  records (stages with a strain-controlled axis). Quasi-static samples keep z of 2-3 (30
  spheres, rattlers included) to 4-6; below 1 most particles touch nothing: a granular gas
  (z median 0.07 in the run at a bound of 1).

* (soft-contact DEM) moved as its load drives it, with no kinetic energy made by the scheme:
  the median over the stage's records past its first tenth of the contacts' *velocity
  zigzag* (:attr:`~grainlab.engine.dem.soft_contact.SoftContactStep.velocity_zigzag`: how much
  the relative velocities at the contacts changed in the last half sub-step of a step, over
  themselves, the larger of the normal and tangential parts) at most :data:`ZIGZAG_LIMIT`.
  A motion the sub-steps resolve changes little in half a sub-step (measured below); a
  numerical instability of the explicit scheme (its dashpots taken explicitly, a sub-step too
  long for their damping rate) flips the velocities at every sub-step and feeds the grains
  kinetic energy no load drives: a periodic triaxial test at e = 0.2 on a sub-step sized by
  the springs alone lost its friction (peak q/p 0.12-0.14 against 0.40 at e = 0.5) with 30
  times the kinetic energy. The energy itself is no sure sign (an unstable run at e = 0.3
  with k_t = k_n lost its friction at an ordinary kinetic energy); the zigzag is. The
  sub-step now counts the dashpots (:mod:`grainlab.engine.dem.soft_stability`); this is the
  check that it did.

Steps whose solver ended at its iteration cap (``max_iterations``, not converged) are counted
per stage and reported; a stage whose share of them is above its ``capped_share_limit``
(:class:`~grainlab.lab.stage_numerics.StageNumerics`) is not as asked. A compaction accepts
any share (default 1: its end is judged by the quasi-static criteria): with the lab's caps
(1000 sweeps in compaction, 2000 in shear) 0.2-1.4 % of the steps of 1000- and 10 000-sphere
triaxial tests end capped, and 0.3-2.9 % of 200-1000 polyhedra's, but up to 9-15 % of a
300-sphere compaction's, whose capped steps end with a relative change of 1.0-1.7e-4 against
its 1e-4 (the residual below it). A loading accepts at most half (default 0.5): 57 % of a
100-sphere triaxial test's loading steps capped while its lateral stresses swung 57 % off
their target. Set ``capped_share_limit`` lower (e.g. 0.02) to have a run fail loudly.

Every strain-controlled stage, either solver, either boundary, judges its stress-controlled
axes (the walls' or the cell's stresses against their targets, past the stage's first
tenth): the median relative error at most :data:`HELD_STRESS_ERROR` (on at least
:data:`HELD_STRESS_ROWS` records) and the worst at most :data:`HELD_STRESS_WORST` (on any
records; the generalised components c = B sigma a true triaxial test holds, sqrt(3) p and 0
along the deviator's direction its b fixes, against sqrt(3) p). Measured: a one-step simple
shear of 200 rigid spheres whose step did not converge took the cell's sigma_zz from 1e4 to
3.4e6 Pa (the contacts' to 8.4e7); the 100-sphere test above, 6 records of its loading, median
errors 20 and 23 % on sigma_xx and sigma_yy (worst 47 and 57 %).

The command line exits with :data:`EXIT_NOT_AS_ASKED` (3) when a run ran but its outcome is not
as asked, 2 on bad input or when a run cannot go on, 0 otherwise.

>>> stage = StageOutcome(name="shear", ended=REACHED, reason="strain reached", steps=100,
...                      capped_steps=5, max_iterations=400, inertia_bound=1e-3,
...                      inertia_median=1.2e-3, inertia_q90=2e-3, inertia_max=3e-3,
...                      z_median=4.1)
>>> stage.inertia_held, stage.problems()
(True, [])
>>> RunOutcome(stages=(stage,), finished=True, steps=100).status
'as asked'
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from grainlab.lab.solver_registry import DEFAULT_SOLVER, solver_record

REACHED = "reached"
MAX_STAGE_STEPS = "max_stage_steps"
BOX_TOO_THIN = "box too thin"
UNFINISHED = "unfinished"
ENDINGS = (REACHED, MAX_STAGE_STEPS, BOX_TOO_THIN, UNFINISHED)
"""How a stage ended: its target reached; ``max_stage_steps`` hit first; stopped because the
box became too thin for its particles; not ended (the run was stopped in it)."""

INERTIA_MEDIAN_FACTOR = 2.0
INERTIA_QUANTILE_FACTOR = 4.0
INERTIA_QUANTILE = 0.9
MIN_COORDINATION = 1.0
HELD_STRESS_ERROR = 0.1
"""Largest median relative error of a stress-controlled boundary against its target in a
strain-controlled stage (either solver, walls or cell), past its first tenth (the servo's
start): beyond it the boundary did not hold the stress asked."""
HELD_STRESS_WORST = 1.0
"""Largest relative error of any single record of a stress-controlled boundary against its
target in a strain-controlled stage, past its first tenth (judged on however few records:
one step that does not converge may carry the stress off by orders of magnitude: in a
one-step simple shear of 200 rigid spheres the cell's sigma_zz went from 1e4 to 3.4e6 Pa, p to
2.3e8): beyond it the stress left its target by more than the target
itself."""
HELD_STRESS_ROWS = 5
"""Fewest records (past the first tenth) on which the held stresses are judged: a shorter
stage is mostly the servo's start."""
EXIT_NOT_AS_ASKED = 3
ZIGZAG_LIMIT = 0.2
"""Largest median velocity zigzag of a DEM stage (module docstring). Measured medians, the
compaction and the shear of triaxial tests (200 spheres in a periodic cell or a wall box,
linear springs at kappa = 1e3 and 1e4 and Hertz at 1e4, e = 0.05 to 1, I = 1e-4 to 1e-2,
mu = 0 to 1; 100 aggregates): 2e-6 to 0.028; on sub-steps sized by the springs alone
(e = 0.2; k_t = k_n at e = 0.3 and 0.5): 0.65 to 0.96 in the shear."""


def _stress(axis: str) -> str:
    """``"sigma_xx"`` of ``"xx"``; a generalised component's own name."""
    return f"sigma_{axis}" if len(axis) == 2 else axis


def _fmt(value: float) -> str:
    return f"{value:.3g}" if math.isfinite(value) else "n/a"


@dataclass(frozen=True)
class StageOutcome:
    """One stage judged (module docstring).

    Attributes
    ----------
    name, ended, reason:
        Stage name; how it ended (:data:`ENDINGS`); its end in words.
    steps, capped_steps, max_iterations:
        Steps of the stage, those ended at the solver's cap, the cap [sweeps] (0: an explicit
        solver, whose steps have no iterations).
    capped_share_limit:
        The largest share of capped steps accepted [-] (1: any).
    start_step, end_step:
        The run's step before the stage's first and at its last (-1: unknown).
    inertia_bound:
        The bound on I asked [-]; None in stages without a strain-controlled axis (not
        judged).
    inertia_median, inertia_q90, inertia_max, z_median:
        Over the stage's records (NaN without records).
    unsettled:
        For a stage without a strain-controlled axis that did not settle: each quasi-static
        criterion that its last record missed, in words.
    stress_errors, stress_worst:
        Strain-controlled stages: per stress-controlled axis (``"xx"``...), the median and
        the largest relative error of the boundary's stress against its target past the
        stage's first tenth (:data:`HELD_STRESS_ERROR`, :data:`HELD_STRESS_WORST`).
    zigzag:
        Soft-contact DEM stages: the median velocity zigzag of the stage's records past its
        first tenth (module docstring; NaN where not judged).
    stability_advice:
        What to change when the zigzag says the explicit scheme is unstable (the solver's
        :attr:`~grainlab.lab.solver_registry.SolverRecord.stability_advice`).
    """

    name: str
    ended: str
    reason: str
    steps: int
    capped_steps: int = 0
    max_iterations: int = 0
    inertia_bound: float | None = None
    inertia_median: float = math.nan
    inertia_q90: float = math.nan
    inertia_max: float = math.nan
    z_median: float = math.nan
    unsettled: tuple[str, ...] = ()
    stress_errors: tuple[tuple[str, float], ...] = ()
    stress_worst: tuple[tuple[str, float], ...] = ()
    start_step: int = -1
    end_step: int = -1
    capped_share_limit: float = 1.0
    zigzag: float = math.nan
    stability_advice: str = ""

    @property
    def capped_share(self) -> float:
        """Share of the stage's steps that ended at the solver's cap (0 without steps)."""
        return self.capped_steps / self.steps if self.steps else 0.0

    @property
    def inertia_held(self) -> bool | None:
        """Whether the bound on I held (None where not judged or without records)."""
        if self.inertia_bound is None or not math.isfinite(self.inertia_median):
            return None
        return (self.inertia_median <= INERTIA_MEDIAN_FACTOR * self.inertia_bound
                and self.inertia_q90 <= INERTIA_QUANTILE_FACTOR * self.inertia_bound)

    @property
    def scheme_stable(self) -> bool | None:
        """Whether the explicit scheme resolved the motion (None where not judged):
        :attr:`zigzag` at most :data:`ZIGZAG_LIMIT`."""
        if not math.isfinite(self.zigzag):
            return None
        return self.zigzag <= ZIGZAG_LIMIT

    @property
    def solid(self) -> bool | None:
        """Whether the sample kept a contact network (None where not judged)."""
        if self.inertia_bound is None or not math.isfinite(self.z_median):
            return None
        return self.z_median >= MIN_COORDINATION

    def problems(self) -> list[str]:
        """Why this stage is not as asked, with what to do (empty when it is)."""
        out = []
        if self.ended == MAX_STAGE_STEPS:
            what = "settling" if self.inertia_bound is None else "its target"
            out.append(f"stage {self.name}: max_stage_steps ({self.steps}) hit before {what}; "
                       f"continue it with `grainlab resume RUN --set "
                       f"solver.max_stage_steps={2 * self.steps}`")
        elif self.ended == BOX_TOO_THIN:
            out.append(f"stage {self.name}: {self.reason}")
        elif self.ended == UNFINISHED:
            out.append(f"stage {self.name}: not finished ({self.reason})")
        if self.inertia_held is False:
            out.append(
                f"stage {self.name}: inertia number above its bound {self.inertia_bound:g} "
                f"(median {_fmt(self.inertia_median)} = "
                f"{self.inertia_median / self.inertia_bound:.3g} x the bound, largest "
                f"{_fmt(self.inertia_max)}): the loading was faster than asked; lower "
                "solver.shear.inertia_number")
        out += self._stress_problems()
        if self.max_iterations and self.capped_share > self.capped_share_limit:
            table = "solver.compaction" if self.inertia_bound is None else "solver.shear"
            out.append(f"stage {self.name}: {self.capped_steps} of {self.steps} steps "
                       f"({100 * self.capped_share:.1f} %) ended at the solver's cap of "
                       f"{self.max_iterations} sweeps unconverged, above the limit of "
                       f"{100 * self.capped_share_limit:g} % ({table}.capped_share_limit); "
                       f"raise {table}.max_iterations or loosen {table}.tolerance")
        if self.scheme_stable is False:
            out.append(f"stage {self.name}: kinetic energy made by the time steps, not driven "
                       f"by the load: the contacts' velocities flip from one sub-step to the "
                       f"next (median zigzag {self.zigzag:.3g} > {ZIGZAG_LIMIT:g}), an unstable "
                       "explicit scheme whose results are not those of the material; "
                       + (self.stability_advice or "shorten the solver's sub-step"))
        if self.solid is False:
            out.append(f"stage {self.name}: the sample lost its contact network (median z "
                       f"{_fmt(self.z_median)} < {MIN_COORDINATION:g}): a granular gas, not a "
                       "quasi-static test; lower solver.shear.inertia_number")
        return out

    def _stress_problems(self) -> list[str]:
        """The held stresses off their targets (median or worst), in words."""
        out = []
        worst = dict(self.stress_worst)
        for axis, error in self.stress_errors:
            if error > HELD_STRESS_ERROR:
                out.append(f"stage {self.name}: the boundary did not hold {_stress(axis)} at its "
                           f"target (median error {100 * error:.3g} % > "
                           f"{100 * HELD_STRESS_ERROR:.0f} %, worst "
                           f"{100 * worst.get(axis, math.nan):.3g} %): the boundary lagged "
                           "its target; lower solver.shear.inertia_number (--inertia), and "
                           "for walls with momentum (solver.wall_servo = false) use the "
                           "servo walls")
        for axis, error in self.stress_worst:
            if error > HELD_STRESS_WORST and dict(self.stress_errors).get(
                    axis, 0.0) <= HELD_STRESS_ERROR:
                out.append(f"stage {self.name}: {_stress(axis)} left its target by "
                           f"{100 * error:.3g} % of it in a record (> "
                           f"{100 * HELD_STRESS_WORST:.0f} %): a step the solver did not "
                           "resolve; raise solver.shear.max_iterations (--max-iterations) "
                           "or shorten the step (solver.shear.time_step_factor, or "
                           "solver.dt, --dt)")
        return out

    def words(self) -> str:
        """The stage in one line."""
        if self.ended == REACHED:
            text = f"{self.name}: reached ({self.reason}) in {self.steps} steps"
        elif self.ended == MAX_STAGE_STEPS:
            text = f"{self.name}: NOT reached: {self.reason}"
            if self.unsettled:
                text += f" ({'; '.join(self.unsettled)})"
        elif self.ended == BOX_TOO_THIN:
            text = f"{self.name}: NOT reached: {self.reason}"
        else:
            text = f"{self.name}: not finished after {self.steps} steps ({self.reason})"
        held = self.inertia_held
        if held is not None:
            bound = self.inertia_bound
            text += (f"; inertia number {'within' if held else 'EXCEEDED'} its bound "
                     f"{bound:g} (median {_fmt(self.inertia_median)} = "
                     f"{self.inertia_median / bound:.3g} x, 90th percentile "
                     f"{_fmt(self.inertia_q90)} = {self.inertia_q90 / bound:.3g} x, largest "
                     f"{_fmt(self.inertia_max)} = {self.inertia_max / bound:.3g} x; allowed: "
                     f"median <= {INERTIA_MEDIAN_FACTOR:g} x, 90th percentile <= "
                     f"{INERTIA_QUANTILE_FACTOR:g} x)")
        if self.scheme_stable is False:
            text += f"; UNSTABLE sub-steps (velocity zigzag {self.zigzag:.3g})"
        if self.solid is False:
            text += f"; contact network LOST (median z {_fmt(self.z_median)})"
        if self.steps and self.max_iterations:  # 0: an explicit solver, no iterations
            share = 100.0 * self.capped_steps / self.steps
            text += (f"; {self.capped_steps} of {self.steps} steps ({share:.0f} %) ended at the "
                     f"solver's cap of {self.max_iterations} sweeps")
        return text

    def to_dict(self) -> dict[str, Any]:
        """Plain data (with the judgement)."""
        data = asdict(self)
        data["unsettled"] = list(self.unsettled)
        data["stress_errors"] = [list(pair) for pair in self.stress_errors]
        data["stress_worst"] = [list(pair) for pair in self.stress_worst]
        data.update(inertia_held=self.inertia_held, solid=self.solid,
                    scheme_stable=self.scheme_stable, problems=self.problems())
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> StageOutcome:
        """Inverse of :meth:`to_dict`."""
        names = {f for f in cls.__dataclass_fields__}
        values = {k: v for k, v in data.items() if k in names}
        values["unsettled"] = tuple(values.get("unsettled", ()))
        for key in ("stress_errors", "stress_worst"):
            values[key] = tuple((str(a), float(e)) for a, e in values.get(key, ()))
        for key in ("inertia_median", "inertia_q90", "inertia_max", "z_median", "zigzag"):
            if values.get(key) is None:
                values[key] = math.nan
        return cls(**values)


@dataclass(frozen=True)
class RunOutcome:
    """A run judged (module docstring): its stages so far, whether it finished, and why it
    stopped early if it did."""

    stages: tuple[StageOutcome, ...]
    finished: bool
    steps: int
    stopped: str = ""
    notes: tuple[str, ...] = field(default=())

    def problems(self) -> list[str]:
        """Why the run is not as asked (empty when it is)."""
        out = [p for stage in self.stages for p in stage.problems()]
        if not self.finished and self.stopped and not any(
                s.ended in (MAX_STAGE_STEPS, BOX_TOO_THIN) for s in self.stages):
            out.append(self.stopped)
        if not self.finished and not out:
            out.append(f"the run stopped at step {self.steps} before the end of its load path")
        return out

    @property
    def as_asked(self) -> bool:
        """True when the run did what was asked (module docstring)."""
        return self.finished and not self.problems()

    @property
    def status(self) -> str:
        """"as asked", or "not as asked"."""
        return "as asked" if self.as_asked else "not as asked"

    @property
    def capped_steps(self) -> int:
        """Steps ended at the solver's iteration cap, all stages."""
        return sum(s.capped_steps for s in self.stages)

    def summary(self) -> str:
        """The outcome in words: the verdict and why, then one line per stage."""
        problems = self.problems()
        head = "outcome: as asked" if not problems else "outcome: NOT as asked"
        lines = [head, *(f"  why: {p}" for p in problems),
                 *(f"  {s.words()}" for s in self.stages),
                 *(f"  note: {n}" for n in self.notes)]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain data for results metadata: the verdict (``status``, ``as_asked``,
        ``problems``, ``summary``), the stages (each with ``name``, ``reason``, ``steps``,
        ``ended``...), ``finished``, ``steps``, ``unconverged_steps`` (capped, all stages)."""
        return {"status": self.status, "as_asked": self.as_asked,
                "problems": self.problems(), "summary": self.summary(),
                "finished": self.finished, "steps": self.steps, "stopped": self.stopped,
                "unconverged_steps": self.capped_steps, "notes": list(self.notes),
                "stages": [s.to_dict() for s in self.stages]}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RunOutcome:
        """Inverse of :meth:`to_dict` (e.g. of ``result.metadata["outcome"]``)."""
        return cls(stages=tuple(StageOutcome.from_dict(s) for s in data["stages"]),
                   finished=bool(data["finished"]), steps=int(data["steps"]),
                   stopped=str(data.get("stopped", "")), notes=tuple(data.get("notes", ())))

    @classmethod
    def of_result(cls, result) -> RunOutcome:
        """The outcome of a discrete run's :class:`~grainlab.result.test_result.TestResult`."""
        return cls.from_dict(result.metadata["outcome"])


@dataclass(frozen=True)
class RunCost:
    """What a run took to reach its last record: ``wall_time`` [s], the seconds spent
    stepping, recording and checkpointing, summed over the sessions that made the steps kept
    (a session's steps after its last checkpoint, lost to a kill, are not counted; a first
    session's kernel compilation is); ``steps``, the simulation steps; ``substeps``, the
    integration sub-steps of an explicit solver (soft-contact DEM: each step cut into
    sub-steps no longer than the stable one), None for contact dynamics, whose steps have
    none. A run's result keeps it in ``metadata["cost"]`` (:meth:`of_result`).

    >>> cost = RunCost(wall_time=12.5, steps=400, substeps=9600)
    >>> RunCost.from_dict(cost.to_dict()) == cost
    True
    """

    wall_time: float
    steps: int
    substeps: int | None = None

    def to_dict(self) -> dict[str, Any]:
        """Plain data (``wall_time`` None where unknown)."""
        return {"wall_time": self.wall_time if math.isfinite(self.wall_time) else None,
                "steps": self.steps, "substeps": self.substeps}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RunCost:
        """Inverse of :meth:`to_dict`."""
        wall_time = data.get("wall_time")
        substeps = data.get("substeps")
        return cls(wall_time=math.nan if wall_time is None else float(wall_time),
                   steps=int(data["steps"]),
                   substeps=None if substeps is None else int(substeps))

    @classmethod
    def of_result(cls, result) -> RunCost:
        """The cost of a discrete run's :class:`~grainlab.result.test_result.TestResult`; a
        result written before costs were kept gives its steps (from the outcome) and an
        unknown (NaN) wall time."""
        if "cost" in result.metadata:
            return cls.from_dict(result.metadata["cost"])
        return cls(wall_time=math.nan, steps=int(result.metadata["outcome"]["steps"]))


def _unsettled(row: dict[str, Any], criteria, targets: dict[str, float]) -> tuple[str, ...]:
    """The quasi-static criteria that ``row`` misses, in words."""
    out = []
    missed = {axis: row.get(f"wall_sigma_{axis}", math.nan) for axis, target in targets.items()
              if not abs(row.get(f"wall_sigma_{axis}", math.nan) - target)
              <= criteria.stress_tolerance * target}
    if missed:
        out.append("wall stresses " + ", ".join(f"sigma_{a} {_fmt(v)}" for a, v in
                                                 missed.items())
                   + f" Pa for {', '.join(f'{targets[a]:g}' for a in missed)} Pa (target "
                   f"within {100 * criteria.stress_tolerance:g} %)")
    ratio = row.get("unbalanced_force_ratio", math.nan)
    if not ratio <= criteria.unbalanced_force:
        out.append(f"unbalanced force ratio {_fmt(ratio)} (target <= "
                   f"{criteria.unbalanced_force:g})")
    kinetic = row.get("kinetic_energy_ratio", math.nan)
    if not kinetic <= criteria.kinetic_energy:
        out.append(f"kinetic energy ratio {_fmt(kinetic)} (target <= "
                   f"{criteria.kinetic_energy:g})")
    return tuple(out)


def _held_stress_errors(rows: list[dict[str, Any]], stress_targets: dict[str, Any]
                        ) -> tuple[tuple[tuple[str, float], ...], tuple[tuple[str, float], ...]]:
    """Per stress-controlled axis ("xx": target [Pa]), the median relative error of the
    boundary's stress (``wall_sigma_`` or ``cell_sigma_`` column) over the rows past the first
    tenth of the stage (none when fewer than :data:`HELD_STRESS_ROWS` are left), and the
    largest over those rows however few (a stress that is not finite counts as infinitely
    far). A generalised component is given as (target [Pa], scale [Pa], its value of a row):
    its error is |value - target| / scale."""
    later = rows[len(rows) // 10:]
    medians, worst = [], []
    for axis, held in stress_targets.items():
        if isinstance(held, tuple):
            target, scale, value_of = held
            values = np.array([value_of(r) for r in later], dtype=float)
        else:
            target = scale = held
            column = next((c for c in (f"wall_sigma_{axis}", f"cell_sigma_{axis}")
                           if any(c in r for r in later)), None)
            if column is None:
                continue
            values = np.array([r.get(column, math.nan) for r in later], dtype=float)
        if not scale > 0.0 or not values.size:
            continue
        errors = np.abs(values - target) / scale
        errors[~np.isfinite(errors)] = math.inf
        worst.append((axis, float(np.max(errors))))
        if errors.size >= HELD_STRESS_ROWS:
            medians.append((axis, float(np.median(errors))))
    return tuple(medians), tuple(worst)


def _zigzag(rows: list[dict[str, Any]]) -> float:
    """The median ``velocity_zigzag`` of the rows past the first tenth (NaN without such
    rows: not judged)."""
    later = np.array([r.get("velocity_zigzag", math.nan) for r in rows[len(rows) // 10:]],
                     dtype=float)
    later = later[np.isfinite(later)]
    return float(np.median(later)) if later.size else math.nan


def stage_outcome(record: dict[str, Any], rows: list[dict[str, Any]], settings,
                  stress_targets: dict[str, Any]) -> StageOutcome:
    """Judge one stage from its record (``name``, ``reason``, ``steps``, ``ended``,
    ``capped_steps``, ``strain_controlled``), its rows and the test's settings
    (:class:`~grainlab.lab.discrete_test.DiscreteTestSettings`); ``stress_targets`` maps
    ``"xx"``... to the stress-controlled axes' targets [Pa], or a generalised component's
    name to (target, scale, value of a row) (:func:`_held_stress_errors`; the normal ones
    also give the words of an unsettled stage)."""
    moving = bool(record.get("strain_controlled", False))
    numerics = settings.numerics_for(moving)
    solver = solver_record(getattr(settings, "method", DEFAULT_SOLVER))
    ended = record.get("ended", REACHED)
    values: dict[str, Any] = {
        "name": record["name"], "ended": ended, "reason": record["reason"],
        "steps": int(record["steps"]), "capped_steps": int(record.get("capped_steps", 0)),
        "start_step": int(record.get("start_step", -1)),
        "end_step": int(record.get("end_step", -1)),
        "max_iterations": int(numerics.max_iterations) if solver.iterative else 0,
        "capped_share_limit": float(getattr(numerics, "capped_share_limit", 1.0))}
    if moving:
        inertia = np.array([r["inertia_number"] for r in rows], dtype=float)
        inertia = inertia[np.isfinite(inertia)]
        z = np.array([r["z"] for r in rows], dtype=float)
        values["inertia_bound"] = float(numerics.inertia_number)
        if inertia.size:
            values.update(inertia_median=float(np.median(inertia)),
                          inertia_q90=float(np.quantile(inertia, INERTIA_QUANTILE)),
                          inertia_max=float(np.max(inertia)))
        if z.size:
            values["z_median"] = float(np.median(z))
        values["stress_errors"], values["stress_worst"] = _held_stress_errors(
            rows, stress_targets)
    elif ended != REACHED and rows:
        normal = {a: t for a, t in stress_targets.items() if not isinstance(t, tuple)}
        values["unsettled"] = _unsettled(rows[-1], settings.quasi_static, normal)
    if solver.explicit_substeps:
        values["zigzag"] = _zigzag(rows)
        values["stability_advice"] = solver.stability_advice
    return StageOutcome(**values)
