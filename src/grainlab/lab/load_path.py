"""Load paths as data: every element test is one mixed stress/strain control (STYLE.md 9).

A :class:`LoadPath` is a named sequence of :class:`LoadStage`. A stage says, for each Voigt
component of its *control frame* (6 in 3D, 3 in 2D), whether the strain or the stress is
controlled, and by how much per step; :func:`grainlab.lab.element_test.run_element_test` runs
it on any :class:`~grainlab.lab.specimen.ElementSpecimen`. Triaxial, oedometer, simple shear...
are preset *functions* returning a path (seed 001 §4.2: one-dimensional compression with
unloading, cubical tests at b, circular paths on the octahedral plane, direct simple shear).

Conventions
-----------
* SI units, compression positive; strains [-] with engineering shears (gamma = 2 eps); stresses
  [Pa]; angles [rad]. Voigt order as in :mod:`grainlab.lab.specimen`: 3D
  (xx, yy, zz, yz, xz, xy), 2D (xx, yy, xy).
* The vertical axis is z in 3D and y in 2D; the other normal axes are lateral.

Control frame
-------------
The controlled components of a stage are *generalised* components ``c = Q T_sigma(R) sigma``
(stress) and ``e = Q T_eps(R) eps`` (strain) where

* ``R = frame_rotation(rotation_axis, theta, dimension)`` rotates the lab basis by ``theta``
  about ``rotation_axis`` (right-handed; in 2D about the out-of-plane axis, counter-clockwise
  from x towards y): the columns of R are the frame's basis vectors in lab coordinates and the
  frame components of a tensor are ``R^T A R``; ``T_sigma``, ``T_eps`` are its Voigt forms
  (:func:`grainlab.lab.element_test.stress_rotation`);
* ``Q`` is an optional orthogonal matrix on the Voigt components (``component_basis``, default
  identity), which keeps stress and strain work-conjugate (c . e = sigma . eps); it lets a
  stage control combinations such as the mean stress and a deviator direction (true triaxial).

Step k of a stage (k = 1 ... n_steps) ends in the frame at angle
``theta_k = rotation_start + k rotation_per_step``; at the end of step k

* strain-controlled i: the strain increment of the step, expressed in that frame, has
  ``e_i = values[i]`` [-];
* stress-controlled i: ``c_i = target_k[i]`` [Pa], with c0 the specimen's generalised stress
  at the start of the stage (frame angle ``rotation_start``) and
  ``stress_mode="increment"``: target_k = c0 + k values (held constant by ``values = 0``, so a
  stress held in a rotating frame rotates with it); ``"target"``: target_k = c0 +
  (k / n_steps)(values - c0) (linear interpolation towards the stage's end value);
  ``"schedule"``: target_k = schedule[k - 1] (one target row per step).

The stress error left at the end of a step is carried: the next step aims at its own target.

Presets (triaxial, oedometer, simple shear, ...) live in :mod:`grainlab.lab.presets`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from numbers import Integral, Real
from typing import Any

import numpy as np

from grainlab.errors import InputError
from grainlab.lab.specimen import voigt_labels

CONTROL_KINDS = ("strain", "stress")
STRESS_MODES = ("increment", "target", "schedule")
ROTATION_AXES = ("x", "y", "z")
STOP_WHEN = ("above", "below")
STOP_ENDS = ("stage", "test")
_ORTHOGONALITY_TOLERANCE = 1e-9


# -- small validators ---------------------------------------------------------------------------
def _integer(field_name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        raise InputError(field_name, value, f"an integer >= {minimum}")
    return int(value)


def _finite(field_name: str, value: Any, unit: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
        raise InputError(field_name, value, f"a finite number{unit and ' in ' + unit}")
    return float(value)


def _positive(field_name: str, value: Any, unit: str = "") -> float:
    number = _finite(field_name, value, unit)
    if number <= 0.0:
        raise InputError(field_name, value, f"a positive number{unit and ' in ' + unit}")
    return number


def _dimension(field_name: str, value: Any) -> int:
    if isinstance(value, bool) or value not in (2, 3):
        raise InputError(field_name, value, "2 or 3")
    return int(value)


def _choice(field_name: str, value: Any, allowed: Sequence[str]) -> str:
    if value not in allowed:
        raise InputError(field_name, value, "one of " + ", ".join(repr(a) for a in allowed))
    return value


def frame_rotation(axis: str, angle: float, dimension: int) -> np.ndarray:
    """Rotation R (d, d) of the control frame: lab basis turned by ``angle`` [rad] about
    ``axis`` (right-handed). Columns of R are the frame's basis vectors in lab coordinates;
    the frame components of a tensor A are ``R^T A R``.

    In 2D only ``axis="z"`` (the out-of-plane axis) exists: x turns towards y.

    >>> np.round(frame_rotation("z", np.pi / 2, 3) @ [1.0, 0.0, 0.0], 12).tolist()
    [0.0, 1.0, 0.0]
    """
    c, s = math.cos(angle), math.sin(angle)
    if dimension == 2:
        if axis != "z":
            raise InputError("rotation_axis", axis, "'z' in 2D (the out-of-plane axis)")
        return np.array([[c, -s], [s, c]])
    if axis == "z":
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    if axis == "x":
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    if axis == "y":
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    raise InputError("rotation_axis", axis, "one of 'x', 'y', 'z'")


# -- stop criteria ------------------------------------------------------------------------------
@dataclass(frozen=True)
class StopCriterion:
    """End a stage (or the whole test) early when a recorded quantity crosses a limit.

    Attributes
    ----------
    quantity:
        A column of the results table, checked on each recorded step: ``"eps_zz"``,
        ``"gamma_xz"``, ``"stress_ratio"``, ``"q"``, a specimen descriptor...
    limit:
        The limit, in the unit of that column.
    when:
        ``"above"`` (stop when value >= limit) or ``"below"`` (value <= limit).
    absolute:
        Compare |value| instead of value.
    ends:
        ``"stage"`` (go on with the next stage) or ``"test"``.

    >>> StopCriterion("stress_ratio", 3.0).met({"stress_ratio": 3.2})
    True
    """

    quantity: str
    limit: float
    when: str = "above"
    absolute: bool = False
    ends: str = "stage"

    def __post_init__(self) -> None:
        if not isinstance(self.quantity, str) or not self.quantity:
            raise InputError("stop.quantity", self.quantity, "the name of a table column")
        object.__setattr__(self, "limit", _finite("stop.limit", self.limit))
        _choice("stop.when", self.when, STOP_WHEN)
        _choice("stop.ends", self.ends, STOP_ENDS)
        if not isinstance(self.absolute, bool):
            raise InputError("stop.absolute", self.absolute, "True or False")

    def met(self, row: Mapping[str, Any]) -> bool:
        """True when the criterion holds for one table row (a missing column is an error)."""
        if self.quantity not in row:
            raise InputError("stop.quantity", self.quantity,
                             "a column of the results table: " + ", ".join(map(str, row)))
        value = float(row[self.quantity])
        value = abs(value) if self.absolute else value
        return value >= self.limit if self.when == "above" else value <= self.limit

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {"quantity": self.quantity, "limit": self.limit, "when": self.when,
                "absolute": self.absolute, "ends": self.ends}


# -- stages -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LoadStage:
    """One stage of a load path: a mixed stress/strain control over ``n_steps`` steps.

    Attributes
    ----------
    name:
        Stage name, written to the ``stage`` column (several stages may share one).
    n_steps:
        Number of steps (recorded rows) [-], >= 1.
    dimension:
        2 or 3; the stage has 3 or 6 Voigt components.
    control:
        ``"strain"`` or ``"stress"`` for each component of the control frame.
    values:
        Per component: strain increment per step [-] (strain-controlled), or the stress
        increment per step / the stress target at the end of the stage [Pa]
        (stress-controlled, per ``stress_mode``; ignored with ``"schedule"``).
    stress_mode:
        ``"increment"``, ``"target"`` or ``"schedule"`` (see the module docstring).
    schedule:
        With ``"schedule"``: ``n_steps`` rows of Voigt stress targets [Pa] (only the
        stress-controlled entries are used); empty otherwise.
    rotation_axis, rotation_start, rotation_per_step:
        Control frame: axis (``"x"``, ``"y"``, ``"z"``; 2D: ``"z"``), angle at the start of
        the stage [rad] and its increment per step [rad] (0 for a fixed frame).
    component_basis:
        Optional orthogonal (n, n) matrix Q on the frame's Voigt components; ``None`` is the
        identity.
    stop:
        :class:`StopCriterion` objects checked after each step.
    """

    name: str
    n_steps: int
    dimension: int
    control: tuple[str, ...]
    values: tuple[float, ...]
    stress_mode: str = "increment"
    schedule: tuple[tuple[float, ...], ...] = ()
    rotation_axis: str = "z"
    rotation_start: float = 0.0
    rotation_per_step: float = 0.0
    component_basis: tuple[tuple[float, ...], ...] | None = None
    stop: tuple[StopCriterion, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InputError("stage.name", self.name, "a non-empty string")
        where = f"stage {self.name!r}"
        _integer(f"{where}: n_steps", self.n_steps, 1)
        dim = _dimension(f"{where}: dimension", self.dimension)
        n = 6 if dim == 3 else 3
        control = tuple(self.control) if isinstance(self.control, Sequence) else None
        if control is None or isinstance(self.control, str) or len(control) != n:
            raise InputError(f"{where}: control", self.control,
                             f"{n} entries 'strain' or 'stress' (Voigt {voigt_labels(dim)})")
        for i, kind in enumerate(control):
            _choice(f"{where}: control[{i}]", kind, CONTROL_KINDS)
        object.__setattr__(self, "control", control)
        if not isinstance(self.values, Sequence | np.ndarray) or len(self.values) != n:
            raise InputError(f"{where}: values", self.values, f"{n} numbers")
        values = tuple(_finite(f"{where}: values[{i}]", v) for i, v in enumerate(self.values))
        object.__setattr__(self, "values", values)
        _choice(f"{where}: stress_mode", self.stress_mode, STRESS_MODES)
        schedule = np.asarray(self.schedule, dtype=float) if len(self.schedule) else None
        if self.stress_mode == "schedule":
            if schedule is None or schedule.shape != (self.n_steps, n) or not np.all(
                np.isfinite(schedule)
            ):
                raise InputError(f"{where}: schedule", self.schedule,
                                 f"{self.n_steps} rows of {n} finite stresses in Pa")
            object.__setattr__(self, "schedule", tuple(tuple(map(float, r)) for r in schedule))
        elif schedule is not None:
            raise InputError(f"{where}: schedule", self.schedule,
                             "empty unless stress_mode='schedule'")
        if dim == 2 and self.rotation_axis != "z":
            raise InputError(f"{where}: rotation_axis", self.rotation_axis,
                             "'z' in 2D (the out-of-plane axis)")
        _choice(f"{where}: rotation_axis", self.rotation_axis, ROTATION_AXES)
        object.__setattr__(self, "rotation_start",
                           _finite(f"{where}: rotation_start", self.rotation_start, "rad"))
        object.__setattr__(self, "rotation_per_step",
                           _finite(f"{where}: rotation_per_step", self.rotation_per_step, "rad"))
        if self.component_basis is not None:
            q = np.asarray(self.component_basis, dtype=float)
            if (q.shape != (n, n) or not np.all(np.isfinite(q))
                    or not np.allclose(q @ q.T, np.eye(n), atol=_ORTHOGONALITY_TOLERANCE)):
                raise InputError(f"{where}: component_basis", self.component_basis,
                                 f"an orthogonal {n}x{n} matrix (Q Q^T = I) or None")
            object.__setattr__(self, "component_basis", tuple(tuple(map(float, r)) for r in q))
        stop = tuple(self.stop) if isinstance(self.stop, Sequence) else (self.stop,)
        for i, criterion in enumerate(stop):
            if not isinstance(criterion, StopCriterion):
                raise InputError(f"{where}: stop[{i}]", criterion, "a StopCriterion")
        object.__setattr__(self, "stop", stop)

    # -- construction by component name -------------------------------------------------------
    @classmethod
    def from_components(
        cls,
        name: str,
        n_steps: int,
        dimension: int,
        *,
        strain: Mapping[str, float] | None = None,
        stress: Mapping[str, float] | None = None,
        stress_mode: str = "increment",
        rotation_axis: str = "z",
        rotation_start: float = 0.0,
        rotation_per_step: float = 0.0,
        stop: Sequence[StopCriterion] = (),
    ) -> LoadStage:
        """A stage from components named by their Voigt label (``"xx"``, ``"xz"``...): each
        component must appear once, in ``strain`` (increment per step [-]) or in ``stress``
        (increment per step or end target [Pa], per ``stress_mode``).

        >>> s = LoadStage.from_components("shear", 10, 2, strain={"xx": 0, "xy": 1e-4},
        ...                               stress={"yy": 0.0})
        >>> s.control
        ('strain', 'stress', 'strain')
        """
        dim = _dimension(f"stage {name!r}: dimension", dimension)
        labels = voigt_labels(dim)
        strain, stress = dict(strain or {}), dict(stress or {})
        for group, given in (("strain", strain), ("stress", stress)):
            for key in given:
                if key not in labels:
                    raise InputError(f"stage {name!r}: {group}[{key!r}]", key,
                                     "a Voigt component among " + ", ".join(labels))
        both = set(strain) & set(stress)
        missing = [c for c in labels if c not in strain and c not in stress]
        if both:
            raise InputError(f"stage {name!r}: components", sorted(both),
                             "each component either strain- or stress-controlled, not both")
        if missing:
            raise InputError(f"stage {name!r}: components", missing,
                             "every Voigt component given in strain or in stress")
        control = tuple("strain" if c in strain else "stress" for c in labels)
        values = tuple(strain[c] if c in strain else stress[c] for c in labels)
        return cls(name, n_steps, dim, control, values, stress_mode=stress_mode,
                   rotation_axis=rotation_axis, rotation_start=rotation_start,
                   rotation_per_step=rotation_per_step, stop=tuple(stop))

    # -- what the driver reads ----------------------------------------------------------------
    @property
    def n_components(self) -> int:
        """3 (2D) or 6 (3D)."""
        return 6 if self.dimension == 3 else 3

    @property
    def stress_controlled(self) -> np.ndarray:
        """Boolean mask (n,) of the stress-controlled components."""
        return np.array([kind == "stress" for kind in self.control])

    @property
    def basis(self) -> np.ndarray:
        """Q (n, n): the component basis (identity when none was given)."""
        if self.component_basis is None:
            return np.eye(self.n_components)
        return np.array(self.component_basis)

    def frame_angle(self, step: float) -> float:
        """Frame angle [rad] at the end of (possibly fractional) step ``step``; 0 = start."""
        return self.rotation_start + step * self.rotation_per_step

    def rotation(self, step: float) -> np.ndarray:
        """R (d, d) of the control frame at the end of step ``step`` (see module docstring)."""
        return frame_rotation(self.rotation_axis, self.frame_angle(step), self.dimension)

    def strain_increment(self) -> np.ndarray:
        """Controlled strain increment per step (n,) [-]; 0 at stress-controlled entries."""
        return np.where(self.stress_controlled, 0.0, np.array(self.values))

    def stress_targets(self, start: np.ndarray) -> np.ndarray:
        """Targets (n_steps + 1, n) [Pa] of the generalised stress, row k = end of step k,
        row 0 = ``start`` (the generalised stress measured at the start of the stage).
        Strain-controlled columns carry ``start`` unchanged (unused)."""
        start = np.asarray(start, dtype=float)
        k = np.arange(self.n_steps + 1, dtype=float)[:, None]
        values = np.array(self.values)
        if self.stress_mode == "increment":
            targets = start + k * values
        elif self.stress_mode == "target":
            targets = start + (k / self.n_steps) * (values - start)
        else:
            targets = np.vstack([start, np.array(self.schedule)])
        return np.where(self.stress_controlled, targets, start)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON-able) for test-result metadata; :meth:`from_dict` reads it."""
        return {
            "name": self.name,
            "n_steps": self.n_steps,
            "dimension": self.dimension,
            "components": list(voigt_labels(self.dimension)),
            "control": list(self.control),
            "values": list(self.values),
            "stress_mode": self.stress_mode,
            "schedule": [list(r) for r in self.schedule],
            "rotation_axis": self.rotation_axis,
            "rotation_start": self.rotation_start,
            "rotation_per_step": self.rotation_per_step,
            "component_basis": (None if self.component_basis is None
                                else [list(r) for r in self.component_basis]),
            "stop": [c.to_dict() for c in self.stop],
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> LoadStage:
        """Inverse of :meth:`to_dict`."""
        data = dict(data)
        data.pop("components", None)
        basis = data.pop("component_basis", None)
        stop = tuple(StopCriterion(**c) for c in data.pop("stop", ()))
        schedule = tuple(tuple(r) for r in data.pop("schedule", ()))
        return cls(**data, schedule=schedule, stop=stop,
                   component_basis=None if basis is None else tuple(map(tuple, basis)))


# -- paths --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LoadPath:
    """A named sequence of stages, all of the same dimension.

    Attributes
    ----------
    name:
        Name of the test (``"oedometer"``...).
    dimension:
        2 or 3.
    stages:
        The :class:`LoadStage` objects, run in order.
    description:
        One line for humans (frame conventions, units).
    """

    name: str
    dimension: int
    stages: tuple[LoadStage, ...]
    description: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InputError("path.name", self.name, "a non-empty string")
        dim = _dimension("path.dimension", self.dimension)
        stages = tuple(self.stages) if isinstance(self.stages, Sequence) else ()
        if not stages:
            raise InputError("path.stages", self.stages, "at least one LoadStage")
        for i, stage in enumerate(stages):
            if not isinstance(stage, LoadStage):
                raise InputError(f"path.stages[{i}]", stage, "a LoadStage")
            if stage.dimension != dim:
                raise InputError(f"path.stages[{i}].dimension", stage.dimension,
                                 f"the path's dimension {dim}")
        object.__setattr__(self, "stages", stages)

    @property
    def n_steps(self) -> int:
        """Total number of steps of all stages."""
        return sum(s.n_steps for s in self.stages)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON-able) for test-result metadata."""
        return {"name": self.name, "dimension": self.dimension,
                "description": self.description,
                "stages": [s.to_dict() for s in self.stages]}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> LoadPath:
        """Inverse of :meth:`to_dict`.

        >>> from grainlab.lab.presets import oedometer
        >>> p = oedometer(strain_final=0.01, n_steps=5, unload_to_stress=1e4)
        >>> LoadPath.from_dict(p.to_dict()) == p
        True
        """
        return cls(data["name"], data["dimension"],
                   tuple(LoadStage.from_dict(s) for s in data["stages"]),
                   data.get("description", ""))


# -- presets ------------------------------------------------------------------------------------
