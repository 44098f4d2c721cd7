"""The rows of a soft-contact neighbour list made from the detection's contacts, compiled
(Numba; STYLE.md 2, 8): each row's member spheres, and the springs the rows of the list it
replaces carried (:mod:`grainlab.engine.dem.soft_contact`).

A list is built every few tens of sub-steps, so its making is measured against them: with
NumPy's fancy indexing, gathers and a sort, the rows of 4000 spheres took ~2 ms beside the
~2.5 ms of the detection, as long as about five sub-steps. Each kernel here is one pass.

>>> import numpy as np
>>> old_keys = np.array([3, 7, 9]); old = np.arange(9.0).reshape(3, 3)
>>> new_keys = np.array([7, 8, 9]); xi, roll = np.zeros((3, 3)), np.zeros((3, 3))
>>> carry_springs_kernel(old_keys, old, -old, new_keys, xi, roll)    # rows 0 and 2 found
2
>>> xi.tolist(), roll[2].tolist()
([[3.0, 4.0, 5.0], [0.0, 0.0, 0.0], [6.0, 7.0, 8.0]], [-6.0, -7.0, -8.0])
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, _nrt=False)
def member_rows_kernel(body_i, body_j, member_i, member_j, first_member, sphere_offsets,
                       sphere_radii, off_i, off_j, rad_i, rad_j):
    """Each row's member spheres: offsets in their bodies' frames ``off_i``, ``off_j``
    (C, 3) [m] and radii ``rad_i``, ``rad_j`` (C,) [m], member a of body b being the
    library's sphere ``first_member[b] + a`` (``first_member`` (N,) the first sphere of each
    body's shape); a wall's side (body_i < 0) zero."""
    for k in range(body_j.shape[0]):
        m = first_member[body_j[k]] + member_j[k]
        rad_j[k] = sphere_radii[m]
        for a in range(3):
            off_j[k, a] = sphere_offsets[m, a]
        if body_i[k] >= 0:
            m = first_member[body_i[k]] + member_i[k]
            rad_i[k] = sphere_radii[m]
            for a in range(3):
                off_i[k, a] = sphere_offsets[m, a]
        else:
            rad_i[k] = 0.0
            for a in range(3):
                off_i[k, a] = 0.0


@njit(cache=True, _nrt=False)
def carry_springs_kernel(old_keys, old_xi, old_roll, new_keys, new_xi, new_roll) -> int:
    """The springs of the rows of the last list carried to the rows of the new one with the
    same key (member pair): tangential springs ``xi`` (C, 3) [N] and rolling moments
    ``roll`` (C, 3) [N m]; ``old_keys`` must never decrease, and a key
    found more than once gives its first row's springs. Rows not found keep theirs. Returns
    the rows found. O(C) when the new keys do not decrease either, O(C log C) else."""
    n_old = old_keys.shape[0]
    found = 0
    lo = 0
    for k in range(new_keys.shape[0]):
        key = new_keys[k]
        # the first old row whose key is >= key: walked on from the last one while the new
        # keys do not decrease (a list in its usual order: one merge, O(C)), else searched
        if k == 0 or key < new_keys[k - 1]:
            lo, hi = 0, n_old
            while lo < hi:
                mid = (lo + hi) >> 1
                if old_keys[mid] < key:
                    lo = mid + 1
                else:
                    hi = mid
        else:
            while lo < n_old and old_keys[lo] < key:
                lo += 1
        if lo < n_old and old_keys[lo] == key:
            found += 1
            for a in range(3):
                new_xi[k, a] = old_xi[lo, a]
                new_roll[k, a] = old_roll[lo, a]
    return found
