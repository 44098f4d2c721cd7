"""The dashpots' bound on the soft-contact sub-step against its slow twin: the exact largest
eigenvalues of the assembled stiffness and damping matrices of small random contact networks
(STYLE.md 11, 12), and the single-mode stability condition of the explicit scheme."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from grainlab.engine.dem.soft_stability import (
    BLOCK,
    DAMPED_FRACTION,
    damped_limit,
    stable_rates_kernel,
    symmetric_max_eigenvalue,
)


def test_the_closed_form_eigenvalue_is_numpys():
    rng = np.random.default_rng(1)
    cases = [rng.normal(size=(3, 3)) for _ in range(200)]
    cases += [np.diag([2.0, 2.0, 2.0]), np.diag([1.0, 3.0, 3.0]), np.outer([1, 2, 2], [1, 2, 2])]
    for m in cases:
        m = m + m.T
        got = symmetric_max_eigenvalue(m[0, 0], m[1, 1], m[2, 2], m[1, 2], m[0, 2], m[0, 1])
        # (acos near a double eigenvalue: errors of ~sqrt(eps))
        assert got == pytest.approx(np.linalg.eigvalsh(m)[-1], rel=1e-7, abs=1e-9)


def cross(r):
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def assembled(elem_i, elem_j, normal, arm_i, arm_j, law, masses, inertia_tensors):
    """(lambda_max(M^-1 K), lambda_max(M^-1 C)) of the assembled 6N x 6N matrices."""
    n = masses.shape[0]
    stiffness, damping = np.zeros((6 * n, 6 * n)), np.zeros((6 * n, 6 * n))
    for e in range(elem_j.shape[0]):
        # the contact's rows on its bodies' 12 (or, against a wall, 6) degrees of freedom
        i, j = elem_i[e], elem_j[e]
        bodies = [j] if i < 0 else [j, i]
        g, spin = np.zeros((3, 6 * len(bodies))), np.zeros((3, 6 * len(bodies)))
        g[:, 0:3] = np.eye(3)
        g[:, 3:6] = -cross(arm_j[e])
        spin[:, 3:6] = np.eye(3)
        if i >= 0:
            g[:, 6:9] = -np.eye(3)
            g[:, 9:12] = cross(arm_i[e])
            spin[:, 9:12] = -np.eye(3)
        dofs = np.concatenate([np.arange(6 * b, 6 * b + 6) for b in bodies])
        block = np.ix_(dofs, dofs)
        nn = np.outer(normal[e], normal[e])
        kn, kt, cn, ct, kr = law[e]
        stiffness[block] += g.T @ (kt * np.eye(3) + (kn - kt) * nn) @ g
        stiffness[block] += spin.T @ (kr * (np.eye(3) - nn)) @ spin
        damping[block] += g.T @ (ct * np.eye(3) + (cn - ct) * nn) @ g
    root = np.zeros((6 * n, 6 * n))
    for b in range(n):
        root[6 * b:6 * b + 3, 6 * b:6 * b + 3] = np.eye(3) / math.sqrt(masses[b])
        w, v = np.linalg.eigh(inertia_tensors[b])
        root[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = v @ np.diag(w ** -0.5) @ v.T
    return (np.linalg.eigvalsh(root @ stiffness @ root)[-1],
            np.linalg.eigvalsh(root @ damping @ root)[-1])


def bound(elem_i, elem_j, normal, arm_i, arm_j, law, masses, inertia_tensors):
    n = masses.shape[0]
    smallest = np.array([np.linalg.eigvalsh(t)[0] for t in inertia_tensors])
    return stable_rates_kernel(elem_i, elem_j, normal, arm_i, arm_j, law, 1.0 / masses,
                               1.0 / smallest, np.empty((n, 2)), np.empty((n, 2, BLOCK)))


def random_network(seed, n_bodies=6, n_elements=14, anisotropic=False, walls=True):
    rng = np.random.default_rng(seed)
    masses = rng.uniform(0.2, 3.0, n_bodies)
    tensors = []
    for b in range(n_bodies):
        moments = masses[b] * rng.uniform(0.02, 0.3, 3 if anisotropic else 1) * np.ones(3)
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        tensors.append(q @ np.diag(moments) @ q.T)
    elem_j = rng.integers(0, n_bodies, n_elements)
    elem_i = (elem_j + rng.integers(1, n_bodies, n_elements)) % n_bodies
    if walls:
        elem_i[: n_elements // 4] = -1
    normal = rng.normal(size=(n_elements, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    arm_i, arm_j = rng.normal(scale=0.5, size=(2, n_elements, 3))
    law = rng.uniform(0.1, 2.0, (n_elements, 5))
    law[rng.random(n_elements) < 0.2] = 0.0  # some rows open
    law[:, 4] *= rng.random(n_elements) < 0.5  # rolling springs on some rows
    return elem_i, elem_j, normal, arm_i, arm_j, law, masses, np.array(tensors)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("anisotropic", [False, True])
def test_the_bound_is_never_below_the_assembled_networks_largest_rates(seed, anisotropic):
    network = random_network(seed, anisotropic=anisotropic, walls=seed % 2 == 0)
    exact_k, exact_c = assembled(*network)
    a, b, _ = bound(*network)
    assert a >= exact_k * (1.0 - 1e-12) and b >= exact_c * (1.0 - 1e-12)
    assert a <= 30.0 * exact_k  # a bound, but not a useless one


def lattice_elements(kind, kn=1.0, kt=0.5, cn=0.3, radius=0.5, mass=1.0):
    """The contacts of a periodic lattice of equal spheres (3 x 3 x 3 cells)."""
    d = 2.0 * radius
    cells = np.array(list(itertools.product(range(3), repeat=3)), dtype=float)
    if kind == "sc":
        centres, width = cells * d, 3 * d
    else:
        a = d * math.sqrt(2.0)
        basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
        centres, width = ((cells[:, None] + basis[None]) * a).reshape(-1, 3), 3 * a
    pairs = []
    for i, j in itertools.combinations(range(len(centres)), 2):
        branch = centres[j] - centres[i]
        branch -= width * np.round(branch / width)
        if abs(np.linalg.norm(branch) - d) < 1e-9:
            pairs.append((i, j, branch / d))
    elem_i = np.array([p[0] for p in pairs])
    elem_j = np.array([p[1] for p in pairs])
    normal = np.array([p[2] for p in pairs])
    law = np.tile([kn, kt, cn, math.sqrt(kt / kn) * cn, 0.0], (len(pairs), 1))
    n = len(centres)
    masses = np.full(n, mass)
    tensors = np.array([np.eye(3) * 0.4 * mass * radius**2] * n)
    return elem_i, elem_j, normal, radius * normal, -radius * normal, law, masses, tensors


@pytest.mark.parametrize("kind, z", [("fcc", 12), ("sc", 6)])
def test_the_bound_is_exact_on_the_uniform_spin_of_a_lattice(kind, z):
    """The uniform spin of equal spheres with z contacts: w^2 = (10 z / 3) k_t / m and
    beta = (10 z / 3) c_t / m, the largest rates of the lattice and those of the bound."""
    network = lattice_elements(kind)
    a, b, _ = bound(*network)
    kt, ct = network[5][0, 1], network[5][0, 3]
    assert a == pytest.approx(10.0 * z / 3.0 * kt, rel=1e-9)
    assert b == pytest.approx(10.0 * z / 3.0 * ct, rel=1e-9)
    exact_k, exact_c = assembled(*network)
    assert (a, b) == pytest.approx((exact_k, exact_c), rel=1e-9)


@pytest.mark.parametrize("w2, beta", [(4.0, 0.0), (4.0, 1.0), (20.0, 28.0), (1.0, 50.0)])
def test_the_limit_keeps_one_damped_mode_of_the_explicit_scheme_stable(w2, beta):
    """x_{n+1} - 2 x_n + x_{n-1} = -h^2 w^2 x_n - h beta (x_n - x_{n-1}): stable at the
    limit (undamped: neither growing nor decaying), unstable a little beyond the bound it is
    a fraction of."""
    h = damped_limit(w2, beta)

    def growth(step):
        roots = np.roots([1.0, -(2.0 - step * step * w2 - step * beta), 1.0 - step * beta])
        return np.max(np.abs(roots))

    assert growth(h) <= 1.0 + 1e-12
    assert growth(1.05 * h / DAMPED_FRACTION) > 1.0


def test_a_dashpot_does_not_reverse_the_approach_it_damps_within_a_sub_step():
    """Two spheres head-on: the relaxation rate of the contact's normal dashpot is
    c_n (1/m_i + 1/m_j), and the limit keeps h c_n / m* <= the safety fraction; an overdamped
    dashpot is held by it, not by the stability bound (which allows h c_n / m* up to 2)."""
    masses = np.array([1.0, 3.0])
    tensors = np.array([np.eye(3) * 0.1, np.eye(3) * 0.3])
    n = np.array([[1.0, 0.0, 0.0]])
    law = np.array([[1.0, 0.5, 10.0, 0.0, 0.0]])
    network = (np.array([0]), np.array([1]), n, 0.5 * n, -0.5 * n, law, masses, tensors)
    a, b, relaxation = bound(*network)
    assert relaxation == pytest.approx(10.0 * (1.0 + 1.0 / 3.0))
    assert damped_limit(a, b, relaxation) == pytest.approx(DAMPED_FRACTION / relaxation)
    assert damped_limit(a, b, relaxation) < damped_limit(a, b)
