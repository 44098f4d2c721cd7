"""The gyroscopic term of the free angular velocities (Numba; research/cd_engines.md 6.1,
pitfall 7; STYLE.md 2).

A rigid body with principal moments I = diag(I_1, I_2, I_3) [kg m^2] spins in its body frame by
Euler's equations I dw_b/dt = -w_b x I w_b (no contact torque in the free motion). Over a step
h [s] this is integrated by one linearised backward-Euler step,

    w_b' = w_b - h J^-1 (w_b x I w_b),    J = I + h ([w_b] I - [I w_b]),

with [a] the cross-product matrix of a (J is the Jacobian of I w + h w x I w). The implicit form
is stable at the spins where the explicit one blows up, and it conserves the kinetic energy and
the world angular momentum to first order in h (tested on a tumbling body in
``tests/engine/test_contact_dynamics.py``). Spheres (isotropic I) give w x I w = 0 exactly.

:func:`gyroscopic_spins` is the launcher: world spins in, world spins out, one body per
iteration of a compiled loop (the former per-body NumPy loop cost ~70 us a body and step, more
than the polyhedron contact detection).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(inline="always")
def _gyroscopic_body(b, spins, rotations, inertias, h, out):
    """The free spin of body b: world spin -> body frame, the backward-Euler step, -> world."""
    r = rotations[b]
    w0 = r[0, 0] * spins[b, 0] + r[1, 0] * spins[b, 1] + r[2, 0] * spins[b, 2]
    w1 = r[0, 1] * spins[b, 0] + r[1, 1] * spins[b, 1] + r[2, 1] * spins[b, 2]
    w2 = r[0, 2] * spins[b, 0] + r[1, 2] * spins[b, 1] + r[2, 2] * spins[b, 2]
    i0, i1, i2 = inertias[b, 0], inertias[b, 1], inertias[b, 2]
    l0, l1, l2 = i0 * w0, i1 * w1, i2 * w2  # I w_b
    t0 = w1 * l2 - w2 * l1  # w_b x I w_b
    t1 = w2 * l0 - w0 * l2
    t2 = w0 * l1 - w1 * l0
    # J = I + h ([w] I - [I w]); [a] = [[0, -a2, a1], [a2, 0, -a0], [-a1, a0, 0]]
    j00 = i0
    j01 = h * (-w2 * i1 + l2)
    j02 = h * (w1 * i2 - l1)
    j10 = h * (w2 * i0 - l2)
    j11 = i1
    j12 = h * (-w0 * i2 + l0)
    j20 = h * (-w1 * i0 + l1)
    j21 = h * (w0 * i1 - l0)
    j22 = i2
    c00 = j11 * j22 - j12 * j21
    c01 = j02 * j21 - j01 * j22
    c02 = j01 * j12 - j02 * j11
    c10 = j12 * j20 - j10 * j22
    c11 = j00 * j22 - j02 * j20
    c12 = j02 * j10 - j00 * j12
    c20 = j10 * j21 - j11 * j20
    c21 = j01 * j20 - j00 * j21
    c22 = j00 * j11 - j01 * j10
    det = j00 * c00 + j01 * c10 + j02 * c20
    x0 = (c00 * t0 + c01 * t1 + c02 * t2) / det
    x1 = (c10 * t0 + c11 * t1 + c12 * t2) / det
    x2 = (c20 * t0 + c21 * t1 + c22 * t2) / det
    w0 -= h * x0
    w1 -= h * x1
    w2 -= h * x2
    for i in range(3):
        out[b, i] = r[i, 0] * w0 + r[i, 1] * w1 + r[i, 2] * w2


@njit(cache=True)
def gyroscopic_kernel(spins, rotations, inertias, h, out):
    """:func:`_gyroscopic_body` for every body: spins (N, 3) world [rad/s], rotations (N, 3, 3)
    body -> world, principal inertias (N, 3) [kg m^2], step h [s]; out (N, 3) world [rad/s]."""
    for b in range(spins.shape[0]):
        _gyroscopic_body(b, spins, rotations, inertias, h, out)


def gyroscopic_spins(spins: np.ndarray, rotations: np.ndarray, inertias: np.ndarray,
                     h: float) -> np.ndarray:
    """Free world spins (N, 3) [rad/s] after the gyroscopic step of the module docstring, for
    world spins (N, 3) [rad/s], body-to-world rotations (N, 3, 3), principal inertias (N, 3)
    [kg m^2] and the step h [s]."""
    spins = np.ascontiguousarray(spins, dtype=np.float64)
    out = np.empty_like(spins)
    gyroscopic_kernel(spins, np.ascontiguousarray(rotations, dtype=np.float64),
                      np.ascontiguousarray(inertias, dtype=np.float64), float(h), out)
    return out
