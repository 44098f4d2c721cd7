"""Seed 000's rotated stress path on regular packings: equilibrium, Coulomb and symmetry.

alpha is the angle of sigma_1 from the Y axis, counter-clockwise, so the major direction is
m = (-sin alpha, cos alpha); a packing rotated counter-clockwise by theta under alpha + theta
is the original packing under alpha, seen from a rotated frame.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from grainlab.analysis import stress_from_contact_dyads
from grainlab.contact import LinearSpring2D, ModifiedHertzMindlin2D
from grainlab.errors import InputError
from grainlab.micromech.regular_packing import (
    RegularPackingModel,
    RotatedStressPath,
    run_rotated_stress_path,
)
from grainlab.prep.regular_packings import named_packing

FAST = {"ratio_step": 0.1, "max_ratio": 2.0}
LAW = ModifiedHertzMindlin2D.seed000()


@functools.cache
def model_of(name: str, rotation: float = 0.0, mirror: bool = False) -> RegularPackingModel:
    packing = named_packing(name)
    if mirror:
        packing = packing.transformed(np.diag([-1.0, 1.0]))
    if rotation:
        packing = packing.rotated(rotation)
    return RegularPackingModel(packing, LAW)


@functools.cache
def run(name: str, alpha_deg: float, rotation: float = 0.0, mirror: bool = False,
        control: str = "sigma3", long: bool = False):
    settings = {"ratio_step": 0.25, "max_ratio": 8.0} if long else FAST
    path = RotatedStressPath(alpha=np.radians(alpha_deg), control=control, **settings)
    return run_rotated_stress_path(model_of(name, rotation, mirror), path), path


def principal_strains(table) -> np.ndarray:
    exx, eyy, gxy = (table[c].to_numpy() for c in ("eps_xx", "eps_yy", "gamma_xy"))
    centre = 0.5 * (exx + eyy)
    radius = np.hypot(0.5 * (exx - eyy), 0.5 * gxy)
    return np.column_stack([centre + radius, centre - radius])


def test_path_stress_has_the_requested_principal_axes():
    for alpha_deg in (-60.0, 0.0, 25.0, 90.0):
        path = RotatedStressPath(alpha=np.radians(alpha_deg), confining_stress=1e4)
        sxx, syy, sxy = path.stress(3.0)
        values, vectors = np.linalg.eigh(np.array([[sxx, sxy], [sxy, syy]]))
        np.testing.assert_allclose(values, [1e4, 3e4], rtol=1e-12)
        major = vectors[:, 1]
        m = np.array([-np.sin(np.radians(alpha_deg)), np.cos(np.radians(alpha_deg))])
        assert abs(major @ m) == pytest.approx(1.0, rel=1e-12)
    p_path = RotatedStressPath(alpha=0.3, confining_stress=1e4, control="p")
    s = p_path.stress(3.0)
    assert 0.5 * (s[0] + s[1]) == pytest.approx(1e4, rel=1e-12)
    with pytest.raises(InputError, match="alpha"):
        RotatedStressPath(alpha=2.0)


@pytest.mark.parametrize(
    ("name", "alpha_deg", "control", "long"),
    [("C", 30.0, "sigma3", False), ("A", -45.0, "sigma3", False), ("B", 10.0, "sigma3", False),
     ("hexagonal", 17.0, "sigma3", False), ("C", 60.0, "p", False),
     # to a stress ratio of 8: contacts slide and open on the way
     ("A", 45.0, "sigma3", True), ("B", 45.0, "sigma3", True), ("C", 45.0, "sigma3", True)],
)
def test_stress_from_recorded_forces_equals_the_applied_stress(name, alpha_deg, control, long):
    result, path = run(name, alpha_deg, control=control, long=long)
    model = model_of(name)
    c = model.contacts
    normal = result.snapshots["normal_force"]
    tangential = result.snapshots["tangential_force"]
    assert normal.shape == (len(result.table), c.n_contacts)
    mu = np.tan(LAW.friction_angle)
    for row, ratio in enumerate(result.table["stress_ratio"]):
        forces = normal[row][:, None] * c.normal + tangential[row][:, None] * c.tangent
        sigma = stress_from_contact_dyads(forces, c.branch, model.packing.cell.area)
        sym = 0.5 * (sigma + sigma.T)
        applied = path.stress(ratio)
        recomputed = np.array([sym[0, 0], sym[1, 1], sym[0, 1]])
        np.testing.assert_allclose(recomputed, applied, rtol=0,
                                   atol=1e-8 * np.linalg.norm(applied))
        # the table's stress columns agree too
        np.testing.assert_allclose(
            result.table.loc[row, ["sigma_xx", "sigma_yy", "sigma_xy"]].to_numpy(float),
            applied, rtol=0, atol=1e-8 * np.linalg.norm(applied),
        )
        # Coulomb at every contact, no tension, open contacts carry nothing
        assert np.all(normal[row] >= 0.0)
        assert np.all(np.abs(tangential[row]) <= mu * normal[row] * (1 + 1e-9))
        slides = np.abs(tangential[row]) >= (1 - 1e-9) * mu * normal[row]
        assert result.table.loc[row, "n_sliding"] == np.count_nonzero(slides & (normal[row] > 0))
        assert result.table.loc[row, "n_open"] == np.count_nonzero(normal[row] <= 0)
    assert result.table["stage"].iloc[0] == "isotropic"
    np.testing.assert_array_equal(result.table.loc[0, ["eps_xx", "eps_yy", "gamma_xy"]], 0.0)


@pytest.mark.parametrize("alpha_deg", [20.0, 45.0, 70.0])
@pytest.mark.parametrize("name", ["C", "A"])
def test_mirror_symmetric_packing_plus_minus_alpha(name, alpha_deg):
    plus, _ = run(name, alpha_deg)
    minus, _ = run(name, -alpha_deg)
    assert len(plus.table) == len(minus.table)
    assert plus.outcome["status"] == minus.outcome["status"]
    t1, t2 = plus.table, minus.table
    scale = np.abs(t1[["eps_xx", "eps_yy", "gamma_xy"]].to_numpy()).max()
    atol = 1e-7 * scale
    np.testing.assert_allclose(t2["eps_xx"], t1["eps_xx"], rtol=1e-6, atol=atol)
    np.testing.assert_allclose(t2["eps_yy"], t1["eps_yy"], rtol=1e-6, atol=atol)
    np.testing.assert_allclose(t2["gamma_xy"], -t1["gamma_xy"], rtol=1e-6, atol=atol)
    np.testing.assert_allclose(
        t2["noncoaxiality_deg"][1:], -t1["noncoaxiality_deg"][1:], rtol=1e-5, atol=1e-5
    )
    np.testing.assert_allclose(t2["D13"], -t1["D13"], rtol=1e-6, atol=1e-7 * t1["D11"].max())
    np.testing.assert_allclose(t2["D23"], -t1["D23"], rtol=1e-6, atol=1e-7 * t1["D11"].max())
    np.testing.assert_allclose(t2["D11"], t1["D11"], rtol=1e-6)
    assert np.abs(t1["gamma_xy"].iloc[-1]) > 1e-3 * scale  # the shear is really there


def test_mirrored_packing_under_mirrored_loading():
    """For a packing without mirror symmetry (rhombic), the mirror image of the packing under
    -alpha gives the mirror image of the response."""
    plus, _ = run("rhombic", 25.0)
    mirrored, _ = run("rhombic", -25.0, mirror=True)
    t1, t2 = plus.table, mirrored.table
    assert len(t1) == len(t2)
    scale = np.abs(t1[["eps_xx", "eps_yy", "gamma_xy"]].to_numpy()).max()
    np.testing.assert_allclose(t2["eps_xx"], t1["eps_xx"], rtol=1e-6, atol=1e-7 * scale)
    np.testing.assert_allclose(t2["gamma_xy"], -t1["gamma_xy"], rtol=1e-6, atol=1e-7 * scale)
    # and it differs from the unmirrored packing under -alpha
    other, _ = run("rhombic", -25.0)
    rows = min(len(other.table), len(t1))
    assert not np.allclose(other.table["eps_xx"][:rows], t1["eps_xx"][:rows], rtol=1e-3)


@pytest.mark.parametrize(("name", "theta_deg", "alpha_deg"),
                         [("C", 20.0, 35.0), ("A", -30.0, 10.0), ("B", 25.0, 40.0)])
def test_rotating_packing_and_loading_together_changes_nothing(name, theta_deg, alpha_deg):
    """Rotating the packing counter-clockwise by theta turns m = (-sin a, cos a) into the
    direction at a + theta from Y (counter-clockwise): same principal strains, and the
    principal strain increment direction rotates with the packing."""
    theta = np.radians(theta_deg)
    base, _ = run(name, alpha_deg)
    turned, _ = run(name, alpha_deg + theta_deg, rotation=theta)
    assert len(base.table) == len(turned.table)
    e1, e2 = principal_strains(base.table), principal_strains(turned.table)
    np.testing.assert_allclose(e2, e1, rtol=1e-6, atol=1e-7 * np.abs(e1).max())
    np.testing.assert_allclose(turned.table["noncoaxiality_deg"][1:],
                               base.table["noncoaxiality_deg"][1:], rtol=1e-5, atol=1e-5)
    # the strain tensor itself is rotated: eps' = R eps R^T
    R = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    for (_, a), (_, b) in zip(base.table.iterrows(), turned.table.iterrows(), strict=True):
        eps = np.array([[a.eps_xx, a.gamma_xy / 2], [a.gamma_xy / 2, a.eps_yy]])
        eps_t = np.array([[b.eps_xx, b.gamma_xy / 2], [b.gamma_xy / 2, b.eps_yy]])
        np.testing.assert_allclose(eps_t, R @ eps @ R.T, rtol=0,
                                   atol=1e-6 * np.abs(e1).max() + 1e-14)
    # the wrong sign convention (alpha - theta) does not reproduce the response
    wrong, _ = run(name, alpha_deg - theta_deg, rotation=theta)
    rows = min(len(wrong.table), len(base.table))
    assert not np.allclose(principal_strains(wrong.table)[:rows], e1[:rows], rtol=1e-3)


@pytest.mark.parametrize("alpha_deg", [0.0, 30.0])
def test_hexagonal_packing_is_coaxial_on_its_symmetry_axes(alpha_deg):
    result, _ = run("hexagonal", alpha_deg)
    table = result.table
    assert table["n_open"].iloc[1] == 0 and table["n_sliding"].iloc[1] == 0
    assert table["noncoaxiality_deg"].iloc[1] == pytest.approx(0.0, abs=1e-6)
    assert table["stress_direction_deg"].iloc[1] == pytest.approx(alpha_deg, abs=1e-9)
    assert table["strain_increment_direction_deg"].iloc[1] == pytest.approx(alpha_deg, abs=1e-6)


def test_hexagonal_first_increment_is_coaxial_for_a_linear_law():
    """With constant spring stiffnesses the hexagonal packing is isotropic in its plane and
    every increment without sliding is coaxial, whatever alpha."""
    model = RegularPackingModel(named_packing("hexagonal"),
                                LinearSpring2D(1e8, 4e7, np.radians(30.0)))
    path = RotatedStressPath(alpha=np.radians(17.0), ratio_step=0.05, max_ratio=1.1)
    table = run_rotated_stress_path(model, path).table
    assert table["n_sliding"].iloc[1] == 0
    assert table["noncoaxiality_deg"].iloc[1] == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("alpha_deg", [0.0, 30.0, -45.0, 90.0])
def test_stress_direction_column_is_alpha(alpha_deg):
    result, _ = run("C", alpha_deg)
    directions = result.table["stress_direction_deg"].iloc[1:].to_numpy()
    # an axis: +90 and -90 deg are the same direction
    difference = (directions - alpha_deg + 90.0) % 180.0 - 90.0
    np.testing.assert_allclose(difference, 0.0, atol=1e-7)
    assert np.all((directions > -90.0 - 1e-9) & (directions <= 90.0))


def test_sigma_1_along_y_compresses_y_more_than_x():
    """alpha = 0: sigma_1 along Y; a stable packing shortens more along Y (compression +)."""
    result, _ = run("C", 0.0)
    last = result.table.iloc[-1]
    assert last["eps_yy"] > last["eps_xx"]
    assert last["eps_yy"] > 0.0
    assert abs(last["gamma_xy"]) < 1e-9 * last["eps_yy"]  # C is symmetric about Y


def test_isotropic_state_of_packing_c_has_shear_forces():
    """Seed 000 Fig. 10(a): under an isotropic stress the contacts of C carry shear forces;
    the hexagonal packing's contacts, all alike by symmetry, carry none."""
    c_result, _ = run("C", 45.0)
    hex_result, _ = run("hexagonal", 0.0)
    fn_c, ft_c = c_result.snapshots["normal_force"][0], c_result.snapshots["tangential_force"][0]
    fn_h, ft_h = (hex_result.snapshots["normal_force"][0],
                  hex_result.snapshots["tangential_force"][0])
    assert np.max(np.abs(ft_c) / fn_c) > 0.01
    assert np.max(np.abs(ft_h)) <= 1e-9 * np.max(fn_h)
    np.testing.assert_allclose(fn_h, fn_h[0], rtol=1e-9)


def test_particles_of_packing_c_are_in_force_equilibrium_at_45_degrees():
    """Seed 000 Fig. 10(b): after a load increment at alpha = 45 deg every particle of C's
    tessellation is in (force) equilibrium. Sum f over the contacts of each particle from the
    recorded forces (f acts on j, -f on i)."""
    result, _ = run("C", 45.0)
    model = model_of("C")
    c = model.contacts
    for fn, ft in zip(result.snapshots["normal_force"], result.snapshots["tangential_force"],
                      strict=True):
        forces = fn[:, None] * c.normal + ft[:, None] * c.tangent
        net = np.zeros((model.packing.n_particles, 2))
        for k in range(c.n_contacts):
            net[c.particle_j[k]] += forces[k]
            net[c.particle_i[k]] -= forces[k]
        assert np.abs(net).max() <= 1e-9 * np.abs(fn).max()
