"""The periodic deformable cell as the stage loop drives it (:class:`CellBoundary`, a
:class:`~grainlab.lab.stage_boundary.StageBoundary`;
:mod:`grainlab.engine.boundaries.periodic_boundary`,
stages from :func:`~grainlab.lab.cell_stages.cell_stages`).

* the largest strain rate e_max of a stage comes from the bound on the inertia number at the
  stage's reference stress (the largest compressive stress target, else the mean stress
  reached), as in the wall box; the time step is ``time_step_factor`` x d_min / (e_max L),
  L the cell's largest width (the speed at which the cell's faces move, as the walls'); the
  step stays the stage's (it does not follow the overlaps);
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
  simple shear (:func:`~grainlab.engine.sample_measures.cell_strains`);
* the cell has no walls to flatten: it stops a stage when a width is within
  :data:`THIN_CELL_MARGIN` of three interaction ranges (the detection refuses thinner).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grainlab.engine.sample_measures import cell_measures, cell_strains
from grainlab.lab.cell_stages import CellStage, cell_stages
from grainlab.lab.specimen import tensor_to_voigt, voigt_labels
from grainlab.lab.stage_boundary import SHORTEST_CUT, TARGET_MARGIN, THIN_BOX
from grainlab.lab.wall_stages import AXES

THIN_CELL_MARGIN = 1.05
"""A stage stops when a width of the cell is within 5 % of the detection's limit."""


class CellBoundary:
    """The periodic cell of ``test``'s sample as its stages drive it (module docstring).

    Attributes
    ----------
    progress:
        The stage's progress lambda [-] in [0, n_steps]; ``progress_step`` the step it was
        last moved at.
    reference_stress:
        The stage's reference stress [Pa] (the servo's scale, the quasi-static tolerance's).
    stage_start_stress:
        (6,) generalised stresses c = B sigma [Pa] at the stage's start.
    stage_start_lengths, reference_lengths:
        (3,) widths [m] of the cell at the stage's start, and the box's reference edges
        (kept in checkpoints; the cell's own reference is its strain's).
    """

    @property
    def steps_by_overlap(self) -> bool:
        """Whether the coming step grows and shrinks with the overlaps
        (:mod:`grainlab.lab.step_control`): in a strain-driven stage (the shear of a
        triaxial test, a simple shear), as in the wall box; in a stress-driven one (the
        compaction) only once the cell carries its targets, while the packing settles. A
        step grown while the cell still closes in let a small cell overshoot (80 spheres of
        size ratio 1.2 at I <= 0.05 went thinner than three interaction ranges, which no
        overlap shows); the first step off the targets falls back to the shortest. With the
        shear's step fixed, 1000 spheres in the cell took 932 sweeps a shearing step to
        eps_q = 0.1 (247 steps); grown, 543 (127 steps). The settling of a frictionless
        compaction is a slow creep (1000 aggregates of eta = 0.3 crept 5600 steps after
        reaching the stress); from the same checkpoint at the creep, the grown step ended it
        in 150 steps against 1086 (packing fraction 0.7242 against 0.7253, z_c 11.38 against
        11.33)."""
        stage = self.test.stage
        if stage is None:
            return False
        return stage.strain_driven or (stage.stage.stress_mode == "target"
                                       and self._targets_met())

    def __init__(self, test) -> None:
        self.test = test
        self.cell = test.sample.boundary
        self.progress = 0.0
        self.progress_step = 0
        self.reference_stress = 1.0
        self.stage_start_stress = np.zeros(6)
        self.stage_start_lengths = test.sample.box.lengths.copy()
        self.reference_lengths = test.sample.box.lengths.copy()

    def load_stages(self, path, deformable: bool) -> list[CellStage]:
        """The path's stages as cell controls (refuses what rigid grains cannot follow;
        ``deformable`` grains follow a strain on every component)."""
        return cell_stages(path, deformable=deformable)

    # -- a stage's start ------------------------------------------------------------------
    def confining(self, stage: CellStage) -> float:
        """The largest compressive generalised stress target [Pa], else the mean stress of
        the last row."""
        start = self._generalised_stress(stage, 0.0)
        goals = stage.targets(start, float(stage.n_steps))[stage.stress_controlled]
        normal = [g for g in goals if g > 0.0]
        return float(max(normal)) if normal else self.test.mean_stress_reached(stage)

    def _generalised_stress(self, stage: CellStage, progress: float) -> np.ndarray:
        """c = B sigma of the last recorded contact stress; before any record, of the stress
        the cell's image contacts carried at the sample's last step (a sample loaded
        elsewhere) -- zero for a sample that never moved."""
        rows = self.test.rows
        if not rows:
            return stage.conjugate(self.cell.boundary_stress, progress)
        row = {"sigma_xz": 0.0, "sigma_yz": 0.0, "sigma_zz": 0.0, **rows[-1]}  # 2D: in plane
        sigma = np.array([[row["sigma_xx"], row["sigma_xy"], row["sigma_xz"]],
                          [row["sigma_xy"], row["sigma_yy"], row["sigma_yz"]],
                          [row["sigma_xz"], row["sigma_yz"], row["sigma_zz"]]])
        return stage.conjugate(sigma, progress)

    def refuse_start(self, stage: CellStage) -> str:
        """Nothing: the cell's thickness is checked as it goes (:meth:`target_end`)."""
        return ""

    def start(self, stage: CellStage, reference_stress: float) -> None:
        """The stage's reference stress, its starting stresses and progress 0."""
        self.reference_stress = reference_stress
        self.stage_start_stress = self._generalised_stress(stage, 0.0)
        self.progress = 0.0
        self.progress_step = self.test.simulation.step_index
        self.stage_start_lengths = self.cell.widths.copy()

    def width(self) -> float:
        """The cell's largest width across its faces [m]."""
        return float(self.cell.widths.max())

    def stage_numerics(self, stage: CellStage) -> None:
        """Nothing: the cell's servo has its own bounds (:mod:`grainlab.engine.
        periodic_boundary`); its control follows at the stage's start and every step
        (:meth:`after_step`)."""

    # -- every step -----------------------------------------------------------------------
    def _rate(self, stage: CellStage) -> float:
        return stage.progress_rate(self.test.strain_rate) if stage.strain_driven else 0.0

    def _control(self, stage: CellStage) -> None:
        """The cell's control at the progress the coming step ends at."""
        rate = self._rate(stage)
        ahead = min(self.progress + rate * self.test.solver.dt, float(stage.n_steps)) \
            if stage.strain_driven else self.progress
        middle = 0.5 * (self.progress + ahead)
        fixed, directions = stage.gradients(middle, rate)
        goals = stage.targets(self.stage_start_stress, ahead if stage.strain_driven
                              else self._stepped_target(stage))[stage.stress_controlled]
        self.cell.set_control(fixed, directions, goals, self.reference_stress,
                              self.test.strain_rate)

    def _stepped_target(self, stage: CellStage) -> float:
        """The step whose targets a stress-driven stage aims at now."""
        return min(math.floor(self.progress) + 1.0, float(stage.n_steps))

    def before_step(self, stage: CellStage) -> None:
        """Move the stage's progress on by the step just done (:meth:`advance`)."""
        self.advance(stage)

    def advance(self, stage: CellStage) -> None:
        """Move the stage's progress on by the steps done since it last moved (once per
        step, whoever asks first: the stage end checks or the drive)."""
        step = self.test.simulation.step_index
        if step == self.progress_step:
            return
        self.progress_step = step
        if stage.strain_driven:
            self.progress += self._step_progress(stage)
            # what is left would take less than SHORTEST_CUT of a step: done (no sliver of a
            # step, whose forces P / dt mean nothing)
            left = (stage.n_steps - self.progress) / self._rate(stage)
            if left < SHORTEST_CUT * self.test.stage_dt:
                self.progress = float(stage.n_steps)
        elif stage.stage.stress_mode != "target" and self._targets_met():
            self.progress = self._stepped_target(stage)

    def _step_progress(self, stage: CellStage) -> float:
        """The progress the last step made: the cell's strain increment in the stage's
        generalised components, e = B^-T eps, projected on the stage's strain direction (the
        cell moves its first half step at the previous step's rate, theta scheme, so this
        is what it did, not what it was asked)."""
        d = stage.stage.dimension  # 2D: the in-plane block
        strain = tensor_to_voigt(self.cell.step_strain[:d, :d], engineering_shear=True)
        generalised = np.linalg.inv(stage.control(self.progress)).T @ strain
        direction = stage.strain_per_step
        return float(generalised @ direction / (direction @ direction))

    def _targets_met(self) -> bool:
        """Whether the image contacts carry the current targets (within the quasi-static
        stress tolerance of the reference stress)."""
        measured = self.cell.conjugate_stress(self.cell.boundary_stress)
        tolerance = self.test.settings.quasi_static.stress_tolerance * self.reference_stress
        return bool(np.all(np.abs(measured - self.cell.targets) <= tolerance))

    def last_step(self, stage: CellStage, dt: float) -> float:
        """``dt`` [s], or the step that lands a strain-driven stage on its end: a step within
        SHORTEST_CUT of the end finishes the stage (no sliver of a step)."""
        if not stage.strain_driven:
            return dt
        cut = (float(stage.n_steps) - self.progress + TARGET_MARGIN) / self._rate(stage)
        return cut if 0.0 < cut <= dt * (1.0 + SHORTEST_CUT) else dt

    def after_step(self, stage: CellStage) -> None:
        """The cell's control for the coming step."""
        self._control(stage)

    # -- stage ends -----------------------------------------------------------------------
    def strains(self) -> dict[str, float]:
        """The strain columns of the cell now (natural strains, from the reference cell)."""
        return cell_strains(self.cell.strain, self.test.sample.library.dimension)

    def target_end(self, stage: CellStage) -> str:
        """"strain reached" at the end of a strain-driven stage, "stress path done" at the
        end of a stepped one, the diagnosis when the cell is too thin, else "" (the
        progress moved on first)."""
        self.advance(stage)
        if stage.strain_driven and self.progress >= stage.n_steps:
            return "strain reached"
        if not stage.strain_driven and stage.stage.stress_mode != "target" \
                and self.progress >= stage.n_steps and self._targets_met():
            return "stress path done"
        return self._thin_cell()

    def _thin_cell(self) -> str:
        """The diagnosis when the cell is about to get thinner than the detection allows
        (three interaction ranges 2 r_max + alert, with :data:`THIN_CELL_MARGIN`), else
        ""."""
        d_max = self.test.largest_diameter
        alert = self.test.solver.alert or 0.0
        limit = THIN_CELL_MARGIN * 3.0 * (d_max + alert)
        widths = self.cell.widths[:self.test.sample.library.dimension]  # 2D: in its plane
        axis = int(np.argmin(widths))
        if widths[axis] >= limit:
            return ""
        return (f"{THIN_BOX}: the periodic cell is {widths[axis] * 1e3:.4g} mm across its "
                f"faces along axis {axis}, {widths[axis] / d_max:.2f} largest "
                f"particle diameters (at least {limit * 1e3:.4g} mm: three interaction ranges, "
                "so that no pair touches through two images); use more particles or a cell "
                "longer along that axis (sample aspect)")

    def settled(self, stage: CellStage, row: dict[str, Any]) -> bool:
        """A stress-driven stage with end targets is quasi-static at ``row`` (module
        docstring); stepped and strain-driven stages end otherwise."""
        if stage.strain_driven or stage.stage.stress_mode != "target":
            return False
        criteria = self.test.settings.quasi_static
        if not self._targets_met():
            return False
        normal = [row[c] for c in ("cell_sigma_xx", "cell_sigma_yy", "cell_sigma_zz")
                  if c in row]  # 2D: the in-plane two
        cell_p = sum(normal) / len(normal)
        if not cell_p > 0 or abs(row["p"] - cell_p) > criteria.stress_tolerance * cell_p:
            return False
        return (row["unbalanced_force_ratio"] <= criteria.unbalanced_force
                and row["kinetic_energy_ratio"] <= criteria.kinetic_energy)

    def stage_ended(self, stage: CellStage) -> None:
        """A stress-driven stage leaves the reference cell (and box edges)."""
        if not stage.moving_axes:
            self.cell.set_reference()
            self.reference_lengths = self.test.sample.box.lengths.copy()

    # -- records, outcome, checks before a run ----------------------------------------------
    def measures(self):
        """The row and network of the cell now."""
        test = self.test
        sim = test.simulation
        return cell_measures(sim.last_report, test.sample.state, test.sample.library,
                             self.cell, sim.last_dt, test.solver.friction)

    def stress_targets(self, stage: CellStage) -> dict[str, Any]:
        """The normal stress targets [Pa] of a stage controlled in the cell's own axes
        (``"target"`` stress mode, no rotation, the Voigt basis), by ``"xx"``...; those of a
        stage in a fixed mixed basis (a true triaxial test: sqrt(3) p and the deviator's
        direction) as :func:`generalised_targets`; empty for the other stages."""
        load = stage.stage
        if load.stress_mode != "target" or load.rotation_start or load.rotation_per_step:
            return {}
        if load.component_basis is not None:
            return generalised_targets(stage)
        return {AXES[a] * 2: float(load.values[a]) for a in range(load.dimension)
                if load.control[a] == "stress" and load.values[a] > 0.0}

    def predicted_flattening(self, stages: list[CellStage], started: bool) -> list:
        """No walls to flatten (the detection refuses a cell thinner than three
        interaction ranges)."""
        return []

    def fraction_done(self, stage: CellStage) -> float:
        """The stage's progress lambda over its steps."""
        return self.progress / max(stage.n_steps, 1)

    def stress_goal(self, stage: CellStage) -> list[float]:
        """The stage's reference stress [Pa]."""
        return [self.reference_stress]

    def checkpoint_arrays(self) -> dict[str, Any]:
        """The stage's progress, its reference and starting stresses, the widths at its
        start and the box's reference edges."""
        return {"stage_start_lengths": self.stage_start_lengths.copy(),
                "reference_lengths": self.reference_lengths.copy(),
                "progress": self.progress, "progress_step": self.progress_step,
                "reference_stress": self.reference_stress,
                "stage_start_stress": self.stage_start_stress.copy()}

    def restore(self, data: dict[str, Any]) -> None:
        """Inverse of :meth:`checkpoint_arrays`."""
        self.stage_start_lengths = np.asarray(data["stage_start_lengths"], dtype=float)
        self.reference_lengths = np.asarray(data["reference_lengths"], dtype=float)
        self.progress = float(data["progress"])
        self.progress_step = int(data["progress_step"])
        self.reference_stress = float(data["reference_stress"])
        self.stage_start_stress = np.asarray(data["stage_start_stress"], dtype=float)


_VOIGT_COLUMNS = {d: tuple(f"cell_sigma_{a}" for a in voigt_labels(d)) for d in (2, 3)}


def generalised_targets(stage: CellStage) -> dict[str, Any]:
    """The stress-controlled generalised components c = B sigma of a ``"target"`` stage in a
    fixed basis B (:mod:`grainlab.lab.cell_stages`), for the run's outcome: ``{"(B
    sigma)_i": (target [Pa], scale [Pa], value of a results row)}``, the scale the largest
    target (components held at 0, the deviator's direction of a true triaxial test, are
    judged against it); empty when every target is 0."""
    b = stage.control(0.0)
    dimension = stage.stage.dimension
    targets = stage.targets(np.zeros(stage.stage.n_components), float(stage.n_steps))
    held = np.flatnonzero(stage.stress_controlled)
    scale = float(np.max(np.abs(targets[held]))) if held.size else 0.0
    if not scale > 0.0:
        return {}

    def component(i: int):
        def value(row: dict[str, Any]) -> float:
            voigt = np.array([row.get(c, np.nan) for c in _VOIGT_COLUMNS[dimension]],
                             dtype=float)
            return float(b[i] @ voigt)
        return value

    return {f"(B sigma)_{i + 1}": (float(targets[i]), scale, component(int(i)))
            for i in held}
