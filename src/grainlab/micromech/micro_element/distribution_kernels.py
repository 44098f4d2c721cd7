"""Compiled kernels of the Maxwellian distribution of strain (seed 001 eqs. 2.31–2.35; Numba,
STYLE.md 2: per-micro-element law -> serial and parallel array kernels, outputs last -> thin
launcher; see :mod:`kernels` for the conventions).

For E micro-elements with local stiffness C^n (k, k) [Pa] and volume fractions V^n/V:

* :func:`_relative_element` — v^n = C_bar^-1 (C^n - C_bar) (eq. 2.33);
* :func:`_series_chunk` — Exp(-v) = sum_(n <= order) (-v)^n / n! (eq. 2.35) on v / 2^s,
  squared back s times. The truncated series is evaluated by the Paterson–Stockmeyer scheme
  (powers S^0..S^b, then Horner in S^b over blocks of b coefficients): about 2 sqrt(order)
  matrix products in place of ``order``, the same polynomial;
* :func:`_distribute_range` — G^n = (V^n/V) A Exp(-v^n) (eq. 2.34) and the overall tangent
  sum_n C^n G^n (eq. 2.31), summed per chunk.

Small matrices are processed in batches stored batch-innermost (:data:`BATCH`), so that each
6 x 6 product is vectorised across micro-elements.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainlab.micromech.micro_element.kernels import BATCH, CHUNK, MIN_PARALLEL_ELEMENTS


@njit(inline="always")
def _product(a, b, out):
    """out = a @ b for small square matrices (out must not alias a or b)."""
    n = a.shape[0]
    for i in range(n):
        for j in range(n):
            s = 0.0
            for x in range(n):
                s += a[i, x] * b[x, j]
            out[i, j] = s


# -- v^n = C_bar^-1 (C^n - C_bar) -------------------------------------------------------------
@njit(inline="always")
def _relative_element(e, c_local, c_bar_inverse, c_bar, v_out, norm_out):
    """v^n into v_out[e]; its largest absolute row sum into norm_out[e]."""
    k = c_bar.shape[0]
    v = v_out[e]
    largest = 0.0
    for i in range(k):
        row = 0.0
        for j in range(k):
            s = 0.0
            for x in range(k):
                s += c_bar_inverse[i, x] * (c_local[e, x, j] - c_bar[x, j])
            v[i, j] = s
            row += abs(s)
        largest = max(largest, row)
    norm_out[e] = largest


@njit(cache=True)
def relative_serial(c_local, c_bar_inverse, c_bar, v_out, norm_out):
    """:func:`_relative_element` for every micro-element, in one thread."""
    for e in range(c_local.shape[0]):
        _relative_element(e, c_local, c_bar_inverse, c_bar, v_out, norm_out)


@njit(cache=True, parallel=True)
def relative_parallel(c_local, c_bar_inverse, c_bar, v_out, norm_out):
    """:func:`_relative_element` for every micro-element, in parallel (gather)."""
    for e in prange(c_local.shape[0]):
        _relative_element(e, c_local, c_bar_inverse, c_bar, v_out, norm_out)


def relative_stiffness(c_local: np.ndarray, c_bar: np.ndarray, c_bar_inverse: np.ndarray
                       ) -> tuple[np.ndarray, float]:
    """v^n = C_bar^-1 (C^n - C_bar) (E, k, k) [-] of eq. 2.33, for C^n (E, k, k) and C_bar
    (k, k) [Pa] with its (pseudo-)inverse [1/Pa]; and max_n ||v^n||_inf, the largest absolute
    row sum (it sets the scaling of :func:`exponential_series_batch`)."""
    n_elements, k, _ = c_local.shape
    v = np.empty((n_elements, k, k))
    norms = np.empty(n_elements)
    kernel = relative_parallel if n_elements >= MIN_PARALLEL_ELEMENTS else relative_serial
    kernel(np.ascontiguousarray(c_local), np.ascontiguousarray(c_bar_inverse),
           np.ascontiguousarray(c_bar), v, norms)
    return v, float(norms.max(initial=0.0))


# -- Exp(-v), eq. 2.35 ----------------------------------------------------------------------------
@njit(inline="always")
def _batch_product(a, b, out, n):
    """out[:, :, c] = a[:, :, c] @ b[:, :, c] for c < n: a batch of small square matrices
    stored (k, k, batch), the batch innermost (contiguous: vectorised across matrices)."""
    k = a.shape[0]
    for i in range(k):
        for j in range(k):
            for c in range(n):
                out[i, j, c] = 0.0
            for x in range(k):
                for c in range(n):
                    out[i, j, c] += a[i, x, c] * b[x, j, c]


@njit(inline="always")
def _batch_add_scaled(coefficient, a, out, n):
    """out[:, :, c] += coefficient a[:, :, c] for c < n."""
    k = a.shape[0]
    for i in range(k):
        for j in range(k):
            for c in range(n):
                out[i, j, c] += coefficient * a[i, j, c]


@njit(inline="always")
def _series_chunk(lo, hi, v, coefficients, scale, squarings, exp_out, term_out, total_out,
                  powers, total, work, acc, base):
    """For the matrices e = lo..hi-1 (at most the batch size of the scratch): the sum
    sum_n coefficients[n] S^n with S = scale v[e] into exp_out[e], squared ``squarings``
    times; the largest |entry| of the last term coefficients[-1] S^order and of the sum (before
    squaring) into term_out[e] and total_out[e]. Scratch, batch innermost: ``powers``
    (b + 1, k, k, batch) with b the block size, ``total``, ``work``, ``acc``, ``base``
    (k, k, batch)."""
    k = v.shape[1]
    n = hi - lo
    order = coefficients.shape[0] - 1
    block = powers.shape[0] - 1
    for i in range(k):
        for j in range(k):
            for c in range(n):
                powers[0, i, j, c] = 1.0 if i == j else 0.0
                powers[1, i, j, c] = v[lo + c, i, j] * scale
    for p in range(2, block + 1):
        _batch_product(powers[p - 1], powers[1], powers[p], n)
    top = order // block
    total[:, :, :n] = 0.0
    for p in range(order - top * block + 1):
        _batch_add_scaled(coefficients[top * block + p], powers[p], total, n)
    for level in range(top - 1, -1, -1):  # Horner in S^b
        _batch_product(total, powers[block], work, n)
        for p in range(block):
            _batch_add_scaled(coefficients[level * block + p], powers[p], work, n)
        total[:, :, :n] = work[:, :, :n]
    # the last term: S^order = (S^b)^top S^r, by binary powering
    acc[:, :, :n] = powers[order - top * block, :, :, :n]
    base[:, :, :n] = powers[block, :, :, :n]
    m = top
    while m > 0:
        if m & 1:
            _batch_product(acc, base, work, n)
            acc[:, :, :n] = work[:, :, :n]
        m >>= 1
        if m > 0:
            _batch_product(base, base, work, n)
            base[:, :, :n] = work[:, :, :n]
    for c in range(n):
        largest_term = 0.0
        largest_total = 0.0
        for i in range(k):
            for j in range(k):
                largest_term = max(largest_term, abs(acc[i, j, c]))
                largest_total = max(largest_total, abs(total[i, j, c]))
        term_out[lo + c] = abs(coefficients[order]) * largest_term
        total_out[lo + c] = largest_total
    for _ in range(squarings):
        _batch_product(total, total, work, n)
        total[:, :, :n] = work[:, :, :n]
    for c in range(n):
        for i in range(k):
            for j in range(k):
                exp_out[lo + c, i, j] = total[i, j, c]


@njit(cache=True)  # not inlined: one compiled body for the serial and the parallel kernel
def _series_range(lo, hi, v, coefficients, block, scale, squarings, exp_out, term_out,
                  total_out):
    """:func:`_series_chunk` over matrices lo..hi-1 in batches of :data:`BATCH`, with one set
    of scratch arrays."""
    k = v.shape[1]
    powers = np.empty((block + 1, k, k, BATCH))
    total = np.empty((k, k, BATCH))
    work = np.empty((k, k, BATCH))
    acc = np.empty((k, k, BATCH))
    base = np.empty((k, k, BATCH))
    for start in range(lo, hi, BATCH):
        _series_chunk(start, min(hi, start + BATCH), v, coefficients, scale, squarings,
                      exp_out, term_out, total_out, powers, total, work, acc, base)


@njit(cache=True)
def series_serial(v, coefficients, block, scale, squarings, exp_out, term_out, total_out):
    """:func:`_series_chunk` for every matrix, in one thread."""
    _series_range(np.int64(0), v.shape[0], v, coefficients, block, scale, squarings, exp_out,
                  term_out, total_out)  # int64(0), not a literal: the parallel kernel's body


@njit(cache=True, parallel=True)
def series_parallel(v, coefficients, block, scale, squarings, exp_out, term_out, total_out):
    """:func:`_series_chunk` for every matrix, in parallel chunks (gather)."""
    n = v.shape[0]
    for chunk in prange((n + CHUNK - 1) // CHUNK):
        lo = np.int64(chunk) * CHUNK  # prange's index is unsigned: cast, one signature
        _series_range(lo, min(n, lo + CHUNK), v, coefficients, block,
                      scale, squarings, exp_out, term_out, total_out)


def exponential_series_batch(v: np.ndarray, order: int, squarings: int
                             ) -> tuple[np.ndarray, float, float]:
    """Exp(-v) (B, k, k) for v (B, k, k): the series of eq. 2.35 to ``order`` (>= 1) on
    v / 2^squarings, squared back; with the largest |entry| of the last series term and of the
    series sum over the batch (the convergence check of :func:`model.exponential_series`)."""
    n_batch, k, _ = v.shape
    order = int(order)
    coefficients = np.array([(-1.0) ** n / math.factorial(n) for n in range(order + 1)])
    block = max(1, round(math.sqrt(order)))
    out = np.empty((n_batch, k, k))
    term = np.zeros(n_batch)
    total = np.zeros(n_batch)
    kernel = series_parallel if n_batch >= MIN_PARALLEL_ELEMENTS else series_serial
    kernel(np.ascontiguousarray(v, dtype=float), coefficients, block, 2.0 ** -int(squarings),
           int(squarings), out, term, total)
    return out, float(term.max(initial=0.0)), float(total.max(initial=0.0))


# -- G^n and C^n G^n, eqs. 2.34 and 2.31 ----------------------------------------------------------
@njit(cache=True)  # not inlined: one compiled body for the serial and the parallel kernel
def _distribute_range(lo, hi, a, exp_v, weights, c_local, g_out, partial):
    """G^n = (V^n/V) A Exp(-v^n) into g_out[n] for n = lo..hi-1, and sum_n C^n G^n into
    ``partial`` (k, k), in batches of :data:`BATCH` stored batch-innermost."""
    k = a.shape[0]
    g = np.empty((k, k, BATCH))
    x_batch = np.empty((k, k, BATCH))
    c_batch = np.empty((k, k, BATCH))
    partial[:, :] = 0.0
    for start in range(lo, hi, BATCH):
        n = min(hi, start + BATCH) - start
        for c in range(n):
            for i in range(k):
                for j in range(k):
                    x_batch[i, j, c] = exp_v[start + c, i, j]
                    c_batch[i, j, c] = c_local[start + c, i, j]
        for i in range(k):
            for j in range(k):
                for c in range(n):
                    g[i, j, c] = 0.0
                for x in range(k):
                    a_ix = a[i, x]
                    for c in range(n):
                        g[i, j, c] += a_ix * x_batch[x, j, c]
                for c in range(n):
                    g[i, j, c] *= weights[start + c]
        for c in range(n):
            for i in range(k):
                for j in range(k):
                    g_out[start + c, i, j] = g[i, j, c]
        for i in range(k):
            for j in range(k):
                s = 0.0
                for x in range(k):
                    for c in range(n):
                        s += c_batch[i, x, c] * g[x, j, c]
                partial[i, j] += s


@njit(cache=True)
def distribute_serial(a, exp_v, weights, c_local, g_out, partial_out):
    """:func:`_distribute_range` over every micro-element, in one thread (partial_out (1, k,
    k))."""
    _distribute_range(np.int64(0), exp_v.shape[0], a, exp_v, weights, c_local, g_out,
                      partial_out[0])


@njit(cache=True, parallel=True)
def distribute_parallel(a, exp_v, weights, c_local, g_out, partial_out):
    """:func:`_distribute_range` over chunks of :data:`CHUNK` micro-elements in parallel, each
    chunk's sum of C^n G^n into its own row of partial_out (chunks, k, k) (gather)."""
    n = exp_v.shape[0]
    for chunk in prange(partial_out.shape[0]):
        lo = np.int64(chunk) * CHUNK  # prange's index is unsigned: cast, one signature
        _distribute_range(lo, min(n, lo + CHUNK), a, exp_v, weights, c_local, g_out,
                          partial_out[chunk])


def maxwellian_tensors(a: np.ndarray, exp_v: np.ndarray, weights: np.ndarray,
                       c_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """G^n = (V^n/V) A Exp(-v^n) (E, k, k) [-] (eq. 2.34) and the overall tangent
    sum_n C^n G^n (k, k) [Pa] (eq. 2.31), for A (k, k), Exp(-v^n) (E, k, k), the volume
    fractions (E,) and C^n (E, k, k) [Pa]."""
    n_elements, k, _ = exp_v.shape
    g = np.empty((n_elements, k, k))
    parallel = n_elements >= MIN_PARALLEL_ELEMENTS
    partial = np.empty(((n_elements + CHUNK - 1) // CHUNK if parallel else 1, k, k))
    kernel = distribute_parallel if parallel else distribute_serial
    kernel(np.ascontiguousarray(a), np.ascontiguousarray(exp_v), np.ascontiguousarray(weights),
           np.ascontiguousarray(c_local), g, partial)
    return g, partial.sum(axis=0)
