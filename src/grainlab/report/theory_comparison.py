"""The overlay of a discrete run and the micro-element models of its packing
(``theory.png``): the simulation in black, one colour per distribution law, on the same axes.

Triaxial and extension: q/p and eps_vol against the vertical strain; the cubical tests
(true_triaxial at constant p, cubical at constant sigma_3, any b): the mobilised angle and
eps_vol (eps_zz; eps_yy of a 2D
run of discs; from the end of the compaction, compression > 0). Oedometer: K0 and the
vertical stress against the vertical strain. Each side is
drawn on its own rows (:attr:`~grainlab.lab.theory_comparison.TheoryComparison.own_curves`:
the run's records, the model's steps, so that a model that stops before the run's first
record still shows); the numbers on the common grid are the table's. The run stated in the
title.
"""

from __future__ import annotations

from matplotlib.figure import Figure

from grainlab.lab.theory_comparison import SIMULATION, TheoryComparison
from grainlab.report.curves import new_figure_axes
from grainlab.report.run_curves import run_title

PANELS = {"oedometer": ("K0", "sigma_v"), "true_triaxial": ("phi_mob", "eps_vol"),
          "cubical": ("phi_mob", "eps_vol")}
"""Per test kind the y columns drawn against eps_axial; the others draw :data:`SHEAR_PANELS`."""
SHEAR_PANELS = ("q_over_p", "eps_vol")

LABELS = {
    "eps_axial": r"vertical strain from the compaction's end, $\varepsilon_{zz}$ "
                 r"(2D: $\varepsilon_{yy}$) [-]",
    "q_over_p": r"$q/p = (\sigma_1 - \sigma_3)/p$ [-]",
    "phi_mob": r"mobilised angle $\arcsin((\sigma_1 - \sigma_3)/(\sigma_1 + \sigma_3))$ "
               r"[deg]",
    "eps_vol": r"$\varepsilon_{vol}$ (compression > 0) [-]",
    "K0": r"$K_0 = \sigma_h / \sigma_v$ [-]",
    "sigma_v": r"vertical stress $\sigma_{zz}$ ($\sigma_{yy}$ in 2D) [Pa]",
}


def theory_comparison_figure(comparison: TheoryComparison) -> Figure:
    """theory.png (module docstring) of a computed :class:`TheoryComparison`: one axes per
    quantity side by side, the run and each model's distribution law on each, a legend on
    the first."""
    columns = PANELS.get(comparison.kind, SHEAR_PANELS)
    figure, axes = new_figure_axes(1, len(columns), figsize=(5.2 * len(columns), 4.0))
    curves = comparison.own_curves
    for index, side in enumerate(dict.fromkeys(curves["side"])):
        rows = curves[curves["side"] == side]
        simulation = side == SIMULATION
        label = "discrete run" if simulation else f"micro-element model, {side}"
        style = {"color": "k", "marker": ".", "ms": 3, "lw": 1.5} if simulation else \
            {"color": f"C{index - 1}", "lw": 1.2, "ls": "--"}
        for ax, column in zip(axes, columns, strict=True):
            ax.plot(rows["eps_axial"], rows[column], label=label, **style)
    for ax, column in zip(axes, columns, strict=True):
        ax.set_xlabel(LABELS["eps_axial"])
        ax.set_ylabel(LABELS[column])
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize="small")
    figure.suptitle(f"{run_title(comparison.result)}: the run and the micro-element model of "
                    "its packing", fontsize="medium")
    figure.set_layout_engine("tight")
    return figure
