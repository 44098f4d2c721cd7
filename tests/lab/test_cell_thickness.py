"""A periodic cell's thickness after its compaction, predicted before a run starts."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.lab.cell_thickness import (
    CELL_MIN_DIAMETERS,
    CELL_PACKING_ESTIMATE,
    compacted_widths,
    particles_needed,
    thin_cell_after_compaction,
)
from grainlab.lab.discrete_run import _new_test
from grainlab.lab.run_config import RunConfig


def test_an_isotropic_compaction_scales_every_width_alike_to_the_packing_asked():
    widths = np.array([4e-3, 5e-3, 8e-3])
    solid = 0.25 * float(np.prod(widths))  # a cell at packing fraction 0.25
    end = compacted_widths(widths, solid, 0.5)
    assert np.allclose(end / widths, 0.5 ** (1.0 / 3.0), rtol=1e-14)
    assert solid / float(np.prod(end)) == pytest.approx(0.5, rel=1e-14)
    assert np.array_equal(compacted_widths(widths, solid, 0.2), widths)  # denser already


def test_the_particles_needed_bring_the_predicted_width_to_the_limit():
    """The widths scale as n^(1/3) at a fixed size distribution and packing."""
    width, limit, n = 4.38e-3, 5.98e-3, 30
    needed = particles_needed(n, width, limit)
    assert width * (needed / n) ** (1.0 / 3.0) >= limit
    assert width * ((needed - 1) / n) ** (1.0 / 3.0) < limit


def test_a_cell_is_refused_only_below_the_limit():
    solid = 200 * np.pi / 6 * (1.5e-3) ** 3
    side = (solid / CELL_PACKING_ESTIMATE) ** (1.0 / 3.0)  # the compacted cube's side
    widths = np.full(3, 2.0 * side)  # loose: packing fraction 0.55 / 8
    thick = thin_cell_after_compaction(widths, solid, side / CELL_MIN_DIAMETERS * 1.01, 200)
    assert "at least about" in thick
    assert thin_cell_after_compaction(widths, solid, side / CELL_MIN_DIAMETERS * 0.99,
                                      200) == ""


def test_the_sample_is_refused_by_its_particle_count_before_any_step():
    config = RunConfig.model_validate({"sample": {"n_particles": 30, "boundary": "periodic"},
                                       "test": {"kind": "simple_shear", "gamma_max": 0.05}})
    with pytest.raises(InputError) as caught:
        _new_test(config)
    assert caught.value.field == "sample.n_particles" and caught.value.value == 30
