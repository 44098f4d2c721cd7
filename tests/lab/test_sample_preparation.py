"""``[sample] preparation``: loose, deposited, or read from a skeleton file; a tiny run
starts from a deposited sample; bad values name the key."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.lab.discrete_run import build_sample, start_run
from grainlab.lab.run_config import RunConfig
from grainlab.prep.sphere_skeleton import SphereSkeleton, write_skeleton

TINY = {
    "sample": {"n_particles": 30, "seed": 3, "preparation": "deposition"},
    "test": {"kind": "compaction"},
    "solver": {"sweep": "serial", "max_stage_steps": 10, "at_max_stage_steps": "stop"},
    "output": {"record_every": 5, "checkpoint_every": 0, "snapshot_every": 0},
}


def config(**sample) -> RunConfig:
    return RunConfig.model_validate(TINY).with_updates({"sample": sample})


def test_loose_stays_the_default():
    assert RunConfig.model_validate({}).sample.preparation == "loose"
    loose = build_sample(RunConfig.model_validate({"sample": {"n_particles": 30}}))
    assert "preparation" not in loose.description


def test_a_run_starts_from_a_deposited_sample(tmp_path):
    run = start_run(tmp_path / "run", config())
    sample = run.test.sample
    assert sample.description["preparation"] == "deposition"
    # the walls at the packing: floor, sides at the deposition's box, the top trimmed
    lower, upper = sample.box.coordinates[::2], sample.box.coordinates[1::2]
    top = np.max(sample.state.positions[:, 2] + sample.library.bounding_radius)
    assert lower.tolist() == [0.0, 0.0, 0.0] and upper[2] == top
    assert sample.solid_volume / np.prod(upper - lower) == pytest.approx(
        sample.description["skeleton_packing_fraction"])
    result = run.run(max_steps=10)
    assert len(result.table) >= 2 and np.all(np.isfinite(result.table["p"]))


def test_a_skeleton_file_gives_the_sample_of_its_spheres(tmp_path):
    deposited = build_sample(config(shape="aggregate", eta=0.5))
    skeleton = build_sample(config()).state.positions
    assert np.array_equal(deposited.state.positions, skeleton)
    lower, upper = deposited.box.coordinates[::2], deposited.box.coordinates[1::2]
    path = write_skeleton(SphereSkeleton(skeleton, deposited.library.bounding_radius,
                                         lower, upper), tmp_path / "spheres.npz")
    read = build_sample(config(shape="aggregate", eta=0.5, preparation="file",
                               skeleton_file=str(path)))
    assert np.array_equal(read.state.positions, deposited.state.positions)
    assert np.array_equal(read.state.orientations, deposited.state.orientations)
    assert read.description["preparation"] == "file"


@pytest.mark.parametrize(("sample", "field"), [
    ({"preparation": "poured"}, "sample.preparation"),
    ({"boundary": "periodic"}, "sample.preparation"),
    ({"preparation": "file"}, "sample.skeleton_file"),
    ({"preparation": "file", "skeleton_file": "no/such/file.npz"}, "sample.skeleton_file"),
    ({"size_ratio": 0.5}, "sample.size_ratio"),
])
def test_bad_preparations_name_the_key(sample, field):
    with pytest.raises(InputError) as error:
        build_sample(config(**sample))
    assert error.value.field == field
    if sample.get("boundary") == "periodic":
        assert "box of walls" in str(error.value)
