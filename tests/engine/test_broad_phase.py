"""Cell-list broad phase against its all-pairs twin, and its invariances (STYLE.md 12)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from grainlab.engine.detect.broad_phase import CellListBroadPhase, all_pairs
from grainlab.errors import GrainlabError, InputError

LO = np.array([-1.0, 0.0, 2.0])
HI = np.array([5.0, 4.5, 6.0])
WALLED = (False, False, False)
PERIODIC = (True, True, True)
MIXED = (True, False, True)


def polydisperse(seed: int, n: int, spill: float = 0.1, solid_fraction: float = 0.5):
    """n centres uniform in the box widened by ``spill`` of its size on each side (so some
    bodies sit outside it) and radii uniform in [a, 3 a], with a set so that the spheres fill
    ``solid_fraction`` of the widened box (overlaps allowed; a <= 0.2 m)."""
    rng = np.random.default_rng(seed)
    size = HI - LO
    volume = np.prod((1.0 + 2.0 * spill) * size)
    a = min(0.2, (solid_fraction * volume / (n * 4.0 / 3.0 * np.pi * 10.0)) ** (1.0 / 3.0))
    centres = LO - spill * size + rng.random((n, 3)) * (1.0 + 2.0 * spill) * size
    radii = rng.uniform(a, 3.0 * a, n)  # E[r^3] = 10 a^3
    return centres, radii


def find(centres, radii, alert, periodic, **kwargs):
    return CellListBroadPhase(alert, periodic, **kwargs).find_pairs(centres, radii, LO, HI)


@pytest.mark.parametrize("periodic", [WALLED, PERIODIC, MIXED])
@pytest.mark.parametrize("alert", [0.0, 0.04])
@pytest.mark.parametrize(("seed", "n"), [(0, 2), (1, 40), (2, 700), (3, 3000)])
def test_equals_all_pairs_on_random_polydisperse_sets(seed, n, alert, periodic):
    centres, radii = polydisperse(seed, n)
    pairs = find(centres, radii, alert, periodic)
    np.testing.assert_array_equal(pairs, all_pairs(centres, radii, alert, LO, HI, periodic))
    assert pairs.dtype == np.int64 and pairs.shape[1] == 2
    if n >= 700:
        assert len(pairs) > n  # the sets are dense enough to test something


def test_far_outside_the_box_is_clamped_or_wrapped():
    centres, radii = polydisperse(4, 1500, spill=1.5)
    for periodic in (WALLED, MIXED):
        np.testing.assert_array_equal(
            find(centres, radii, 0.02, periodic),
            all_pairs(centres, radii, 0.02, LO, HI, periodic))


@pytest.mark.parametrize("periodic", [WALLED, PERIODIC])
def test_bodies_on_cell_boundaries_and_at_exact_cut_off(periodic):
    """A lattice whose spacing equals the cut-off (pairs at exactly r_i + r_j + alert), then
    bodies on every cell face and on the box faces lo and hi."""
    radius, alert = 0.2, 0.1
    cut = 2 * radius + alert
    axes = [np.arange(lo, hi + 1e-12, cut) for lo, hi in zip(LO, HI, strict=True)]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    broad_phase = CellListBroadPhase(alert, periodic)
    broad_phase.find_pairs(lattice, np.full(len(lattice), radius), LO, HI)
    width = np.array(broad_phase.statistics.cell_width)
    shape = np.array(broad_phase.statistics.cell_shape)
    rng = np.random.default_rng(5)
    faces = LO + rng.integers(0, shape + 1, (600, 3)) * width  # includes lo and hi exactly
    centres = np.concatenate((lattice, faces))
    radii = np.concatenate((np.full(len(lattice), radius), rng.uniform(0.04, 0.12, 600)))
    pairs = broad_phase.find_pairs(centres, radii, LO, HI)
    np.testing.assert_array_equal(pairs, all_pairs(centres, radii, alert, LO, HI, periodic))
    exact = all_pairs(lattice, np.full(len(lattice), radius), 0.0, LO, HI, periodic)
    assert len(exact) == 0 or len(pairs) > len(exact)  # the alert distance adds the lattice


def test_capacity_overflow_is_detected_and_regrown():
    centres, radii = polydisperse(6, 2000)
    broad_phase = CellListBroadPhase(0.03, MIXED, capacity=1)
    pairs = broad_phase.find_pairs(centres, radii, LO, HI)
    np.testing.assert_array_equal(pairs, all_pairs(centres, radii, 0.03, LO, HI, MIXED))
    stats = broad_phase.statistics
    assert broad_phase.n_regrowths == stats.n_regrowths == 1
    assert stats.capacity == broad_phase.capacity >= stats.n_pairs == len(pairs) > 1
    again = broad_phase.find_pairs(centres, radii, LO, HI)  # fits now: no new growth
    np.testing.assert_array_equal(again, pairs)
    assert broad_phase.n_regrowths == 1 and broad_phase.statistics.n_calls == 2
    denser = broad_phase.find_pairs(centres, 1.5 * radii, LO, HI)
    assert broad_phase.n_regrowths == 2 and len(denser) > len(pairs)


def test_statistics_before_a_call_raise():
    with pytest.raises(GrainlabError, match="find_pairs"):
        _ = CellListBroadPhase(0.0).statistics


@pytest.mark.parametrize("periodic", [WALLED, MIXED])
def test_relabelling_maps_the_pairs(periodic):
    centres, radii = polydisperse(7, 1200)
    pairs = find(centres, radii, 0.03, periodic)
    perm = np.random.default_rng(8).permutation(len(radii))  # new body k is old body perm[k]
    relabelled = find(centres[perm], radii[perm], 0.03, periodic)
    mapped = np.sort(perm[relabelled], axis=1)
    mapped = mapped[np.lexsort((mapped[:, 1], mapped[:, 0]))]
    np.testing.assert_array_equal(mapped, pairs)


@pytest.mark.parametrize("periodic", [PERIODIC, MIXED])
def test_translation_by_a_lattice_vector_changes_nothing(periodic):
    centres, radii = polydisperse(9, 1500)
    shift = np.array([2.0, -1.0, 3.0]) * (HI - LO) * np.array(periodic)
    np.testing.assert_array_equal(
        find(centres + shift, radii, 0.03, periodic), find(centres, radii, 0.03, periodic))


def test_result_does_not_depend_on_the_thread_count():
    centres, radii = polydisperse(10, 3000)
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        serial = find(centres, radii, 0.03, MIXED)
    finally:
        numba.set_num_threads(threads)
    np.testing.assert_array_equal(find(centres, radii, 0.03, MIXED), serial)


def test_tiny_bodies_in_a_large_box_cap_the_cells():
    rng = np.random.default_rng(11)
    centres = LO + rng.random((500, 3)) * (HI - LO)
    radii = np.full(500, 1e-4)
    radii[:50] = 0.3  # a few large ones, and coincident points with zero cut-off below
    broad_phase = CellListBroadPhase(1e-5, PERIODIC)
    pairs = broad_phase.find_pairs(centres, radii, LO, HI)
    assert broad_phase.statistics.n_cells <= 4 * 500
    np.testing.assert_array_equal(pairs, all_pairs(centres, radii, 1e-5, LO, HI, PERIODIC))
    points = np.repeat(centres[:5], 2, axis=0)
    np.testing.assert_array_equal(
        find(points, np.zeros(10), 0.0, WALLED), [[0, 1], [2, 3], [4, 5], [6, 7], [8, 9]])


def test_single_body_and_empty_input():
    for n in (0, 1):
        pairs = find(np.zeros((n, 3)), np.full(n, 0.5), 0.1, MIXED)
        assert pairs.shape == (0, 2) and pairs.dtype == np.int64
        assert all_pairs(np.zeros((n, 3)), np.full(n, 0.5), 0.1, LO, HI, MIXED).shape == (0, 2)


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"radii": -1.0}, "radii[3]"),
        ({"centre": np.nan}, "centres[3]"),
        ({"hi": LO + np.array([1.0, 0.0, 1.0])}, "hi[1]"),
        ({"hi": LO + np.array([1.0, 1.0, -1.0])}, "hi[2]"),
        ({"hi": [1.0, np.nan, 7.0]}, "hi"),
        ({"alert": -0.1}, "alert"),
        ({"periodic": (True, False)}, "periodic"),
        ({"periodic": PERIODIC, "hi": LO + np.array([5.0, 0.5, 5.0])}, "hi[1]"),  # < 3 cells
        ({"shape": (5, 2)}, "centres"),
    ],
)
def test_bad_input_names_the_field(change, field):
    centres, radii = polydisperse(12, 5)
    if "shape" in change:
        centres = np.zeros(change["shape"])
    if "radii" in change:
        radii[3] = change["radii"]
    if "centre" in change:
        centres[3, 1] = change["centre"]
    hi = change.get("hi", HI)
    with pytest.raises(InputError) as error:
        CellListBroadPhase(change.get("alert", 0.0), change.get("periodic", WALLED)) \
            .find_pairs(centres, radii, LO, hi)
    assert error.value.field == field
    assert field in str(error.value)
