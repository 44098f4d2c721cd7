"""Stress and strain invariants as test-result columns, computed the same way for every
specimen (names and meanings in :mod:`grainlab.result.columns`).

Stress (compression positive, [Pa]), from the symmetric part of a (d, d) tensor with principal
values sigma_1 >= (sigma_2 >=) sigma_3:

    p = tr(sigma)/d                          q = sigma_1 - sigma_3        q_over_3 = q/3
    q_over_trace = q / tr(sigma)             sin_phi = q / (sigma_1 + sigma_3)
    stress_ratio = sigma_1 / sigma_3         b = (sigma_2 - sigma_3) / q   (3D)

q_over_trace is the seeds' q/p ((q/3)/p in 3D, seed 002 eqs. 5, 11); seed 002 eq. 11,
sin phi = 3 (q/p) / (2 + q/p), equals sin_phi when sigma_2 = sigma_3. q_over_trace and sin_phi
are NaN where their denominator is zero, stress_ratio unless sigma_3 > 0, and b at an isotropic
state (q <= 1e-9 max(|sigma_1|, |sigma_3|)).

Strain (compression positive, [-]), from a (d, d) tensor (small strains, or the logarithmic
strains of a box): eps_vol = tr(eps) (seed 002 eq. 9), eps_q = eps_1 - eps_3 with eps_1, eps_3
the largest and smallest principal strains (seed 002 eq. 10).
"""

from __future__ import annotations

import math

import numpy as np

from grainlab.errors import InputError

ISOTROPIC_TOLERANCE = 1e-9
"""b is NaN when q <= ISOTROPIC_TOLERANCE max(|sigma_1|, |sigma_3|)."""


def _ratio(numerator: float, denominator: float) -> float:
    """numerator / denominator, NaN (without a warning) when the denominator is zero."""
    return float(numerator / denominator) if denominator != 0.0 else math.nan


def _symmetric(tensor: np.ndarray, what: str) -> np.ndarray:
    t = np.asarray(tensor, dtype=float)
    if t.ndim != 2 or t.shape[0] != t.shape[1] or t.shape[0] not in (2, 3):
        raise InputError(what, t.shape, "a (2, 2) or (3, 3) tensor")
    return 0.5 * (t + t.T)


def stress_invariants(stress: np.ndarray) -> dict[str, float]:
    """The stress-invariant columns of a (d, d) stress [Pa] (module docstring):
    ``sigma_1``, ``sigma_2`` (3D), ``sigma_3``, ``p``, ``q``, ``q_over_3``, ``q_over_trace``,
    ``sin_phi``, ``stress_ratio``, ``b`` (3D).

    >>> row = stress_invariants(np.diag([1e4, 1e4, 4e4]))
    >>> row["q"], row["q_over_3"], row["p"], row["q_over_trace"], row["sin_phi"]
    (30000.0, 10000.0, 20000.0, 0.5, 0.6)
    >>> sorted(stress_invariants(np.diag([3.0, 1.0])))  # 2D: sigma_1 and sigma_3
    ['p', 'q', 'q_over_3', 'q_over_trace', 'sigma_1', 'sigma_3', 'sin_phi', 'stress_ratio']
    """
    sym = _symmetric(stress, "stress")
    d = sym.shape[0]
    values = np.linalg.eigvalsh(sym)  # ascending
    s1, s3 = float(values[-1]), float(values[0])
    trace = float(np.trace(sym))
    q = s1 - s3
    row = {"sigma_1": s1}
    if d == 3:
        row["sigma_2"] = float(values[1])
    row.update({
        "sigma_3": s3,
        "p": trace / d,
        "q": q,
        "q_over_3": q / 3.0,
        "q_over_trace": _ratio(q, trace),
        "sin_phi": _ratio(q, s1 + s3),
        "stress_ratio": s1 / s3 if s3 > 0.0 else math.nan,
    })
    if d == 3:
        isotropic = q <= ISOTROPIC_TOLERANCE * max(abs(s1), abs(s3)) or q == 0.0
        row["b"] = math.nan if isotropic else (float(values[1]) - s3) / q
    return row


def strain_invariants(strain: np.ndarray) -> dict[str, float]:
    """``eps_vol`` and ``eps_q`` of a (d, d) strain tensor [-] (module docstring; shears as
    tensor components, half the engineering ones).

    >>> strain_invariants(np.diag([-0.01, -0.01, 0.04]))
    {'eps_vol': 0.02, 'eps_q': 0.05}
    """
    sym = _symmetric(strain, "strain")
    values = np.linalg.eigvalsh(sym)
    return {"eps_vol": float(np.trace(sym)), "eps_q": float(values[-1] - values[0])}
