"""The stages of a lab load path as controls of a periodic cell (mixed control of all six
components in the stage's frame; :mod:`grainlab.engine.boundaries.periodic_boundary`).

A :class:`~grainlab.lab.load_path.LoadStage` controls generalised components c = B sigma
(stress) and e = B^-T eps (strain), B = Q T_sigma(R(k)) (:func:`~grainlab.lab.element_test.
control_matrix`: the frame R may rotate with the step k, Q mixes components). On a discrete
sample the stage runs in time, not in the element test's steps: its progress is a real
number lambda in [0, n_steps] (the element test's step count), and

* a stage with a strain-controlled component that moves (values != 0) is *strain driven*:
  lambda grows at the rate that makes the fastest generalised strain rate equal the stage's
  largest rate e_max (from the bound on the inertia number), the strain-controlled
  components follow e_i = lambda values_i, and the stress targets are the element test's at
  lambda (linear between its steps);
* a stage whose strain-controlled components are all held (values = 0) is *stress driven*:
  with ``stress_mode = "target"`` the targets are the stage's end values at once and the
  stage ends once the sample is quasi-static on them (as the wall box does); with
  ``"increment"`` or ``"schedule"`` (e.g. the circle of a circular stress path) lambda moves
  on by one step each time the targets of the current one are reached.

The velocity gradient of generalised strain rates de/dt is L = -U(B^T de/dt) with U(eps)
the upper-triangular gradient of a Voigt strain (engineering shears): L_aa = -eps_aa,
L_ab = -gamma_ab for a < b, L_ba = 0 (a simple shear, the cell's vectors keep their
directions below the diagonal), so that its symmetric part is minus the strain rate
(compression positive). A stress-controlled component d has the direction G_d = L(e_d) and
the conjugate stress c_d = -G_d : sigma = (B sigma)_d.

Rigid grains cannot follow a stage whose every component is strain-controlled with a
compression (an oedometer, a simple shear at constant height): there is no volume change a
rigid packing can give without a stress that grows without bound. Such a stage needs
deformable contacts: soft-contact DEM runs it, contact dynamics refuses it
(:func:`cell_stages`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from grainlab.errors import InputError
from grainlab.lab.element_test import ControlFrame
from grainlab.lab.load_path import LoadPath, LoadStage, StopCriterion
from grainlab.lab.solver_registry import deformable_words
from grainlab.lab.specimen import voigt_labels


def velocity_gradient(strain_rate: np.ndarray) -> np.ndarray:
    """L (3, 3) [1/s] of a Voigt strain rate (6,) [1/s] (compression positive, engineering
    shears): upper triangular, symmetric part = -strain rate (module docstring); a 2D one
    (3,) (xx, yy, xy) gives the in-plane block, with no z row or column (a planar cell)."""
    e = [float(v) for v in np.asarray(strain_rate, dtype=np.float64)]
    if len(e) == 3:
        e = [e[0], e[1], 0.0, 0.0, 0.0, e[2]]
    xy, xz, yz = 0.5 * e[5], 0.5 * e[4], 0.5 * e[3]  # the tensor's halves, added back
    return -np.array([[e[0] + 0.0, xy + xy, xz + xz],
                      [0.0, e[1] + 0.0, yz + yz],
                      [0.0, 0.0, e[2] + 0.0]])


@dataclass(frozen=True)
class CellStage:
    """One load stage as a periodic cell runs it (module docstring)."""

    stage: LoadStage

    @property
    def name(self) -> str:
        """The stage's name."""
        return self.stage.name

    @property
    def stop(self) -> tuple[StopCriterion, ...]:
        """The stage's stop criteria."""
        return self.stage.stop

    @property
    def n_steps(self) -> int:
        """The element test's steps: lambda runs from 0 to this."""
        return self.stage.n_steps

    @property
    def stress_controlled(self) -> np.ndarray:
        """(6,) bool ((3,) in 2D: xx, yy, xy)."""
        return self.stage.stress_controlled

    @property
    def modes(self) -> tuple[str, ...]:
        """Per generalised component, "stress" or "strain" (as a wall stage's modes: what a
        resumed run may not change for a stage under way)."""
        return tuple("stress" if c else "strain" for c in self.stress_controlled)

    @cached_property
    def strain_per_step(self) -> np.ndarray:
        """(6,) generalised strain per unit of lambda [-] (0 at stress components)."""
        values = self.stage.strain_increment()
        values.flags.writeable = False  # kept: read at every step
        return values

    @cached_property
    def strain_driven(self) -> bool:
        """Whether a strain-controlled component moves (module docstring)."""
        return bool(np.any(self.strain_per_step != 0.0))

    @property
    def moving_axes(self) -> tuple[int, ...]:
        """The generalised components whose strain moves (empty for a stress-driven stage;
        the lab's stage logic reads it as "a strain-controlled stage")."""
        return tuple(int(i) for i in np.flatnonzero(self.strain_per_step != 0.0))

    stress_axes: tuple[int, ...] = ()
    oedometric: bool = False

    def to_dict(self) -> dict:
        """Plain data: the lab stage's (the results' load path adds the boundary's name:
        :meth:`~grainlab.lab.boundary_registry.BoundaryRecord.stage_data`)."""
        return self.stage.to_dict()

    def progress_rate(self, max_rate: float) -> float:
        """d lambda / dt [1/s] of a strain-driven stage: the fastest generalised strain rate
        equals ``max_rate`` [1/s]."""
        return max_rate / float(np.max(np.abs(self.strain_per_step)))

    def targets(self, start: np.ndarray, progress: float) -> np.ndarray:
        """(6,) generalised stress targets [Pa] at ``progress`` lambda, from the generalised
        stress ``start`` at the start of the stage (module docstring: ``"target"`` stages
        that are stress driven aim at their end values at once)."""
        rows = self.stage.stress_targets(start)
        if not self.strain_driven and self.stage.stress_mode == "target":
            return rows[-1]
        k = min(max(progress, 0.0), float(self.n_steps))
        low = int(np.floor(k))
        high = min(low + 1, self.n_steps)
        return rows[low] + (k - low) * (rows[high] - rows[low])

    @cached_property
    def _frame(self) -> ControlFrame:
        """The stage's control matrices (kept for a frame that does not rotate)."""
        return ControlFrame(self.stage)

    @cached_property
    def _fixed_directions(self) -> np.ndarray | None:
        """The directions G_d of a frame that does not rotate (the same at any progress: the
        lab asks for them at every step); None for a rotating frame."""
        fixed = self._frame.fixed
        return None if fixed is None else self._directions(fixed)

    def control(self, progress: float) -> np.ndarray:
        """B (6, 6) at ``progress`` lambda."""
        return self._frame.matrix(progress)

    def _directions(self, b: np.ndarray) -> np.ndarray:
        unit = np.eye(self.stage.n_components)[self.stress_controlled]
        return np.array([velocity_gradient(b.T @ e) for e in unit]).reshape(-1, 3, 3)

    def gradients(self, progress: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
        """The prescribed velocity gradient L_0 (3, 3) [1/s] at progress lambda moving at
        ``rate`` d lambda/dt [1/s], and the directions G_d (D, 3, 3) of the stress-controlled
        components (module docstring)."""
        b = self.control(progress)
        kept = self._fixed_directions
        directions = kept.copy() if kept is not None else self._directions(b)
        return velocity_gradient(b.T @ (rate * self.strain_per_step)), directions

    def conjugate(self, stress: np.ndarray, progress: float) -> np.ndarray:
        """(6,) generalised stress c = B sigma [Pa] of a (3, 3) stress tensor ((3,) of its
        in-plane block in 2D)."""
        s = np.asarray(stress)
        voigt = np.array([s[0, 0], s[1, 1], s[2, 2], s[1, 2], s[0, 2], s[0, 1]]) \
            if self.stage.dimension == 3 else np.array([s[0, 0], s[1, 1], s[0, 1]])
        return self.control(progress) @ voigt


def cell_stages(path: LoadPath, deformable: bool = False) -> list[CellStage]:
    """The stages of a ``path`` for a periodic cell (a 2D path: a planar cell's in-plane
    components); for rigid grains (``deformable`` False: contact dynamics) refuses a stage
    whose every component is strain-controlled and that compresses or shears (module
    docstring); deformable contacts (soft-contact DEM) follow it."""
    stages = []
    for stage in path.stages:
        cell_stage = CellStage(stage)
        if not deformable and not np.any(stage.stress_controlled) \
                and cell_stage.strain_driven:
            labels = ", ".join(voigt_labels(path.dimension))
            raise InputError(
                f"stage {stage.name!r}: control", stage.control,
                f"at least one stress-controlled component ({labels}): a packing of rigid "
                "grains cannot follow a strain imposed on every component (an oedometer, a "
                "shear at constant height) without a stress that grows without bound; that "
                f"needs deformable contacts ({deformable_words()}), or run it in the "
                "wall box")
        stages.append(CellStage(stage, oedometric=_oedometric(cell_stage)))
    return stages


def _oedometric(stage: CellStage) -> bool:
    """Whether ``stage`` is a one-dimensional compression: every component strain-controlled,
    only the vertical strain moving (eps_zz; eps_yy in 2D; its rows then carry K0)."""
    moving = stage.strain_per_step != 0.0
    vertical = stage.stage.dimension - 1
    return (not np.any(stage.stress_controlled) and bool(moving[vertical])
            and not np.any(np.delete(moving, vertical)))
