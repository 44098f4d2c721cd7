"""Figures of seed 000 for regular packings: Figs. 7, 8, 9 and 10, and the tessellation."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.collections import LineCollection, PatchCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Polygon

from grainlab.geometry.disc_packing import DiscPacking2D
from grainlab.geometry.power_tessellation import power_tessellation
from grainlab.micromech.regular_packing.model import RegularPackingModel
from grainlab.report.curves import new_figure_axes
from grainlab.result.test_result import TestResult


def stress_ratio_strain_figure(results: TestResult | Sequence[TestResult]) -> Figure:
    """Seed 000 Fig. 7: stress ratio sigma_1/sigma_3 against eps_x, eps_y and gamma_xy."""
    if isinstance(results, TestResult):
        results = [results]
    figure, axes = new_figure_axes(1, 3, figsize=(12, 3.8), sharey=True)
    for result in results:
        shear = result.table
        label = f"alpha = {result.load_path.get('alpha_deg', 0):g} deg"
        for ax, column in zip(axes, ("eps_xx", "eps_yy", "gamma_xy"), strict=True):
            ax.plot(100 * shear[column], shear["stress_ratio"], marker=".", ms=3, label=label)
            ax.set_xlabel(f"{column} [%]")
            ax.grid(alpha=0.3)
    axes[0].set_ylabel("stress ratio sigma_1/sigma_3")
    axes[0].legend(fontsize="small")
    packing = results[0].specimen.get("packing", "")
    figure.suptitle(f"Packing {packing}: strains against stress ratio (compression positive)")
    return figure


def _broken_at_poles(x: np.ndarray, ratio: np.ndarray, denominator: np.ndarray):
    """Insert NaN between neighbours whose denominator changes sign, so that a line is not
    drawn through the pole of a ratio."""
    xs, ys = [x[0]], [ratio[0]]
    for k in range(1, len(x)):
        if denominator[k - 1] * denominator[k] < 0.0:
            xs.append(np.nan)
            ys.append(np.nan)
        xs.append(x[k])
        ys.append(ratio[k])
    return np.array(xs), np.array(ys)


def strain_ratio_figure(summary: TestResult) -> Figure:
    """Seed 000 Fig. 8: gamma_xy/eps_x and eps_x/eps_y against the loading direction alpha.

    Lines break where eps_x (left) or eps_y (right) changes sign: the ratio has a pole there."""
    table = summary.table
    ratio = summary.metadata["parameters"].get("reference_stress_ratio")
    figure, axes = new_figure_axes(1, 2, figsize=(9, 3.8))
    alpha = table["alpha_deg"].to_numpy()
    axes[0].plot(*_broken_at_poles(alpha, table["gamma_xy_over_eps_xx"].to_numpy(),
                                   table["eps_xx"].to_numpy()), "o-")
    axes[0].set_ylabel("gamma_xy / eps_x")
    axes[1].plot(*_broken_at_poles(alpha, table["eps_xx_over_eps_yy"].to_numpy(),
                                   table["eps_yy"].to_numpy()), "s-")
    axes[1].set_ylabel("eps_x / eps_y")
    for ax in axes:
        ax.set_xlabel("alpha [deg]")
        ax.grid(alpha=0.3)
    figure.suptitle(
        f"Packing {summary.specimen.get('packing', '')}: strain ratios at "
        f"sigma_1/sigma_3 = {ratio:g}"
    )
    figure.set_layout_engine("tight")
    return figure


def noncoaxiality_figure(summary: TestResult) -> Figure:
    """Seed 000 Fig. 9: angle between the stress and strain-increment directions vs alpha."""
    table = summary.table
    ratio = summary.metadata["parameters"].get("reference_stress_ratio")
    figure, ax = new_figure_axes(figsize=(5, 3.8))
    ax.plot(table["alpha_deg"], table["noncoaxiality_deg"], "o-",
            label=f"at sigma_1/sigma_3 = {ratio:g}")
    if "initial_noncoaxiality_deg" in table:
        ax.plot(table["alpha_deg"], table["initial_noncoaxiality_deg"], "s--",
                label="first increment")
    ax.legend(fontsize="small")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("alpha [deg]")
    ax.set_ylabel("non-coaxiality [deg]")
    ax.set_title(
        f"Packing {summary.specimen.get('packing', '')}: strain-increment minus stress "
        f"direction\nat sigma_1/sigma_3 = {ratio:g}",
        fontsize="medium",
    )
    ax.grid(alpha=0.3)
    return figure


def _draw_packing(ax, packing: DiscPacking2D, reach: int = 1) -> None:
    """Discs of the cell and their images, the power cells of the cell, the cell outline."""
    lattice = packing.cell.lattice
    tessellation = power_tessellation(packing)
    discs, cells = [], []
    for n1 in range(-reach, reach + 1):
        for n2 in range(-reach, reach + 1):
            shift = n1 * lattice[0] + n2 * lattice[1]
            for centre, radius in zip(packing.centres, packing.radii, strict=True):
                discs.append(Circle(centre + shift, radius))
            for polygon in tessellation.polygons:
                cells.append(Polygon(polygon + shift, closed=True))
    ax.add_collection(PatchCollection(cells, facecolor="none", edgecolor="0.6", lw=0.6))
    ax.add_collection(PatchCollection(discs, facecolor="0.85", edgecolor="0.3", lw=0.8))
    own = [Polygon(p, closed=True) for p in tessellation.polygons]
    ax.add_collection(PatchCollection(own, facecolor="tab:blue", alpha=0.12, edgecolor="tab:blue"))
    corner = np.array([[0, 0], lattice[0], lattice[0] + lattice[1], lattice[1], [0, 0]])
    ax.plot(corner[:, 0], corner[:, 1], "k--", lw=0.8)
    for centre, label in zip(packing.centres, packing.labels, strict=True):
        ax.annotate(label, centre, ha="center", va="center", fontsize=7)
    ax.set_aspect("equal")
    box = np.vstack([corner, packing.centres])
    margin = 1.5 * packing.radii.max()
    ax.set_xlim(box[:, 0].min() - margin, box[:, 0].max() + margin)
    ax.set_ylim(box[:, 1].min() - margin, box[:, 1].max() + margin)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def tessellation_figure(packing: DiscPacking2D) -> Figure:
    """The packing, its periodic cell (dashed) and its radical-plane tessellation (shaded)."""
    figure, ax = new_figure_axes(figsize=(5.5, 5.5))
    _draw_packing(ax, packing)
    ax.set_title(
        f"Packing {packing.name}: e = {packing.void_ratio:.4f}", fontsize="medium"
    )
    return figure


def contact_force_figure(
    model: RegularPackingModel, result: TestResult, rows: Sequence[int] = (0, -1)
) -> Figure:
    """Seed 000 Fig. 10: contact forces drawn in the tessellation, at the given table rows.

    Each contact carries two bars centred on its contact point: the normal part of its force
    (thick, red) and the tangential part (thin, green), of lengths proportional to their
    magnitudes, each panel scaled to its largest force (given in its title).
    """
    normal = result.snapshots["normal_force"]
    tangential = result.snapshots["tangential_force"]
    figure, axes = new_figure_axes(
        1, len(rows), figsize=(5.5 * len(rows), 5.5), squeeze=False
    )
    contacts = model.contacts
    lattice = model.packing.cell.lattice
    arrow_length = 0.8 * model.packing.radii.min()
    for ax, row in zip(axes[0], rows, strict=True):
        scale_force = max(float(np.max(np.hypot(normal[row], tangential[row]))), 1e-300)
        _draw_packing(ax, model.packing)
        point = model.packing.centres[contacts.particle_i] + contacts.contact_point_offset_i
        fn = normal[row][:, None] * contacts.normal * arrow_length / scale_force
        ft = tangential[row][:, None] * contacts.tangent * arrow_length / scale_force
        normal_lines, tangential_lines = [], []
        for n1 in (-1, 0, 1):
            for n2 in (-1, 0, 1):
                p = point + n1 * lattice[0] + n2 * lattice[1]
                normal_lines += [[a - f / 2, a + f / 2] for a, f in zip(p, fn, strict=True)]
                tangential_lines += [[a - f / 2, a + f / 2] for a, f in zip(p, ft, strict=True)]
        ax.add_collection(LineCollection(normal_lines, colors="tab:red", lw=3))
        ax.add_collection(LineCollection(tangential_lines, colors="tab:green", lw=1.5))
        table_row = result.table.iloc[row]
        ax.set_title(
            f"{result.specimen.get('packing', '')}: sigma_1/sigma_3 = "
            f"{table_row['stress_ratio']:.3g}, alpha = {result.load_path.get('alpha_deg', 0):g}"
            f" deg\nred: normal, green: tangential (max |f| = {scale_force:.3g} N/m)",
            fontsize="small",
        )
    figure.set_layout_engine("tight")
    return figure
