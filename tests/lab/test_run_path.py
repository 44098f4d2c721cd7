"""A discrete run's load path, cut into more steps for an element test: the same controls,
the same total strain, the same stress targets and stop criteria."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.lab.load_path import LoadPath, LoadStage, StopCriterion
from grainlab.lab.run_path import element_path, run_load_path


def run_like_path() -> LoadPath:
    """Two stages as the discrete runs write them: one step each, a stop criterion."""
    control = ("stress",) * 6
    compaction = LoadStage("compaction", 1, 3, control, (1e5, 1e5, 1e5, 0, 0, 0), "target")
    shear = LoadStage("shear", 1, 3, ("stress", "stress", "strain", "strain", "strain",
                                      "strain"), (1e5, 1e5, 0.1, 0, 0, 0), "target",
                      stop=(StopCriterion("eps_q", 0.08),))
    return LoadPath("triaxial_compression", 3, (compaction, shear))


def test_the_shear_stage_is_cut_into_steps_with_the_same_totals():
    path = element_path(run_like_path(), "shear", 400)
    (stage,) = path.stages
    assert stage.n_steps == 400 and stage.control[2] == "strain"
    assert stage.values[2] * stage.n_steps == pytest.approx(0.1, rel=1e-15)
    assert stage.values[:2] == (1e5, 1e5)  # targets, not increments
    assert stage.stop == run_like_path().stages[1].stop


def test_increments_are_divided_and_rotations_too():
    stage = LoadStage("turn", 2, 2, ("stress", "stress", "strain"), (10.0, -4.0, 1e-3),
                      "increment", rotation_per_step=0.2)
    (cut,) = element_path(LoadPath("p", 2, (stage,)), "turn", 4).stages
    np.testing.assert_allclose(np.array(cut.values) * cut.n_steps,
                               np.array(stage.values) * stage.n_steps)
    assert cut.rotation_per_step * cut.n_steps == pytest.approx(0.4)


def test_a_run_metadata_path_with_its_boundary_is_read():
    data = run_like_path().to_dict()
    data["stages"] = [{**s, "boundary": "periodic"} for s in data["stages"]]
    del data["dimension"]
    assert run_load_path({"load_path": data}) == run_like_path()


def test_bad_requests_are_named():
    with pytest.raises(InputError, match="first_stage"):
        element_path(run_like_path(), "unloading", 10)
    with pytest.raises(InputError, match="steps_per_step"):
        element_path(run_like_path(), "shear", 0)
    with pytest.raises(InputError, match="load_path"):
        run_load_path({})
