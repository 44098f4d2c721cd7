"""Compiled kernels of the micro-element model (Numba; STYLE.md 2: per-micro-element law
``@njit(inline="always")`` -> array kernel ``@njit(cache=True)``, outputs last -> thin launcher).

Per micro-element n (E micro-elements, up to M contacts, d dimensions, k Voigt and w skew
components; seed 001 ch. 2, Table 2.1):

* :func:`_condense_batch` — contact stiffness K = k_n n n + k_r (I - n n) (eq. 2.5), the
  non-affine move T = -[sum K]^+ [sum K L] (eq. 2.14), the stretch map
  P_p(kl) = delta_pk L_l + T_p(kl) (eq. 2.15) and the local stiffness
  C_ij,kl = 1/(2 V^n) sum_m K_ip P_p(kl) L_j (eq. 2.18), condensed to the blocks
  [S'; W'] C [S W] (symmetric Voigt / skew, :mod:`tensor_basis`) and, with a free particle spin,
  C^n = C_ss + C_sw spin, spin = -C_ww^+ C_ws;
* :func:`_stretch_element` — the local strain eps^n = (V/V^n) G^n eps (eq. 2.27), the spin, each
  spring's approach d_delta = P eps^n (eqs. 2.13–2.15) and the translation of its branch;
* :func:`move_kernel` — branches shortened by the translation, volumes by the volumetric strain;
* the Maxwellian distribution (eqs. 2.32–2.35) is in :mod:`distribution_kernels`.

Array kernels come in pairs: a serial one and a parallel one (``prange`` over chunks of
:data:`CHUNK` micro-elements, whose scratch arrays are allocated once per chunk; every iteration
writes only its own micro-elements' rows: a gather, never a scatter). The launchers take the
parallel one from :data:`MIN_PARALLEL_ELEMENTS` micro-elements on: waking the threads costs
~0.1 ms, more than a whole increment of a 30-micro-element unit. Sums over all contacts
(stress, descriptors) are serial loops. The slow, obviously right twins are the NumPy versions
in ``tests/micromech/test_micro_element_kernels.py``.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit, prange

from grainlab._numba_setup import kernel_input
from grainlab.micromech.micro_element.tensor_basis import bases

MIN_PARALLEL_ELEMENTS = 2048
"""Micro-elements from which the launchers use the parallel kernels."""

CHUNK = 64
"""Micro-elements per parallel work item (its scratch arrays are allocated once)."""

BATCH = 32
"""Micro-elements computed together, stored batch-innermost so that their small-matrix
arithmetic is vectorised across them (one micro-element's 3 x 3 and 6 x 6 matrices alone do
not fill the vector units)."""

SPIN_MODES = {"none": 0, "micro-element": 1, "uniform": 2}
"""Particle-spin options of :class:`MicroElementModel` as kernel codes (2: set by the caller)."""


# -- small dense algebra ------------------------------------------------------------------------
@njit(inline="always")
def _determinant(a):
    """Determinant of a 2 x 2 or 3 x 3 matrix."""
    if a.shape[0] == 2:
        return a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    return (a[0, 0] * (a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1])
            + a[0, 1] * (a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2])
            + a[0, 2] * (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]))


@njit(inline="always")
def _invert_into(a, inv):
    """inv = a^-1 for a small (1 x 1 to 3 x 3) symmetric positive semi-definite matrix; the
    pseudo-inverse (relative cut-off 1e-12) when it is (nearly) singular."""
    d = a.shape[0]
    if d == 1:
        inv[0, 0] = 1.0 / a[0, 0] if a[0, 0] != 0.0 else 0.0
        return
    scale = 1e-300
    for i in range(d):
        scale += abs(a[i, i])
    det = _determinant(a) if d <= 3 else 0.0
    if d == 2 and abs(det) > 1e-10 * scale * scale:
        inv[0, 0] = a[1, 1] / det
        inv[1, 1] = a[0, 0] / det
        inv[0, 1] = -a[0, 1] / det
        inv[1, 0] = -a[1, 0] / det
        return
    if d == 3 and abs(det) > 1e-10 * scale * scale * scale:
        inv[0, 0] = (a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]) / det
        inv[1, 0] = (a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]) / det
        inv[2, 0] = (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]) / det
        inv[0, 1] = (a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]) / det
        inv[1, 1] = (a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]) / det
        inv[2, 1] = (a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]) / det
        inv[0, 2] = (a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]) / det
        inv[1, 2] = (a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]) / det
        inv[2, 2] = (a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) / det
        return
    inv[:, :] = np.linalg.pinv(np.ascontiguousarray(a), 1e-12)


@njit(inline="always")
def _pinv_above(a, cutoff, inv):
    """inv = the pseudo-inverse of a small square matrix with singular values <= ``cutoff``
    (absolute, in the units of a) taken as zero: 0 when every |entry| <= cutoff, the closed-form
    inverse when a is well conditioned, an SVD otherwise."""
    n = a.shape[0]
    scale = 0.0
    for i in range(n):
        for j in range(n):
            scale = max(scale, abs(a[i, j]))
    inv[:, :] = 0.0
    if scale <= cutoff:
        return
    if n == 1 or (n <= 3 and abs(_determinant(a)) > 1e-10 * scale**n):
        _invert_into(a, inv)
        return
    u, sv, vt = np.linalg.svd(np.ascontiguousarray(a))
    keep = max(cutoff, 1e-12 * sv[0])
    for x in range(sv.shape[0]):
        if sv[x] > keep:
            for i in range(n):
                for j in range(n):
                    inv[i, j] += vt[x, i] * u[j, x] / sv[x]


# -- local stiffness (eqs. 2.5, 2.14, 2.15, 2.18) ----------------------------------------------
@njit(inline="always")
def _condense_batch(lo, hi, branches, mask, kn, kr, volumes, non_affine, right_index,
                    right_weight, left_index, left_weight, t_out, blocks_out, normals, lb, knb,
                    krb, a, b, inv, t, t_right, p_right, c_right, blocks, a_one, inv_one):
    """Micro-elements e = lo..hi-1 (at most the batch size of the scratch): T (d, d^2) into
    t_out[e] and the condensed blocks L' C R into blocks_out[e].

    R (d^2, b) and L' (b, d^2) are [S] and [S'] (b = k) or [S W] and [S'; W'] (b = k + w),
    given sparse: column c of R is sum_r right_weight[c, r] e_(right_index[c, r]), row c of L'
    likewise (at most two entries each). With K = k_r I + (k_n - k_r) n n and
    P R = delta L R + T R, contact m adds (1/(2V)) (K P R)_ic L_j to row (i, j) of C R.

    The micro-elements of the batch are processed together, the batch index innermost in the
    scratch arrays (normals, lb (M, d, batch); knb, krb (M, batch); a, inv (d, d, batch);
    b, t (d, d^2, batch); t_right, p_right (d, b, batch); c_right (d^2, b, batch); blocks
    (b, b, batch); a_one, inv_one (d, d)) so that the arithmetic is vectorised across them. A
    padded contact enters with k_n = k_r = 0 and L = 0: it adds exact zeros."""
    n_contacts, d = branches.shape[1], branches.shape[2]
    dd = d * d
    n_b = right_index.shape[0]
    n = hi - lo
    for c in range(n):
        e = lo + c
        for m in range(n_contacts):
            active = mask[e, m]
            knb[m, c] = kn[e, m] if active else 0.0
            krb[m, c] = kr[e, m] if active else 0.0
            length = 0.0
            for i in range(d):
                lb[m, i, c] = branches[e, m, i] if active else 0.0
                length += lb[m, i, c] ** 2
            length = np.sqrt(length) if active else 1.0
            for i in range(d):
                normals[m, i, c] = lb[m, i, c] / length
    a[:, :, :n] = 0.0
    b[:, :, :n] = 0.0
    for m in range(n_contacts):
        for i in range(d):
            for j in range(d):
                delta = 1.0 if i == j else 0.0
                for c in range(n):
                    nn = normals[m, i, c] * normals[m, j, c]
                    k_ij = knb[m, c] * nn + krb[m, c] * (delta - nn)
                    a[i, j, c] += k_ij
                    for col in range(d):
                        b[i, j * d + col, c] += k_ij * lb[m, col, c]
    for c in range(n):  # the centre's compliance [sum K]^+ (zero: no non-affine move)
        e = lo + c
        count = 0
        for m in range(n_contacts):
            if mask[e, m]:
                count += 1
        if non_affine and count >= 2:
            for i in range(d):
                for j in range(d):
                    a_one[i, j] = a[i, j, c]
            _invert_into(a_one, inv_one)
            for i in range(d):
                for j in range(d):
                    inv[i, j, c] = inv_one[i, j]
        else:
            inv[:, :, c] = 0.0
    for p in range(d):  # T = -[sum K]^+ [sum K L]
        for x in range(dd):
            for c in range(n):
                t[p, x, c] = 0.0
            for q in range(d):
                for c in range(n):
                    t[p, x, c] -= inv[p, q, c] * b[q, x, c]
    for p in range(d):  # T R
        for col in range(n_b):
            i0, i1 = right_index[col, 0], right_index[col, 1]
            w0, w1 = right_weight[col, 0], right_weight[col, 1]
            for c in range(n):
                t_right[p, col, c] = t[p, i0, c] * w0 + t[p, i1, c] * w1
    c_right[:, :, :n] = 0.0  # C R
    for m in range(n_contacts):
        p_right[:, :, :n] = t_right[:, :, :n]
        for col in range(n_b):
            for r in range(2):
                q = right_index[col, r]
                k = q // d
                weight = right_weight[col, r]
                for c in range(n):
                    p_right[k, col, c] += lb[m, q - k * d, c] * weight
        for col in range(n_b):
            for c in range(n):
                scale = 1.0 / (2.0 * volumes[lo + c])
                k_r = krb[m, c]
                k_nr = knb[m, c] - k_r
                along = 0.0
                for p in range(d):
                    along += normals[m, p, c] * p_right[p, col, c]
                for i in range(d):
                    kp = scale * (k_r * p_right[i, col, c] + k_nr * normals[m, i, c] * along)
                    for j in range(d):
                        c_right[i * d + j, col, c] += kp * lb[m, j, c]
    for row in range(n_b):
        i0, i1 = left_index[row, 0], left_index[row, 1]
        w0, w1 = left_weight[row, 0], left_weight[row, 1]
        for col in range(n_b):
            for c in range(n):
                blocks[row, col, c] = w0 * c_right[i0, col, c] + w1 * c_right[i1, col, c]
    for c in range(n):
        e = lo + c
        for p in range(d):
            for x in range(dd):
                t_out[e, p, x] = t[p, x, c]
        for row in range(n_b):
            for col in range(n_b):
                blocks_out[e, row, col] = blocks[row, col, c]


@njit(inline="always")
def _spin_element(e, blocks_out, spin_out, c_local_out):
    """Free particle spin of micro-element e (``spin="micro-element"``): the spin map
    -C_ww^+ C_ws (w, k) into spin_out[e] and C_ss + C_sw spin (k, k) into c_local_out[e]."""
    n_v = c_local_out.shape[1]
    n_b = blocks_out.shape[1]
    n_w = n_b - n_v
    blocks = blocks_out[e]
    spin = spin_out[e]
    c_local = c_local_out[e]
    # C_ww is zero up to round-off when no contact resists a relative spin (k_r = 0):
    # singular values below 1e-10 of the micro-element's stiffness count as zero.
    largest = 0.0
    for row in range(n_b):
        for c in range(n_b):
            largest = max(largest, abs(blocks[row, c]))
    inv_ww = np.empty((n_w, n_w))
    _pinv_above(np.ascontiguousarray(blocks[n_v:, n_v:]), 1e-10 * largest, inv_ww)
    for x in range(n_w):
        for j in range(n_v):
            s = 0.0
            for y in range(n_w):
                s += inv_ww[x, y] * blocks[n_v + y, j]
            spin[x, j] = -s
    for i in range(n_v):
        for j in range(n_v):
            s = blocks[i, j]
            for x in range(n_w):
                s += blocks[i, n_v + x] * spin[x, j]
            c_local[i, j] = s


@njit(cache=True)  # not inlined: one compiled body for the serial and the parallel kernel
def _condense_range(lo, hi, branches, mask, kn, kr, volumes, non_affine, spin_mode,
                    right_index, right_weight, left_index, left_weight, t_out, blocks_out,
                    spin_out, c_local_out):
    """:func:`_condense_batch` over micro-elements lo..hi-1 in batches of :data:`BATCH` with one
    set of scratch arrays, then :func:`_spin_element` with ``spin_mode`` 1."""
    n_contacts, d = branches.shape[1], branches.shape[2]
    n_b = right_index.shape[0]
    normals = np.empty((n_contacts, d, BATCH))
    lb = np.empty((n_contacts, d, BATCH))
    knb = np.empty((n_contacts, BATCH))
    krb = np.empty((n_contacts, BATCH))
    a = np.empty((d, d, BATCH))
    b = np.empty((d, d * d, BATCH))
    inv = np.empty((d, d, BATCH))
    t = np.empty((d, d * d, BATCH))
    t_right = np.empty((d, n_b, BATCH))
    p_right = np.empty((d, n_b, BATCH))
    c_right = np.empty((d * d, n_b, BATCH))
    blocks = np.empty((n_b, n_b, BATCH))
    a_one = np.empty((d, d))
    inv_one = np.empty((d, d))
    for start in range(lo, hi, BATCH):
        _condense_batch(start, min(hi, start + BATCH), branches, mask, kn, kr, volumes,
                        non_affine, right_index, right_weight, left_index, left_weight, t_out,
                        blocks_out, normals, lb, knb, krb, a, b, inv, t, t_right, p_right,
                        c_right, blocks, a_one, inv_one)
    if spin_mode == 1:
        for e in range(lo, hi):
            _spin_element(e, blocks_out, spin_out, c_local_out)


@njit(cache=True)
def condense_serial(branches, mask, kn, kr, volumes, non_affine, spin_mode, right_index,
                    right_weight, left_index, left_weight, t_out, blocks_out, spin_out,
                    c_local_out):
    """:func:`_condense_range` over every micro-element, in one thread."""
    _condense_range(np.int64(0), branches.shape[0], branches, mask, kn, kr, volumes, non_affine,
                    spin_mode, right_index, right_weight, left_index, left_weight, t_out,
                    blocks_out, spin_out, c_local_out)


@njit(cache=True, parallel=True)
def condense_parallel(branches, mask, kn, kr, volumes, non_affine, spin_mode, right_index,
                      right_weight, left_index, left_weight, t_out, blocks_out, spin_out,
                      c_local_out):
    """:func:`_condense_range` over chunks of :data:`CHUNK` micro-elements, in parallel
    (gather)."""
    n = branches.shape[0]
    for chunk in prange((n + CHUNK - 1) // CHUNK):
        lo = np.int64(chunk) * CHUNK  # prange's index is unsigned: cast, one signature
        _condense_range(lo, min(n, lo + CHUNK), branches, mask, kn, kr,
                        volumes, non_affine, spin_mode, right_index, right_weight, left_index,
                        left_weight, t_out, blocks_out, spin_out, c_local_out)


def _sparse_columns(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(index, weight), both (columns, 2): the at most two non-zero entries of each column
    (a missing second entry has weight 0)."""
    n_columns = matrix.shape[1]
    index = np.zeros((n_columns, 2), dtype=np.int64)
    weight = np.zeros((n_columns, 2))
    for c in range(n_columns):
        rows = np.flatnonzero(matrix[:, c])
        if not 1 <= rows.size <= 2:
            raise ValueError("a tensor basis column has more than two entries")
        index[c, :] = rows[0]
        index[c, : rows.size] = rows
        weight[c, : rows.size] = matrix[rows, c]
    return index, weight


@lru_cache(maxsize=4)
def condensation_bases(dimension: int, with_skew: bool
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sparse R = [S] or [S W] (d^2, b) and L' = [S'] or [S'; W'] (b, d^2) of
    :mod:`tensor_basis`, as (right_index, right_weight, left_index, left_weight) for
    :func:`_condense_range`."""
    s, w, s_dual, w_dual = bases(dimension)
    right = np.hstack([s, w]) if with_skew else s
    left = np.vstack([s_dual, w_dual]) if with_skew else s_dual
    return (*_sparse_columns(right), *_sparse_columns(left.T))


def condense_local_stiffness(branches: np.ndarray, mask: np.ndarray, kn: np.ndarray,
                             kr: np.ndarray, volumes: np.ndarray, non_affine: bool, spin: str,
                             parallel: bool | None = None
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Launcher of :func:`_condense_range`.

    Parameters: branches (E, M, d) [m], mask (E, M), contact stiffnesses kn, kr (E, M) [N/m]
    (read only where mask is True), volumes (E,) [m^3], ``non_affine`` (eq. 2.14), ``spin``
    (a key of :data:`SPIN_MODES`), ``parallel`` (the threaded kernel; None: from
    :data:`MIN_PARALLEL_ELEMENTS` micro-elements on).

    Returns T (E, d, d^2) [m]; the blocks [S' ; W'] C [S W] (E, k + w, k + w) [Pa] (with
    ``spin="none"`` only S' C S, (E, k, k)); the spin map (E, w, k) [-] (zero unless
    ``spin="micro-element"``); and C^n (E, k, k) [Pa] (C_ss + C_sw spin; C_ss, the first
    block, unless ``spin="micro-element"``).
    """
    n_elements, _, d = branches.shape
    with_skew = spin != "none"
    basis = condensation_bases(d, with_skew)
    n_v = 6 if d == 3 else 3
    n_w = 3 if d == 3 else 1
    n_b = n_v + n_w if with_skew else n_v
    t = np.empty((n_elements, d, d * d))
    blocks = np.empty((n_elements, n_b, n_b))
    spin_map = np.zeros((n_elements, n_w, n_v))
    c_local = np.empty((n_elements if spin == "micro-element" else 0, n_v, n_v))
    if parallel is None:
        parallel = n_elements >= MIN_PARALLEL_ELEMENTS
    kernel = condense_parallel if parallel else condense_serial
    kernel(kernel_input(branches), kernel_input(mask), kernel_input(kn, float),
           kernel_input(kr, float), kernel_input(volumes), bool(non_affine), SPIN_MODES[spin],
           *basis, t, blocks, spin_map, c_local)
    if spin != "micro-element":
        c_local = np.ascontiguousarray(blocks[:, :n_v, :n_v])
    return t, blocks, spin_map, c_local


# -- the increment: stretch map (eqs. 2.13–2.15, 2.27) and structure update --------------------
@njit(inline="always")
def _stretch_element(e, g, d_eps, weights, spin_map, s_basis, w_basis, branches, mask, t,
                     with_spin, approach_out, translation_out, volumetric_out, local, spin,
                     full, rotation, moved):
    """Micro-element e: eps^n = G^n eps / (V^n/V), the spin w = spin_map eps^n, the full
    strain S eps^n + W w; each contact's approach P (S eps^n + W w) = (S eps^n + W w) L +
    T (S eps^n + W w) into approach_out[e] and its branch translation (approach minus the
    spin's rotation W w L) into translation_out[e]; the volumetric strain trace(S eps^n) into
    volumetric_out[e]. The arguments after volumetric_out are scratch."""
    n_contacts, d = branches.shape[1], branches.shape[2]
    dd = d * d
    k = d_eps.shape[0]
    n_w = w_basis.shape[1]
    for i in range(k):
        s = 0.0
        for j in range(k):
            s += g[e, i, j] * d_eps[j]
        local[i] = s / weights[e]
    for x in range(n_w):
        s = 0.0
        if with_spin:
            for j in range(k):
                s += spin_map[e, x, j] * local[j]
        spin[x] = s
    for q in range(dd):
        s = 0.0
        for j in range(k):
            s += local[j] * s_basis[q, j]
        r = 0.0
        for x in range(n_w):
            r += spin[x] * w_basis[q, x]
        full[q] = s + r
        rotation[q] = r
    volumetric = 0.0
    for i in range(d):
        s = 0.0
        for j in range(k):
            s += local[j] * s_basis[i * d + i, j]
        volumetric += s
    volumetric_out[e] = volumetric
    for p in range(d):  # T (S eps^n + W w): the centre particle's move (eq. 2.14)
        s = 0.0
        for q in range(dd):
            s += t[e, p, q] * full[q]
        moved[p] = s
    for m in range(n_contacts):
        for p in range(d):
            if not mask[e, m]:
                approach_out[e, m, p] = 0.0
                translation_out[e, m, p] = 0.0
                continue
            s = 0.0
            turn = 0.0
            for j in range(d):
                s += full[p * d + j] * branches[e, m, j]
                turn += rotation[p * d + j] * branches[e, m, j]
            s += moved[p]
            approach_out[e, m, p] = s
            translation_out[e, m, p] = s - turn if with_spin else s


@njit(cache=True)  # not inlined: one compiled body for the serial and the parallel kernel
def _stretch_range(lo, hi, g, d_eps, weights, spin_map, s_basis, w_basis, branches, mask, t,
                   with_spin, approach_out, translation_out, volumetric_out):
    """:func:`_stretch_element` for micro-elements lo..hi-1 with one set of scratch arrays."""
    dd = branches.shape[2] ** 2
    local = np.empty(d_eps.shape[0])
    spin = np.empty(w_basis.shape[1])
    full = np.empty(dd)
    rotation = np.empty(dd)
    moved = np.empty(branches.shape[2])
    for e in range(lo, hi):
        _stretch_element(e, g, d_eps, weights, spin_map, s_basis, w_basis, branches, mask, t,
                         with_spin, approach_out, translation_out, volumetric_out, local, spin,
                         full, rotation, moved)


@njit(cache=True)
def stretch_serial(g, d_eps, weights, spin_map, s_basis, w_basis, branches, mask, t,
                   with_spin, approach_out, translation_out, volumetric_out):
    """:func:`_stretch_element` for every micro-element, in one thread."""
    _stretch_range(np.int64(0), branches.shape[0], g, d_eps, weights, spin_map, s_basis, w_basis,
                   branches, mask, t, with_spin, approach_out, translation_out, volumetric_out)


@njit(cache=True, parallel=True)
def stretch_parallel(g, d_eps, weights, spin_map, s_basis, w_basis, branches, mask, t,
                     with_spin, approach_out, translation_out, volumetric_out):
    """:func:`_stretch_element` for every micro-element, in parallel chunks (gather)."""
    n = branches.shape[0]
    for chunk in prange((n + CHUNK - 1) // CHUNK):
        lo = np.int64(chunk) * CHUNK  # prange's index is unsigned: cast, one signature
        _stretch_range(lo, min(n, lo + CHUNK), g, d_eps, weights,
                       spin_map, s_basis, w_basis, branches, mask, t, with_spin, approach_out,
                       translation_out, volumetric_out)


def stretch(g: np.ndarray, d_eps: np.ndarray, weights: np.ndarray, spin_map: np.ndarray,
            s_basis: np.ndarray, w_basis: np.ndarray, branches: np.ndarray, mask: np.ndarray,
            t: np.ndarray, with_spin: bool, parallel: bool | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Launcher of :func:`_stretch_element`: for G^n (E, k, k), the overall Voigt strain
    increment (k,), the volume fractions (E,), the spin maps (E, w, k), the bases S (d^2, k)
    and W (d^2, w), the branches (E, M, d) [m], the mask (E, M) and T (E, d, d^2) [m]
    (``with_spin=False``: no spin), returns the approaches (E, M, d) [m], the branch
    translations (E, M, d) [m] and the local volumetric strains (E,) [-]. ``parallel``: the
    threaded kernel (None: from :data:`MIN_PARALLEL_ELEMENTS` micro-elements on)."""
    n_elements, n_contacts, d = branches.shape
    approach = np.empty((n_elements, n_contacts, d))
    translation = np.empty((n_elements, n_contacts, d))
    volumetric = np.empty(n_elements)
    if parallel is None:
        parallel = n_elements >= MIN_PARALLEL_ELEMENTS
    kernel = stretch_parallel if parallel else stretch_serial
    kernel(kernel_input(g), kernel_input(d_eps, float), kernel_input(weights),
           kernel_input(spin_map), kernel_input(s_basis), kernel_input(w_basis),
           kernel_input(branches), kernel_input(mask), kernel_input(t), bool(with_spin),
           approach, translation, volumetric)
    return approach, translation, volumetric


@njit(cache=True)
def move_kernel(branches, mask, translation, volumes, volumetric, branches_out, volumes_out):
    """Branches L - translation where mask (0 elsewhere) [m] and volumes V^n (1 - eps_v^n)
    [m^3] (compression positive), for E micro-elements (memory-bound: one thread)."""
    n_elements, n_contacts, d = branches.shape
    for e in range(n_elements):
        volumes_out[e] = volumes[e] * (1.0 - volumetric[e])
        for m in range(n_contacts):
            for i in range(d):
                branches_out[e, m, i] = (branches[e, m, i] - translation[e, m, i]
                                         if mask[e, m] else 0.0)


def move_structure(branches: np.ndarray, mask: np.ndarray, translation: np.ndarray,
                   volumes: np.ndarray, volumetric: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """New branches (E, M, d) [m] and volumes (E,) [m^3] after an increment (new arrays)."""
    branches_out = np.empty(branches.shape)
    volumes_out = np.empty(volumes.shape)
    move_kernel(np.ascontiguousarray(branches), np.ascontiguousarray(mask),
                np.ascontiguousarray(translation), np.ascontiguousarray(volumes),
                np.ascontiguousarray(volumetric), branches_out, volumes_out)
    return branches_out, volumes_out


# -- per-contact helpers and sums over contacts --------------------------------------------------
@njit(cache=True)
def unit_vectors_kernel(vectors, normals_out, lengths_out):
    """Unit vectors v/|v| (0 where |v| = 0) and lengths |v| of N vectors (N, d)."""
    n, d = vectors.shape
    for c in range(n):
        s = 0.0
        for i in range(d):
            s += vectors[c, i] * vectors[c, i]
        length = np.sqrt(s)
        lengths_out[c] = length
        for i in range(d):
            normals_out[c, i] = vectors[c, i] / length if length > 0.0 else 0.0


def unit_vectors(vectors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unit vectors, lengths) of vectors (..., d): shapes (..., d) and (...)."""
    vectors = np.ascontiguousarray(vectors, dtype=float)
    d = vectors.shape[-1]
    flat = vectors.reshape(-1, d)
    normals = np.empty_like(flat)
    lengths = np.empty(flat.shape[0])
    unit_vectors_kernel(flat, normals, lengths)
    return normals.reshape(vectors.shape), lengths.reshape(vectors.shape[:-1])


@njit(cache=True)
def dyad_sum_kernel(normal_force, normals, vectors, branches, mask, out):
    """out (d, d) = sum over the contacts with mask of (f_n n + v) (x) L [N m] (E, M arrays)."""
    n_elements, n_contacts, d = branches.shape
    out[:, :] = 0.0
    f = np.empty(d)
    for e in range(n_elements):
        for m in range(n_contacts):
            if not mask[e, m]:
                continue
            for i in range(d):
                f[i] = normal_force[e, m] * normals[e, m, i] + vectors[e, m, i]
            for i in range(d):
                for j in range(d):
                    out[i, j] += f[i] * branches[e, m, j]


def dyad_sum(normal_force: np.ndarray | None, normals: np.ndarray | None,
             vectors: np.ndarray, branches: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """sum_(e, m) (f_n n + v) (x) L (d, d) over the contacts where ``mask`` (E, M) is True:
    with f_n (E, M) [N] and normals (E, M, d) the contact forces, without (None) the vectors
    (E, M, d) [N] alone; L the branches (E, M, d) [m]."""
    d = branches.shape[-1]
    if normal_force is None:
        normal_force = np.zeros(mask.shape)
        normals = np.zeros(branches.shape)
    out = np.empty((d, d))
    dyad_sum_kernel(np.ascontiguousarray(normal_force, dtype=float),
                    np.ascontiguousarray(normals, dtype=float),
                    np.ascontiguousarray(vectors, dtype=float), np.ascontiguousarray(branches),
                    np.ascontiguousarray(mask), out)
    return out


@njit(cache=True)
def contact_census(mask, normal_force, shear_force, sliding, bonded, mu):
    """Counts over the contacts with mask (E, M): (contacts, sliding, open (f_n <= 0, not
    bonded), bonded, closed (not open)) and the sum over closed contacts of the mobilisation
    |f_r| / (mu f_n) (0 where f_n <= 0)."""
    n_elements, n_contacts = mask.shape
    d = shear_force.shape[2]
    total = 0
    n_sliding = 0
    n_open = 0
    n_bonded = 0
    mobilised = 0.0
    for e in range(n_elements):
        for m in range(n_contacts):
            if not mask[e, m]:
                continue
            total += 1
            if sliding[e, m]:
                n_sliding += 1
            if bonded[e, m]:
                n_bonded += 1
            fn = normal_force[e, m]
            if fn <= 0.0 and not bonded[e, m]:
                n_open += 1
                continue
            limit = mu * max(fn, 0.0)
            if limit > 0.0:
                s = 0.0
                for i in range(d):
                    s += shear_force[e, m, i] ** 2
                mobilised += np.sqrt(s) / limit
    return total, n_sliding, n_open, n_bonded, total - n_open, mobilised
