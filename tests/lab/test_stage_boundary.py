"""One stage loop for both boundaries (grainlab.lab.stage_boundary): the box of walls and the
periodic cell each give the loop everything it asks for, a checkpoint keeps what it kept
before (so that runs written before resume), and each boundary's strains start at zero from
its own reference."""

from __future__ import annotations

import inspect

import pytest

from grainlab.lab.boundary_registry import boundary_record
from grainlab.lab.box_boundary import BoxBoundary
from grainlab.lab.cell_boundary import CellBoundary
from grainlab.lab.discrete_test import DiscreteTest, DiscreteTestSettings
from grainlab.lab.presets import triaxial_compression
from grainlab.lab.stage_boundary import StageBoundary
from grainlab.prep.loose_sample import loose_sample

COMMON_KEYS = {
    "stage_index", "stage_started", "stage_start_step", "stage_start_lengths",
    "reference_lengths", "strain_rate", "n_snapshots", "finished", "halted",
    "stage_start_unconverged", "stage_wall_speed", "dt", "stage_dt", "step_scale", "alert",
    "alert_growths", "friction", "step_index", "time", "unconverged_steps",
    "unconverged_in_row"}
"""The keys of a checkpoint's progress before the boundaries were split out of the test."""
NLGS_KEYS = {"max_iterations", "overlap_recovery", "overlap_recovery_speed", "tolerance"}
CELL_KEYS = {"progress", "progress_step", "reference_stress", "stage_start_stress"}


def protocol_methods() -> set[str]:
    return {name for name, value in vars(StageBoundary).items()
            if inspect.isfunction(value) and not name.startswith("_")}


@pytest.mark.parametrize("kind", [BoxBoundary, CellBoundary])
def test_each_boundary_gives_the_loop_all_it_asks(kind):
    missing = {name for name in protocol_methods() if not callable(getattr(kind, name, None))}
    assert not missing
    # a fixed answer, or one per stage (the cell: its strain-driven stages only)
    assert isinstance(kind.steps_by_overlap, bool | property)


@pytest.mark.parametrize(("boundary", "method", "kind", "extra"), [
    ("walls", "cd", BoxBoundary, NLGS_KEYS),
    ("periodic", "cd", CellBoundary, NLGS_KEYS | CELL_KEYS),
    ("walls", "dem", BoxBoundary, set()),
])
def test_a_checkpoint_keeps_the_progress_it_kept(boundary, method, kind, extra):
    sample = loose_sample(n_particles=20, seed=1, boundary=boundary_record(boundary).around)
    test = DiscreteTest(sample, triaxial_compression(confining=1e4, axial_strain=0.01, n_steps=1),
                        DiscreteTestSettings(method=method))
    assert isinstance(test.boundary, kind)
    assert set(test.progress_arrays()) == COMMON_KEYS | extra
    # strains from the boundary's own reference: none before anything moved
    assert all(value == pytest.approx(0.0, abs=1e-15)
               for value in test.boundary.strains().values())
