"""Sliding proportion and friction mobilisation (seed 002 §III.B; seed 003 eqs. 33–34, Figs.
19–20): contacts built on, inside and just off the Coulomb cone; solver flags; branch-frame
mu'; per-type proportions; frame invariance; the missing-mu error.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.friction import Friction, branch_friction_coefficient
from grainlab.errors import InputError

MU = 0.4


def cone_network(rng, ratios, mu=MU, d=3, normal_forces=None, branch_along_normal=True,
                 types=None, type_names=(), sliding_flags=None) -> ContactNetwork:
    """Single-point pairs with |f_t| = ratio * mu * f_n, random normal and tangent directions;
    branch along the normal (or random when ``branch_along_normal`` is False)."""
    ratios = np.asarray(ratios, dtype=float)
    m = ratios.size
    f_n = rng.uniform(0.5, 2.0, m) if normal_forces is None else np.asarray(normal_forces)
    normals = rng.normal(size=(m, d))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    tangents = rng.normal(size=(m, d))
    tangents -= np.einsum("ci,ci->c", tangents, normals)[:, None] * normals
    tangents /= np.linalg.norm(tangents, axis=1)[:, None]
    forces = f_n[:, None] * normals + (ratios * mu * f_n)[:, None] * tangents
    if branch_along_normal:
        branches = 2.0 * normals
    else:
        branches = rng.normal(size=(m, d))
    return ContactNetwork.from_arrays(
        positions=rng.uniform(0, 5, (2 * m, d)), volumes=np.ones(2 * m), volume=1000.0,
        pair_particles=np.arange(2 * m).reshape(m, 2), pair_branches=branches,
        point_pairs=np.arange(m), point_positions=np.zeros((m, d)), point_normals=normals,
        point_forces=forces, friction_coefficient=mu, pair_types=types, type_names=type_names,
        point_sliding=sliding_flags)


def test_contacts_on_the_cone_slide_and_inside_do_not():
    rng = np.random.default_rng(0)
    ratios = np.array([1.0] * 6 + [0.99] * 3 + [0.5, 0.0, 0.0])
    net = cone_network(rng, ratios)
    fr = Friction().compute(net)
    assert fr.sliding.tolist() == [True] * 6 + [False] * 6
    assert fr.sliding_proportion == pytest.approx(0.5)
    np.testing.assert_allclose(fr.contact_mobilisation, ratios, atol=1e-12)
    # I_mu = <|f_t|>/<mu f_n>
    f_n = net.point_normal_forces
    assert fr.mobilisation_index == pytest.approx(np.sum(ratios * f_n) / np.sum(f_n), rel=1e-12)


def test_tolerance_is_respected():
    rng = np.random.default_rng(1)
    tol = 1e-3
    net = cone_network(rng, [1 - 0.5 * tol, 1 - 2 * tol, 0.97])
    assert Friction(tolerance=tol).compute(net).sliding.tolist() == [True, False, False]
    assert Friction(tolerance=0.05).compute(net).sliding.tolist() == [True, True, True]
    assert Friction(tolerance=0.0).compute(net).sliding.tolist() == [False, False, False]


def test_solver_flags_override_unless_disabled():
    rng = np.random.default_rng(2)
    net = cone_network(rng, [1.0, 0.2, 1.0, 0.3], sliding_flags=[False, True, True, True])
    assert Friction().compute(net).sliding.tolist() == [False, True, True, True]
    assert Friction(use_solver_flags=False).compute(net).sliding.tolist() == [True, False,
                                                                              True, False]


def test_inactive_points_are_ignored():
    rng = np.random.default_rng(3)
    net = cone_network(rng, [1.0, 1.0, 0.2], normal_forces=[1.0, -1.0, 1.0])
    fr = Friction(use_solver_flags=False).compute(net)
    assert fr.sliding.tolist() == [True, False, False]
    assert fr.sliding_proportion == pytest.approx(0.5)
    assert np.isnan(fr.contact_mobilisation[1])
    assert np.isnan(fr.branch_friction[1])


def test_branch_frame_equals_contact_frame_when_normals_are_along_branches():
    rng = np.random.default_rng(4)
    ratios = rng.uniform(0, 1, 50)
    fr = Friction().compute(cone_network(rng, ratios))
    np.testing.assert_allclose(fr.branch_friction, MU, rtol=1e-9)
    np.testing.assert_allclose(fr.pair_mobilisation, ratios, rtol=1e-9, atol=1e-12)
    assert fr.mobilisation_index_branch == pytest.approx(fr.mobilisation_index, rel=1e-9)
    assert fr.mean_branch_friction == pytest.approx(MU, rel=1e-9)
    assert fr.n_pairs_excluded == 0


def test_oblique_frictionless_contact_is_on_the_branch_cone():
    # normal at 60 deg to the branch, mu = 0, F = f_n n: f_n' = f_n/2, |f_t'| = f_n sqrt(3)/2,
    # so the derived mu' = sqrt(3) puts the pair exactly on its cone (I' = 1). The printed
    # form's square-root argument 1 - (f_n/f_n')^2 = -3 is negative: the pair is excluded.
    n = np.array([0.5, np.sqrt(3) / 2, 0.0])
    net = ContactNetwork.from_arrays(
        positions=[[0, 0, 0], [2, 0, 0]], volumes=[1.0, 1.0], volume=100.0,
        pair_particles=[[0, 1]], pair_branches=[[2, 0, 0]], point_pairs=[0],
        point_positions=[[1, 0, 0]], point_normals=[n], point_forces=[3.0 * n],
        friction_coefficient=0.0)
    fr = Friction().compute(net)
    assert fr.branch_friction[0] == pytest.approx(np.sqrt(3.0))
    assert fr.mobilisation_index_branch == pytest.approx(1.0)
    assert fr.sliding_proportion == 1.0  # mu = 0: every active point is on its cone
    assert np.isnan(fr.mobilisation_index)
    printed = Friction(branch_form="printed").compute(net)
    assert printed.n_pairs_excluded == 1
    assert np.isnan(printed.mobilisation_index_branch)


def test_branch_friction_coefficient_forms():
    # f_n = 2, f_n' = 1, mu = 1: derived (2/1) sqrt(2 - 1/4) = sqrt(7);
    # printed (1/2) sqrt(2 - 4) -> excluded. Swapped values: derived excluded, printed sqrt(7).
    derived, ok = branch_friction_coefficient(np.array([2.0, 1.0]), np.array([1.0, 2.0]), 1.0)
    np.testing.assert_allclose(derived[0], np.sqrt(7.0))
    assert ok.tolist() == [True, False]
    printed, ok = branch_friction_coefficient(np.array([2.0, 1.0]), np.array([1.0, 2.0]), 1.0,
                                              "printed")
    np.testing.assert_allclose(printed[1], np.sqrt(7.0))
    assert ok.tolist() == [False, True]
    _, ok = branch_friction_coefficient(np.array([1.0, -1.0]), np.array([0.0, 1.0]), 0.5)
    assert ok.tolist() == [False, False]
    with pytest.raises(InputError, match="branch_form"):
        branch_friction_coefficient(np.ones(1), np.ones(1), 0.5, "other")


def test_multipoint_pair_uses_its_resultant_and_mean_normal():
    # an ff pair: three coplanar points with normal e_x and |f_t| = mu f_n each (along e_y),
    # branch along x: F = (3, 3 mu, 0); f_n = f_n' = 3, |f_t'| = 3 mu -> I' = 1, mu' = mu.
    net = ContactNetwork.from_arrays(
        positions=[[0, 0, 0], [2, 0, 0]], volumes=[1.0, 1.0], volume=100.0,
        pair_particles=[[0, 1]], pair_branches=[[2, 0, 0]], point_pairs=[0, 0, 0],
        point_positions=[[1, 0, 0], [1, 0.1, 0], [1, 0, 0.1]], point_normals=[[1, 0, 0]] * 3,
        point_forces=[[1, MU, 0]] * 3, friction_coefficient=MU, pair_types=[0],
        type_names=("ff",))
    fr = Friction().compute(net)
    assert fr.branch_friction[0] == pytest.approx(MU)
    assert fr.pair_mobilisation[0] == pytest.approx(1.0)
    assert fr.sliding_proportion == 1.0


def test_sliding_by_contact_type():
    rng = np.random.default_rng(5)
    # types s, d, t: s points [slide, slide, no], d [slide, no], t [no]
    ratios = [1.0, 1.0, 0.1, 1.0, 0.2, 0.3]
    types = [0, 0, 0, 1, 1, 2]
    fr = Friction().compute(cone_network(rng, ratios, types=types, type_names=("s", "d", "t")))
    assert fr.sliding_proportion == pytest.approx(0.5)
    assert fr.sliding_proportion_by_type == pytest.approx({"s": 2 / 6, "d": 1 / 6, "t": 0.0})
    assert sum(fr.sliding_proportion_by_type.values()) == pytest.approx(fr.sliding_proportion)
    assert fr.sliding_fraction_within_type == pytest.approx({"s": 2 / 3, "d": 0.5, "t": 0.0})
    assert fr.descriptors()["sliding_proportion_s"] == pytest.approx(1 / 3)


def test_rotation_and_relabelling_leave_indices_unchanged():
    rng = np.random.default_rng(6)
    ratios = np.where(rng.uniform(size=40) < 0.4, 1.0, rng.uniform(size=40))
    net = cone_network(rng, ratios, branch_along_normal=False)
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    before = Friction().compute(net)
    assert 0 < before.sliding_proportion < 1
    assert 0 < before.n_pairs_excluded < 40
    for other in (net.transformed(q * np.sign(np.diag(r))),
                  net.relabelled(rng.permutation(net.n_particles),
                                 rng.permutation(net.n_pairs), rng.permutation(net.n_points))):
        after = Friction().compute(other)
        assert after.descriptors() == pytest.approx(before.descriptors(), rel=1e-9,
                                                    nan_ok=True)


def test_missing_friction_coefficient_raises():
    rng = np.random.default_rng(7)
    net = cone_network(rng, [0.5])
    values = {k: getattr(net, k) for k in net.__dataclass_fields__}
    values["friction_coefficient"] = None
    with pytest.raises(InputError, match="friction_coefficient") as error:
        Friction().compute(ContactNetwork(**values))
    assert error.value.field == "friction_coefficient"


def test_errors():
    with pytest.raises(NotComputedError):
        Friction().sliding_proportion  # noqa: B018
    with pytest.raises(InputError, match="tolerance"):
        Friction(tolerance=1.0)
    with pytest.raises(InputError, match="branch_form"):
        Friction(branch_form="paper")
