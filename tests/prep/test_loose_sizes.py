"""The sizes of a loose sample: uniform by volume between d_min and d_max, or two sizes with a
given number fraction of fine particles (seed 001 ch. 3: 13 discs of radius 0.105 mm and 12
of 0.21 mm), refused by name when out of range."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.boundaries.periodic_boundary import PeriodicCell
from grainlab.errors import InputError
from grainlab.lab.option_scope import inert_settings
from grainlab.lab.run_config import RunConfig
from grainlab.prep.loose_sample import binary_diameters, loose_sample


def test_two_sizes_give_the_fine_count_asked_in_random_order():
    d = binary_diameters(25, 0.21e-3, 0.42e-3, 0.52, np.random.default_rng(1))
    assert np.count_nonzero(d == 0.21e-3) == 13 and np.count_nonzero(d == 0.42e-3) == 12
    assert not np.all(np.diff(d) >= 0.0) and not np.all(np.diff(d) <= 0.0)  # shuffled


def test_seed_001s_chapter_3_specimen_is_12_large_and_13_small_discs_in_a_plane():
    sample = loose_sample(shape="disc", n_particles=25, d_min=0.21e-3, size_ratio=2.0,
                          sizes="binary", fine_fraction=0.52, packing_fraction=0.3,
                          boundary=PeriodicCell.around, seed=3)
    radii = np.sort(sample.library.sphere_radii[sample.library.sphere_start])
    np.testing.assert_array_equal(radii, [0.105e-3] * 13 + [0.21e-3] * 12)
    assert sample.description["sizes"] == "binary"
    assert sample.library.thickness == pytest.approx(2.0 * np.mean(radii), rel=1e-12)
    assert sample.box.planar


@pytest.mark.parametrize("fraction", [0.0, 1.0, -0.1, True])
def test_a_fine_fraction_outside_the_open_unit_interval_is_refused(fraction):
    with pytest.raises(InputError) as error:
        loose_sample(n_particles=10, sizes="binary", fine_fraction=fraction)
    assert error.value.field == "fine_fraction"


def test_an_unknown_size_distribution_is_refused_naming_the_choices():
    with pytest.raises(InputError, match="uniform_volume, binary"):
        loose_sample(n_particles=10, sizes="lognormal")
    with pytest.raises(InputError) as error:
        RunConfig.model_validate({"sample": {"sizes": "lognormal"}})
    assert error.value.field == "sample.sizes"


def test_the_fine_fraction_does_nothing_without_two_sizes():
    config = RunConfig.model_validate({"sample": {"fine_fraction": 0.3}})
    assert "sample.fine_fraction" in inert_settings(config, ["sample.fine_fraction"])
    binary = RunConfig.model_validate({"sample": {"sizes": "binary", "fine_fraction": 0.3}})
    assert not inert_settings(binary, ["sample.fine_fraction"])


def test_the_cli_takes_two_sizes_and_refuses_a_fine_fraction_alone():
    from grainlab.cli.run_input import asked_config

    binary = asked_config("triaxial", None, {"n": 60, "sizes": "binary",
                                             "fine_fraction": 0.3})[0]
    assert (binary.sample.sizes, binary.sample.fine_fraction) == ("binary", 0.3)
    with pytest.raises(InputError) as error:
        asked_config("triaxial", None, {"n": 60, "fine_fraction": 0.3})
    assert error.value.field == "--fine-fraction" and "does nothing" in error.value.allowed
