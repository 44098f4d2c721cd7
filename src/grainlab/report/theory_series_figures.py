"""The figures of a theory-vs-simulation series (:mod:`grainlab.lab.theory_series`), in the
manner of seed 001's Figs. 3.3–3.6: the discrete run solid, each distribution law of the
model in its own line style, every seed drawn (the first seed bold, the others thin).

* :func:`k0_figure` (Fig. 3.3): K0 = sigma_h / sigma_v against the vertical strain in
  one-dimensional compression, one colour per phi_mu, one panel per side (the run, then
  each law), the report's end values marked on the right edge.
* :func:`packing_figure` (Fig. 3.1): a packing at the end of its compaction, the state
  both sides start from: the discs, and a line along each contact's branch vector whose
  width is proportional to the pair's normal force.
* :func:`biaxial_figure` (Figs. 3.4, 3.5; Fig. 3.6 with several sigma0): the report's
  q/p = (sigma_v - sigma_h) / (sigma_v + sigma_h) and the volumetric strain against the
  vertical strain, one colour per side, one figure per k_s/k_n (line width per sigma0 when
  there are several).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.collections import LineCollection, PatchCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from grainlab.lab.theory_comparison import SIMULATION
from grainlab.lab.theory_series import REPORT_K0
from grainlab.report.curves import new_figure_axes

STYLES = ("--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)))
"""Line styles of the models, in the order of their laws."""

VERTICAL = r"vertical strain from the compaction's end, $\varepsilon_{yy}$ [-]"


def _sides(curves: pd.DataFrame) -> list[str]:
    sides = list(dict.fromkeys(curves["side"]))
    return [SIMULATION, *[s for s in sides if s != SIMULATION]] if SIMULATION in sides \
        else sides


def _label(side: str) -> str:
    return "discrete run (DEM)" if side == SIMULATION else f"model, {side}"


def k0_figure(curves: pd.DataFrame) -> Figure:
    """Fig. 3.3 of the series' oedometer curves (module docstring)."""
    oedometer = curves[curves["test"] == "oedometer"]
    sides = _sides(oedometer)
    figure, axes = new_figure_axes(1, len(sides), figsize=(4.2 * len(sides), 3.8))
    angles = sorted(set(oedometer["phi_mu"]))
    first_seed = min(oedometer["seed"])
    for ax, side in zip(axes, sides, strict=True):
        for colour, angle in enumerate(angles):
            rows = oedometer[(oedometer["side"] == side) & (oedometer["phi_mu"] == angle)]
            for seed in dict.fromkeys(rows["seed"]):
                part = rows[rows["seed"] == seed]
                first = seed == first_seed
                ax.plot(part["eps_axial"], part["K0"], color=f"C{colour}",
                        ls="-" if side == SIMULATION else STYLES[0],
                        lw=1.5 if first else 0.6, alpha=1.0 if first else 0.5,
                        label=f"phi_mu {angle:g} deg" if first else None)
            report = REPORT_K0[SIMULATION if side == SIMULATION else "model"].get(angle)
            if report is not None:
                ax.plot([1.0], [report], transform=ax.get_yaxis_transform(), marker="<",
                        color=f"C{colour}", ms=8, clip_on=False)
        ax.set_title(_label(side), fontsize="medium")
        ax.set_xlabel(VERTICAL)
        ax.set_ylim(0.0, 1.1)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(r"$K_0 = \sigma_{xx} / \sigma_{yy}$ [-]  (triangles: the report)")
    axes[0].legend(fontsize="small")
    figure.suptitle(f"one-dimensional compression, {len(set(oedometer['seed']))} packing(s) "
                    "(the first bold)", fontsize="medium")
    figure.set_layout_engine("tight")
    return figure


def biaxial_figure(curves: pd.DataFrame, stiffness_ratio: float) -> Figure:
    """Fig. 3.4/3.5 (3.6 with several sigma0) of the series' biaxial curves at one k_s/k_n
    (module docstring)."""
    biaxial = curves[(curves["test"] == "biaxial") &
                     (curves["stiffness_ratio"] == stiffness_ratio)]
    figure, axes = new_figure_axes(1, 2, figsize=(13.5, 4.2))
    pressures = sorted(set(biaxial["sigma0"]))
    first_seed = min(biaxial["seed"])
    for index, side in enumerate(_sides(biaxial)):
        colour = "k" if side == SIMULATION else f"C{index - 1}"
        style = "-" if side == SIMULATION else STYLES[(index - 1) % len(STYLES)]
        for level, sigma0 in enumerate(pressures):
            rows = biaxial[(biaxial["side"] == side) & (biaxial["sigma0"] == sigma0)]
            for seed in dict.fromkeys(rows["seed"]):
                part = rows[rows["seed"] == seed]
                first = seed == first_seed
                width = (1.5 if first else 0.6) * (1.0 + 0.6 * level)
                label = None
                if first:
                    label = _label(side) + (f", sigma0 {sigma0 / 1e3:g} kPa"
                                            if len(pressures) > 1 else "")
                axes[0].plot(part["eps_axial"], 0.5 * part["q_over_p"], color=colour,
                             ls=style, lw=width, alpha=1.0 if first else 0.5, label=label)
                axes[1].plot(part["eps_axial"], part["eps_vol"], color=colour, ls=style,
                             lw=width, alpha=1.0 if first else 0.5)
    axes[0].set_ylabel(r"$q/p = (\sigma_v - \sigma_h) / (\sigma_v + \sigma_h)$ [-]")
    axes[1].set_ylabel(r"$\varepsilon_{vol}$ (compression > 0) [-]")
    for ax in axes:
        ax.set_xlabel(VERTICAL)
        ax.grid(alpha=0.3)
    # the legend beside the axes: with several sigma0 it would hide the curves
    axes[1].legend(*axes[0].get_legend_handles_labels(), fontsize="x-small",
                   loc="upper left", bbox_to_anchor=(1.02, 1.0))
    angles = ", ".join(f"{a:g}" for a in sorted(set(biaxial["phi_mu"])))
    figure.suptitle(f"biaxial compression, k_s/k_n = {stiffness_ratio:g}, phi_mu = {angles} "
                    f"deg, {len(set(biaxial['seed']))} packing(s) (the first bold)",
                    fontsize="medium")
    figure.set_layout_engine("tight")
    return figure


def packing_figure(network, title: str = "") -> Figure:
    """Fig. 3.1 of a 2D contact network (module docstring): discs of radius sqrt(area / pi)
    at their centres, force lines of width proportional to the normal force (capped at four
    times the mean)."""
    positions = np.asarray(network.positions)[:, :2]
    radii = np.sqrt(np.asarray(network.volumes) / np.pi)
    branches = np.asarray(network.pair_branches)[:, :2]
    forces = np.asarray(network.pair_forces)[:, :2]
    lengths = np.linalg.norm(branches, axis=1)
    normal = np.abs(np.einsum("pi,pi->p", forces, branches)) / np.where(lengths > 0, lengths,
                                                                         1.0)
    start = positions[np.asarray(network.pair_particles)[:, 0]]
    mean = max(float(normal.mean()) if len(normal) else 0.0, 1e-300)
    figure, ax = new_figure_axes(figsize=(5.5, 5.5))
    ax.add_collection(PatchCollection([Circle(c, r) for c, r in zip(positions, radii,
                                                                    strict=True)],
                                      facecolor="0.85", edgecolor="0.4", lw=0.6))
    ax.add_collection(LineCollection(np.stack([start, start + branches], axis=1),
                                     linewidths=np.clip(2.0 * normal / mean, 0.2, 8.0),
                                     colors="tab:red"))
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title or f"{len(positions)} discs, {len(normal)} contacts (line width: "
                 "normal force)", fontsize="medium")
    return figure


def b_sweep_figure(table: pd.DataFrame, title: str = "") -> Figure:
    """The peak mobilised angle against b of a theory-vs-simulation b-sweep
    (:func:`~grainlab.lab.theory_b_sweep.run_b_sweep`'s table): the run black, a colour per
    distribution law, solid at constant sigma_3 and dashed at constant p; filled markers
    where the side reached its peak (the run as asked, a model that failed at its strength),
    hollow where a model stopped or was still hardening; the report's cubical strengths as
    grey stars."""
    from grainlab.lab.theory_b_sweep import PATHS, REPORT_ANGLES

    figure, ax = new_figure_axes(1, 1, figsize=(10.0, 4.8))
    sides = [side for side in _sides(table)
             if table.loc[table["side"] == side, "peak_phi"].notna().any()]
    for index, side in enumerate(sides):
        colour = "k" if side == SIMULATION else f"C{index - 1}"
        for path in dict.fromkeys(table["path"]):
            rows = table[(table["side"] == side) & (table["path"] == path)].sort_values("b")
            label = "discrete run" if side == SIMULATION else side
            ax.plot(rows["b"], rows["peak_phi"], color=colour,
                    ls="-" if path == "cubical" else "--", lw=1.3,
                    label=f"{label}, {PATHS[path]}")
            peak = rows["ended"].isin(["failed", "as asked"]).to_numpy()
            ax.plot(rows["b"][peak], rows["peak_phi"][peak], "o", color=colour, ms=5)
            ax.plot(rows["b"][~peak], rows["peak_phi"][~peak], "o", color=colour, ms=5,
                    mfc="none")
    ax.plot(list(REPORT_ANGLES), list(REPORT_ANGLES.values()), "*", color="0.5", ms=11,
            label="the report (model, constant sigma_3)")
    ax.set_xlabel("b = (sigma_2 - sigma_3) / (sigma_1 - sigma_3) [-]")
    ax.set_ylabel(r"peak mobilised angle $\arcsin((\sigma_1-\sigma_3)/(\sigma_1+\sigma_3))$"
                  " [deg]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    if title:
        ax.set_title(title, fontsize="medium")
    figure.set_layout_engine("tight")
    return figure
