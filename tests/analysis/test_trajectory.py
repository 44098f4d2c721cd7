"""Trajectory analysis: a table over snapshots and residual-state averages."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.analysis.compute import NotComputedError
from grainlab.analysis.synthetic import synthetic_network
from grainlab.analysis.trajectory import TrajectoryAnalysis
from grainlab.errors import InputError


@pytest.fixture(scope="module")
def trajectory():
    networks = []
    for k, strain in enumerate(np.linspace(0.0, 1.0, 6)):
        net = synthetic_network(20000, a_c=0.25 * min(strain / 0.4, 1.0), seed=k)
        net.state.update({"step": k, "eps_q": float(strain)})
        networks.append(net)
    return TrajectoryAnalysis().run(networks)


def test_table_has_a_row_per_snapshot_with_state(trajectory):
    table = trajectory.table
    assert len(table) == 6
    np.testing.assert_allclose(table["eps_q"], np.linspace(0, 1, 6))
    assert table["step"].tolist() == list(range(6))
    # The imposed contact anisotropy is recovered along the run.
    np.testing.assert_allclose(table["a_c"].iloc[3:], 0.25, atol=0.03)
    assert abs(table["a_c"].iloc[0]) < 0.03


def test_residual_state_averages_the_window(trajectory):
    residual = trajectory.residual_state("eps_q", (0.5, 0.9)).set_index("descriptor")
    inside = trajectory.table[(trajectory.table.eps_q >= 0.5) & (trajectory.table.eps_q <= 0.9)]
    assert residual.loc["a_c", "n_snapshots"] == len(inside) == 2
    assert residual.loc["a_c", "mean"] == pytest.approx(inside["a_c"].mean())
    assert residual.loc["a_c", "std"] == pytest.approx(inside["a_c"].std(ddof=1))


def test_bad_window_and_strain_are_named(trajectory):
    with pytest.raises(InputError, match="window"):
        trajectory.residual_state("eps_q", (2.0, 3.0))
    with pytest.raises(InputError, match="strain"):
        trajectory.residual_state("eps_zz", (0.5, 0.9))


def test_table_before_run_raises():
    with pytest.raises(NotComputedError):
        _ = TrajectoryAnalysis().table


def test_to_test_result_round_trips(trajectory, tmp_path):
    from grainlab.result.test_result import read_test_result

    result = trajectory.to_test_result(source="synthetic", strain="eps_q")
    result.save(tmp_path)
    assert read_test_result(tmp_path / "result.h5").equals(result)
    assert result.units["p"] == "Pa"
