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
            table[f"a_c_branch_{t}_residual"] = 0.07
            table[f"sliding_proportion_{t}_residual"] = 0.1
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
    assert "10.00%" in rows[0]


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


def typed_synthetic(seed: int, a_ft: float = 0.1, mu: float = 0.4):
    """A synthetic network (known a_c = 0.2, a_fn = 0.1) whose pairs are typed s or d at
    random, half and half."""
    from grainlab.analysis.contact_network import ContactNetwork
    from grainlab.analysis.synthetic import synthetic_network

    net = synthetic_network(4000, a_c=0.2, a_fn=0.1, a_ft=a_ft, friction_coefficient=mu,
                            seed=seed)
    types = np.random.default_rng(seed + 100).integers(0, 2, net.n_pairs)
    values = {k: getattr(net, k) for k in net.__dataclass_fields__}
    values.update(pair_types=types, type_names=("s", "d"))
    return ContactNetwork(**values)


def summary_of(networks) -> pd.DataFrame:
    """A summary table whose residual columns are the descriptors of one network per sample."""
    from grainlab.analysis import SnapshotAnalysis

    rows = []
    for k, net in enumerate(networks):
        d = SnapshotAnalysis().compute(net).descriptors
        row = {"name": f"S{k}", "measured": 0.1 * k}
        row.update({f"{name}_residual": v for name, v in d.items()
                    if isinstance(v, float | int)})
        rows.append(row)
    return pd.DataFrame(rows)


def _plotted(ax, label: str) -> np.ndarray:
    for container in ax.containers:
        if container.get_label() == label:
            return np.asarray(container.lines[0].get_ydata(), float)
    raise AssertionError(f"no {label} in {[c.get_label() for c in ax.containers]}")


def test_partial_anisotropies_by_type_sum_to_the_imposed_anisotropy():
    from grainlab.report.study_figures import partial_anisotropies_figure

    table = summary_of([typed_synthetic(1), typed_synthetic(2)])
    figure = partial_anisotropies_figure(table, "eta")
    assert figure is not None and len(figure.axes) == 3
    fabric = figure.axes[0]
    s, d = _plotted(fabric, "s"), _plotted(fabric, "d")
    np.testing.assert_allclose(s, table["a_c_branch_s_residual"])
    # normalised by the totals: the types' shares add up to the sample's a'_c, here the
    # imposed a_c = 0.2 (branch vectors along the normals), each type about half of it
    np.testing.assert_allclose(s + d, table["a_c_branch_residual"], rtol=1e-9)
    np.testing.assert_allclose(s + d, 0.2, atol=0.03)
    np.testing.assert_allclose(s, 0.1, atol=0.025)


def test_sliding_by_type_is_each_type_s_share_of_the_sliding_contacts():
    from grainlab.report.study_figures import sliding_by_type_figure

    networks = [typed_synthetic(3, a_ft=0.5, mu=0.1), typed_synthetic(4, a_ft=0.5, mu=0.1)]
    table = summary_of(networks)
    ax = sliding_by_type_figure(table, "eta").axes[0]
    for k, net in enumerate(networks):
        # by hand: Coulomb's cap reached (the synthetic forces are clipped at mu f_n)
        fn = net.point_normal_forces
        ft = np.linalg.norm(net.point_tangential_forces, axis=1)
        active = fn > 0
        sliding = active & (ft >= (1 - 1e-3) * 0.1 * fn)
        types = net.pair_types[net.point_pairs]
        for code, name in enumerate(("s", "d")):
            expected = np.count_nonzero(sliding & (types == code)) / np.count_nonzero(active)
            assert _plotted(ax, name)[k] == pytest.approx(expected)
        assert sum(_plotted(ax, t)[k] for t in ("s", "d")) == pytest.approx(
            np.count_nonzero(sliding) / np.count_nonzero(active))


def test_strength_from_anisotropies_draws_the_peak_beside_the_residual():
    from grainlab.report.study_figures import stress_dilatancy_figure

    table = summary_by_hand(with_micro=True)
    table["q_over_trace_27a_at_peak"] = [0.30, 0.35, 0.40, 0.45]
    table["q_over_trace_at_peak"] = [0.31, 0.37, 0.43, 0.47]
    ax = stress_dilatancy_figure(table, "eta").axes[0]
    peak = {c.get_label(): list(_plotted(ax, c.get_label())) for c in ax.containers
            if "peak" in c.get_label()}
    assert peak == {"measured peak": [0.31, 0.37, 0.43, 0.47],
                    "eq. 27a peak": [0.30, 0.35, 0.40, 0.45]}
    assert "eq. 27a residual" in ax.get_legend_handles_labels()[1]


def _bar_heights(ax, label: str) -> np.ndarray:
    """Half-heights of the error bars of the series ``label`` (0 where a point has none)."""
    for container in ax.containers:
        if container.get_label() == label:
            y = np.asarray(container.lines[0].get_ydata(), float)
            if not container.lines[2]:
                return np.zeros_like(y)
            segments = container.lines[2][0].get_segments()
            return np.array([abs(seg[1][1] - seg[0][1]) / 2 for seg in segments])
    raise AssertionError(f"no {label} in {[c.get_label() for c in ax.containers]}")


def test_a_pooled_point_carries_the_seeds_spread_on_its_initial_state_and_peak():
    """Seed 002's protocol with replicas: the pooled shape's peak and initial packing
    fraction get the standard deviation over its seeds as error bars, a shape of one run
    none (issue: every trend with an error bar from independent samples)."""
    from grainlab.report.study_figures import packing_fraction_figure, strength_figure
    from grainlab.study.study_summary import pooled_replicas

    table = summary_by_hand(with_micro=False)
    table["replica_of"] = ""
    table["seed"] = 0
    repeat = table.iloc[[0, 0]].copy()
    repeat["name"] = ["a-seed1", "a-seed2"]
    repeat["replica_of"] = table["name"].iloc[0]
    repeat["seed"] = [1, 2]
    first = table.index[0]
    repeat["q_over_trace_peak"] = table.loc[first, "q_over_trace_peak"] + np.array([0.02, -0.02])
    repeat["packing_fraction_initial"] = table.loc[first, "packing_fraction_initial"] + \
        np.array([0.004, -0.004])
    pooled = pooled_replicas(pd.concat([table, repeat], ignore_index=True))
    left = strength_figure(pooled, "eta").axes[0]
    bars = _bar_heights(left, "peak $(q/p)^+$")
    assert bars[0] == pytest.approx(0.02) and not bars[1:].any()
    ax = packing_fraction_figure(pooled, "eta").axes[0]
    label = next(c.get_label() for c in ax.containers if "initial" in c.get_label())
    bars = _bar_heights(ax, label)
    assert bars[0] == pytest.approx(0.004) and not bars[1:].any()


def test_window_averaged_polar_diagrams_and_force_pdfs_of_the_report(tmp_path):
    from types import SimpleNamespace

    from grainlab.analysis.snapshot_files import write_snapshots
    from grainlab.analysis.synthetic import synthetic_network
    from grainlab.analysis.window_average import WindowAverage
    from grainlab.report.microstructure_figures import (
        averaged_force_pdf_figure,
        averaged_polar_figure,
    )
    from grainlab.report.study_report import _window_distributions

    networks = [synthetic_network(6000, a_c=0.2, seed=k) for k in range(3)]
    for k, net in enumerate(networks):
        net.state.update(eps_q=0.6 + 0.1 * k, stage="shear")
    folder = tmp_path / "samples" / "A"
    folder.mkdir(parents=True)
    write_snapshots(folder / "snapshots.h5", networks)
    study = SimpleNamespace(sample_folder=lambda name: tmp_path / "samples" / name,
                            states=lambda: {"A": "ended"},
                            spec=SimpleNamespace(study=SimpleNamespace(
                                window=(0.5, 0.9), core_margin=1.0, parameter="eta"),
                                samples=[SimpleNamespace(name="A", replica_of="")]))
    figures = _window_distributions(study, pd.DataFrame({"name": ["A"]}), tmp_path)
    assert [f for _, f in figures] == ["polar_A.png", "force_pdfs_A.png"]
    assert all((tmp_path / f).stat().st_size > 0 for _, f in figures)
    assert "3 snapshots" in figures[0][0] and "whole box" in figures[0][0]  # no box here
    assert figures[0][0].endswith("(seed 003 insets of Figs. 12, 13, 17, 22)")
    assert figures[1][0].endswith("(seed 003 Figs. 14, 16)")

    distributions = WindowAverage((0.5, 0.9)).run(networks).distributions
    # P(theta) with its harmonic fit: the fit drawn (red) has 1 + a_c (3 cos^2 - 1) of the
    # imposed a_c = 0.2 between the first and the last bin
    ax = averaged_polar_figure(distributions).axes[0]
    fit = next(line for line in ax.get_lines() if line.get_color() == "tab:red")
    theta = np.radians(distributions["contact_frame"]["theta_deg"].to_numpy())
    y = np.asarray(fit.get_ydata(), float)
    shape = 3 * np.cos(theta) ** 2 - 1
    a_c = (y[0] - y[-1]) / (y[-1] * shape[0] - y[0] * shape[-1])
    assert a_c == pytest.approx(0.2, abs=0.03)
    # the tangential forces drawn are the meridional components their harmonic curve
    # models (seed 002 eq. 26), not the mean magnitudes
    sheared = [synthetic_network(3000, a_c=0.2, a_fn=0.3, a_ft=0.15, seed=10 + k)
               for k in range(2)]
    for net in sheared:
        net.state.update(eps_q=0.7, stage="shear")
    tangential = WindowAverage((0.5, 0.9)).run(sheared).distributions
    axes = averaged_polar_figure(tangential).axes
    table = tangential["contact_frame"]
    f_t = next(a for a in axes if a.get_title().startswith("f_t (meridional)\ncontact"))
    drawn = np.asarray(f_t.containers[0].lines[0].get_ydata(), float)[:len(table)]
    np.testing.assert_array_equal(drawn, np.abs(table["f_t_meridional_mean"].to_numpy()))
    assert not np.allclose(drawn, table["f_t_mean"].to_numpy())
    # normal forces exponential about their mean: the density of f / <f> is exp(-x)
    pdf = averaged_force_pdf_figure(distributions).axes[0]
    drawn = pdf.containers[0].lines[0]
    x, density = np.asarray(drawn.get_xdata()), np.asarray(drawn.get_ydata())
    near = (x > 0.2) & (x < 2.0)
    lo, hi = x[near] - 0.1, x[near] + 0.1  # bins of width 0.2 about the centres
    expected = (np.exp(-lo) - np.exp(-hi)) / 0.2
    np.testing.assert_allclose(density[near], expected, rtol=0.12)


def test_without_a_core_the_figures_and_report_do_not_speak_of_a_box(tmp_path):
    """A periodic cell has no walls: its packing fraction and connectivity are drawn without
    the words "whole box", and the report calls its study periodic (a box study: not)."""
    from grainlab.report.study_figures import connectivity_figure, packing_fraction_figure
    from grainlab.report.study_report import periodic_study
    from grainlab.study.series_presets import series_spec
    from grainlab.study.study_runner import Study

    table = summary_by_hand(with_micro=True)
    for make in (packing_fraction_figure, connectivity_figure):
        labels = make(table, "eta").axes[0].get_legend_handles_labels()[1]
        assert labels and not any("box" in label or "core" in label for label in labels)
    assert "residual" in packing_fraction_figure(table, "eta").axes[0] \
        .get_legend_handles_labels()[1]
    table["coordination_number_core_residual"] = 6.0
    labels = connectivity_figure(table, "eta").axes[0].get_legend_handles_labels()[1]
    assert "z, whole box residual" in labels and "z, core residual" in labels

    names = pd.DataFrame({"name": ["eta-0.0", "eta-0.7"]})
    cell = Study.create(tmp_path / "cell", series_spec("nonconvexity", n_particles=40,
                                                        boundary="periodic"))
    box = Study.create(tmp_path / "box", series_spec("nonconvexity", n_particles=40))
    assert periodic_study(cell, names) and not periodic_study(box, names)


def test_every_report_figure_names_its_counterpart_in_each_seed_or_has_none_on_purpose():
    """Each figure against the shape parameter names the seeds' figure it draws; the ones a
    paper does not draw are listed as such (seed 002 has no sliding by contact type, seed 003
    no partial anisotropies by type), so a figure added without its reference is caught."""
    from grainlab.report.study_figures import PAPER_FIGURES, seed_figure_words
    absent = {("partial_anisotropies", "eta"), ("sliding_by_type", "mean_angularity"),
              ("force_pdfs", "mean_angularity"), ("connectivity_map", "eta")}
    stems = [stem for stem, _, _ in STUDY_FIGURES] + [
        "curves", "polar", "force_pdfs", "force_network", "mobilised_network",
        "connectivity_map"]
    for stem in stems:
        for parameter, seed in (("mean_angularity", "seed 002"), ("eta", "seed 003")):
            words = seed_figure_words(stem, parameter)
            if (stem, parameter) in absent:
                assert words == "", (stem, parameter)
            else:
                assert words.startswith(f" ({seed} ") and "Fig" in words, (stem, parameter)
    assert set(PAPER_FIGURES) == set(stems)
    assert seed_figure_words("strength", "aspect_ratio") == ""  # a study of another parameter
