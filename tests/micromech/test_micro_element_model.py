"""Seed 001's micro-element model: analytic limits, symmetries, objectivity, Coulomb, energy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from grainlab.contact.spring_contact import SpringContactLaw, force_vectors, mindlin_c2
from grainlab.errors import ConvergenceError, InputError, StrengthReached
from grainlab.micromech.micro_element import MicroElementModel, exponential_series
from grainlab.micromech.micro_element.small_strain import (
    poisson_ratio_eq41,
    shear_modulus_eq42,
    shear_modulus_uniform_strain,
)
from grainlab.micromech.micro_element.structures import binary_units, idealized_material

P0 = 100e3


def linear_law(phi_deg=25.0, ks_ratio=1.0, **bonds):
    return SpringContactLaw(normal_stiffness=1e5, shear_stiffness=ks_ratio * 1e5,
                            friction_angle=np.radians(phi_deg), **bonds)


@pytest.fixture(scope="module")
def idealized():
    return idealized_material(seed=3)


@pytest.mark.parametrize("nu_mu", [0.0, 0.15, 0.3, 0.45])
def test_binary_units_poisson_ratio_eq41_linear(nu_mu):
    structure = binary_units("icosahedron", radius=1e-3, void_ratio=0.6)
    law = SpringContactLaw(normal_stiffness=1e5, shear_stiffness=mindlin_c2(nu_mu) * 1e5,
                           friction_angle=0.5)
    model = MicroElementModel(structure, law, spin="uniform", update_geometry=False)
    model.consolidate_isotropically(P0)
    compliance = np.linalg.inv(model.tangent())
    assert -compliance[0, 1] / compliance[0, 0] == pytest.approx(poisson_ratio_eq41(nu_mu),
                                                                 abs=1e-12)
    # isotropy: D11 = D22 = D33, D44 = (D11 - D12)/2
    d = model.tangent()
    assert d[3, 3] == pytest.approx((d[0, 0] - d[0, 1]) / 2, rel=1e-10)


@pytest.mark.parametrize("pressure", [1e4, 1e5, 1e6])
def test_binary_units_hertz_shear_modulus(pressure):
    structure = binary_units("icosahedron", radius=0.5e-3, void_ratio=0.7,
                             coordination_number=7)
    law = SpringContactLaw(shear_modulus=29e9, poisson_ratio=0.2, friction_angle=0.5)
    model = MicroElementModel(structure, law, spin="uniform", update_geometry=False)
    model.consolidate_isotropically(pressure)
    z = structure.description["z_eq_4_4"]
    tangent = model.tangent()
    assert tangent[3, 3] == pytest.approx(
        shear_modulus_uniform_strain(z, 29e9, 0.2, pressure), rel=1e-10)
    compliance = np.linalg.inv(tangent)
    assert -compliance[0, 1] / compliance[0, 0] == pytest.approx(poisson_ratio_eq41(0.2),
                                                                 abs=1e-12)
    # The printed eq. 4.2 differs from the uniform-strain value by 2 (2 + 3 C2)/(2 + C2).
    c2 = mindlin_c2(0.2)
    assert shear_modulus_uniform_strain(z, 29e9, 0.2, pressure) / shear_modulus_eq42(
        z, 29e9, 0.2, pressure) == pytest.approx(2 * (2 + 3 * c2) / (2 + c2), rel=1e-12)


def test_micro_element_spin_balances_moments_in_the_elastic_range(idealized):
    model = MicroElementModel(idealized, linear_law(phi_deg=89.0), spin="micro-element",
                              update_geometry=False)
    model.consolidate_isotropically(P0)
    model.apply_strain(np.array([1e-5, -2e-5, 3e-5, 1e-5, 0.0, -1e-5]))
    stresses = model.micro_element_stresses()
    assert np.abs(stresses - np.swapaxes(stresses, 1, 2)).max() < 1e-6 * P0


def test_free_spin_of_a_binary_unit_releases_its_shear_stiffness():
    """With each binary unit balancing its own moment, a single contact cannot carry shear:
    only central forces remain and nu = 1/4 (why binary units use the uniform spin)."""
    structure = binary_units("icosahedron", radius=1e-3, void_ratio=0.6)
    model = MicroElementModel(structure, linear_law(), spin="micro-element",
                              update_geometry=False)
    model.consolidate_isotropically(P0)
    compliance = np.linalg.inv(model.tangent())
    assert -compliance[0, 1] / compliance[0, 0] == pytest.approx(0.25, abs=1e-12)


def loop_stress(model):
    """Slow twin of the model stress: (1/2V) sum f (x) L with explicit loops."""
    st = model.state
    total = np.zeros((3, 3))
    normals = model.normals
    for e in range(st.mask.shape[0]):
        for m in range(st.mask.shape[1]):
            if st.mask[e, m]:
                f = st.contacts.normal_force[e, m] * normals[e, m] + st.contacts.shear_force[e, m]
                total += np.outer(f, st.branches[e, m])
    return total / (2 * st.volumes.sum())


@pytest.mark.parametrize("distribution", ["homogeneous", "maxwellian"])
def test_stress_from_forces_is_the_applied_stress(idealized, distribution):
    model = MicroElementModel(idealized, linear_law(), distribution=distribution)
    model.consolidate_isotropically(P0)
    target = np.array([1.2, 0.9, 1.5, 0.05, -0.1, 0.08]) * P0
    model.solve_stress(target)
    np.testing.assert_allclose(model.stress(), target, rtol=0, atol=1e-8 * P0)
    tensor = loop_stress(model)
    np.testing.assert_allclose(model.stress_tensor(), tensor, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("non_affine", [True, False])
def test_local_stiffness_symmetric_and_distribution_sums_to_identity(idealized, non_affine):
    for distribution in ("homogeneous", "maxwellian"):
        model = MicroElementModel(idealized, linear_law(), distribution=distribution,
                                  non_affine=non_affine)
        model.consolidate_isotropically(P0)
        local = model.local_stiffness()
        np.testing.assert_allclose(local, np.swapaxes(local, 1, 2), rtol=0,
                                   atol=1e-9 * np.abs(local).max())
        g = model.distribution_tensors()
        np.testing.assert_allclose(g.sum(axis=0), np.eye(6), atol=1e-10)  # eq. 2.28
        assert np.linalg.eigvalsh(model.tangent())[0] > 0


def test_non_affine_move_balances_the_centre_particle(idealized):
    """Eq. 2.14: the centre moves so that the force increments on it sum to zero."""
    model = MicroElementModel(idealized, linear_law(phi_deg=80.0), non_affine=True,
                              update_geometry=False)
    model.consolidate_isotropically(P0)
    before = force_vectors(model.state.contacts, model.normals).sum(axis=1)
    model.apply_strain(np.array([1e-5, -2e-5, 3e-5, 1e-5, 0.0, -1e-5]))
    after = force_vectors(model.state.contacts, model.normals).sum(axis=1)
    scale = np.abs(force_vectors(model.state.contacts, model.normals)).max()
    np.testing.assert_allclose(after - before, 0.0, atol=1e-9 * scale)


def test_series_matches_the_matrix_exponential():
    rng = np.random.default_rng(0)
    v = 0.3 * rng.normal(size=(5, 6, 6))
    series, last = exponential_series(v, 30)
    np.testing.assert_allclose(series, np.stack([expm(-m) for m in v]), atol=1e-12)
    assert last < 1e-12


def test_unconverged_series_is_reported(idealized):
    from grainlab.errors import ConvergenceError

    model = MicroElementModel(idealized, linear_law(), distribution="maxwellian",
                              series_order=1)
    with pytest.raises(ConvergenceError, match="series"):
        model.consolidate_isotropically(P0)


def test_objectivity_rotating_structure_and_loading(idealized):
    angle = 0.6
    c, s = np.cos(angle), np.sin(angle)
    rotation = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    target = np.array([[1.4, 0.1, 0.0], [0.1, 0.9, 0.05], [0.0, 0.05, 1.1]]) * P0
    results = []
    for structure, stress in ((idealized, target),
                              (idealized.rotated(rotation), rotation @ target @ rotation.T)):
        model = MicroElementModel(structure, linear_law(phi_deg=20))
        model.consolidate_isotropically(P0)
        voigt = np.array([stress[0, 0], stress[1, 1], stress[2, 2], stress[1, 2], stress[0, 2],
                          stress[0, 1]])
        model.solve_stress(voigt)
        e = model.strain()
        results.append(np.array([[e[0], e[5] / 2, e[4] / 2], [e[5] / 2, e[1], e[3] / 2],
                                 [e[4] / 2, e[3] / 2, e[2]]]))
    np.testing.assert_allclose(results[1], rotation @ results[0] @ rotation.T, rtol=0,
                               atol=1e-7 * np.abs(results[0]).max())


def test_elastic_range_is_path_independent(idealized):
    a = np.array([2e-6, 0, -1e-6, 0, 1e-6, 0])
    b = np.array([0, -1e-6, 2e-6, 1e-6, 0, 0])
    stresses = []
    for order in ((a, b), (b, a)):
        model = MicroElementModel(idealized, linear_law(phi_deg=89.0), update_geometry=False)
        model.consolidate_isotropically(P0)
        for step in order:
            for _ in range(5):
                model.apply_strain(step / 5)
        stresses.append(model.stress())
    np.testing.assert_allclose(stresses[0], stresses[1], rtol=1e-9, atol=1e-6)


def test_closed_strain_cycle_dissipates_non_negative_energy(idealized):
    model = MicroElementModel(idealized, linear_law(phi_deg=15))
    model.consolidate_isotropically(P0)
    amplitude = np.array([0, 0, 4e-4, 0, 0, 2e-4])
    path = np.concatenate([np.linspace(0, 1, 40), np.linspace(1, -1, 80)[1:],
                           np.linspace(-1, 0, 40)[1:]])
    work = 0.0
    previous = 0.0
    for level in path[1:]:
        d_eps = (level - previous) * amplitude
        s0 = model.stress()
        model.apply_strain(d_eps)
        work += 0.5 * (s0 + model.stress()) @ d_eps
        previous = level
    assert work >= 0.0
    assert model.descriptors()["n_sliding"] >= 0


@pytest.mark.parametrize("reference", ["overall", "average"])
def test_coulomb_and_no_tension_after_every_increment(idealized, reference):
    rng = np.random.default_rng(1)
    law = linear_law(phi_deg=20)
    model = MicroElementModel(idealized, law, distribution="maxwellian",
                              maxwellian_reference=reference)
    model.consolidate_isotropically(P0)
    mu = law.friction_coefficient
    for increment in range(60):
        try:
            model.apply_strain(rng.normal(scale=2e-5, size=6))
        except StrengthReached:  # the self-consistent unit fails on this random walk
            assert reference == "overall" and increment >= 10
            break
        c = model.state.contacts
        assert np.all(c.normal_force >= -1e-9)
        shear = np.linalg.norm(c.shear_force, axis=2)
        assert np.all(shear <= mu * np.maximum(c.normal_force, 0) * (1 + 1e-9) + 1e-12)


def test_bonds_carry_tension_then_break_for_good():
    structure = binary_units(4, radius=1e-3, void_ratio=0.6, dimension=2)
    law = linear_law(bond_tensile_strength=1e-3, bond_shear_strength=1e-3)
    model = MicroElementModel(structure, law, spin="uniform", update_geometry=False)
    # stretch isotropically: bonded contacts go into tension
    model.apply_strain(np.array([-2e-7, -2e-7, 0.0]))
    assert np.all(model.state.contacts.normal_force < 0) and model.state.contacts.bonded.all()
    model.apply_strain(np.array([-1e-5, -1e-5, 0.0]))
    assert not model.state.contacts.bonded.any()
    assert np.all(model.state.contacts.normal_force == 0)
    model.apply_strain(np.array([-1e-5, -1e-5, 0.0]) * -1.5)  # close again: no bond returns
    assert not model.state.contacts.bonded.any()


def test_bad_options_are_named(idealized):
    with pytest.raises(InputError, match="distribution"):
        MicroElementModel(idealized, linear_law(), distribution="gaussian")
    with pytest.raises(InputError, match="spin"):
        MicroElementModel(idealized, linear_law(), distribution="maxwellian", spin="uniform")
    with pytest.raises(InputError, match="contact law"):
        SpringContactLaw(normal_stiffness=1.0, shear_modulus=1.0)


def test_diverging_stress_iterations_are_reported_not_carried_on(idealized):
    """A tangent of the wrong sign (as an indefinite distribution law can give) doubles the
    stress residual at every Newton step (r_k+1 = 2 r_k for linear springs): solve_stress
    stops with a ConvergenceError naming the law once the residual passes 1e3 of the
    target, instead of iterating to non-finite strains."""
    model = MicroElementModel(idealized, linear_law(), update_geometry=False)
    model.consolidate_isotropically(P0)
    true_tangent = model.tangent()
    model.tangent = lambda: -true_tangent  # the instance's own tangent, negated
    target = np.array([0.5, 0.5, 0.5, 0.0, 0.0, 0.0]) * P0
    with pytest.raises(ConvergenceError, match=r"diverged.*'homogeneous' distribution"):
        model.solve_stress(target)
    residual = np.linalg.norm(target - model.stress()) / np.linalg.norm(target)
    assert 1e3 < residual < 4e3  # stopped at the first doubling past the bound
