"""Fabric and force anisotropies (seed 002 eqs. 26–27, A1–A2, B1; seed 003 eqs. 14–36).

Synthetic networks are sampled from the harmonic model of seed 002 eq. 26 about a known axis,
and what Fabric returns is compared with the same model integrated by Gauss–Legendre
quadrature (the expected value of every A2 estimator, cross terms included), with a
tolerance of about 4 standard errors of the sampling. A loop-based twin (STYLE.md 12) checks
the vectorised tensors on small irregular networks.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.fabric import Fabric, q_over_trace_second_order
from grainlab.errors import InputError

N_SAMPLES = 200_000
# Standard errors at 2e5 samples: a_c ~ 0.0025, a_fn and a_ft ~ 0.003 (checked over seeds).
TOL = 0.012
LENGTH = 2e-3  # branch length L [m] (spheres of radius 1 mm)
MEAN_FORCE = 10.0  # f0 [N]


# -- synthetic networks ----------------------------------------------------------------------
def _basis(axis):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.array([0, 1.0, 0])
    b1 = np.cross(axis, helper)
    b1 /= np.linalg.norm(b1)
    return axis, b1, np.cross(axis, b1)


def sample_3d(n, a_c, a_fn, a_ft, *, axis=(0, 0, 1), a_ln=0.0, a_lt=0.0, seed=0,
              n_types=0):
    """One pair of two particles per contact point. Normals from P(theta) = (1 + a_c Y)/(4 pi)
    by rejection, Y = 3cos^2 - 1; f = f0(1 + a_fn Y) n + f0 a_ft sin 2theta m, with m = -dn/dtheta
    the tangent towards the axis (friction resisting the deviatoric strain); l = L(1 + a_ln Y) n
    + L a_lt sin 2theta m (a_ln = a_lt = 0: spheres)."""
    rng = np.random.default_rng(seed)
    bound = max(1 + 2 * a_c, 1 - a_c)
    cos = np.empty(0)
    while cos.size < n:
        u = rng.uniform(-1, 1, 2 * n)
        keep = rng.uniform(0, bound, 2 * n) < 1 + a_c * (3 * u**2 - 1)
        cos = np.concatenate([cos, u[keep]])
    u = cos[:n]
    s = np.sqrt(1 - u**2)
    phi = rng.uniform(0, 2 * np.pi, n)
    e, b1, b2 = _basis(axis)
    radial = np.cos(phi)[:, None] * b1 + np.sin(phi)[:, None] * b2
    normal = u[:, None] * e + s[:, None] * radial
    towards_axis = s[:, None] * e - u[:, None] * radial
    shape, sin2 = 3 * u**2 - 1, 2 * u * s
    force = (MEAN_FORCE * (1 + a_fn * shape))[:, None] * normal + \
        (MEAN_FORCE * a_ft * sin2)[:, None] * towards_axis
    branch = (LENGTH * (1 + a_ln * shape))[:, None] * normal + \
        (LENGTH * a_lt * sin2)[:, None] * towards_axis
    first = rng.uniform(0, 1.0, (n, 3))
    positions = np.empty((2 * n, 3))
    positions[0::2], positions[1::2] = first, first + branch
    extra = {}
    if n_types:
        extra = dict(pair_types=rng.integers(0, n_types, n),
                     type_names=tuple(f"k{i}" for i in range(n_types)))
    return ContactNetwork(
        positions=positions, volumes=np.full(2 * n, np.pi / 6 * LENGTH**3),
        volume=2 * n * np.pi / 6 * LENGTH**3 / 0.6,
        pair_particles=np.arange(2 * n).reshape(n, 2), pair_branches=branch,
        point_pairs=np.arange(n), point_positions=first + 0.5 * branch, point_normals=normal,
        point_forces=force, **extra)


def model_3d(a_c, a_fn, a_ft, a_ln=0.0, a_lt=0.0):
    """Expected A2 anisotropies and exact q/p of the sampled model, by quadrature in
    u = cos theta (axial and transverse components of each axisymmetric tensor)."""
    u, w = np.polynomial.legendre.leggauss(64)
    s, shape = np.sqrt(1 - u**2), 3 * u**2 - 1
    sin2 = 2 * u * s
    p = w * (1 + a_c * shape)
    p /= p.sum()
    l_n, l_t = 1 + a_ln * shape, a_lt * sin2
    f_n, f_t = 1 + a_fn * shape, a_ft * sin2

    def a2(nn, nt):  # k (X_axial - X_transverse) / tr X for X = <nn n n + nt sym(n m)>
        axial = np.sum(p * (nn * u * u + nt * u * s))
        transverse = np.sum(p * (nn * s * s - nt * u * s)) / 2
        return 2.5 * (axial - transverse) / (axial + 2 * transverse)

    r_f, r_ln, r_l = a2(1.0, 0.0), a2(l_n, 0.0), a2(l_n, l_t)
    r_fn, r_f_all = a2(f_n, 0.0), a2(f_n, f_t)
    axial = np.sum(p * (f_n * u + f_t * s) * (l_n * u + l_t * s))
    transverse = np.sum(p * (f_n * s - f_t * u) * (l_n * s - l_t * u)) / 2
    return {"a_c": r_f, "a_ln": r_ln - r_f, "a_lt": r_l - r_ln, "a_fn": r_fn - r_f,
            "a_ft": r_f_all - r_fn,
            "q_over_trace": (axial - transverse) / (axial + 2 * transverse)}


def sample_2d(n, a_c, a_fn, a_ft, *, axis_angle=0.0, seed=0):
    """2D: P(theta) = (1 + a_c cos 2theta)/(2 pi), f = f0(1 + a_fn cos 2theta) n
    + f0 a_ft sin 2theta m, m = -dn/dtheta, l = L n, theta from the axis at ``axis_angle``."""
    rng = np.random.default_rng(seed)
    theta = np.empty(0)
    while theta.size < n:
        t = rng.uniform(0, 2 * np.pi, 2 * n)
        keep = rng.uniform(0, 1 + abs(a_c), 2 * n) < 1 + a_c * np.cos(2 * t)
        theta = np.concatenate([theta, t[keep]])
    theta = theta[:n]
    angle = theta + axis_angle
    normal = np.column_stack([np.cos(angle), np.sin(angle)])
    towards_axis = np.column_stack([np.sin(angle), -np.cos(angle)])
    force = (MEAN_FORCE * (1 + a_fn * np.cos(2 * theta)))[:, None] * normal + \
        (MEAN_FORCE * a_ft * np.sin(2 * theta))[:, None] * towards_axis
    branch = LENGTH * normal
    first = rng.uniform(0, 1.0, (n, 2))
    positions = np.empty((2 * n, 2))
    positions[0::2], positions[1::2] = first, first + branch
    return ContactNetwork(
        positions=positions, volumes=np.full(2 * n, np.pi / 4 * LENGTH**2),
        volume=2 * n * np.pi / 4 * LENGTH**2 / 0.8,
        pair_particles=np.arange(2 * n).reshape(n, 2), pair_branches=branch,
        point_pairs=np.arange(n), point_positions=first + 0.5 * branch, point_normals=normal,
        point_forces=force)


def model_2d(a_c, a_fn, a_ft):
    """Expected 2D A2 anisotropies (k = 2) and q/p, by quadrature over theta."""
    theta = (np.arange(4096) + 0.5) * 2 * np.pi / 4096
    p = 1 + a_c * np.cos(2 * theta)
    p /= p.sum()
    c, s = np.cos(theta), np.sin(theta)
    f_n, f_t = 1 + a_fn * np.cos(2 * theta), a_ft * np.sin(2 * theta)

    def a2(nn, nt):  # axis along x: n = (c, s), m = (s, -c)
        xx, yy = np.sum(p * (nn * c * c + nt * c * s)), np.sum(p * (nn * s * s - nt * s * c))
        return 2 * (xx - yy) / (xx + yy)

    r_f, r_fn, r_f_all = a2(1.0, 0.0), a2(f_n, 0.0), a2(f_n, f_t)
    xx, yy = np.sum(p * (f_n * c + f_t * s) * c), np.sum(p * (f_n * s - f_t * c) * s)
    return {"a_c": r_f, "a_fn": r_fn - r_f, "a_ft": r_f_all - r_fn,
            "q_over_trace": (xx - yy) / (xx + yy)}


# -- loop-based twin (STYLE.md 12) -----------------------------------------------------------
def loop_fabric(net, level="points"):
    """Tensors and A2 anisotropies with plain loops, written from the definitions."""
    d = net.dimension
    stress = np.zeros((d, d))
    for c in range(net.n_points):
        stress += np.outer(net.point_forces[c], net.pair_branches[net.point_pairs[c]])
    stress = 0.5 * (stress + stress.T) / net.volume
    _, vectors = np.linalg.eigh(stress)
    e1, em = vectors[:, -1], vectors[:, 0]

    def entry(n, f, br):
        f_n = f @ n
        ft_vec = f - f_n * n
        if np.linalg.norm(ft_vec) > 1e-9 * np.linalg.norm(f):
            t = ft_vec / np.linalg.norm(ft_vec)
        else:
            lt_vec = br - (br @ n) * n
            if np.linalg.norm(lt_vec) > 1e-9 * np.linalg.norm(br):
                t = lt_vec / np.linalg.norm(lt_vec)
            else:
                t = np.array([-n[1], n[0]]) if d == 2 else np.cross(n, [0.6, 0.8, 0.0])
                t /= np.linalg.norm(t)
        return n, t, f_n, np.linalg.norm(ft_vec) if ft_vec @ t > 0 else 0.0, br @ n, br @ t

    contact, branch = [], []
    pair_force = np.zeros((net.n_pairs, d))
    pair_normal = np.zeros((net.n_pairs, d))
    active_pair = np.zeros(net.n_pairs, bool)
    for c in range(net.n_points):
        k = net.point_pairs[c]
        pair_force[k] += net.point_forces[c]
        f_n = net.point_forces[c] @ net.point_normals[c]
        if f_n > 0:
            active_pair[k] = True
            pair_normal[k] += net.point_normals[c]
            if level == "points":
                contact.append(entry(net.point_normals[c], net.point_forces[c],
                                     net.pair_branches[k]))
    for k in range(net.n_pairs):
        if active_pair[k]:
            br = net.pair_branches[k]
            if level == "pairs":
                contact.append(entry(pair_normal[k] / np.linalg.norm(pair_normal[k]),
                                     pair_force[k], br))
            branch.append(entry(br / np.linalg.norm(br), pair_force[k], br))

    def tensors(entries):
        m = len(entries)
        mean_ln = sum(e[4] for e in entries) / m
        mean_fn = sum(e[2] for e in entries) / m
        out = {name: np.zeros((d, d)) for name in ("F", "chi_ln", "chi_lt", "chi_fn", "chi_ft")}
        for n, t, f_n, f_t, l_n, l_t in entries:
            nt = 0.5 * (np.outer(n, t) + np.outer(t, n))
            out["F"] += np.outer(n, n) / m
            out["chi_ln"] += l_n * np.outer(n, n) / (m * mean_ln)
            out["chi_lt"] += l_t * nt / (m * mean_ln)
            out["chi_fn"] += f_n * np.outer(n, n) / (m * mean_fn)
            out["chi_ft"] += f_t * nt / (m * mean_fn)
        return out

    k = 2.5 if d == 3 else 2.0

    def ratio(x):
        return k * (e1 @ x @ e1 - em @ x @ em) / np.trace(x)

    tc, tb = tensors(contact), tensors(branch)
    a = {"a_c": ratio(tc["F"])}
    a["a_ln"] = ratio(tc["chi_ln"]) - a["a_c"]
    a["a_lt"] = ratio(tc["chi_ln"] + tc["chi_lt"]) - a["a_c"] - a["a_ln"]
    a["a_fn"] = ratio(tc["chi_fn"]) - a["a_c"]
    a["a_ft"] = ratio(tc["chi_fn"] + tc["chi_ft"]) - a["a_c"] - a["a_fn"]
    a["a_c_branch"] = ratio(tb["F"])
    a["a_ln_branch"] = ratio(tb["chi_ln"]) - a["a_c_branch"]
    a["a_fn_branch"] = ratio(tb["chi_fn"]) - a["a_c_branch"]
    a["a_ft_branch"] = ratio(tb["chi_fn"] + tb["chi_ft"]) - a["a_c_branch"] - a["a_fn_branch"]
    tensors_all = dict(tc)
    tensors_all.update({f"{name}_branch": v for name, v in tb.items() if name != "chi_lt"})
    return tensors_all, a, e1


def irregular_network(d=3, seed=1, n_particles=30, n_pairs=60):
    """Random pairs with 1–3 points each, some tensile points, some frictionless points, some
    with branch vectors along the normal (all fallbacks of t), and contact types."""
    rng = np.random.default_rng(seed)
    pairs = np.array([rng.choice(n_particles, 2, replace=False) for _ in range(n_pairs)])
    branches = rng.normal(size=(n_pairs, d))
    counts = rng.integers(1, 4, n_pairs)
    point_pairs = np.repeat(np.arange(n_pairs), counts)
    c = point_pairs.size
    normals = branches[point_pairs] + 0.4 * rng.normal(size=(c, d))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    normals[:5] = branches[point_pairs[:5]] / np.linalg.norm(branches[point_pairs[:5]],
                                                               axis=1)[:, None]
    f_n = rng.exponential(1.0, c) * np.where(rng.uniform(size=c) < 0.1, -0.3, 1.0)
    tangential = rng.normal(size=(c, d)) * 0.3
    tangential -= np.einsum("ci,ci->c", tangential, normals)[:, None] * normals
    tangential[:8] = 0.0  # frictionless points: t from the branch, or any perpendicular
    forces = f_n[:, None] * normals + tangential
    return ContactNetwork(
        positions=rng.uniform(0, 5, (n_particles, d)), volumes=np.full(n_particles, 0.5),
        volume=125.0, pair_particles=pairs, pair_branches=branches, point_pairs=point_pairs,
        point_positions=rng.uniform(0, 5, (c, d)), point_normals=normals, point_forces=forces,
        pair_types=rng.integers(0, 3, n_pairs), type_names=("a", "b", "c"))


# -- fixtures --------------------------------------------------------------------------------
A_C, A_FN, A_FT = 0.3, 0.4, 0.2
TILTED_AXIS = np.array([0.3, -0.5, 0.8])


@pytest.fixture(scope="module")
def axial():
    return Fabric().compute(sample_3d(N_SAMPLES, A_C, A_FN, A_FT, seed=11))


@pytest.fixture(scope="module")
def tilted_network():
    return sample_3d(N_SAMPLES, A_C, A_FN, A_FT, axis=TILTED_AXIS, seed=12, n_types=3)


# -- tests -----------------------------------------------------------------------------------
def test_recovers_harmonic_anisotropies(axial):
    expected = model_3d(A_C, A_FN, A_FT)
    a = axial.anisotropies
    assert abs(axial.stress_directions[2, 0]) > 0.999  # e1 along z
    for name in ("a_c", "a_fn", "a_ft"):
        assert a[name] == pytest.approx(expected[name], abs=TOL), name
    # the A2 estimators differ from the inputs by cross terms only
    assert a["a_fn"] == pytest.approx(A_FN, abs=0.02)
    assert a["a_ft"] == pytest.approx(A_FT, abs=0.02)
    # spheres: l_n = L everywhere and l_t = 0, so chi_ln = F and chi_lt = 0 exactly
    assert a["a_ln"] == pytest.approx(0.0, abs=1e-12)
    assert a["a_lt"] == pytest.approx(0.0, abs=1e-12)
    for name in ("F", "chi_ln", "chi_l", "chi_fn", "chi_f"):
        assert np.trace(axial.tensors[name]) == pytest.approx(1.0, abs=1e-12), name
    for name in ("chi_lt", "chi_ft"):
        assert np.trace(axial.tensors[name]) == pytest.approx(0.0, abs=1e-12), name
    assert axial.mean_normal_length == pytest.approx(LENGTH, rel=1e-12)
    assert axial.mean_branch_length == pytest.approx(LENGTH, rel=1e-12)
    # <f_n> = f0 (1 + a_c a_fn <Y^2>) with <Y^2> = 4/5 over the isotropic sphere
    assert axial.mean_normal_force == pytest.approx(MEAN_FORCE * (1 + 0.8 * A_C * A_FN),
                                                    rel=0.01)
    assert axial.mean_radial_force == pytest.approx(axial.mean_normal_force, rel=1e-12)


def test_q_over_trace_harmonic_approximations(axial):
    expected = model_3d(A_C, A_FN, A_FT)
    assert axial.q_over_trace == pytest.approx(expected["q_over_trace"], abs=TOL)
    harmonic = axial.q_over_trace_harmonic
    # the measured q/p and eq. 27a with the inputs differ by the neglected cross terms only
    assert abs(axial.q_over_trace - 0.4 * (A_C + A_FN + A_FT)) < 0.02
    # for equal spheres, chi_l = F and sigma / tr sigma = chi_f: eqs. 27a and 27b are exact
    # identities for the A2 anisotropies
    assert harmonic["contact_first_order"] == pytest.approx(axial.q_over_trace, abs=1e-10)
    assert harmonic["branch_first_order"] == pytest.approx(axial.q_over_trace, abs=1e-10)
    a = axial.anisotropies
    b1 = (0.4 * (a["a_c"] + a["a_fn"] + a["a_ft"]) + 4 / 105 * a["a_c"] * a["a_fn"]
          + 16 / 105 * a["a_c"] * a["a_ft"])  # eq. B1 with a_ln = a_lt = 0
    assert harmonic["contact_second_order"] == pytest.approx(b1, abs=1e-12)
    d = axial.descriptors()
    assert d["q_over_trace_27a"] == harmonic["contact_first_order"]
    assert d["q_over_trace_B1"] == harmonic["contact_second_order"]
    assert d["a_c"] == a["a_c"] and d["a_ft_branch"] == a["a_ft_branch"]


def test_second_order_formula_by_hand():
    # eq. B1 term by term for (a_c, a_ln, a_lt, a_fn, a_ft) = (0.3, 0.1, 0.05, 0.4, 0.2)
    first = 0.4 * 1.05
    second = 4 / 105 * (0.12 + 0.03 + 0.04) + 16 / 105 * (0.06 + 0.015 + 0.02 + 0.02)
    assert q_over_trace_second_order(0.3, 0.1, 0.05, 0.4, 0.2) == pytest.approx(first + second)


def test_non_spherical_branch_vectors():
    """l_n and l_t depend on the direction: a_ln and a_lt recovered, and eq. 27a misses the
    measured q/p by exactly the model's neglected terms (which B1 does not reproduce)."""
    a_ln, a_lt = 0.1, 0.05
    fab = Fabric().compute(sample_3d(N_SAMPLES, A_C, A_FN, A_FT, a_ln=a_ln, a_lt=a_lt,
                                     seed=13))
    expected = model_3d(A_C, A_FN, A_FT, a_ln, a_lt)
    for name in ("a_c", "a_ln", "a_lt", "a_fn", "a_ft", "q_over_trace"):
        value = fab.q_over_trace if name == "q_over_trace" else fab.anisotropies[name]
        assert value == pytest.approx(expected[name], abs=TOL), name
    gap = fab.q_over_trace_harmonic["contact_first_order"] - fab.q_over_trace
    expected_gap = 0.4 * sum(expected[k] for k in ("a_c", "a_ln", "a_lt", "a_fn", "a_ft")) \
        - expected["q_over_trace"]
    assert abs(expected_gap) > 0.002  # the cross terms are visible here
    assert gap == pytest.approx(expected_gap, abs=0.002)


def test_tilted_loading_axis(tilted_network):
    fab = Fabric().compute(tilted_network)
    axis = TILTED_AXIS / np.linalg.norm(TILTED_AXIS)
    assert abs(fab.stress_directions[:, 0] @ axis) > 0.999
    expected = model_3d(A_C, A_FN, A_FT)
    for name in ("a_c", "a_fn", "a_ft"):
        assert fab.anisotropies[name] == pytest.approx(expected[name], abs=TOL), name
    for name in ("F", "chi_fn", "chi_f"):
        assert fab.misalignment_deg[name] < 2.0, name
    assert np.allclose(fab.stress_directions.T @ fab.stress_directions, np.eye(3))
    assert np.linalg.det(fab.stress_directions) == pytest.approx(1.0)
    # near axial symmetry the magnitude-only variants agree with the projected ones
    for name in ("a_c", "a_fn", "a_ft"):
        assert fab.magnitude_anisotropies[name + "_mag"] == pytest.approx(
            fab.anisotropies[name], abs=TOL), name


def test_isotropic_sample_has_no_anisotropy():
    fab = Fabric().compute(sample_3d(N_SAMPLES, 0.0, 0.0, 0.0, seed=14))
    for name, value in fab.anisotropies.items():
        assert abs(value) < TOL, name
    assert abs(fab.q_over_trace) < TOL


def test_rotation_rotates_tensors_and_keeps_anisotropies(tilted_network):
    rotation = np.linalg.qr(np.random.default_rng(5).normal(size=(3, 3)))[0]
    rotation *= np.sign(np.linalg.det(rotation))
    fab = Fabric().compute(tilted_network)
    rot = Fabric().compute(tilted_network.transformed(rotation, shift=[1.0, 2.0, 3.0]))
    for name, value in fab.tensors.items():
        np.testing.assert_allclose(rot.tensors[name], rotation @ value @ rotation.T,
                                   atol=1e-12, err_msg=name)
    for name, value in fab.anisotropies.items():
        assert rot.anisotropies[name] == pytest.approx(value, abs=1e-10), name
    for name, value in fab.magnitude_anisotropies.items():
        assert rot.magnitude_anisotropies[name] == pytest.approx(value, abs=1e-10), name
    for name, value in fab.partial_anisotropies["k1"].items():
        assert rot.partial_anisotropies["k1"][name] == pytest.approx(value, abs=1e-10), name
    cosines = np.abs(np.sum((rotation @ fab.stress_directions) * rot.stress_directions, 0))
    np.testing.assert_allclose(cosines, 1.0, atol=1e-10)
    assert rot.q_over_trace == pytest.approx(fab.q_over_trace, abs=1e-12)


def test_relabelling_changes_nothing():
    net = irregular_network()
    rng = np.random.default_rng(3)
    other = net.relabelled(rng.permutation(net.n_particles), rng.permutation(net.n_pairs),
                           rng.permutation(net.n_points))
    for level in ("points", "pairs"):
        a = Fabric(level).compute(net).descriptors()
        b = Fabric(level).compute(other).descriptors()
        assert a.keys() == b.keys()
        for name in a:
            assert b[name] == pytest.approx(a[name], abs=1e-10, nan_ok=True), name


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("level", ["points", "pairs"])
def test_matches_loop_based_twin(d, level):
    net = irregular_network(d=d, seed=d)
    fab = Fabric(level).compute(net)
    tensors, anisotropies, e1 = loop_fabric(net, level)
    assert abs(fab.stress_directions[:, 0] @ e1) == pytest.approx(1.0, abs=1e-12)
    for name, value in tensors.items():
        np.testing.assert_allclose(fab.tensors[name], value, atol=1e-12, err_msg=name)
    for name, value in anisotropies.items():
        assert fab.anisotropies[name] == pytest.approx(value, abs=1e-12), name
    assert fab.contact_components.size == (np.sum(net.active_points()) if level == "points"
                                           else np.sum(net.active_pairs()))
    assert fab.branch_components.size == np.sum(net.active_pairs())


def test_branch_frame_equals_contact_frame_for_frictionless_spheres():
    fab = Fabric().compute(sample_3d(20_000, A_C, A_FN, 0.0, seed=15))
    a = fab.anisotropies
    assert a["a_ft"] == pytest.approx(0.0, abs=1e-12)
    for name in ("a_c", "a_ln", "a_fn", "a_ft"):
        assert a[name + "_branch"] == pytest.approx(a[name], abs=1e-12), name
    for name in ("F", "chi_ln", "chi_fn", "chi_ft"):
        np.testing.assert_allclose(fab.tensors[name + "_branch"], fab.tensors[name],
                                   atol=1e-12, err_msg=name)


def test_partial_anisotropies_add_up(tilted_network):
    fab = Fabric().compute(tilted_network)
    partial = fab.partial_anisotropies
    assert set(partial) == {"k0", "k1", "k2"}
    for name in ("a_c_branch", "a_ln_branch", "a_fn_branch", "a_ft_branch"):
        total = sum(values[name] for values in partial.values())
        assert total == pytest.approx(fab.anisotropies[name], abs=1e-12), name
    assert sum(v["pair_fraction"] for v in partial.values()) == pytest.approx(1.0)
    assert sum(fab.partial_q_over_trace_harmonic.values()) == pytest.approx(
        fab.q_over_trace_harmonic["branch_first_order"], abs=1e-12)
    assert sum(fab.partial_q_over_trace.values()) == pytest.approx(fab.q_over_trace, abs=1e-12)
    # types drawn at random: each carries its share of every anisotropy (sampling error)
    for values in partial.values():
        share = values["pair_fraction"]
        assert values["a_c_branch"] == pytest.approx(share * fab.anisotropies["a_c_branch"],
                                                     abs=TOL)
        assert values["a_fn_branch"] == pytest.approx(share * fab.anisotropies["a_fn_branch"],
                                                      abs=TOL)
    d = fab.descriptors()
    assert d["a_c_branch_k2"] == partial["k2"]["a_c_branch"]
    assert d["q_over_trace_27b_k0"] == fab.partial_q_over_trace_harmonic["k0"]


def test_two_dimensional_fourier_anisotropies():
    a_c, a_fn, a_ft = 0.4, 0.5, 0.2
    fab = Fabric().compute(sample_2d(N_SAMPLES, a_c, a_fn, a_ft, axis_angle=0.7, seed=16))
    e1 = fab.stress_directions[:, 0]
    assert abs(e1 @ [np.cos(0.7), np.sin(0.7)]) > 0.999
    expected = model_2d(a_c, a_fn, a_ft)
    for name in ("a_c", "a_fn", "a_ft"):
        assert fab.anisotropies[name] == pytest.approx(expected[name], abs=TOL), name
    assert fab.anisotropies["a_c"] == pytest.approx(a_c, abs=TOL)  # no cross term in a_c
    assert fab.q_over_trace == pytest.approx(expected["q_over_trace"], abs=TOL)
    # first order misses only second-order cross terms, bounded by a_c (a_fn + a_ft) / 2
    assert 0 < 0.5 * (a_c + a_fn + a_ft) - fab.q_over_trace < 0.5 * a_c * (a_fn + a_ft)
    assert fab.q_over_trace_harmonic["contact_first_order"] == pytest.approx(fab.q_over_trace,
                                                                         abs=1e-10)
    assert np.isnan(fab.q_over_trace_harmonic["contact_second_order"])
    for name in ("a_c", "a_fn", "a_ft"):  # 2D: the magnitude form equals the projected one
        assert fab.magnitude_anisotropies[name + "_mag"] == pytest.approx(
            fab.anisotropies[name], abs=1e-3), name


def test_results_before_compute_raise():
    fab = Fabric()
    for name in ("stress_directions", "tensors", "anisotropies", "misalignment_deg",
                 "q_over_trace_harmonic", "partial_anisotropies", "partial_q_over_trace_harmonic",
                 "mean_normal_force", "mean_radial_force", "mean_normal_length",
                 "mean_branch_length"):
        with pytest.raises(NotComputedError):
            getattr(fab, name)
    with pytest.raises(NotComputedError):
        fab.descriptors()
    with pytest.raises(InputError):
        Fabric(frame_level="contacts")


def test_no_active_contact_gives_nan():
    net = sample_3d(10, 0.0, 0.0, 0.0, seed=18, n_types=2)
    unloaded = ContactNetwork(**{**{k: getattr(net, k) for k in net.__dataclass_fields__},
                                 "point_forces": np.zeros((10, 3))})
    d = Fabric().compute(unloaded).descriptors()
    assert d["n_contact_entries"] == 0 and d["n_branch_entries"] == 0
    assert np.isnan(d["a_c"]) and np.isnan(d["q_over_trace_27b"]) and np.isnan(d["q_over_trace"])
    assert np.isnan(d["a_c_branch_k1"])
