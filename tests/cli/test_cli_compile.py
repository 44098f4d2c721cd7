"""``grainlab compile``: its parts, a part it does not know named in one line, and every
registered shape kind (one registered for a test too) compiled through its family's tiny
run in its family's part."""

import dataclasses

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.cli.precompile import (
    FAMILY_PARTS,
    FAMILY_TINY_RUNS,
    PARTS,
    _kinds_of,
    _tiny_config,
)
from grainlab.engine.shape_kinds import AGGREGATE, SHAPE_KINDS, SPHERE, ShapeKind

runner = CliRunner()


def test_compile_names_an_unknown_part():
    result = runner.invoke(app, ["compile", "--part", "discrete,nope"])
    assert result.exit_code == 2
    assert "--part" in result.output and "nope" in result.output
    assert all(part in " ".join(result.output.split()) for part in PARTS)


def test_compile_help_says_what_it_does():
    result = runner.invoke(app, ["compile", "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0 and "cached" in result.output


def compiled_kinds() -> dict[str, tuple[ShapeKind, ...]]:
    return {part: _kinds_of(part) for part in PARTS}


def assert_compiled_through_its_family(kind: ShapeKind) -> None:
    """``kind`` is run once, in its family's part, with its family's tiny run."""
    where = [part for part, kinds in compiled_kinds().items() if kind in kinds]
    assert where == [FAMILY_PARTS[kind.narrow_phase]]
    config = _tiny_config(kind)
    assert config.sample.shape == kind.name
    run = FAMILY_TINY_RUNS[kind.narrow_phase]
    for section, updates in run.items():
        written = getattr(config, section).model_dump()
        for key, value in updates.items():
            if isinstance(value, dict):
                assert {k: written[key][k] for k in value} == value
            else:
                assert written[key] == value


COMPILED_KINDS = [kind for kind in SHAPE_KINDS if kind.dimension == 3]
"""The kinds the compile runs: the 3D ones (discs go through the spheres' kernels, same types)."""


@pytest.mark.parametrize("kind", COMPILED_KINDS, ids=lambda kind: kind.name)
def test_compile_runs_every_registered_kind_through_its_family(kind):
    assert_compiled_through_its_family(kind)


def test_compile_runs_each_kind_once_spheres_first():
    """Every registered 3D kind once over the parts; the discrete part starts with spheres
    (its coloured sweep, analyses and export run on the first kind)."""
    runs = [kind for kinds in compiled_kinds().values() for kind in kinds]
    assert sorted(runs, key=lambda kind: kind.code) == COMPILED_KINDS
    assert _kinds_of("discrete")[0] is SPHERE


def test_a_kind_registered_for_a_test_is_compiled_without_an_entry(register_shape_kind,
                                                                   monkeypatch):
    """A new member-sphere kind with a sample maker joins the discrete part with the
    member-sphere run; the compile module is not told about it."""
    from grainlab.prep import sample_shapes

    dimer = register_shape_kind(dataclasses.replace(
        AGGREGATE, name="test_dimer", code=max(k.code for k in SHAPE_KINDS) + 1,
        plural="test_dimers"))
    maker = dataclasses.replace(sample_shapes.SAMPLE_SHAPES[AGGREGATE.name], kind=dimer)
    monkeypatch.setitem(sample_shapes.SAMPLE_SHAPES, dimer.name, maker)
    assert _kinds_of("discrete")[-1] is dimer
    assert_compiled_through_its_family(dimer)
    assert _tiny_config(dimer).with_updates({"sample": {"shape": AGGREGATE.name}}) \
        == _tiny_config(AGGREGATE)
