"""Study figures: seed 002 eq. 12's fit, eq. 11's friction angle, the figures and the report
table from a summary table made by hand."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from grainlab.report.study_figures import (
    STUDY_FIGURES,
    contact_type_columns,
    exponential_saturation,
)
from grainlab.report.study_report import summary_markdown
from grainlab.study.study_summary import friction_angle


def test_exponential_fit_recovers_equation_12():
    # seed 002: phi* = phi0 + (phi1 - phi0)(1 - exp(-alpha / alpha_c)), alpha_c ~ 0.4
    alpha = np.array([0.0, 0.135, 0.248, 0.339, 0.496, 0.631, 0.772, 1.181])
    phi = 0.3 + (0.5 - 0.3) * (1.0 - np.exp(-alpha / 0.4))
    y0, y1, xc = exponential_saturation(alpha, phi)
    assert (y0, y1, xc) == pytest.approx((0.3, 0.5, 0.4), rel=1e-6)


def test_exponential_fit_needs_four_points():
    assert exponential_saturation(np.array([0.0, 0.1, 0.2]), np.array([1.0, 2.0, 3.0])) is None


@pytest.mark.parametrize(("s1", "s3"), [(3.0, 1.0), (2.0, 1.0), (1.0, 1.0), (5.0, 2.0)])
def test_friction_angle_is_mohr_coulomb_for_triaxial_stresses(s1, s3):
    # q/p of the seeds: q = (s1 - s3)/3, p = (s1 + 2 s3)/3; Mohr-Coulomb: sin phi =
    # (s1 - s3)/(s1 + s3)
    q_over_p = (s1 - s3) / (s1 + 2.0 * s3)
    assert friction_angle(q_over_p) == pytest.approx(math.asin((s1 - s3) / (s1 + s3)),
                                                     abs=1e-14)


def summary_by_hand(with_micro: bool) -> pd.DataFrame:
    x = np.array([0.0, 0.2, 0.4, 0.6])
    table = pd.DataFrame({
        "name": ["A", "B", "C", "D"], "value": x, "measured": x, "status": "as asked",
        "as_asked": True, "wall_time": [1.0, 2.0, 3.0, 4.0], "capped_share": 0.1,
        "n_particles": 60,
        "q_over_trace_peak": [0.3, 0.4, 0.45, 0.5],
        "q_over_trace_residual": [0.2, 0.3, 0.35, 0.37],
        "q_over_trace_residual_std": [0.01, 0.02, 0.02, 0.03],
        "packing_fraction_initial": [0.64, 0.66, 0.67, 0.65],
        "packing_fraction_residual": [0.60, 0.59, 0.58, 0.57],
        "packing_fraction_residual_std": 0.005,
        "z_initial": 6.0, "z_residual": 4.0, "z_residual_std": 0.1,
        "z_c_initial": [6.0, 12.0, 12.0, 12.0], "z_c_residual": 4.5, "z_c_residual_std": 0.2,
    })
    table["phi_residual"] = [friction_angle(q) for q in table["q_over_trace_residual"]]
    table["sin_phi_star"] = np.sin(table["phi_residual"])
    if with_micro:
        for t in ("s", "ds", "d"):
            table[f"k_{t}_initial"] = 1 / 3
            table[f"k_{t}_residual"] = 1 / 3
            table[f"k_{t}_residual_std"] = 0.01
            table[f"q_over_trace_{t}_residual"] = 0.1
        for stem in ("a_c", "a_c_branch", "a_fn", "a_ft", "sliding_proportion",
                     "q_over_trace_27a"):
            table[f"{stem}_residual"] = 0.2
            table[f"{stem}_residual_std"] = 0.01
    return table


def test_every_figure_is_drawn_from_a_full_summary():
    table = summary_by_hand(with_micro=True)
    assert contact_type_columns(table) == ["s", "ds", "d"]
    for stem, make, _ in STUDY_FIGURES:
        figure = make(table, "eta")
        assert figure is not None, stem
        assert any(ax.has_data() for ax in figure.axes), stem


def test_microstructure_figures_are_left_out_without_snapshots():
    table = summary_by_hand(with_micro=False)
    drawn = {stem for stem, make, _ in STUDY_FIGURES if make(table, "eta") is not None}
    assert drawn == {"strength", "packing_fraction", "connectivity"}


def test_report_table_gives_mean_and_standard_deviation():
    text = summary_markdown(summary_by_hand(with_micro=False))
    rows = [line for line in text.splitlines() if line.startswith("| B |")]
    assert len(rows) == 1
    assert "0.300 ± 0.020" in rows[0]  # (q/p)* of B
    assert "0.590 ± 0.005" in rows[0]  # nu* of B
    assert f"| {3 * 0.3 / 2.3:.3f} |" in rows[0]  # sin phi* = 3 (q/p)* / (2 + (q/p)*), eq. 11
    assert "10%" in rows[0]


def test_wall_profile_figure_draws_the_profile_and_the_margin():
    from grainlab.analysis.synthetic import cubic_lattice
    from grainlab.analysis.wall_layer import mean_diameter, packing_profile
    from grainlab.report.study_figures import wall_profile_figure

    net = cubic_lattice(6, 1.0)
    d = mean_diameter(net)
    assert d == pytest.approx(2.0)
    edges, fraction = packing_profile(net, 0.25 * d)
    figure = wall_profile_figure({"lattice": (edges / d, fraction)}, 1.0)
    ax = figure.axes[0]
    line = ax.get_lines()[0]
    # shells of a quarter diameter: the centres at 1, 3, 5 from the walls sit at 0.5, 1.5, 2.5 d
    drawn = np.asarray(line.get_ydata(), float)
    assert np.count_nonzero(np.nan_to_num(drawn) > 0) >= 3
    assert [x for x, y in zip(line.get_xdata(), drawn, strict=True) if y > 0][:3] == \
        pytest.approx([0.5, 1.5, 2.5])
    margin = ax.get_lines()[1]
    assert list(margin.get_xdata()) == [1.0, 1.0]
    assert wall_profile_figure({}, 1.0) is None


def test_microstructure_figures_draw_the_core_where_the_summary_has_it():
    from grainlab.report.study_figures import anisotropies_figure, connectivity_figure

    table = summary_by_hand(with_micro=True)
    table["a_c_core_residual"] = [0.1, 0.2, 0.3, 0.4]
    table["a_c_core_residual_std"] = 0.01
    table["coordination_number_core_residual"] = 6.0
    figure = anisotropies_figure(table, "eta")
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert "$a_c$ (core)" in labels and "$a'_c$" in labels  # no core a'_c: the whole box
    lines = [c for c in figure.axes[0].containers if c.get_label() == "$a_c$ (core)"]
    assert list(lines[0].lines[0].get_ydata()) == [0.1, 0.2, 0.3, 0.4]
    labels = connectivity_figure(table, "eta").axes[0].get_legend_handles_labels()[1]
    assert "z, whole box residual" in labels and "z, core residual" in labels


def test_volume_change_panel_states_its_sign_against_seed_002():
    from grainlab.report.study_figures import EPS_VOL_SIGN, curves_figure

    eps = np.linspace(0.0, 0.3, 7)
    curve = pd.DataFrame({"eps_q": eps, "q_over_trace": 0.3, "eps_vol": -0.1 * eps,
                          "packing_fraction": 0.6})
    figure = curves_figure({"A": curve}, {"A": "A"})
    panel = figure.axes[1]
    assert panel.get_title() == EPS_VOL_SIGN and "opposite sign" in EPS_VOL_SIGN
    np.testing.assert_allclose(panel.get_lines()[0].get_ydata(), -0.1 * eps)  # as recorded
