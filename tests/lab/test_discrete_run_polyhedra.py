"""Polyhedra in run folders: config validation naming the field, the polyhedron library
through a checkpoint (every array of the library), and the time-step length."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

from grainlab.engine.state import ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import TABLE_I, from_vertices
from grainlab.lab.discrete_run import read_checkpoint, start_run
from grainlab.lab.discrete_test import time_step_length
from grainlab.lab.run_config import RunConfig

TINY = {
    "sample": {"shape": "polyhedron", "n_faces": 30, "templates": 3, "n_particles": 8,
               "seed": 2},
    "test": {"kind": "triaxial", "eps_q_max": 0.01},
    "solver": {"sweep": "serial",
               "compaction": {"inertia_number": 0.05, "time_step_factor": 0.02},
               "shear": {"inertia_number": 0.01}},
    "output": {"record_every": 10, "checkpoint_every": 0},
}


@pytest.mark.parametrize(("sample", "field"), [
    ({"n_faces": 31}, "sample.n_faces"), ({"n_faces": 4}, "sample.n_faces"),
    ({"templates": -2}, "sample.templates"), ({"shape": "cube"}, "sample.shape"),
    ({"n_face": 30}, "sample.n_face"),
])
def test_bad_polyhedron_settings_name_the_field(sample, field):
    with pytest.raises(InputError) as error:
        RunConfig.model_validate({"sample": {"shape": "polyhedron", **sample}})
    assert error.value.field == field


def test_polyhedron_library_goes_through_a_checkpoint(tmp_path):
    config = RunConfig.model_validate(TINY)
    run = start_run(tmp_path / "run", config)
    library = run.test.sample.library
    assert library.n_shapes == 8 and library.vertices.shape[0] > 0
    saved = read_checkpoint(run.checkpoint())
    for f in dataclasses.fields(ShapeLibrary):
        np.testing.assert_array_equal(getattr(saved["library"], f.name),
                                      getattr(library, f.name), err_msg=f.name)
    np.testing.assert_array_equal(saved["state"].orientations,
                                  run.test.sample.state.orientations)
    assert saved["description"]["n_faces"] == 30 and saved["description"]["templates"] == 3
    assert RunConfig.read(tmp_path / "run" / "config.toml").sample.n_faces == 30


def test_time_step_length_is_the_smallest_inscribed_or_member_diameter():
    cube = from_vertices([[x, y, z] for x in (0, 2) for y in (0, 2) for z in (0, 2)])
    library = ShapeLibrary.from_polyhedra([cube]).concatenate(
        ShapeLibrary.from_spheres([3.0]))
    assert time_step_length(library) == pytest.approx(2.0)  # the cube's inscribed sphere
    assert time_step_length(ShapeLibrary.from_spheres([0.2, 0.5])) == pytest.approx(0.4)
    assert time_step_length(library.concatenate(ShapeLibrary.from_spheres([0.25]))) \
        == pytest.approx(0.5)


@pytest.fixture(scope="module")
def polyhedra_run(tmp_path_factory):
    """A tiny triaxial run; its folder is also copied as it stands at the end of compaction
    (checkpoint just written), as if the run had been killed there."""
    root = tmp_path_factory.mktemp("poly")
    folder, killed = root / "triaxial", root / "killed"
    config = RunConfig.model_validate(TINY).with_updates(
        {"output": {"snapshot_every": 20, "vtk_every": 200}})
    run = start_run(folder, config)
    stage_ended = run.test.on_stage_end

    def copy_after_the_checkpoint(test):
        stage_ended(test)
        if not killed.exists():
            shutil.copytree(folder, killed)

    run.test.on_stage_end = copy_after_the_checkpoint
    result = run.run()
    return folder, killed, result


def test_polyhedra_triaxial_runs_with_pair_types(polyhedra_run):
    from grainlab.analysis.snapshot_files import read_snapshots

    folder, _, result = polyhedra_run
    assert result.metadata["outcome"]["finished"]
    assert result.metadata["specimen"]["shape"] == "polyhedron"
    table = result.table
    shear = table[table["stage"] != "compaction"]
    assert shear["eps_q"].iloc[-1] >= 0.01
    loaded = table[table["z"] > 0]
    fractions = loaded[[f"fraction_{t}" for t in ("fv", "ee", "fe", "ff")]]
    np.testing.assert_allclose(fractions.sum(axis=1), 1.0)
    np.testing.assert_allclose(loaded["z_c"], loaded["z"] * (
        1 + loaded["fraction_fe"] + 2 * loaded["fraction_ff"]))
    network = list(read_snapshots(folder / "snapshots.h5"))[-1]
    assert network.type_names == ("point", "fv", "ee", "fe", "ff")
    assert network.n_points == network.n_pairs  # one resultant per polyhedron pair
    assert set(network.pair_types.tolist()) <= {1, 2, 3, 4}
    # ParaView frames written during the run: faceted particles, one line per pair
    import meshio

    frames = sorted((folder / "vtk").glob("contacts_*.vtu"))
    assert frames
    lines = meshio.read(frames[-1]).cell_data_dict["contact_type"]["line"]
    assert set(lines.tolist()) <= {1, 2, 3, 4}


def test_shearing_starts_without_a_burst(polyhedra_run):
    """Overlap recovery switched on at the start of shear pushes the compaction's overlaps
    back no faster than the walls move: the mean stress stays of the order of sigma0 (it
    jumped to ~1e4 sigma0 and the sample flew apart when the separation speed beta |g| / h
    was not capped, with the short steps of spinning polyhedra)."""
    _, _, result = polyhedra_run
    table = result.table
    shear = table[table["stage"] == "shear"]
    sigma0 = float(table[table["stage"] == "compaction"]["p"].iloc[-1])
    assert len(shear) > 0
    assert shear["p"].max() < 5.0 * sigma0
    assert shear["z"].min() > 0.0


def test_polyhedra_checkpoint_exports_faceted_shapes(polyhedra_run, tmp_path):
    import meshio

    from grainlab.lab.discrete_run import export_checkpoint_vtk

    folder, _, _ = polyhedra_run
    paths = export_checkpoint_vtk(folder, tmp_path / "vtk")
    particles = meshio.read(next(p for p in paths if p.name.startswith("particles")))
    saved = read_checkpoint(folder / "checkpoint.h5")
    library = saved["library"]
    ids = saved["state"].shape_ids
    assert len(particles.points) == int(library.vertex_count[ids].sum())
    n_faces = sum(len(block) for block in particles.cells)
    assert n_faces == int(library.face_count[ids].sum())
    contacts = meshio.read(next(p for p in paths if p.name.startswith("contacts")))
    assert set(contacts.cell_data_dict["contact_type"]["line"].tolist()) <= {1, 2, 3, 4}


def test_polyhedra_run_resumed_from_a_checkpoint_reproduces_the_rows(polyhedra_run):
    from grainlab.lab.discrete_run import resume_run

    _, killed, reference = polyhedra_run
    run = resume_run(killed)
    compaction = reference.metadata["outcome"]["stages"][0]
    assert run.test.simulation.step_index == compaction["end_step"]
    table, expected = run.run().table, reference.table
    assert len(table) == len(expected)
    np.testing.assert_array_equal(table["step"], expected["step"])
    np.testing.assert_allclose(table["q_over_trace"], expected["q_over_trace"], rtol=1e-6,
                               atol=1e-9)
    np.testing.assert_allclose(table["packing_fraction"], expected["packing_fraction"],
                               rtol=1e-9)
    np.testing.assert_allclose(table["z_c"], expected["z_c"])


@pytest.mark.long
@pytest.mark.parametrize("n_faces", sorted(TABLE_I))
def test_every_table_i_polyhedron_runs_a_triaxial_test(n_faces, tmp_path):
    """Seed 002's seven shapes (n_f = 8 ... 596) each run the triaxial test through the API:
    frictionless compaction (at most 2000 steps here), then shear to the strain asked, with
    the pair types counted and overlaps small."""
    config = RunConfig.model_validate(TINY).with_updates(
        {"sample": {"n_faces": n_faces, "templates": 2, "n_particles": 8, "seed": 3,
                    "packing_fraction": 0.2},
         # n_f = 596 settles in ~22 000 steps (73 s): the compaction is cut short here, and
         # the shear starts all the same (the outcome then says the compaction did not settle)
         "solver": {"max_stage_steps": 2000, "at_max_stage_steps": "next_stage"}})
    result = start_run(tmp_path / "run", config).run()
    assert result.metadata["outcome"]["finished"]
    table = result.table
    assert table["eps_q"].iloc[-1] >= 0.01
    compacted = table[table["stage"] == "compaction"].iloc[-1]
    assert compacted["z"] > 0.0 and compacted["p"] > 0.0
    assert compacted["packing_fraction"] > 0.3
    assert table["max_overlap_over_d"].max() < 0.05
