"""2D samples of discs through the lab (grainlab.engine.planar): the lab's 2D load paths
(vertical axis y), the results in the plane's columns and invariants, K0 of a 1D compression,
and the test kinds a 2D sample does not run refused by name. The whole matrix of solvers and
boundaries with discs (a biaxial test, a resume bit for bit, a ParaView frame) is in
tests/lab/test_run_matrix.py."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig
from grainlab.report.element_test_figures import oedometer_stages_figure
from grainlab.report.run_summary import run_summary

SIGMA0 = 1e4


def disc_config(kind: str, boundary: str = "walls", **test) -> RunConfig:
    return RunConfig.model_validate({
        "sample": {"shape": "disc", "n_particles": 40, "seed": 2, "size_ratio": 1.5,
                   "boundary": boundary, "packing_fraction": 0.35},
        "test": {"kind": kind, "sigma0": SIGMA0,
                 "quasi_static": {"stress_tolerance": 0.05, "unbalanced_force": 0.05,
                                  "kinetic_energy": float("inf")}, **test},
        "solver": {"method": "dem", "max_stage_steps": 1500,
                   "at_max_stage_steps": "next_stage", "dem": {"kappa": 1e3},
                   "compaction": {"inertia_number": 0.1},
                   "shear": {"friction": 0.4, "inertia_number": 0.02}},
        "output": {"record_every": 5, "snapshot_every": 0, "checkpoint_every": 0,
                   "vtk_every": 0},
    })


def test_a_disc_sample_runs_a_2d_path_with_the_planes_columns():
    config = disc_config("triaxial", eps_q_max=0.02)
    path = config.load_path()
    assert path.dimension == 2
    assert [s.control for s in path.stages] == [("stress",) * 3,
                                                ("stress", "strain", "strain")]


def test_a_1d_compression_of_discs_reports_k0_as_the_lateral_over_the_vertical_stress(
        tmp_path):
    run = start_run(tmp_path / "run", disc_config("oedometer", axial_strain=0.005))
    result = run.run()
    table = result.table
    assert "sigma_zz" not in table.columns and "eps_zz" not in table.columns
    assert {"sigma_xx", "sigma_yy", "sigma_xy", "eps_xx", "eps_yy"} <= set(table.columns)
    loading = table[table["stage"] == "loading"]
    assert len(loading) >= 3
    np.testing.assert_allclose(loading["K0"], loading["sigma_xx"] / loading["sigma_yy"],
                               rtol=1e-12)
    # the lateral strain held, the vertical one imposed (strains from the compacted box)
    np.testing.assert_allclose(loading["eps_xx"], 0.0, atol=1e-12)
    assert loading["eps_yy"].iloc[-1] == pytest.approx(0.005, rel=1e-3)
    assert loading["sigma_yy"].iloc[-1] > 1.5 * SIGMA0  # compressed from the isotropic state
    # 2D invariants: p the mean of the two principal stresses
    np.testing.assert_allclose(table["p"], 0.5 * (table["sigma_1"] + table["sigma_3"]),
                               rtol=1e-12)
    np.testing.assert_allclose(table["p"], 0.5 * (table["sigma_xx"] + table["sigma_yy"]),
                               rtol=1e-9)
    state = run.test.sample.state
    assert np.all(state.positions[:, 2] == state.positions[0, 2])  # in its plane
    # the summary and the figure read the vertical axis y; soft grains: no rigid-grain note
    lines = run_summary(result)
    assert any(line.startswith("loading: to eps_yy 0.005") for line in lines), lines
    assert not any(line.startswith("note: rigid grains") for line in lines)
    figure = oedometer_stages_figure(result)
    assert figure.axes[1].get_ylabel() == "sigma_yy [kPa]"


@pytest.mark.parametrize("kind", ["true_triaxial", "cubical", "circular", "cyclic_shear"])
def test_test_kinds_of_three_axes_are_refused_with_discs(kind):
    with pytest.raises(InputError) as error:
        disc_config(kind, boundary="periodic").load_path()
    assert error.value.field == "test.kind" and "discs" in error.value.allowed
