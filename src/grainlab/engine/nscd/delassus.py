"""The Delassus blocks W_kk of the contacts (their local 3 x 3 compliance: seed 002 eq. 1 and
research/cd_engines.md 1.2), with W_tt clamped to >= 1e-6 W_nn (pitfall 5) (Numba).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from grainlab.engine.nscd.contact_update import _dot3

_WTT_CLAMP = 1e-6  # W_tt >= 1e-6 W_nn (LMGC90, pitfall 5)


# --------------------------------------------------------------------------------------------
# Array kernels (outputs last)
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def delassus_kernel(body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                    wall_inv_mass, images, cell_basis, cell_inv_mass, out):
    """Local Delassus blocks W_aa (C, 3, 3) [1/kg] = F (K_i + K_j) F^T (module docstring);
    a wall w contributes K = wall_inv_mass[w] n_w n_w^T, and the free degrees of freedom of
    a periodic cell K = sum_d kappa_d g_d g_d^T at a contact with an image m_k (g_d =
    H_d m_k, :func:`_apply_to_cell`)."""
    _delassus_blocks(body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                     wall_inv_mass, images, cell_basis, cell_inv_mass, np.empty((3, 3, 3)), out)


# no reference counts on the arrays in the loops (inline helpers): compiled without the Numba
# runtime (_nrt=False), so it allocates nothing (scratch from the caller)
@njit(cache=True, _nrt=False)
def _delassus_blocks(body_i, body_j, frame, arm_i, arm_j, inv_mass, inv_inertia, wall_normals,
                     wall_inv_mass, images, cell_basis, cell_inv_mass, scratch, out):
    """:func:`delassus_kernel` with a scratch array (3, 3, 3) for K, [r] and products."""
    k_world, skew, product = scratch[0], scratch[1], scratch[2]
    for k in range(body_i.shape[0]):
        for d in range(3):
            for e in range(3):
                k_world[d, e] = 0.0
        for side in range(2):
            b = body_j[k] if side == 0 else body_i[k]
            if b < 0:
                w = -1 - b
                for d in range(3):
                    for e in range(3):
                        k_world[d, e] += (wall_inv_mass[w] * wall_normals[w, d]
                                          * wall_normals[w, e])
                continue
            r = arm_j[k] if side == 0 else arm_i[k]
            skew[0, 0], skew[0, 1], skew[0, 2] = 0.0, -r[2], r[1]
            skew[1, 0], skew[1, 1], skew[1, 2] = r[2], 0.0, -r[0]
            skew[2, 0], skew[2, 1], skew[2, 2] = -r[1], r[0], 0.0
            # [r]^T I^-1 [r] = -[r] I^-1 [r]
            inv = inv_inertia[b]
            for d in range(3):
                for e in range(3):
                    product[d, e] = _dot3(skew[d, 0], skew[d, 1], skew[d, 2],
                                          inv[0, e], inv[1, e], inv[2, e])
            for d in range(3):
                for e in range(3):
                    k_world[d, e] -= _dot3(product[d, 0], product[d, 1], product[d, 2],
                                           skew[0, e], skew[1, e], skew[2, e])
            for d in range(3):
                k_world[d, d] += inv_mass[b]
        mx, my, mz = images[k, 0], images[k, 1], images[k, 2]
        if mx != 0.0 or my != 0.0 or mz != 0.0:
            for c in range(cell_inv_mass.shape[0]):
                h = cell_basis[c]
                gx = h[0, 0] * mx + h[0, 1] * my + h[0, 2] * mz
                gy = h[1, 0] * mx + h[1, 1] * my + h[1, 2] * mz
                gz = h[2, 0] * mx + h[2, 1] * my + h[2, 2] * mz
                kappa = cell_inv_mass[c]
                k_world[0, 0] += kappa * gx * gx
                k_world[0, 1] += kappa * gx * gy
                k_world[0, 2] += kappa * gx * gz
                k_world[1, 0] += kappa * gy * gx
                k_world[1, 1] += kappa * gy * gy
                k_world[1, 2] += kappa * gy * gz
                k_world[2, 0] += kappa * gz * gx
                k_world[2, 1] += kappa * gz * gy
                k_world[2, 2] += kappa * gz * gz
        # W = F K F^T
        f = frame[k]
        for d in range(3):
            for e in range(3):
                product[d, e] = _dot3(f[d, 0], f[d, 1], f[d, 2],
                                      k_world[0, e], k_world[1, e], k_world[2, e])
        for d in range(3):
            for e in range(3):
                out[k, d, e] = _dot3(product[d, 0], product[d, 1], product[d, 2],
                                     f[e, 0], f[e, 1], f[e, 2])
        for d in range(1, 3):
            out[k, d, d] = max(out[k, d, d], _WTT_CLAMP * out[k, 0, 0])




