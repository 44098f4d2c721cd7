"""The bodies' pass of a sub-step as vector code (:mod:`grainlab.engine.dem.sphere_bodies`)
against the scalar pass of :func:`~grainlab.engine.dem.soft_contact_kernels.bodies_kernel`: the
same velocities, spins, positions, orientations and travels, bit for bit, for spheres that
do not turn, turn a little or turn by large angles in a sub-step, with and without the take-up
of a change of the cell's velocity gradient."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.engine.dem.body_pass import BODY_BLOCK, bodies_kernel, isotropic_blocks
from grainlab.engine.quaternion import SMALL_TURN


def random_bodies(seed: int, n: int = 2 * BODY_BLOCK + 77):
    """Spheres with random loads, velocities and unit quaternions; spins of three kinds: zero,
    small (a half-turn below SMALL_TURN in a sub-step) and large (above it)."""
    rng = np.random.default_rng(seed)
    dt = 1e-6
    spins = rng.normal(size=(n, 3))
    spins /= np.linalg.norm(spins, axis=1)[:, None]
    kind = rng.integers(0, 3, n)
    size = np.where(kind == 0, 0.0, np.where(kind == 1, 0.2, 5.0) * SMALL_TURN * 2.0 / dt)
    spins *= (size * rng.uniform(0.5, 1.0, n))[:, None]
    orientations = rng.normal(size=(n, 4))
    orientations /= np.linalg.norm(orientations, axis=1)[:, None]
    masses = rng.uniform(1e-6, 3e-6, n)
    inertia = 0.4 * masses * 1e-6
    torque = rng.normal(0.0, 1e-7, (n, 3)) * (kind > 0)[:, None]  # kind 0 keeps zero spin
    return dict(dt=dt, masses=masses, inv_mass=1.0 / masses,
                principal=np.repeat(inertia[:, None], 3, axis=1),
                isotropic=np.ones(n, dtype=bool), arm=rng.uniform(0.0, 1e-3, n),
                positions=rng.uniform(0.0, 0.02, (n, 3)), orientations=orientations,
                velocities=rng.normal(0.0, 0.01, (n, 3)), spins=spins,
                body_force=rng.normal(0.0, 1e-3, (n, 3)),
                body_torque=torque, kind=kind)


def run_pass(bodies, close, carry, open_, vector):
    """One bodies' pass, vector blocks or not; each body's load comes through one row of the
    gather's list (no gravity)."""
    n = bodies["masses"].shape[0]
    out = {k: bodies[k].copy() for k in ("positions", "orientations", "velocities", "spins")}
    travel = np.zeros(n)
    # each body's load through one row of the gather's list: entry 2 k (the j side of row k)
    adj_start = np.arange(n + 1, dtype=np.int64)
    adj_entry = 2 * np.arange(n, dtype=np.int64)
    force, torque_j = bodies["body_force"].copy(), bodies["body_torque"].copy()
    body_force, body_torque = np.zeros((n, 3)), np.zeros((n, 3))
    gradient = np.array([[1e-2, 3e-3, 0.0], [0.0, -2e-2, 1e-3], [4e-3, 0.0, 5e-3]])
    carried = np.zeros((3, 3))
    plain = isotropic_blocks(bodies["isotropic"]) & vector
    bodies_kernel(close, carry, open_, 0.5 * bodies["dt"], bodies["dt"], adj_start, adj_entry,
                  force, np.zeros((n, 3)), torque_j, bodies["masses"], np.zeros(3),
                  bodies["inv_mass"], bodies["principal"], bodies["isotropic"], 0.0,
                  bodies["arm"], gradient, carried, 0.01, 0.009, 0.011, out["positions"],
                  out["orientations"], out["velocities"], out["spins"], body_force,
                  body_torque, travel, plain)
    out["travel"], out["body_force"] = travel, body_force
    return out


@pytest.mark.parametrize(("close", "carry", "open_"), [
    (True, True, True), (True, False, True), (False, False, True), (True, True, False)])
def test_vector_bodies_give_the_scalar_bodies_bits(close, carry, open_):
    bodies = random_bodies(seed=3)
    scalar = run_pass(bodies, close, carry, open_, vector=False)
    vector = run_pass(bodies, close, carry, open_, vector=True)
    for name in scalar:
        assert np.array_equal(vector[name], scalar[name]), name
    turned = np.any(scalar["orientations"] != bodies["orientations"], axis=1)
    if open_:  # every kind of turn was there: none, the series', the library's
        assert not np.any(turned[bodies["kind"] == 0])
        assert np.all(turned[bodies["kind"] > 0])
        assert np.allclose(np.linalg.norm(vector["orientations"], axis=1), 1.0, atol=1e-15)
    else:
        assert not np.any(turned)


def test_blocks_with_an_anisotropic_body_go_body_by_body():
    isotropic = np.ones(2 * BODY_BLOCK + 3, dtype=bool)
    assert isotropic_blocks(isotropic).tolist() == [True, True, True]
    isotropic[BODY_BLOCK + 1] = False
    assert isotropic_blocks(isotropic).tolist() == [True, False, True]
