"""The first-order C_bar distribution law: Table 2.1 of seed 001 with eq. 2.35 cut at order 1.

Seed 001 writes the distributive law of strain as a function of the micro-element stiffness
and the average alone (Table 2.1: H^n = f(C^n, C_bar)) and its Maxwellian form as
G^n = A Exp(-v^n) V^n/V (eq. 2.34), v^n = C_bar^-1 (C^n - C_bar) (eq. 2.33 with the average of
eq. 2.24), Exp(-v) = I - v + v^2/2! - ... (eq. 2.35). Cut after the first-order term,
Exp(-v^n) ~ I - v^n = 2I - C_bar^-1 C^n, and

    G^n = (V^n/V) (2I - C_bar^-1 C^n)                                          (k, k) [-]

needs no normalisation: sum_n G^n = 2I - C_bar^-1 sum_n (V^n/V) C^n = I exactly (eq. 2.28),
so A = I. The overall tangent (eq. 2.31) is then

    C = sum_n C^n G^n = C_bar - sum_n (V^n/V) (C^n - C_bar) C_bar^-1 (C^n - C_bar)      [Pa]

i.e. the average stiffness less a (symmetric, positive semi-definite) spread of the C^n:
unlike the homogeneous law (C = C_bar) and the full series (which keeps every G^n positive
definite), this C can lose positive definiteness, and the unit can fail.

Its defect: the eigenvalues of (V/V^n) G^n are 2 - lambda, lambda the (real, >= 0) eigenvalues
of C_bar^-1 C^n. A micro-element stiffer than twice the average in some direction
(lambda > 2) takes a strain share of the *opposite* sign there: G^n is not positive
definite. :func:`strain_share_eigenvalues` measures it along a test (the descriptors
``strain_share_lowest_eigenvalue`` and ``strain_share_negative_fraction`` of
:class:`~grainlab.micromech.micro_element.model.MicroElementModel`).

>>> c_local = np.array([[[1.0]], [[3.0]]]) * 1e6     # two 1 x 1 "micro-elements" [Pa]
>>> g, tangent = first_order_tensors(c_local, np.array([[2e6]]), np.array([0.5, 0.5]))
>>> g[:, 0, 0].tolist(), float(tangent[0, 0])        # (1/2)(2 - 1/2), (1/2)(2 - 3/2)
([0.75, 0.25], 1500000.0)
"""

from __future__ import annotations

import numpy as np

from grainlab.micromech.micro_element.distribution_kernels import (
    maxwellian_tensors,
    relative_stiffness,
)


def first_order_tensors(c_local: np.ndarray, c_bar: np.ndarray, weights: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    """G^n = (V^n/V)(2I - C_bar^-1 C^n) (E, k, k) [-] and the overall tangent
    sum_n C^n G^n (k, k) [Pa] (seed 001 Table 2.1, eqs. 2.31, 2.33–2.35 with the series cut
    after its first-order term), for C^n (E, k, k) [Pa], their volume average C_bar (k, k)
    [Pa] (eq. 2.24) and the volume fractions V^n/V (E,) [-].

    A singular C_bar (a mechanism) takes its pseudo-inverse C_bar^+: then
    G^n = (V^n/V)(I + C_bar^+ C_bar - C_bar^+ C^n), which still sums to I."""
    c_local = np.asarray(c_local, dtype=float)
    k = c_bar.shape[0]
    v, _ = relative_stiffness(c_local, c_bar, np.linalg.pinv(c_bar, rcond=1e-12))  # eq. 2.33
    series = np.eye(k)[None] - v  # Exp(-v) to first order (eq. 2.35)
    return maxwellian_tensors(np.eye(k), series, np.asarray(weights, dtype=float), c_local)


def strain_share_eigenvalues(c_local: np.ndarray, c_bar: np.ndarray) -> np.ndarray:
    """Eigenvalues (E, k) [-] of (V/V^n) G^n = 2I - C_bar^-1 C^n, ascending: 1 everywhere for
    a micro-element as stiff as the average, negative where it is stiffer than twice the
    average in some direction (then it strains against the overall strain there).

    The eigenvalues of C_bar^-1 C^n are those of the symmetric L^-1 C^n L^-T (C_bar = L L^T,
    C^n symmetric): real. A C_bar that is not positive definite takes the real parts of the
    eigenvalues of C_bar^+ C^n."""
    c_local = np.asarray(c_local, dtype=float)
    try:
        lower = np.linalg.cholesky(c_bar)
    except np.linalg.LinAlgError:
        lam = np.sort(np.linalg.eigvals(np.linalg.pinv(c_bar, rcond=1e-12) @ c_local).real,
                      axis=-1)
    else:
        inverse = np.linalg.inv(lower)
        symmetric = inverse @ c_local @ inverse.T
        lam = np.linalg.eigvalsh(0.5 * (symmetric + np.swapaxes(symmetric, -1, -2)))
    return 2.0 - lam[..., ::-1]
