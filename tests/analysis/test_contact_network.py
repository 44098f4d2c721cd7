"""The contact-network data class: validation, derived arrays, transformations, files."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.snapshot_files import (
    append_snapshot,
    count_snapshots,
    read_snapshot,
    read_snapshots,
    resolve_snapshot_file,
    write_snapshots,
)
from grainlab.analysis.synthetic import synthetic_network
from grainlab.errors import InputError


def two_pairs(**changes):
    """Three spheres in a row; the middle pair has two contact points."""
    arrays = dict(
        positions=[[0, 0, 0], [2, 0, 0], [4, 0, 0]], volumes=[4.0, 4.0, 4.0], volume=50.0,
        pair_particles=[[0, 1], [1, 2]], pair_branches=[[2, 0, 0], [2, 0, 0]],
        point_pairs=[0, 1, 1], point_positions=[[1, 0, 0], [3, 0.1, 0], [3, -0.1, 0]],
        point_normals=[[1, 0, 0], [1, 0, 0], [1, 0, 0]],
        point_forces=[[4, 1, 0], [2, 0.5, 0], [2, -0.5, 0]],
        pair_types=[0, 1], type_names=("single", "double"), friction_coefficient=0.4,
        state={"step": 3, "eps_q": 0.25},
    )
    arrays.update(changes)
    return ContactNetwork(**arrays)


def test_derived_arrays():
    net = two_pairs()
    assert net.dimension == 3 and net.n_particles == 3
    assert net.n_pairs == 2 and net.n_points == 3
    np.testing.assert_allclose(net.point_normal_forces, [4, 2, 2])
    np.testing.assert_allclose(net.pair_forces, [[4, 1, 0], [4, 0, 0]])
    np.testing.assert_allclose(net.point_tangential_forces[0], [0, 1, 0])
    assert net.pair_point_counts.tolist() == [1, 2]
    assert net.active_pairs().all()


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"volumes": [4.0, -1.0, 4.0]}, "volumes[1]"),
        ({"volume": 0.0}, "volume"),
        ({"pair_particles": [[0, 1], [1, 7]]}, "pair_particles"),
        ({"point_pairs": [0, 0, 0]}, "pair_particles[1]"),
        ({"point_normals": [[2, 0, 0], [1, 0, 0], [1, 0, 0]]}, "point_normals[0]"),
        ({"point_forces": [[np.nan, 0, 0], [1, 0, 0], [1, 0, 0]]}, "point_forces[0, 0]"),
        ({"pair_types": [0, 5]}, "pair_types"),
        ({"pair_branches": [[2, 0, 0]]}, "pair_branches"),
        ({"friction_coefficient": -0.1}, "friction_coefficient"),
        ({"friction_coefficient": np.inf}, "friction_coefficient"),
        ({"pair_particles": [[0, 1, 2], [1, 2, 0]]}, "pair_particles"),
        ({"pair_branches": [[2, 0], [2, 0], [0, 0]]}, "pair_branches"),
        ({"pair_branches": [[2, 0, 0], [0, 0, 0]]}, "pair_branches[1]"),
    ],
)
def test_bad_arrays_are_named(changes, field):
    with pytest.raises(InputError) as error:
        two_pairs(**changes)
    assert field in str(error.value)


def test_rotation_moves_every_vector():
    net = two_pairs()
    angle = 0.7
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0],
                         [0, 0, 1]])
    turned = net.transformed(rotation, shift=[1.0, 2.0, 3.0])
    np.testing.assert_allclose(turned.pair_forces, net.pair_forces @ rotation.T)
    np.testing.assert_allclose(turned.point_normal_forces, net.point_normal_forces)
    np.testing.assert_allclose(turned.positions[1] - turned.positions[0],
                               rotation @ (net.positions[1] - net.positions[0]))


def test_rotation_must_be_orthogonal():
    with pytest.raises(InputError, match="rotation"):
        two_pairs().transformed(np.diag([1.0, 2.0, 1.0]))


def test_relabelling_keeps_the_pairs():
    net = two_pairs()
    moved = net.relabelled([2, 0, 1], pair_order=[1, 0], point_order=[2, 0, 1])
    # Same particles in each pair, by position.
    original = {tuple(sorted(map(tuple, net.positions[p]))) for p in net.pair_particles}
    relabelled = {tuple(sorted(map(tuple, moved.positions[p]))) for p in moved.pair_particles}
    assert original == relabelled
    np.testing.assert_allclose(sorted(moved.pair_forces[:, 0]), sorted(net.pair_forces[:, 0]))
    assert sorted(moved.pair_point_counts) == [1, 2]


def test_hdf5_round_trip(tmp_path):
    net = two_pairs(point_sliding=[False, True, False])
    with h5py.File(tmp_path / "n.h5", "w") as handle:
        net.to_hdf5(handle.create_group("net"))
    with h5py.File(tmp_path / "n.h5", "r") as handle:
        back = ContactNetwork.from_hdf5(handle["net"])
    for name in ContactNetwork.ARRAYS:
        np.testing.assert_array_equal(getattr(back, name), getattr(net, name))
    assert back.type_names == net.type_names and back.state == net.state
    assert back.friction_coefficient == net.friction_coefficient
    assert back.volume == net.volume


def test_snapshot_file(tmp_path):
    nets = [synthetic_network(200, a_c=0.1 * k, seed=k) for k in range(3)]
    path = write_snapshots(tmp_path / "snapshots.h5", nets)
    assert count_snapshots(path) == 3
    assert append_snapshot(path, nets[0]) == 3
    read = list(read_snapshots(path))
    assert len(read) == 4
    np.testing.assert_array_equal(read[1].point_forces, nets[1].point_forces)
    np.testing.assert_array_equal(read_snapshot(path, -1).point_forces, nets[0].point_forces)
    assert resolve_snapshot_file(tmp_path) == path
    with pytest.raises(InputError, match="index"):
        read_snapshot(path, 9)
    (tmp_path / "other.h5").write_bytes(b"not hdf5")
    with pytest.raises(InputError, match="snapshot file"):
        count_snapshots(tmp_path / "other.h5")
