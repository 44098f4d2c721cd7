"""Which settings of a run act, given its solver, contact law, boundary, test and sample: a
setting that would do nothing is refused, not kept silently.

A run reads only part of its config. Contact dynamics (``solver.method = "cd"``) has rigid
grains: the ``[solver.dem]`` table (stiffness, law, restitution, damping) does nothing. The
soft-contact solver (``"dem"``) is explicit: it has no NLGS sweeps, so ``solver.sweep``,
``theta``, ``warm_start_extrapolation``, ``correction``, the stage tables' ``tolerance``,
``max_iterations``, ``overlap_recovery``, ``capped_share_limit`` and ``time_step_growth``, and
``output.problems_every`` (the contact problems of contact-dynamics steps) do nothing. A linear
law reads ``normal_stiffness`` (or ``kappa``), Hertz-Mindlin ``young_modulus`` and
``poisson_ratio`` (or ``kappa``). The periodic cell has no walls (``solver.wall_servo``,
``solver.wall_mass_factor``, ``sample.wall_friction``, ``solver.dem.rigid_walls``), and
``wall_mass_factor`` acts only on walls with momentum (``wall_servo = false``). Each test
reads its own targets (:data:`TEST_TARGETS`); a path with no strain-controlled stage (a
compaction, the stress-driven circular path) reads no ``[solver.shear]``: its stages take
``[solver.compaction]``'s numerics, friction included. Each particle shape reads its own
parameters, and a sample read from a file takes its sizes (a skeleton) or everything but its
density and wall friction (a particle file) from the file.

:func:`inert_settings` lists, for the keys asked about, those that do nothing and why;
:func:`refuse_inert` refuses the first. The command line refuses the options given that do
nothing, and notes the keys of a ``--config`` file that differ from their defaults and do
nothing (a file may serve several commands).

>>> from grainlab.lab.run_config import RunConfig
>>> config = RunConfig.model_validate({"solver": {"dem": {"kappa": 1e3}}})
>>> list(inert_settings(config, ["solver.dem.kappa", "test.sigma0"]))
['solver.dem.kappa']
"""

from __future__ import annotations

from typing import Any

from grainlab.errors import InputError
from grainlab.lab.boundary_registry import boundary_record
from grainlab.lab.solver_registry import NLGS_KEYS, solver_record, wall_keys
from grainlab.prep.sample_shapes import SAMPLE_SHAPES

CD_ONLY = NLGS_KEYS
"""The keys only contact dynamics reads (module docstring; its record's ``own_keys``,
:mod:`grainlab.lab.solver_registry`)."""

WALLS_ONLY = ("solver.wall_servo", "solver.wall_mass_factor", "sample.wall_friction",
              *wall_keys())
"""The keys only a box of walls reads (a solver's own among them: its record's
``wall_keys``)."""

TEST_TARGETS = {
    "test.eps_q_max": ("triaxial", "extension", "true_triaxial", "cubical"),
    "test.axial_strain": ("oedometer",), "test.unload_strain": ("oedometer",),
    "test.b": ("true_triaxial", "cubical"), "test.gamma_max": ("simple_shear",),
    "test.q_ratio": ("circular",), "test.circle_points": ("circular",),
    "test.amplitude": ("cyclic_shear",), "test.n_cycles": ("cyclic_shear",),
}
"""Each test target's key and the tests that read it."""

SHAPE_KEYS = {"sample.eta": "eta", "sample.n_faces": "n_faces",
              "sample.templates": "templates"}
"""The shape parameters' keys (:data:`~grainlab.prep.sample_shapes.SAMPLE_SHAPES`)."""

FROM_SKELETON = ("sample.n_particles", "sample.d_min", "sample.size_ratio",
                 "sample.height_ratio", "sample.packing_fraction", "sample.sizes",
                 "sample.fine_fraction")
"""The keys a skeleton file gives (the particles' number, sizes and box)."""

FROM_PARTICLE_FILE = (*FROM_SKELETON, "sample.shape", "sample.seed", *SHAPE_KEYS)
"""The keys a particle file gives (all but the density and the wall friction)."""


def _solver_reason(config: Any, key: str) -> str:
    """Why ``key`` does nothing with the config's solver and law ("" when it acts): its
    record's words (:meth:`~grainlab.lab.solver_registry.SolverRecord.inert_reason`)."""
    return solver_record(config.solver.method).inert_reason(config, key)


def _boundary_reason(config: Any, key: str) -> str:
    """Why ``key`` does nothing with the config's boundary ("" when it acts)."""
    record = boundary_record(config.sample.boundary)
    if record.wallless_words and key in WALLS_ONLY:
        return (f"it sets the walls of a box; --boundary {record.name} (sample.boundary = "
                f"'{record.name}') has none: {record.wallless_words}")
    if key == "solver.wall_mass_factor" and config.solver.wall_servo:
        return ("it sets the mass of walls with momentum, which solver.wall_servo = true "
                "(the default: overdamped servo walls, no mass) does not use")
    return ""


def _test_reason(config: Any, key: str) -> str:
    """Why ``key`` does nothing in the config's test ("" when it acts)."""
    kind = config.test.kind
    if key in TEST_TARGETS and kind not in TEST_TARGETS[key]:
        return (f"it is a target of {' and '.join(TEST_TARGETS[key])}, not of "
                f"test.kind = {kind!r}")
    if key.startswith("solver.shear.") and not _has_loading(config):
        return (f"it sets the stages with a strain-controlled axis; test.kind = {kind!r} has "
                "none: every stage of its path is stress-driven and takes "
                "[solver.compaction]'s numerics (friction: solver.compaction.friction, "
                "in --config)")
    return ""


def _has_loading(config: Any) -> bool:
    """Whether the path of ``config`` has a stage with a strain-controlled axis that moves
    (the stages :data:`~grainlab.lab.stage_numerics.SHEAR`'s table sets); True for a path
    its boundary refuses (judged there)."""
    try:
        path = config.load_path()
        stages = boundary_record(config.sample.boundary).stages(path, True)
    except InputError:
        return True
    return any(stage.moving_axes for stage in stages)


def _sample_reason(config: Any, key: str) -> str:
    """Why ``key`` does nothing for the config's sample ("" when it acts)."""
    s = config.sample
    if s.preparation == "file" and s.particle_file and key in FROM_PARTICLE_FILE:
        return ("the particle file (sample.particle_file, --particle-file) gives the "
                "particles' shapes, sizes and places")
    if s.preparation == "file" and s.skeleton_file and key in FROM_SKELETON:
        return ("the skeleton file (sample.skeleton_file, --skeleton-file) gives the "
                "particles' number, sizes and box")
    if key in ("sample.sizes", "sample.fine_fraction") and s.preparation == "deposition":
        return ("a deposition draws its sizes uniform by volume: two sizes (sample.sizes = "
                "'binary') are for a loose sample (sample.preparation = 'loose')")
    if key == "sample.fine_fraction" and s.sizes != "binary":
        return "it is the fine share of two sizes (sample.sizes = 'binary', --sizes binary)"
    parameters = SAMPLE_SHAPES[s.shape].parameters if s.shape in SAMPLE_SHAPES else ()
    if key in SHAPE_KEYS and SHAPE_KEYS[key] not in parameters:
        return (f"it is a parameter of {_shape_of(SHAPE_KEYS[key])} particles, not of "
                f"sample.shape = {s.shape!r}")
    return ""


def _shape_of(parameter: str) -> str:
    return " and ".join(name for name, shape in SAMPLE_SHAPES.items()
                        if parameter in shape.parameters)


def inert_settings(config: Any, keys) -> dict[str, str]:
    """``{key: why it does nothing}`` for those of ``keys`` (``"solver.dem.kappa"``...) that
    the run of ``config`` (a :class:`~grainlab.lab.run_config.RunConfig`) does not read
    (module docstring), in the order given."""
    out = {}
    for key in keys:
        for reason in (_solver_reason, _boundary_reason, _test_reason, _sample_reason):
            why = reason(config, key)
            if why:
                out[key] = why
                break
    return out


def refuse_inert(config: Any, keys) -> None:
    """An :class:`InputError` naming the first of ``keys`` that does nothing in the run of
    ``config`` (:func:`inert_settings`), its value and why."""
    for key, why in inert_settings(config, keys).items():
        value: Any = config
        for name in key.split("."):
            value = getattr(value, name)
        raise InputError(key, value, f"not given: it does nothing here ({why})")
