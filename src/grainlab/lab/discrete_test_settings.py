"""The numerical settings of a discrete test (:class:`DiscreteTestSettings`): the numerics of
each kind of stage (:class:`~grainlab.lab.stage_numerics.StageNumerics`) and those of the
whole run (time step, solver and its own settings, records, stage caps, walls, quasi-static
criteria); their roles are those of :mod:`grainlab.lab.discrete_test`.

>>> DiscreteTestSettings().numerics_for(strain_controlled=True) == SHEAR
True
>>> from grainlab.lab.soft_contact_settings import SoftContactSettings
>>> settings = DiscreteTestSettings(solver_settings={"dem": SoftContactSettings(kappa=1e3)})
>>> settings.dem.kappa, settings.solver_settings["dem"].law
(1000.0, 'linear')
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from itertools import pairwise
from typing import Any

import numpy as np

from grainlab._validate import at_least
from grainlab.engine.nscd.contact_dynamics import WARM_START_EXTRAPOLATION
from grainlab.errors import InputError
from grainlab.lab.solver_registry import (
    DEFAULT_SOLVER,
    default_solver_settings,
    solver_record,
    solver_settings,
)
from grainlab.lab.stage_numerics import (
    COMPACTION,
    SHEAR,
    STAGE_KINDS,
    StageNumerics,
    stage_kind,
)
from grainlab.lab.wall_stages import QuasiStaticCriteria

RECOVERY_SPEED_FRACTION = 0.25
"""Cap of the overlap recovery's separation speed, as a fraction of the stage's wall speed [-].
On 200 polyhedra (n_f = 30, 7.5 % overlaps left by the compaction) a cap at the full wall speed
let p swing between 115 Pa and 170 kPa (sigma0 = 10 kPa) early in shear, with I up to 0.21;
at 0.25 the largest I was 4e-3. Spheres never reach it (beta |g| / h <= 0.08 of the wall speed
at 0.5 % overlaps)."""


@dataclass(frozen=True)
class DiscreteTestSettings:
    """Numerical settings of a discrete test (module docstring for their roles): the
    numerics of each kind of stage, and those of the whole run.

    Attributes
    ----------
    compaction, shear:
        :class:`~grainlab.lab.stage_numerics.StageNumerics` (friction, bound on the inertia
        number, time step factor, NLGS tolerance and sweep cap, overlap recovery) of the
        stages without and with a strain-controlled axis (:meth:`numerics_for`); defaults
        :data:`~grainlab.lab.stage_numerics.COMPACTION` and
        :data:`~grainlab.lab.stage_numerics.SHEAR`. The overlap recovery's separation speed
        is capped at :data:`RECOVERY_SPEED_FRACTION` of the stage's wall speed
        (``overlap_recovery_speed`` of the solver).
    dt:
        Time step [s]; None: from the stage's ``time_step_factor``.
    theta, sweep, warm_start_extrapolation:
        Solver settings (:class:`~grainlab.engine.nscd.contact_dynamics.ContactDynamicsStep`;
        ``warm_start_extrapolation`` lambda in [0, 1], default
        :data:`~grainlab.engine.nscd.contact_dynamics.WARM_START_EXTRAPOLATION`).
    correction:
        The correction between sweeps of the contact-dynamics steps (``correction`` of
        :class:`~grainlab.engine.nscd.contact_dynamics.ContactDynamicsStep`): ``"subspace"``
        (default; it acts on the frictionless steps: the compaction), ``"none"``: NLGS alone,
        the reference.
    record_every, snapshot_every:
        Steps between results rows and between contact-network snapshots (0: none; with
        snapshots on, the state each stage ends in is one too). Snapshots are taken on
        records: at the first record at or past each multiple of ``snapshot_every``.
    snapshot_eps_q:
        Deviatoric strains eps_q [-] (increasing, > 0) at which a strain-driven stage also
        snapshots the contact network: at the first record where eps_q has risen past each
        (the peak's neighbourhood, say, denser than ``snapshot_every``); () none.
    max_stage_steps:
        Cap on the steps of one stage (>= 1); reaching it, the stage did not reach its end.
    at_max_stage_steps:
        What a stage that reaches ``max_stage_steps`` does: ``"stop"`` the test there
        (default; resumable with a larger cap) or start the ``"next_stage"`` all the same.
    wall_mass_factor:
        Mass of a stress-controlled wall / mass of the particles (> 0), when ``wall_servo``
        is False.
    wall_servo:
        Stress-controlled walls as overdamped servos (default): no speed carried over from
        one step to the next, damping c = sigma A / v_max (speed v_max when nothing holds
        them, at rest when the particles push back sigma A;
        :class:`~grainlab.engine.boundaries.wall_box.WallBox`). False: walls with the mass above.
    quasi_static:
        End criteria of stages without a strain-controlled axis.
    seed:
        Seed of the solver's visiting order.
    method:
        The solver, a name of :data:`~grainlab.lab.solver_registry.SOLVERS`: contact
        dynamics (rigid grains; default) or soft-contact DEM
        (:class:`~grainlab.engine.dem.soft_contact.SoftContactStep`); the NLGS settings
        (``tolerance``, ``max_iterations``, ``overlap_recovery``, ``theta``, ``sweep``)
        serve an iterative solver only (:attr:`~grainlab.lab.solver_registry.SolverRecord.
        iterative`).
    solver_settings:
        The settings of each solver that has its own, by its ``settings_key``
        (:class:`~grainlab.lab.solver_registry.SolverRecord`; those left out take their
        defaults), e.g. ``"dem"``: the soft-contact law
        (:class:`~grainlab.lab.soft_contact_settings.SoftContactSettings`), its stiffness
        number taken at the first stage's confining stress. Each is read as an attribute
        too: ``settings.dem``.
    """

    compaction: StageNumerics = COMPACTION
    shear: StageNumerics = SHEAR
    dt: float | None = None
    theta: float = 0.5
    sweep: str = "coloured"
    warm_start_extrapolation: float = WARM_START_EXTRAPOLATION
    correction: str = "subspace"
    record_every: int = 10
    snapshot_every: int = 0
    snapshot_eps_q: tuple[float, ...] = ()
    max_stage_steps: int = 200_000
    at_max_stage_steps: str = "stop"
    wall_mass_factor: float = 1.0
    wall_servo: bool = True
    quasi_static: QuasiStaticCriteria = field(default_factory=QuasiStaticCriteria)
    seed: int = 0
    method: str = DEFAULT_SOLVER
    solver_settings: dict[str, Any] = field(default_factory=default_solver_settings)

    def __post_init__(self) -> None:
        for kind in STAGE_KINDS:
            if not isinstance(getattr(self, kind), StageNumerics):
                raise InputError(kind, getattr(self, kind), "a StageNumerics")
        solver_record(self.method)  # a registered solver
        object.__setattr__(self, "solver_settings", solver_settings(self.solver_settings))
        at_least("wall_mass_factor", self.wall_mass_factor)
        if self.dt is not None:
            at_least("dt", self.dt)
        if self.at_max_stage_steps not in ("stop", "next_stage"):
            raise InputError("at_max_stage_steps", self.at_max_stage_steps,
                             '"stop" or "next_stage"')
        for name, low in (("record_every", 1), ("snapshot_every", 0), ("max_stage_steps", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) \
                    or value < low:
                raise InputError(name, value, f"an integer >= {low}")
        object.__setattr__(self, "snapshot_eps_q", strain_marks(self.snapshot_eps_q))

    def __getattr__(self, name: str) -> Any:
        """A solver's own settings by its ``settings_key`` (``settings.dem``)."""
        own = self.__dict__.get("solver_settings", {})
        if name in own:
            return own[name]
        raise AttributeError(f"{type(self).__name__} has no field or solver settings {name!r}")

    def numerics_for(self, strain_controlled: bool) -> StageNumerics:
        """The numerics of a stage with (True) or without a strain-controlled axis
        (:func:`~grainlab.lab.stage_numerics.stage_kind`)."""
        return getattr(self, stage_kind(strain_controlled))

    def to_dict(self) -> dict[str, Any]:
        """Plain data (each kind of stage's numerics a nested dict, each solver's own
        settings under its ``settings_key``)."""
        data = asdict(self)
        data["quasi_static"] = self.quasi_static.to_dict()
        data.update(data.pop("solver_settings"))
        return data


def strain_marks(values, field: str = "snapshot_eps_q") -> tuple[float, ...]:
    """``values`` as a tuple of strains [-], each finite and > 0, strictly increasing;
    otherwise :class:`~grainlab.errors.InputError` naming ``field``.

    >>> strain_marks([0.01, 0.02])
    (0.01, 0.02)
    """
    try:
        marks = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise InputError(field, values, "a list of strains > 0, increasing") from None
    if not all(math.isfinite(m) and m > 0.0 for m in marks) \
            or any(b <= a for a, b in pairwise(marks)):
        raise InputError(field, list(marks), "a list of strains > 0, increasing")
    return marks
