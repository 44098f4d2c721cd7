"""The input of a discrete run, as a TOML file a user can write and read (pydantic models).

A run's ``config.toml`` has four tables, ``[solver]`` with a sub-table per kind of stage;
every key has a default, an unknown key is an error that names it::

    [sample]   shape (a name of :data:`~grainlab.prep.sample_shapes.SAMPLE_SHAPES`, such
               as "sphere", "aggregate", "polyhedron"), n_particles, d_min [m],
               size_ratio, sizes and fine_fraction (uniform by volume, or two sizes), eta
               (aggregates), n_faces and templates (polyhedra), density
               [kg/m^3], packing_fraction (loose start), wall_friction, seed, boundary
               (a name of :data:`~grainlab.lab.boundary_registry.BOUNDARY_NAMES`:
               "walls" | "periodic"), height_ratio (the start box's height / width),
               preparation ("loose" | "deposition" | "file"), skeleton_file (for "file")
    [test]     kind (:data:`TEST_KINDS`), sigma0 [Pa], eps_q_max (triaxial, extension,
               true_triaxial, cubical), axial_strain and unload_strain (oedometer), b
               (true_triaxial, cubical), gamma_max (simple_shear), q_ratio and
               circle_points (circular),
               amplitude and n_cycles (cyclic_shear)
    [test.quasi_static]   stress_tolerance, unbalanced_force, kinetic_energy: when a
               compaction has settled (:class:`~grainlab.lab.wall_stages.QuasiStaticCriteria`;
               inf: not checked)
    [solver]   method ("cd": contact dynamics | "dem": soft-contact DEM), dt [s]
               (0: automatic), theta, sweep, warm_start_extrapolation, correction
               ("subspace" | "none": NLGS alone), max_stage_steps,
               at_max_stage_steps ("stop" | "next_stage"), wall_mass_factor, wall_servo,
               seed
    [solver.compaction]   friction, inertia_number, time_step_factor, tolerance,
    [solver.shear]        max_iterations, overlap_recovery, capped_share_limit,
                          time_step_growth, overlap_bound
               (:class:`~grainlab.lab.stage_numerics.StageNumerics`: compaction for the
               stages without a strain-controlled axis, shear for the others; defaults
               :data:`~grainlab.lab.stage_numerics.COMPACTION` and
               :data:`~grainlab.lab.stage_numerics.SHEAR`)
    [solver.dem]   law ("linear" | "hertz_mindlin"), kappa, normal_stiffness [N/m],
               young_modulus [Pa], poisson_ratio, stiffness_ratio, restitution,
               rolling_friction, local_damping, time_step_fraction, rigid_walls
               (:class:`~grainlab.lab.soft_contact_settings.SoftContactSettings`)
    [output]   record_every, snapshot_every, checkpoint_every, vtk_every, problems_every,
               snapshot_eps_q
               (steps; 0: never)

Types are strict: a key that takes a number or a count refuses ``true`` and ``false`` (and a
count refuses 2.0), a switch refuses numbers, and a key that is a table (``test``,
``solver.shear``) refuses a value, each with a message naming the key and what it takes.

A config of the earlier layout, with the per-stage keys flat in ``[solver]`` (``friction``,
``compaction_friction``, ``tolerance``, ``compaction_tolerance``, ...: :data:`EARLIER_SOLVER_KEYS`),
is read as the same config (:func:`current_layout`), so that runs made with it can be resumed;
a key given in both layouts is refused.

A resumed run may change the keys of :data:`CHANGEABLE_ON_RESUME` (in ``config.toml`` or with
``grainlab resume RUN --set solver.shear.tolerance=1e-5``; :func:`parse_assignments`): how the
rest of the run is solved and written, and the targets of stages not ended yet. Every other
key made what the run already did (the sample, friction, the solver's scheme, the seeds) and
is refused with a message naming it (:meth:`RunConfig.changes_on_resume`).

>>> config = RunConfig.model_validate({"sample": {"n_particles": 50}})
>>> config.sample.n_particles, config.test.kind
(50, 'triaxial')
>>> try:
...     RunConfig.model_validate({"sample": {"n_particle": 50}})
... except InputError as error:
...     print(error.field)
sample.n_particle
"""

from __future__ import annotations

import tomllib
from dataclasses import fields
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, get_args, get_origin

import tomli_w
from pydantic import (
    ConfigDict,
    Field,
    StrictBool,
    StrictFloat,
    StrictInt,
    ValidationError,
    create_model,
    field_validator,
)

from grainlab._validate import MAX_SEED, read_toml
from grainlab.engine.shape_kinds import SPHERE
from grainlab.errors import InputError
from grainlab.lab.boundary_registry import (
    BOUNDARY_NAMES,
    DEFAULT_BOUNDARY,
    boundary_record,
    quoted,
    shearing_names,
)
from grainlab.lab.config_section import ConfigSection, settings_table, units
from grainlab.lab.discrete_test import DiscreteTestSettings
from grainlab.lab.discrete_test_settings import strain_marks
from grainlab.lab.kind_stages import kind_stages, renamed
from grainlab.lab.load_path import LoadPath
from grainlab.lab.presets import isotropic_compression
from grainlab.lab.solver_registry import SOLVERS, own_settings_records, solver_record
from grainlab.lab.stage_numerics import COMPACTION, SHEAR, STAGE_KINDS, StageNumerics
from grainlab.lab.wall_stages import QuasiStaticCriteria
from grainlab.prep.loose_sample import SIZE_DISTRIBUTIONS
from grainlab.prep.sample_shapes import MAX_FACES, sample_shape

TEST_KINDS = ("compaction", "triaxial", "extension", "oedometer", "true_triaxial", "cubical",
              "simple_shear", "circular", "cyclic_shear")
"""The lab tests of a discrete run: every one starts with an isotropic compaction to sigma0
(:meth:`RunConfig.load_path`)."""
PERIODIC_ONLY = ("true_triaxial", "cubical", "simple_shear", "circular", "cyclic_shear")
"""Tests that shear or control every principal stress: a periodic cell runs them, a box of
walls (which moves only along its axes, one stress per axis) cannot (the boundaries that run
them: :func:`~grainlab.lab.boundary_registry.shearing_names`)."""

UNITS = {"sample.d_min": "m", "sample.density": "kg/m^3", "test.sigma0": "Pa",
         "solver.dt": "s"}
"""Units of the keys that carry one, but for the solvers' own keys (:func:`unit_of`); the
others are dimensionless or counts."""


def unit_of(key: str) -> str:
    """The unit of the config key ``key`` ("" for none): :data:`UNITS`, or the one its
    solver's settings field declares (``"solver.dem.young_modulus"``: ``"Pa"``)."""
    if key in UNITS:
        return UNITS[key]
    for record in own_settings_records():
        own = units(record.settings_type, f"solver.{record.settings_key}.")
        if key in own:
            return own[key]
    return ""

_FACES_NOTE = ("even: n_f = 2 n_v - 4; Table I of Azéma, Radjaï & Dubois 2013: 8, 20, 30, "
               "46, 96, 176, 596")

CHANGEABLE_STAGE_KEYS = ("inertia_number", "time_step_factor", "tolerance",
                         "max_iterations", "overlap_recovery", "capped_share_limit",
                         "time_step_growth", "overlap_bound")
"""The keys of ``[solver.compaction]`` and ``[solver.shear]`` a resumed run may change (all but
the friction)."""

QUASI_STATIC_KEYS = ("stress_tolerance", "unbalanced_force", "kinetic_energy")
"""The keys of ``[test.quasi_static]``: a resumed run may change them (the end of a
compaction not ended yet)."""

CHANGEABLE_ON_RESUME = (
    "test.eps_q_max", "test.axial_strain", "test.unload_strain",
    *(f"test.quasi_static.{key}" for key in QUASI_STATIC_KEYS),
    "solver.dt", "solver.max_stage_steps", "solver.at_max_stage_steps",
    *(f"solver.{kind}.{key}" for kind in STAGE_KINDS for key in CHANGEABLE_STAGE_KEYS),
    "output.record_every", "output.snapshot_every", "output.checkpoint_every",
    "output.vtk_every", "output.problems_every", "output.snapshot_eps_q",
)
"""Keys a resumed run may change (module docstring): they take effect from the resumed step
on, in the stage under way too (a target only in a stage not ended yet). Every per-stage key
but the friction."""

EARLIER_SOLVER_KEYS = {
    "friction": "shear.friction", "compaction_friction": "compaction.friction",
    "inertia_number": "shear.inertia_number",
    "compaction_inertia_number": "compaction.inertia_number",
    "time_step_factor": "shear.time_step_factor",
    "compaction_time_step_factor": "compaction.time_step_factor",
    "tolerance": "shear.tolerance", "compaction_tolerance": "compaction.tolerance",
    "max_iterations": "shear.max_iterations",
    "compaction_max_iterations": "compaction.max_iterations",
    "overlap_recovery": "shear.overlap_recovery",
}
"""The per-stage keys of the earlier layout, flat in ``[solver]`` (compaction always ran
without overlap recovery then), and the key of ``[solver]`` each is now."""

_RUN_WIDE = DiscreteTestSettings()
_SETTLED = QuasiStaticCriteria()
"""The defaults of the run-wide settings (one place: :class:`DiscreteTestSettings`)."""

class SampleConfig(ConfigSection):
    """Particles of a sample: ``preparation`` "loose" (a loose random sample,
    :func:`grainlab.prep.loose_sample.loose_sample`), "deposition" (the particles inscribed in
    a dense deposited sphere packing, seeds 002/003 §II,
    :func:`grainlab.prep.inscribed_sample.deposited_sample`; a box of walls only) or "file":
    either inscribed in the spheres of ``skeleton_file`` (a .npz or .csv file of
    :mod:`grainlab.prep.sphere_skeleton`; n_particles, d_min, size_ratio and height_ratio
    then come from the file) or the particles of ``particle_file`` themselves (a .npz or .csv
    file of :mod:`grainlab.prep.particle_files`: each particle's sphere, member spheres or
    vertices in world coordinates; the shapes, sizes and box then come from the file too, and
    only density and wall_friction apply).

    ``n_faces`` (even, in [8, 1000]; seed 002 Table I: 8, 20, 30, 46, 96, 176, 596) and
    ``templates`` (0: every polyhedron its own, as seed 002; K > 0: K shapes reused in random
    orientations) apply to polyhedra only, ``eta`` to aggregates only.
    """

    shape: str = SPHERE.name
    n_particles: StrictInt = Field(1000, ge=1)
    d_min: StrictFloat = Field(1e-3, gt=0)
    size_ratio: StrictFloat = Field(2.0, ge=1)
    sizes: Literal[SIZE_DISTRIBUTIONS] = "uniform_volume"
    fine_fraction: StrictFloat = Field(0.5, gt=0, lt=1)
    eta: StrictFloat = Field(0.4, ge=0, le=0.828)
    n_faces: StrictInt = Field(30, ge=8, le=MAX_FACES, description=_FACES_NOTE)
    templates: StrictInt = Field(0, ge=0)
    density: StrictFloat = Field(2600.0, gt=0)
    packing_fraction: StrictFloat = Field(0.3, gt=0, le=0.35)
    wall_friction: StrictFloat = Field(0.0, ge=0)
    seed: StrictInt = Field(0, ge=0, le=MAX_SEED)
    boundary: Literal[BOUNDARY_NAMES] = DEFAULT_BOUNDARY
    height_ratio: StrictFloat = Field(1.0, ge=0.25, le=4.0)
    preparation: Literal["loose", "deposition", "file"] = "loose"
    skeleton_file: str = ""
    particle_file: str = ""

    @field_validator("shape", mode="before")
    @classmethod
    def _registered_shape(cls, value: Any) -> str:
        """A shape a loose sample can be made of (the kinds of
        :data:`~grainlab.prep.sample_shapes.SAMPLE_SHAPES`; discs make a 2D sample)."""
        kind = sample_shape(value).kind
        return kind.name

    @field_validator("n_faces")
    @classmethod
    def _even_faces(cls, value: int) -> int:
        if value % 2:
            raise ValueError(_FACES_NOTE)
        return value


class QuasiStaticConfig(ConfigSection):
    """``[test.quasi_static]``: when a stage without a strain-controlled axis (the
    compaction) has settled (:class:`~grainlab.lab.wall_stages.QuasiStaticCriteria`: the
    stresses within ``stress_tolerance`` of their targets, the unbalanced force ratio and the
    kinetic energy ratio at most ``unbalanced_force`` and ``kinetic_energy``; ``inf``: not
    checked)."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=True)

    stress_tolerance: StrictFloat = Field(_SETTLED.stress_tolerance, gt=0, lt=1)
    unbalanced_force: StrictFloat = Field(_SETTLED.unbalanced_force, gt=0,
                                    description="or inf: not checked")
    kinetic_energy: StrictFloat = Field(_SETTLED.kinetic_energy, gt=0,
                                  description="or inf: not checked")

    frozen_as: ClassVar[type] = QuasiStaticCriteria

    def criteria(self) -> QuasiStaticCriteria:
        """The :class:`~grainlab.lab.wall_stages.QuasiStaticCriteria` of this table."""
        return self.frozen()


class TestConfig(ConfigSection):
    """The lab test: isotropic compaction to sigma0, then (triaxial) compression at constant
    lateral stress sigma0 to eps_q_max, (extension) the same with the axial strain reversed,
    (oedometer) 1-D compression by axial_strain and optional unloading by unload_strain,
    (true_triaxial) constant p = sigma0 and constant b to eps_q_max, (cubical) constant
    sigma_3 = sigma0 and constant b to eps_q_max (Lade & Duncan's cubical test),
    (simple_shear) gamma_xz to gamma_max with sigma_zz held at sigma0 and eps_xx = eps_yy =
    0, (circular) a full
    turn on the octahedral plane at p = sigma0 and q = q_ratio sigma0 (circle_points
    targets), (cyclic_shear) n_cycles of gamma_xz between +-amplitude with sigma_zz held."""

    __test__ = False

    kind: Literal["compaction", "triaxial", "extension", "oedometer", "true_triaxial", "cubical",
                  "simple_shear", "circular", "cyclic_shear"] = "triaxial"
    sigma0: StrictFloat = Field(1e4, gt=0)
    eps_q_max: StrictFloat = Field(0.5, gt=0, le=2.0)
    axial_strain: StrictFloat = Field(0.05, gt=0, le=1.0)
    unload_strain: StrictFloat = Field(0.0, ge=0, le=1.0)
    b: StrictFloat = Field(0.5, ge=0, le=1)
    gamma_max: StrictFloat = Field(0.5, gt=0, le=10.0)
    q_ratio: StrictFloat = Field(0.3, gt=0, le=1.5)
    circle_points: StrictInt = Field(36, ge=4, le=3600)
    amplitude: StrictFloat = Field(0.01, gt=0, le=1.0)
    n_cycles: StrictInt = Field(2, ge=1, le=1000)
    quasi_static: QuasiStaticConfig = Field(default_factory=QuasiStaticConfig)


Friction = Annotated[StrictFloat, Field(ge=0)]
InertiaBound = Annotated[StrictFloat, Field(gt=0, le=1.0)]
TimeStepFactor = Annotated[StrictFloat, Field(gt=0, le=0.5)]
Tolerance = Annotated[StrictFloat, Field(gt=0, lt=1)]
SweepCap = Annotated[StrictInt, Field(ge=1)]
OverlapRecovery = Annotated[StrictFloat, Field(ge=0, le=1)]
ShareLimit = Annotated[StrictFloat, Field(ge=0, le=1)]
StepGrowth = Annotated[StrictFloat, Field(ge=1)]
OverlapBound = Annotated[StrictFloat, Field(gt=0, lt=0.1)]


STAGE_KEY_TYPES: dict[str, Any] = {
    "friction": Friction, "inertia_number": InertiaBound, "time_step_factor": TimeStepFactor,
    "tolerance": Tolerance, "max_iterations": SweepCap, "overlap_recovery": OverlapRecovery,
    "capped_share_limit": ShareLimit, "time_step_growth": StepGrowth,
    "overlap_bound": OverlapBound,
}
"""What each key of a stage table takes: one per field of
:class:`~grainlab.lab.stage_numerics.StageNumerics` (the tables are made from its fields)."""


class _StageSection(ConfigSection):
    frozen_as: ClassVar[type] = StageNumerics

    def numerics(self) -> StageNumerics:
        """The :class:`~grainlab.lab.stage_numerics.StageNumerics` of this table."""
        return self.frozen()


def _stage_table(name: str, defaults: StageNumerics, doc: str) -> type[_StageSection]:
    """The pydantic model of a stage table: a key per field of
    :class:`~grainlab.lab.stage_numerics.StageNumerics`, in its order, typed by
    :data:`STAGE_KEY_TYPES`, its default that of ``defaults``."""
    names = [field.name for field in fields(StageNumerics)]
    if set(names) != set(STAGE_KEY_TYPES):
        raise TypeError(f"STAGE_KEY_TYPES {sorted(STAGE_KEY_TYPES)} must name the fields of "
                        f"StageNumerics {sorted(names)}")
    return create_model(name, __base__=_StageSection, __doc__=doc, __module__=__name__,
                        **{key: (STAGE_KEY_TYPES[key], getattr(defaults, key))
                           for key in names})


CompactionConfig = _stage_table(
    "CompactionConfig", COMPACTION,
    "``[solver.compaction]``: the numerics of stages without a strain-controlled axis "
    "(:class:`~grainlab.lab.stage_numerics.StageNumerics`; defaults "
    ":data:`~grainlab.lab.stage_numerics.COMPACTION`).")
ShearConfig = _stage_table(
    "ShearConfig", SHEAR,
    "``[solver.shear]``: the numerics of stages with a strain-controlled axis (triaxial "
    "shear, oedometer loading and unloading; "
    ":class:`~grainlab.lab.stage_numerics.StageNumerics`; defaults "
    ":data:`~grainlab.lab.stage_numerics.SHEAR`).")


class _RunWideSolver(ConfigSection):
    """The keys of ``[solver]`` every solver has: the run-wide keys and a table per kind of
    stage (:func:`solver_config` sets the solvers ``method`` takes and adds their own
    tables)."""

    method: str = _RUN_WIDE.method
    dt: StrictFloat = Field(0.0, ge=0)
    theta: StrictFloat = Field(_RUN_WIDE.theta, ge=0.5, le=1.0)
    sweep: Literal["coloured", "serial"] = _RUN_WIDE.sweep
    warm_start_extrapolation: StrictFloat = Field(_RUN_WIDE.warm_start_extrapolation, ge=0, le=1)
    correction: Literal["subspace", "none"] = _RUN_WIDE.correction
    max_stage_steps: StrictInt = Field(_RUN_WIDE.max_stage_steps, ge=1)
    at_max_stage_steps: Literal["stop", "next_stage"] = _RUN_WIDE.at_max_stage_steps
    wall_mass_factor: StrictFloat = Field(_RUN_WIDE.wall_mass_factor, gt=0)
    wall_servo: StrictBool = _RUN_WIDE.wall_servo
    seed: StrictInt = Field(_RUN_WIDE.seed, ge=0, le=MAX_SEED)
    compaction: CompactionConfig = Field(default_factory=CompactionConfig)
    shear: ShearConfig = Field(default_factory=ShearConfig)

    @property
    def solver_settings(self) -> dict[str, Any]:
        """The solvers' own tables as their frozen settings, by ``settings_key``
        (:attr:`~grainlab.lab.discrete_test_settings.DiscreteTestSettings.solver_settings`)."""
        return {record.settings_key: getattr(self, record.settings_key).frozen()
                for record in own_settings_records()}


def solver_config() -> type[ConfigSection]:
    """The model of ``[solver]`` for the solvers registered now
    (:data:`~grainlab.lab.solver_registry.SOLVERS`): ``method`` (one of their names, the
    first the default), the run-wide keys and stage tables, and a table
    ``[solver.<settings_key>]`` per solver with settings of its own, made from their
    dataclass (:func:`~grainlab.lab.config_section.settings_table`)."""
    tables = {}
    for record in own_settings_records():
        table = settings_table(
            f"{record.settings_key.title()}Config", record.settings_type,
            f"``[solver.{record.settings_key}]``: the settings of ``method = "
            f"\"{record.name}\"``, {record.title} "
            f"(:class:`{record.settings_type.__module__}.{record.settings_type.__name__}`).")
        tables[record.settings_key] = (table, Field(default_factory=table))
    return create_model(
        "SolverConfig", __base__=_RunWideSolver, __module__=__name__,
        __doc__="Numerical settings (:class:`grainlab.lab.discrete_test.DiscreteTestSettings`): "
                "the solver, the run-wide keys, a table per kind of stage and one per solver "
                "with settings of its own.",
        method=(Literal[tuple(SOLVERS)], _RUN_WIDE.method), **tables)


SolverConfig = solver_config()


class OutputConfig(ConfigSection):
    """How often (in steps) to record, snapshot, checkpoint, export VTK and store the
    contact problem of a step (0: never). Contact networks are snapshotted by default (every
    500 steps: some 30 over a 1000-sphere triaxial test to eps_q = 0.5), so that ``grainlab
    analyse RUN`` has something to read. ``problems_every``: the frictional contact problem
    of every such contact-dynamics step goes to ``problems/step-NNNNNNNN.hdf5`` in FCLib's
    layout (:mod:`grainlab.engine.nscd.contact_problem`), to compare solvers on it
    (``benchmarks/benchmark_plain_problem_methods.py``). ``snapshot_eps_q``: deviatoric
    strains at which a strain-driven stage also snapshots, at the first record past each (a
    list, e.g. ``[0.01, 0.02, 0.03]`` to catch the peak;
    ``DiscreteTestSettings.snapshot_eps_q``)."""

    record_every: StrictInt = Field(_RUN_WIDE.record_every, ge=1)
    snapshot_every: StrictInt = Field(500, ge=0)
    checkpoint_every: StrictInt = Field(500, ge=0)
    vtk_every: StrictInt = Field(0, ge=0)
    problems_every: StrictInt = Field(0, ge=0)
    snapshot_eps_q: tuple[float, ...] = ()

    @field_validator("snapshot_eps_q")
    @classmethod
    def _strain_marks(cls, value: tuple[float, ...]) -> tuple[float, ...]:
        return strain_marks(value, "output.snapshot_eps_q")


class RunConfig(ConfigSection):
    """The whole input of a run."""

    sample: SampleConfig = Field(default_factory=SampleConfig)
    test: TestConfig = Field(default_factory=TestConfig)
    solver: SolverConfig = Field(default_factory=SolverConfig)
    output: OutputConfig = Field(default_factory=OutputConfig)

    @classmethod
    def model_validate(cls, obj: Any, **kwargs) -> RunConfig:  # type: ignore[override]
        """Validate plain data (of the earlier layout too: :func:`current_layout`); errors
        become :class:`InputError` naming the field as the data spells it."""
        data, earlier = current_layout(obj)
        try:
            return super().model_validate(data, **kwargs)
        except ValidationError as error:
            raise _as_written(_input_error(error), earlier) from None

    @classmethod
    def read(cls, path: str | Path, *, saved: bool = False) -> RunConfig:
        """Read a TOML file (``saved``: a run folder's ``config.toml``, read as
        :meth:`of_saved_run` reads it)."""
        path = Path(path)
        data = read_toml(path, "config")
        try:
            return cls.of_saved_run(data) if saved else cls.model_validate(data)
        except InputError as error:
            raise InputError(f"{error.field} (in {path})", error.value,
                             error.allowed) from None

    @classmethod
    def of_saved_run(cls, data: Any) -> RunConfig:
        """Validate the config a run saved (its checkpoint's, its folder's ``config.toml``).
        A run writes every key; a stage table without ``time_step_growth`` was saved before
        the step grew (:mod:`grainlab.lab.step_control`), with fixed steps, and is read with
        ``time_step_growth = 1`` so that the run resumes as it ran; one without
        ``capped_share_limit`` was saved before capped steps were limited, and is read with
        1 (any share accepted, as it was)."""
        data, _ = current_layout(data)
        if isinstance(data, dict) and isinstance(data.get("solver"), dict):
            solver = dict(data["solver"])
            for kind in STAGE_KINDS:
                table = solver.get(kind, {})
                if isinstance(table, dict) and "time_step_growth" not in table:
                    solver[kind] = {**table, "time_step_growth": 1.0}
                if isinstance(solver.get(kind), dict) \
                        and "capped_share_limit" not in solver[kind]:
                    solver[kind] = {**solver[kind], "capped_share_limit": 1.0}
            data = {**data, "solver": solver}
        return cls.model_validate(data)

    def write(self, path: str | Path) -> Path:
        """Write as TOML."""
        path = Path(path)
        path.write_text(tomli_w.dumps(self.model_dump()))
        return path

    def with_updates(self, updates: dict[str, dict[str, Any]]) -> RunConfig:
        """A copy with some keys changed (``{section: {key: value}}``, nested for the
        sub-tables: ``{"solver": {"shear": {"tolerance": 1e-5}}}``; earlier-layout keys read
        as in :func:`current_layout`), validated."""
        updates, earlier = current_layout(updates)
        try:
            return RunConfig.model_validate(_merged(self.model_dump(), updates))
        except InputError as error:
            raise _as_written(error, earlier) from None

    def changes_on_resume(self, started: RunConfig) -> dict[str, tuple[Any, Any]]:
        """The keys changed from ``started`` (the config the run was last checkpointed with)
        as ``{"section.key": (old, new)}``; an :class:`InputError` names the first key that
        may not change (:data:`CHANGEABLE_ON_RESUME`)."""
        old, new = flat_keys(started.model_dump()), flat_keys(self.model_dump())
        changed = {k: (old[k], new[k]) for k in new if old.get(k) != new[k]}
        for key, (before, after) in changed.items():
            if key not in CHANGEABLE_ON_RESUME:
                raise InputError(key, after, (
                    f"{before!r}, the value the run was started with: it made what the run has "
                    "done already, so it cannot change on resume (start a new run, or "
                    "`grainlab resume RUN --restart` to start this one over); keys that can "
                    "change: " + ", ".join(CHANGEABLE_ON_RESUME)))
        return changed

    # -- what the config means ----------------------------------------------------------------
    def load_path(self) -> LoadPath:
        """The lab load path of the test (presets of :mod:`grainlab.lab.presets`), after an
        isotropic compaction to sigma0 (stage ``"compaction"``)."""
        t = self.test
        boundary = boundary_record(self.sample.boundary)
        if t.kind in PERIODIC_ONLY and not boundary.shears:
            raise InputError("sample.boundary", self.sample.boundary,
                             f"{quoted(shearing_names())} for test.kind = {t.kind!r}: "
                             f"{boundary.shear_refusal}")
        dimension = self.dimension
        compaction = renamed(isotropic_compression(p_final=t.sigma0, n_steps=1,
                                                    dimension=dimension).stages, "compaction")
        if t.kind == "compaction":
            return LoadPath("isotropic_compaction", dimension, compaction,
                            f"isotropic compaction to {t.sigma0:g} Pa")
        stages, name, what = kind_stages(t, dimension)
        return LoadPath(name, dimension, (*compaction, *stages),
                        f"isotropic compaction to {t.sigma0:g} Pa, then {what}")

    @property
    def dimension(self) -> int:
        """3, or 2 for a sample of discs (:mod:`grainlab.engine.planar`): the load path's."""
        return sample_shape(self.sample.shape).kind.dimension

    def check_solver(self, kinds=None) -> None:
        """Refuse a sample the solver cannot run, before anything is built (the kinds of
        ``sample.shape``) or once a file gave the particles (``kinds``, their shape kinds):
        a solver whose rolling resistance acts on some families of grains only
        (:attr:`~grainlab.lab.solver_registry.SolverRecord.rolling_families`; the
        soft-contact solver gives polyhedra none: their faces resist rolling) refuses it
        on the others, an :class:`InputError` naming its key
        (``solver.dem.rolling_friction``)."""
        record = solver_record(self.solver.method)
        if record.rolling_families is None:
            return
        key = f"solver.{record.settings_key}.{record.rolling_key}"
        rolling = getattr(getattr(self.solver, record.settings_key), record.rolling_key)
        for kind in kinds or (sample_shape(self.sample.shape).kind,):
            if kind.narrow_phase not in record.rolling_families and rolling > 0.0:
                raise InputError(key, rolling, (
                    f"0 with {kind.plural} and solver.method = '{self.solver.method}' "
                    "(rolling resistance is a model for spheres and aggregates; the faces "
                    "of polyhedra resist rolling)"))

    def settings(self) -> DiscreteTestSettings:
        """The discrete test's numerical settings: each field of
        :class:`~grainlab.lab.discrete_test.DiscreteTestSettings` from the key of its name
        (:data:`SETTINGS_TABLES`), a table as its frozen settings object, the solvers' own
        tables as ``solver_settings``; ``solver.dt = 0`` is None (automatic)."""
        values = {}
        for name, table in SETTINGS_TABLES.items():
            value = getattr(getattr(self, table), name)
            values[name] = value.frozen() if isinstance(value, ConfigSection) else value
        values["dt"] = values["dt"] or None
        return DiscreteTestSettings(**values)


def _settings_tables() -> dict[str, str]:
    """``{field of DiscreteTestSettings: the table of RunConfig holding its key}``, looked for
    in [solver], then [output], then [test] (a key, or a property such as
    ``solver_settings``); a field without a key is left out (it keeps its default)."""
    tables = {"solver": SolverConfig, "output": OutputConfig, "test": TestConfig}
    found = {}
    for field in fields(DiscreteTestSettings):
        for table, model in tables.items():
            if field.name in model.model_fields \
                    or isinstance(getattr(model, field.name, None), property):
                found[field.name] = table
                break
    return found


def with_registered_solvers() -> tuple[type[ConfigSection], type[RunConfig]]:
    """``(SolverConfig, RunConfig)`` remade for the solvers registered now: a solver added to
    :data:`~grainlab.lab.solver_registry.SOLVERS` after this module was imported (a test's)
    has its ``method`` and table in them."""
    solver = solver_config()
    return solver, create_model("RunConfig", __base__=RunConfig, __module__=__name__,
                                __doc__=RunConfig.__doc__,
                                solver=(solver, Field(default_factory=solver)))


SETTINGS_TABLES = _settings_tables()
"""Where :meth:`RunConfig.settings` reads each field of
:class:`~grainlab.lab.discrete_test.DiscreteTestSettings` (the solver's seed, not the
sample's)."""


def current_layout(data: Any) -> tuple[Any, dict[str, str]]:
    """``data`` (a config as plain data) with the keys of the earlier layout
    (:data:`EARLIER_SOLVER_KEYS`: per-stage keys flat in ``[solver]``) moved into
    ``[solver.compaction]`` and ``[solver.shear]``, and ``{new key: earlier key}`` of those
    moved (``"solver.shear.friction": "solver.friction"``). ``data`` is not changed. A key
    given in both layouts raises :class:`InputError` naming it.

    >>> data, moved = current_layout({"solver": {"friction": 0.5, "compaction_tolerance": 1e-5}})
    >>> data
    {'solver': {'shear': {'friction': 0.5}, 'compaction': {'tolerance': 1e-05}}}
    >>> moved["solver.shear.friction"]
    'solver.friction'
    """
    if not isinstance(data, dict) or not isinstance(data.get("solver"), dict):
        return data, {}
    solver = dict(data["solver"])
    moved: dict[str, str] = {}
    for old, new in EARLIER_SOLVER_KEYS.items():
        if old not in solver:
            continue
        kind, key = new.split(".")
        table = solver.get(kind, {})
        if not isinstance(table, dict):
            continue  # pydantic names the table that is not one
        if key in table:
            raise InputError(f"solver.{old}", solver[old], (
                f"one key, not both: solver.{old} is the earlier name of solver.{new} (given "
                f"too, = {table[key]!r}); keep solver.{new} only"))
        solver[kind] = {**table, key: solver.pop(old)}
        moved[f"solver.{new}"] = f"solver.{old}"
    return {**data, "solver": solver}, moved


def _as_written(error: InputError, earlier: dict[str, str]) -> InputError:
    """``error`` naming the key as the data spelt it (an earlier-layout key:
    :func:`current_layout`)."""
    if error.field not in earlier:
        return error
    return InputError(earlier[error.field], error.value,
                      f"{error.allowed} (read as {error.field})")


def _merged(data: dict[str, Any], updates: dict[str, Any]) -> dict[str, Any]:
    """``data`` with ``updates`` written over it, table by table (nested tables too)."""
    out = dict(data)
    for key, value in updates.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merged(out[key], value)
        else:
            out[key] = value
    return out


def flat_keys(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"solver.shear.tolerance": 1e-5, ...}`` of nested tables."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, dict):
            out.update(flat_keys(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def parse_assignments(assignments: list[str]) -> dict[str, dict[str, Any]]:
    """``["solver.shear.tolerance=1e-5", "test.eps_q_max=0.3"]`` as ``{section: {key: value}}``
    (nested for sub-tables), each value read as a TOML value (a bare word as text).

    >>> parse_assignments(["solver.shear.tolerance=1e-5", "solver.sweep=serial"])
    {'solver': {'shear': {'tolerance': 1e-05}, 'sweep': 'serial'}}
    """
    out: dict[str, dict[str, Any]] = {}
    for text in assignments:
        key, sep, value = text.partition("=")
        names = [name.strip() for name in key.split(".")]
        if not sep or len(names) < 2 or not all(names):
            raise InputError("--set", text, "section.key=value, e.g. "
                                            "solver.shear.tolerance=1e-5")
        try:
            parsed = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            parsed = value.strip()
        table: dict[str, Any] = out
        for name in names[:-1]:
            table = table.setdefault(name, {})
            if not isinstance(table, dict):
                raise InputError("--set", text, f"a key of a table ({name} was given a value)")
        table[names[-1]] = parsed
    return out


def _input_error(error: ValidationError) -> InputError:
    """The first error, naming the key (``section.key``) and all that the key allows."""
    first = error.errors()[0]
    field = ".".join(str(p) for p in first["loc"]) or "config"
    kind = first["type"]
    if kind == "extra_forbidden":
        return InputError(field, first.get("input"), "no such key: see the keys of "
                          "grainlab.lab.run_config (or `grainlab triaxial --help`)")
    cause = first.get("ctx", {}).get("error")
    if isinstance(cause, InputError):  # a validator that names what it allows
        return InputError(field, first.get("input"), cause.allowed)
    info = _field_info(first["loc"])
    if info is None:
        return InputError(field, first.get("input"), first["msg"].lower())
    allowed = _allowed_text(info, unit_of(field), field)
    if isinstance(first.get("input"), bool) and info.annotation is not bool:
        allowed += " (true and false are not numbers)"
    return InputError(field, first.get("input"), allowed)


def _field_info(loc: tuple) -> Any:
    """The pydantic field at ``loc`` (section, key, or section, table, key) of
    :class:`RunConfig`, or None."""
    model: Any = RunConfig
    info = None
    for name in loc:
        fields = getattr(model, "model_fields", None)
        if not isinstance(name, str) or fields is None or name not in fields:
            return None
        info = fields[name]
        model = info.annotation
    return info


def _number(value: Any) -> str:
    return str(value) if isinstance(value, int) else f"{value:g}"


def _allowed_text(info: Any, unit: str = "", field: str = "") -> str:
    """What a config field allows, in words: ``"a finite number in (0, 1] (in Pa)"``,
    ``"an integer >= 1"``, ``"one of 'coloured', 'serial'"``, ``"a table [test] of the
    keys kind, sigma0, ..."`` for a table named ``field`` (plus the field's description)."""
    annotation = info.annotation
    if hasattr(annotation, "model_fields"):
        text = (f"a table [{field}] of the keys {', '.join(annotation.model_fields)} (each "
                "optional)")
    elif get_origin(annotation) is Literal:
        text = "one of " + ", ".join(repr(a) for a in get_args(annotation))
    elif annotation is bool:
        text = "true or false"
    else:
        text = "an integer" if annotation is int else "a finite number"
        low = high = None
        for item in info.metadata:
            for name, side in (("gt", "("), ("ge", "["), ("lt", ")"), ("le", "]")):
                bound = getattr(item, name, None)
                if bound is not None and side in "([":
                    low = (side, bound)
                elif bound is not None:
                    high = (side, bound)
        if low and high:
            text += f" in {low[0]}{_number(low[1])}, {_number(high[1])}{high[0]}"
        elif low:
            text += f" {'>' if low[0] == '(' else '>='} {_number(low[1])}"
        elif high:
            text += f" {'<' if high[0] == ')' else '<='} {_number(high[1])}"
    if unit:
        text += f" (in {unit})"
    if info.description:
        text += f" ({info.description})"
    return text
