"""Failures a user can cause at the command line: exit status 2, one line that names the file
or the option as typed (in its units), no traceback, and nothing left behind that blocks the
corrected command."""

from __future__ import annotations

import errno
import os
import pathlib

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app

runner = CliRunner()


def refused(*args, named=(), absent=(), after_output=False) -> str:
    """Run the command; it must exit with status 2 and print one line holding every string
    of ``named`` and none of ``absent`` (the last line, after what the command printed
    before it failed when ``after_output``). Returns the line."""
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 2, (result.output, result.exception)
    assert "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    if after_output:
        lines = lines[-1:]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    for text in named:
        assert text in lines[0], lines[0]
    for text in absent:
        assert text not in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def a_file(tmp_path) -> pathlib.Path:
    path = tmp_path / "a_file"
    path.write_text("not a folder\n")
    return path


@pytest.fixture
def a_png(tmp_path) -> pathlib.Path:
    path = tmp_path / "picture.png"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe" * 8)
    return path


# -- files that are read -------------------------------------------------------------------
def test_a_config_that_is_a_picture_is_named(tmp_path, a_png):
    refused("triaxial", "--config", a_png, "--out", tmp_path / "run",
            named=("--config", str(a_png)))
    assert not (tmp_path / "run").exists()


def test_a_config_that_is_a_folder_is_named(tmp_path):
    refused("compaction", "--config", tmp_path, "--out", tmp_path / "run",
            named=("--config", str(tmp_path)))


def test_a_packing_file_that_is_binary_is_named(tmp_path, a_png):
    path = tmp_path / "binary.toml"
    path.write_bytes(a_png.read_bytes())
    refused("packing2d", "show", path, "--out", tmp_path / "t.png", named=(str(path),))
    csv = tmp_path / "binary.csv"
    csv.write_bytes(a_png.read_bytes())
    refused("packing2d", "load", "--packing", csv, "--out", tmp_path / "o", named=(str(csv),))


# -- folders and files that are written ----------------------------------------------------
def _commands_with_out(tmp_path):
    """Each command that writes a folder, with arguments that would otherwise run it."""
    return {
        "triaxial": ["triaxial", "-n", "8"],
        "compare": ["compare", "compaction", "-n", "8"],
        "demo": ["demo"],
        "packing2d load": ["packing2d", "load", "--max-ratio", "1.2"],
        "analyse": ["analyse", "--synthetic", "20"],
        "vtk": ["vtk", tmp_path],
        "microelement run": ["microelement", "run", "--steps", "8"],
    }


@pytest.mark.parametrize("command", ["triaxial", "compare", "demo", "packing2d load",
                                     "analyse", "vtk", "microelement run"])
def test_out_that_is_a_file_is_named(tmp_path, a_file, command):
    refused(*_commands_with_out(tmp_path)[command], "--out", a_file,
            named=("--out", str(a_file)))
    assert a_file.read_text() == "not a folder\n"


@pytest.mark.parametrize("command", ["triaxial", "compare", "demo", "packing2d load",
                                     "analyse", "vtk", "microelement run"])
def test_out_under_a_file_is_named(tmp_path, a_file, command):
    refused(*_commands_with_out(tmp_path)[command], "--out", a_file / "sub",
            named=("--out", str(a_file)))


def test_a_figure_in_an_unknown_format_is_named(tmp_path):
    refused("packing2d", "show", "C", "--out", tmp_path / "x.xyz", named=("--out", "xyz", "png"))
    assert not (tmp_path / "x.xyz").exists()


def test_a_read_only_file_system_is_one_line_naming_the_file(tmp_path, monkeypatch):
    target = tmp_path / "t.csv"

    def read_only(self, *args, **kwargs):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(self))

    monkeypatch.setattr(pathlib.Path, "write_text", read_only)
    refused("packing2d", "table", "--csv", target, named=(str(target), "Read-only"),
            after_output=True)


def test_a_folder_without_permission_is_one_line_naming_it(tmp_path, monkeypatch):
    target = tmp_path / "run"

    def not_permitted(self, *args, **kwargs):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(self))

    monkeypatch.setattr(pathlib.Path, "mkdir", not_permitted)
    refused("analyse", "--synthetic", "20", "--out", target,
            named=(str(target), "Permission denied"))


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0,
                    reason="root writes into read-only folders")
def test_a_read_only_folder_is_named(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        refused("triaxial", "-n", "8", "--out", locked / "run", named=("--out", str(locked)))
    finally:
        locked.chmod(0o700)


# -- numbers named as typed ----------------------------------------------------------------
@pytest.mark.parametrize("arguments, named, absent", [
    (["--seed", "-1"], ("--seed", "-1"), ("ValueError",)),
    (["--sigma0", "inf"], ("--sigma0", "Pa"), ("p_final",)),
    (["--mu", "inf"], ("--mu",), ("solver.shear.friction", "friction =")),
    (["--size-ratio", "inf"], ("--size-ratio", ">= 1"), ("> 0",)),
    (["-n", "2"], ("--n-particles", "2"), ("packing_fraction =", "'too high'")),
    (["--shape", "polyhedron", "--faces", "100000"], ("--faces", "1000"), ()),
])
def test_discrete_options_are_named_as_typed(tmp_path, arguments, named, absent):
    refused("triaxial", "-n", "8", *arguments, "--out", tmp_path / "run", named=named,
            absent=absent)


@pytest.mark.parametrize("text, key", [
    ("[solver.shear]\nfriction = -1.0\n", "solver.shear.friction"),
    ("[solver.compaction]\ninertia_number = 2.0\n", "solver.compaction.inertia_number"),
    ("[solver]\nfriction = -1.0\n", "solver.friction"),  # the earlier layout, as written
])
def test_a_value_from_the_config_file_is_named_by_its_key(tmp_path, text, key):
    config = tmp_path / "c.toml"
    config.write_text(text)
    refused("triaxial", "--config", config, "--out", tmp_path / "run",
            named=(f"{key} (in {config})",))


@pytest.mark.parametrize("text, named", [
    # a boolean is not a count: read as 1 it made another key look wrong
    ("[sample]\nn_particles = true\n",
     ("sample.n_particles (in {config}) = true", "an integer >= 1",
      "true and false are not numbers")),
    ("[sample]\nd_min = false\n", ("sample.d_min (in {config}) = false", "a finite number > 0")),
    ("[solver.shear]\nmax_iterations = true\n",
     ("solver.shear.max_iterations (in {config}) = true", "an integer >= 1")),
    ("[output]\nsnapshot_every = true\n",
     ("output.snapshot_every (in {config}) = true", "an integer >= 0")),
    ("[solver]\nwall_servo = 1\n", ("solver.wall_servo (in {config}) = 1", "true or false")),
    # a value where a table is expected: the table named, with its keys
    ("test = 5\n", ("test (in {config}) = 5", "a table [test] of the keys kind, sigma0")),
    ("[solver]\nshear = 0.4\n",
     ("solver.shear (in {config}) = 0.4", "a table [solver.shear] of the keys friction")),
])
def test_a_config_value_of_the_wrong_type_names_its_key_and_what_it_takes(tmp_path, text,
                                                                          named):
    config = tmp_path / "c.toml"
    config.write_text(text)
    out = tmp_path / "run"
    line = refused("triaxial", "--config", config, "--out", out,
                   named=[part.format(config=config) for part in named],
                   absent=("finite number.", "test.eps_q_max", "True"))
    assert line.count(" = ") == 1  # one key blamed: the one the file holds
    assert not out.exists()


@pytest.mark.parametrize("value", ["0", "-3"])
def test_analyse_synthetic_below_one_is_named_and_makes_no_folder(tmp_path, value):
    out = tmp_path / "analysis"
    refused("analyse", "--synthetic", value, "--out", out,
            named=(f"--synthetic = {value}", "an integer >= 1"), absent=("RUN|SNAPSHOT",))
    assert not out.exists()


def test_analyse_refused_options_make_no_folder(tmp_path):
    out = tmp_path / "analysis"
    refused("analyse", "--synthetic", "5", "--snapshot", "9", "--out", out,
            named=("--snapshot = 9", "[-6, 5]"))
    assert not out.exists()


@pytest.mark.parametrize("arguments, named", [
    (["--alpha", "200"], ("--alpha", "200", "deg")),
    (["--friction-angle", "-5"], ("--friction-angle", "-5", "deg")),
    (["--sigma0", "inf"], ("--sigma0", "Pa")),
    (["--poisson-ratio", "0.6"], ("--poisson-ratio",)),
])
def test_packing2d_options_are_named_as_typed_in_their_units(tmp_path, arguments, named):
    refused("packing2d", "load", *arguments, "--out", tmp_path / "o", named=named,
            absent=("np.float64", "rad"))


def test_microelement_seed_is_named_as_typed(tmp_path):
    refused("microelement", "run", "--seed", "-1", "--out", tmp_path / "o",
            named=("--seed", "-1"))


# -- a rejected start leaves nothing that blocks the retry ---------------------------------
@pytest.mark.parametrize("wrong", [["--sigma0", "inf"], ["--seed", "-1"], ["-n", "2"]])
def test_a_rejected_start_leaves_no_run_folder(tmp_path, wrong):
    out = tmp_path / "run"
    refused("compaction", "-n", "8", *wrong, "--out", out)
    assert not out.exists() or not any(out.iterdir())


def test_the_corrected_command_runs_after_a_rejected_one(tmp_path):
    out = tmp_path / "run"
    refused("compaction", "-n", "8", "--seed", "1", "--sigma0", "inf", "--out", out)
    result = runner.invoke(app, ["compaction", "-n", "8", "--seed", "1", "--out", str(out),
                                 "--no-progress"])
    assert result.exit_code == 0, result.output
    assert (out / "results.csv").exists()


def test_a_rejected_overwrite_keeps_the_run_that_was_there(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "config.toml").write_text("[sample]\nn_particles = 8\n")
    (out / "results.csv").write_text("kept\n")
    refused("compaction", "-n", "2", "--overwrite", "--out", out, named=("--n-particles",))
    assert (out / "results.csv").read_text() == "kept\n"


# -- help a newcomer can read --------------------------------------------------------------
@pytest.mark.parametrize("command", [["triaxial"], ["compaction"], ["oedometer"], ["demo"],
                                     ["packing2d", "load"], ["microelement", "run"],
                                     ["microelement", "cyclic"]])
def test_help_cites_papers_by_author_and_year(command):
    result = runner.invoke(app, [*command, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    assert "seed 00" not in result.output
    assert any(name in result.output for name in ("Azéma", "Chang"))


def test_help_explains_the_solver_options():
    result = runner.invoke(app, ["triaxial", "--help"], env={"COLUMNS": "200"})
    text = " ".join(result.output.split())
    assert "Gauss-Seidel" in text
    assert "inertia number I = " in text
    for option in ("--tolerance", "--inertia", "--max-iterations"):
        assert option in text
    assert "[default: 1000]" in text and "[default 1000]" not in text
