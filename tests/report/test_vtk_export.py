"""VTK export read back with meshio: particle surfaces and points in the world frame, contact
lines carrying their forces, box walls, ParaView collections, and named input errors."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.detect.narrow_phase import Contacts
from grainlab.engine.shape_kinds import AGGREGATE
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.engine.step_report import StepReport, contact_frames
from grainlab.errors import InputError
from grainlab.report.shape_drawing import (
    SHAPE_KIND_DRAWERS,
    ShapeKindDrawer,
    ShapeMeshes,
    member_sphere_points,
)
from grainlab.report.vtk_export import (
    CONTACT_TYPE_PARTICLE,
    CONTACT_TYPE_WALL,
    BoxWalls,
    ContactLines,
    VtkSeries,
    read_pvd,
    write_pvd,
    write_vtk_frame,
)

OFFSETS = np.array([[0.4, 0.0, 0.0], [-0.2, 0.3, 0.0], [-0.2, -0.3, 0.1]])
RADII = np.array([0.3, 0.25, 0.2])


def rotation(axis, angle) -> tuple[np.ndarray, np.ndarray]:
    """Unit quaternion (w first) and its matrix (Rodrigues) for ``angle`` about ``axis``."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    q = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * k])
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    matrix = np.eye(3) + math.sin(angle) * skew + (1 - math.cos(angle)) * skew @ skew
    return q, matrix


def sample_library() -> ShapeLibrary:
    """Shape 0: sphere r = 0.3; shape 1: three-sphere aggregate (OFFSETS, RADII)."""
    aggregate = ShapeLibrary(
        kind=[AGGREGATE.code], sphere_start=[0], sphere_count=[3], sphere_offsets=OFFSETS,
        sphere_radii=RADII, volume=[0.2], principal_inertia=[[0.01, 0.02, 0.03]],
        bounding_radius=[0.7],
    )
    return ShapeLibrary.from_spheres([0.3]).concatenate(aggregate)


def sample_frame():
    q1, r1 = rotation([1.0, 2.0, 0.5], 0.9)
    q2, r2 = rotation([0.0, -1.0, 1.0], 2.3)
    return {
        "positions": np.array([[0.0, 0.0, 0.0], [1.5, 0.2, -0.3], [-1.0, 2.0, 0.5]]),
        "orientations": np.array([[1.0, 0, 0, 0], q1, q2]),
        "shape_ids": np.array([0, 1, 1]),
        "rotations": np.array([np.eye(3), r1, r2]),
    }


def frame_arguments(frame) -> dict:
    return {k: frame[k] for k in ("positions", "orientations", "shape_ids")}


# -- particles ------------------------------------------------------------------------------


def test_surfaces_lie_on_rotated_member_spheres(tmp_path):
    library, frame = sample_library(), sample_frame()
    files = write_vtk_frame(tmp_path, 0, 0.0, library=library, **frame_arguments(frame))
    mesh = meshio.read(files["particles"])
    members = 1 + 3 + 3
    assert len(mesh.points) == members * 42
    triangles = mesh.cells_dict["triangle"]
    assert triangles.shape == (members * 80, 3)
    data = mesh.point_data
    for p in range(3):
        shape = frame["shape_ids"][p]
        offsets = OFFSETS if shape == 1 else np.zeros((1, 3))
        radii = RADII if shape == 1 else np.array([0.3])
        for m, (offset, radius) in enumerate(zip(offsets, radii, strict=True)):
            mine = (data["particle_id"] == p) & (data["member"] == m)
            assert mine.sum() == 42
            centre = frame["positions"][p] + frame["rotations"][p] @ offset
            distance = np.linalg.norm(mesh.points[mine] - centre, axis=1)
            np.testing.assert_allclose(distance, radius, rtol=1e-12)
            np.testing.assert_allclose(data["radius"][mine], radius)
            assert np.all(data["shape_id"][mine] == shape)
    # every triangle joins three vertices of one member sphere, wound outward
    owner = data["particle_id"] * 10 + data["member"]
    assert np.all(owner[triangles] == owner[triangles[:, :1]])
    corners = mesh.points[triangles]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    first = triangles[:, 0]
    centres = np.array([mesh.points[owner == owner[v]].mean(axis=0) for v in first])
    assert np.all(np.einsum("ti,ti->t", normal, corners.mean(axis=1) - centres) > 0)


def test_points_carry_member_centres_radii_and_particle_data(tmp_path):
    library, frame = sample_library(), sample_frame()
    velocities = np.arange(9.0).reshape(3, 3)
    spins = -np.arange(9.0).reshape(3, 3)
    extra = {"coordination": np.array([1.0, 4.0, 2.5]), "rattler": np.array([True, False, True]),
             "cluster": np.array([7, 8, 9])}
    files = write_vtk_frame(tmp_path, 5, 1.0, library=library, velocities=velocities,
                            angular_velocities=spins, extra=extra, as_points=True,
                            **frame_arguments(frame))
    mesh = meshio.read(files["particles"])
    assert len(mesh.points) == 7
    np.testing.assert_array_equal(mesh.cells_dict["vertex"].ravel(), np.arange(7))
    owner = mesh.point_data["particle_id"]
    np.testing.assert_array_equal(owner, [0, 1, 1, 1, 2, 2, 2])
    expected = np.concatenate([
        frame["positions"][[0]],
        frame["positions"][1] + OFFSETS @ frame["rotations"][1].T,
        frame["positions"][2] + OFFSETS @ frame["rotations"][2].T,
    ])
    np.testing.assert_allclose(mesh.points, expected, atol=1e-14)
    np.testing.assert_allclose(mesh.point_data["radius"], np.concatenate([[0.3], RADII, RADII]))
    np.testing.assert_array_equal(mesh.point_data["velocity"], velocities[owner])
    np.testing.assert_array_equal(mesh.point_data["angular_velocity"], spins[owner])
    np.testing.assert_array_equal(mesh.point_data["coordination"], extra["coordination"][owner])
    np.testing.assert_array_equal(mesh.point_data["rattler"], extra["rattler"][owner])
    np.testing.assert_array_equal(mesh.point_data["cluster"], extra["cluster"][owner])


def test_subdivisions_set_the_triangles_per_member(tmp_path):
    library = ShapeLibrary.from_spheres([1.0])
    for level, triangles in ((0, 20), (2, 320)):
        files = write_vtk_frame(tmp_path, level, 0.0, positions=[[0, 0, 0]],
                                orientations=[[1, 0, 0, 0]], shape_ids=[0], library=library,
                                subdivisions=level)
        assert len(meshio.read(files["particles"]).cells_dict["triangle"]) == triangles


def test_a_new_shape_kind_plugs_in_through_its_drawer(tmp_path, monkeypatch):
    """A drawer returning its own body-frame vertices and faces (a tetrahedron standing in
    for a polyhedron) is rotated and placed by the writer unchanged."""
    tetra = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    faces = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])

    def surface(library, shapes, subdivisions):
        k = shapes.shape[0]
        return ShapeMeshes(
            vertex_start=4 * np.arange(k + 1), vertices=np.tile(tetra, (k, 1)),
            member=np.zeros(4 * k), radius=np.full(4 * k, math.sqrt(3.0)),
            triangle_start=4 * np.arange(k + 1), triangles=np.tile(faces, (k, 1)))

    monkeypatch.setitem(SHAPE_KIND_DRAWERS, AGGREGATE.name,
                        ShapeKindDrawer(surface=surface, points=member_sphere_points))
    library, frame = sample_library(), sample_frame()
    files = write_vtk_frame(tmp_path, 0, 0.0, library=library, **frame_arguments(frame))
    mesh = meshio.read(files["particles"])
    assert len(mesh.points) == 42 + 2 * 4
    assert len(mesh.cells_dict["triangle"]) == 80 + 2 * 4
    mine = mesh.point_data["particle_id"] == 2
    expected = frame["positions"][2] + tetra @ frame["rotations"][2].T
    np.testing.assert_allclose(mesh.points[mine], expected, atol=1e-14)
    np.testing.assert_array_equal(mesh.cells_dict["triangle"][-4:], faces + 42 + 4)


# -- contacts and walls ---------------------------------------------------------------------


def test_contact_lines_carry_the_forces(tmp_path):
    library, frame = sample_library(), sample_frame()
    normal = np.array([[1.0, 0, 0], [0, 0, 1.0]])
    force = np.array([[3.0, 4.0, 0.0], [0.5, 0.0, 2.0]])
    contacts = ContactLines(start=[[0, 0, 0], [1, 2, 0]], end=[[1.5, 0.2, -0.3], [1, 2, 1]],
                            force=force, normal=normal, type=[0, 1], sliding=[False, True])
    files = write_vtk_frame(tmp_path, 1, 0.5, library=library, contacts=contacts,
                            **frame_arguments(frame))
    mesh = meshio.read(files["contacts"])
    np.testing.assert_array_equal(mesh.points, [[0, 0, 0], [1.5, 0.2, -0.3], [1, 2, 0],
                                                [1, 2, 1]])
    np.testing.assert_array_equal(mesh.cells_dict["line"], [[0, 1], [2, 3]])
    data = {name: blocks["line"] for name, blocks in mesh.cell_data_dict.items()}
    np.testing.assert_allclose(data["normal_force"], [3.0, 2.0])
    np.testing.assert_allclose(data["tangential_force"], [4.0, 0.5])
    np.testing.assert_array_equal(data["force"], force)
    np.testing.assert_array_equal(data["normal"], normal)
    np.testing.assert_array_equal(data["type"], [0, 1])
    np.testing.assert_array_equal(data["sliding"], [0, 1])


def test_frame_without_contacts_is_an_empty_grid(tmp_path):
    library, frame = sample_library(), sample_frame()
    empty = ContactLines(start=np.zeros((0, 3)), end=np.zeros((0, 3)),
                         force=np.zeros((0, 3)), normal=np.zeros((0, 3)))
    files = write_vtk_frame(tmp_path, 0, 0.0, library=library, contacts=empty,
                            **frame_arguments(frame))
    root = ET.parse(files["contacts"]).getroot()
    piece = root.find("UnstructuredGrid/Piece")
    assert (piece.get("NumberOfPoints"), piece.get("NumberOfCells")) == ("0", "0")
    names = {array.get("Name") for array in piece.iter("DataArray")}
    assert {"normal_force", "tangential_force", "force", "normal"} <= names


def test_contact_lines_from_a_step_report():
    positions = np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 1.5]])
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    contacts = Contacts(
        body_i=np.array([0, -1]), body_j=np.array([1, 0]), member_i=np.array([0, -1]),
        member_j=np.array([0, 0]), point=np.array([[0.0, 0, 1.0], [0.0, 0, 0.0]]),
        normal=normals, gap=np.zeros(2))
    frames = contact_frames(normals)
    impulses = np.array([[2e-3, 1e-3, 0.0], [4e-3, 0.0, 0.0]])  # [N s]
    report = StepReport(n_contacts=2, iterations=1, converged=True, change=0.0, residual=0.0,
                        max_overlap=0.0, contacts=contacts, frames=frames, impulses=impulses,
                        relative_velocity=np.zeros((2, 3)))
    lines = ContactLines.from_step_report(report, positions, dt=1e-3, friction=0.5)
    np.testing.assert_array_equal(lines.start, [[0, 0, 0.5], [0, 0, 0]])
    np.testing.assert_array_equal(lines.end, [[0, 0, 1.5], [0, 0, 0.5]])
    np.testing.assert_allclose(lines.normal_force, [2.0, 4.0])
    np.testing.assert_allclose(lines.tangential_force, [1.0, 0.0])
    np.testing.assert_allclose(lines.force[0], 2.0 * normals[0] + 1.0 * frames[0, 1])
    np.testing.assert_array_equal(lines.type, [CONTACT_TYPE_PARTICLE, CONTACT_TYPE_WALL])
    np.testing.assert_array_equal(lines.sliding, [True, False])


def test_walls_are_six_inward_quads(tmp_path):
    library, frame = sample_library(), sample_frame()
    box = WallBox(lower=[-2, -1, -3], upper=[4, 5, 6])
    box.reactions[:] = np.arange(6.0)
    walls = BoxWalls.from_wall_box(box)
    files = write_vtk_frame(tmp_path, 0, 0.0, library=library, walls=walls,
                            **frame_arguments(frame))
    mesh = meshio.read(files["walls"])
    assert len(mesh.points) == 8
    quads = mesh.cells_dict["quad"]
    assert quads.shape == (6, 4)
    data = {name: blocks["quad"] for name, blocks in mesh.cell_data_dict.items()}
    np.testing.assert_array_equal(data["wall"], np.arange(6))
    np.testing.assert_array_equal(data["reaction"], np.arange(6.0))
    np.testing.assert_array_equal(data["normal"], box.normals)
    points, _ = box.planes()
    for w in range(6):
        corners = mesh.points[quads[w]]
        axis = w // 2
        np.testing.assert_allclose(corners[:, axis], points[w, axis])
        right_hand = np.cross(corners[1] - corners[0], corners[3] - corners[0])
        np.testing.assert_allclose(right_hand / np.linalg.norm(right_hand), box.normals[w])


# -- collections ----------------------------------------------------------------------------


def test_pvd_lists_frames_in_order_with_their_times(tmp_path):
    library, frame = sample_library(), sample_frame()
    walls = BoxWalls(lower=[-3, -3, -3], upper=[3, 3, 3])
    for index, time in ((2, 0.2), (0, 0.0), (1, 0.1), (2, 0.25)):
        write_vtk_frame(tmp_path, index, time, library=library,
                        walls=walls if index != 1 else None, **frame_arguments(frame))
    root = ET.parse(tmp_path / "particles.pvd").getroot()
    assert (root.tag, root.get("type")) == ("VTKFile", "Collection")
    entries = read_pvd(tmp_path / "particles.pvd")
    assert [(t, p.name) for t, p in entries] == [
        (0.0, "particles_000000.vtu"), (0.1, "particles_000001.vtu"),
        (0.25, "particles_000002.vtu")]
    assert all(p.exists() for _, p in entries)
    assert [p.name for _, p in read_pvd(tmp_path / "walls.pvd")] == [
        "walls_000000.vtu", "walls_000002.vtu"]
    assert not (tmp_path / "contacts.pvd").exists()


def test_series_keeps_its_index_up_to_date(tmp_path):
    library, frame = sample_library(), sample_frame()
    write_pvd(tmp_path / "particles.pvd", [(9.0, "old.vtu")])  # an older series
    state = BodyState.from_library(library, frame["shape_ids"], frame["positions"], 1000.0,
                                   orientations=frame["orientations"])
    contacts = ContactLines(start=[[0, 0, 0]], end=[[1, 0, 0]], force=[[1.0, 0, 0]],
                            normal=[[1.0, 0, 0]])
    with VtkSeries(tmp_path, library, subdivisions=0) as series:
        series.add_state(0.0, state)
        # readable after every frame, as an interrupted run leaves it
        assert [(t, p.name) for t, p in read_pvd(tmp_path / "particles.pvd")] == [
            (0.0, "particles_000000.vtu")]
        files = series.add_state(0.5, state, contacts=contacts)
        series.add_frame(1.5, **frame_arguments(frame))
    assert series.closed and series.n_frames == 3
    assert files["contacts"].name == "contacts_000001.vtu"
    assert [t for t, _ in read_pvd(tmp_path / "particles.pvd")] == [0.0, 0.5, 1.5]
    assert [(t, p.name) for t, p in read_pvd(tmp_path / "contacts.pvd")] == [
        (0.5, "contacts_000001.vtu")]
    mesh = meshio.read(tmp_path / "particles_000002.vtu")
    assert len(mesh.cells_dict["triangle"]) == 7 * 20
    with pytest.raises(InputError, match="VtkSeries"):
        series.add_state(2.0, state)


# -- input errors ---------------------------------------------------------------------------


def _with(**changes):
    frame = sample_frame()
    arguments = frame_arguments(frame)
    arguments.update(changes)
    return arguments


BAD_INPUTS = [
    ("positions", _with(positions=np.zeros((3, 2)))),
    ("positions[1]", _with(positions=[[0, 0, 0], [np.nan, 0, 0], [1, 1, 1]])),
    ("orientations", _with(orientations=np.ones((2, 4)))),
    ("orientations[2]", _with(orientations=[[1, 0, 0, 0], [1, 0, 0, 0], [1, 1, 0, 0]])),
    ("shape_ids[1]", _with(shape_ids=[0, 5, 1])),
    ("shape_ids", _with(shape_ids=[0.0, 1.0, 1.0])),
    ("velocities[0]", _with(velocities=[[np.inf, 0, 0], [0, 0, 0], [0, 0, 0]])),
    ("angular_velocities", _with(angular_velocities=np.zeros(3))),
    ("extra['phi']", _with(extra={"phi": np.zeros(2)})),
    ("extra", _with(extra={"radius": np.zeros(3)})),
    ("subdivisions", _with(subdivisions=9)),
]


@pytest.mark.parametrize(("field", "arguments"), BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS])
def test_bad_particle_input_names_the_field_and_writes_nothing(tmp_path, field, arguments):
    with pytest.raises(InputError) as error:
        write_vtk_frame(tmp_path / "out", 0, 0.0, library=sample_library(), **arguments)
    assert error.value.field == field
    assert field in str(error.value)
    assert not (tmp_path / "out").exists()


def test_bad_frame_contact_and_wall_inputs_name_the_field(tmp_path):
    arguments = _with()
    line = {"start": [[0, 0, 0]], "end": [[1, 0, 0]], "force": [[1.0, 0, 0]],
            "normal": [[1.0, 0, 0]]}
    cases = [
        ("time", lambda: write_vtk_frame(tmp_path, 0, math.nan, library=sample_library(),
                                         **arguments)),
        ("frame_index", lambda: write_vtk_frame(tmp_path, -1, 0.0, library=sample_library(),
                                                **arguments)),
        ("contacts.normal[0]", lambda: ContactLines(**{**line, "normal": [[2.0, 0, 0]]})),
        ("contacts.end", lambda: ContactLines(**{**line, "end": [[1, 0, 0], [2, 0, 0]]})),
        ("contacts.force[0]", lambda: ContactLines(**{**line, "force": [[np.nan, 0, 0]]})),
        ("contacts.sliding", lambda: ContactLines(**line, sliding=[2])),
        ("walls.upper", lambda: BoxWalls(lower=[0, 0, 0], upper=[1, 0, 1])),
        ("walls.reactions", lambda: BoxWalls(lower=[0, 0, 0], upper=[1, 1, 1],
                                             reactions=np.zeros(5))),
        ("contacts", lambda: write_vtk_frame(tmp_path, 0, 0.0, library=sample_library(),
                                             contacts=line, **arguments)),
    ]
    for field, call in cases:
        with pytest.raises(InputError) as error:
            call()
        assert error.value.field == field, field


def test_step_report_conversion_checks_its_inputs():
    contacts = Contacts(
        body_i=np.array([0]), body_j=np.array([3]), member_i=np.array([0]),
        member_j=np.array([0]), point=np.zeros((1, 3)), normal=np.array([[0.0, 0, 1]]),
        gap=np.zeros(1))
    report = StepReport(n_contacts=1, iterations=1, converged=True, change=0.0, residual=0.0,
                        max_overlap=0.0, contacts=contacts,
                        frames=contact_frames(contacts.normal), impulses=np.zeros((1, 3)),
                        relative_velocity=np.zeros((1, 3)))
    for field, arguments in (("positions", (np.zeros((2, 3)), 1e-3)),
                             ("dt", (np.zeros((4, 3)), 0.0)),
                             ("friction", (np.zeros((4, 3)), 1e-3, [0.1, 0.2]))):
        with pytest.raises(InputError) as error:
            ContactLines.from_step_report(report, *arguments)
        assert error.value.field == field
