"""What a run adds to its simulation's operations
(:class:`~grainlab.engine.simulation.Simulation`, besides the test's own stage control and
records): an action every few steps (checkpoints, ParaView frames), the contact problems of
chosen steps written to files, and
the progress bar of a stage with the figures it shows (:func:`progress_fields`, also the
study display's).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from grainlab.lab.discrete_test import DiscreteTest
from grainlab.lab.wall_stages import QuasiStaticCriteria


class Every:
    """Calls ``action()`` every ``period`` steps."""

    def __init__(self, name: str, period: int, action: Callable[[], Any]) -> None:
        from grainlab.engine.simulation import Periodic

        self.name = name
        self.trigger = Periodic(period)
        self.action = action

    def act(self, simulation) -> None:
        self.action()


class ProblemWriter:
    """Stores the contact problem of every ``period``-th step in FCLib's layout
    (:func:`~grainlab.engine.nscd.contact_problem.write_fclib`): it asks the solver to assemble
    the problem only on those steps."""

    name = "problems"

    def __init__(self, folder: Path, period: int) -> None:
        self.folder = folder
        self.period = period

    @staticmethod
    def trigger(step_index: int) -> bool:
        return True

    def act(self, simulation) -> None:
        from grainlab.engine.nscd.contact_problem import write_fclib

        report = simulation.last_report
        if report is not None and report.problem is not None and report.n_contacts:
            self.folder.mkdir(exist_ok=True)
            step = simulation.step_index
            write_fclib(report.problem, self.folder / f"step-{step:08d}.hdf5",
                        title=f"grainlab step {step}",
                        description=f"{report.n_contacts} contacts, {report.iterations} "
                                    f"sweeps, converged {report.converged}",
                        reactions=report.impulses)
        simulation.solver.keep_problem = (simulation.step_index + 1) % self.period == 0


class ProgressBar:
    """A rich progress bar per stage (strain or quasi-static state), with the time spent and
    the time left in the stage as its progress so far predicts (the bar restarts with each
    stage, so that the estimate is the stage's own). It shows in a terminal and in a Jupyter
    notebook (``notebook``: as :class:`grainlab._live_progress.LiveProgress`)."""

    def __init__(self, test: DiscreteTest, notebook: bool | None = None) -> None:
        from rich.progress import BarColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        from grainlab._live_progress import LiveProgress

        self.test = test
        self.progress = LiveProgress(TextColumn("[bold]{task.description}"), BarColumn(),
                                     TextColumn("{task.fields[info]}"), TimeElapsedColumn(),
                                     TextColumn("left"), TimeRemainingColumn(),
                                     notebook=notebook)
        self.task = None
        self.stage_name: str | None = None

    def start(self) -> None:
        self.progress.start()
        self.task = self.progress.add_task("starting", total=1.0, info="")

    def update(self, test: DiscreteTest, row: dict) -> None:
        if test.stage is None or self.task is None:
            return
        if test.stage.name != self.stage_name:
            self.stage_name = test.stage.name
            self.progress.reset(self.task, total=1.0, completed=0.0)
        done, info = progress_fields(test, row)
        self.progress.update(self.task, completed=done, description=test.stage.name,
                             info=info)

    def stop(self) -> None:
        self.progress.stop()


def progress_fields(test: DiscreteTest, row: dict) -> tuple[float, str]:
    """(fraction done in [0, 1], text) of the progress bar at a record. A stage with a
    strain-controlled axis: its stop quantity (eps_q...) against its limit, else its strain
    (walls) or progress (periodic cell) against its target. A compaction: half the mean
    boundary stress (walls or cell) against its target, half the unbalanced force ratio
    against its quasi-static bound on a log scale (1 to the bound), the text showing both and
    the kinetic energy ratio with their targets, so that a compaction that does not settle is
    seen stuck at its numbers, not at a percentage. Before the first contact (a dilute start)
    the ratios are undefined (0/0) or meaningless (over a pressure of ~0): the text says that
    there are no contacts yet instead of printing them."""
    stage = test.stage
    steps = f"step {row['step']} ({row['step'] - test.stage_start_step} of <= " \
            f"{test.settings.max_stage_steps} in the stage)"
    if stage.moving_axes:
        stop = [abs(row[c.quantity] / c.limit) for c in stage.stop if c.when == "above"
                and c.limit and math.isfinite(row.get(c.quantity, math.nan))]
        done = max(stop) if stop else test.boundary.fraction_done(stage)
        return min(max(done, 0.0), 1.0), (
            f"{steps}  q/p {row['q_over_trace']:.3f}  packing fraction "
            f"{row['packing_fraction']:.4f}  z {row['z']:.2f}  I {row['inertia_number']:.1e} (<= "
            f"{test.stage_numerics.inertia_number:g})")
    criteria: QuasiStaticCriteria = test.settings.quasi_static
    targets = test.boundary.stress_goal(stage)
    held = "wall_sigma_" if "wall_sigma_xx" in row else "cell_sigma_"  # walls or cell
    wall_p = (row[held + "xx"] + row[held + "yy"] + row[held + "zz"]) / 3.0
    loaded = min(1.0, max(wall_p / np.mean(targets), 0.0)) if targets else 1.0
    ratio, bound = row["unbalanced_force_ratio"], criteria.unbalanced_force
    settled = min(1.0, max(math.log(ratio) / math.log(bound), 0.0)) \
        if ratio > 0.0 and math.isfinite(ratio) else 0.0
    state = f"p {row['p']:.4g} Pa  packing fraction {row['packing_fraction']:.4f}"
    if row.get("n_contacts", 1) == 0 or not math.isfinite(ratio):
        # a dilute start: both ratios divide by a contact force or a pressure of ~0 (nan,
        # 1e+28), which reads as a blow-up where nothing is wrong
        return 0.5 * loaded, f"{steps}  no contacts yet (a gas being compacted)  {state}"
    info = (f"{steps}  unbalanced force {ratio:.3g} (-> <= {bound:g})  kinetic energy "
            f"{row['kinetic_energy_ratio']:.2g} (-> <= {criteria.kinetic_energy:g})  {state}")
    return 0.5 * loaded + 0.5 * settled, info
