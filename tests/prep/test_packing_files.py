"""Packings read from and written to TOML and CSV files."""

from __future__ import annotations

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.geometry import DiscPacking2D, find_disc_contacts
from grainlab.prep import read_packing, write_packing
from grainlab.prep.regular_packings import named_packing

NAMES = ["square", "rhombic", "hexagonal", "A", "B", "C"]


def describe(packing):
    contacts = find_disc_contacts(packing)
    return packing.void_ratio, contacts.coordination_number(packing.n_particles)


@pytest.mark.parametrize("suffix", [".toml", ".csv"])
@pytest.mark.parametrize("name", NAMES)
def test_round_trip(tmp_path, name, suffix):
    packing = named_packing(name).rotated(0.3).translated([1e-3, -2e-3])
    path = write_packing(packing, tmp_path / f"{name}{suffix}")
    back = read_packing(path)
    # floats are written exactly
    np.testing.assert_array_equal(back.centres, packing.centres)
    np.testing.assert_array_equal(back.radii, packing.radii)
    np.testing.assert_array_equal(back.cell.lattice, packing.cell.lattice)
    assert back.labels == packing.labels
    assert describe(back) == describe(packing)
    if suffix == ".toml":
        assert back.name == packing.name
    else:
        assert back.name == name  # CSV has no name field: the file stem


def test_read_handwritten_toml(tmp_path):
    path = tmp_path / "square.toml"
    path.write_text(
        'lattice = [[0.0127, 0.0], [0.0, 0.0127]]\n'
        "[[particles]]\nx = 0.0\ny = 0.0\nradius = 0.00635\n",
        encoding="utf-8",
    )
    packing = read_packing(path)
    assert packing.name == "square"
    assert packing.labels == ("p0",)
    assert packing.void_ratio == pytest.approx(4 / np.pi - 1, rel=1e-12)
    assert describe(packing)[1] == 4.0


def test_read_handwritten_csv(tmp_path):
    path = tmp_path / "c.csv"
    R = 0.00635
    h = float(np.sqrt(5.0) * R)
    path.write_text(
        "kind,x,y,radius,label\n"
        f"lattice,{2 * R!r},0.0,,\n"
        f"lattice,0.0,{h!r},,\n"
        f"particle,0.0,0.0,{R!r},big\n"
        f"particle,{R!r},{h / 2!r},{R / 2!r},\n",
        encoding="utf-8",
    )
    packing = read_packing(path)
    assert packing.labels == ("big", "p1")
    contacts = find_disc_contacts(packing)
    assert contacts.per_particle(2).tolist() == [6, 4]


def _toml_with(tmp_path, particle_lines: str, top: str = "") -> object:
    path = tmp_path / "bad.toml"
    path.write_text(
        top + 'lattice = [[1.0, 0.0], [0.0, 1.0]]\n'
        "[[particles]]\nx = 0.0\ny = 0.0\nradius = 0.5\n"
        "[[particles]]\n" + particle_lines,
        encoding="utf-8",
    )
    return path


def test_negative_radius_is_named(tmp_path):
    path = _toml_with(tmp_path, "x = 0.5\ny = 0.5\nradius = -0.1\n")
    with pytest.raises(InputError) as info:
        read_packing(path)
    assert "particles.1.radius" in str(info.value)
    assert "-0.1" in str(info.value)


def test_negative_radius_in_csv_is_named(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text(
        "kind,x,y,radius,label\nlattice,1.0,0.0,,\nlattice,0.0,1.0,,\n"
        "particle,0.0,0.0,-0.5,\n",
        encoding="utf-8",
    )
    with pytest.raises(InputError, match=r"particles\.0\.radius"):
        read_packing(path)


def test_unknown_particle_key_rejected(tmp_path):
    path = _toml_with(tmp_path, "x = 0.5\ny = 0.5\nradius = 0.1\ncolour = 'red'\n")
    with pytest.raises(InputError, match="colour"):
        read_packing(path)


def test_unknown_top_level_key_rejected(tmp_path):
    path = _toml_with(tmp_path, "x = 0.5\ny = 0.5\nradius = 0.1\n", top="lattise = 3\n")
    with pytest.raises(InputError, match="lattise"):
        read_packing(path)


def test_missing_field_rejected(tmp_path):
    path = _toml_with(tmp_path, "x = 0.5\nradius = 0.1\n")
    with pytest.raises(InputError, match=r"particles\.1\.y"):
        read_packing(path)


def test_invalid_toml_and_unknown_kind(tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text("lattice = [[1.0, 0.0]\n", encoding="utf-8")
    with pytest.raises(InputError, match="TOML"):
        read_packing(broken)
    csv_path = tmp_path / "odd.csv"
    csv_path.write_text("kind,x,y,radius,label\ncircle,0,0,1,\n", encoding="utf-8")
    with pytest.raises(InputError, match="line 2"):
        read_packing(csv_path)


def test_missing_file_and_bad_extension(tmp_path):
    with pytest.raises(InputError):
        read_packing(tmp_path / "nothing.toml")
    other = tmp_path / "packing.json"
    other.write_text("{}", encoding="utf-8")
    with pytest.raises(InputError):
        read_packing(other)
    with pytest.raises(InputError):
        write_packing(named_packing("square"), tmp_path / "out.json")


def test_parallel_lattice_in_file_is_a_geometry_error(tmp_path):
    from grainlab.errors import GeometryError

    path = tmp_path / "flat.toml"
    path.write_text(
        'lattice = [[1.0, 0.0], [2.0, 0.0]]\n[[particles]]\nx = 0.0\ny = 0.0\nradius = 0.5\n',
        encoding="utf-8",
    )
    with pytest.raises(GeometryError, match="parallel"):
        read_packing(path)




@pytest.mark.parametrize(
    ("name", "labels"),
    [
        ("plain name", ("big", "small")),
        ("back\\slash", ("big", "small")),
        ("Chang's C", ("big", "small")),
        ("C", ('the "big" one', "small")),
    ],
)
def test_toml_round_trip_of_names_and_labels(tmp_path, name, labels):
    base = named_packing("C")
    packing = DiscPacking2D(base.cell, base.centres, base.radii, name, labels)
    back = read_packing(write_packing(packing, tmp_path / "named.toml"))
    assert back.name == name
    assert back.labels == labels
