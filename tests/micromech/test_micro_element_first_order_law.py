"""The first-order C_bar distribution law (seed 001 Table 2.1, eq. 2.35 cut at order 1):
G^n = (V^n/V)(2I - C_bar^-1 C^n) by hand, its sum (eq. 2.28), its tangent (eq. 2.31), its
negative strain shares, and the model and lab paths that use it."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.contact.spring_contact import SpringContactLaw
from grainlab.errors import InputError
from grainlab.lab.element_test import run_element_test
from grainlab.lab.micro_element_setup import build_model, build_structure, default_path_parameters
from grainlab.lab.presets import preset
from grainlab.micromech.micro_element import MicroElementModel
from grainlab.micromech.micro_element.first_order_law import (
    first_order_tensors,
    strain_share_eigenvalues,
)
from grainlab.micromech.micro_element.structures import idealized_material


def test_two_micro_elements_by_hand():
    """C_bar = [[2, 1], [1, 2]], C^1 = I, C^2 = 2 C_bar - I, V^n/V = 1/2 (worked by hand):
    C_bar^-1 = [[2, -1], [-1, 2]]/3, G^1 = [[2/3, 1/6], [1/6, 2/3]],
    G^2 = [[1/3, -1/6], [-1/6, 1/3]], C = C^1 G^1 + C^2 G^2 = [[4/3, 1/3], [1/3, 4/3]]."""
    c_bar = np.array([[2.0, 1.0], [1.0, 2.0]])
    c_local = np.array([np.eye(2), 2.0 * c_bar - np.eye(2)])
    g, tangent = first_order_tensors(c_local, c_bar, np.array([0.5, 0.5]))
    np.testing.assert_allclose(g[0], [[2 / 3, 1 / 6], [1 / 6, 2 / 3]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(g[1], [[1 / 3, -1 / 6], [-1 / 6, 1 / 3]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(tangent, [[4 / 3, 1 / 3], [1 / 3, 4 / 3]], rtol=0, atol=1e-15)
    # (V/V^n) G^n = 2 G^n: eigenvalues 2/3 +- 1/3 ... (1, 5/3) and (1/3, 1)
    np.testing.assert_allclose(strain_share_eigenvalues(c_local, c_bar),
                               [[1.0, 5 / 3], [1 / 3, 1.0]], rtol=0, atol=1e-15)


def test_a_micro_element_stiffer_than_twice_the_average_strains_against_the_overall():
    """V^1/V = 1/4, C^1 = diag(3, 1), C^2 = diag(1/3, 1): C_bar = I and
    (V/V^1) G^1 = 2I - C^1 = diag(-1, 1): G^1 is not positive definite."""
    c_local = np.array([np.diag([3.0, 1.0]), np.diag([1 / 3, 1.0])])
    weights = np.array([0.25, 0.75])
    c_bar = np.tensordot(weights, c_local, axes=1)
    np.testing.assert_allclose(c_bar, np.eye(2), rtol=0, atol=1e-15)
    g, _ = first_order_tensors(c_local, c_bar, weights)
    np.testing.assert_allclose(g[0], np.diag([-0.25, 0.25]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(strain_share_eigenvalues(c_local, c_bar),
                               [[-1.0, 1.0], [1.0, 5 / 3]], rtol=0, atol=1e-15)


def random_unit(rng, n, k):
    """n random symmetric positive semi-definite C^n (k x k) [Pa] and volume fractions."""
    a = rng.normal(size=(n, k, k)) * rng.uniform(0.1, 3.0, size=(n, 1, 1))
    c_local = 1e8 * a @ np.swapaxes(a, 1, 2)
    weights = rng.uniform(0.5, 2.0, size=n)
    return c_local, weights / weights.sum()


@pytest.mark.parametrize("k", [3, 6])
def test_matches_the_formula_sums_to_identity_and_softens_the_average(k):
    """Against numpy: G^n = w_n (2I - C_bar^-1 C^n); sum_n G^n = 2I - C_bar^-1 C_bar = I
    (eq. 2.28, no normalisation A needed); C = sum C^n G^n = C_bar - sum w_n (C^n - C_bar)
    C_bar^-1 (C^n - C_bar), so C_bar - C is positive semi-definite (the law can soften the
    unit below its average stiffness, which the homogeneous law C = C_bar cannot)."""
    rng = np.random.default_rng(7)
    c_local, weights = random_unit(rng, 40, k)
    c_bar = np.tensordot(weights, c_local, axes=1)
    g, tangent = first_order_tensors(c_local, c_bar, weights)
    inverse = np.linalg.inv(c_bar)
    expected = weights[:, None, None] * (2.0 * np.eye(k) - inverse @ c_local)
    np.testing.assert_allclose(g, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(g.sum(axis=0), np.eye(k), rtol=0, atol=1e-12)
    spread = c_local - c_bar
    identity = c_bar - np.einsum("n,nij,jk,nkl->il", weights, spread, inverse, spread)
    np.testing.assert_allclose(tangent, identity, rtol=0, atol=1e-6 * np.abs(c_bar).max())
    np.testing.assert_allclose(tangent, tangent.T, rtol=0, atol=1e-6 * np.abs(c_bar).max())
    assert np.linalg.eigvalsh(c_bar - tangent)[0] >= -1e-7 * np.abs(c_bar).max()
    shares = strain_share_eigenvalues(c_local, c_bar)
    np.testing.assert_allclose(
        shares, np.sort(np.linalg.eigvals(2.0 * np.eye(k) - inverse @ c_local).real, axis=-1),
        rtol=0, atol=1e-9)


@pytest.fixture(scope="module")
def sheared():
    """The idealized material under the first-order law, consolidated and sheared a little
    (triaxial compression, 40 steps: sliding and heterogeneous micro-elements)."""
    law = SpringContactLaw(normal_stiffness=1e5, shear_stiffness=1e5,
                           friction_angle=np.radians(25.0))
    model = MicroElementModel(idealized_material(seed=1), law,
                              distribution="maxwellian-first-order")
    model.consolidate_isotropically(1e5)
    run_element_test(model, preset("triaxial_compression", confining=1e5, axial_strain=4e-3,
                                   n_steps=40, consolidation_steps=0))
    return model


def test_model_distributes_by_the_formula_from_its_own_local_stiffness(sheared):
    """The model's G^n and tangent are the formula applied to its own C^n and V^n/V
    (computed here with numpy), and its descriptors are the eigenvalues of (V/V^n) G^n."""
    c_local = sheared.local_stiffness()
    weights = sheared.state.volumes / sheared.volume
    c_bar = np.tensordot(weights, c_local, axes=1)
    expected = weights[:, None, None] * (2.0 * np.eye(6) - np.linalg.solve(c_bar, c_local))
    g = sheared.distribution_tensors()
    np.testing.assert_allclose(g, expected, rtol=0, atol=1e-9)
    tangent = np.einsum("nij,njk->ik", c_local, expected)
    np.testing.assert_allclose(sheared.tangent(), 0.5 * (tangent + tangent.T), rtol=0,
                               atol=1e-9 * np.abs(c_bar).max())
    own = np.linalg.eigvals(g / weights[:, None, None]).real.min(axis=1)
    described = sheared.descriptors()
    assert described["strain_share_lowest_eigenvalue"] == pytest.approx(own.min(), abs=1e-9)
    assert described["strain_share_negative_fraction"] == pytest.approx(np.mean(own < 0.0))


def test_readings_are_named_and_differ():
    """'maxwellian-first-order' is offered by name next to the other laws and gives another
    distribution than the full series with C_bar; a misspelt law is refused by name."""
    structure = build_structure("idealized", seed=2)
    first = build_model(structure, distribution="maxwellian-first-order")
    full = build_model(structure, distribution="maxwellian", maxwellian_reference="average")
    assert first.describe()["distribution"] == "maxwellian-first-order"
    assert not np.allclose(first.distribution_tensors(), full.distribution_tensors())
    with pytest.raises(InputError, match="--distribution"):
        build_model(structure, distribution="first_order")


@pytest.mark.parametrize("b", [0.0, 0.6, 1.0])
def test_constant_sigma3_path_holds_sigma3_and_b_on_the_model(b):
    """The cubical path at constant sigma_3 on the first-order model: on every row where
    the driver met its stress targets, sigma_yy = sigma_3 = the confining stress, sigma_yy is
    the minor principal stress, b = (sigma_xx - sigma_yy)/(sigma_zz - sigma_yy) is the one
    asked for (driver tolerance 1e-4 of |sigma|), no shear stress, and p grows."""
    model = build_model(build_structure("idealized", seed=1),
                        distribution="maxwellian-first-order")
    parameters = default_path_parameters("cubical_constant_sigma3", model, n_steps=40)
    parameters.update(b=b)
    table = run_element_test(model, preset("cubical_constant_sigma3", **parameters)).table
    rows = table[table["converged"] & (table["step"] > 0)]
    assert len(rows) >= 10
    size = np.sqrt((rows[["sigma_xx", "sigma_yy", "sigma_zz"]] ** 2).sum(axis=1)).to_numpy()
    confining = parameters["confining"]
    assert np.all(np.abs(rows["sigma_yy"] - confining).to_numpy() <= 1e-4 * size)
    assert np.all(np.abs(rows["sigma_3"] - rows["sigma_yy"]).to_numpy() <= 1e-4 * size)
    q = (rows["sigma_zz"] - rows["sigma_yy"]).to_numpy()
    late = q > 0.2 * confining  # b is a ratio: read it where the deviator is not small
    assert late.sum() >= 5
    measured = ((rows["sigma_xx"] - rows["sigma_yy"]).to_numpy() / q)[late]
    assert np.all(np.abs(measured - b) <= 1e-4 * size[late] / q[late])
    assert np.all(np.abs(rows[["sigma_yz", "sigma_xz", "sigma_xy"]].to_numpy())
                  <= 1e-4 * size[:, None])
    assert rows["p"].iloc[-1] > confining
