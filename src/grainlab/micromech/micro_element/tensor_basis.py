"""Bases for second-order tensors: full (row-major, d^2 components), symmetric Voigt with
engineering shears, and skew parts; used to condense the asymmetric strain of seed 001.

A full tensor a (d, d) is flattened row-major, a_flat[d*i + j] = a_ij.

* strain: a_flat = S e + W w, with e the Voigt strain (engineering shears) and w the skew
  components (w_k = a_[ij] for (ij) = (yz, xz, xy) in 3D, (xy) in 2D);
* stress: the Voigt stress of the symmetric part is S' a_flat, the skew part W' a_flat, with
  S', W' the dual projectors (S' S = I, W' W = I, S' W = 0, W' S = 0).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

PAIRS_3D = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
PAIRS_2D = ((0, 0), (1, 1), (0, 1))
SKEW_3D = ((1, 2), (0, 2), (0, 1))
SKEW_2D = ((0, 1),)


@lru_cache(maxsize=2)
def bases(dimension: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(S, W, S_dual, W_dual) for d = 2 or 3 (see the module docstring)."""
    d = dimension
    pairs = PAIRS_3D if d == 3 else PAIRS_2D
    skews = SKEW_3D if d == 3 else SKEW_2D
    n_v, n_w = len(pairs), len(skews)
    s = np.zeros((d * d, n_v))
    s_dual = np.zeros((n_v, d * d))
    for k, (i, j) in enumerate(pairs):
        if i == j:
            s[d * i + j, k] = 1.0
            s_dual[k, d * i + j] = 1.0
        else:
            s[d * i + j, k] = s[d * j + i, k] = 0.5  # engineering shear: e_ij = g/2
            s_dual[k, d * i + j] = s_dual[k, d * j + i] = 0.5  # sigma_sym = (s_ij + s_ji)/2
    w = np.zeros((d * d, n_w))
    w_dual = np.zeros((n_w, d * d))
    for k, (i, j) in enumerate(skews):
        w[d * i + j, k], w[d * j + i, k] = 1.0, -1.0
        w_dual[k, d * i + j], w_dual[k, d * j + i] = 0.5, -0.5
    for array in (s, w, s_dual, w_dual):
        array.setflags(write=False)
    return s, w, s_dual, w_dual
