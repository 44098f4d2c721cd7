"""The solver registry (grainlab.lab.solver_registry): the config's solver names are the
registry's; what the lab pushes into a solver and keeps in checkpoints follows its record; an
explicit step carries no convergence record, an iterative one does, and only steps that
really end unconverged count as such (grainlab.engine.simulation); a solver with settings of
its own (registered here by a fixture) gets its config table from its settings dataclass,
validated by the bounds its fields declare, and its settings reach the solver it builds."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import get_args

import pytest

from grainlab.cli.run_options import option_named, options_of
from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.convergence import EXPLICIT_COLUMNS, Convergence, convergence_columns
from grainlab.engine.dem.soft_contact import SoftContactStep
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.lab import run_config, solver_registry
from grainlab.lab.discrete_test import DiscreteTest, DiscreteTestSettings
from grainlab.lab.option_scope import inert_settings
from grainlab.lab.run_config import RunConfig, SolverConfig
from grainlab.lab.setting_bounds import bounded
from grainlab.lab.soft_contact_settings import SoftContactSettings
from grainlab.lab.solver_registry import (
    SOLVER_NAMES,
    SolverRecord,
    solver_label,
    solver_record,
)
from grainlab.lab.stage_numerics import SHEAR
from grainlab.prep.loose_sample import loose_sample


def test_the_config_offers_the_registered_solvers_and_refuses_others():
    assert get_args(SolverConfig.model_fields["method"].annotation) == SOLVER_NAMES
    assert SOLVER_NAMES[0] == DiscreteTestSettings().method  # the default is the first
    with pytest.raises(InputError, match="method"):
        DiscreteTestSettings(method="lattice")


def test_stage_settings_reach_only_a_solver_that_reads_them():
    law = SoftContactLaw.linear(1e5)
    explicit = SoftContactStep(law, dt=1e-5, friction=0.0)
    iterative = ContactDynamicsStep(dt=1e-5, friction=0.0)
    for record, solver in ((solver_record("dem"), explicit), (solver_record("cd"), iterative)):
        record.set_stage(solver, SHEAR, recovery_speed=0.1)
        assert solver.friction == SHEAR.friction
        fields = record.checkpoint_fields(solver)
        if record.iterative:
            assert fields == {"max_iterations": SHEAR.max_iterations,
                              "overlap_recovery": SHEAR.overlap_recovery,
                              "overlap_recovery_speed": 0.1, "tolerance": SHEAR.tolerance}
        else:  # an explicit solver has no tolerance, no sweep cap to set or keep
            assert fields == {}
            assert not hasattr(solver, "tolerance") and not hasattr(solver, "max_iterations")


def _pair(gap: float):
    library = ShapeLibrary.from_spheres([1e-3])
    state = BodyState.from_library(library, [0, 0], [[0.0, 0.0, 0.0], [2e-3 + gap, 0.0, 0.0]],
                                   density=2600.0)
    state.velocities[0] = [0.01, 0.0, 0.0]
    state.velocities[1] = [-0.01, 0.0, 0.0]
    return library, state


def test_an_explicit_step_has_no_convergence_record_and_its_columns_read_one_evaluation():
    library, state = _pair(-1e-6)
    report = SoftContactStep(SoftContactLaw.linear(1e5), dt=1e-6, friction=0.0).step(
        state, library)
    assert report.n_contacts == 1 and report.convergence is None
    assert convergence_columns(report.convergence) == EXPLICIT_COLUMNS


def test_an_iterative_step_reports_its_sweeps_and_a_converged_head_on_contact():
    """Two frictionless spheres closing head-on at 0.02 m/s, 1 nm apart: the step (theta =
    1) lets them close the gap g exactly, so each ends at g / (2 h) towards the other,
    found within the tolerance."""
    gap, dt = 1e-9, 1e-6
    library, state = _pair(gap)
    solver = ContactDynamicsStep(dt=dt, friction=0.0, theta=1.0, tolerance=1e-10,
                                 max_iterations=200)
    report = solver.step(state, library)
    convergence = report.convergence
    assert isinstance(convergence, Convergence) and convergence.converged
    assert convergence.iterations >= 1
    columns = convergence_columns(convergence)
    assert columns["solver_iterations"] == float(report.iterations)
    assert columns["solver_converged"] == 1.0
    assert state.velocities[:, 0] == pytest.approx([gap / (2 * dt), -gap / (2 * dt)],
                                                   rel=1e-6)


def test_options_of_one_solver_are_refused_with_the_other():
    cd = RunConfig.model_validate({"solver": {"method": "cd"}})
    dem = RunConfig.model_validate({"solver": {"method": "dem"}})
    nlgs = ["solver.sweep", "solver.shear.max_iterations", "output.problems_every"]
    soft = ["solver.dem.kappa", "solver.dem.restitution"]
    assert list(inert_settings(cd, nlgs + soft)) == soft
    assert list(inert_settings(dem, nlgs + soft)) == nlgs
    assert "does not use" in inert_settings(dem, ["solver.sweep"])["solver.sweep"]


def test_the_solver_option_offers_every_registered_solver():
    help_text = option_named("compaction", "solver").help
    for name, record in solver_registry.SOLVERS.items():
        assert f"{name} ({record.help})" in help_text
    soft = {option.typed for option in options_of("compaction")
            if option.key and option.key.startswith("solver.dem.")}
    assert soft == {"--law", "--kappa", "--young-modulus", "--restitution"}


def test_a_solver_in_words():
    assert solver_label({"method": "cd"}) == "contact dynamics (cd)"
    assert solver_label({"method": "dem", "dem": {"law": "linear", "kappa": 1e3}}) == \
        "soft-contact DEM (dem): linear, kappa = 1000"
    assert solver_record("dem").substeps(SoftContactStep(SoftContactLaw.linear(1e5),
                                                          dt=1e-5)) == 0
    assert solver_record("cd").substeps(ContactDynamicsStep(dt=1e-5)) is None
    assert math.isnan(solver_record("cd").row_fields(ContactDynamicsStep(dt=1e-5))[
        "velocity_zigzag"])


@dataclass(frozen=True)
class SpringSettings:
    """The settings of a test solver: linear springs of a given stiffness."""

    normal_stiffness: float = bounded(2e5, gt=0, unit="N/m")
    restitution: float = bounded(0.5, gt=0, le=1)
    rigid_walls: bool = bounded(False)


def _build_springs(settings, sample, confining, gyroscopic):
    own = settings.springs
    law = SoftContactLaw.linear(own.normal_stiffness, restitution=own.restitution,
                                rigid_walls=own.rigid_walls)
    return SoftContactStep(law, dt=settings.dt or 1.0,
                           friction=settings.compaction.friction), law


SPRINGS = SolverRecord(
    name="springs", title="fixed springs", words="fixed springs", build=_build_springs,
    settings_key="springs", settings_type=SpringSettings, deformable=True,
    explicit_substeps=True, own_keys=("solver.springs.",),
    keys_words="the fixed springs (--solver springs)", runs_words="solver.method = 'springs'")


@pytest.fixture
def springs_registered(monkeypatch):
    """The registry with the solver ``springs`` added, and the config models remade from it
    (they are made from the registry when :mod:`grainlab.lab.run_config` is imported)."""
    monkeypatch.setitem(solver_registry.SOLVERS, SPRINGS.name, SPRINGS)
    solver, run = run_config.with_registered_solvers()
    monkeypatch.setattr(run_config, "SolverConfig", solver)
    monkeypatch.setattr(run_config, "RunConfig", run)
    return run


def test_a_registered_solver_gets_a_table_made_from_its_settings(springs_registered):
    config = springs_registered.model_validate(
        {"solver": {"method": "springs", "springs": {"normal_stiffness": 3e5,
                                                     "rigid_walls": True}}})
    settings = config.settings()
    assert settings.springs == SpringSettings(normal_stiffness=3e5, rigid_walls=True)
    assert settings.dem == SoftContactSettings()  # the other solver's defaults
    assert springs_registered().settings().springs == SpringSettings()
    again = config.with_updates({"solver": {"springs": {"restitution": 0.8}}})
    assert again.settings().springs.restitution == 0.8
    assert again.settings().springs.normal_stiffness == 3e5


@pytest.mark.parametrize(("key", "value", "allowed"), [
    ("normal_stiffness", 0.0, "> 0 (in N/m)"), ("normal_stiffness", True, "not numbers"),
    ("restitution", 1.5, "in (0, 1]"), ("rigid_walls", 1, "true or false"),
    ("stiffness", 1e5, "no such key"),
])
def test_a_registered_solvers_table_refuses_what_its_fields_do_not_allow(
        springs_registered, key, value, allowed):
    with pytest.raises(InputError) as caught:
        springs_registered.model_validate({"solver": {"springs": {key: value}}})
    assert caught.value.field == f"solver.springs.{key}"
    assert allowed in caught.value.allowed


def test_a_registered_solvers_settings_reach_the_solver_it_builds(springs_registered):
    config = springs_registered.model_validate(
        {"sample": {"n_particles": 20}, "test": {"kind": "compaction"},
         "solver": {"method": "springs", "springs": {"normal_stiffness": 3e5,
                                                     "restitution": 0.7}}})
    test = DiscreteTest(loose_sample(n_particles=20, seed=1), config.load_path(),
                        config.settings())
    assert test.solver_record is SPRINGS and isinstance(test.solver, SoftContactStep)
    assert test.solver.law.normal_stiffness == 3e5
    assert test.solver.law.restitution == pytest.approx(0.7)
    # its keys act with it only; those of the soft-contact law do not
    assert list(inert_settings(config, ["solver.springs.restitution", "solver.dem.kappa"])) \
        == ["solver.dem.kappa"]
    dem = config.with_updates({"solver": {"method": "dem"}})
    assert list(inert_settings(dem, ["solver.springs.restitution"])) \
        == ["solver.springs.restitution"]


def test_run_settings_refuse_settings_of_no_solver_or_of_the_wrong_type():
    with pytest.raises(InputError, match=r"solver_settings\['lattice'\]"):
        DiscreteTestSettings(solver_settings={"lattice": SoftContactSettings()})
    with pytest.raises(InputError, match=r"solver_settings\['dem'\].*SoftContactSettings"):
        DiscreteTestSettings(solver_settings={"dem": {"kappa": 1e3}})
    given = DiscreteTestSettings(solver_settings={"dem": SoftContactSettings(kappa=1e3)})
    assert given.dem.kappa == 1e3 and given.to_dict()["dem"]["kappa"] == 1e3
