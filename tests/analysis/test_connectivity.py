"""Packing fraction, z, z_c, recursive rattlers and contact-type proportions (seed 002 eqs.
13–14, seed 003 eq. 13) on hand-built lattices and layouts, with a slow twin of the rattler
peeling.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.connectivity import Connectivity, find_rattlers, packing_fraction
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.errors import InputError

R = 1.0e-3


def lattice_network(positions, box, radius, bond_length, force=1.0) -> ContactNetwork:
    """Periodic lattice of spheres: every pair at (minimum-image) distance ``bond_length`` is an
    interaction with one point loaded by ``force`` along its branch."""
    positions = np.asarray(positions, dtype=float)
    delta = positions[None, :, :] - positions[:, None, :]
    delta -= box * np.round(delta / box)
    i, j = np.nonzero(np.triu(np.isclose(np.linalg.norm(delta, axis=2), bond_length), k=1))
    branches = delta[i, j]
    normals = branches / np.linalg.norm(branches, axis=1)[:, None]
    return ContactNetwork.from_arrays(
        positions=positions, volumes=np.full(len(positions), 4.0 / 3.0 * np.pi * radius**3),
        volume=box**3, pair_particles=np.column_stack([i, j]), pair_branches=branches,
        point_pairs=np.arange(len(i)), point_positions=positions[i] + radius * normals,
        point_normals=normals, point_forces=force * normals)


def simple_cubic(n=3):
    a = 2.0 * R
    cells = np.array(list(itertools.product(range(n), repeat=3)), dtype=float)
    return lattice_network(a * cells, n * a, R, a)


def fcc(n=2):
    a = 2.0 * np.sqrt(2.0) * R
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    positions = [a * (np.array(c) + b) for c in itertools.product(range(n), repeat=3)
                 for b in basis]
    return lattice_network(positions, n * a, R, 2.0 * R)


def chain_network(pairs, n, inactive=(), points=None, types=None, type_names=()):
    """Particles on a line; ``pairs`` listed as (i, j); pairs whose index is in ``inactive``
    carry a tensile force; ``points[k]`` points for pair k (default 1)."""
    pairs = np.asarray(pairs)
    counts = np.ones(len(pairs), dtype=int) if points is None else np.asarray(points)
    point_pairs = np.repeat(np.arange(len(pairs)), counts)
    sign = np.where(np.isin(point_pairs, list(inactive)), -1.0, 1.0)
    c = point_pairs.size
    return ContactNetwork.from_arrays(
        positions=np.column_stack([np.arange(n), np.zeros(n), np.zeros(n)]),
        volumes=np.ones(n), volume=10.0 * n, pair_particles=pairs,
        pair_branches=np.tile([1.0, 0.0, 0.0], (len(pairs), 1)), point_pairs=point_pairs,
        point_positions=np.zeros((c, 3)), point_normals=np.tile([1.0, 0.0, 0.0], (c, 1)),
        point_forces=sign[:, None] * np.array([1.0, 0.0, 0.0]),
        pair_types=types, type_names=type_names)


def slow_rattlers(n, pairs, min_contacts):
    """Twin of find_rattlers: recount from scratch and remove all under-connected particles,
    until nothing changes."""
    alive = set(range(n))
    while True:
        counts = dict.fromkeys(alive, 0)
        for i, j in pairs:
            if i in alive and j in alive:
                counts[i] += 1
                counts[j] += 1
        drop = {k for k, v in counts.items() if v < min_contacts}
        if not drop:
            break
        alive -= drop
    return np.array([k not in alive for k in range(n)])


def random_rotation(rng, d=3):
    q, r = np.linalg.qr(rng.normal(size=(d, d)))
    return q * np.sign(np.diag(r))


# -- lattices -----------------------------------------------------------------------------------
def test_simple_cubic():
    c = Connectivity().compute(simple_cubic())
    assert c.coordination_number == pytest.approx(6.0)
    assert c.connectivity_number == pytest.approx(6.0)
    assert c.packing_fraction == pytest.approx(np.pi / 6.0, rel=1e-12)
    assert not c.rattlers.any()
    assert c.coordination_number_no_rattlers == pytest.approx(6.0)
    assert c.type_proportions == {}


def test_fcc():
    net = fcc()
    c = Connectivity().compute(net)
    assert c.coordination_number == pytest.approx(12.0)
    assert c.connectivity_number == pytest.approx(12.0)
    assert c.packing_fraction == pytest.approx(np.pi / (3.0 * np.sqrt(2.0)), rel=1e-12)
    assert packing_fraction(net) == pytest.approx(0.74048, abs=1e-5)


def test_self_image_pairs_count_twice():
    # one sphere in a periodic cubic cell of side 2R: three pairs (0, 0) with itself along
    # x, y, z; each touches the sphere on both sides, so z = 2 * 3 / 1 = 6.
    eye = np.eye(3)
    net = ContactNetwork.from_arrays(
        positions=[[0.0, 0.0, 0.0]], volumes=[4.0 / 3.0 * np.pi * R**3], volume=(2 * R) ** 3,
        pair_particles=[[0, 0]] * 3, pair_branches=2 * R * eye, point_pairs=[0, 1, 2],
        point_positions=R * eye, point_normals=eye, point_forces=eye)
    c = Connectivity(min_contacts=6).compute(net)
    assert c.coordination_number == pytest.approx(6.0)
    assert not c.rattlers.any()
    assert Connectivity(min_contacts=7).compute(net).rattlers.all()


# -- contact types ------------------------------------------------------------------------------
def test_connectivity_ratio_matches_seed002_eq13():
    # 5 ee and 7 fv pairs (1 point), 4 fe (2 points), 3 ff (3 coplanar points); plus an
    # inactive ff pair (tensile points) that must not count.
    names = ("fv", "ee", "fe", "ff")
    layout = [(1, 1)] * 5 + [(0, 1)] * 7 + [(2, 2)] * 4 + [(3, 3)] * 3 + [(3, 3)]
    types, points = zip(*layout, strict=True)
    n = len(layout) + 1
    pairs = [(k, k + 1) for k in range(len(layout))]
    net = chain_network(pairs, n, inactive={len(layout) - 1}, points=points, types=types,
                        type_names=names)
    c = Connectivity().compute(net)
    k = {"ee": 5 / 19, "fv": 7 / 19, "fe": 4 / 19, "ff": 3 / 19}
    assert c.type_proportions == pytest.approx(k)
    assert sum(c.type_proportions.values()) == pytest.approx(1.0)
    assert c.coordination_number == pytest.approx(2 * 19 / n)
    assert c.connectivity_number == pytest.approx(2 * (5 + 7 + 8 + 9) / n)
    eq13 = k["ee"] + k["fv"] + 2 * k["fe"] + 3 * k["ff"]
    assert c.connectivity_number / c.coordination_number == pytest.approx(eq13)
    assert c.connectivity_ratio == pytest.approx(eq13)
    # eq. 14: z_c = (1 + k_fe + 2 k_ff) z
    assert c.connectivity_number == pytest.approx(
        (1 + k["fe"] + 2 * k["ff"]) * c.coordination_number)
    assert c.points_per_pair_by_type == pytest.approx({"fv": 1, "ee": 1, "fe": 2, "ff": 3})
    assert c.descriptors()["k_ff"] == pytest.approx(3 / 19)


def test_resultant_pairs_count_their_nominal_points(tmp_path):
    """A polyhedra network stores each pair as ONE resultant point; with ``type_points``
    (fv 1, ee 1, fe 2, ff 3) the connectivity number is still eq. 14 and equals that of the
    same network stored point by point; it survives a file round trip and a relabelling."""
    import h5py

    names, m = ("fv", "ee", "fe", "ff"), (1, 1, 2, 3)
    layout = [1] * 5 + [0] * 7 + [2] * 4 + [3] * 3 + [3]
    n = len(layout) + 1
    pairs = [(k, k + 1) for k in range(len(layout))]
    inactive = {len(layout) - 1}
    points_each = chain_network(pairs, n, inactive=inactive, points=[m[t] for t in layout],
                                types=layout, type_names=names)
    resultant = chain_network(pairs, n, inactive=inactive, types=layout, type_names=names)
    assert Connectivity().compute(resultant).connectivity_number == pytest.approx(
        2 * 19 / n)  # without type_points a resultant counts once
    resultant = ContactNetwork(**{**{f: getattr(resultant, f) for f in
                                     resultant.__dataclass_fields__}, "type_points": m})
    reference = Connectivity().compute(points_each)
    c = Connectivity().compute(resultant)
    assert c.connectivity_number == pytest.approx(2 * (5 + 7 + 8 + 9) / n)
    assert c.connectivity_number == pytest.approx(reference.connectivity_number)
    assert c.connectivity_number_no_rattlers == pytest.approx(  # a chain: all rattlers
        reference.connectivity_number_no_rattlers, nan_ok=True)
    assert c.points_per_pair_by_type == pytest.approx(dict(zip(names, m, strict=True)))
    with h5py.File(tmp_path / "net.h5", "w") as f:
        resultant.to_hdf5(f.create_group("net"))
    with h5py.File(tmp_path / "net.h5", "r") as f:
        back = ContactNetwork.from_hdf5(f["net"])
    assert back.type_points == m
    order = np.random.default_rng(0).permutation(n)
    assert Connectivity().compute(back.relabelled(order)).connectivity_number == \
        pytest.approx(c.connectivity_number)
    with pytest.raises(InputError, match="type_points"):
        ContactNetwork(**{**{f: getattr(resultant, f) for f in
                             resultant.__dataclass_fields__}, "type_points": (1, 1, 2)})


def test_partly_active_pairs_and_aggregate_types():
    # aggregates (seed 003 eq. 13): one "t" pair has a tensile third point, so m_t = 2.5
    names = ("s", "ds", "d", "t", "q")
    net0 = chain_network([(0, 1), (1, 2), (2, 3), (3, 4)], 5, points=[1, 2, 3, 3],
                         types=[0, 2, 3, 3], type_names=names)
    forces = net0.point_forces.copy()
    forces[-1] *= -1.0  # last point of the last pair is tensile
    net = ContactNetwork.from_arrays(**{
        **{k: getattr(net0, k) for k in net0.__dataclass_fields__}, "point_forces": forces})
    c = Connectivity().compute(net)
    assert c.points_per_pair_by_type["t"] == pytest.approx(2.5)
    assert np.isnan(c.points_per_pair_by_type["q"])
    assert c.type_proportions["q"] == 0.0
    k = c.type_proportions
    m = c.points_per_pair_by_type
    assert c.connectivity_ratio == pytest.approx(k["s"] * 1 + k["d"] * 2 + k["t"] * m["t"])
    assert c.connectivity_number == pytest.approx(2 * 8 / 5)


# -- rattlers -----------------------------------------------------------------------------------
def test_rattlers_are_removed_recursively():
    # core: tetrahedron 0-1-2-3 (3 contacts each); tail 3-4-5-6; isolated 7 with a tensile
    # (inactive) pair to 0. Non-recursive rule: {6, 7}. Recursive: 6 goes, then 5, then 4;
    # 3 keeps its three core contacts.
    core = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    tail = [(3, 4), (4, 5), (5, 6)]
    net = chain_network(core + tail + [(7, 0)], 8, inactive={9}, points=[2] + [1] * 9)
    c = Connectivity().compute(net)
    assert np.flatnonzero(c.rattlers).tolist() == [4, 5, 6, 7]
    assert c.rattler_fraction == pytest.approx(0.5)
    assert c.coordination_number == pytest.approx(2 * 9 / 8)
    assert c.coordination_number_no_rattlers == pytest.approx(2 * 6 / 4)
    assert c.connectivity_number_no_rattlers == pytest.approx(2 * 7 / 4)
    # min_contacts = 1 keeps every particle with an active interaction
    assert np.flatnonzero(Connectivity(min_contacts=1).compute(net).rattlers).tolist() == [7]
    # min_contacts = 4 dissolves the whole core
    assert Connectivity(min_contacts=4).compute(net).rattlers.all()


@pytest.mark.parametrize("seed", range(5))
def test_rattlers_match_slow_twin(seed):
    rng = np.random.default_rng(seed)
    n = 60
    pairs = rng.integers(0, n, (int(rng.integers(40, 120)), 2))
    for min_contacts in (1, 2, 3):
        fast = find_rattlers(n, pairs, min_contacts)
        np.testing.assert_array_equal(fast, slow_rattlers(n, pairs.tolist(), min_contacts))


def test_long_chain_peels_completely():
    n = 2000
    pairs = np.column_stack([np.arange(n - 1), np.arange(1, n)])
    assert find_rattlers(n, pairs).all()
    ring = np.vstack([pairs, [[n - 1, 0]]])
    assert not find_rattlers(n, ring).any()


# -- invariance and errors ----------------------------------------------------------------------
def test_rotation_and_relabelling_leave_numbers_unchanged():
    rng = np.random.default_rng(3)
    core = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3), (3, 4), (4, 5), (5, 6)]
    net = chain_network(core, 7, points=[1, 2, 3, 1, 1, 2, 1, 1, 1],
                        types=[0, 1, 2, 0, 0, 1, 0, 0, 0], type_names=("s", "d", "t"))
    before = Connectivity().compute(net)
    rotated = Connectivity().compute(net.transformed(random_rotation(rng)))
    order = rng.permutation(net.n_particles)
    relabelled = Connectivity().compute(
        net.relabelled(order, rng.permutation(net.n_pairs), rng.permutation(net.n_points)))
    for other in (rotated, relabelled):
        assert other.descriptors() == pytest.approx(before.descriptors(), rel=1e-12)
    np.testing.assert_array_equal(relabelled.rattlers, before.rattlers[order])


def test_errors():
    with pytest.raises(NotComputedError):
        Connectivity().coordination_number  # noqa: B018
    with pytest.raises(NotComputedError):
        Connectivity().descriptors()
    with pytest.raises(InputError, match="min_contacts"):
        Connectivity(min_contacts=0)
