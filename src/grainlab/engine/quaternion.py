"""Unit quaternions for rigid-body orientation (Numba; STYLE.md 2).

Convention: q = (w, x, y, z), scalar first, Hamilton product. A unit quaternion q maps body-frame
vectors to the world frame, v_world = R(q) v_body, with

    R(q) = [[1 - 2(y^2 + z^2), 2(xy - wz),       2(xz + wy)      ],
            [2(xy + wz),       1 - 2(x^2 + z^2), 2(yz - wx)      ],
            [2(xz - wy),       2(yz + wx),       1 - 2(x^2 + y^2)]],

and R(p q) = R(p) R(q): the product p q first applies q, then p.

The scalar laws (:func:`rotate`) are inlined into kernels; the array helpers allocate their
small results and are meant for Python code and tests.

>>> import numpy as np
>>> q = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])  # 90 deg about z
>>> np.round(quat_to_matrix(q) @ np.array([1.0, 0.0, 0.0]), 12) + 0.0
array([0., 1., 0.])
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainlab._numba_setup import kernel_input


@njit(inline="always")
def rotate(w, x, y, z, vx, vy, vz):
    """R(q) v for q = (w, x, y, z) (unit) and v = (vx, vy, vz); returns three floats."""
    return (
        (1.0 - 2.0 * (y * y + z * z)) * vx + 2.0 * (x * y - w * z) * vy
        + 2.0 * (x * z + w * y) * vz,
        2.0 * (x * y + w * z) * vx + (1.0 - 2.0 * (x * x + z * z)) * vy
        + 2.0 * (y * z - w * x) * vz,
        2.0 * (x * z - w * y) * vx + 2.0 * (y * z + w * x) * vy
        + (1.0 - 2.0 * (x * x + y * y)) * vz,
    )


@njit(cache=True)
def quat_to_matrix(q):
    """Rotation matrix (3, 3) of a unit quaternion q (4,) = (w, x, y, z)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    m = np.empty((3, 3))
    m[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    m[0, 1] = 2.0 * (x * y - w * z)
    m[0, 2] = 2.0 * (x * z + w * y)
    m[1, 0] = 2.0 * (x * y + w * z)
    m[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    m[1, 2] = 2.0 * (y * z - w * x)
    m[2, 0] = 2.0 * (x * z - w * y)
    m[2, 1] = 2.0 * (y * z + w * x)
    m[2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return m


@njit(cache=True, parallel=True)
def quat_to_matrices_kernel(q, out):
    """Rotation matrices of N unit quaternions: ``q`` (N, 4) -> ``out`` (N, 3, 3)."""
    for i in prange(q.shape[0]):
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        out[i, 0, 0] = 1.0 - 2.0 * (y * y + z * z)
        out[i, 0, 1] = 2.0 * (x * y - w * z)
        out[i, 0, 2] = 2.0 * (x * z + w * y)
        out[i, 1, 0] = 2.0 * (x * y + w * z)
        out[i, 1, 1] = 1.0 - 2.0 * (x * x + z * z)
        out[i, 1, 2] = 2.0 * (y * z - w * x)
        out[i, 2, 0] = 2.0 * (x * z - w * y)
        out[i, 2, 1] = 2.0 * (y * z + w * x)
        out[i, 2, 2] = 1.0 - 2.0 * (x * x + y * y)


def quat_to_matrices(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of unit quaternions ``q`` (N, 4), w first."""
    q = kernel_input(np.reshape(q, (-1, 4)), np.float64)
    out = np.empty((q.shape[0], 3, 3))
    quat_to_matrices_kernel(q, out)
    return out


@njit(cache=True)
def quat_multiply(p, q):
    """Hamilton product p q (4,) of quaternions p, q (4,): R(p q) = R(p) R(q)."""
    pw, px, py, pz = p[0], p[1], p[2], p[3]
    qw, qx, qy, qz = q[0], q[1], q[2], q[3]
    out = np.empty(4)
    out[0] = pw * qw - px * qx - py * qy - pz * qz
    out[1] = pw * qx + px * qw + py * qz - pz * qy
    out[2] = pw * qy - px * qz + py * qw + pz * qx
    out[3] = pw * qz + px * qy - py * qx + pz * qw
    return out


@njit(cache=True)
def quat_normalise(q):
    """q / |q| (4,); the identity (1, 0, 0, 0) for a zero quaternion."""
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    out = np.zeros(4)
    if n == 0.0:
        out[0] = 1.0
        return out
    for k in range(4):
        out[k] = q[k] / n
    return out


SMALL_TURN = 0.05
"""Half-angles [rad] below which :func:`half_turn` sums the series instead of calling the C
library's sine and cosine."""


@njit(inline="always")
def half_turn_series(half):
    """(cos a, sin a / a) of a half-angle a = ``half`` [rad] by their Taylor series to a^10
    (the next term, a^12 / 12!, is below 1e-24 for a < :data:`SMALL_TURN`), in five
    multiply-adds each and without a branch (vector code may use it)."""
    a2 = half * half
    cos = 1.0 + a2 * (-1.0 / 2.0 + a2 * (1.0 / 24.0 + a2 * (
        -1.0 / 720.0 + a2 * (1.0 / 40320.0 + a2 * (-1.0 / 3628800.0)))))
    sinc = 1.0 + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 + a2 * (
        -1.0 / 5040.0 + a2 * (1.0 / 362880.0 + a2 * (-1.0 / 39916800.0)))))
    return cos, sinc


@njit(inline="always")
def half_turn(half):
    """(cos a, sin a / a) of a half-angle a = ``half`` >= 0 [rad] of a turn, as the rotation
    quaternion exp(a u) = (cos a, (sin a / a) a u) needs them. Below :data:`SMALL_TURN`, the
    turns of a sub-step, by their Taylor series (:func:`half_turn_series`): within a few
    units in the last place of the library's, the same bits on every processor, and about
    five times faster than its two calls (which were four fifths of the drift of spinning
    spheres)."""
    if half < SMALL_TURN:
        return half_turn_series(half)
    return math.cos(half), math.sin(half) / half


@njit(inline="always")
def turned(w, x, y, z, cos, factor, wx, wy, wz):
    """The unit quaternion (w, x, y, z) turned by the rotation quaternion (cos a, factor
    omega) (``factor`` = sin a / |omega| [s]), then put back onto |q| = 1 by one Newton step
    of 1 / sqrt(|q|^2) from 1 (|q|^2 - 1 is a few rounding errors: the step leaves
    (|q|^2 - 1)^2, below them), without a root or a division."""
    dx, dy, dz = factor * wx, factor * wy, factor * wz
    nw = cos * w - dx * x - dy * y - dz * z
    nx = cos * x + w * dx + dy * z - dz * y
    ny = cos * y + w * dy + dz * x - dx * z
    nz = cos * z + w * dz + dx * y - dy * x
    unit = 1.5 - 0.5 * (nw * nw + nx * nx + ny * ny + nz * nz)
    return nw * unit, nx * unit, ny * unit, nz * unit


@njit(cache=True, _nrt=False)
def turn_quaternions_kernel(q, rotation, out):
    """exp(rotation / 2) q, normalised, for unit quaternions ``q`` (N, 4) and world rotation
    vectors ``rotation`` (N, 3) [rad], into ``out`` (N, 4): each row in scalar code with the
    C library's sine and cosine (NumPy's own, vectorised by processor, differ in the last
    bits from one processor to the next)."""
    for i in range(q.shape[0]):
        rx, ry, rz = rotation[i, 0], rotation[i, 1], rotation[i, 2]
        angle = math.sqrt(rx * rx + ry * ry + rz * rz)
        half = 0.5 * angle
        factor = math.sin(half) / angle if angle > 0.0 else 0.5
        dw = math.cos(half)
        dx, dy, dz = factor * rx, factor * ry, factor * rz
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        nw = dw * w - (dx * x + dy * y + dz * z)
        nx = dw * x + w * dx + (dy * z - dz * y)
        ny = dw * y + w * dy + (dz * x - dx * z)
        nz = dw * z + w * dz + (dx * y - dy * x)
        norm = math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = nw / norm, nx / norm, ny / norm, nz / norm


def rotate_quaternions(q: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """exp(rotation / 2) q, normalised, for unit quaternions q (N, 4) and world rotation
    vectors (N, 3) [rad] (:func:`~grainlab.engine.quaternion.turn_quaternions_kernel`: the
    same bits on every processor)."""
    q = np.ascontiguousarray(q, dtype=np.float64).reshape(-1, 4)
    out = np.empty_like(q)
    turn_quaternions_kernel(q, np.ascontiguousarray(rotation, dtype=np.float64).reshape(-1, 3),
                            out)
    return out




