"""Lab tests on a discrete sample in a periodic cell: runs from a config, the servo holds its
stresses, the strains follow the path, checkpoints resume exactly, and what rigid grains
cannot do is refused."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.lab.cell_stages import cell_stages, velocity_gradient
from grainlab.lab.discrete_run import resume_run, start_run
from grainlab.lab.presets import oedometer, simple_shear, true_triaxial
from grainlab.lab.run_config import RunConfig

SIGMA0 = 1e4
PERIODIC = {
    "sample": {"n_particles": 80, "size_ratio": 1.2, "seed": 2, "boundary": "periodic"},
    "test": {"kind": "triaxial", "sigma0": SIGMA0, "eps_q_max": 0.03},
    "solver": {"compaction": {"inertia_number": 0.05}, "shear": {"inertia_number": 0.01}},
    "output": {"record_every": 10, "checkpoint_every": 0, "snapshot_every": 0},
}


def config(**updates) -> RunConfig:
    return RunConfig.model_validate(PERIODIC).with_updates(updates)


@pytest.fixture(scope="module")
def triaxial(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cell") / "triaxial"
    return folder, start_run(folder, config()).run()


def test_velocity_gradient_of_a_strain_rate():
    # compression positive, engineering shear: L is upper triangular, sym(L) = -strain rate
    rate = np.array([1.0, 2.0, 3.0, 0.4, 0.5, 0.6])
    grad = velocity_gradient(rate)
    np.testing.assert_allclose(np.tril(grad, -1), 0.0)
    sym = 0.5 * (grad + grad.T)
    np.testing.assert_allclose(sym, -np.array([[1.0, 0.3, 0.25], [0.3, 2.0, 0.2],
                                               [0.25, 0.2, 3.0]]))


def test_stress_directions_are_conjugate_to_the_generalised_stress():
    # true triaxial mixes components (Q): c_d = -G_d : sigma must equal (B sigma)_d
    stage = cell_stages(true_triaxial(p=1e4, b=0.3, n_steps=4, strain=0.1))[-1]
    _, directions = stage.gradients(0.5, 1.0)
    rng = np.random.default_rng(0)
    a = rng.normal(size=(3, 3))
    sigma = a + a.T
    c = stage.conjugate(sigma, 0.5)[stage.stress_controlled]
    np.testing.assert_allclose(-np.einsum("dab,ab->d", directions, sigma), c, atol=1e-12)


def test_rigid_grains_cannot_follow_an_imposed_strain_on_every_component():
    with pytest.raises(InputError, match="deformable contacts"):
        cell_stages(oedometer(strain_final=0.01, n_steps=4))
    with pytest.raises(InputError, match="deformable contacts"):
        cell_stages(simple_shear(gamma_final=0.1, n_steps=4, vertical_stress=1e4,
                                 constant="height"))
    with pytest.raises(InputError, match=r"sample\.boundary"):
        RunConfig.model_validate({"test": {"kind": "simple_shear"}}).load_path()


def test_periodic_triaxial_compacts_then_shears_at_held_lateral_stress(triaxial):
    _, result = triaxial
    table = result.table
    assert result.metadata["outcome"]["finished"]
    assert list(dict.fromkeys(table["stage"])) == ["compaction", "shear"]
    compaction = table[table["stage"] == "compaction"].iloc[-1]
    # quasi-static end: the image contacts carry sigma0 on every axis (1 %), the contact
    # stress agrees, no shear stress, a dense packing
    for axis in ("xx", "yy", "zz"):
        assert compaction[f"cell_sigma_{axis}"] == pytest.approx(SIGMA0, rel=0.011)
    assert compaction["p"] == pytest.approx(SIGMA0, rel=0.02)
    assert compaction["packing_fraction"] > 0.6
    shear = table[table["stage"] == "shear"]
    assert shear["eps_q"].iloc[-1] >= 0.03
    assert shear["q_over_trace"].max() > 0.2  # frictional spheres resist
    assert shear["inertia_number"].max() <= 0.011
    # the stress servo: the lateral stresses the image contacts carry hold sigma0 within
    # its stated tolerance at every record (periodic_boundary: proportional + integral)
    for axis in ("xx", "yy"):
        np.testing.assert_allclose(shear[f"cell_sigma_{axis}"], SIGMA0, rtol=0.05)
        assert shear[f"cell_sigma_{axis}"].mean() == pytest.approx(SIGMA0, rel=0.02)
        np.testing.assert_allclose(shear[f"sigma_{axis}"], SIGMA0, rtol=0.15)
    # the step: the shortest while the cell closes in on its stress (a grown step lets a
    # small cell overshoot), free to grow once it carries it and in the strain-driven
    # shear, while the largest overlap stays below half the bound (0.5 % of <d>)
    compacting = table[table["stage"] == "compaction"]
    closing = compacting[compacting["p"] < 0.9 * SIGMA0]
    assert len(closing) and (closing["dt"] == compacting["dt"].min()).all()
    assert shear["dt"].iloc[-1] > shear["dt"].iloc[0]
    assert shear["max_overlap_over_d"].max() < 0.0025
    # the shear strains are held (the triaxial preset controls them at zero, as rigid platens
    # would): the cell does not shear after the first half step, which still moves at the
    # compaction's last rate (theta scheme)
    for component in ("xy", "xz", "yz"):
        gamma = table[f"gamma_{component}"][table["stage"] == "shear"]
        assert np.ptp(gamma) < 1e-9 and np.abs(gamma).max() < 1e-4


def test_periodic_simple_shear_holds_the_vertical_stress(tmp_path):
    result = start_run(tmp_path / "shear", config(
        sample={"height_ratio": 1.0},
        test={"kind": "simple_shear", "gamma_max": 0.05})).run()
    shear = result.table[result.table["stage"] == "shear"]
    assert shear["gamma_xz"].abs().iloc[-1] > 0.04
    # eps_xx and eps_yy held (after the first half step, at the compaction's last rate):
    # natural strains, so a simple shear has no normal strain along x and y
    for axis in ("xx", "yy"):
        assert np.ptp(shear[f"eps_{axis}"]) < 1e-9 and abs(shear[f"eps_{axis}"]).max() < 1e-4
    assert shear["gamma_xz"].abs().iloc[-1] == pytest.approx(0.05, rel=1e-3)
    np.testing.assert_allclose(shear["cell_sigma_zz"], SIGMA0, rtol=0.05)
    # the sample resists the shear: the mobilised tau / sigma_v grows
    ratio = (shear["sigma_xz"] / shear["sigma_zz"]).abs()
    assert ratio.max() > 0.2


def test_a_periodic_run_resumes_exactly(triaxial, tmp_path):
    _, full = triaxial
    folder = tmp_path / "resumed"
    run = start_run(folder, config())
    run.run(max_steps=int(full.table["step"].iloc[-1]) // 2)
    run.checkpoint()
    resumed = resume_run(folder).run()
    np.testing.assert_array_equal(resumed.table["step"], full.table["step"])
    np.testing.assert_array_equal(resumed.table["q_over_trace"], full.table["q_over_trace"])
    np.testing.assert_array_equal(resumed.table["cell_sigma_zz"], full.table["cell_sigma_zz"])
