"""The closing velocities a step reports and its frictionless correction reads: the compiled
law of the sweeps against its NumPy twin and a hand-worked contact."""

from __future__ import annotations

import numpy as np

from grainlab.engine.nscd.contact_dynamics import _closing_velocities, closing_velocities_twin
from grainlab.engine.nscd.sweep_arrays import ContactRows, Motion, WallRows


def _scene(rng, n_bodies=7, n_contacts=40, n_walls=3):
    body_i = rng.integers(-n_walls, n_bodies, n_contacts)  # -1 - w: wall w
    body_j = rng.integers(0, n_bodies, n_contacts)
    frames = np.linalg.qr(rng.normal(size=(n_contacts, 3, 3)))[0]
    images = rng.integers(-1, 2, (n_contacts, 3)).astype(float)
    images[rng.random(n_contacts) < 0.5] = 0.0  # half the pairs inside the cell
    rows = ContactRows(body_i, body_j, np.ascontiguousarray(frames),
                       rng.normal(size=(n_contacts, 3)) * 1e-3,
                       rng.normal(size=(n_contacts, 3)) * 1e-3, images,
                       np.full(n_contacts, 0.4), rng.random(n_contacts) * 1e-5)
    normals = rng.normal(size=(n_walls, 3))
    walls = WallRows(normals / np.linalg.norm(normals, axis=1)[:, None], np.ones(n_walls),
                     np.zeros(n_walls), np.full(n_walls, np.inf))
    motion = Motion(rng.normal(size=(n_bodies, 3)), rng.normal(size=(n_bodies, 3)) * 100.0,
                    rng.normal(size=n_walls), np.zeros(0), rng.normal(size=(3, 3)) * 1e-2)
    return rows, walls, motion


def test_the_compiled_closing_velocities_match_their_numpy_twin():
    rng = np.random.default_rng(5)
    for _ in range(5):
        rows, walls, motion = _scene(rng)
        np.testing.assert_allclose(_closing_velocities(rows, walls, motion),
                                   closing_velocities_twin(rows, walls, motion),
                                   rtol=1e-12, atol=1e-15)


def test_a_spinning_body_slides_past_a_resting_one_at_omega_times_its_arm():
    """Body j spins at omega about z; the contact point lies r along x from its centre: the
    point moves at omega r along y, which the contact's frame (n = x, t = y, s = z) reads as a
    tangential velocity omega r and no approach. Through a periodic image moving with the
    cell at hdot m, that velocity is added."""
    omega, r = 3.0, 2e-3
    rows = ContactRows(np.array([0]), np.array([1]), np.eye(3)[None].copy(),
                       np.array([[r, 0.0, 0.0]]), np.array([[r, 0.0, 0.0]]),
                       np.zeros((1, 3)), np.array([0.4]), np.zeros(1))
    walls = WallRows(np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0))
    motion = Motion(np.zeros((2, 3)), np.array([[0.0, 0.0, 0.0], [0.0, 0.0, omega]]),
                    np.zeros(0), np.zeros(0), np.zeros((3, 3)))
    np.testing.assert_allclose(_closing_velocities(rows, walls, motion), [[0.0, omega * r, 0.0]])
    rate = np.zeros((3, 3))
    rate[0, 0] = -0.5  # the cell shortens along x at 0.5 m/s per cell length
    imaged = rows._replace(images=np.array([[1.0, 0.0, 0.0]]))
    np.testing.assert_allclose(_closing_velocities(imaged, walls, motion._replace(cell_rate=rate)),
                               [[-0.5, omega * r, 0.0]])
