"""Strength of seed 001's micro-element model: Coulomb sliding at contacts, failure of a
micro-element whose contacts all slide, the self-consistent Maxwellian distribution (eq. 2.32
with the overall C)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from grainlab.contact.spring_contact import SpringContactLaw
from grainlab.errors import InputError, StrengthReached
from grainlab.lab.derived import peak_friction_angle
from grainlab.lab.element_test import run_element_test
from grainlab.lab.presets import preset
from grainlab.micromech.micro_element import MicroElementModel
from grainlab.micromech.micro_element.structure import MicroElementStructure
from grainlab.micromech.micro_element.structures import idealized_material

P0 = 100e3
RADIUS = 0.2e-3


def linear_law(phi_deg: float, thickness: float = 1.0) -> SpringContactLaw:
    return SpringContactLaw(normal_stiffness=1e5 / thickness, shear_stiffness=1e5 / thickness,
                            friction_angle=np.radians(phi_deg))


def x_micro_element(alpha_deg: float = 45.0) -> MicroElementStructure:
    """One 2D micro-element: a disc touching four equal discs at +-alpha from the vertical
    axis, above and below (branch vectors of length 2r)."""
    a = np.radians(alpha_deg)
    directions = np.array([[np.sin(a), np.cos(a)], [-np.sin(a), np.cos(a)],
                           [np.sin(a), -np.cos(a)], [-np.sin(a), -np.cos(a)]])
    return MicroElementStructure(
        branches=(2 * RADIUS * directions)[None], mask=np.ones((1, 4), bool),
        volumes=np.array([4 * RADIUS**2]), centre_radii=np.array([RADIUS]),
        neighbour_radii=np.full((1, 4), RADIUS), name="x-element")


def test_sliding_contact_stays_on_the_coulomb_cone():
    """Fig. 2.5b: while a contact slides its shear force equals the strength mu f_n, also when
    f_n grows; it must not drop below the cone and stick again every other increment."""
    mu = np.tan(np.radians(25.0))
    law = linear_law(25.0)
    normal = np.array([[0.0, 0.0, 1.0]])
    state = law.initial_state((1,), 3)
    state, _ = law.update(state, np.array([[0.0, 0.0, 1e-7]]), normal, np.array([RADIUS]))
    ratios, flags = [], []
    for _ in range(8):  # slip 3e-8 m and approach 1e-8 m per increment: slip wins
        state, _ = law.update(state, np.array([[3e-8, 0.0, 1e-8]]), normal,
                                     np.array([RADIUS]))
        ratios.append(np.linalg.norm(state.shear_force[0]) / (mu * state.normal_force[0]))
        flags.append(bool(state.sliding[0]))
    first = flags.index(True)
    assert first <= 2
    np.testing.assert_allclose(ratios[first:], 1.0, rtol=1e-12)
    assert all(flags[first:])
    # a twin by hand: elastic trial k_s * slip, returned radially to mu f_n
    assert state.normal_force[0] == pytest.approx(1e5 * (1e-7 + 8e-8))


@pytest.mark.parametrize("phi_deg", [14.0, 25.0])
def test_micro_element_whose_contacts_all_slide_fails_at_the_coulomb_ratio(phi_deg):
    """Four contacts at +-45 deg from the vertical slide together under biaxial compression:
    with f_t = mu f_n at each, sigma_yy/sigma_xx = cot(alpha) cot(alpha - phi_mu), i.e.
    sin(phi_mob) = tan(phi_mu) at alpha = 45 deg; the unit then has no stiffness left in
    the mode that keeps sigma_xx (the 2x2 normal block of the tangent is singular) and the
    stress stays on that plateau."""
    law = linear_law(phi_deg, thickness=2 * RADIUS)
    model = MicroElementModel(x_micro_element(45.0), law, update_geometry=False)
    model.consolidate_isotropically(P0)
    normal_block = model.tangent()[:2, :2]
    assert np.linalg.eigvalsh(normal_block)[0] > 0.1 * np.linalg.eigvalsh(normal_block)[1]
    eps = P0 / model.tangent()[1, 1]
    result = run_element_test(model, preset("biaxial", confining=P0, strain=40 * eps,
                                            n_steps=80, consolidation_steps=0))
    table = result.table
    ratio = table["sigma_yy"].to_numpy() / table["sigma_xx"].to_numpy()
    coulomb = 1.0 / np.tan(np.radians(45.0 - phi_deg))  # cot(45) cot(45 - phi)
    assert ratio.max() == pytest.approx(coulomb, rel=1e-4)
    plateau = ratio[-10:]
    np.testing.assert_allclose(plateau, coulomb, rtol=1e-4)
    phi_mob = np.degrees(np.arcsin((coulomb - 1) / (coulomb + 1)))
    assert np.sin(np.radians(phi_mob)) == pytest.approx(np.tan(np.radians(phi_deg)))
    assert model.descriptors()["n_sliding"] == 4
    block = model.tangent()[:2, :2]
    assert abs(np.linalg.det(block)) <= 1e-9 * np.linalg.norm(block) ** 2


def test_uniform_strain_cannot_fail_in_triaxial_compression():
    """Why the homogeneous law (eq. 2.30) has no peak: under a uniform strain a contact whose
    normal lies within the cone tan(theta) < tan(phi_mu) eps_a / (eps_a - eps_r) of the
    compression axis never reaches Coulomb, so it keeps loading elastically and sigma_1 grows
    without bound (here checked on the idealized material at 2 % axial strain)."""
    structure = idealized_material(seed=3)
    model = MicroElementModel(structure, linear_law(25.0))
    model.consolidate_isotropically(P0)
    increment = np.array([-0.25e-4, -0.25e-4, 1e-4, 0.0, 0.0, 0.0])
    sigma = []
    for _ in range(200):
        model.apply_strain(increment)
        sigma.append(model.stress()[2])
    normals = model.normals[model.state.mask]
    theta = np.arccos(np.abs(normals[:, 2]))
    cone = theta < np.arctan(np.tan(np.radians(25.0)) * 1.0 / 1.25) * 0.9
    assert cone.sum() > 0
    closed = model.state.contacts.normal_force[model.state.mask] > 0
    assert np.all(closed[cone]) and not np.any(model.state.contacts.sliding[model.state.mask][cone])
    growth = np.diff(sigma[-50:])
    assert np.all(growth > 0)


def self_consistent_twin(c_local: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Eqs. 2.31–2.35 with the overall C in v^n by plain fixed-point iteration, scipy expm."""
    c_bar = np.tensordot(weights, c_local, axes=1)
    c = c_bar.copy()
    for _ in range(500):
        v = [np.linalg.solve(c, cn - c_bar) for cn in c_local]
        e = np.array([expm(-vn) for vn in v])
        a = np.linalg.inv(np.tensordot(weights, e, axes=1))
        g = np.array([a @ en * w for en, w in zip(e, weights, strict=True)])
        new = sum(cn @ gn for cn, gn in zip(c_local, g, strict=True))
        new = 0.5 * (new + new.T)
        if np.linalg.norm(new - c) < 1e-12 * np.linalg.norm(c_bar):
            return new
        c = 0.5 * (c + new)
    raise AssertionError("twin did not converge")


def test_self_consistent_maxwellian_is_the_fixed_point_of_eqs_231_232():
    structure = idealized_material(seed=3)
    model = MicroElementModel(structure, linear_law(25.0), distribution="maxwellian")
    assert model.maxwellian_reference == "overall"
    model.consolidate_isotropically(P0)
    model.apply_strain(np.array([-0.25e-4, -0.25e-4, 1e-4, 0.0, 0.0, 0.0]))
    weights = model.state.volumes / model.volume
    twin = self_consistent_twin(model.local_stiffness(), weights)
    np.testing.assert_allclose(model.tangent(), twin, rtol=0, atol=1e-7 * np.abs(twin).max())
    np.testing.assert_allclose(model.distribution_tensors().sum(axis=0), np.eye(6),
                               atol=1e-10)  # eq. 2.28
    average = MicroElementModel(structure, linear_law(25.0), distribution="maxwellian",
                                maxwellian_reference="average")
    average.state = model.state
    average._invalidate()
    # the overall C is softer than C_bar, so the self-consistent strain concentrates more
    # on soft micro-elements and the overall tangent is softer
    assert np.trace(model.tangent()) < np.trace(average.tangent())


def test_unknown_maxwellian_reference_is_named():
    with pytest.raises(InputError, match="maxwellian_reference"):
        MicroElementModel(x_micro_element(), linear_law(25.0), distribution="maxwellian",
                          maxwellian_reference="overal")


def self_consistent_triaxial(seed: int, n_steps: int) -> tuple[MicroElementModel, object]:
    model = MicroElementModel(idealized_material(seed=seed), linear_law(25.0),
                              distribution="maxwellian")
    model.consolidate_isotropically(P0)
    eps_ref = P0 / np.mean(np.diag(model.tangent())[:3])
    path = preset("triaxial_compression", confining=P0, axial_strain=8 * eps_ref,
                  n_steps=n_steps, consolidation_steps=0)
    return model, run_element_test(model, path)


def test_self_consistent_failure_converges_with_the_step_size():
    """Solved tightly (Anderson-accelerated, continued from the previous increment), the
    self-consistent unit fails where its fixed point ceases to exist; that point, and the
    peak angle, no longer depend on the step once the steps are small."""
    peaks = []
    for n_steps in (1600, 3200):
        _, result = self_consistent_triaxial(2, n_steps)
        assert result.outcome["status"] == "failure"
        assert "self-consistent" in result.outcome["reason"]
        phi, row = peak_friction_angle(result.table)
        peaks.append(np.degrees(phi))
        assert bool(result.table["converged"].iloc[row])
    assert abs(peaks[0] - peaks[1]) < 0.1


def test_self_consistent_failure_is_where_no_fixed_point_exists():
    """At the failed state a plain under-relaxed iteration of eqs. 2.31-2.35 (scipy expm,
    no acceleration, from C_bar) finds no positive-definite fixed point either, while one
    step before it the fixed point the model used is that of the plain iteration."""
    model, result = self_consistent_triaxial(2, 400)
    assert result.outcome["status"] == "failure"
    weights = model.state.volumes / model.volume
    with pytest.raises(StrengthReached):
        model.tangent()
    try:
        twin = self_consistent_twin(model.local_stiffness(), weights)
    except (AssertionError, np.linalg.LinAlgError):
        twin = None
    assert twin is None or np.linalg.eigvalsh(twin)[0] <= 0.0
