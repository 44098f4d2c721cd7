"""Polyhedra in run folders: config validation naming the field, the polyhedron library
through a checkpoint (every array of the library), and the time-step length."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from grainlab.engine.state import ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import from_vertices
from grainlab.lab.discrete_run import read_checkpoint, start_run
from grainlab.lab.discrete_test import time_step_length
from grainlab.lab.run_config import RunConfig

TINY = {
    "sample": {"shape": "polyhedron", "n_faces": 20, "templates": 3, "n_particles": 12,
               "seed": 1},
    "test": {"kind": "triaxial", "eps_q_max": 0.01},
    "solver": {"compaction_inertia_number": 0.05, "inertia_number": 0.01, "sweep": "serial"},
    "output": {"record_every": 10, "checkpoint_every": 50},
}


@pytest.mark.parametrize(("sample", "field"), [
    ({"n_faces": 31}, "sample.n_faces"), ({"n_faces": 4}, "sample.n_faces"),
    ({"templates": -2}, "sample.templates"), ({"shape": "cube"}, "sample.shape"),
    ({"n_face": 30}, "sample.n_face"),
])
def test_bad_polyhedron_settings_name_the_field(sample, field):
    with pytest.raises(InputError) as error:
        RunConfig.model_validate({"sample": {"shape": "polyhedron", **sample}})
    assert error.value.field == field


def test_polyhedron_library_goes_through_a_checkpoint(tmp_path):
    config = RunConfig.model_validate(TINY)
    run = start_run(tmp_path / "run", config)
    library = run.test.sample.library
    assert library.n_shapes == 12 and library.vertices.shape[0] > 0
    saved = read_checkpoint(run.checkpoint())
    for f in dataclasses.fields(ShapeLibrary):
        np.testing.assert_array_equal(getattr(saved["library"], f.name),
                                      getattr(library, f.name), err_msg=f.name)
    np.testing.assert_array_equal(saved["state"].orientations,
                                  run.test.sample.state.orientations)
    assert saved["description"]["n_faces"] == 20 and saved["description"]["templates"] == 3
    assert RunConfig.read(tmp_path / "run" / "config.toml").sample.n_faces == 20


def test_time_step_length_is_the_smallest_inscribed_or_member_diameter():
    cube = from_vertices([[x, y, z] for x in (0, 2) for y in (0, 2) for z in (0, 2)])
    library = ShapeLibrary.from_polyhedra([cube]).concatenate(
        ShapeLibrary.from_spheres([3.0]))
    assert time_step_length(library) == pytest.approx(2.0)  # the cube's inscribed sphere
    assert time_step_length(ShapeLibrary.from_spheres([0.2, 0.5])) == pytest.approx(0.4)
    assert time_step_length(library.concatenate(ShapeLibrary.from_spheres([0.25]))) \
        == pytest.approx(0.5)
