"""Figures and reports drawn from test results (the faces layer; matplotlib, Agg backend)."""

from grainlab.report.curves import plot_curves, save_figure
from grainlab.report.packing_figures import (
    contact_force_figure,
    noncoaxiality_figure,
    strain_ratio_figure,
    stress_ratio_strain_figure,
    tessellation_figure,
)

__all__ = [
    "contact_force_figure",
    "noncoaxiality_figure",
    "plot_curves",
    "save_figure",
    "strain_ratio_figure",
    "stress_ratio_strain_figure",
    "tessellation_figure",
]
