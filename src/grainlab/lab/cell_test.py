"""A load path run on a discrete sample in a periodic deformable cell
(:mod:`grainlab.engine.periodic_boundary`, :mod:`grainlab.lab.cell_stages`).

:class:`CellTest` is a :class:`~grainlab.lab.discrete_test.DiscreteTest` whose boundary is
the cell: the same settings, records, snapshots, stage ends, outcome and checkpoints, with
the stage controls of the cell instead of walls:

* the largest strain rate e_max of a stage comes from the bound on the inertia number at the
  stage's reference stress (the largest compressive stress target, else the mean stress
  reached), as in the wall box; the time step is ``time_step_factor`` x d_min / (e_max L),
  L the cell's largest width (the speed at which the cell's faces move, as the walls');
* every step the cell gets the prescribed velocity gradient and the stress-controlled
  directions and targets of the stage at its progress lambda (:class:`~grainlab.lab.
  cell_stages.CellStage`); the servo is the cell's (gain, bounds: :mod:`grainlab.engine.
  periodic_boundary`);
* a strain-driven stage ends when lambda reaches its steps (the last time step cut to land
  on it); a stress-driven stage with end targets ends once quasi-static: the generalised
  stresses the cell's image contacts carry within ``quasi_static.stress_tolerance`` x the
  reference stress of their targets, the contact stress's p within the same of the
  boundary's, and the unbalanced force and kinetic energy criteria; a stepped one moves on
  each time its targets are met and ends at its last;
* strains are the cell's natural strains (its step strains summed) from the reference cell
  (the cell at the end of the last stress-driven stage), compression positive: what the
  stages control, the logarithmic strains on coaxial paths, gamma = int gammadot dt in a
  simple shear (:func:`~grainlab.engine.sample_measures.cell_strains`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grainlab.engine.sample_measures import cell_measures, cell_strains
from grainlab.lab.cell_stages import CellStage, cell_stages
from grainlab.lab.discrete_test import (
    MAX_STEPS_REASON,
    RECOVERY_SPEED_FRACTION,
    SHORTEST_CUT,
    TARGET_MARGIN,
    THIN_BOX,
    DiscreteTest,
    _stop_reason,
)
from grainlab.lab.load_path import LoadPath
from grainlab.lab.solver_registry import solver_record
from grainlab.lab.specimen import tensor_to_voigt
from grainlab.lab.wall_stages import AXES

THIN_CELL_MARGIN = 1.05
"""A stage stops when a width of the cell is within 5 % of the detection's limit."""


class CellTest(DiscreteTest):
    """A load path on a discrete sample in a periodic cell (module docstring)."""

    def __init__(self, sample, path: LoadPath, settings=None, **callbacks) -> None:
        self.progress = 0.0
        self.progress_step = 0
        self.reference_stress = 1.0
        self.stage_start_stress = np.zeros(6)
        super().__init__(sample, path, settings, **callbacks)

    def load_stages(self, path: LoadPath) -> list[CellStage]:
        """The path's stages as cell controls (refuses what rigid grains cannot follow;
        soft-contact DEM's deformable contacts follow a strain on every component)."""
        return cell_stages(path, deformable=solver_record(self.settings.method).deformable)

    # -- stage logic -----------------------------------------------------------------------------
    def _confining(self, stage: CellStage) -> float:
        start = self._generalised_stress(stage, 0.0)
        goals = stage.targets(start, float(stage.n_steps))[stage.stress_controlled]
        normal = [g for g in goals if g > 0.0]
        if normal:
            return float(max(normal))
        return super()._confining_from_rows(stage)

    def _generalised_stress(self, stage: CellStage, progress: float) -> np.ndarray:
        """c = B sigma of the last recorded contact stress; before any record, of the stress
        the cell's image contacts carried at the sample's last step (a sample loaded
        elsewhere) -- zero for a sample that never moved."""
        if not self.rows:
            return stage.conjugate(self.sample.boundary.boundary_stress, progress)
        row = self.rows[-1]
        sigma = np.array([[row["sigma_xx"], row["sigma_xy"], row["sigma_xz"]],
                          [row["sigma_xy"], row["sigma_yy"], row["sigma_yz"]],
                          [row["sigma_xz"], row["sigma_yz"], row["sigma_zz"]]])
        return stage.conjugate(sigma, progress)

    def outcome_stress_targets(self, stage: CellStage) -> dict[str, Any]:
        """The normal stress targets [Pa] of a stage controlled in the cell's own axes
        (``"target"`` stress mode, no rotation, the Voigt basis), by ``"xx"``...; those of a
        stage in a fixed mixed basis (a true triaxial test: sqrt(3) p and the deviator's
        direction) as :func:`generalised_targets`; empty for the other stages."""
        load = stage.stage
        if load.stress_mode != "target" or load.rotation_start or load.rotation_per_step:
            return {}
        if load.component_basis is not None:
            return generalised_targets(stage)
        return {AXES[a] * 2: float(load.values[a]) for a in range(3)
                if load.control[a] == "stress" and load.values[a] > 0.0}

    def start_stage(self) -> None:
        """Set the cell's control, friction, strain rate and time step of the current
        stage."""
        stage = self.stage
        assert stage is not None
        cell = self.sample.boundary
        p_ref = self._confining(stage)
        inertia = self.stage_numerics.inertia_number
        self.strain_rate = inertia * math.sqrt(p_ref / self.sample.state.density) / \
            self.sample.mean_diameter
        self.reference_stress = p_ref
        self.stage_start_stress = self._generalised_stress(stage, 0.0)
        self.progress = 0.0
        self.progress_step = self.simulation.step_index
        self.stage_wall_speed = self.strain_rate * float(cell.widths.max())  # [m/s]
        self.stage_start_step = self.simulation.step_index
        self.stage_start_unconverged = self.simulation.unconverged_steps
        self.stage_start_lengths = cell.widths.copy()
        self._stage_numerics()
        self._control()
        self.stage_started = True

    def _stage_numerics(self) -> None:
        s, numerics = self.settings, self.stage_numerics
        v_max = self.stage_wall_speed
        self.solver_record.set_stage(self.solver, numerics, RECOVERY_SPEED_FRACTION * v_max)
        if s.dt is None:
            self.stage_dt = self.automatic_step()
        else:
            self.stage_dt = s.dt
        self.solver.dt = self._last_step(self.stage_dt)

    def _rate(self) -> float:
        stage = self.stage
        return stage.progress_rate(self.strain_rate) if stage.strain_driven else 0.0

    def _control(self) -> None:
        """The cell's control at the progress the coming step ends at."""
        stage = self.stage
        rate = self._rate()
        ahead = min(self.progress + rate * self.solver.dt, float(stage.n_steps)) \
            if stage.strain_driven else self.progress
        middle = 0.5 * (self.progress + ahead)
        fixed, directions = stage.gradients(middle, rate)
        goals = stage.targets(self.stage_start_stress, ahead if stage.strain_driven
                              else self._stepped_target())[stage.stress_controlled]
        self.sample.boundary.set_control(fixed, directions, goals, self.reference_stress,
                                         self.strain_rate)

    def _stepped_target(self) -> float:
        """The step whose targets a stress-driven stage aims at now."""
        return min(math.floor(self.progress) + 1.0, float(self.stage.n_steps))

    def drive(self) -> None:
        """Advance the stage's progress by the step just done, then set the cell for the
        next step (its length cut to land on the end of a strain-driven stage)."""
        stage = self.stage
        if stage is None:
            return
        self._advance()
        dt = self.stage_dt
        if self.adaptive_step and self.settings.dt is None:
            dt = min(dt, self._particle_speed_step())
        self.solver.dt = self._last_step(dt)
        self._control()

    def _advance(self) -> None:
        """Move the stage's progress on by the steps done since it last moved (once per
        step, whoever asks first: the stage end checks or the drive)."""
        step = self.simulation.step_index
        if step == self.progress_step:
            return
        self.progress_step = step
        stage = self.stage
        if stage.strain_driven:
            self.progress += self._step_progress()
            # what is left would take less than SHORTEST_CUT of a step: done (no sliver of a
            # step, whose forces P / dt mean nothing)
            left = (stage.n_steps - self.progress) / self._rate()
            if left < SHORTEST_CUT * self.stage_dt:
                self.progress = float(stage.n_steps)
        elif stage.stage.stress_mode != "target" and self._targets_met():
            self.progress = self._stepped_target()

    def _step_progress(self) -> float:
        """The progress the last step made: the cell's strain increment in the stage's
        generalised components, e = B^-T eps, projected on the stage's strain direction (the
        cell moves its first half step at the previous step's rate, theta scheme, so this
        is what it did, not what it was asked)."""
        stage = self.stage
        strain = tensor_to_voigt(self.sample.boundary.step_strain, engineering_shear=True)
        generalised = np.linalg.inv(stage.control(self.progress)).T @ strain
        direction = stage.strain_per_step
        return float(generalised @ direction / (direction @ direction))

    def _targets_met(self) -> bool:
        """Whether the image contacts carry the current targets (within the quasi-static
        stress tolerance of the reference stress)."""
        cell = self.sample.boundary
        measured = cell.conjugate_stress(cell.boundary_stress)
        tolerance = self.settings.quasi_static.stress_tolerance * self.reference_stress
        return bool(np.all(np.abs(measured - cell.targets) <= tolerance))

    def _last_step(self, dt: float) -> float:
        stage = self.stage
        if stage is None or not stage.strain_driven:
            return dt
        rate = self._rate()
        cut = (float(stage.n_steps) - self.progress + TARGET_MARGIN) / rate
        # a step within SHORTEST_CUT of the end finishes the stage (no sliver of a step,
        # whose forces P / dt would mean nothing: discrete_test.SHORTEST_CUT)
        return cut if 0.0 < cut <= dt * (1.0 + SHORTEST_CUT) else dt

    def wall_end(self) -> tuple[bool, str]:
        """Whether the stage ends now: a stop criterion on a strain column, the end of a
        strain-driven or stepped stage, ``max_stage_steps``."""
        stage = self.stage
        assert stage is not None
        self._advance()
        strains = self.wall_strains()
        for criterion in stage.stop:
            if criterion.quantity in strains and criterion.met(strains):
                return True, _stop_reason(criterion)
        if stage.strain_driven and self.progress >= stage.n_steps:
            return True, "strain reached"
        if not stage.strain_driven and stage.stage.stress_mode != "target" \
                and self.progress >= stage.n_steps and self._targets_met():
            return True, "stress path done"
        thin = self._thin_cell()
        if thin:
            return True, thin
        if self.simulation.step_index - self.stage_start_step >= self.settings.max_stage_steps:
            return True, MAX_STEPS_REASON
        return False, ""

    def _thin_cell(self) -> str:
        """The diagnosis when the cell is about to get thinner than the detection allows
        (three interaction ranges 2 r_max + alert, with :data:`THIN_CELL_MARGIN`), else
        ""."""
        cell = self.sample.boundary
        alert = self.solver.alert or 0.0
        limit = THIN_CELL_MARGIN * 3.0 * (self.largest_diameter + alert)
        widths = cell.widths
        axis = int(np.argmin(widths))
        if widths[axis] >= limit:
            return ""
        return (f"{THIN_BOX}: the periodic cell is {widths[axis] * 1e3:.4g} mm across its "
                f"faces along axis {axis}, {widths[axis] / self.largest_diameter:.2f} largest "
                f"particle diameters (at least {limit * 1e3:.4g} mm: three interaction ranges, "
                "so that no pair touches through two images); use more particles or a cell "
                "longer along that axis (sample aspect)")

    def settled(self, row: dict[str, Any]) -> bool:
        """A stress-driven stage with end targets is quasi-static at ``row`` (module
        docstring); stepped and strain-driven stages end otherwise."""
        stage = self.stage
        return not stage.strain_driven and stage.stage.stress_mode == "target" \
            and self._quasi_static(row)

    def _quasi_static(self, row: dict[str, Any]) -> bool:
        criteria = self.settings.quasi_static
        if not self._targets_met():
            return False
        cell_p = (row["cell_sigma_xx"] + row["cell_sigma_yy"] + row["cell_sigma_zz"]) / 3.0
        if not cell_p > 0 or abs(row["p"] - cell_p) > criteria.stress_tolerance * cell_p:
            return False
        return (row["unbalanced_force_ratio"] <= criteria.unbalanced_force
                and row["kinetic_energy_ratio"] <= criteria.kinetic_energy)

    def end_stage(self, reason: str, ended: str = "reached") -> None:
        if self.stage is not None and not self.stage.moving_axes:
            self.sample.boundary.set_reference()
        super().end_stage(reason, ended)

    # -- strains and records ---------------------------------------------------------------------
    def wall_strains(self, lengths: np.ndarray | None = None) -> dict[str, float]:
        """The strain columns of the cell now (natural strains, from the reference cell)."""
        return cell_strains(self.sample.boundary.strain)

    def _stage_strains(self) -> np.ndarray:
        return np.zeros(3)

    def box_limits(self, reference: np.ndarray) -> np.ndarray:
        """No walls: the cell's thickness is checked at each detection."""
        return np.zeros(3)

    def predicted_flattening(self) -> list:
        """No walls to flatten (the detection refuses a cell thinner than three
        interaction ranges)."""
        return []

    def measures(self):
        """The row and network of the cell now."""
        report = self.simulation.last_report
        return cell_measures(report, self.sample.state, self.sample.library,
                             self.sample.boundary, self.simulation.last_dt,
                             self.solver.friction)

    def progress_arrays(self) -> dict[str, Any]:
        data = super().progress_arrays()
        data.update({"progress": self.progress, "progress_step": self.progress_step,
                     "reference_stress": self.reference_stress,
                     "stage_start_stress": self.stage_start_stress.copy()})
        return data

    def restore_progress(self, data: dict[str, Any]) -> None:
        super().restore_progress(data)
        self.progress = float(data["progress"])
        self.progress_step = int(data["progress_step"])
        self.reference_stress = float(data["reference_stress"])
        self.stage_start_stress = np.asarray(data["stage_start_stress"], dtype=float)


_VOIGT_COLUMNS = tuple(f"cell_sigma_{a}" for a in ("xx", "yy", "zz", "yz", "xz", "xy"))


def generalised_targets(stage: CellStage) -> dict[str, Any]:
    """The stress-controlled generalised components c = B sigma of a ``"target"`` stage in a
    fixed basis B (:mod:`grainlab.lab.cell_stages`), for the run's outcome: ``{"(B
    sigma)_i": (target [Pa], scale [Pa], value of a results row)}``, the scale the largest
    target (components held at 0, the deviator's direction of a true triaxial test, are
    judged against it); empty when every target is 0."""
    b = stage.control(0.0)
    targets = stage.targets(np.zeros(6), float(stage.n_steps))
    held = np.flatnonzero(stage.stress_controlled)
    scale = float(np.max(np.abs(targets[held]))) if held.size else 0.0
    if not scale > 0.0:
        return {}

    def component(i: int):
        def value(row: dict[str, Any]) -> float:
            voigt = np.array([row.get(c, np.nan) for c in _VOIGT_COLUMNS], dtype=float)
            return float(b[i] @ voigt)
        return value

    return {f"(B sigma)_{i + 1}": (float(targets[i]), scale, component(int(i)))
            for i in held}
