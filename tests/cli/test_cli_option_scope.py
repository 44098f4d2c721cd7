"""Every command-line option of a discrete run acts or is refused: walked against every test,
solver, boundary and contact law (:mod:`grainlab.lab.option_scope`).

An option *acts* when it changes what the run reads, measured here apart from the refusal's
own table: the load path (:meth:`~grainlab.lab.run_config.RunConfig.load_path`, the stages a
boundary runs), the sample made (positions, masses, sizes), the soft-contact law the engine
gets (:meth:`~grainlab.lab.soft_contact_settings.SoftContactSettings.law_at`), the numerics
of the stages the path has (a path without a strain-controlled stage reads no loading
numerics), and, by solver and boundary, the settings each documents reading (contact
dynamics: NLGS; soft-contact DEM: no NLGS; walls: the wall servo). An option refused must
change none of it; one accepted must change some of it.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

from grainlab.cli.run_input import asked_config
from grainlab.cli.run_options import options_of
from grainlab.errors import InputError
from grainlab.lab.cell_stages import cell_stages
from grainlab.lab.discrete_run import build_sample
from grainlab.lab.run_config import TEST_KINDS
from grainlab.lab.wall_stages import wall_stages

VALUES = {
    "shape": "aggregate", "n": 25, "d_min": 2e-3, "size_ratio": 1.5, "eta": 0.2,
    "faces": 20, "templates": 2, "density": 2000.0, "seed": 7, "sigma0": 2e4, "eps_q": 0.2,
    "axial_strain": 0.02, "unload_strain": 0.005, "mu": 0.3, "inertia": 5e-4, "dt": 1e-6,
    "tolerance": 1e-5, "sweep": "serial", "correction": "none", "max_iterations": 500,
    "record_every": 7,
    "snapshot_every": 7, "checkpoint_every": 7, "vtk_every": 7, "kappa": 2e3,
    "young_modulus": 1e9, "restitution": 0.3, "height_ratio": 1.5, "b": 0.3, "gamma": 0.2,
    "q_ratio": 0.4, "circle_points": 12, "amplitude": 0.02, "cycles": 3, "law": "linear",
    "solver": "dem", "boundary": "periodic",
}
"""A value other than the default of each option walked."""

NOT_WALKED = {"preparation", "skeleton_file", "particle_file", "sizes", "fine_fraction"}
"""How the sample is made (files and deposition, which build_sample checks), and its two sizes
(half the walk's 20 particles large do not fit a loose box: tests/prep/test_loose_sizes.py
walks them on 60)."""

_OPTIONS = {option.name: (option.typed, option.key) for option in options_of("test")
            if option.key is not None}
"""Each option of ``grainlab test`` that sets a config key: (as typed, the key)."""

CD_ONLY = ("tolerance", "max_iterations", "overlap_recovery", "capped_share_limit",
           "time_step_growth")
BASES = [(solver, boundary, law) for solver in ("cd", "dem")
         for boundary in ("walls", "periodic")
         for law in ((None,) if solver == "cd" else ("linear", "hertz_mindlin"))]
_SAMPLES: dict[str, tuple] = {}


def _sample_made(config) -> tuple:
    key = repr(config.sample.model_dump())
    if key not in _SAMPLES:
        sample = build_sample(config)
        _SAMPLES[key] = (sample.state.positions.tobytes(), sample.state.masses.tobytes(),
                         sample.library.bounding_radius.tobytes(),
                         np.asarray(sample.library.kind).tobytes())
    return _SAMPLES[key]


def what_the_run_reads(config) -> dict:
    """The run's inputs as the module docstring measures them."""
    path = config.load_path()
    method, periodic = config.solver.method, config.sample.boundary == "periodic"
    stages = cell_stages(path, deformable=method == "dem") if periodic else wall_stages(path)
    settings = asdict(config.settings())
    settings.update(settings.pop("solver_settings"))  # each solver's own under its key
    if not any(stage.moving_axes for stage in stages):
        settings.pop("shear")  # no loading stage
    if method == "dem":
        for key in ("sweep", "correction", "theta", "warm_start_extrapolation"):
            settings.pop(key)
        for kind in ("compaction", "shear"):
            for key in CD_ONLY:
                settings.get(kind, {}).pop(key, None)
        settings["dem"] = asdict(config.solver.dem.settings().law_at(config.test.sigma0, 1.5e-3))
    else:
        settings.pop("dem")
    if periodic:
        settings.pop("wall_servo")
        settings.pop("wall_mass_factor")
        settings.get("dem", {}).pop("rigid_walls", None)
    elif settings["wall_servo"]:
        settings.pop("wall_mass_factor")
    return {"path": [stage.to_dict() for stage in path.stages], "settings": settings,
            "output": config.output.model_dump(), "sample": _sample_made(config)}


def _base(solver, boundary, law) -> dict:
    base = {"n": 20, "solver": solver, "boundary": boundary}
    if law is not None:
        base["law"] = law
    return base


def _walk(kind: str):
    """(base, option, refused error or None, reads without, reads with) for every option."""
    for solver, boundary, law in BASES:
        base = _base(solver, boundary, law)
        try:
            before = what_the_run_reads(asked_config(kind, None, base)[0])
        except InputError:  # the test itself cannot run here (a walls-only kind...)
            continue
        for option, value in VALUES.items():
            if option in base:
                continue
            options = {**base, option: value}
            try:
                config = asked_config(kind, None, options)[0]
            except InputError as error:
                without = {**options, option: None}
                yield base, option, error, before, what_the_run_reads(
                    asked_config(kind, None, without)[0])
                continue
            yield base, option, None, before, what_the_run_reads(config)


def test_every_option_is_walked():
    assert set(_OPTIONS) - NOT_WALKED == set(VALUES)


@pytest.mark.parametrize("kind", TEST_KINDS)
def test_every_option_changes_the_run_or_is_refused_by_name(kind):
    walked = 0
    for base, option, error, before, after in _walk(kind):
        walked += 1
        where = f"{kind} {base} {_OPTIONS[option][0]}"
        if error is not None:
            assert error.field == _OPTIONS[option][0], where  # named as typed
            assert "does nothing" in error.allowed, where
            assert after == before, f"{where}: refused, but it changes the run"
        else:
            assert after != before, f"{where}: accepted, but it changes nothing"
    assert walked > 0


@pytest.mark.parametrize(("options", "named"), [
    ({"law": "linear", "young_modulus": 1e9, "solver": "dem"}, "--young-modulus"),
    ({"kappa": 1e3, "restitution": 0.3}, "--kappa"),
    ({"solver": "dem", "sweep": "serial", "max_iterations": 5}, "--sweep"),
])
def test_the_options_that_did_nothing_are_refused(options, named):
    with pytest.raises(InputError) as caught:
        asked_config("triaxial", None, options)
    assert caught.value.field == named
    assert "does nothing" in str(caught.value)


def test_the_loading_numerics_asked_of_a_compaction_are_its_own():
    config, _ = asked_config("compaction", None, {"tolerance": 1e-5, "max_iterations": 300})
    assert config.solver.compaction.tolerance == 1e-5
    assert config.solver.compaction.max_iterations == 300


@pytest.mark.parametrize(("shape", "option"), [("aggregate", "eta"), ("polyhedron", "faces"),
                                               ("polyhedron", "templates")])
def test_a_shapes_own_parameter_changes_its_sample(shape, option):
    base = {"n": 20, "shape": shape, "templates": 3} if shape == "polyhedron" \
        else {"n": 20, "shape": shape}
    before = what_the_run_reads(asked_config("triaxial", None, base)[0])
    after = what_the_run_reads(asked_config("triaxial", None, {**base, option: VALUES[option]})[0])
    assert after["sample"] != before["sample"]


def test_a_config_key_that_does_nothing_is_noted_not_refused(tmp_path, capsys):
    path = tmp_path / "shared.toml"
    path.write_text("[solver.shear]\ninertia_number = 0.01\n")
    config, _ = asked_config("compaction", path, {})
    assert config.solver.shear.inertia_number == 0.01
    said = " ".join(capsys.readouterr().out.split())
    assert f"solver.shear.inertia_number = 0.01 (in {path}) does nothing here" in said
    with pytest.raises(InputError) as caught:  # given as an option, it is refused
        asked_config("compaction", path, {"inertia": 0.02})
    assert caught.value.field == "--inertia"
