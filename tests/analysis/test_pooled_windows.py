"""Pooling the window averages of independent runs: the same as one average over all their
snapshots (an exact oracle), whatever the grouping or order of the runs."""

import numpy as np
import pandas as pd
import pytest

from grainlab.analysis.pooled_windows import pooled_distributions, pooled_table
from grainlab.analysis.synthetic import synthetic_network
from grainlab.analysis.window_average import WindowAverage
from grainlab.errors import InputError


def _networks(count, first_seed):
    nets = []
    for k in range(count):
        net = synthetic_network(300, a_c=0.05 + 0.03 * k, a_fn=0.2, a_ft=0.05,
                                seed=first_seed + k)
        net.state["eps_q"] = 0.6 + 0.05 * k
        nets.append(net)
    return nets


@pytest.fixture(scope="module")
def runs():
    groups = [_networks(3, 0), _networks(1, 10), _networks(4, 20)]
    parts = [WindowAverage((0.5, 0.9), n_angle_bins=12).run(nets).distributions
             for nets in groups]
    whole = WindowAverage((0.5, 0.9), n_angle_bins=12).run(
        [net for nets in groups for net in nets]).distributions
    return parts, whole


def test_pooled_runs_are_one_average_over_all_their_snapshots(runs):
    parts, whole = runs
    pooled = pooled_distributions(parts)
    assert set(pooled) == set(whole)
    for name, table in whole.items():
        mine = pooled[name]
        assert list(mine.columns) == list(table.columns)
        for column in table.columns:
            np.testing.assert_allclose(mine[column].to_numpy(float),
                                       table[column].to_numpy(float),
                                       rtol=1e-9, atol=1e-12, equal_nan=True,
                                       err_msg=f"{name}.{column}")
    assert int(pooled["contact_frame"]["P_n"].max()) == 8


def test_pooling_does_not_depend_on_the_runs_order(runs):
    parts, _ = runs
    one = pooled_distributions(parts)["normal_pdf_log"]
    other = pooled_distributions(parts[::-1])["normal_pdf_log"]
    pd.testing.assert_frame_equal(one, other, rtol=1e-12, atol=1e-14)


def test_a_single_run_pools_into_itself(runs):
    parts, _ = runs
    pooled = pooled_table([parts[0]["contact_frame"]])
    pd.testing.assert_frame_equal(pooled, parts[0]["contact_frame"], check_dtype=False)


def test_tables_over_other_bins_are_refused_with_their_name(runs):
    parts, _ = runs
    coarse = WindowAverage((0.5, 0.9), n_angle_bins=6).run(_networks(2, 40)).distributions
    with pytest.raises(InputError, match="contact_frame"):
        pooled_distributions([parts[0], coarse])
