"""Particle files: each particle's own geometry in world coordinates, read back into the
sample it came from (mass properties, positions, box, each particle's shape kind: every
registered kind, and one registered for a test only), independent of a rigid motion of the
file, with closed forms for a cube and a sphere, and bad files refused by name."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.discrete_sample import DiscreteSample
from grainlab.engine.shape_kinds import AGGREGATE, POLYHEDRON, SHAPE_KINDS
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import from_vertices
from grainlab.geometry.sphere_aggregate import SphereAggregate
from grainlab.lab.discrete_run import build_sample
from grainlab.lab.run_config import RunConfig
from grainlab.prep.inscribed_sample import deposited_sample
from grainlab.prep.particle_files import _world_points, read_particles, write_particles


def world_geometry(sample) -> list[np.ndarray]:
    """Each body's points (member spheres with radii, or vertices), sorted rows."""
    particle, _, points, radii = _world_points(sample.library, sample.state)
    rows = np.column_stack([points, radii])
    return [np.array(sorted(map(tuple, rows[particle == b])))
            for b in range(sample.state.n_bodies)]


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
@pytest.mark.parametrize("shape", [kind.name for kind in SHAPE_KINDS if kind.dimension == 3])
def test_a_written_sample_reads_back_as_itself(shape, suffix, tmp_path):
    made = deposited_sample(shape=shape, n_particles=25, seed=4, eta=0.5, n_faces=20,
                            templates=3)
    path = write_particles(made, tmp_path / f"sample{suffix}")
    assert set(_world_points(made.library, made.state)[1]) == {shape}  # the file's kind column
    read = read_particles(path)
    ids = made.state.shape_ids
    scale = made.library.bounding_radius.max()
    assert read.state.n_bodies == made.state.n_bodies
    # each particle keeps its kind's code and name
    np.testing.assert_array_equal(read.library.kind[read.state.shape_ids],
                                  made.library.kind[ids])
    assert read.description["shape"] == shape
    np.testing.assert_allclose(read.state.positions, made.state.positions, atol=1e-12 * scale)
    # a union of member spheres read back is integrated again in the file's frame: two
    # quadratures agree to 1e-11 (geometry/sphere_aggregate.py), not to the last bits
    np.testing.assert_allclose(read.library.volume, made.library.volume[ids], rtol=1e-11)
    np.testing.assert_allclose(read.library.principal_inertia,
                               made.library.principal_inertia[ids], rtol=1e-10)
    np.testing.assert_allclose(read.state.masses, made.state.masses, rtol=1e-11)
    for mine, theirs in zip(world_geometry(read), world_geometry(made), strict=True):
        np.testing.assert_allclose(mine, theirs, atol=1e-12 * scale)
    assert np.array_equal(read.box.lower, made.box.lower)
    assert np.array_equal(read.box.upper, made.box.upper)
    assert np.all(read.state.velocities == 0) and read.description["preparation"] == "file"


def cube_rows(centre, rotation, side):
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * side / 2
    return centre + corners @ rotation.T


def test_a_cube_and_a_sphere_have_their_closed_form_mass_properties(tmp_path):
    side, radius, density = 2e-3, 1e-3, 2000.0
    turn = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    centre = np.array([5e-3, 5e-3, 5e-3])
    lines = ["particle,kind,x,y,z,radius"]
    lines += [f"7,polyhedron,{float(x)!r},{float(y)!r},{float(z)!r},"
              for x, y, z in cube_rows(centre, turn, side)]
    path = tmp_path / "cube.csv"
    path.write_text("\n".join(lines) + "\n-1,lower,0,0,0,\n-1,upper,1e-2,1e-2,1e-2,\n")
    cube = read_particles(path, density=density)
    mass = density * side**3
    assert cube.state.masses[0] == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(cube.library.principal_inertia[0] * density,
                               mass * side**2 / 6, rtol=1e-12)
    np.testing.assert_allclose(cube.state.positions[0], centre, atol=1e-15)
    # the body's vertices, turned by its orientation, are the file's
    assert np.allclose(np.sort(world_geometry(cube)[0][:, :3], axis=0),
                       np.sort(cube_rows(centre, turn, side), axis=0), atol=1e-15)
    (tmp_path / "ball.csv").write_text(f"particle,kind,x,y,z,radius\n3,sphere,0,0,0,{radius}\n")
    ball = read_particles(tmp_path / "ball.csv", density=density)
    assert ball.state.masses[0] == pytest.approx(density * 4 / 3 * np.pi * radius**3, rel=1e-12)
    assert ball.box.lengths.tolist() == pytest.approx([2 * radius] * 3)


def test_a_rigid_motion_of_the_file_moves_the_sample_and_keeps_its_shapes(tmp_path):
    made = deposited_sample(shape="aggregate", n_particles=12, seed=1, eta=0.6)
    path = write_particles(made, tmp_path / "a.npz")
    with np.load(path) as data:
        arrays = dict(data)
    turn = Rotation.from_rotvec([0.1, 0.7, -0.4]).as_matrix()
    shift = np.array([1.0, -2.0, 0.5])
    arrays["points"] = arrays["points"] @ turn.T + shift
    del arrays["lower"], arrays["upper"]  # the box of the moved particles' extent
    np.savez(tmp_path / "moved.npz", **arrays)
    moved = read_particles(tmp_path / "moved.npz")
    np.testing.assert_allclose(moved.state.positions, made.state.positions @ turn.T + shift,
                               atol=1e-12)
    np.testing.assert_allclose(moved.library.volume, made.library.volume, rtol=1e-12)
    np.testing.assert_allclose(moved.library.principal_inertia,
                               made.library.principal_inertia, rtol=1e-10)


def test_spheres_and_aggregates_mix_in_file_order(tmp_path):
    (tmp_path / "mix.csv").write_text(
        "particle,kind,x,y,z,radius\n"
        "0,sphere,0,0,0,1e-3\n"
        "1,aggregate,4e-3,0,0,1e-3\n1,aggregate,5e-3,0,0,1e-3\n"
        "2,sphere,9e-3,0,0,2e-3\n")
    sample = read_particles(tmp_path / "mix.csv")
    kinds = sample.library.kind[sample.state.shape_ids].tolist()
    assert kinds[0] == kinds[2] != kinds[1]
    np.testing.assert_allclose(sample.state.positions[:, 0], [0, 4.5e-3, 9e-3], atol=1e-15)
    assert sample.description["shape"] == "mixed"


@pytest.mark.parametrize("text, field", [
    ("particle,kind,x,y,z\n0,sphere,0,0,0\n", "header"),
    ("particle,kind,x,y,z,radius\n0,cube,0,0,0,1\n", "particle 0 kind"),
    ("particle,kind,x,y,z,radius\n0,sphere,0,0,0,1\n0,sphere,1,0,0,1\n", "particle 0 rows"),
    ("particle,kind,x,y,z,radius\n0,sphere,0,0,0,-1\n", "particle 0 radius"),
    ("particle,kind,x,y,z,radius\n0,sphere,0,zero,0,1\n", "line 2: y"),
    ("particle,kind,x,y,z,radius\nA,sphere,0,0,0,1\n", "line 2: particle"),
    ("particle,kind,x,y,z,radius\n" + "".join(
        f"0,polyhedron,{x},{y},0,\n" for x, y in [(0, 0), (1, 0), (0, 1)]), "vertices"),
    ("particle,kind,x,y,z,radius\n" + "".join(
        f"4,polyhedron,{x},{y},0,\n" for x, y in [(0, 0), (1, 0), (0, 1), (1, 1)]),
     "particle 4 vertices"),
    ("particle,kind,x,y,z,radius\n0,sphere,0,0,0,1\n" + "".join(
        f"1,polyhedron,{x},{y},{z},\n" for x, y, z in
        [(5, 5, 5), (6, 5, 5), (5, 6, 5), (5, 5, 6)]), "kind"),
    ("particle,kind,x,y,z,radius\n0,sphere,0,0,0,1\n-1,lower,0,0,0,\n-1,upper,1,1,1,\n",
     "box"),
    ("particle,kind,x,y,z,radius\n0,sphere,0,0,0,1\n-1,lower,-1,-1,-1,\n", "box"),
])
def test_bad_particle_files_name_what_is_wrong(text, field, tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match="particle file") as caught:
        read_particles(path)
    assert field in caught.value.field


def test_an_npz_without_its_arrays_is_refused(tmp_path):
    np.savez(tmp_path / "bad.npz", points=np.zeros((2, 3)))
    with pytest.raises(InputError, match=r"missing particle, kind, radii"):
        read_particles(tmp_path / "bad.npz")


def test_the_config_reads_a_particle_file_and_wants_one_file(tmp_path):
    made = deposited_sample(shape="polyhedron", n_particles=10, seed=2, n_faces=8,
                            templates=2)
    path = str(write_particles(made, tmp_path / "p.csv"))
    config = RunConfig.model_validate({"sample": {"preparation": "file",
                                                  "particle_file": path}})
    sample = build_sample(config)
    assert sample.state.n_bodies == 10 and sample.description["shape"] == "polyhedron"
    both = RunConfig.model_validate({"sample": {"preparation": "file", "particle_file": path,
                                                "skeleton_file": path}})
    with pytest.raises(InputError, match=r"sample\.particle_file"):
        build_sample(both)


def test_a_scaled_turned_copy_of_an_aggregate_has_scaled_mass_properties(tmp_path):
    """The second aggregate, the first scaled by 2 and turned, is made from the first
    (f^3 volume, f^5 moments, its own centre); a third of other proportions is not."""
    turn = Rotation.from_rotvec([0.4, -0.9, 0.2]).as_matrix()
    first = np.array([[0.0, 0.0, 0.0], [1.2e-3, 0.0, 0.0], [0.3e-3, 0.9e-3, 0.0]])
    radii = np.array([1e-3, 0.8e-3, 0.6e-3])
    copy = 2.0 * first @ turn.T + np.array([2e-2, 1e-2, 0.0])
    other = first * np.array([1.0, 1.5, 1.0]) + np.array([-2e-2, 0.0, 0.0])
    lines = ["particle,kind,x,y,z,radius"]
    for pid, (points, rs) in enumerate([(first, radii), (copy, 2 * radii), (other, radii)]):
        lines += [f"{pid},aggregate,{x!r},{y!r},{z!r},{r!r}"
                  for (x, y, z), r in zip(points.tolist(), rs.tolist(), strict=True)]
    (tmp_path / "three.csv").write_text("\n".join(lines) + "\n")
    sample = read_particles(tmp_path / "three.csv")
    library, state = sample.library, sample.state
    assert library.volume[1] == pytest.approx(8 * library.volume[0], rel=1e-12)
    np.testing.assert_allclose(library.principal_inertia[1], 32 * library.principal_inertia[0],
                               rtol=1e-12)
    np.testing.assert_allclose(state.positions[1], 2.0 * turn @ state.positions[0]
                               + np.array([2e-2, 1e-2, 0.0]), atol=1e-15)
    for mine, given in zip(world_geometry(sample)[:2], [first, copy], strict=True):
        np.testing.assert_allclose(mine[:, :3], np.array(sorted(map(tuple, given))),
                                   atol=1e-15)
    assert library.volume[2] != pytest.approx(library.volume[0], rel=1e-6)


# -- kinds registered for a test only: what the file says is what reads back ------------------


def placed(library: ShapeLibrary, spacing: float) -> DiscreteSample:
    """The library's shapes in a row along x, ``spacing`` [m] apart, turned, in a box."""
    n = library.n_shapes
    positions = np.column_stack([spacing * np.arange(n), np.zeros(n), np.zeros(n)])
    turns = Rotation.from_rotvec(np.outer(np.arange(1, n + 1), [0.3, -0.5, 0.2]))
    state = BodyState.from_library(library, np.arange(n), positions, 2000.0,
                                   turns.as_quat()[:, [3, 0, 1, 2]])
    reach = float(library.bounding_radius.max())
    box = WallBox(positions.min(axis=0) - 2 * reach, positions.max(axis=0) + 2 * reach)
    return DiscreteSample(library, state, box, {"shape": "mixed"})


def next_code() -> int:
    return max(kind.code for kind in SHAPE_KINDS) + 1


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_a_member_sphere_kind_registered_for_a_test_reads_back_as_itself(
        register_shape_kind, suffix, tmp_path):
    """A dimer kind (two equal spheres), mixed in file order with a sphere and an
    aggregate of the same member spheres, reads back as a dimer: its code, its name, its
    mass properties; before it is registered, the file is refused naming the kinds."""
    dimer = dataclasses.replace(AGGREGATE, name="test_dimer", code=next_code(),
                                plural="test_dimers")
    pair = SphereAggregate.from_spheres(np.array([[-0.5e-3, 0, 0], [0.5e-3, 0, 0]]),
                                        np.array([1e-3, 1e-3]))
    triple = SphereAggregate.from_spheres(np.array([[-0.5e-3, 0, 0], [0.5e-3, 0, 0],
                                                    [0, 0.7e-3, 0]]), np.full(3, 1e-3))
    register_shape_kind(dimer)
    library = ShapeLibrary.from_spheres([1e-3]).concatenate(
        ShapeLibrary.from_aggregates([pair], dimer)).concatenate(
        ShapeLibrary.from_aggregates([triple])).concatenate(
        ShapeLibrary.from_aggregates([pair], dimer))
    made = placed(library, 5e-3)
    read = read_particles(write_particles(made, tmp_path / f"mix{suffix}"))
    codes = read.library.kind[read.state.shape_ids].tolist()
    assert codes == library.kind.tolist() == [0, dimer.code, AGGREGATE.code, dimer.code]
    assert set(_world_points(read.library, read.state)[1]) == {"sphere", "test_dimer",
                                                              "aggregate"}
    np.testing.assert_allclose(read.library.volume, library.volume, rtol=1e-12)
    np.testing.assert_allclose(read.state.positions, made.state.positions, atol=1e-15)
    alone = placed(ShapeLibrary.from_aggregates([pair, pair], dimer), 5e-3)
    path = write_particles(alone, tmp_path / f"dimers{suffix}")
    assert read_particles(path).description["shape"] == "test_dimer"


def test_a_polyhedron_kind_registered_for_a_test_reads_back_as_itself(register_shape_kind,
                                                                      tmp_path):
    """A cube kind of the polyhedron family reads back as a cube beside a polyhedron, with
    a cube's mass and moments (m a^2 / 6) and no radius in the file."""
    cube_kind = register_shape_kind(dataclasses.replace(POLYHEDRON, name="test_cube",
                                                        code=next_code(), plural="test_cubes"))
    a = 2e-3
    cube = from_vertices([[x, y, z] for x in (0, a) for y in (0, a) for z in (0, a)])
    wedge = from_vertices([[0, 0, 0], [a, 0, 0], [0, a, 0], [0, 0, a], [a, a, 0], [a, 0, a]])
    library = ShapeLibrary.from_polyhedra([cube], cube_kind).concatenate(
        ShapeLibrary.from_polyhedra([wedge]))
    path = write_particles(placed(library, 6e-3), tmp_path / "cubes.csv")
    rows = path.read_text().splitlines()
    assert all(row.endswith(",") for row in rows if ",test_cube," in row)
    read = read_particles(path, density=2000.0)
    assert read.library.kind[read.state.shape_ids].tolist() == [cube_kind.code, POLYHEDRON.code]
    mass = 2000.0 * a**3
    assert read.state.masses[0] == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(read.state.inertias[0], mass * a**2 / 6, rtol=1e-12)
    assert read.description["shape"] == "mixed" and "mean_angularity" in read.description


def test_a_kind_not_registered_is_refused_naming_the_registered_ones(register_shape_kind,
                                                                      tmp_path):
    path = tmp_path / "dimer.csv"
    path.write_text("particle,kind,x,y,z,radius\n0,test_dimer,0,0,0,1e-3\n"
                    "0,test_dimer,1e-3,0,0,1e-3\n")
    with pytest.raises(InputError) as caught:
        read_particles(path)
    assert "particle 0 kind" in caught.value.field and "'aggregate'" in caught.value.allowed
    dimer = register_shape_kind(dataclasses.replace(AGGREGATE, name="test_dimer",
                                                    code=next_code(), plural="test_dimers"))
    read = read_particles(path)
    assert read.library.kind.tolist() == [dimer.code]
