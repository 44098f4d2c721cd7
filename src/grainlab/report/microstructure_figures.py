"""Figures of a contact network's microstructure (seeds 002 and 003).

* polar diagrams of the angular distributions with their harmonic fits (002 Fig. 14);
* force PDFs, log-linear and log-log (003 Figs. 14, 16);
* both, averaged over a strain window with the standard deviation as error bars (the residual
  state of 002/003; :class:`~grainlab.analysis.window_average.WindowAverage`);
* the radial ("neighbour") force network, lines scaled by force and coloured by contact type or
  by friction mobilisation (002 Figs. 12, 18, 21; 003 Figs. 15, 21);
* the particles of a slab shaded by their number of contact neighbours (002 Fig. 9);
* anisotropies and q/p (direct and harmonic) against strain (002 Figs. 16–20).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.collections import LineCollection, PatchCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from matplotlib.ticker import MaxNLocator

from grainlab.analysis.angular_distributions import AngularDistributions
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.force_statistics import ForceStatistics
from grainlab.report.curves import new_figure_axes

_FRAMES = (("contact_frame", "contact frame (n, t)"), ("branch_frame", "branch frame (n', t')"))


def _polar_panel(ax, theta: np.ndarray, values: np.ndarray, fit: np.ndarray,
                 errors: np.ndarray | None = None) -> None:
    """One polar diagram: data (|values|, with error bars when given) unfolded by symmetry
    over the full circle, the compression axis vertical, and the harmonic fit as a line.

    The four mirror copies are drawn as one artist each for the data and for the fit (the fit's
    copies apart by NaN gaps), error bars without caps, the grid every 45 degrees and three
    radial ticks: a panel of separate copies with capped bars took twice as long to draw."""
    copies = [np.pi / 2 - sign * theta + shift for sign in (1, -1) for shift in (0.0, np.pi)]
    angles, data = np.concatenate(copies), np.tile(np.abs(values), len(copies))
    if errors is None:
        ax.plot(angles, data, "o", ms=2.5, color="tab:blue")
    else:
        ax.errorbar(angles, data, yerr=np.tile(np.nan_to_num(errors), len(copies)), fmt="o",
                    ms=2.5, color="tab:blue", elinewidth=0.8, capsize=0)
    gap = np.array([np.nan])
    ax.plot(np.concatenate([part for copy in copies for part in (gap, copy)][1:]),
            np.concatenate([part for _ in copies for part in (gap, np.abs(fit))][1:]),
            "-", lw=1.0, color="tab:red")
    ax.set_ylim(bottom=0.0)  # r = 0 at the centre: error bars below zero would shift it
    ax.set_xticks(np.radians(np.arange(0.0, 360.0, 45.0)))
    ax.yaxis.set_major_locator(MaxNLocator(3))
    ax.set_xticklabels([])
    ax.tick_params(labelsize="x-small")


def _polar_grid(frames: list[tuple[pd.DataFrame, str]], suffixes: tuple[str, str, str | None]
                ) -> Figure:
    """Rows of polar diagrams, one row per frame, one panel per quantity with a harmonic
    column; ``suffixes`` name the data, fit and error columns (``"", "_harmonic", None`` for
    one snapshot's table). A tangential quantity is drawn as its signed meridional component
    (``f_t_meridional``, ``l_t_meridional``), the one its harmonic curve, <f_n> a_ft sin 2
    theta, describes (seed 002 eq. 26; :mod:`grainlab.analysis.angular_distributions`): the
    mean magnitude ``f_t`` is no projection and lies above the curve at every angle."""
    data, harmonic, error = suffixes
    columns = set(frames[0][0].columns)
    bases = [c[:len(c) - len(data)] for c in frames[0][0].columns if c.endswith(data)]
    quantities = [c for c in bases if f"{c}{harmonic}{data}" in columns]
    figure = Figure(figsize=(3.0 * max(len(quantities), 1), 6.2))
    for row, (table, title) in enumerate(frames):
        columns = [c for c in quantities if f"{c}{data}" in table.columns]
        for k, column in enumerate(columns):
            ax = figure.add_subplot(2, len(quantities), row * len(quantities) + k + 1,
                                    projection="polar")
            shown = f"{column}_meridional"
            shown = shown if f"{shown}{data}" in table.columns else column
            _polar_panel(ax, np.radians(table["theta_deg"].to_numpy()),
                         table[f"{shown}{data}"].to_numpy(),
                         table[f"{column}{harmonic}{data}"].to_numpy(),
                         None if error is None else table[f"{shown}{error}"].to_numpy())
            words = f"{column} (meridional)" if shown != column else column
            ax.set_title(f"{words}\n{title}", fontsize="small")
    figure.set_layout_engine("tight")
    return figure


def polar_distributions_figure(angular: AngularDistributions) -> Figure:
    """Polar diagrams of P(theta), <l>(theta), <f>(theta) in both frames, data as symbols and
    the harmonic approximation (seed 002 eq. 26) as lines; theta from the major principal
    stress direction (vertical in the plots)."""
    return _polar_grid([(getattr(angular, attr), title) for attr, title in _FRAMES],
                       ("", "_harmonic", None))


def averaged_polar_figure(distributions: dict[str, pd.DataFrame]) -> Figure:
    """:func:`polar_distributions_figure` of a window average
    (:class:`~grainlab.analysis.window_average.WindowAverage` ``.distributions``): the mean
    over the window's snapshots of each bin, the standard deviation as error bars, and the
    mean of the snapshots' harmonic curves as lines."""
    return _polar_grid([(distributions[attr], title) for attr, title in _FRAMES],
                       ("_mean", "_harmonic", "_std"))


def _pdf_axes(figure_axes, curves) -> None:
    """Draw PDFs on the log-linear and log-log axes: ``curves`` yields (linear, log, label,
    marker), each table with force_ratio, a density and optionally its deviation."""
    axes = figure_axes
    for linear, logarithmic, label, marker in curves:
        for ax, table, draw in ((axes[0], linear, "semilogy"), (axes[1], logarithmic,
                                                                "loglog")):
            x, y, err = table
            keep = np.isfinite(y) & (y > 0)
            if err is None:
                getattr(ax, draw)(x[keep], y[keep], marker, ms=3, label=label)
            else:
                ax.errorbar(x[keep], y[keep], yerr=np.nan_to_num(err[keep]), fmt=marker, ms=3,
                            elinewidth=0.8, capsize=1.5, label=label)
                ax.set_yscale("log")
                if draw == "loglog":
                    ax.set_xscale("log")
    for ax in axes:
        ax.set_xlabel("force / mean force")
        ax.set_ylabel("probability density")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize="small")


_PDFS = (("normal", "f_n / <f_n>", "o"), ("radial", "f_n' / <f_n'>", "s"))


def force_pdf_figure(forces: ForceStatistics) -> Figure:
    """PDFs of normal and radial forces normalised by their means: log-linear and log-log."""
    figure, axes = new_figure_axes(1, 2, figsize=(9.5, 3.8))

    def table(frame: pd.DataFrame):
        return frame["force_ratio"].to_numpy(), frame["density"].to_numpy(), None

    _pdf_axes(axes, [(table(getattr(forces, f"{name}_pdf_linear")),
                      table(getattr(forces, f"{name}_pdf_log")), label, marker)
                     for name, label, marker in _PDFS])
    figure.set_layout_engine("tight")
    return figure


def averaged_force_pdf_figure(distributions: dict[str, pd.DataFrame]) -> Figure:
    """:func:`force_pdf_figure` of a window average: the mean density of each fixed bin over
    the window's snapshots, the standard deviation as error bars (bins with a zero mean are
    not drawn on the log axes)."""
    figure, axes = new_figure_axes(1, 2, figsize=(9.5, 3.8))

    def table(frame: pd.DataFrame):
        return (frame["force_ratio"].to_numpy(), frame["density_mean"].to_numpy(),
                frame["density_std"].to_numpy())

    _pdf_axes(axes, [(table(distributions[f"{name}_pdf_linear"]),
                      table(distributions[f"{name}_pdf_log"]), label, marker)
                     for name, label, marker in _PDFS])
    figure.set_layout_engine("tight")
    return figure


def pair_mobilisation(network: ContactNetwork) -> np.ndarray | None:
    """(P,) largest friction mobilisation |f_t| / (mu f_n) over each pair's points, in [0, 1];
    None when the network does not know mu."""
    mu = network.friction_coefficient
    if mu is None or mu <= 0:
        return None
    normal = network.point_normal_forces
    tangential = np.linalg.norm(network.point_tangential_forces, axis=1)
    ratio = np.divide(tangential, mu * normal, out=np.zeros_like(normal), where=normal > 0)
    best = np.zeros(network.n_pairs)
    np.maximum.at(best, network.point_pairs, np.clip(ratio, 0.0, 1.0))
    return best


def _slab(network: ContactNetwork, points: np.ndarray, plane: tuple[int, int],
          thickness: float) -> tuple[np.ndarray, int, int]:
    """(mask of ``points`` within ``thickness`` / 2 of the sample's mid-plane normal to the
    axis not in ``plane``, the two drawn axes); every point in 2D."""
    d = network.dimension
    a, b = plane[0] % d, plane[1] % d
    if d == 2:
        return np.ones(len(points), dtype=bool), a, b
    depth = ({0, 1, 2} - {a, b}).pop()
    centre = 0.5 * (network.positions[:, depth].min() + network.positions[:, depth].max())
    return np.abs(points[:, depth] - centre) <= thickness / 2, a, b


def force_network_figure(
    network: ContactNetwork,
    color_by: str = "type",
    plane: tuple[int, int] = (0, -1),
    slab: float | None = None,
    mobilisation: np.ndarray | None = None,
) -> Figure:
    """The radial force network: a line from each particle centre to its neighbour along the
    branch vector, width proportional to the radial force f_n' (seed 002 Fig. 12).

    ``color_by`` is ``"type"`` (contact types), ``"sliding"`` (red where the pair slides or, if
    ``mobilisation`` (per pair, in [0, 1]) is given, coloured by it) or ``"none"``. In 3D only
    pairs whose mid-point lies within ``slab`` (default: three mean branch lengths) of the
    sample's mid-plane are drawn, projected on ``plane`` (axis indices).
    """
    forces = network.pair_forces
    branches = network.pair_branches
    lengths = np.linalg.norm(branches, axis=1)
    radial = np.einsum("pi,pi->p", forces, branches) / np.where(lengths > 0, lengths, 1.0)
    start = network.positions[network.pair_particles[:, 0]]
    thickness = 3.0 * float(np.mean(lengths)) if slab is None else slab
    near, a, b = _slab(network, start + 0.5 * branches, plane, thickness)
    keep = (radial > 0) & near
    segments = np.stack([start[keep][:, [a, b]], (start + branches)[keep][:, [a, b]]], axis=1)
    mean_radial = max(float(np.mean(radial[radial > 0])) if np.any(radial > 0) else 0.0, 1e-300)
    widths = np.clip(1.2 * radial[keep] / mean_radial, 0.1, 6.0)
    figure, ax = new_figure_axes(figsize=(6.5, 6.5))
    if color_by == "type" and network.pair_types is not None and network.type_names:
        palette = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown"]
        colors = [palette[t % len(palette)] for t in network.pair_types[keep]]
        for code, name in enumerate(network.type_names):
            ax.plot([], [], color=palette[code % len(palette)], lw=3, label=name)
        ax.legend(fontsize="small", loc="upper right")
    elif color_by == "sliding" and mobilisation is not None:
        colors = [(m, 0.1, 1.0 - m) for m in np.clip(mobilisation[keep], 0.0, 1.0)]
        ax.plot([], [], color=(1.0, 0.1, 0.0), lw=3, label="fully mobilised, I_c = 1")
        ax.plot([], [], color=(0.0, 0.1, 1.0), lw=3, label="I_c = 0")
        ax.legend(fontsize="small", loc="upper right")
    else:
        colors = "0.2"
    ax.add_collection(LineCollection(segments, linewidths=widths, colors=colors))
    ax.autoscale()
    ax.set_aspect("equal")
    names = "xyz"
    ax.set_xlabel(f"{names[a]} [m]")
    ax.set_ylabel(f"{names[b]} [m]")
    ax.set_title("radial force network (width proportional to f_n', capped at 5 <f_n'>)",
                 fontsize="medium")
    return figure


def connectivity_map_figure(network: ContactNetwork, plane: tuple[int, int] = (0, -1),
                            slab: float | None = None) -> Figure:
    """The particles whose centre lies within ``slab`` / 2 of the sample's mid-plane (default
    slab: one mean volume-equivalent diameter), each a disc of its volume-equivalent radius,
    shaded by its number of contact neighbours z_i (pairs with a positive normal force): seed
    002 Fig. 9, "color intensity is proportional to coordination number". A rattler is white.
    Projected on ``plane`` (axis indices)."""
    d = network.dimension
    counts = np.zeros(network.n_particles)
    active = network.active_pairs()
    np.add.at(counts, network.pair_particles[active].ravel(), 1.0)
    volumes = np.asarray(network.volumes, dtype=float)
    radii = (3.0 * volumes / (4.0 * np.pi)) ** (1.0 / 3.0) if d == 3 else \
        np.sqrt(volumes / np.pi)
    thickness = 2.0 * float(np.mean(radii)) if slab is None else slab
    keep, a, b = _slab(network, network.positions, plane, thickness)
    figure, ax = new_figure_axes(figsize=(6.5, 6.5))
    discs = PatchCollection([Circle((x[a], x[b]), r) for x, r in
                             zip(network.positions[keep], radii[keep], strict=True)],
                            cmap="Greys", edgecolor="0.5", linewidth=0.3)
    discs.set_array(counts[keep])
    discs.set_clim(0.0, max(float(counts.max()), 1.0))
    ax.add_collection(discs)
    ax.autoscale()
    ax.set_aspect("equal")
    names = "xyz"
    ax.set_xlabel(f"{names[a]} [m]")
    ax.set_ylabel(f"{names[b]} [m]")
    figure.colorbar(discs, ax=ax, shrink=0.8, label="contact neighbours z_i")
    ax.set_title(f"{int(keep.sum())} particles in a slab {thickness:.3g} m thick\n"
                 f"(mean z_i {float(np.mean(counts)):.2f} over the sample)", fontsize="medium")
    return figure


def anisotropy_evolution_figure(table: pd.DataFrame, strain: str = "eps_q") -> Figure:
    """Anisotropies and q/p (direct and from the anisotropies) against a strain column.

    Snapshots of a discrete run carry their ``stage``; eps_q starts again from 0 when the
    shear begins, so against eps_q only the snapshots of the stages after the compaction are
    drawn (a compaction snapshot joined to the shear ones would draw a line back across the
    axis)."""
    title = "snapshots"
    if "stage" in table.columns and strain == "eps_q":
        sheared = table["stage"].astype(str) != "compaction"
        if sheared.any() and not sheared.all():
            table = table[sheared]
            title = "snapshots after the compaction"
    x = table[strain] if strain in table.columns else np.arange(len(table))
    figure, axes = new_figure_axes(1, 3, figsize=(14, 4.0))
    groups = (
        ("contact frame", "anisotropy [-]", ["a_c", "a_ln", "a_lt", "a_fn", "a_ft"]),
        ("branch frame", "anisotropy [-]",
         ["a_c_branch", "a_ln_branch", "a_fn_branch", "a_ft_branch"]),
        ("q/p (direct and eqs. 27a, 27b, B1)", "q / (sigma_1 + sigma_2 + sigma_3) [-]",
         ["q_over_trace", "q_over_trace_27a", "q_over_trace_27b", "q_over_trace_B1"]),
    )
    for ax, (name, ylabel, columns) in zip(axes, groups, strict=True):
        for column in columns:
            if column in table.columns:
                ax.plot(x, table[column], marker=".", label=column)
        ax.set_title(name, fontsize="medium")
        ax.set_xlabel(f"{strain} [-]" if strain in table.columns else "snapshot")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize="x-small", loc="best", framealpha=0.6)
    figure.suptitle(f"Anisotropies of the contact network ({len(table)} {title})",
                    fontsize="medium")
    figure.set_layout_engine("tight")
    return figure
