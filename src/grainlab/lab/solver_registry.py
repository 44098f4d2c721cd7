"""The solvers a discrete test can run, one record each (:class:`SolverRecord`), in one
registry (:data:`SOLVERS`, STYLE.md 3): what the lab, the run's estimate, its outcome, its
options and its report know of a solver is read from its record, never from its name.

* ``"cd"``, contact dynamics (NSCD, rigid grains, implicit;
  :class:`~grainlab.engine.nscd.contact_dynamics.ContactDynamicsStep`): an iterative solve
  (:class:`~grainlab.engine.solver.IterativeSolver`), so each stage sets its NLGS tolerance,
  sweep cap and overlap recovery (:class:`~grainlab.lab.stage_numerics.StageNumerics`), its
  steps may end at the sweep cap (counted, judged by the outcome's capped share), and its
  automatic step may grow with the overlaps (``time_step_growth``);
* ``"dem"``, soft-contact DEM (explicit, deformable contacts;
  :class:`~grainlab.engine.dem.soft_contact.SoftContactStep`), its law from ``[solver.dem]``
  (:class:`~grainlab.lab.soft_contact_settings.SoftContactSettings`): no iterations, its
  steps in whole stable sub-steps, its cost in sub-steps (:mod:`grainlab.lab.run_estimate`),
  its sub-steps' zigzag judged (:mod:`grainlab.lab.run_outcome`); its contacts deform, so a
  periodic cell may strain it on every component (:func:`~grainlab.lab.cell_stages.
  cell_stages`).

A new solver is one more record: its builder, its settings, its stage settings and
checkpoint fields, the columns it writes and the config keys only it reads. A solver with
settings of its own names their frozen dataclass (``settings_type``, each field declaring
its bounds: :func:`~grainlab.lab.setting_bounds.bounded`) and their key (``settings_key``):
the config's ``[solver.<settings_key>]`` table is made from the dataclass
(:mod:`grainlab.lab.run_config`), and the run's settings hold them under that key
(:attr:`~grainlab.lab.discrete_test_settings.DiscreteTestSettings.solver_settings`).
``grainlab compare`` runs the pair :data:`COMPARED`.

>>> solver_record("dem").iterative, solver_record("cd").iterative
(False, True)
>>> SOLVER_NAMES
('cd', 'dem')
>>> sorted(default_solver_settings())
['dem']
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from grainlab.engine.dem.soft_contact import SoftContactStep
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.shape_kinds import MEMBER_SPHERES
from grainlab.errors import InputError
from grainlab.lab.soft_contact_settings import SoftContactSettings

STAGE_KEYS = ("compaction", "shear")
"""The stage tables of ``[solver]`` (:data:`~grainlab.lab.stage_numerics.STAGE_KINDS`)."""


@dataclass(frozen=True)
class SolverOption:
    """A command-line option of the run commands that sets a key of a solver's own table:
    the command's parameter ``name``, its ``flags``, its ``help``, the value's ``type`` and
    the config ``key`` it sets (the commands add the key's default to the help)."""

    name: str
    flags: tuple[str, ...]
    help: str
    type: type
    key: str


@dataclass(frozen=True)
class SolverRecord:
    """One solver of a discrete test (module docstring).

    Attributes
    ----------
    name, title, words:
        ``solver.method``'s value, its name and its words in a report.
    help:
        What it is, in the ``--solver`` option's help (:func:`solver_help`).
    settings_key, settings_type:
        The key of its own settings in
        :attr:`~grainlab.lab.discrete_test_settings.DiscreteTestSettings.solver_settings`
        (and its table ``[solver.<settings_key>]``), and their frozen dataclass, each field
        with its bounds (:func:`~grainlab.lab.setting_bounds.bounded`; None: it reads only
        the run-wide and stage settings).
    build:
        ``(settings, sample, confining, gyroscopic) -> (solver, contact law or None)``:
        the engine solver of a test's settings, its law (if any) taken at the first
        stage's confining stress ``confining()`` [Pa] (asked only by a solver with a law).
    iterative:
        Whether it solves each step iteratively (:class:`~grainlab.engine.solver.
        IterativeSolver`): the stages set its tolerance, sweep cap and overlap recovery,
        the outcome judges its share of capped steps.
    grows_step:
        Whether its automatic step may grow from the stage's shortest by
        ``time_step_growth`` (:mod:`grainlab.lab.step_control`).
    deformable:
        Whether its grains deform (a periodic cell may then strain every component).
    explicit_substeps:
        Whether it cuts each step into stable sub-steps: the stage's step is taken in whole
        sub-steps, its cost counted and estimated in sub-steps, the sub-steps' zigzag
        written (``velocity_zigzag``) and judged.
    stability_advice:
        What to change when its sub-steps zigzag (an unstable explicit scheme), in config
        keys (:mod:`grainlab.lab.run_outcome`).
    own_keys:
        Config keys only it reads (a key ending in ``.``: every key under it).
    keys_words, runs_words:
        Words for an option of its own set on another solver, and for it running.
    setting_reason:
        ``(config, key) -> str``: why a key of its own does nothing with the config's other
        settings ("" when it acts).
    label:
        ``(solver table of a config, plain data) -> str``: its settings in words.
    rolling_families, rolling_key:
        The narrow-phase families (:mod:`grainlab.engine.shape_kinds`) whose grains its
        rolling resistance (the key ``rolling_key`` of its own table, e.g.
        ``solver.dem.rolling_friction``) applies to; None: it has none.
    wall_keys:
        Keys of its own that only a box of walls reads.
    options:
        The command-line options that set keys of its own table (:class:`SolverOption`).
    stiffness_key:
        ``(solver table of a config) -> (key, value)``: the key that sets its stable
        sub-step (named when a run's estimate is too long; None: ``solver.method``).
    """

    name: str
    title: str
    words: str
    build: Callable[..., tuple[Any, Any]]
    help: str = ""
    settings_key: str | None = None
    settings_type: type | None = None
    iterative: bool = False
    grows_step: bool = False
    deformable: bool = False
    explicit_substeps: bool = False
    stability_advice: str = ""
    own_keys: tuple[str, ...] = ()
    keys_words: str = ""
    runs_words: str = ""
    setting_reason: Callable[[Any, str], str] = field(default=lambda config, key: "")
    label: Callable[[dict], str] | None = None
    rolling_families: tuple[str, ...] | None = None
    rolling_key: str = ""
    wall_keys: tuple[str, ...] = ()
    options: tuple[SolverOption, ...] = ()
    stiffness_key: Callable[[Any], tuple[str, float]] | None = None

    def __post_init__(self) -> None:
        if (self.settings_key is None) != (self.settings_type is None):
            raise TypeError(f"solver {self.name!r}: settings_key and settings_type go together")
        if self.rolling_families is not None and not (self.settings_key and self.rolling_key):
            raise TypeError(f"solver {self.name!r}: rolling_families needs the rolling_key "
                            "of its own settings")

    # -- the lab's use of the engine solver --------------------------------------------------
    def set_stage(self, solver, numerics, recovery_speed: float) -> None:
        """Give ``solver`` a stage's settings (:class:`~grainlab.lab.stage_numerics.
        StageNumerics`): its friction, and for an iterative solve its tolerance, sweep cap,
        overlap recovery and its speed cap ``recovery_speed`` [m/s]."""
        solver.friction = numerics.friction
        if self.iterative:
            solver.max_iterations = numerics.max_iterations
            solver.overlap_recovery = numerics.overlap_recovery
            solver.tolerance = numerics.tolerance
            solver.overlap_recovery_speed = recovery_speed

    def checkpoint_fields(self, solver) -> dict[str, Any]:
        """Its stage settings as plain data (a checkpoint; inverse :meth:`restore`)."""
        if not self.iterative:
            return {}
        return {"max_iterations": solver.max_iterations,
                "overlap_recovery": solver.overlap_recovery,
                "overlap_recovery_speed": solver.overlap_recovery_speed,
                "tolerance": solver.tolerance}

    def restore(self, solver, data: dict[str, Any]) -> None:
        """Inverse of :meth:`checkpoint_fields` (keys a checkpoint lacks are left)."""
        if not self.iterative:
            return
        if "max_iterations" in data:
            solver.max_iterations = int(data["max_iterations"])
            solver.overlap_recovery = float(data["overlap_recovery"])
            solver.tolerance = float(data["tolerance"])
        if "overlap_recovery_speed" in data:
            solver.overlap_recovery_speed = float(data["overlap_recovery_speed"])

    def step_length(self, solver, dt: float, state, library) -> float:
        """A stage's step [s] from ``dt``: in whole stable sub-steps for a solver of
        ``explicit_substeps`` (:meth:`~grainlab.engine.dem.soft_contact.SoftContactStep.
        whole_substeps`), else ``dt``."""
        return solver.whole_substeps(dt, state, library) if self.explicit_substeps else dt

    def row_fields(self, solver) -> dict[str, float]:
        """The results columns it writes besides the sample's measures:
        ``velocity_zigzag`` (its last step's, NaN without sub-steps)."""
        zigzag = solver.velocity_zigzag if self.explicit_substeps else math.nan
        return {"velocity_zigzag": float(zigzag)}

    def substeps(self, solver) -> int | None:
        """Its sub-steps so far (the run's cost), None without sub-steps."""
        return solver.n_substeps if self.explicit_substeps else None

    def inert_reason(self, config, key: str) -> str:
        """Why ``key`` does nothing with this solver running ("" when it acts): a key only
        another solver reads, or one of its own that its other settings make inert."""
        if _owns(self, key):
            return self.setting_reason(config, key)
        for other in SOLVERS.values():
            if other is not self and _owns(other, key):
                return f"it sets {other.keys_words}, which {self.runs_words} does not use"
        return ""


def _owns(record: SolverRecord, key: str) -> bool:
    return any(key == own or (own.endswith(".") and key.startswith(own))
               for own in record.own_keys)


# -- contact dynamics ---------------------------------------------------------------------------
def _build_contact_dynamics(settings, sample, confining, gyroscopic: bool):
    first = settings.compaction  # each stage sets its own numerics when it starts
    solver = ContactDynamicsStep(
        dt=settings.dt or 1.0, theta=settings.theta, tolerance=first.tolerance,
        max_iterations=first.max_iterations, friction=first.friction, sweep=settings.sweep,
        seed=settings.seed, overlap_recovery=first.overlap_recovery, gyroscopic=gyroscopic,
        warm_start_extrapolation=settings.warm_start_extrapolation,
        correction=settings.correction)
    return solver, None


NLGS_KEYS = ("solver.sweep", "solver.theta", "solver.warm_start_extrapolation",
             "solver.correction",
             "output.problems_every",
             *(f"solver.{kind}.{key}" for kind in STAGE_KEYS
               for key in ("tolerance", "max_iterations", "overlap_recovery",
                           "capped_share_limit", "time_step_growth")))
"""The keys only contact dynamics reads: its NLGS, its overlap recovery, its step growth and
the contact problems its steps write."""

CONTACT_DYNAMICS = SolverRecord(
    name="cd", title="contact dynamics", words="contact dynamics (rigid grains)",
    build=_build_contact_dynamics, help="contact dynamics: rigid grains, implicit",
    iterative=True, grows_step=True, own_keys=NLGS_KEYS,
    keys_words="the contact-dynamics solver (NLGS sweeps)",
    runs_words=("solver.method = 'cd' (the default solver, contact dynamics: rigid grains, "
                "no stiffness, damping or restitution)"))


# -- soft-contact DEM ---------------------------------------------------------------------------
def _build_soft_contact(settings, sample, confining, gyroscopic: bool):
    law = settings.dem.law_at(confining(), sample.mean_diameter)
    return SoftContactStep(law, dt=settings.dt or 1.0,
                           friction=settings.compaction.friction), law


def stiffness_setting(dem) -> tuple[str, float]:
    """The ``[solver.dem]`` key (and its value) that sets the stiffness of ``dem`` (a
    :class:`~grainlab.lab.soft_contact_settings.SoftContactSettings` or its config table):
    the law's own constant when given, else ``kappa``."""
    if dem.law == "linear" and dem.normal_stiffness > 0.0:
        return "solver.dem.normal_stiffness", dem.normal_stiffness
    if dem.law == "hertz_mindlin" and dem.young_modulus > 0.0:
        return "solver.dem.young_modulus", dem.young_modulus
    return "solver.dem.kappa", dem.kappa


def _soft_law_reason(config, key: str) -> str:
    dem = config.solver.dem
    if dem.law == "linear" and key in ("solver.dem.young_modulus", "solver.dem.poisson_ratio"):
        return ("it sets Hertz-Mindlin grains; solver.dem.law = 'linear' (--law linear) "
                "takes its stiffness from solver.dem.normal_stiffness or --kappa")
    if dem.law == "hertz_mindlin" and key == "solver.dem.normal_stiffness":
        return ("it sets linear springs; solver.dem.law = 'hertz_mindlin' (--law "
                "hertz_mindlin) takes its stiffness from --young-modulus or --kappa")
    if key == "solver.dem.kappa":
        given, value = stiffness_setting(dem)
        if given != key:
            return (f"{given} = {value:g} sets the stiffness already "
                    "(kappa is used only when it is 0)")
    return ""


def _soft_contact_label(table: dict) -> str:
    dem = table.get("dem", {})
    law = dem.get("law", "linear")
    if law == "linear" and dem.get("normal_stiffness", 0.0) > 0.0:
        stiffness = f"k_n = {dem['normal_stiffness']:g} N/m"
    elif law == "hertz_mindlin" and dem.get("young_modulus", 0.0) > 0.0:
        stiffness = f"E = {dem['young_modulus']:g} Pa"
    else:
        stiffness = f"kappa = {dem.get('kappa', math.nan):g}"
    return f"{law}, {stiffness}"


SOFT_CONTACT_OPTIONS = (
    SolverOption("law", ("--law",), "dem: contact law, linear (spring-dashpot, Cundall & "
                 "Strack) or hertz_mindlin.", str, "solver.dem.law"),
    SolverOption("kappa", ("--kappa",), "dem: stiffness number kappa = k_n / (SIGMA0 <d>) "
                 "(linear) or (E / ((1 - nu^2) SIGMA0))^(2/3) (Hertz); >= 1e4 for "
                 "quasi-rigid grains.", float, "solver.dem.kappa"),
    SolverOption("young_modulus", ("--young-modulus",), "dem, hertz_mindlin: the grains' "
                 "Young's modulus E [Pa] (0: from --kappa).", float,
                 "solver.dem.young_modulus"),
    SolverOption("restitution", ("--restitution",), "dem: coefficient of restitution of a "
                 "normal impact, in (0, 1].", float, "solver.dem.restitution"),
)
"""The command-line options of the soft-contact law."""

SOFT_CONTACT = SolverRecord(
    name="dem", title="soft-contact DEM", words="soft-contact DEM",
    build=_build_soft_contact, help="soft-contact DEM: elastic contacts, explicit",
    settings_key="dem", settings_type=SoftContactSettings,
    deformable=True, explicit_substeps=True, own_keys=("solver.dem.",),
    stability_advice="lower solver.dem.time_step_fraction or raise solver.dem.restitution",
    keys_words="the soft-contact law of solver.method = 'dem' (--solver dem)",
    runs_words=("solver.method = 'dem' (--solver dem, soft contacts, explicit: no sweeps, "
                "tolerance or iteration cap)"),
    setting_reason=_soft_law_reason, label=_soft_contact_label,
    rolling_families=(MEMBER_SPHERES,), rolling_key="rolling_friction",
    options=SOFT_CONTACT_OPTIONS,
    wall_keys=("solver.dem.rigid_walls",),
    stiffness_key=lambda table: stiffness_setting(table.dem))


SOLVERS: dict[str, SolverRecord] = {r.name: r for r in (CONTACT_DYNAMICS, SOFT_CONTACT)}
"""The registry, by ``solver.method``; the first is the default."""

SOLVER_NAMES = tuple(SOLVERS)
"""The solvers' names (``solver.method``'s values), the default first."""

DEFAULT_SOLVER = SOLVER_NAMES[0]

COMPARED = ("cd", "dem")
"""The pair ``grainlab compare`` runs on one sample, the reference first
(:mod:`grainlab.lab.solver_comparison`; its columns ``dem_minus_cd``, ``dem_over_cd``)."""


def solver_record(name: str) -> SolverRecord:
    """The record of ``solver.method = name``; an :class:`InputError` naming the allowed
    ones otherwise."""
    if name not in SOLVERS:
        raise InputError("method", name, " or ".join(f'"{m}"' for m in SOLVERS))
    return SOLVERS[name]


def own_settings_records() -> tuple[SolverRecord, ...]:
    """The solvers with settings of their own (a ``settings_key``), in the registry's order."""
    return tuple(r for r in SOLVERS.values() if r.settings_key is not None)


def default_solver_settings() -> dict[str, Any]:
    """``{settings_key: default settings}`` of every solver with settings of its own."""
    return {r.settings_key: r.settings_type() for r in own_settings_records()}


def solver_settings(given: Any) -> dict[str, Any]:
    """``given`` (a mapping ``{settings_key: settings}``) checked and completed with the
    defaults of the solvers it leaves out; an :class:`InputError` naming
    ``solver_settings[key]`` for a key no solver has or a value not of its type."""
    if not isinstance(given, Mapping):
        raise InputError("solver_settings", given, "a mapping {settings_key: settings}")
    records = {r.settings_key: r for r in own_settings_records()}
    out = default_solver_settings()
    for key, value in given.items():
        if key not in records:
            raise InputError(f"solver_settings[{key!r}]", value, "a key of "
                             + " or ".join(repr(k) for k in records))
        if not isinstance(value, records[key].settings_type):
            raise InputError(f"solver_settings[{key!r}]", value,
                             f"a {records[key].settings_type.__name__}")
        out[key] = value
    return out


def solver_help() -> str:
    """The ``--solver`` option's help: every registered solver with what it is."""
    return "The solver: " + "; ".join(f"{name} ({record.help or record.title})"
                                      for name, record in SOLVERS.items()) + "."


def solver_options() -> tuple[SolverOption, ...]:
    """The command-line options of every solver's own settings, in the registry's order."""
    return tuple(option for record in SOLVERS.values() for option in record.options)


def deformable_words() -> str:
    """The solvers whose grains deform, as a message names them:
    ``"solver.method = 'dem', --solver dem"``."""
    return " or ".join(f"solver.method = '{r.name}', --solver {r.name}"
                       for r in SOLVERS.values() if r.deformable)


def wall_keys() -> tuple[str, ...]:
    """The keys of the solvers' own tables that only a box of walls reads."""
    return tuple(key for record in SOLVERS.values() for key in record.wall_keys)


def solver_label(table: dict) -> str:
    """A config's solver in words (``table``: its ``[solver]`` as plain data):
    ``"contact dynamics (cd)"``, ``"soft-contact DEM (dem): linear, kappa = 1000"``."""
    method = table.get("method", DEFAULT_SOLVER)
    record = SOLVERS.get(method)
    if record is None:
        return method
    text = f"{record.title} ({method})"
    return text if record.label is None else f"{text}: {record.label(table)}"
