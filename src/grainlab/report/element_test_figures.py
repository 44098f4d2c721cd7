"""Figures of element tests on seed 001's model (Figs. 3.3–3.6, 4.3–4.4 and 4.6–4.16).

Every function takes test results (:class:`~grainlab.result.test_result.TestResult`) or a
summary in the same format and returns a matplotlib :class:`~matplotlib.figure.Figure` made
without pyplot (:func:`grainlab.report.curves.new_figure_axes`). Compression is positive;
strains are drawn in percent, stresses in kPa, angles in degrees.

===============================  ================================================================
function                         figure
===============================  ================================================================
:func:`triaxial_figure`          q/p and eps_vol against the vertical strain (Figs. 3.4–3.6, 4.9)
:func:`k0_figure`                K0 against the vertical strain and against OCR (Figs. 3.3, 4.6)
:func:`oedometer_stages_figure`  K0 and sigma_zz against eps_zz, one line per stage (a
                                 discrete ``grainlab oedometer`` run: loading, unloading)
:func:`b_sweep_figure`           peak phi against b, failure points on the octahedral plane with
                                 Mohr–Coulomb, Matsuoka–Nakai and Lade–Duncan, strain-increment
                                 directions at failure (Figs. 4.11–4.13)
:func:`circular_path_figure`     stress and strain paths on the octahedral plane (Fig. 4.14)
:func:`simple_shear_figure`      tau/sigma_v–gamma, sigma_2 against (sigma_1 + sigma_3)/2,
                                 tau/sigma_v against tan psi with kappa, angles psi, beta, omega,
                                 chi, xi against gamma (Figs. 4.15–4.16)
:func:`cyclic_figure`            G_s/G_max and damping ratio against the shear-strain amplitude
                                 (Figs. 4.3–4.4)
:func:`hysteresis_figure`        tau against gamma of a cyclic simple-shear test
===============================  ================================================================

Summaries. :func:`b_sweep_figure` reads a summary table with one row per b and the columns
``b``, ``phi_peak`` [rad], ``oct_x_over_p``, ``oct_y_over_p`` [-] (failure point, see
:func:`grainlab.lab.derived.octahedral_coordinates`) and ``deps_oct_x``, ``deps_oct_y`` [-]
(strain increment at failure projected the same way); :func:`cyclic_figure` the columns
``gamma_amplitude`` [-], ``modulus_ratio`` G_s/G_max [-] and ``damping_ratio`` [-].
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from scipy.optimize import brentq

from grainlab.errors import InputError
from grainlab.lab.derived import (
    continuous_inclination,
    cyclic_shear_response,
    fit_kappa,
    k0_series,
    octahedral_coordinates,
    principal_angles,
)
from grainlab.report.curves import new_figure_axes
from grainlab.result.test_result import TestResult

SQRT2 = math.sqrt(2.0)
SQRT6 = math.sqrt(6.0)


# -- helpers ------------------------------------------------------------------------------------
def _as_list(results: TestResult | Sequence[TestResult]) -> list[TestResult]:
    if isinstance(results, TestResult):
        return [results]
    results = list(results)
    if not results or not all(isinstance(r, TestResult) for r in results):
        raise InputError("results", type(results).__name__, "one or more TestResult objects")
    return results


def _is_3d(table: pd.DataFrame) -> bool:
    return "sigma_zz" in table.columns


def _need(table: pd.DataFrame, columns: Sequence[str], what: str) -> None:
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise InputError(f"{what}: columns", missing, "a table holding " + ", ".join(columns))


def _label(result: TestResult, k: int, labels: Sequence[str] | None) -> str:
    if labels is not None:
        return str(labels[k])
    table = result.table
    if result.load_path.get("name") in ("true_triaxial", "cubical_constant_sigma3") and \
            "b" in table:
        b = table["b"].to_numpy(dtype=float)
        if np.any(np.isfinite(b)):
            return f"b = {np.nanmedian(b):.2g}"
    return str(result.metadata.get("title") or f"test {k + 1}")


def _finish(ax: Axes) -> None:
    ax.grid(alpha=0.3)


def _legend(ax: Axes) -> None:
    if any(not str(line.get_label()).startswith("_") for line in ax.lines):
        ax.legend(fontsize="small")


def vertical_strain_column(table: pd.DataFrame) -> str:
    """``eps_zz`` in 3D, ``eps_yy`` in 2D (the vertical axis of the presets)."""
    return "eps_zz" if _is_3d(table) else "eps_yy"


# -- triaxial / biaxial -------------------------------------------------------------------------
def stress_ratio(table: pd.DataFrame) -> tuple[np.ndarray, str]:
    """q/p [-] and its label: 3D q = sigma_1 - sigma_3, p = trace/3; 2D (seed 001 ch. 3)
    q = (sigma_1 - sigma_3)/2, p = (sigma_1 + sigma_3)/2, so q/p = sin(phi_mobilised)."""
    s1 = table["sigma_1"].to_numpy(dtype=float)
    s3 = table["sigma_3"].to_numpy(dtype=float)
    if _is_3d(table):
        p = table["p"].to_numpy(dtype=float)
        label = "q/p  (q = s1 - s3, p = tr/3)"
        q = s1 - s3
    else:
        p = 0.5 * (s1 + s3)
        q = 0.5 * (s1 - s3)
        label = "q/p  (q = (s1 - s3)/2, p = (s1 + s3)/2)"
    ratio = np.full(q.shape, np.nan)
    np.divide(q, p, out=ratio, where=p > 0)
    return ratio, label


def triaxial_figure(results: TestResult | Sequence[TestResult],
                    labels: Sequence[str] | None = None) -> Figure:
    """Stress ratio q/p and volumetric strain against the vertical strain (eps_zz in 3D,
    eps_yy in 2D) for one or several triaxial, true-triaxial or biaxial tests (seed 001
    Figs. 3.4–3.6, 4.9). Two axes."""
    results = _as_list(results)
    figure, (ax_q, ax_v) = new_figure_axes(1, 2, figsize=(10, 3.8))
    ylabel = ""
    for k, result in enumerate(results):
        table = result.table
        _need(table, ("sigma_1", "sigma_3", "p", "eps_vol"), "triaxial_figure")
        x = 100.0 * table[vertical_strain_column(table)].to_numpy(dtype=float)
        ratio, ylabel = stress_ratio(table)
        label = _label(result, k, labels)
        ax_q.plot(x, ratio, label=label)
        ax_v.plot(x, 100.0 * table["eps_vol"].to_numpy(dtype=float), label=label)
    vertical = vertical_strain_column(results[0].table)
    for ax in (ax_q, ax_v):
        ax.set_xlabel(f"vertical strain {vertical} [%]")
        _finish(ax)
    ax_q.set_ylabel(ylabel)
    ax_v.set_ylabel("volumetric strain [%] (compression +)")
    ax_v.axhline(0.0, color="k", lw=0.5)
    _legend(ax_q)
    figure.suptitle(results[0].specimen.get("structure", ""), fontsize="medium")
    figure.set_layout_engine("tight")
    return figure


# -- one-dimensional compression ----------------------------------------------------------------
def k0_figure(results: TestResult | Sequence[TestResult],
              labels: Sequence[str] | None = None) -> Figure:
    """K0 = sigma_h/sigma_v against the vertical strain, and against OCR on unloading
    (rows with OCR > 1, starting from the last loading row) (seed 001 Figs. 3.3, 4.6).
    Two axes."""
    results = _as_list(results)
    figure, (ax_e, ax_o) = new_figure_axes(1, 2, figsize=(10, 3.8))
    any_unloading = False
    for k, result in enumerate(results):
        table = result.table
        series = k0_series(table)
        label = _label(result, k, labels)
        x = 100.0 * table[vertical_strain_column(table)].to_numpy(dtype=float)
        ax_e.plot(x, series["K0"], label=label)
        ocr = series["OCR"].to_numpy(dtype=float)
        unloading = np.flatnonzero(ocr > 1.0 + 1e-9)
        if unloading.size:
            any_unloading = True
            rows = np.concatenate([[max(unloading[0] - 1, 0)], unloading])
            ax_o.plot(ocr[rows], series["K0"].to_numpy()[rows], marker=".", ms=3, label=label)
    ax_e.set_xlabel(f"vertical strain {vertical_strain_column(results[0].table)} [%]")
    ax_e.set_ylabel("K0 = sigma_h / sigma_v")
    ax_o.set_xlabel("OCR = sigma_v,max / sigma_v")
    ax_o.set_ylabel("K0 = sigma_h / sigma_v")
    if not any_unloading:
        ax_o.text(0.5, 0.5, "no unloading", transform=ax_o.transAxes, ha="center")
    for ax in (ax_e, ax_o):
        _finish(ax)
    _legend(ax_e)
    figure.suptitle("One-dimensional compression: loading and unloading", fontsize="medium")
    figure.set_layout_engine("tight")
    return figure


def oedometer_stages_figure(result: TestResult, skip: Sequence[str] = ("compaction",)
                            ) -> Figure:
    """K0 = (sigma_xx + sigma_yy)/(2 sigma_zz) (:func:`~grainlab.lab.derived.k0_series`) and
    sigma_zz against eps_zz of a one-dimensional compression in stages (2D: K0 =
    sigma_xx / sigma_yy and sigma_yy against eps_yy), one line per stage
    labelled by its name (``loading``, ``unloading``), each starting at the last row of the
    stage before so that the curves join. Stages named in ``skip`` are left out: the
    compaction of a discrete run, whose strains are from the initial box while those of the
    later stages are from the box the compaction ended in; the first line drawn starts at
    the last skipped row, at eps_zz = 0. Two axes.

    >>> t = pd.DataFrame({"stage": ["loading"] * 2 + ["unloading"], "eps_zz": [0, 1e-3, 5e-4],
    ...                   "sigma_xx": [1e4, 2e4, 1.5e4], "sigma_yy": [1e4, 2e4, 1.5e4],
    ...                   "sigma_zz": [1e4, 4e4, 2e4]})
    >>> figure = oedometer_stages_figure(TestResult.create(t, specimen={}, load_path={}))
    >>> [line.get_label() for line in figure.axes[0].lines]
    ['loading', 'unloading']
    """
    table = result.table
    planar = not _is_3d(table)  # 2D: vertical axis y, K0 = sigma_xx / sigma_yy
    eps, sigma_v = ("eps_yy", "sigma_yy") if planar else ("eps_zz", "sigma_zz")
    _need(table, ("stage", eps, "sigma_xx", "sigma_yy") + (() if planar else ("sigma_zz",)),
          "oedometer_stages_figure")
    k0 = k0_series(table)["K0"].to_numpy(dtype=float)
    strain = 100.0 * table[eps].to_numpy(dtype=float)
    sigma = 1e-3 * table[sigma_v].to_numpy(dtype=float)
    stages = table["stage"].astype(str).to_numpy()
    figure, (ax_k, ax_s) = new_figure_axes(1, 2, figsize=(10, 3.8))
    previous, skipped = None, None
    for name in dict.fromkeys(stages):
        rows = np.flatnonzero(stages == name)
        if name in skip:
            skipped = rows[-1]
            continue
        x, k, y = strain[rows], k0[rows], sigma[rows]
        start = previous if previous is not None else skipped
        if start is not None:
            x = np.concatenate([[strain[start] if previous is not None else 0.0], x])
            k, y = np.concatenate([[k0[start]], k]), np.concatenate([[sigma[start]], y])
        ax_k.plot(x, k, marker=".", ms=4, label=name)
        ax_s.plot(x, y, marker=".", ms=4, label=name)
        previous = rows[-1]
    ax_k.set_ylabel("K0 = sigma_xx / sigma_yy" if planar else
                    "K0 = (sigma_xx + sigma_yy) / (2 sigma_zz)")
    ax_s.set_ylabel(f"{sigma_v} [kPa]")
    for ax in (ax_k, ax_s):
        ax.set_xlabel(f"vertical strain {eps} [%]")
        _finish(ax)
        _legend(ax)
    figure.suptitle(str(result.metadata.get("title") or "one-dimensional compression"),
                    fontsize="medium")
    figure.set_layout_engine("tight")
    return figure


# -- failure surfaces on the octahedral plane ---------------------------------------------------
def _unit_deviators(alpha: np.ndarray) -> np.ndarray:
    """(n, 3) principal stresses (x, y, z) of p = 1... minus p, per unit q, at the angles
    alpha of :func:`grainlab.lab.presets.octahedral_stress`."""
    return (2.0 / 3.0) * np.column_stack([np.cos(alpha - 2 * np.pi / 3),
                                          np.cos(alpha + 2 * np.pi / 3), np.cos(alpha)])


def _solve_ratio(function: Callable[[float], float], top: float) -> float:
    """Root of ``function`` on (0, top) (it is < 0 at 0 and > 0 near top)."""
    high = top * (1.0 - 1e-12)
    if function(high) <= 0.0:
        return high
    return float(brentq(function, 0.0, high, xtol=1e-12))


def _invariant_residual(criterion: str, constant: float,
                        deviator: tuple[float, float, float]) -> Callable[[float], float]:
    """f(rho) = I1 I2 - k I3 (Matsuoka–Nakai) or I1^3 - k I3 (Lade–Duncan) of the principal
    stresses 1 + rho s_i (p = 1)."""

    def residual(rho: float) -> float:
        a, b, c = (1.0 + rho * v for v in deviator)
        i1, i3 = a + b + c, a * b * c
        if criterion == "matsuoka-nakai":
            return i1 * (a * b + b * c + c * a) - constant * i3
        return i1**3 - constant * i3

    return residual


def failure_surface(phi: float, criterion: str, n: int = 361) -> np.ndarray:
    """(n, 2) points (oct_x/p, oct_y/p) of a failure surface on the octahedral plane that
    passes through triaxial compression at the friction angle ``phi`` [rad].

    With sigma_i = p (1 + rho s_i), s the unit deviator at angle alpha and rho = q/p, and
    N = (1 + sin phi)/(1 - sin phi):

    * ``"mohr-coulomb"``: sigma_1 - sigma_3 = (sigma_1 + sigma_3) sin phi, so
      rho = 2 sin phi / ((s_1 - s_3) - sin phi (s_1 + s_3));
    * ``"matsuoka-nakai"``: I1 I2 / I3 = (N + 2)(2N + 1)/N;
    * ``"lade-duncan"``: I1^3 / I3 = (N + 2)^3 / N;

    (the last two solved for rho by bisection between 0 and sigma_3 = 0). Coordinates as
    :func:`grainlab.lab.derived.octahedral_coordinates` divided by p.

    >>> tc = failure_surface(np.radians(30.0), "lade-duncan", 7)[0]
    >>> round(float(tc[1] * np.sqrt(3 / 2)), 9)  # q/p in compression = 6 sin phi/(3 - sin phi)
    1.2
    """
    if criterion not in ("mohr-coulomb", "matsuoka-nakai", "lade-duncan"):
        raise InputError("criterion", criterion,
                         "'mohr-coulomb', 'matsuoka-nakai' or 'lade-duncan'")
    sine = math.sin(phi)
    if not 0.0 < sine < 1.0:
        raise InputError("phi", phi, "a friction angle in (0, pi/2) rad")
    ratio_n = (1.0 + sine) / (1.0 - sine)
    constant = ((ratio_n + 2.0) * (2.0 * ratio_n + 1.0) / ratio_n
                if criterion == "matsuoka-nakai" else (ratio_n + 2.0) ** 3 / ratio_n)
    alpha = np.linspace(0.0, 2.0 * np.pi, n)
    deviators = _unit_deviators(alpha)
    rho = np.empty(n)
    for k, s in enumerate(deviators):
        s1, s2, s3 = np.sort(s)[::-1]
        if criterion == "mohr-coulomb":
            rho[k] = 2.0 * sine / ((s1 - s3) - sine * (s1 + s3))
        else:
            rho[k] = _solve_ratio(_invariant_residual(criterion, constant, (s1, s2, s3)),
                                  -1.0 / s3)
    x = rho * (deviators[:, 0] - deviators[:, 1]) / SQRT2
    y = rho * (2.0 * deviators[:, 2] - deviators[:, 0] - deviators[:, 1]) / SQRT6
    return np.column_stack([x, y])


def _octahedral_axes(ax: Axes, reach: float) -> None:
    """Projections of the x, y, z axes on the octahedral plane (z up)."""
    for name, angle in (("z", 0.0), ("x", 2 * np.pi / 3), ("y", -2 * np.pi / 3)):
        end = reach * np.array([np.sin(angle), np.cos(angle)])
        ax.plot([0, end[0]], [0, end[1]], color="0.6", lw=0.6, ls=":")
        ax.annotate(f"sigma_{name}", end, fontsize="small", color="0.4", ha="center")
    ax.set_aspect("equal")


def _reference_phi(table: pd.DataFrame) -> float:
    b = table["b"].to_numpy(dtype=float)
    row = int(np.nanargmin(np.abs(b)))
    return float(table["phi_peak"].iloc[row])


def b_sweep_figure(summary: TestResult, reference_phi: float | None = None) -> Figure:
    """Seed 001 Figs. 4.11–4.13 from a b-sweep summary (module docstring): peak friction
    angle against b; failure points on the octahedral plane with the Mohr–Coulomb,
    Matsuoka–Nakai and Lade–Duncan surfaces through triaxial compression at
    ``reference_phi`` [rad] (default: the peak angle of the row with the smallest b); and the
    strain-increment directions at failure as arrows from the failure points. Three axes."""
    table = summary.table
    _need(table, ("b", "phi_peak", "oct_x_over_p", "oct_y_over_p", "deps_oct_x",
                  "deps_oct_y"), "b_sweep_figure")
    figure, (ax_b, ax_s, ax_d) = new_figure_axes(1, 3, figsize=(15, 4.6))
    b = table["b"].to_numpy(dtype=float)
    phi = table["phi_peak"].to_numpy(dtype=float)
    ax_b.plot(b, np.degrees(phi), "o-")
    ax_b.set_xlabel("b = (sigma_2 - sigma_3)/(sigma_1 - sigma_3)")
    ax_b.set_ylabel("peak friction angle [deg]")
    held = {"true_triaxial": ", constant p",
            "cubical_constant_sigma3": ", constant sigma_3"}.get(
        str(summary.load_path.get("preset", "")), "")
    ax_b.set_title(f"Peak friction angle against b{held}", fontsize="medium")
    _finish(ax_b)
    x = table["oct_x_over_p"].to_numpy(dtype=float)
    y = table["oct_y_over_p"].to_numpy(dtype=float)
    phi_ref = _reference_phi(table) if reference_phi is None else float(reference_phi)
    radii = np.hypot(x, y)
    reach = max(float(np.nanmax(radii)) if np.any(np.isfinite(radii)) else 1.0, 0.1)
    if 0.0 < math.sin(phi_ref) < 1.0 - 1e-9:
        for criterion, style in (("mohr-coulomb", "-"), ("matsuoka-nakai", "--"),
                                 ("lade-duncan", "-.")):
            curve = failure_surface(phi_ref, criterion)
            ax_s.plot(curve[:, 0], curve[:, 1], style, lw=1.0, label=criterion)
            reach = max(reach, float(np.max(np.hypot(curve[:, 0], curve[:, 1]))))
    ax_s.plot(x, y, "ko", ms=5, label="model (failure points)")
    ax_s.set_title(f"Failure on the octahedral plane (phi_TC = {np.degrees(phi_ref):.1f} deg)",
                   fontsize="medium")
    ax_d.plot(x, y, "ko-", ms=4, lw=0.8, label="failure points")
    dx = table["deps_oct_x"].to_numpy(dtype=float)
    dy = table["deps_oct_y"].to_numpy(dtype=float)
    length = np.hypot(dx, dy)
    ok = np.isfinite(length) & (length > 0)
    scale = 0.3 * reach
    ax_d.quiver(x[ok], y[ok], scale * dx[ok] / length[ok], scale * dy[ok] / length[ok],
                angles="xy", scale_units="xy", scale=1.0, color="tab:red", width=0.006)
    ax_d.set_title("Strain-increment directions at failure", fontsize="medium")
    for ax in (ax_s, ax_d):
        _octahedral_axes(ax, 1.15 * reach)
        ax.set_xlabel("(sigma_x - sigma_y) / (sqrt(2) p)")
        ax.set_ylabel("(2 sigma_z - sigma_x - sigma_y) / (sqrt(6) p)")
        ax.set_xlim(-1.3 * reach, 1.3 * reach)
        ax.set_ylim(-1.3 * reach, 1.3 * reach)
        _finish(ax)
        _legend(ax)
    figure.set_layout_engine("tight")
    return figure


# -- circular stress paths ----------------------------------------------------------------------
def strain_octahedral_coordinates(table: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """(e_x, e_y) = ((eps_xx - eps_yy)/sqrt 2, (2 eps_zz - eps_xx - eps_yy)/sqrt 6) [-]: the
    strain path on the deviatoric plane, axes as for the stresses."""
    exx, eyy, ezz = (table[c].to_numpy(dtype=float) for c in ("eps_xx", "eps_yy", "eps_zz"))
    return (exx - eyy) / SQRT2, (2.0 * ezz - exx - eyy) / SQRT6


def circular_path_figure(results: TestResult | Sequence[TestResult],
                         labels: Sequence[str] | None = None) -> Figure:
    """Stress path [kPa] and strain path [%] on the octahedral (deviatoric) plane of
    circular stress-path tests (seed 001 Fig. 4.14); rows of the stage ``circle`` drawn
    solid, the approach dotted. Two axes."""
    results = _as_list(results)
    figure, (ax_s, ax_e) = new_figure_axes(1, 2, figsize=(10, 4.8))
    reach_s, reach_e = 0.0, 0.0
    for k, result in enumerate(results):
        table = result.table
        if not _is_3d(table):
            raise InputError("results", "a 2D test", "3D tests (octahedral plane)")
        label = _label(result, k, labels)
        if labels is None and result.load_path.get("name") == "circular_octahedral":
            label = _circle_label(result, k)
        c = octahedral_coordinates(table["sigma_xx"], table["sigma_yy"], table["sigma_zz"])
        sx, sy = c["oct_x"].to_numpy() / 1e3, c["oct_y"].to_numpy() / 1e3
        ex, ey = (100.0 * v for v in strain_octahedral_coordinates(table))
        circle = (table["stage"].astype(str) == "circle").to_numpy() if "stage" in table \
            else np.ones(len(table), bool)
        start = max(int(np.argmax(circle)) - 1, 0) if circle.any() else 0
        line = ax_s.plot(sx[start:], sy[start:], label=label)[0]
        ax_s.plot(sx[:start + 1], sy[:start + 1], ":", color=line.get_color())
        ax_e.plot(ex[start:], ey[start:], color=line.get_color(), label=label)
        ax_e.plot(ex[:start + 1], ey[:start + 1], ":", color=line.get_color())
        reach_s = max(reach_s, float(np.nanmax(np.hypot(sx, sy))))
        reach_e = max(reach_e, float(np.nanmax(np.hypot(ex, ey))))
    _octahedral_axes(ax_s, 1.1 * max(reach_s, 1e-12))
    _octahedral_axes(ax_e, 1.1 * max(reach_e, 1e-12))
    ax_s.set_xlabel("(sigma_x - sigma_y)/sqrt(2) [kPa]")
    ax_s.set_ylabel("(2 sigma_z - sigma_x - sigma_y)/sqrt(6) [kPa]")
    ax_s.set_title("Stress path", fontsize="medium")
    ax_e.set_xlabel("(eps_x - eps_y)/sqrt(2) [%]")
    ax_e.set_ylabel("(2 eps_z - eps_x - eps_y)/sqrt(6) [%]")
    ax_e.set_title("Strain path", fontsize="medium")
    for ax in (ax_s, ax_e):
        _finish(ax)
    _legend(ax_s)
    figure.set_layout_engine("tight")
    return figure


def _circle_label(result: TestResult, k: int) -> str:
    stages = {s["name"]: s for s in result.load_path.get("stages", [])}
    approach = stages.get("approach")
    if approach is None:
        return f"test {k + 1}"
    target = np.array(approach["values"][:3], dtype=float)
    c = octahedral_coordinates(*target)
    p = float(c["sigma_oct"][0])
    return (f"alpha0 = {np.degrees(float(c['alpha'][0])):.0f} deg, "
            f"q/p = {float(c['q_equivalent'][0]) / p:.2g}")


# -- simple shear -------------------------------------------------------------------------------
def _shear_rows(table: pd.DataFrame) -> np.ndarray:
    if "stage" in table:
        rows = np.array(table["stage"].astype(str) == "shear", dtype=bool)
        if rows.any():
            first = int(np.argmax(rows))
            rows[max(first - 1, 0)] = True  # the state the shear starts from
            return rows
    return np.ones(len(table), bool)


def simple_shear_figure(result: TestResult) -> Figure:
    """Direct simple shear (seed 001 Figs. 4.15–4.16), rows of the ``shear`` stage: (a)
    tau/sigma_v against gamma; (b) sigma_2 against (sigma_1 + sigma_3)/2 with the line of
    equality (Hill's proposition; 3D only); (c) tau/sigma_v against tan psi with the fitted
    kappa of eq. 4.8; (d) the angles psi, beta, omega, chi, xi against gamma, each on its branch
    continuous modulo 180 deg (:func:`grainlab.lab.derived.principal_angles`,
    :func:`~grainlab.lab.derived.continuous_inclination`). Four axes."""
    if not isinstance(result, TestResult):
        raise InputError("result", type(result).__name__, "a TestResult")
    table = result.table
    rows = _shear_rows(table)
    shear = "xz" if _is_3d(table) else "xy"
    angles = principal_angles(table)[rows]
    part = table[rows]
    gamma = 100.0 * part[f"gamma_{shear}"].to_numpy(dtype=float)
    if "stage" in part and len(part) and str(part["stage"].iloc[0]) != "shear":
        gamma[0] = 0.0  # the state the shear starts from: its strains count from there
    figure, axes = new_figure_axes(2, 2, figsize=(10, 8))
    (ax_t, ax_2), (ax_k, ax_a) = axes
    ratio = angles["tau_over_sigma_v"].to_numpy(dtype=float)
    ax_t.plot(gamma, ratio)
    ax_t.set_xlabel(f"gamma_{shear} [%]")
    ax_t.set_ylabel(f"tau / sigma_v  (sigma_{shear} / sigma_v)")
    ax_t.set_title("(a) stress ratio", fontsize="medium")
    if "sigma_2" in part:
        mean13 = 0.5 * (part["sigma_1"] + part["sigma_3"]).to_numpy(dtype=float) / 1e3
        s2 = part["sigma_2"].to_numpy(dtype=float) / 1e3
        ax_2.plot(mean13, s2, ".-", ms=3, label="model")
        both = np.concatenate([mean13, s2])
        low, high = float(np.nanmin(both)), float(np.nanmax(both))
        ax_2.plot([low, high], [low, high], "k--", lw=0.8, label="sigma_2 = (s1 + s3)/2")
        ax_2.legend(fontsize="small")
    else:
        ax_2.text(0.5, 0.5, "no sigma_2 in a 2D test", transform=ax_2.transAxes,
                  ha="center")
    ax_2.set_xlabel("(sigma_1 + sigma_3)/2 [kPa]")
    ax_2.set_ylabel("sigma_2 [kPa]")
    ax_2.set_title("(b) intermediate principal stress", fontsize="medium")
    tan_psi = np.tan(angles["psi"].to_numpy(dtype=float))
    ax_k.plot(tan_psi, ratio, ".", ms=4, label="model")
    try:
        kappa = fit_kappa(ratio, angles["psi"].to_numpy(dtype=float))
    except InputError:
        kappa = math.nan
    if math.isfinite(kappa):
        top = float(np.nanmax(tan_psi)) if np.any(np.isfinite(tan_psi)) else 1.0
        ax_k.plot([0.0, top], [0.0, kappa * top], "k--", lw=0.8,
                  label=f"tau/sigma_v = {kappa:.3f} tan psi")
    ax_k.legend(fontsize="small")
    ax_k.set_xlabel("tan psi")
    ax_k.set_ylabel("tau / sigma_v")
    ax_k.set_title("(c) Oda & Konishi: kappa (eq. 4.8)", fontsize="medium")
    for name in ("psi", "beta", "omega", "chi", "xi"):  # planes: continuous modulo 180 deg
        ax_a.plot(gamma, np.degrees(continuous_inclination(angles[name].to_numpy(dtype=float))),
                  label=name)
    ax_a.axhline(0.0, color="k", lw=0.5)
    ax_a.set_xlabel(f"gamma_{shear} [%]")
    ax_a.set_ylabel("inclination from the horizontal [deg]")
    ax_a.set_title("(d) psi, beta, omega, chi, xi", fontsize="medium")
    ax_a.legend(fontsize="small", ncols=2)
    for ax in (ax_t, ax_2, ax_k, ax_a):
        _finish(ax)
    figure.set_layout_engine("tight")
    return figure


# -- cyclic shear -------------------------------------------------------------------------------
def cyclic_figure(summary: TestResult) -> Figure:
    """Secant modulus ratio G_s/G_max and damping ratio against the shear-strain amplitude,
    log scale (seed 001 Figs. 4.3–4.4), from a summary with the columns
    ``gamma_amplitude``, ``modulus_ratio`` and ``damping_ratio``. Two axes."""
    table = summary.table
    _need(table, ("gamma_amplitude", "modulus_ratio", "damping_ratio"), "cyclic_figure")
    order = np.argsort(table["gamma_amplitude"].to_numpy(dtype=float))
    gamma = 100.0 * table["gamma_amplitude"].to_numpy(dtype=float)[order]
    figure, (ax_g, ax_d) = new_figure_axes(1, 2, figsize=(10, 3.8))
    ax_g.plot(gamma, table["modulus_ratio"].to_numpy(dtype=float)[order], "o-")
    ax_g.set_ylabel("G_s / G_max")
    ax_d.plot(gamma, 100.0 * table["damping_ratio"].to_numpy(dtype=float)[order], "s-")
    ax_d.set_ylabel("damping ratio [%]")
    for ax in (ax_g, ax_d):
        ax.set_xscale("log")
        ax.set_xlabel("shear-strain amplitude [%]")
        _finish(ax)
    figure.suptitle("Cyclic simple shear: secant modulus and damping", fontsize="medium")
    figure.set_layout_engine("tight")
    return figure


def hysteresis_figure(results: TestResult | Sequence[TestResult],
                      labels: Sequence[str] | None = None) -> Figure:
    """Shear stress against shear strain of cyclic simple-shear tests, with the secant
    modulus of the last cycle in the legend. One axes."""
    results = _as_list(results)
    figure, ax = new_figure_axes(figsize=(5.5, 4.2))
    for k, result in enumerate(results):
        table = result.table
        shear = "xz" if _is_3d(table) else "xy"
        label = _label(result, k, labels)
        try:
            loops = cyclic_shear_response(table)
            label += f" (G_s = {loops['secant_modulus'].iloc[-1] / 1e6:.4g} MPa)"
        except InputError:
            pass
        ax.plot(100.0 * table[f"gamma_{shear}"].to_numpy(dtype=float),
                table[f"sigma_{shear}"].to_numpy(dtype=float) / 1e3, label=label)
    ax.set_xlabel("gamma [%]")
    ax.set_ylabel("tau [kPa]")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.axvline(0.0, color="k", lw=0.5)
    _finish(ax)
    _legend(ax)
    return figure
