"""The boundary registry (:mod:`grainlab.lab.boundary_registry`): every registered boundary
compacts a sample through the lab and comes back from its checkpoint as itself, with the
friction its walls had; an unknown name is refused naming the key, the value and the names
allowed; the config and the CLI offer exactly the registered names."""

from __future__ import annotations

import re
from typing import get_args

import h5py
import numpy as np
import pytest

from grainlab.engine.boundaries.boundary import FixedPlanes
from grainlab.errors import InputError
from grainlab.lab.boundary_registry import (
    BOUNDARIES,
    BOUNDARY_NAMES,
    DEFAULT_BOUNDARY,
    boundary_help,
    boundary_record,
    boundary_record_of,
)
from grainlab.lab.discrete_run import resume_run, start_run
from grainlab.lab.run_checkpoint import CHECKPOINT
from grainlab.lab.run_config import RunConfig, SampleConfig

WALL_FRICTION = 0.3


def tiny_compaction(boundary: str) -> RunConfig:
    """A compaction of 80 nearly equal spheres (thick enough for a periodic cell), a
    checkpoint every 10 steps."""
    return RunConfig.model_validate({
        "sample": {"n_particles": 80, "size_ratio": 1.2, "seed": 2, "boundary": boundary,
                   "wall_friction": WALL_FRICTION},
        "test": {"kind": "compaction"},
        "solver": {"sweep": "serial"},
        "output": {"record_every": 5, "checkpoint_every": 10},
    })


def friction_seen(boundary) -> np.ndarray:
    """The Coulomb coefficients of the walls as the contact problem sees them."""
    return boundary.constraints(1e-4, 0.5).wall_friction


@pytest.mark.parametrize("name", BOUNDARY_NAMES)
def test_every_boundary_compacts_and_resumes_as_itself(tmp_path, name):
    record = boundary_record(name)
    folder = tmp_path / name
    run = start_run(folder, tiny_compaction(name))
    boundary = run.test.sample.boundary
    assert type(boundary) is record.engine_class
    assert run.test.boundary_record is record
    assert isinstance(run.test.boundary, record.stage_driver)
    assert run.test.sample.periodic == record.periodic == boundary.periodic
    start_volume = boundary.volume
    run.run(max_steps=12)  # a checkpoint at step 10
    assert boundary.volume < start_volume  # the compaction closed in on the sample
    with h5py.File(folder / CHECKPOINT, "r") as handle:
        assert handle["box"].attrs["kind"] == record.checkpoint_kind
    friction = friction_seen(boundary)
    # the walls (if any) have the friction the config gave, as the boundary applies it
    np.testing.assert_array_equal(
        friction, friction_seen(record.around(np.ones(3), WALL_FRICTION, 1.0)))
    if not record.periodic:
        assert friction.max() == WALL_FRICTION

    resumed = resume_run(folder)
    again = resumed.test.sample.boundary
    assert type(again) is type(boundary)
    assert resumed.test.boundary_record is record
    assert isinstance(resumed.test.boundary, record.stage_driver)
    np.testing.assert_array_equal(friction_seen(again), friction)
    steps = resumed.test.simulation.step_index
    resumed.run(max_steps=2)
    assert resumed.test.simulation.step_index == steps + 2  # it goes on compacting
    assert again.volume < start_volume


def test_an_unknown_boundary_is_refused_naming_the_key_the_value_and_the_names():
    with pytest.raises(InputError) as error:
        boundary_record("cylinder")
    assert error.value.field == "sample.boundary" and error.value.value == "cylinder"
    assert all(f'"{name}"' in error.value.allowed for name in BOUNDARY_NAMES)
    with pytest.raises(InputError) as error:
        RunConfig.model_validate({"sample": {"boundary": "cylinder"}})
    assert error.value.field == "sample.boundary" and error.value.value == "cylinder"
    assert all(repr(name) in error.value.allowed for name in BOUNDARY_NAMES)


def test_an_unregistered_engine_boundary_is_refused_by_its_class():
    with pytest.raises(InputError) as error:
        boundary_record_of(FixedPlanes())
    assert error.value.value == "FixedPlanes"
    assert all(r.engine_class.__name__ in error.value.allowed for r in BOUNDARIES.values())


def test_the_config_and_the_cli_offer_exactly_the_registered_names():
    from grainlab.cli.run_options import BOUNDARY_HELP, RUN_OPTIONS

    assert get_args(SampleConfig.model_fields["boundary"].annotation) == BOUNDARY_NAMES
    assert SampleConfig().boundary == DEFAULT_BOUNDARY == BOUNDARY_NAMES[0]
    option = next(o for o in RUN_OPTIONS if o.name == "boundary")
    assert option.help == BOUNDARY_HELP == boundary_help()
    listed = re.findall(r"(?:: |, | or )([a-z_]+) \(", BOUNDARY_HELP)
    assert tuple(listed) == BOUNDARY_NAMES
    for record in BOUNDARIES.values():
        assert f"{record.name} ({record.words})" in BOUNDARY_HELP
