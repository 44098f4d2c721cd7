"""The Coulomb cone of contact dynamics (grainlab.contact.coulomb_cone): the projection
against its NumPy twin and Moreau's decomposition, the local solve's open, sticking and
sliding solutions, and the natural-map residual that vanishes at a solution."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainlab.contact.coulomb_cone import local_solve, natural_map, project_cone
from grainlab.engine.nscd.contact_problem import project_on_cones


def test_the_projection_is_moreau_s_and_agrees_with_its_numpy_twin():
    rng = np.random.default_rng(3)
    z = rng.normal(size=(300, 3))
    mu = rng.uniform(0.05, 1.5, size=300)
    twin = project_on_cones(z, mu)
    for a in range(300):
        p = np.array(project_cone(mu[a], *z[a]))
        assert p == pytest.approx(twin[a], rel=1e-14, abs=1e-15)
        assert math.hypot(p[1], p[2]) <= mu[a] * p[0] * (1 + 1e-14)  # in K
        q = z[a] - p  # in the polar cone, orthogonal to p
        assert mu[a] * math.hypot(q[1], q[2]) <= -q[0] + 1e-14
        assert abs(p @ q) <= 1e-13 * (1.0 + z[a] @ z[a])
        assert np.array(project_cone(mu[a], *p)) == pytest.approx(p, rel=1e-14, abs=1e-15)


def _block(rng):
    """A Delassus block [1/kg] as of a contact between bodies: a positive diagonal and a weak
    symmetric coupling of the normal and tangential directions."""
    a = 0.1 * rng.normal(size=(3, 3))
    return np.diag(rng.uniform(1.0, 3.0, size=3)) + 0.5 * (a + a.T)


def test_an_opening_contact_carries_nothing():
    w = _block(np.random.default_rng(0))
    assert local_solve(w, 0.1, 0.3, -0.2, 0.5, 1.0, 0.0, 0.0) == (0.0, 0.0, 0.0)


def test_a_sticking_contact_stops_the_relative_motion():
    w = np.diag([2.0, 3.0, 3.0])
    u_free = np.array([-1.0, 0.1, -0.05])
    p = np.array(local_solve(w, *u_free, 0.5, 0.0, 0.0, 0.0))
    assert p == pytest.approx(-np.linalg.solve(w, u_free), rel=1e-14)
    assert w @ p + u_free == pytest.approx(np.zeros(3), abs=1e-14)


def test_the_local_solutions_satisfy_coulomb_s_law():
    rng = np.random.default_rng(5)
    sliding = 0
    for _ in range(200):
        w, mu = _block(rng), rng.uniform(0.1, 1.0)
        u_free = rng.normal(size=3)
        u_free[0] = -abs(u_free[0])
        p = np.array(local_solve(w, *u_free, mu, 0.0, 0.0, 0.0))
        u = w @ p + u_free
        res2, z2, u2 = natural_map(mu, 1.0, *p, *u)  # W_nn = 1: z = P
        assert math.sqrt(res2) <= 1e-9 * math.sqrt(max(z2, u2))
        sliding += math.hypot(p[1], p[2]) > mu * p[0] * (1 - 1e-9)
    assert sliding > 20


def test_the_natural_map_is_not_zero_off_a_solution():
    # an impulse on a separating contact: frictionless part r_n = min(z_n, U_n) = U_n
    res2, z2, u2 = natural_map(0.3, 2.0, 1.0, 0.0, 0.0, 0.5, 0.0, 0.0)
    assert z2 == 4.0 and u2 == 0.25
    assert res2 == 0.25
    # an open contact (P = 0, separating) is a solution
    assert natural_map(0.3, 2.0, 0.0, 0.0, 0.0, 0.5, 0.2, 0.0)[0] == 0.0
