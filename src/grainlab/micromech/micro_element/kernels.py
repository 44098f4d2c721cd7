"""Compiled kernels of the micro-element model (Numba; STYLE.md 2: array kernels, outputs last).

:func:`local_stiffness_kernel` builds, for every micro-element, the stretch maps P (eq. 2.15,
with the non-affine T of eq. 2.14) and the full-tensor local stiffness C^n (eq. 2.18), looping
over micro-elements and contacts with small fixed-size matrices; the slow, obviously right twin
is the NumPy version in the tests.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(inline="always")
def _inverse_or_pinv(a):
    """Inverse of a small symmetric positive semi-definite matrix; the pseudo-inverse when it
    is (nearly) singular."""
    d = a.shape[0]
    if d == 2:
        det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        scale = abs(a[0, 0]) + abs(a[1, 1]) + 1e-300
        if abs(det) > 1e-10 * scale * scale:
            inv = np.empty((2, 2))
            inv[0, 0] = a[1, 1] / det
            inv[1, 1] = a[0, 0] / det
            inv[0, 1] = -a[0, 1] / det
            inv[1, 0] = -a[1, 0] / det
            return inv
    elif d == 3:
        c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
        c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
        c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
        det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
        scale = abs(a[0, 0]) + abs(a[1, 1]) + abs(a[2, 2]) + 1e-300
        if abs(det) > 1e-10 * scale * scale * scale:
            inv = np.empty((3, 3))
            inv[0, 0] = c00 / det
            inv[1, 0] = c01 / det
            inv[2, 0] = c02 / det
            inv[0, 1] = (a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]) / det
            inv[1, 1] = (a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]) / det
            inv[2, 1] = (a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]) / det
            inv[0, 2] = (a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]) / det
            inv[1, 2] = (a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]) / det
            inv[2, 2] = (a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) / det
            return inv
    return np.linalg.pinv(a, 1e-12)


@njit(cache=True, parallel=True)
def local_stiffness_kernel(branches, mask, kn, kr, volumes, non_affine, p_out, c_out):
    """Fill p_out (E, M, d, d*d) with P[e, m, p, k*d + l] = delta_pk L_l + T[e, p, k*d + l] and
    c_out (E, d*d, d*d) with C[e, i*d + j, k*d + l] = 1/(2 V^e) sum_m K_ip P_p(kl) L_j.

    K = k_n n n + k_r (I - n n); T = -[sum_m K]^+ [sum_m K_qk L_l] when ``non_affine`` and the
    micro-element has at least two contacts (pseudo-inverse: a free direction of the centre
    particle takes no move), else 0.
    """
    n_elements, n_contacts, d = branches.shape
    dd = d * d
    for e in prange(n_elements):
        a = np.zeros((d, d))
        b = np.zeros((d, dd))
        stiff = np.zeros((n_contacts, d, d))
        count = 0
        for m in range(n_contacts):
            if not mask[e, m]:
                continue
            count += 1
            length = 0.0
            for i in range(d):
                length += branches[e, m, i] ** 2
            length = np.sqrt(length)
            for i in range(d):
                for j in range(d):
                    nn = branches[e, m, i] * branches[e, m, j] / (length * length)
                    k_ij = kn[e, m] * nn + kr[e, m] * ((1.0 if i == j else 0.0) - nn)
                    stiff[m, i, j] = k_ij
                    a[i, j] += k_ij
            for q in range(d):
                for k in range(d):
                    for col in range(d):
                        b[q, k * d + col] += stiff[m, q, k] * branches[e, m, col]
        t = np.zeros((d, dd))
        if non_affine and count >= 2:
            t = -(np.ascontiguousarray(_inverse_or_pinv(a)) @ b)
        for i in range(dd):
            for j in range(dd):
                c_out[e, i, j] = 0.0
        scale = 1.0 / (2.0 * volumes[e])
        for m in range(n_contacts):
            for p in range(d):
                for q in range(dd):
                    p_out[e, m, p, q] = 0.0
            if not mask[e, m]:
                continue
            for p in range(d):
                for k in range(d):
                    for col in range(d):
                        p_out[e, m, p, k * d + col] = (
                            (branches[e, m, col] if p == k else 0.0) + t[p, k * d + col])
            for i in range(d):
                for q in range(dd):
                    kp = 0.0
                    for p in range(d):
                        kp += stiff[m, i, p] * p_out[e, m, p, q]
                    for j in range(d):
                        c_out[e, i * d + j, q] += scale * kp * branches[e, m, j]
