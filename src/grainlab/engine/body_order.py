"""The order in which the bodies are stored for the sweeps: along a Morton (Z-order) curve of
their positions, so that the bodies of neighbouring contacts sit near each other in memory
(better use of the caches; the same results in any order).
"""

from __future__ import annotations

import numpy as np


def spatial_order(positions, bits: int = 10) -> np.ndarray:
    """The bodies at ``positions`` (N, 3) [m] sorted along a Morton (Z-order) curve on a
    grid of 2^``bits`` cells per axis over their bounding box (stable in the body index):
    bodies near in space end up near in memory (:func:`~grainlab.engine.nscd.nlgs_parallel.
    nlgs_coloured_kernel`'s ``body_order``)."""
    x = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    if x.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    low = x.min(axis=0)
    width = np.maximum(x.max(axis=0) - low, 1e-300)
    cells = np.clip(((x - low) / width * (1 << bits)).astype(np.int64), 0, (1 << bits) - 1)
    code = np.zeros(x.shape[0], dtype=np.int64)
    for bit in range(bits):
        for axis in range(3):
            code |= ((cells[:, axis] >> bit) & 1) << (3 * bit + axis)
    return np.argsort(code, kind="stable").astype(np.int64)
