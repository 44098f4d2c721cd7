"""Micro-element models of a simulated packing, taken with its contact forces: the model's
initial stress is the snapshot's contact-force stress (1/V) sum f (x) l over the same
contacts, its small-strain stiffness is the regular-packing theory's (seed 000 eq. 15) for a
regular packing fed through the same snapshot file, and keeping or dropping the periodic-image
(and wall) contacts changes the coordination and stress as the contacts counted say."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.snapshot_files import write_snapshots
from grainlab.analysis.synthetic import synthetic_network
from grainlab.contact import LinearSpring2D
from grainlab.contact.spring_contact import SpringContactLaw
from grainlab.errors import InputError
from grainlab.lab.element_test import run_element_test
from grainlab.lab.micro_element_setup import build_model, build_structure
from grainlab.lab.presets import isotropic_compression
from grainlab.micromech.micro_element.from_snapshot import (
    micro_elements_from_snapshot,
    periodic_image_pairs,
)
from grainlab.micromech.micro_element.model import MicroElementModel
from grainlab.micromech.regular_packing import RegularPackingModel, consolidate_isotropically
from grainlab.prep.regular_packings import named_packing

LAW = SpringContactLaw(friction_angle=np.radians(25.0), normal_stiffness=1e5,
                       shear_stiffness=0.7e5)
ROUND_OFF = 1e-12


def contact_stress(network: ContactNetwork, keep: np.ndarray) -> np.ndarray:
    """(1/V) sum over the kept interactions of f (x) l, written out here (not the library's)."""
    forces = np.zeros((network.n_pairs, network.dimension))
    np.add.at(forces, network.point_pairs, network.point_forces)
    return np.einsum("pi,pj->ij", forces[keep], network.pair_branches[keep]) / network.volume


def cubic_lattice(n: int = 3, radius: float = 1e-3, forces=(30.0, 20.0, 10.0),
                  periodic: bool = True) -> ContactNetwork:
    """n^3 touching equal spheres on a simple cubic lattice (spacing a = 2R), in a periodic
    cell of side n a (every particle has its 6 neighbours, those across the faces through the
    images) or, ``periodic=False``, in a box of the same size whose walls are left out of the
    network as the engine leaves them. Each contact along axis k carries forces[k] [N]."""
    a = 2.0 * radius
    index = np.array(np.unravel_index(np.arange(n**3), (n, n, n))).T
    positions = (index + 0.5) * a
    pairs, branches, forces_out = [], [], []
    for p, cell in enumerate(index):
        for axis in range(3):
            step = np.eye(3, dtype=int)[axis]
            other = cell + step
            if other[axis] == n and not periodic:
                continue
            q = int(np.ravel_multi_index(tuple(other % n), (n, n, n)))
            pairs.append((p, q))
            branches.append(a * step)
            forces_out.append(forces[axis] * step)
    pairs, branches, forces_out = np.array(pairs), np.array(branches), np.array(forces_out)
    return ContactNetwork(
        positions=positions, volumes=np.full(n**3, 4.0 / 3.0 * np.pi * radius**3),
        volume=(n * a) ** 3, pair_particles=pairs, pair_branches=branches,
        point_pairs=np.arange(len(pairs)),
        point_positions=positions[pairs[:, 0]] + 0.5 * branches,
        point_normals=branches / a, point_forces=forces_out)


# -- (a) the initial stress is the snapshot's, to round-off -----------------------------------
@pytest.mark.parametrize("dimension", [2, 3])
@pytest.mark.parametrize("periodic", ["keep", "drop"])
def test_initial_stress_is_the_snapshots_contact_stress(dimension, periodic):
    """A disordered, anisotropic network with friction forces (not in balance: the identity
    holds contact by contact)."""
    network = synthetic_network(80, dimension=dimension, a_c=0.2, a_fn=0.3, a_ft=0.4,
                                coordination=5.0, seed=3)
    # make half of the pairs direct (branch = x_j - x_i) so that "drop" keeps some of them
    positions = np.array(network.positions)
    pairs = network.pair_particles
    direct = np.arange(network.n_pairs) % 2 == 0
    for k in np.flatnonzero(direct):
        positions[pairs[k, 1]] = positions[pairs[k, 0]] + network.pair_branches[k]
    moved = ContactNetwork(**{**network.__dict__, "positions": positions})
    images = periodic_image_pairs(moved)
    keep = np.ones(moved.n_pairs, bool) if periodic == "keep" else ~images
    assert 0 < keep.sum() and (periodic == "keep" or keep.sum() < moved.n_pairs)
    structure = micro_elements_from_snapshot(moved, periodic=periodic)
    model = MicroElementModel(structure, LAW)
    expected = contact_stress(moved, keep)
    assert np.abs(expected).max() > 0
    np.testing.assert_allclose(model.stress_tensor(), expected,
                               atol=ROUND_OFF * np.abs(expected).max())
    assert structure.total_volume == pytest.approx(moved.volume, rel=ROUND_OFF)


def test_wall_contacts_kept_give_the_stress_on_the_walls():
    """A simple cubic lattice in a box: the particle contacts alone give (n - 1)/n of the
    stress on the walls (forces[k] / a^2 on the walls normal to k); "balance" adds the wall
    contacts and gives all of it, each particle then in balance."""
    n, radius, forces = 3, 1e-3, np.array([30.0, 20.0, 10.0])
    a = 2 * radius
    network = cubic_lattice(n, radius, forces, periodic=False)
    wall_stress = np.diag(forces / a**2)
    dropped = MicroElementModel(micro_elements_from_snapshot(network, walls="drop"), LAW)
    np.testing.assert_allclose(dropped.stress_tensor(), (n - 1) / n * wall_stress,
                               atol=ROUND_OFF * wall_stress.max())
    kept_structure = micro_elements_from_snapshot(network, walls="balance")
    kept = MicroElementModel(kept_structure, LAW)
    np.testing.assert_allclose(kept.stress_tensor(), wall_stress,
                               atol=ROUND_OFF * wall_stress.max())
    # every particle has its 6 contacts (particles or walls) and no unbalanced force left
    assert kept_structure.contact_counts.tolist() == [6] * n**3
    assert kept_structure.description["n_wall_contacts"] == 6 * n**2
    np.testing.assert_allclose(kept_structure.initial_forces.sum(axis=1), 0.0,
                               atol=ROUND_OFF * forces.max())


# -- (b) small-strain stiffness: the regular-packing theory's ---------------------------------
@pytest.mark.parametrize(("packing", "non_affine"),
                         [("hexagonal", True), ("square", True), ("C", True), ("A", False),
                          ("D", False)])
def test_stiffness_of_a_regular_packing_through_a_snapshot_file(tmp_path, packing,
                                                                non_affine):
    """Seed 000's periodic packing loaded isotropically, written as a snapshot file, read
    back as micro-elements with its forces: the model's initial stress and tangent are the
    regular-packing theory's D (seed 000 eq. 15). Centrosymmetric micro-elements (hexagonal,
    square, C) have no non-affine move (eq. 2.14 gives T = 0); those of packings A and D do,
    so they are compared with affine kinematics, the theory's."""
    kn, kt, phi = 3.0e8, 1.1e8, 30.0
    theory = RegularPackingModel(named_packing(packing), LinearSpring2D(kn, kt,
                                                                        np.radians(phi)))
    state = consolidate_isotropically(theory, 17.24e3, steps=2)
    path = write_snapshots(tmp_path / "snapshots.h5", [theory.contact_network(state)])
    structure = build_structure(str(path))
    model = build_model(structure, normal_stiffness=kn, shear_stiffness=kt, thickness=1.0,
                        friction_angle_deg=phi, non_affine=non_affine)
    assert not np.any(model.state.contacts.sliding)
    stress = theory.stress(state)
    np.testing.assert_allclose(model.stress(), stress, atol=ROUND_OFF * np.abs(stress).max())
    stiffness = theory.stiffness_matrix(state)
    np.testing.assert_allclose(model.tangent(), stiffness,
                               atol=1e-12 * np.abs(stiffness).max())
    # and the response to a small strain is the theory's: D deps from the snapshot's stress
    # (small-strain model: the large-strain update also turns the contacts' initial forces
    # with the branches, terms of order sigma deps that seed 000's D leaves out)
    model = build_model(structure, normal_stiffness=kn, shear_stiffness=kt, thickness=1.0,
                        friction_angle_deg=phi, non_affine=non_affine, update_geometry=False)
    d_eps = 1e-7 * np.array([1.0, -0.4, 0.7])
    model.apply_strain(d_eps)
    np.testing.assert_allclose(model.stress(), theory.stress(theory.update(state, d_eps)),
                               rtol=1e-9, atol=1e-9 * np.abs(stress).max())


@pytest.mark.parametrize("packing", ["A", "D"])
def test_non_affine_move_softens_a_non_centrosymmetric_packing(packing):
    """Packings A and D with the centre's move (eq. 2.14) are softer than the uniform-strain
    theory (a bound the model must respect, and a check that the comparison above would fail
    if the kinematics differed)."""
    theory = RegularPackingModel(named_packing(packing), LinearSpring2D(3e8, 1.1e8,
                                                                        np.radians(30.0)))
    state = consolidate_isotropically(theory, 17.24e3, steps=2)
    structure = micro_elements_from_snapshot(theory.contact_network(state))
    law = SpringContactLaw(friction_angle=np.radians(30.0), normal_stiffness=3e8,
                           shear_stiffness=1.1e8)
    difference = theory.stiffness_matrix(state) - MicroElementModel(structure, law).tangent()
    eigenvalues = np.linalg.eigvalsh(0.5 * (difference + difference.T))
    assert eigenvalues.min() > -1e-9 * np.abs(difference).max()
    assert eigenvalues.max() > 1e-3 * np.abs(theory.stiffness_matrix(state)).max()


# -- (c) periodic-image contacts kept or dropped ----------------------------------------------
def test_dropping_periodic_contacts_loses_coordination_and_stress():
    """A 3 x 3 x 3 simple cubic periodic lattice: one in three contacts along each axis
    crosses the cell's faces. Kept: z = 6, stress forces[k]/a^2 and the regular-packing
    stiffness (C_kk = k_n/a, shear k_s/2a). Dropped:
    z = 4, stress and (affine) normal stiffness 2/3 of those."""
    n, radius, forces = 3, 1e-3, np.array([30.0, 20.0, 10.0])
    a = 2 * radius
    network = cubic_lattice(n, radius, forces, periodic=True)
    assert periodic_image_pairs(network).sum() == 3 * n**2
    kept = micro_elements_from_snapshot(network, periodic="keep")
    dropped = micro_elements_from_snapshot(network, periodic="drop")
    assert kept.coordination_number == 6.0 and dropped.coordination_number == 4.0
    assert dropped.description["n_periodic_dropped"] == 3 * n**2
    full = np.diag(forces / a**2)
    kept_model, dropped_model = MicroElementModel(kept, LAW), MicroElementModel(dropped, LAW)
    np.testing.assert_allclose(kept_model.stress_tensor(), full, atol=ROUND_OFF * full.max())
    np.testing.assert_allclose(dropped_model.stress_tensor(), 2.0 / 3.0 * full,
                               atol=ROUND_OFF * full.max())
    kn, ks = LAW.normal_stiffness, LAW.shear_stiffness
    # seed 000's D = (1/V) sum_c B^T K B for the cubic lattice (V = a^3 per sphere, 3
    # contacts): C_xx = k_n / a, C_yz = k_s / (2 a) on engineering shears, no coupling
    expected = np.diag([kn / a] * 3 + [ks / (2 * a)] * 3)
    np.testing.assert_allclose(kept_model.tangent(), expected, rtol=1e-12,
                               atol=1e-12 * kn / a)
    affine = MicroElementModel(dropped, LAW, non_affine=False)
    np.testing.assert_allclose(np.diag(affine.tangent())[:3], 2.0 / 3.0 * kn / a, rtol=1e-12)
    # the particles on the cell's faces, left with a contact on one side only, move to
    # balance it (eq. 2.14): softer still; the complete lattice has no such move
    assert np.all(np.diag(dropped_model.tangent())[:3] < 0.99 * 2.0 / 3.0 * kn / a)
    np.testing.assert_allclose(MicroElementModel(kept, LAW, non_affine=False).tangent(),
                               kept_model.tangent(), rtol=1e-12, atol=1e-12 * kn / a)


def test_a_packing_made_only_of_image_contacts_cannot_drop_them():
    theory = RegularPackingModel(named_packing("hexagonal"), LinearSpring2D(3e8, 1.1e8))
    network = theory.contact_network(consolidate_isotropically(theory, 1e4, steps=2))
    with pytest.raises(InputError, match="none kept"):
        micro_elements_from_snapshot(network, periodic="drop")
    with pytest.raises(InputError, match="periodic"):
        micro_elements_from_snapshot(network, periodic="ignore")
    with pytest.raises(InputError, match="walls"):
        micro_elements_from_snapshot(network, walls="keep")


# -- the load path then drives the model from the snapshot's state -----------------------------
def test_load_path_starts_from_the_snapshots_stress(tmp_path):
    """No consolidation: an isotropic compression from the lattice's isotropic state starts
    at its stress, and doubling p takes the linear lattice's strain d eps = d p a / k_n per
    axis (C11 = k_n / a, no Poisson coupling; the geometry update adds ~d eps relative)."""
    radius, force = 1e-3, 20.0
    a = 2 * radius
    network = cubic_lattice(3, radius, (force, force, force), periodic=True)
    path = write_snapshots(tmp_path / "s.h5", [network])
    kn = 1e8
    model = build_model(build_structure(str(path)), normal_stiffness=kn,
                        shear_stiffness=0.5 * kn)
    p0 = force / a**2
    with pytest.raises(InputError, match="sigma0"):
        build_model(build_structure(str(path)), sigma0=1e5)
    result = run_element_test(model, isotropic_compression(p_final=2 * p0, n_steps=4))
    table = result.table
    assert table["p"].iloc[0] == pytest.approx(p0, rel=1e-12)
    assert table["p"].iloc[-1] == pytest.approx(2 * p0, rel=1e-4)
    assert table["eps_xx"].iloc[-1] == pytest.approx(p0 * a / kn, rel=1e-3)
