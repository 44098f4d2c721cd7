"""Derived outputs of element tests, computed from a :class:`~grainlab.result.TestResult` table.

Pure functions of the table (or of arrays): they read the columns written by
:func:`grainlab.lab.element_test.run_element_test` (compression positive, SI units, angles in
radians) and return arrays or data frames aligned with the table rows.

* One-dimensional compression (seed 001 §4.2.1): K0 = sigma_h / sigma_v and
  OCR = sigma_v,max / sigma_v (:func:`k0_series`).
* Strength: mobilised friction angle phi = asin((sigma_1 - sigma_3)/(sigma_1 + sigma_3)) and
  its peak (:func:`mobilised_friction_angle`, :func:`peak_friction_angle`); Lode angle and
  octahedral coordinates for failure points on the octahedral plane (seed 001 §4.2.2,
  Fig. 4.12: :func:`lode_angle`, :func:`octahedral_coordinates`, :func:`failure_point`).
* Direct simple shear (seed 001 §4.2.4, Fig. 4.16): inclinations from the horizontal plane,
  in the vertical plane of shear (x–z in 3D, x–y in 2D), of the major principal stress psi,
  the plane of maximum shear stress beta, of maximum stress ratio omega, of the major
  principal stress increment chi and of the major principal strain increment xi
  (:func:`principal_angles`), and kappa of Oda & Konishi's tau/sigma_v = kappa tan psi
  (eq. 4.8, :func:`fit_kappa`).
* Cyclic shear (seed 001 §4.1.3): per cycle the secant shear modulus and the damping ratio
  D = W_loop / (4 pi W_elastic) (:func:`cyclic_loops`, :func:`cyclic_shear_response`).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd

from grainlab.errors import InputError
from grainlab.result.test_result import TestResult

_CYCLE_STAGE = re.compile(r"^cycle_(\d+)$")


def _table(result: TestResult | pd.DataFrame) -> pd.DataFrame:
    if isinstance(result, TestResult):
        return result.table
    if isinstance(result, pd.DataFrame):
        return result
    raise InputError("result", type(result).__name__, "a TestResult or a pandas DataFrame")


def _column(table: pd.DataFrame, name: str) -> np.ndarray:
    if name not in table.columns:
        raise InputError("column", name, "one of " + ", ".join(map(str, table.columns)))
    return table[name].to_numpy(dtype=float)


def _is_3d(table: pd.DataFrame) -> bool:
    return "sigma_zz" in table.columns


def _ratio(numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """numerator / denominator, NaN where the denominator is not > 0 (no warnings)."""
    numerator = np.asarray(numerator, dtype=float)
    denominator = np.asarray(denominator, dtype=float)
    out = np.full(np.broadcast(numerator, denominator).shape, np.nan)
    np.divide(numerator, denominator, out=out, where=denominator > 0.0)
    return out


# -- one-dimensional compression ----------------------------------------------------------------
def k0_series(result: TestResult | pd.DataFrame) -> pd.DataFrame:
    """K0 and OCR along a test (seed 001 §4.2.1, Figs. 4.6–4.8).

    sigma_v [Pa] is sigma_zz (3D) or sigma_yy (2D); sigma_h [Pa] the mean lateral normal
    stress ((sigma_xx + sigma_yy)/2 in 3D, sigma_xx in 2D); K0 = sigma_h / sigma_v [-];
    sigma_v_max is the running maximum of sigma_v and OCR = sigma_v_max / sigma_v [-] (1
    while loading, > 1 while unloading).

    >>> t = pd.DataFrame({"sigma_xx": [1.0, 2.0, 1.5], "sigma_yy": [2.0, 4.0, 2.0],
    ...                   "sigma_xy": [0.0, 0.0, 0.0]})
    >>> k0_series(t)[["K0", "OCR"]].to_numpy().tolist()
    [[0.5, 1.0], [0.5, 1.0], [0.75, 2.0]]
    """
    table = _table(result)
    if _is_3d(table):
        sigma_v = _column(table, "sigma_zz")
        sigma_h = 0.5 * (_column(table, "sigma_xx") + _column(table, "sigma_yy"))
    else:
        sigma_v = _column(table, "sigma_yy")
        sigma_h = _column(table, "sigma_xx")
    running = np.maximum.accumulate(sigma_v)
    return pd.DataFrame({"sigma_v": sigma_v, "sigma_h": sigma_h,
                         "K0": _ratio(sigma_h, sigma_v), "sigma_v_max": running,
                         "OCR": _ratio(running, sigma_v)}, index=table.index)


# -- strength -----------------------------------------------------------------------------------
def mobilised_friction_angle(sigma_1: np.ndarray, sigma_3: np.ndarray) -> np.ndarray:
    """phi = asin((sigma_1 - sigma_3)/(sigma_1 + sigma_3)) [rad]; NaN where
    sigma_1 + sigma_3 <= 0.

    >>> round(float(np.degrees(mobilised_friction_angle(3.0, 1.0))), 6)
    30.0
    """
    s1 = np.asarray(sigma_1, dtype=float)
    s3 = np.asarray(sigma_3, dtype=float)
    sine = _ratio(s1 - s3, s1 + s3)
    return np.arcsin(np.clip(sine, -1.0, 1.0))


def peak_friction_angle(result: TestResult | pd.DataFrame) -> tuple[float, int]:
    """Peak mobilised friction angle [rad] of a test and the table row where it occurs.

    Rows whose stress-controlled components missed their targets (``converged`` False: the
    step at which a strain-driven test fails is recorded with the error it was left with,
    :mod:`grainlab.lab.element_test`) are not candidates: their sigma_3 is not the controlled
    one, so their angle is not a state the test reached."""
    table = _table(result)
    phi = mobilised_friction_angle(_column(table, "sigma_1"), _column(table, "sigma_3"))
    if "converged" in table.columns:
        phi = np.where(table["converged"].to_numpy(dtype=bool), phi, np.nan)
    if not np.any(np.isfinite(phi)):
        raise InputError("result", "no converged row with sigma_1 + sigma_3 > 0",
                         "a test with a compressive state")
    row = int(np.nanargmax(phi))
    return float(phi[row]), row


def lode_angle(sigma_1: np.ndarray, sigma_2: np.ndarray, sigma_3: np.ndarray) -> np.ndarray:
    """Lode angle theta [rad] in [0, pi/3] of ordered principal stresses
    (sigma_1 >= sigma_2 >= sigma_3): tan theta = sqrt(3)(sigma_2 - sigma_3) /
    (2 sigma_1 - sigma_2 - sigma_3), i.e. tan theta = sqrt(3) b / (2 - b): 0 in triaxial
    compression (b = 0), pi/3 in triaxial extension (b = 1); 0 at isotropic states.

    >>> round(float(np.degrees(lode_angle(3.0, 1.0, 1.0))), 9), round(float(np.degrees(
    ...     lode_angle(3.0, 3.0, 1.0))), 9)
    (0.0, 60.0)
    """
    s1 = np.asarray(sigma_1, dtype=float)
    s2 = np.asarray(sigma_2, dtype=float)
    s3 = np.asarray(sigma_3, dtype=float)
    return np.arctan2(math.sqrt(3.0) * (s2 - s3), 2.0 * s1 - s2 - s3)


def octahedral_coordinates(
    sigma_xx: np.ndarray, sigma_yy: np.ndarray, sigma_zz: np.ndarray
) -> pd.DataFrame:
    """Position of stresses with principal axes x, y, z on the octahedral plane.

    Columns: ``sigma_oct`` = (sx + sy + sz)/3 [Pa]; ``tau_oct`` =
    sqrt((sx - sy)^2 + (sy - sz)^2 + (sz - sx)^2)/3 [Pa]; ``q_equivalent`` = sqrt(3 J2) =
    3 tau_oct / sqrt(2) [Pa]; plot coordinates ``oct_x`` = (sx - sy)/sqrt(2) and ``oct_y`` =
    (2 sz - sx - sy)/sqrt(6) [Pa] (z projects upwards, x to the right of it), at distance
    sqrt(2/3) q_equivalent from the origin; ``alpha`` = atan2(oct_x, oct_y) [rad], the angle
    of :func:`grainlab.lab.load_path.octahedral_stress`; ``lode_angle`` [rad] (of the sorted
    values). Valid when the shear stresses are zero (cubical tests, circular paths).

    >>> c = octahedral_coordinates(1.0, 1.0, 4.0)
    >>> float(c["alpha"][0]), round(float(c["q_equivalent"][0]), 12)
    (0.0, 3.0)
    """
    sx, sy, sz = (np.atleast_1d(np.asarray(v, dtype=float)) for v in
                  (sigma_xx, sigma_yy, sigma_zz))
    tau = np.sqrt((sx - sy) ** 2 + (sy - sz) ** 2 + (sz - sx) ** 2) / 3.0
    ordered = np.sort(np.stack([sx, sy, sz]), axis=0)
    x = (sx - sy) / math.sqrt(2.0)
    y = (2.0 * sz - sx - sy) / math.sqrt(6.0)
    return pd.DataFrame({
        "sigma_oct": (sx + sy + sz) / 3.0, "tau_oct": tau,
        "q_equivalent": 3.0 * tau / math.sqrt(2.0), "oct_x": x, "oct_y": y,
        "alpha": np.arctan2(x, y),
        "lode_angle": lode_angle(ordered[2], ordered[1], ordered[0]),
    })


def failure_point(result: TestResult | pd.DataFrame) -> dict[str, float]:
    """The state at the peak mobilised friction angle of a 3D test, for failure surfaces on
    the octahedral plane (seed 001 Fig. 4.12): ``phi`` [rad], ``row``, ``b`` [-],
    ``lode_angle`` [rad], ``alpha`` [rad] and the normalised coordinates ``oct_x / p``,
    ``oct_y / p`` [-] (see :func:`octahedral_coordinates`)."""
    table = _table(result)
    if not _is_3d(table):
        raise InputError("result", "a 2D test", "a 3D test (octahedral plane)")
    phi, row = peak_friction_angle(table)
    coordinates = octahedral_coordinates(*(table[c].to_numpy(dtype=float)[row:row + 1]
                                           for c in ("sigma_xx", "sigma_yy", "sigma_zz")))
    p = float(coordinates["sigma_oct"][0])
    ordered = [float(table[c].iloc[row]) for c in ("sigma_1", "sigma_2", "sigma_3")]
    q = ordered[0] - ordered[2]
    return {
        "phi": phi, "row": row, "b": (ordered[1] - ordered[2]) / q if q > 0 else math.nan,
        "lode_angle": float(lode_angle(*ordered)), "alpha": float(coordinates["alpha"][0]),
        "oct_x / p": float(coordinates["oct_x"][0]) / p,
        "oct_y / p": float(coordinates["oct_y"][0]) / p,
    }


# -- simple shear -------------------------------------------------------------------------------
def _major_direction(horizontal: np.ndarray, vertical: np.ndarray,
                     shear: np.ndarray) -> np.ndarray:
    """Angle [rad] of the major eigenvector of [[h, s], [s, v]] from the vertical axis
    (= inclination of the plane it acts on from the horizontal), in (-pi/2, pi/2];
    positive towards +horizontal for s > 0. NaN for a zero tensor."""
    angle = 0.5 * np.arctan2(2.0 * shear, vertical - horizontal)
    zero = (horizontal == 0.0) & (vertical == 0.0) & (shear == 0.0)
    return np.where(zero, np.nan, angle)


def continuous_inclination(angles: np.ndarray) -> np.ndarray:
    """The branch of inclinations [rad] (defined modulo pi, as returned in (-pi/2, pi/2] by
    :func:`principal_angles`) that is continuous along the rows: each finite value is moved
    by a multiple of pi to lie within pi/2 of the previous finite one (NaNs stay NaN). A
    direction turning through the vertical then reads 85, 92, 95 deg instead of 85, -88, -85.

    >>> np.degrees(continuous_inclination(np.radians([80.0, 89.0, -88.0, np.nan, -80.0])))
    array([ 80.,  89.,  92.,  nan, 100.])
    """
    values = np.array(angles, dtype=float)
    finite = np.isfinite(values)
    values[finite] = 0.5 * np.unwrap(2.0 * values[finite])
    return values


def principal_angles(result: TestResult | pd.DataFrame) -> pd.DataFrame:
    """Inclinations [rad] from the horizontal plane in a simple-shear test (seed 001 §4.2.4,
    Fig. 4.16b), in the vertical plane of shear: horizontal x, vertical z with shear xz (3D)
    or vertical y with shear xy (2D).

    With sigma_h, sigma_v, tau the in-plane stresses and phi_m the in-plane mobilised friction
    angle (sin phi_m = radius / centre of the in-plane Mohr circle):

    * ``psi`` = 1/2 atan2(2 tau, sigma_v - sigma_h): the plane on which the major principal
      stress acts (its normal is the major direction, measured from the vertical; 0 for a
      vertical sigma_1, positive under positive tau);
    * ``beta`` = pi/4 - psi: plane of maximum shear stress (the conjugate plane that turns
      towards the horizontal as psi grows; 0 when the horizontal plane carries the maximum
      shear stress, i.e. at psi = 45 deg);
    * ``omega`` = pi/4 + phi_m/2 - psi: plane of maximum stress ratio tau_n/sigma_n (0 when it
      is the horizontal plane);
    * ``chi``: as psi for the stress increment between consecutive rows;
    * ``xi``: as psi for the strain increment (1/2 atan2(d gamma, d eps_v - d eps_h));

    plus ``tau_over_sigma_v`` [-] and ``phi_m`` [rad]. Increment angles are NaN on the first
    row and where the increment is zero.
    """
    table = _table(result)
    shear, vertical = ("xz", "zz") if _is_3d(table) else ("xy", "yy")
    s_h = _column(table, "sigma_xx")
    s_v = _column(table, f"sigma_{vertical}")
    tau = _column(table, f"sigma_{shear}")
    e_h = _column(table, "eps_xx")
    e_v = _column(table, f"eps_{vertical}")
    gamma = _column(table, f"gamma_{shear}")
    psi = _major_direction(s_h, s_v, tau)
    centre = 0.5 * (s_h + s_v)
    radius = np.hypot(0.5 * (s_v - s_h), tau)
    phi_m = np.arcsin(np.clip(_ratio(radius, centre), -1.0, 1.0))

    def increments(values: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.diff(values)])

    chi = _major_direction(increments(s_h), increments(s_v), increments(tau))
    xi = _major_direction(increments(e_h), increments(e_v), 0.5 * increments(gamma))
    chi[0] = xi[0] = np.nan
    return pd.DataFrame({
        "psi": psi, "beta": 0.25 * np.pi - psi, "omega": 0.25 * np.pi + 0.5 * phi_m - psi,
        "chi": chi, "xi": xi, "tau_over_sigma_v": _ratio(tau, s_v), "phi_m": phi_m,
    }, index=table.index)


def fit_kappa(tau_over_sigma_v: np.ndarray, psi: np.ndarray) -> float:
    """kappa of tau/sigma_v = kappa tan(psi) (seed 001 eq. 4.8, Oda & Konishi 1974) by least
    squares through the origin over the finite pairs: kappa = sum(y x)/sum(x^2), x = tan psi.

    >>> psi = np.radians([5.0, 10.0, 20.0, 30.0])
    >>> round(fit_kappa(0.64 * np.tan(psi), psi), 12)
    0.64
    """
    y = np.asarray(tau_over_sigma_v, dtype=float)
    x = np.tan(np.asarray(psi, dtype=float))
    keep = np.isfinite(x) & np.isfinite(y)
    denominator = float(np.sum(x[keep] ** 2))
    if denominator == 0.0:
        raise InputError("psi", "all zero or NaN", "some rows with a rotated major stress")
    return float(np.sum(x[keep] * y[keep]) / denominator)


# -- cyclic shear -------------------------------------------------------------------------------
def cyclic_loops(gamma: np.ndarray, tau: np.ndarray, cycle: np.ndarray) -> pd.DataFrame:
    """Secant modulus and damping per loading cycle (seed 001 §4.1.3, Figs. 4.3–4.4).

    ``cycle`` (int per row) numbers the cycles from 1; rows with 0 belong to none. Each loop
    is cycle c's rows preceded by the row just before them (the state the cycle starts from),
    closed back to its first point. Per cycle: ``gamma_amplitude`` = (max - min)/2 [-],
    ``tau_amplitude`` = (max - min)/2 [Pa], ``secant_modulus`` = peak-to-peak tau /
    peak-to-peak gamma [Pa], ``loop_area`` W_loop = |closed integral of tau d gamma|
    (shoelace) [Pa], ``elastic_energy`` W_el = tau_a gamma_a / 2 [Pa] and
    ``damping_ratio`` D = W_loop / (4 pi W_el) [-].

    >>> t = np.linspace(0.0, 2 * np.pi, 401)[1:]
    >>> loops = cyclic_loops(np.sin(t), 2.0 * np.sin(t), np.ones(t.size, int))
    >>> float(loops["secant_modulus"][0]), abs(float(loops["damping_ratio"][0])) < 1e-12
    (2.0, True)
    """
    gamma = np.asarray(gamma, dtype=float)
    tau = np.asarray(tau, dtype=float)
    cycle = np.asarray(cycle, dtype=int)
    if not gamma.shape == tau.shape == cycle.shape or gamma.ndim != 1:
        raise InputError("gamma, tau, cycle", (gamma.shape, tau.shape, cycle.shape),
                         "three 1D arrays of the same length")
    records = []
    for c in np.unique(cycle[cycle > 0]):
        rows = np.flatnonzero(cycle == c)
        if rows[0] > 0:
            rows = np.concatenate([[rows[0] - 1], rows])
        g, t = gamma[rows], tau[rows]
        area = 0.5 * abs(float(np.sum(g * np.roll(t, -1) - np.roll(g, -1) * t)))
        g_a = 0.5 * (g.max() - g.min())
        t_a = 0.5 * (t.max() - t.min())
        elastic = 0.5 * g_a * t_a
        records.append({
            "cycle": int(c), "gamma_amplitude": g_a, "tau_amplitude": t_a,
            "secant_modulus": t_a / g_a if g_a > 0 else math.nan, "loop_area": area,
            "elastic_energy": elastic,
            "damping_ratio": area / (4.0 * math.pi * elastic) if elastic > 0 else math.nan,
        })
    return pd.DataFrame(records, columns=["cycle", "gamma_amplitude", "tau_amplitude",
                                          "secant_modulus", "loop_area", "elastic_energy",
                                          "damping_ratio"])


def cyclic_shear_response(result: TestResult | pd.DataFrame) -> pd.DataFrame:
    """:func:`cyclic_loops` of a :func:`grainlab.lab.load_path.cyclic_shear` test: cycles
    from the stage names ``cycle_<k>``, tau = sigma_xz and gamma = gamma_xz (3D) or
    sigma_xy, gamma_xy (2D)."""
    table = _table(result)
    shear = "xz" if _is_3d(table) else "xy"
    stages = table["stage"].astype(str) if "stage" in table.columns else None
    if stages is None:
        raise InputError("column", "stage", "a table with a 'stage' column")
    cycle = np.array([int(m.group(1)) if (m := _CYCLE_STAGE.match(s)) else 0 for s in stages])
    if not np.any(cycle):
        raise InputError("stage", sorted(set(stages)), "stages named 'cycle_<k>'")
    return cyclic_loops(_column(table, f"gamma_{shear}"), _column(table, f"sigma_{shear}"),
                        cycle)
