"""Checkpoints of discrete runs: two kept and rotated, a damaged one named and passed over for
the one before (the run still ends bit for bit as the uninterrupted one), none usable: one
message and nothing touched, a full disk: one message and the last good checkpoint kept;
resuming without a checkpoint never deletes a run's files."""

from __future__ import annotations

import errno

import h5py
import numpy as np
import pytest

from grainlab.analysis.snapshot_files import count_snapshots, read_snapshots
from grainlab.lab import run_checkpoint
from grainlab.lab.discrete_run import RESULTS, SNAPSHOTS, resume_run, start_run
from grainlab.lab.run_checkpoint import (
    CHECKPOINT,
    LIBRARY_FIELDS,
    PREVIOUS_CHECKPOINT,
    CheckpointDamaged,
    NoCheckpoint,
    RunStorageError,
    read_checkpoint,
)
from grainlab.lab.run_config import RunConfig
from grainlab.result.test_result import read_test_result

TINY = {  # a compaction of 30 spheres cut short with max_steps: ~0.05 s a step
    "sample": {"n_particles": 30, "seed": 3},
    "test": {"kind": "compaction"},
    "solver": {"sweep": "serial"},
    "output": {"record_every": 5, "checkpoint_every": 20, "snapshot_every": 10},
}


def _step(path) -> int:
    return read_checkpoint(path)["progress"]["step_index"]


def _table(folder):
    return read_test_result(folder / RESULTS).table


def test_the_last_two_checkpoints_are_kept(tmp_path):
    run = start_run(tmp_path / "run", RunConfig.model_validate(TINY))
    run.run(max_steps=45)
    assert _step(tmp_path / "run" / CHECKPOINT) == 40
    assert _step(tmp_path / "run" / PREVIOUS_CHECKPOINT) == 20
    assert not (tmp_path / "run" / (CHECKPOINT + ".tmp")).exists()


def test_resume_from_the_previous_checkpoint_ends_as_the_uninterrupted_run(tmp_path):
    config = RunConfig.model_validate(TINY)
    reference = start_run(tmp_path / "reference", config)
    expected = reference.run(max_steps=70).table
    folder = tmp_path / "run"
    start_run(folder, config).run(max_steps=50)  # checkpoints at steps 20 and 40
    assert len(_table(folder)) == 8 and count_snapshots(folder / SNAPSHOTS) == 5
    data = (folder / CHECKPOINT).read_bytes()
    (folder / CHECKPOINT).write_bytes(data[: len(data) // 3])  # truncated
    run = resume_run(folder)
    said = " ".join(run.notes)
    assert "checkpoint.h5 is damaged (truncated" in said and "checkpoint.prev.h5" in said
    assert run.test.simulation.step_index == 20
    assert (folder / (CHECKPOINT + ".damaged")).exists() and not (folder / CHECKPOINT).exists()
    # rows and snapshots past the checkpoint are cut back to it
    assert list(_table(folder)["step"]) == [5, 10, 15, 20]
    assert count_snapshots(folder / SNAPSHOTS) == 2
    table = run.run(max_steps=50).table
    assert list(table.columns) == list(expected.columns)
    for column in expected.columns:
        np.testing.assert_array_equal(table[column], expected[column], err_msg=column)
    snapshots = list(read_snapshots(folder / SNAPSHOTS))
    assert len(snapshots) == 7
    np.testing.assert_array_equal(snapshots[-1].positions,
                                  list(read_snapshots(tmp_path / "reference" / SNAPSHOTS))[-1]
                                  .positions)
    # the next checkpoint does not rotate the damaged file over the good one
    assert _step(folder / CHECKPOINT) == 60 and _step(folder / PREVIOUS_CHECKPOINT) == 40


@pytest.mark.parametrize("damage", [b"", bytes(range(256)) * 4, "half"])
def test_damaged_checkpoints_are_named_and_the_folder_untouched(tmp_path, damage):
    folder = tmp_path / "run"
    start_run(folder, RunConfig.model_validate(TINY)).run(max_steps=45)
    for name in (CHECKPOINT, PREVIOUS_CHECKPOINT):
        data = (folder / name).read_bytes()
        (folder / name).write_bytes(data[: len(data) // 2] if damage == "half" else damage)
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    with pytest.raises(CheckpointDamaged) as error:
        resume_run(folder)
    said = str(error.value)
    assert "checkpoint.h5 is damaged" in said and "checkpoint.prev.h5 is damaged" in said
    assert "--restart" in said
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before


def test_resume_without_a_checkpoint_keeps_the_files_and_restart_moves_them(tmp_path):
    folder = tmp_path / "run"
    start_run(folder, RunConfig.model_validate(TINY).with_updates(
        {"output": {"checkpoint_every": 0}})).run(max_steps=12)
    (folder / RESULTS).write_text("results of a run killed before its first checkpoint")
    files = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    with pytest.raises(NoCheckpoint, match="no checkpoint"):
        resume_run(folder)
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == files
    run = resume_run(folder, restart=True)
    assert run.test.simulation.step_index == 0
    aside = folder / "previous-1"
    assert (aside / RESULTS).read_bytes() == files[RESULTS]
    assert (aside / SNAPSHOTS).read_bytes() == files[SNAPSHOTS]
    assert (aside / "config.toml").exists() and (folder / "config.toml").exists()
    assert not (folder / RESULTS).exists()
    run.run(max_steps=3)
    assert "started over" in (folder / "run.log").read_text()


def _disk_full(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_a_full_disk_stops_the_run_with_the_last_checkpoint_kept(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    run = start_run(folder, RunConfig.model_validate(TINY))
    run.run(max_steps=25)  # a checkpoint at step 20
    good = (folder / CHECKPOINT).read_bytes()
    results = (folder / RESULTS).read_bytes()

    def half_written(path, contents):  # the disk fills up in the middle of the file
        with h5py.File(path, "w") as handle:
            handle["state"] = np.zeros(10)
        _disk_full()

    monkeypatch.setattr(run_checkpoint, "_write_file", half_written)
    with pytest.raises(RunStorageError) as error:
        run.run(max_steps=20)
    said = str(error.value)
    assert "disk is full" in said and "step 20" in said and "grainlab resume" in said
    assert (folder / CHECKPOINT).read_bytes() == good
    assert (folder / RESULTS).read_bytes() == results
    assert not (folder / (CHECKPOINT + ".tmp")).exists()
    monkeypatch.undo()
    assert resume_run(folder).test.simulation.step_index == 20


def test_a_full_disk_while_writing_the_results_keeps_the_previous_ones(tmp_path, monkeypatch):
    from grainlab.result.test_result import TestResult

    folder = tmp_path / "run"
    run = start_run(folder, RunConfig.model_validate(TINY))
    run.run(max_steps=25)
    results = (folder / RESULTS).read_bytes()
    monkeypatch.setattr(TestResult, "to_csv", _disk_full)
    with pytest.raises(RunStorageError, match="disk is full"):
        run.checkpoint()
    assert (folder / RESULTS).read_bytes() == results
    assert not (folder / (RESULTS + ".tmp")).exists()
    assert _step(folder / CHECKPOINT) == 25


def _library_files(folder):
    return sorted(p.name for p in folder.glob("shapes-*.h5"))


def test_the_shape_library_is_written_once_and_named_by_both_checkpoints(tmp_path):
    folder = tmp_path / "run"
    run = start_run(folder, RunConfig.model_validate(TINY))
    run.run(max_steps=45)
    [name] = _library_files(folder)
    library = run.test.sample.library
    for checkpoint in (CHECKPOINT, PREVIOUS_CHECKPOINT):
        with h5py.File(folder / checkpoint, "r") as handle:
            assert "library" not in handle and handle.attrs["library_file"] == name
        saved = read_checkpoint(folder / checkpoint)["library"]
        for field in LIBRARY_FIELDS:
            np.testing.assert_array_equal(getattr(saved, field), getattr(library, field))
    written = (folder / name).stat().st_mtime_ns
    run.run(max_steps=20)
    assert _library_files(folder) == [name] and (folder / name).stat().st_mtime_ns == written


def test_a_checkpoint_with_its_library_inline_is_read_and_resumed(tmp_path):
    # checkpoints written before the library file held the library in a group of their own
    folder = tmp_path / "run"
    start_run(folder, RunConfig.model_validate(TINY)).run(max_steps=45)
    [name] = _library_files(folder)
    for checkpoint in (CHECKPOINT, PREVIOUS_CHECKPOINT):
        with h5py.File(folder / name, "r") as shapes, \
                h5py.File(folder / checkpoint, "a") as handle:
            shapes.copy("library", handle)
            del handle.attrs["library_file"], handle.attrs["library_digest"]
    (folder / name).unlink()
    run = resume_run(folder)
    assert run.test.simulation.step_index == 40
    run.run(max_steps=20)
    # the next checkpoint writes the library file; the previous one still holds its own
    assert len(_library_files(folder)) == 1
    assert read_checkpoint(folder / PREVIOUS_CHECKPOINT)["progress"]["step_index"] == 40


def test_a_missing_or_foreign_library_file_is_named_and_nothing_touched(tmp_path):
    folder, other = tmp_path / "run", tmp_path / "other"
    start_run(folder, RunConfig.model_validate(TINY)).run(max_steps=45)
    start_run(other, RunConfig.model_validate(TINY).with_updates(
        {"sample": {"n_particles": 31}})).run(max_steps=25)
    [name] = _library_files(folder)
    [foreign] = _library_files(other)
    (folder / name).unlink()
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    with pytest.raises(CheckpointDamaged) as error:
        resume_run(folder)
    said = str(error.value)
    assert f"its shape library {name} is missing" in said and "checkpoint.prev.h5" in said
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before
    (folder / name).write_bytes((other / foreign).read_bytes())  # another run's shapes
    with pytest.raises(CheckpointDamaged, match=f"its shape library {name} holds other shapes"):
        resume_run(folder)


def test_restart_moves_the_library_file_aside_with_the_checkpoints(tmp_path):
    folder = tmp_path / "run"
    start_run(folder, RunConfig.model_validate(TINY)).run(max_steps=25)
    [name] = _library_files(folder)
    run = resume_run(folder, restart=True)
    assert _library_files(folder / "previous-1") == [name]
    assert read_checkpoint(folder / "previous-1" / CHECKPOINT)["progress"]["step_index"] == 20
    run.run(max_steps=25)
    assert _library_files(folder) == [name]  # the same sample: the same shapes
