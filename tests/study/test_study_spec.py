"""Study files: validation names the key, presets are the papers' series."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainlab.errors import InputError
from grainlab.geometry.polyhedron import TABLE_I
from grainlab.study.series_presets import ETAS, LENGTHS, series_spec
from grainlab.study.study_spec import StudySpec

BASE = {"sample": {"n_particles": 40}, "test": {"eps_q_max": 0.2}}


def spec(samples, **study):
    header = {"name": "s", "parameter": "eta", "window": [0.1, 0.2], **study}
    return StudySpec.model_validate({"study": header, "base": BASE, "samples": samples})


def test_sample_config_is_base_with_its_keys_over_it():
    s = spec([{"name": "a", "value": 0.3,
               "set": {"sample": {"shape": "aggregate", "eta": 0.3}}},
              {"name": "b", "value": 0.0}])
    a, b = s.sample_config("a"), s.sample_config("b")
    assert (a.sample.shape, a.sample.eta, a.sample.n_particles) == ("aggregate", 0.3, 40)
    assert (b.sample.shape, b.test.eps_q_max) == ("sphere", 0.2)


def test_round_trip_through_toml(tmp_path):
    s = series_spec("nonconvexity", n_particles=30)
    path = s.write(tmp_path / "study.toml")
    assert StudySpec.read(path) == s


@pytest.mark.parametrize(("samples", "study", "field"), [
    ([{"name": "a", "value": 0, "set": {"sample": {"eta": 5.0}}}], {}, "samples[0].set.sample.eta"),
    ([{"name": "a", "value": 0, "set": {"sample": {"n_particle": 5}}}], {},
     "samples[0].set.sample.n_particle"),
    ([{"name": "a", "value": 0}, {"name": "a", "value": 1}], {}, "samples[1].name"),
    ([{"name": "../a", "value": 0}], {}, "samples[0].name"),
    ([{"name": "a", "value": 0}], {"window": [0.3, 0.2]}, "study.window"),
    ([], {}, "samples"),
])
def test_bad_input_names_the_key(samples, study, field):
    with pytest.raises(InputError) as caught:
        spec(samples, **study)
    assert caught.value.field == field


def test_bad_base_key_is_named_in_base():
    with pytest.raises(InputError) as caught:
        StudySpec.model_validate({"study": {"name": "s"}, "base": {"test": {"sigma0": -1}},
                                  "samples": [{"name": "a", "value": 0}]})
    assert caught.value.field == "base.test.sigma0"


def test_angularity_preset_is_table_one():
    s = series_spec("angularity", n_particles=50, length="full", boundary="walls")
    assert s.names == [f"S{k}" for k in range(1, 9)]
    faces = [s.sample_config(n).sample.n_faces for n in s.names[1:]]
    assert faces == [596, 176, 96, 46, 30, 20, 8]
    assert [x.value for x in s.samples[1:]] == [TABLE_I[f] for f in faces]
    config = s.sample_config("S5")
    assert config.sample.preparation == "deposition"
    assert (config.sample.size_ratio, config.sample.templates) == (2.0, 0)
    assert (config.solver.compaction.friction, config.solver.shear.friction) == (0.0, 0.4)
    assert config.sample.wall_friction == 0.0
    assert config.solver.shear.inertia_number == 1e-3
    assert (config.test.eps_q_max, s.study.window) == (0.9, (0.6, 0.9))
    assert config.sample.height_ratio == 2.0  # room for eps_q = 0.9 (a lab specimen's 2)


def test_nonconvexity_preset_is_seed_003():
    s = series_spec("nonconvexity", length="full", boundary="walls")
    configs = [s.sample_config(n) for n in s.names]
    assert [c.sample.shape for c in configs] == ["sphere"] + ["aggregate"] * 7
    assert [c.sample.eta for c in configs[1:]] == list(ETAS[1:])
    assert all(c.sample.size_ratio == 3.0 for c in configs)
    assert all(c.sample.n_particles == 1000 for c in configs)
    assert s.study.window == (0.5, 0.9)
    # one skeleton per series: every sample has the same seed and sizes
    assert len({(c.sample.seed, c.sample.d_min, c.sample.size_ratio) for c in configs}) == 1


def test_unknown_series_and_length():
    with pytest.raises(InputError) as caught:
        series_spec("elongation")
    assert caught.value.field == "series"
    with pytest.raises(InputError) as caught:
        series_spec("angularity", length="long")
    assert caught.value.field == "length"


@pytest.mark.parametrize("name", ["angularity", "nonconvexity"])
def test_every_length_keeps_the_papers_protocol_and_its_window_inside_the_path(name):
    """A length changes how far and how large, never the protocol: the same friction,
    inertia number, walls and preparation; its window ends at the strain the samples reach,
    and snapshots fall in it."""
    for length, spec in LENGTHS.items():
        s = series_spec(name, length=length, boundary="walls")
        config = s.sample_config(s.names[-1])
        lo, hi = s.study.window
        assert 0.0 < lo < hi == config.test.eps_q_max == spec.eps_q_max, length
        assert config.sample.n_particles == spec.particles
        assert config.sample.height_ratio == spec.height_ratio
        assert (config.solver.compaction.friction, config.solver.shear.friction) == (0.0, 0.4)
        assert config.solver.shear.inertia_number == 1e-3
        assert config.sample.preparation == "deposition"
        steps_in_window = 1100.0 * (spec.particles / 60.0) ** (1 / 3) * (hi - lo)
        assert steps_in_window / config.output.snapshot_every >= spec.snapshots_per_window


def test_the_study_lengths_are_ordered():
    order = sorted(LENGTHS.values(), key=lambda length: length.eps_q_max)
    assert [length.particles for length in order] == sorted(length.particles
                                                            for length in order)


@pytest.mark.parametrize("name", ["angularity", "nonconvexity"])
@pytest.mark.parametrize("length", list(LENGTHS))
def test_the_periodic_presets_run_loose_samples_in_a_cell_large_enough(name, length):
    from grainlab.study.series_presets import cell_height_ratio, cell_particles
    walls = series_spec(name, length=length, boundary="walls")
    cell = series_spec(name, length=length, boundary="periodic")
    assert cell.names == walls.names
    size_ratio = walls.sample_config(walls.names[0]).sample.size_ratio
    raised = 0
    for sample in cell.names:
        config, boxed = cell.sample_config(sample), walls.sample_config(sample)
        assert config.sample.boundary == "periodic" and config.sample.preparation == "loose"
        # the study's count is a floor, raised to the room the sample's cell needs
        table = {"shape": config.sample.shape, "eta": config.sample.eta,
                 "n_faces": config.sample.n_faces, "templates": config.sample.templates}
        needed = cell_particles(table, length, size_ratio)
        assert config.sample.n_particles == max(boxed.sample.n_particles, needed)
        raised += config.sample.n_particles > boxed.sample.n_particles
        # as narrow after the compaction as at the end of the shear, which shortens it
        assert config.sample.height_ratio == pytest.approx(
            math.exp(2.0 / 3.0 * config.test.eps_q_max), abs=1e-3)
        assert config.sample.height_ratio == cell_height_ratio(length)
        # the same protocol otherwise: shapes, sizes, friction, rate, path and window
        for field in ("shape", "eta", "n_faces", "templates", "size_ratio", "seed"):
            assert getattr(config.sample, field) == getattr(boxed.sample, field), field
        assert config.solver == boxed.solver and config.test == boxed.test
    assert cell.study.window == walls.study.window
    assert "periodic cell" in cell.study.description
    assert ("more where a cell needs the room" in cell.study.description) == (raised > 0)
    # a number of particles asked for is kept where the cell has the room
    assert series_spec(name, length=length, boundary="periodic",
                       n_particles=900).sample_config(cell.names[0]).sample.n_particles == 900


@pytest.mark.parametrize("name, sample, length", [
    ("angularity", "S8", "short"), ("nonconvexity", "eta-0.7", "full"),
    ("angularity", "S1", "smoke")])
def test_a_periodic_sample_keeps_the_room_of_the_detection_with_its_own_particles(
        name, sample, length):
    """The particle count of a periodic preset, checked against the particles it draws: a
    cell of its height ratio compacted to the densest packing fraction assumed (0.75) keeps
    its sides, and its height once the shear has shortened it by exp(-2/3 eps_q), above
    3.15 (d_max + alert); and it does not ask for a quarter more particles than the drawn
    ones need."""
    from grainlab.prep.loose_sample import diameters_uniform_by_volume
    from grainlab.prep.sample_shapes import sample_shape

    config = series_spec(name, length=length, boundary="periodic").sample_config(sample)
    s = config.sample
    rng = np.random.default_rng(s.seed)
    d = diameters_uniform_by_volume(s.n_particles, 1.0, s.size_ratio, rng)
    shape = sample_shape(s.shape)
    library, _ = shape.make_library(0.5 * d, rng, **{k: getattr(s, k) for k in shape.parameters})
    d_max = 2.0 * float(library.bounding_radius.max())
    width = (float(library.volume.sum()) / (0.75 * s.height_ratio)) ** (1.0 / 3.0)
    narrowest = min(width, s.height_ratio * width * math.exp(-2.0 / 3.0 * config.test.eps_q_max))
    limit = 1.05 * 3.0 * (d_max + 0.05)
    assert narrowest >= limit
    needed = s.n_particles * (limit / narrowest) ** 3
    assert s.n_particles <= 1.25 * needed


@pytest.mark.parametrize("name", ["angularity", "nonconvexity"])
def test_a_full_study_runs_in_a_cell_and_a_quick_one_in_walls_unless_told(name):
    """The papers' values are the bulk's: a full study runs in a periodic cell by default, a
    smoke or short one in the papers' box; --boundary overrides either."""
    for length, expected in (("smoke", "walls"), ("short", "walls"), ("full", "periodic")):
        assert LENGTHS[length].boundary == expected
        default = series_spec(name, length=length, n_particles=50)
        told = series_spec(name, length=length, n_particles=50, boundary=expected)
        assert default == told, length
        other = "walls" if expected == "periodic" else "periodic"
        overridden = series_spec(name, length=length, n_particles=50, boundary=other)
        first = overridden.sample_config(overridden.names[0]).sample
        assert first.boundary == ("periodic" if other == "periodic" else "walls")
        assert ("periodic cell" in overridden.study.description) == (other == "periodic")


def test_an_unknown_boundary_is_refused_by_name():
    with pytest.raises(InputError, match="boundary"):
        series_spec("angularity", boundary="spherical")


@pytest.mark.parametrize("name, expected", [
    ("angularity", ("S1", "S4", "S8")), ("nonconvexity", ("eta-0.0", "eta-0.3", "eta-0.7"))])
def test_replicas_repeat_the_ends_and_middle_of_a_series_with_other_packing_seeds(
        name, expected, tmp_path):
    single = series_spec(name, length="full", seed=3)
    repeated = series_spec(name, length="full", seed=3, replicas=3)
    # one replica is the series as it was: study folders made before resume
    assert series_spec(name, length="full", seed=3, replicas=1) == single
    assert repeated.names[:8] == single.names
    extra = repeated.samples[8:]
    assert [s.name for s in extra] == [f"{n}-seed{s}" for s in (4, 5) for n in expected]
    for sample in extra:
        of = repeated.sample(sample.replica_of)
        assert sample.value == of.value and not of.replica_of
        config, base = repeated.sample_config(sample.name), repeated.sample_config(of.name)
        assert config.sample.seed == int(sample.name.rsplit("seed", 1)[1]) != base.sample.seed
        # the same shape and protocol otherwise
        assert config.sample.model_copy(update={"seed": 3}) == base.sample
        assert config.solver == base.solver and config.test == base.test
    # written and read back: a sample of its own carries no replica_of
    path = repeated.write(tmp_path / "study.toml")
    assert StudySpec.read(path) == repeated
    assert path.read_text().count("replica_of") == len(extra)


def test_replicas_are_refused_by_name_where_they_make_no_sense():
    with pytest.raises(InputError) as error:
        series_spec("angularity", replicas=2, replicated=("S1", "S9"))
    assert error.value.field == "replicated" and error.value.value == "S9"
    with pytest.raises(InputError) as error:
        series_spec("nonconvexity", replicas=0)
    assert error.value.field == "replicas"
    base = {"study": {"name": "s", "parameter": "eta", "window": [0.1, 0.2]},
            "base": {"sample": {"shape": "aggregate", "n_particles": 40}}}
    a = {"name": "a", "value": 0.1, "set": {"sample": {"eta": 0.1}}}
    for k, (replica, field) in enumerate([
            ({"name": "b", "value": 0.1, "replica_of": "z"}, "samples[1].replica_of"),
            ({"name": "b", "value": 0.2, "replica_of": "a"}, "samples[1].value"),
            ({"name": "b", "value": 0.1, "replica_of": "b"}, "samples[1].replica_of")]):
        with pytest.raises(InputError) as error:
            StudySpec.model_validate({**base, "samples": [a, replica]})
        assert error.value.field == field, k
    # a replica of a replica
    with pytest.raises(InputError) as error:
        StudySpec.model_validate({**base, "samples": [
            a, {"name": "b", "value": 0.1, "replica_of": "a"},
            {"name": "c", "value": 0.1, "replica_of": "b"}]})
    assert error.value.field == "samples[2].replica_of"


@pytest.mark.parametrize("series, folder", [
    ("angularity", "studies/angularity-periodic-1000"),
    ("nonconvexity", "docs/studies/nonconvexity-periodic-1000")])
def test_the_committed_series_are_what_the_bare_full_command_builds(series, folder):
    """`grainlab study SERIES --length full -n 1000 --replicas 3` (the issue's command with
    its seeds option) builds the very study the committed series ran: a rerun from a clean
    clone runs the same samples with the same settings, and `grainlab study compare` reads
    it against them."""
    from pathlib import Path
    committed = StudySpec.read(Path(__file__).parents[2] / folder / "study.toml")
    assert series_spec(series, length="full", n_particles=1000, replicas=3) == committed
