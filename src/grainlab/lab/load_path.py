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

>>> path = triaxial_compression(confining=1e5, axial_strain=0.01, n_steps=10)
>>> [s.name for s in path.stages], path.dimension
(['consolidation', 'shear'], 3)
>>> path.stages[1].control
('stress', 'stress', 'strain', 'strain', 'strain', 'strain')
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Mapping, Sequence
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

        >>> p = oedometer(strain_final=0.01, n_steps=5, unload_to_stress=1e4)
        >>> LoadPath.from_dict(p.to_dict()) == p
        True
        """
        return cls(data["name"], data["dimension"],
                   tuple(LoadStage.from_dict(s) for s in data["stages"]),
                   data.get("description", ""))


# -- presets ------------------------------------------------------------------------------------
def _vertical(dimension: int) -> str:
    return "zz" if dimension == 3 else "yy"


def _laterals(dimension: int) -> tuple[str, ...]:
    return ("xx", "yy") if dimension == 3 else ("xx",)


def _shears(dimension: int) -> tuple[str, ...]:
    return ("yz", "xz", "xy") if dimension == 3 else ("xy",)


def _isotropic_stage(name: str, pressure: float, n_steps: int, dimension: int) -> LoadStage:
    """All normal stresses to ``pressure`` [Pa], shear stresses to 0 (stress targets)."""
    stress = {c: pressure for c in (*_laterals(dimension), _vertical(dimension))}
    stress.update({c: 0.0 for c in _shears(dimension)})
    return LoadStage.from_components(name, n_steps, dimension, stress=stress,
                                     stress_mode="target")


def _k0_stage(vertical_stress: float, n_steps: int, dimension: int) -> LoadStage:
    """One-dimensional (K0) consolidation: vertical stress target, every other strain 0."""
    return LoadStage.from_components(
        "k0_consolidation", n_steps, dimension,
        strain={c: 0.0 for c in (*_laterals(dimension), *_shears(dimension))},
        stress={_vertical(dimension): vertical_stress}, stress_mode="target")


def isotropic_compression(*, p_final: float, n_steps: int, dimension: int = 3) -> LoadPath:
    """Isotropic compression to the mean stress ``p_final`` [Pa]: every normal stress is
    stress-controlled towards ``p_final``, every shear stress towards 0 (linear targets)."""
    p_final = _positive("p_final", p_final, "Pa")
    dim = _dimension("dimension", dimension)
    return LoadPath("isotropic_compression", dim,
                    (_isotropic_stage("isotropic", p_final, n_steps, dim),),
                    f"all normal stresses to {p_final:g} Pa, shear stresses 0")


def oedometer(
    *,
    strain_final: float,
    n_steps: int,
    unload_to_stress: float | None = None,
    unload_strain: float | None = None,
    unload_steps: int | None = None,
    dimension: int = 3,
) -> LoadPath:
    """One-dimensional (oedometric, K0) compression with optional unloading (seed 001 §4.2.1).

    Stage ``"loading"``: vertical strain (z in 3D, y in 2D) increases by ``strain_final`` [-]
    in ``n_steps`` equal increments; every lateral normal strain and every shear strain is 0.
    Optional stage ``"unloading"`` (``unload_steps``, default ``n_steps``), lateral and shear
    strains still 0: either the vertical stress goes linearly to ``unload_to_stress`` [Pa]
    (stress target), or the vertical strain decreases by ``unload_strain`` [-] (strain
    control). K0 = sigma_h/sigma_v against OCR = sigma_v,max/sigma_v:
    :func:`grainlab.lab.derived.k0_series`.
    """
    strain_final = _positive("strain_final", strain_final)
    dim = _dimension("dimension", dimension)
    v = _vertical(dim)
    n = _integer("n_steps", n_steps, 1)
    others = (*_laterals(dim), *_shears(dim))
    stages = [LoadStage.from_components(
        "loading", n, dim, strain={v: strain_final / n, **{c: 0.0 for c in others}})]
    if unload_to_stress is not None and unload_strain is not None:
        raise InputError("unload_strain", unload_strain,
                         "None when unload_to_stress is given (one unloading control)")
    m = n if unload_steps is None else _integer("unload_steps", unload_steps, 1)
    if unload_to_stress is not None:
        target = _positive("unload_to_stress", unload_to_stress, "Pa")
        stages.append(LoadStage.from_components(
            "unloading", m, dim, strain={c: 0.0 for c in others}, stress={v: target},
            stress_mode="target"))
    elif unload_strain is not None:
        amount = _positive("unload_strain", unload_strain)
        stages.append(LoadStage.from_components(
            "unloading", m, dim, strain={v: -amount / m, **{c: 0.0 for c in others}}))
    return LoadPath("oedometer", dim, tuple(stages),
                    f"vertical ({v}) strain-controlled, lateral and shear strains 0")


def _triaxial(name: str, confining: float, axial_strain: float, n_steps: int, drained: bool,
              consolidation_steps: int, sign: float) -> LoadPath:
    confining = _positive("confining", confining, "Pa")
    axial_strain = _positive("axial_strain", axial_strain)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("consolidation_steps", consolidation_steps, 0)
    if not isinstance(drained, bool):
        raise InputError("drained", drained, "True or False")
    d_axial = sign * axial_strain / n
    shears = {c: 0.0 for c in _shears(3)}
    if drained:
        shear = LoadStage.from_components(
            "shear", n, 3, strain={"zz": d_axial, **shears},
            stress={"xx": confining, "yy": confining}, stress_mode="target")
    else:
        shear = LoadStage.from_components(
            "shear", n, 3,
            strain={"zz": d_axial, "xx": -d_axial / 2, "yy": -d_axial / 2, **shears})
    stages = ([_isotropic_stage("consolidation", confining, m, 3)] if m else []) + [shear]
    return LoadPath(name, 3, tuple(stages),
                    f"confining {confining:g} Pa, axial (z) strain {sign * axial_strain:g}, "
                    + ("drained" if drained else "undrained (isochoric)"))


def triaxial_compression(
    *,
    confining: float,
    axial_strain: float,
    n_steps: int,
    drained: bool = True,
    consolidation_steps: int = 10,
) -> LoadPath:
    """Conventional triaxial compression (3D; axis z).

    Stage ``"consolidation"`` (skipped when ``consolidation_steps=0``): isotropic to
    ``confining`` [Pa]. Stage ``"shear"``: eps_zz increases by ``axial_strain`` [-] in
    ``n_steps`` increments, shear strains 0, and

    * drained: sigma_xx = sigma_yy = ``confining`` (stress targets, held);
    * undrained: constant volume, eps_xx = eps_yy = -eps_zz/2 (strain-controlled). The table
      then holds effective stresses; with the total lateral stress held at ``confining`` the
      excess pore pressure is u = confining - sigma_xx.
    """
    return _triaxial("triaxial_compression", confining, axial_strain, n_steps, drained,
                     consolidation_steps, 1.0)


def triaxial_extension(
    *,
    confining: float,
    axial_strain: float,
    n_steps: int,
    drained: bool = True,
    consolidation_steps: int = 10,
) -> LoadPath:
    """Triaxial extension by reduced axial stress (3D; axis z).

    As :func:`triaxial_compression` but eps_zz *decreases* by ``axial_strain`` [-] (given
    positive) while the lateral stresses stay at ``confining``: sigma_zz becomes the minor
    principal stress (b = 1). Undrained: eps_xx = eps_yy = -eps_zz/2.
    """
    return _triaxial("triaxial_extension", confining, axial_strain, n_steps, drained,
                     consolidation_steps, -1.0)


def true_triaxial_direction(b: float) -> np.ndarray:
    """Unit direction (n_x, n_y, n_z) of the principal stress increments that keeps the mean
    stress and b constant, with z major, x intermediate, y minor.

    From d1 + d2 + d3 = 0 and d2 - d3 = b (d1 - d3) with d1 = 1:
    d3 = -(1 + b)/(2 - b), d2 = (2b - 1)/(2 - b), i.e. (d1, d2, d3) proportional to
    (2 - b, 2b - 1, -(1 + b)); along it sigma_1 - sigma_3 grows by 3/|d| per unit length.

    >>> np.round(true_triaxial_direction(0.0) * np.sqrt(6), 12).tolist()  # (x, y, z)
    [-1.0, -1.0, 2.0]
    """
    b = _finite("b", b)
    if not 0.0 <= b <= 1.0:
        raise InputError("b", b, "a number in [0, 1]")
    d = np.array([2.0 * b - 1.0, -(1.0 + b), 2.0 - b])
    return d / np.linalg.norm(d)


def true_triaxial(
    *,
    p: float,
    b: float,
    n_steps: int,
    strain: float | None = None,
    q_final: float | None = None,
    consolidation_steps: int = 10,
) -> LoadPath:
    """Cubical (true) triaxial test at constant mean stress p and constant b (seed 001
    §4.2.2, eq. 4.7: b = (sigma_2 - sigma_3)/(sigma_1 - sigma_3)); 3D, z major, x
    intermediate, y minor principal axis, shear stresses 0.

    Stage ``"consolidation"``: isotropic to ``p`` [Pa]. Stage ``"shear"`` controls, through
    an orthogonal ``component_basis`` on (xx, yy, zz), the generalised components along
    n_d = :func:`true_triaxial_direction` (b), n_p = (1, 1, 1)/sqrt(3) and n_p x n_d:

    * sigma . n_p = sqrt(3) p and sigma . (n_p x n_d) = 0 (stress targets), so p and b stay
      exactly constant;
    * along n_d either the conjugate strain eps . n_d grows by ``strain`` [-] (strain
      control, which can follow a softening branch past the peak) or the stress goes to
      ``q_final`` = sigma_1 - sigma_3 [Pa] (stress target: sigma . n_d = q_final |d|/3).

    Give exactly one of ``strain`` and ``q_final``.
    """
    p = _positive("p", p, "Pa")
    n_d = true_triaxial_direction(b)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("consolidation_steps", consolidation_steps, 0)
    if (strain is None) == (q_final is None):
        raise InputError("strain", strain, "exactly one of strain and q_final to be given")
    n_p = np.ones(3) / np.sqrt(3.0)
    q3 = np.vstack([n_d, n_p, np.cross(n_p, n_d)])
    basis = np.eye(6)
    basis[:3, :3] = q3
    d_norm = np.linalg.norm([2.0 * b - 1.0, -(1.0 + b), 2.0 - b])
    stress = ["stress", "stress", "stress", "stress", "stress"]
    if strain is not None:
        control = ("strain", *stress)
        values = (_positive("strain", strain) / n, math.sqrt(3.0) * p, 0.0, 0.0, 0.0, 0.0)
    else:
        control = ("stress", *stress)
        values = (_positive("q_final", q_final, "Pa") * d_norm / 3.0, math.sqrt(3.0) * p,
                  0.0, 0.0, 0.0, 0.0)
    shear = LoadStage("shear", n, 3, control, values, stress_mode="target",
                      component_basis=tuple(map(tuple, basis)))
    stages = ([_isotropic_stage("consolidation", p, m, 3)] if m else []) + [shear]
    return LoadPath("true_triaxial", 3, tuple(stages),
                    f"p = {p:g} Pa and b = {b:g} held; z major, x intermediate, y minor")


def octahedral_stress(p: float, q: float, alpha: float) -> np.ndarray:
    """Voigt stress (3D) [Pa] at mean stress ``p``, deviator q = sqrt(3 J2) and angle
    ``alpha`` [rad] on the octahedral plane, measured from the projection of the z axis
    towards that of the x axis (alpha = 0: triaxial compression along z):
    sigma_zz = p + 2q/3 cos(alpha), sigma_xx = p + 2q/3 cos(alpha - 2 pi/3),
    sigma_yy = p + 2q/3 cos(alpha + 2 pi/3); shear stresses 0. The point lies at distance
    sqrt(2/3) q from the hydrostatic axis.

    >>> np.round(octahedral_stress(1.0, 3.0, 0.0), 12).tolist()
    [0.0, 0.0, 3.0, 0.0, 0.0, 0.0]
    """
    r = 2.0 * q / 3.0
    return np.array([p + r * math.cos(alpha - 2 * math.pi / 3),
                     p + r * math.cos(alpha + 2 * math.pi / 3),
                     p + r * math.cos(alpha), 0.0, 0.0, 0.0])


def circular_octahedral(
    *,
    p: float,
    radius_q: float,
    n_steps: int,
    alpha0: float = 0.0,
    consolidation_steps: int = 10,
    approach_steps: int = 10,
) -> LoadPath:
    """Circular stress path on the octahedral plane (seed 001 §4.2.3), 3D, fixed principal
    axes x, y, z (shear stresses 0, every component stress-controlled).

    Stages: ``"consolidation"`` isotropic to ``p`` [Pa] (skipped when 0 steps);
    ``"approach"``: radially at constant p to the point (p, ``radius_q``, ``alpha0``) of
    :func:`octahedral_stress`; ``"circle"``: ``n_steps`` targets (a schedule) at constant p
    and q = sqrt(3 J2) = ``radius_q`` [Pa], alpha = alpha0 + 2 pi k / n_steps, a full turn.
    """
    p = _positive("p", p, "Pa")
    radius_q = _positive("radius_q", radius_q, "Pa")
    n = _integer("n_steps", n_steps, 3)
    alpha0 = _finite("alpha0", alpha0, "rad")
    m = _integer("consolidation_steps", consolidation_steps, 0)
    a = _integer("approach_steps", approach_steps, 1)
    everything = ("stress",) * 6
    start = octahedral_stress(p, radius_q, alpha0)
    schedule = tuple(tuple(octahedral_stress(p, radius_q, alpha0 + 2 * math.pi * k / n))
                     for k in range(1, n + 1))
    stages = [_isotropic_stage("consolidation", p, m, 3)] if m else []
    stages.append(LoadStage("approach", a, 3, everything, tuple(start), stress_mode="target"))
    stages.append(LoadStage("circle", n, 3, everything, (0.0,) * 6, stress_mode="schedule",
                            schedule=schedule))
    return LoadPath("circular_octahedral", 3, tuple(stages),
                    f"p = {p:g} Pa, q = {radius_q:g} Pa, a full turn of the Lode angle")


def simple_shear(
    *,
    gamma_final: float,
    n_steps: int,
    vertical_stress: float,
    k0_consolidation_steps: int = 20,
    constant: str = "vertical_stress",
    dimension: int = 3,
) -> LoadPath:
    """Strain-controlled direct simple shear after K0 consolidation (seed 001 §4.2.4).

    Stage ``"k0_consolidation"`` (skipped with 0 steps): vertical stress (z in 3D, y in 2D)
    linearly to ``vertical_stress`` [Pa], every other strain 0. Stage ``"shear"``: the
    engineering shear strain gamma_xz (3D) / gamma_xy (2D) grows by ``gamma_final`` [-] in
    ``n_steps`` increments; lateral normal strains and the other shear strains are 0, and
    ``constant="vertical_stress"`` holds the vertical stress at ``vertical_stress``, while
    ``constant="height"`` holds the vertical strain (constant volume).
    """
    gamma_final = _positive("gamma_final", gamma_final)
    sigma_v = _positive("vertical_stress", vertical_stress, "Pa")
    dim = _dimension("dimension", dimension)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("k0_consolidation_steps", k0_consolidation_steps, 0)
    _choice("constant", constant, ("vertical_stress", "height"))
    shear = _shear_stage("shear", n, dim, gamma_final / n, sigma_v, constant)
    stages = ([_k0_stage(sigma_v, m, dim)] if m else []) + [shear]
    return LoadPath("simple_shear", dim, tuple(stages),
                    f"gamma_{_shear_component(dim)} to {gamma_final:g}, constant {constant}")


def _shear_component(dimension: int) -> str:
    return "xz" if dimension == 3 else "xy"


def _shear_stage(name: str, n_steps: int, dimension: int, d_gamma: float,
                 sigma_v: float | None, constant: str) -> LoadStage:
    s = _shear_component(dimension)
    v = _vertical(dimension)
    strain = {c: 0.0 for c in (*_laterals(dimension), *_shears(dimension))}
    strain[s] = d_gamma
    if constant == "vertical_stress" and sigma_v is not None:
        return LoadStage.from_components(name, n_steps, dimension, strain=strain,
                                         stress={v: sigma_v}, stress_mode="target")
    return LoadStage.from_components(name, n_steps, dimension, strain={**strain, v: 0.0})


def biaxial(
    *, confining: float, strain: float, n_steps: int, consolidation_steps: int = 10
) -> LoadPath:
    """Biaxial compression (2D): stage ``"consolidation"`` isotropic to ``confining`` [Pa];
    stage ``"shear"``: eps_yy grows by ``strain`` [-] in ``n_steps`` increments, sigma_xx held
    at ``confining``, gamma_xy = 0."""
    confining = _positive("confining", confining, "Pa")
    strain = _positive("strain", strain)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("consolidation_steps", consolidation_steps, 0)
    shear = LoadStage.from_components("shear", n, 2, strain={"yy": strain / n, "xy": 0.0},
                                      stress={"xx": confining}, stress_mode="target")
    stages = ([_isotropic_stage("consolidation", confining, m, 2)] if m else []) + [shear]
    return LoadPath("biaxial", 2, tuple(stages),
                    f"sigma_xx = {confining:g} Pa held, eps_yy to {strain:g}")


def cyclic_shear(
    *,
    amplitude: float,
    n_cycles: int,
    steps_per_quarter: int,
    vertical_stress: float | None = None,
    k0_consolidation_steps: int = 20,
    constant: str = "vertical_stress",
    dimension: int = 3,
) -> LoadPath:
    """Strain-controlled cyclic simple shear, gamma_xz (3D) / gamma_xy (2D) between
    +-``amplitude`` [-].

    Optional K0 consolidation to ``vertical_stress`` [Pa] first (as :func:`simple_shear`,
    and then the vertical stress or the height held per ``constant``); without
    ``vertical_stress`` the vertical strain is held (every strain controlled). Cycle k is
    three stages named ``"cycle_k"``: 0 -> +amplitude (``steps_per_quarter`` steps),
    -> -amplitude (2 ``steps_per_quarter``), -> 0 (``steps_per_quarter``); lateral strains
    and the other shears are 0. Per-cycle modulus and damping:
    :func:`grainlab.lab.derived.cyclic_shear_response`.
    """
    amplitude = _positive("amplitude", amplitude)
    cycles = _integer("n_cycles", n_cycles, 1)
    quarter = _integer("steps_per_quarter", steps_per_quarter, 1)
    dim = _dimension("dimension", dimension)
    m = _integer("k0_consolidation_steps", k0_consolidation_steps, 0)
    _choice("constant", constant, ("vertical_stress", "height"))
    sigma_v = None if vertical_stress is None else _positive("vertical_stress",
                                                              vertical_stress, "Pa")
    stages = [_k0_stage(sigma_v, m, dim)] if sigma_v is not None and m else []
    d = amplitude / quarter
    for k in range(1, cycles + 1):
        for steps, sign in ((quarter, 1.0), (2 * quarter, -1.0), (quarter, 1.0)):
            stages.append(_shear_stage(f"cycle_{k}", steps, dim, sign * d, sigma_v, constant))
    return LoadPath("cyclic_shear", dim, tuple(stages),
                    f"{cycles} cycles of gamma_{_shear_component(dim)} = +-{amplitude:g}")


# -- registry -----------------------------------------------------------------------------------
_PRESETS: dict[str, tuple[Callable[..., LoadPath], str]] = {
    "isotropic_compression": (isotropic_compression,
                              "all normal stresses to p_final, shear stresses 0"),
    "oedometer": (oedometer, "vertical strain, zero lateral strain, optional unloading (K0)"),
    "triaxial_compression": (triaxial_compression,
                             "eps_zz up at constant lateral stress (or constant volume)"),
    "triaxial_extension": (triaxial_extension,
                           "eps_zz down at constant lateral stress (or constant volume)"),
    "true_triaxial": (true_triaxial, "cubical test at constant p and b (strain or q_final)"),
    "circular_octahedral": (circular_octahedral,
                            "full circle on the octahedral plane at constant p and q"),
    "simple_shear": (simple_shear,
                     "K0 consolidation, then gamma at constant vertical stress or height"),
    "biaxial": (biaxial, "2D: eps_yy up at constant sigma_xx"),
    "cyclic_shear": (cyclic_shear, "strain-controlled cycles of gamma between +-amplitude"),
}


def preset_names() -> tuple[str, ...]:
    """Names of the preset load paths.

    >>> "oedometer" in preset_names()
    True
    """
    return tuple(_PRESETS)


def preset_description(name: str) -> str:
    """One-line description of a preset."""
    if name not in _PRESETS:
        raise InputError("preset", name, "one of " + ", ".join(_PRESETS))
    return _PRESETS[name][1]


def preset(name: str, **parameters: Any) -> LoadPath:
    """Build the preset ``name`` with keyword ``parameters`` (each checked against the
    preset's signature, so a misspelt name is an error).

    >>> preset("isotropic_compression", p_final=1e5, n_steps=4).n_steps
    4
    """
    if name not in _PRESETS:
        raise InputError("preset", name, "one of " + ", ".join(_PRESETS))
    function = _PRESETS[name][0]
    accepted = inspect.signature(function).parameters
    for key in parameters:
        if key not in accepted:
            raise InputError(f"{name}: {key}", parameters[key],
                             "a parameter among " + ", ".join(accepted))
    missing = [k for k, v in accepted.items()
               if v.default is inspect.Parameter.empty and k not in parameters]
    if missing:
        raise InputError(f"{name}: parameters", sorted(parameters),
                         "also " + ", ".join(missing))
    return function(**parameters)
