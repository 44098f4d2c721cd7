"""Compiled micro-element kernels against slow, obviously right NumPy twins (STYLE.md 12):
the local stiffness with the non-affine move and the particle spin (eqs. 2.5, 2.14–2.18), the
Maxwellian series and distribution (eqs. 2.31–2.35), the stretch map (eqs. 2.13–2.15, 2.27),
the stress and contact counts; the parallel kernels against the serial ones."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainlab.micromech.micro_element import exponential_series
from grainlab.micromech.micro_element import kernels as k
from grainlab.micromech.micro_element.distribution_kernels import (
    distribute_parallel,
    distribute_serial,
    maxwellian_tensors,
    relative_stiffness,
    series_parallel,
    series_serial,
)
from grainlab.micromech.micro_element.structures import binary_units, idealized_material
from grainlab.micromech.micro_element.tensor_basis import bases


def random_structure(dimension, n_elements=37, max_contacts=6, seed=0):
    """Branches, a mask with 1..M contacts per micro-element (padding zero), stiffnesses
    (some k_r = 0, as sliding contacts) and volumes."""
    rng = np.random.default_rng(seed)
    branches = rng.normal(size=(n_elements, max_contacts, dimension)) * 1e-3
    counts = rng.integers(1, max_contacts + 1, n_elements)
    mask = np.arange(max_contacts)[None, :] < counts[:, None]
    branches[~mask] = 0.0
    kn = rng.uniform(0.5e5, 2e5, mask.shape)
    kr = rng.uniform(0.0, 1e5, mask.shape) * (rng.random(mask.shape) > 0.2)
    volumes = rng.uniform(1e-9, 3e-9, n_elements)
    return branches, mask, kn, kr, volumes


def twin_local_stiffness(branches, mask, kn, kr, volumes, non_affine, spin):
    """The local stiffness with explicit loops: K, T = -[sum K]^+ [sum K L], P = delta L + T,
    C_ij,kl = (1/2V) sum K_ip P_p(kl) L_j on full tensors, then the Voigt/skew blocks."""
    n_elements, n_contacts, d = branches.shape
    s, w, s_dual, w_dual = bases(d)
    n_v = s.shape[1]
    t_all, c_all, spin_all = [], [], []
    for e in range(n_elements):
        stiff = {}
        for m in range(n_contacts):
            if mask[e, m]:
                n = branches[e, m] / np.linalg.norm(branches[e, m])
                stiff[m] = kn[e, m] * np.outer(n, n) + kr[e, m] * (np.eye(d) - np.outer(n, n))
        a = sum(stiff.values())
        b = sum(np.einsum("qk,l->qkl", kk, branches[e, m]).reshape(d, d * d)
                for m, kk in stiff.items())
        t = -np.linalg.pinv(a, rcond=1e-12) @ b if non_affine and len(stiff) >= 2 else (
            np.zeros((d, d * d)))
        c = np.zeros((d * d, d * d))
        for m, kk in stiff.items():
            p = np.einsum("pk,l->pkl", np.eye(d), branches[e, m]).reshape(d, d * d) + t
            c += np.einsum("iq,j->ijq", kk @ p, branches[e, m]).reshape(d * d, d * d)
        c /= 2.0 * volumes[e]
        c_ss, c_sw, c_ws, c_ww = s_dual @ c @ s, s_dual @ c @ w, w_dual @ c @ s, w_dual @ c @ w
        spin_map = np.zeros((w.shape[1], n_v))
        if spin == "micro-element":
            spin_map = -np.linalg.pinv(c_ww, rcond=1e-12) @ c_ws
        t_all.append(t)
        c_all.append(c_ss + c_sw @ spin_map)
        spin_all.append(spin_map)
    return np.array(t_all), np.array(c_all), np.array(spin_all)


@pytest.mark.parametrize("dimension", [2, 3])
@pytest.mark.parametrize("spin", ["none", "micro-element"])
def test_local_stiffness_matches_the_loop_twin(dimension, spin):
    branches, mask, kn, kr, volumes = random_structure(dimension)
    kr[:, 0] = np.maximum(kr[:, 0], 1e4)  # every micro-element resists a spin
    for non_affine in (True, False):
        t, blocks, spin_map, c_local = k.condense_local_stiffness(
            branches, mask, kn, kr, volumes, non_affine, spin)
        t_twin, c_twin, spin_twin = twin_local_stiffness(branches, mask, kn, kr, volumes,
                                                         non_affine, spin)
        scale = np.abs(c_twin).max()
        np.testing.assert_allclose(t, t_twin, rtol=0, atol=1e-9 * np.abs(t_twin).max() + 1e-300)
        np.testing.assert_allclose(c_local, c_twin, rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(spin_map, spin_twin, rtol=0,
                                   atol=1e-8 * max(np.abs(spin_twin).max(), 1.0))
        assert blocks.shape[1] == (c_local.shape[1] if spin == "none" else
                                   c_local.shape[1] + (1 if dimension == 2 else 3))


@pytest.mark.long
def test_spin_without_rotational_stiffness_takes_no_spin():
    """Contacts without tangential stiffness (k_r = 0) leave C_ww zero up to round-off: the
    spin map is zero and C^n the Voigt block, not the inverse of round-off."""
    structure = idealized_material(seed=3)
    kn = np.full(structure.mask.shape, 1e5)
    _, blocks, spin_map, c_local = k.condense_local_stiffness(
        structure.branches, structure.mask, kn, np.zeros_like(kn), structure.volumes, True,
        "micro-element")
    assert np.all(spin_map == 0.0)
    np.testing.assert_array_equal(c_local, blocks[:, :6, :6])


def sequential_series(v, order):
    """Eq. 2.35 term by term (term_n = -term_(n-1) v / n) with the same scaling and squaring,
    and the relative size of the last term."""
    norm = float(np.max(np.abs(v).sum(axis=-1)))
    squarings = max(0, int(np.ceil(np.log2(norm))) + 1) if norm > 0.5 else 0
    scaled = v / 2.0**squarings
    total = np.broadcast_to(np.eye(v.shape[-1]), v.shape).copy()
    term = total.copy()
    for n in range(1, order + 1):
        term = -term @ scaled / n
        total = total + term
    last = float(np.max(np.abs(term))) / float(np.max(np.abs(total)))
    for _ in range(squarings):
        total = total @ total
    return total, last


@pytest.mark.parametrize("order", [1, 2, 3, 5, 9, 16, 23])
def test_series_matches_the_term_by_term_sum(order):
    rng = np.random.default_rng(order)
    v = 0.8 * rng.normal(size=(40, 6, 6))
    series, last = exponential_series(v, order)
    twin, twin_last = sequential_series(v, order)
    np.testing.assert_allclose(series, twin, rtol=0, atol=1e-12 * np.abs(twin).max())
    assert last == pytest.approx(twin_last, rel=1e-10)


def test_distribution_tensors_and_tangent_match_numpy():
    rng = np.random.default_rng(5)
    c_local = rng.normal(size=(70, 6, 6)) * 1e7
    c_local = c_local @ np.swapaxes(c_local, 1, 2) + 1e8 * np.eye(6)
    weights = rng.uniform(0.5, 1.5, 70)
    weights /= weights.sum()
    c_bar = np.tensordot(weights, c_local, axes=1)
    v, norm = relative_stiffness(c_local, c_bar, np.linalg.inv(c_bar))
    np.testing.assert_allclose(v, np.linalg.inv(c_bar) @ (c_local - c_bar), atol=1e-12)
    assert norm == pytest.approx(np.abs(v).sum(axis=2).max(), rel=1e-14)
    exp_v, _ = exponential_series(v, 16, norm=norm)
    a = np.linalg.inv(np.tensordot(weights, exp_v, axes=1))
    g, tangent = maxwellian_tensors(a, exp_v, weights, c_local)
    g_twin = (a @ exp_v) * weights[:, None, None]
    np.testing.assert_allclose(g, g_twin, rtol=0, atol=1e-14)
    np.testing.assert_allclose(tangent, (c_local @ g_twin).sum(axis=0), rtol=1e-12)
    np.testing.assert_allclose(g.sum(axis=0), np.eye(6), atol=1e-12)  # eq. 2.28


def twin_stretch(g, d_eps, weights, spin_map, branches, mask, t, with_spin):
    """Approaches P (S eps^n + W w) with P = delta L + T, translations, volumetric strain."""
    d = branches.shape[2]
    s, w, _, _ = bases(d)
    local = (g @ d_eps) / weights[:, None]
    spin = (spin_map @ local[:, :, None])[..., 0] if with_spin else np.zeros(
        (len(weights), w.shape[1]))
    full = local @ s.T + spin @ w.T
    p = np.einsum("pk,eml->empkl", np.eye(d), branches).reshape(*branches.shape, d * d)
    p = np.where(mask[..., None, None], p + t[:, None], 0.0)
    approach = np.einsum("empq,eq->emp", p, full)
    rotation = (spin @ w.T).reshape(-1, d, d)
    translation = approach - np.einsum("eij,emj->emi", rotation, branches)
    volumetric = np.trace((local @ s.T).reshape(-1, d, d), axis1=1, axis2=2)
    return approach, translation, volumetric


@pytest.mark.parametrize("dimension", [2, 3])
def test_stretch_map_matches_the_einsum_twin(dimension):
    branches, mask, kn, kr, volumes = random_structure(dimension, seed=2)
    t, _, spin_map, _ = k.condense_local_stiffness(branches, mask, kn + 1.0, kr + 1e4,
                                                   volumes, True, "micro-element")
    rng = np.random.default_rng(3)
    n_v = 6 if dimension == 3 else 3
    g = rng.normal(size=(len(volumes), n_v, n_v)) / len(volumes)
    weights = volumes / volumes.sum()
    d_eps = rng.normal(size=n_v) * 1e-5
    s, w, _, _ = bases(dimension)
    for with_spin in (False, True):
        got = k.stretch(g, d_eps, weights, spin_map, s, w, branches, mask, t, with_spin)
        twin = twin_stretch(g, d_eps, weights, spin_map, branches, mask, t, with_spin)
        for a, b in zip(got, twin, strict=True):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
        assert np.all(got[0][~mask] == 0.0)


def test_stress_and_contact_census_match_numpy():
    rng = np.random.default_rng(4)
    branches, mask, _, _, _ = random_structure(3, seed=4)
    normals, lengths = k.unit_vectors(branches)
    np.testing.assert_allclose(lengths, np.linalg.norm(branches, axis=2))
    np.testing.assert_allclose(normals[mask], branches[mask] / lengths[mask][:, None])
    assert np.all(normals[~mask] == 0.0)
    fn = rng.normal(size=mask.shape)
    shear = rng.normal(size=branches.shape) * 0.3
    total = k.dyad_sum(fn, normals, shear, branches, mask)
    f = np.where(mask[..., None], fn[..., None] * normals + shear, 0.0)
    np.testing.assert_allclose(total, np.einsum("emi,emj->ij", f, branches), rtol=1e-12)
    sliding = rng.random(mask.shape) < 0.3
    bonded = rng.random(mask.shape) < 0.2
    mu = 0.5
    counts = k.contact_census(mask, fn, shear, sliding, bonded, mu)
    open_ = mask & (fn <= 0) & ~bonded
    closed = mask & ~open_
    limit = mu * np.maximum(fn, 0.0)
    magnitude = np.linalg.norm(shear, axis=2)
    mobilised = np.divide(magnitude, limit, out=np.zeros_like(limit), where=limit > 0)
    assert counts[:5] == (mask.sum(), (sliding & mask).sum(), open_.sum(),
                          (bonded & mask).sum(), closed.sum())
    assert counts[5] == pytest.approx(mobilised[closed].sum(), rel=1e-12)


@pytest.mark.long
def test_parallel_kernels_match_the_serial_ones():
    """Several chunks and a partial one: every micro-element written once, sums per chunk."""
    n = 3 * k.CHUNK + 5
    branches, mask, kn, kr, volumes = random_structure(3, n_elements=n, seed=6)
    basis = k.condensation_bases(3, True)
    outputs = []
    for kernel in (k.condense_serial, k.condense_parallel):
        out = (np.empty((n, 3, 9)), np.empty((n, 9, 9)), np.zeros((n, 3, 6)),
               np.empty((n, 6, 6)))
        inputs = (k.kernel_input(a) for a in (branches, mask, kn, kr, volumes))
        kernel(*inputs, True, 1, *basis, *out)  # the launcher's argument types
        outputs.append(out)
    for a, b in zip(*outputs, strict=True):
        np.testing.assert_array_equal(a, b)
    rng = np.random.default_rng(7)
    v = 0.5 * rng.normal(size=(n, 6, 6))
    coefficients = np.array([(-1.0) ** i / math.factorial(i) for i in range(17)])
    series = []
    for kernel in (series_serial, series_parallel):
        out = (np.empty((n, 6, 6)), np.empty(n), np.empty(n))
        kernel(v, coefficients, 4, 0.5, 1, *out)
        series.append(out)
    for a, b in zip(*series, strict=True):
        np.testing.assert_array_equal(a, b)
    weights = np.full(n, 1.0 / n)
    c_local = rng.normal(size=(n, 6, 6))
    g_s, g_p = np.empty((n, 6, 6)), np.empty((n, 6, 6))
    partial_s, partial_p = np.empty((1, 6, 6)), np.empty(((n + k.CHUNK - 1) // k.CHUNK, 6, 6))
    distribute_serial(np.eye(6), series[0][0], weights, c_local, g_s, partial_s)
    distribute_parallel(np.eye(6), series[0][0], weights, c_local, g_p, partial_p)
    np.testing.assert_array_equal(g_s, g_p)
    np.testing.assert_allclose(partial_s[0], partial_p.sum(axis=0), rtol=1e-12, atol=1e-12)


def test_binary_units_keep_their_single_contact_rigid():
    """One contact per micro-element: no non-affine move (T = 0), C^n = (1/2V) K L L."""
    structure = binary_units("icosahedron", radius=1e-3, void_ratio=0.6)
    kn = np.full(structure.mask.shape, 2e5)
    kr = np.full(structure.mask.shape, 5e4)
    t, _, _, c_local = k.condense_local_stiffness(structure.branches, structure.mask, kn, kr,
                                                  structure.volumes, True, "none")
    assert np.all(t == 0.0)
    _, c_twin, _ = twin_local_stiffness(structure.branches, structure.mask, kn, kr,
                                        structure.volumes, True, "none")
    np.testing.assert_allclose(c_local, c_twin, rtol=1e-12)
