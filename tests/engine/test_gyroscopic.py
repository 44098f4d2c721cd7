"""The compiled gyroscopic step against a plain NumPy twin, and its physics."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from grainlab.engine.gyroscopic import gyroscopic_spins
from grainlab.engine.quaternion import quat_to_matrices


def skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def twin(spins, rotations, inertias, h):
    """Backward-Euler step body by body with a dense solve (the formula of the docstring)."""
    out = np.empty_like(spins)
    for b in range(len(spins)):
        inertia = np.diag(inertias[b])
        wb = rotations[b].T @ spins[b]
        iw = inertia @ wb
        jac = inertia + h * (skew(wb) @ inertia - skew(iw))
        out[b] = rotations[b] @ (wb - h * np.linalg.solve(jac, np.cross(wb, iw)))
    return out


def random_bodies(n, seed):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    return (rng.normal(scale=300.0, size=(n, 3)), quat_to_matrices(q),
            rng.uniform(1e-12, 5e-12, size=(n, 3)))


def test_compiled_step_matches_the_dense_twin():
    spins, rotations, inertias = random_bodies(200, 1)
    h = 1e-4
    np.testing.assert_allclose(gyroscopic_spins(spins, rotations, inertias, h),
                               twin(spins, rotations, inertias, h), rtol=1e-12, atol=1e-9)


def test_isotropic_bodies_and_principal_axes_keep_their_spin():
    spins, rotations, inertias = random_bodies(50, 2)
    spherical = np.repeat(inertias[:, :1], 3, axis=1)
    np.testing.assert_allclose(gyroscopic_spins(spins, rotations, spherical, 1e-3), spins,
                               rtol=1e-13, atol=1e-10)
    axis = rotations[:, :, 1] * 40.0  # spinning about a principal axis: steady rotation
    np.testing.assert_allclose(gyroscopic_spins(axis, rotations, inertias, 1e-3), axis,
                               rtol=1e-13, atol=1e-10)


def test_step_is_invariant_under_a_rotation_of_the_world():
    spins, rotations, inertias = random_bodies(30, 3)
    turn = Rotation.from_rotvec([0.3, -0.8, 0.5]).as_matrix()
    once = gyroscopic_spins(spins, rotations, inertias, 2e-4)
    turned = gyroscopic_spins(spins @ turn.T, np.einsum("ij,njk->nik", turn, rotations),
                              inertias, 2e-4)
    np.testing.assert_allclose(turned, once @ turn.T, rtol=1e-12, atol=1e-9)
