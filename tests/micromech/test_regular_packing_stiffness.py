"""The stiffness D of a regular packing (seed 000 eqs. 13–16): closed forms and tensor
symmetries.

Conventions: dsigma = D deps with sigma = [s_xx, s_yy, s_xy], eps = [e_xx, e_yy, gamma_xy],
gamma_xy = 2 e_xy (engineering shear); D includes 1/V.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.contact import LinearSpring2D, ModifiedHertzMindlin2D
from grainlab.geometry.rotation import rotation_matrix_2d
from grainlab.micromech.regular_packing import RegularPackingModel, consolidate_isotropically
from grainlab.prep.regular_packings import named_packing

KN, KT = 3.0e8, 1.1e8
P0 = 17.24e3  # seed 000's isotropic stress [Pa]
VOIGT = {(0, 0): 0, (1, 1): 1, (0, 1): 2, (1, 0): 2}


def linear_law():
    return LinearSpring2D(KN, KT, np.radians(15.0))


def linear_state(model):
    """Forces of an isotropic state (linear law); D does not depend on them while no contact
    slides or opens."""
    return consolidate_isotropically(model, P0, steps=2)


def voigt_to_tensor(D: np.ndarray) -> np.ndarray:
    """C_ijkl with sigma_ij = C_ijkl eps_kl: since D multiplies gamma = eps_xy + eps_yx,
    C_ijkl = D[v(ij), v(kl)] for every index pair."""
    C = np.zeros((2, 2, 2, 2))
    for (i, j), a in VOIGT.items():
        for (k, m), b in VOIGT.items():
            C[i, j, k, m] = D[a, b]
    return C


def tensor_to_voigt(C: np.ndarray) -> np.ndarray:
    D = np.zeros((3, 3))
    for (i, j), a in VOIGT.items():
        for (k, m), b in VOIGT.items():
            D[a, b] = C[i, j, k, m]
    return D


def transform_voigt(D: np.ndarray, Q: np.ndarray) -> np.ndarray:
    C = voigt_to_tensor(D)
    return tensor_to_voigt(np.einsum("ia,jb,kc,ld,abcd->ijkl", Q, Q, Q, Q, C))


def brute_force_stiffness(model, kn, kt) -> np.ndarray:
    """Slow twin of D: apply each unit Voigt strain, move every contact spring by eps l,
    take its force in the (n, t) frame, and average the dyads f (x) l over the cell."""
    c = model.contacts
    D = np.zeros((3, 3))
    for b, unit in enumerate(np.eye(3)):
        eps = np.array([[unit[0], unit[2] / 2], [unit[2] / 2, unit[1]]])
        sigma = np.zeros((2, 2))
        for k in range(c.n_contacts):
            du = eps @ c.branch[k]
            n, t = c.normal[k], c.tangent[k]
            force = kn[k] * (du @ n) * n + kt[k] * (du @ t) * t
            sigma += np.outer(force, c.branch[k])
        sigma = 0.5 * (sigma + sigma.T) / model.area
        D[:, b] = [sigma[0, 0], sigma[1, 1], sigma[0, 1]]
    return D


def test_square_packing_closed_form():
    """Contacts l = (d, 0) and (0, d), V = d^2. Stretching x loads only the first spring:
    D11 = kn d^2 / d^2 = kn. A shear gamma moves each spring tangentially by gamma d / 2; each
    gives a dyad kt d^2 gamma / 2 on one off-diagonal entry, and the symmetric part averages
    them: sigma_xy = kt gamma / 2, D33 = kt / 2."""
    model = RegularPackingModel(named_packing("square"), linear_law())
    D = model.stiffness_matrix(linear_state(model))
    np.testing.assert_allclose(
        D, [[KN, 0.0, 0.0], [0.0, KN, 0.0], [0.0, 0.0, KT / 2]], atol=1e-9 * KN
    )
    scaled = RegularPackingModel(named_packing("square").scaled(4.0), linear_law())
    np.testing.assert_allclose(scaled.stiffness_matrix(linear_state(scaled)), D, rtol=1e-12,
                               atol=1e-9 * KN)


def test_hexagonal_packing_is_isotropic():
    model = RegularPackingModel(named_packing("hexagonal"), linear_law())
    D = model.stiffness_matrix(linear_state(model))
    assert D[0, 0] == pytest.approx(D[1, 1], rel=1e-12)
    assert D[2, 2] == pytest.approx((D[0, 0] - D[0, 1]) / 2, rel=1e-12)
    assert abs(D[0, 2]) < 1e-12 * D[0, 0] and abs(D[1, 2]) < 1e-12 * D[0, 0]
    # closed form: three contacts per cell, V = sqrt3/2 d^2, sum of n^4 terms over
    # 0, 60, 120 deg: D11 = (2/sqrt3) (9 kn + 3 kt) / 8, D12 = (2/sqrt3) 3 (kn - kt) / 8
    assert D[0, 0] == pytest.approx(2 / np.sqrt(3) * (9 * KN + 3 * KT) / 8, rel=1e-12)
    assert D[0, 1] == pytest.approx(2 / np.sqrt(3) * 3 * (KN - KT) / 8, rel=1e-12)


@pytest.mark.parametrize("name", ["square", "rhombic", "hexagonal", "A", "B", "C"])
def test_stiffness_matches_brute_force_twin(name):
    model = RegularPackingModel(named_packing(name), ModifiedHertzMindlin2D.seed000())
    state = consolidate_isotropically(model, P0)
    kn, kt = model.contact_stiffness(state)
    np.testing.assert_allclose(
        model.stiffness_matrix(state), brute_force_stiffness(model, kn, kt), rtol=1e-12,
        atol=1e-12 * np.max(kn),
    )


@pytest.mark.parametrize("name", ["A", "B", "C", "hexagonal"])
def test_symmetric_positive_definite_under_isotropic_stress(name):
    model = RegularPackingModel(named_packing(name), ModifiedHertzMindlin2D.seed000())
    state = consolidate_isotropically(model, P0)
    np.testing.assert_allclose(model.stress(state), [P0, P0, 0.0], rtol=1e-9, atol=1e-9 * P0)
    D = model.stiffness_matrix(state)
    np.testing.assert_allclose(D, D.T, rtol=1e-14, atol=1e-14 * np.abs(D).max())
    assert np.linalg.eigvalsh(D)[0] > 0.0


def test_linear_stiffness_is_the_secant_of_small_strains():
    """D predicts the stress change of a small strain increment (no sliding, linear law)."""
    model = RegularPackingModel(named_packing("C"), linear_law())
    state = linear_state(model)
    assert not np.any(state.contacts.sliding)
    D = model.stiffness_matrix(state)
    rng = np.random.default_rng(0)
    strain_scale = P0 / KN * 1e-4
    for _ in range(5):
        deps = rng.normal(size=3) * strain_scale
        change = model.stress(model.update(state, deps)) - model.stress(state)
        np.testing.assert_allclose(change, D @ deps, rtol=1e-7, atol=1e-9 * np.abs(change).max())


def test_hertz_mindlin_stiffness_is_the_tangent_of_normal_loading():
    """Isotropic strain keeps contacts of the square packing free of shear: dsigma = D deps
    to first order in the Hertz-Mindlin law too."""
    model = RegularPackingModel(named_packing("square"), ModifiedHertzMindlin2D.seed000())
    state = consolidate_isotropically(model, P0)
    D = model.stiffness_matrix(state)
    deps = np.array([1.0, 1.0, 0.0]) * 1e-9
    change = model.stress(model.update(state, deps)) - model.stress(state)
    np.testing.assert_allclose(change[:2], (D @ deps)[:2], rtol=1e-5)


@pytest.mark.parametrize("name", ["square", "rhombic", "A", "B", "C"])
@pytest.mark.parametrize("angle", [0.37, -1.2, np.pi / 2])
def test_rotation_rotates_the_stiffness_tensor_linear(name, angle):
    packing = named_packing(name)
    model = RegularPackingModel(packing, linear_law())
    rotated = RegularPackingModel(packing.rotated(angle), linear_law())
    D = model.stiffness_matrix(linear_state(model))
    D_rot = rotated.stiffness_matrix(linear_state(rotated))
    expected = transform_voigt(D, rotation_matrix_2d(angle))
    np.testing.assert_allclose(D_rot, expected, rtol=1e-9, atol=1e-9 * np.abs(D).max())


@pytest.mark.parametrize("name", ["A", "C"])
def test_rotation_rotates_the_stiffness_tensor_hertz_mindlin(name):
    angle = 0.61
    packing = named_packing(name)
    law = ModifiedHertzMindlin2D.seed000()
    model = RegularPackingModel(packing, law)
    rotated = RegularPackingModel(packing.rotated(angle), law)
    D = model.stiffness_matrix(consolidate_isotropically(model, P0))
    D_rot = rotated.stiffness_matrix(consolidate_isotropically(rotated, P0))
    expected = transform_voigt(D, rotation_matrix_2d(angle))
    np.testing.assert_allclose(D_rot, expected, rtol=1e-7, atol=1e-7 * np.abs(D).max())


def test_transform_voigt_helper_is_a_tensor_rotation():
    """The helper itself: an isotropic D is unchanged by any rotation, and a quarter turn
    swaps D11 and D22."""
    lam, mu = 2.0, 3.0
    iso = np.array([[lam + 2 * mu, lam, 0], [lam, lam + 2 * mu, 0], [0, 0, mu]])
    np.testing.assert_allclose(transform_voigt(iso, rotation_matrix_2d(0.8)), iso, atol=1e-12)
    D = np.array([[5.0, 1.0, 0.5], [1.0, 2.0, -0.3], [0.5, -0.3, 1.5]])
    quarter = transform_voigt(D, rotation_matrix_2d(np.pi / 2))
    assert quarter[0, 0] == pytest.approx(2.0) and quarter[1, 1] == pytest.approx(5.0)
    assert quarter[0, 2] == pytest.approx(0.3) and quarter[1, 2] == pytest.approx(-0.5)


@pytest.mark.parametrize("name", ["rhombic", "A", "C"])
def test_mirror_flips_the_coupling_terms(name):
    mirror = np.diag([-1.0, 1.0])
    packing = named_packing(name)
    model = RegularPackingModel(packing, linear_law())
    mirrored = RegularPackingModel(packing.transformed(mirror), linear_law())
    D = model.stiffness_matrix(linear_state(model))
    D_m = mirrored.stiffness_matrix(linear_state(mirrored))
    flip = np.array([[1, 1, -1], [1, 1, -1], [-1, -1, 1]])
    np.testing.assert_allclose(D_m, flip * D, rtol=1e-9, atol=1e-9 * np.abs(D).max())
    np.testing.assert_allclose(D_m, transform_voigt(D, mirror), rtol=1e-9,
                               atol=1e-9 * np.abs(D).max())
    if name == "rhombic":  # no mirror symmetry: the coupling is really there
        assert abs(D[0, 2]) > 1e-3 * D[0, 0]


@pytest.mark.parametrize("name", ["A", "C"])
def test_mirror_symmetric_packing_has_no_coupling(name):
    """A and C are mirror-symmetric about the y axis; D13 = -D13 = 0 under isotropic stress,
    for Hertz–Mindlin contacts too."""
    model = RegularPackingModel(named_packing(name), ModifiedHertzMindlin2D.seed000())
    D = model.stiffness_matrix(consolidate_isotropically(model, P0))
    assert abs(D[0, 2]) <= 1e-9 * D[0, 0]
    assert abs(D[1, 2]) <= 1e-9 * D[0, 0]
