"""The drop-and-roll deposition: every sphere rests on its supports, none overlaps, the
packing fraction of the construction, a cost linear in N (checked against an all-pairs
twin of the contacts)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import nnls

from grainlab.errors import InputError
from grainlab.prep.deposition import (
    core_packing_fraction,
    deposit_spheres,
    deposited_packing,
)
from grainlab.prep.deposition_kernels import FLOOR, NO_SUPPORT

CONTACT = 1e-9  # relative gap of a contact (round-off)


def resting_supports(centres, radii, side, k):
    """All-pairs twin: the contact normals of sphere k with the spheres deposited before it
    and with the walls, and whether it touches the floor."""
    r = radii[k]
    gap = np.linalg.norm(centres[:k] - centres[k], axis=1) - (radii[:k] + r)
    touching = np.flatnonzero(np.abs(gap) <= CONTACT * (radii[:k] + r))
    normals = [(centres[k] - centres[j]) / (radii[j] + r) for j in touching]
    x, y, z = centres[k]
    for value, limit, normal in ((x, r, (1, 0, 0)), (side[0] - x, r, (-1, 0, 0)),
                                 (y, r, (0, 1, 0)), (side[1] - y, r, (0, -1, 0))):
        if abs(value - limit) <= CONTACT * r:
            normals.append(np.array(normal, dtype=float))
    return touching, np.array(normals).reshape(-1, 3), abs(z - r) <= CONTACT * r


@pytest.mark.parametrize("size_ratio", [1.0, 3.0])
def test_every_sphere_rests_on_its_supports_without_overlap(size_ratio):
    packing = deposited_packing(n_particles=300, d_min=1e-3, size_ratio=size_ratio,
                                height_ratio=1.5, seed=5)
    c, r, side = packing.centres, packing.radii, packing.side
    # no pair overlaps beyond round-off
    gap = np.linalg.norm(c[:, None] - c[None], axis=2) - (r[:, None] + r[None])
    np.fill_diagonal(gap, np.inf)
    assert np.all(gap >= -CONTACT * (r[:, None] + r[None]))
    # all inside the box, the box trimmed to the top
    assert np.all(c - r[:, None] >= -CONTACT * r[:, None])
    assert np.all(c + r[:, None] <= side * (1 + CONTACT))
    assert np.max(c[:, 2] + r) == side[2]
    on_three = 0
    for k in range(len(r)):
        touching, normals, on_floor = resting_supports(c, r, side, k)
        if on_floor:
            continue
        # at least three supports (two in a valley), the weight in the cone of their normals:
        # the vertical through the centre inside the triangle of the contact points
        assert len(normals) >= 2, (k, packing.supports[k])
        _, residual = nnls(normals.T, np.array([0.0, 0.0, 1.0]))
        assert residual <= 1e-7, (k, normals)
        on_three += len(normals) >= 3
        # the supports the kernel recorded are among the contacts the twin finds
        for code in packing.supports[k]:
            if code >= 0:
                assert code in touching
            else:
                assert code != FLOOR and code in (-2, -3, -4, -5, NO_SUPPORT)
    floor = np.abs(c[:, 2] - r) <= CONTACT * r
    assert on_three == np.count_nonzero(~floor) - packing.status_counts()["two"]
    assert packing.status_counts()["unsettled"] == 0


def test_a_sphere_left_unsupported_is_found():
    """The twin can fail: a sphere lifted off its supports is not held."""
    packing = deposited_packing(n_particles=120, d_min=1e-3, seed=1)
    c = packing.centres.copy()
    k = int(np.flatnonzero(packing.status == 0)[-1])
    c[k, 2] += 1e-5
    _, normals, on_floor = resting_supports(c, packing.radii, packing.side, k)
    assert not on_floor and len(normals) < 2


def test_the_packing_fraction_of_drop_and_roll():
    """Equal spheres: phi ~ 0.58 in the bulk (Visscher & Bolsterli 1972: 0.582)."""
    fractions = []
    for seed in (1, 2):
        packing = deposited_packing(n_particles=2500, d_min=1e-3, size_ratio=1.0,
                                    height_ratio=1.0, seed=seed)
        margin = 2.0 * 2.0 * packing.radii.max()
        fractions.append(core_packing_fraction(packing.centres, packing.radii,
                                               np.full(3, margin), packing.side - margin))
    assert 0.56 <= np.mean(fractions) <= 0.60
    assert packing.packing_fraction < np.mean(fractions)  # walls and the rough top


def test_core_packing_fraction_of_a_known_lattice():
    # simple cubic lattice of unit spheres: pi/6, with spheres cut by every face
    g = np.arange(-1.0, 7.0, 2.0)
    centres = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    phi = core_packing_fraction(centres, np.ones(len(centres)), np.full(3, 0.3),
                                np.full(3, 4.3))
    assert phi == pytest.approx(np.pi / 6, rel=0.01)


def test_the_cost_is_linear_in_n():
    """Distance evaluations per sphere do not grow with N (an all-pairs search would grow
    4 times from N to 4 N)."""
    per_sphere = []
    for n in (400, 1600):
        packing = deposited_packing(n_particles=n, d_min=1e-3, size_ratio=2.0,
                                    height_ratio=1.0, seed=3)
        per_sphere.append(packing.checks.mean())
    assert per_sphere[1] / per_sphere[0] < 1.5


def test_the_deposition_is_deterministic():
    a = deposited_packing(n_particles=200, d_min=1e-3, size_ratio=3.0, seed=9)
    b = deposited_packing(n_particles=200, d_min=1e-3, size_ratio=3.0, seed=9)
    assert np.array_equal(a.centres, b.centres) and np.array_equal(a.radii, b.radii)
    c = deposited_packing(n_particles=200, d_min=1e-3, size_ratio=3.0, seed=10)
    assert not np.array_equal(a.centres, c.centres)


def test_a_tall_pile_grows_the_grid():
    """Spheres resting above the first grid: it is grown and the deposition redone."""
    radii = np.full(400, 1e-3)
    packing = deposit_spheres(radii, 4.1e-3, 4.1e-3, np.random.default_rng(0))
    assert packing.side[2] > 50e-3 and packing.status_counts()["unsettled"] == 0


@pytest.mark.parametrize(("arguments", "field"), [
    ({"n_particles": 0, "d_min": 1e-3}, "n_particles"),
    ({"n_particles": 5, "d_min": -1.0}, "d_min"),
    ({"n_particles": 5, "d_min": 1e-3, "size_ratio": 0.5}, "size_ratio"),
])
def test_bad_input_names_the_field(arguments, field):
    with pytest.raises(InputError) as error:
        deposited_packing(**arguments)
    assert error.value.field == field


def test_a_box_narrower_than_a_sphere_is_refused():
    with pytest.raises(InputError, match="width"):
        deposit_spheres(np.full(3, 1e-3), 1.5e-3, 5e-3, np.random.default_rng(0))
