"""Window averages of a run's snapshots, against the per-snapshot analyses done by hand."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.force_statistics import probability_density
from grainlab.analysis.snapshot_analysis import SnapshotAnalysis
from grainlab.analysis.snapshot_files import write_snapshots
from grainlab.analysis.synthetic import synthetic_network
from grainlab.analysis.window_average import (
    ANGULAR_NAMES,
    PDF_NAMES,
    StrainWindow,
    WindowAverage,
)
from grainlab.errors import InputError

N_BINS = 10
LINEAR = np.linspace(0.0, 6.0, N_BINS + 1)
LOG = np.geomspace(1e-2, 10.0, N_BINS + 1)


def series():
    """Five snapshots: a compaction one at eps_q 0.6 (skipped), then the shear at eps_q 0.2,
    0.5, 0.7, 0.9 (the last three in [0.5, 0.9])."""
    stages = [("compaction", 0.6), ("shear", 0.2), ("shear", 0.5), ("shear", 0.7),
              ("shear", 0.9)]
    networks = []
    for k, (stage, strain) in enumerate(stages):
        net = synthetic_network(600, a_c=0.05 + 0.1 * k / 4, a_fn=0.2, a_ft=0.05, seed=k)
        net.state.update({"step": 10 * k, "stage": stage, "eps_q": strain})
        networks.append(net)
    return networks


def by_hand(networks):
    """The analyses of the snapshots in the window, each on the same fixed bins."""
    return [SnapshotAnalysis(n_force_bins=N_BINS, force_linear_edges=LINEAR,
                             force_log_edges=LOG).compute(net)
            for net in networks if net.state["stage"] == "shear" and net.state["eps_q"] >= 0.5]


@pytest.fixture(scope="module")
def average():
    return WindowAverage((0.5, 0.9), n_force_bins=N_BINS, linear_edges=LINEAR,
                         log_edges=LOG).run(iter(series()))


def test_only_the_shear_snapshots_in_the_window_are_averaged(average):
    assert average.n_snapshots == 3
    assert list(average.snapshots["eps_q"]) == [0.5, 0.7, 0.9]
    assert list(average.snapshots["index"]) == [2, 3, 4]  # positions in the run
    assert set(average.snapshots["stage"]) == {"shear"}


def test_scalar_means_and_sample_deviations_match_a_hand_computation(average):
    analyses = by_hand(series())
    for name in ("a_c", "coordination_number", "q_over_trace", "sliding_proportion"):
        values = np.array([a.descriptors[name] for a in analyses])
        mean, std, n = average.scalar(name)
        assert mean == pytest.approx(values.mean(), rel=1e-12)
        assert std == pytest.approx(values.std(ddof=1), rel=1e-9)
        assert n == 3
    table = average.scalars
    assert list(table.columns) == ["descriptor", "mean", "std", "n", "unit"]
    assert set(analyses[0].descriptors) <= set(table["descriptor"])
    assert table.set_index("descriptor").loc["p", "unit"] == "Pa"


def test_pdf_and_angular_bins_average_bin_by_bin(average):
    analyses = by_hand(series())
    pdf = average.distributions["normal_pdf_linear"]
    np.testing.assert_allclose(pdf["ratio_lo"], LINEAR[:-1])
    k = 2  # f_n / <f_n> in [1.2, 1.8)
    densities = np.array([a.forces.normal_pdf_linear["density"].iloc[k] for a in analyses])
    assert pdf["density_mean"].iloc[k] == pytest.approx(densities.mean())
    assert pdf["density_std"].iloc[k] == pytest.approx(densities.std(ddof=1))
    contact = average.distributions["contact_frame"]
    for column in ("P", "f_n", "f_t_meridional"):
        # an empty bin has a NaN mean force: it is left out of that bin's average only
        values = np.array([a.angular.contact_frame[column].to_numpy() for a in analyses])
        np.testing.assert_allclose(contact[f"{column}_mean"], np.nanmean(values, axis=0))
        np.testing.assert_allclose(contact[f"{column}_std"],
                                   np.nanstd(values, axis=0, ddof=1))
        np.testing.assert_array_equal(contact[f"{column}_n"],
                                      np.isfinite(values).sum(axis=0))
    np.testing.assert_allclose(contact["theta_deg"],
                               analyses[0].angular.contact_frame["theta_deg"])
    assert set(average.distributions) == set(PDF_NAMES) | set(ANGULAR_NAMES)


def test_fixed_bins_keep_the_ratios_outside_in_the_normalisation():
    _, density, edges = probability_density(np.array([0.5, 1.5, 1.5, 9.0]), 2,
                                            edges=[0.0, 1.0, 2.0])
    np.testing.assert_allclose(density, [0.25, 0.5])  # 9.0 is outside: the sum is 3/4
    assert float(np.sum(density * np.diff(edges))) == pytest.approx(0.75)
    _, density, _ = probability_density(np.array([-1.0, 0.5]), 2, "log", edges=[0.1, 1, 10])
    np.testing.assert_allclose(density, [1.0 / 0.9, 0.0])  # the log bins see 0.5 only
    with pytest.raises(InputError, match="linear bin edges"):
        probability_density(np.ones(3), 2, edges=[0.0, 2.0, 1.0])


def test_the_share_of_ratios_inside_the_fixed_bins_is_a_scalar(average):
    mean, _, n = average.scalar("pdf_binned_fraction_normal_pdf_linear")
    assert 0.9 < mean <= 1.0 and n == 3


def test_an_empty_window_names_itself_and_the_range_the_run_has():
    with pytest.raises(InputError) as caught:
        WindowAverage((1.0, 2.0)).run(series())
    message = str(caught.value)
    assert "window = 'eps_q in [1, 2]'" in message
    assert "eps_q from 0.2 to 0.9" in message  # the compaction's 0.6 is no shear strain
    with pytest.raises(InputError, match="low < high"):
        StrainWindow(0.9, 0.5)


def test_a_snapshot_file_streams_and_the_results_write_to_csv(tmp_path, average):
    path = write_snapshots(tmp_path / "snapshots.h5", series())
    from_file = WindowAverage((0.5, 0.9), n_force_bins=N_BINS, linear_edges=LINEAR,
                              log_edges=LOG).run(tmp_path)  # a run folder
    pd.testing.assert_frame_equal(from_file.scalars, average.scalars)
    paths = from_file.write(tmp_path / "out")
    assert paths[0].name == "window_scalars.csv" and len(paths) == 7
    written = pd.read_csv(paths[0])
    assert list(written.columns) == ["descriptor", "mean", "std", "n", "unit"]
    data = from_file.to_dict()
    assert data["n_snapshots"] == 3 and data["window"]["low"] == 0.5
    assert data["scalars"]["a_c"]["mean"] == pytest.approx(average.scalar("a_c")[0])
    assert path.exists()


def test_results_are_refused_before_run():
    with pytest.raises(NotComputedError, match="call run"):
        _ = WindowAverage().scalars
