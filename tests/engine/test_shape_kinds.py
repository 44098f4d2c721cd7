"""The shape-kind registry: complete records, lookups by name and by code, unknown kinds
refused with the registered names, each kind's time-step length against a hand computation,
and the tables of the other layers (sample makers, drawers, compile runs, the CLI's
``--shape``, the config's allowed shapes) keyed by the registry's names."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from grainlab.engine.shape_kinds import (
    AGGREGATE,
    MEMBER_SPHERES,
    NARROW_PHASE_FAMILIES,
    PAIR_TYPINGS,
    POLYHEDRON,
    POLYHEDRON_FEATURES,
    SHAPE_KIND_NAMES,
    SHAPE_KINDS,
    SPHERE,
    ShapeKind,
    family_mask,
    kinds_present,
    library_time_step_length,
    shape_kind,
)
from grainlab.engine.state import ShapeLibrary
from grainlab.errors import InputError
from grainlab.geometry.polyhedron import from_vertices
from grainlab.geometry.sphere_aggregate import SphereAggregate


def cube(side: float):
    return from_vertices([[x, y, z] for x in (0.0, side) for y in (0.0, side)
                          for z in (0.0, side)])


@pytest.mark.parametrize("kind", SHAPE_KINDS, ids=SHAPE_KIND_NAMES)
def test_every_kind_has_every_field(kind):
    for field in dataclasses.fields(ShapeKind):
        value = getattr(kind, field.name)
        if field.name != "pair_typing":
            assert value is not None and value != "", field.name
    assert isinstance(kind.code, int) and kind.code >= 0
    assert kind.plural and kind.plural != kind.name
    assert kind.description and "\n" not in kind.description
    assert kind.narrow_phase in NARROW_PHASE_FAMILIES
    assert kind.pair_typing is None or kind.pair_typing in PAIR_TYPINGS
    assert isinstance(kind.spins_fast, bool)
    assert callable(kind.time_step_length)


def test_names_and_codes_are_unique_and_in_code_order():
    assert SHAPE_KIND_NAMES == ("sphere", "aggregate", "polyhedron", "disc")
    assert [k.code for k in SHAPE_KINDS] == [0, 1, 2, 3]  # in checkpoints: never renumber
    assert [k.dimension for k in SHAPE_KINDS] == [3, 3, 3, 2]
    assert len({k.name for k in SHAPE_KINDS}) == len({k.code for k in SHAPE_KINDS}) \
        == len(SHAPE_KINDS)


@pytest.mark.parametrize("kind", SHAPE_KINDS, ids=SHAPE_KIND_NAMES)
def test_lookups_by_name_and_by_code_agree(kind):
    assert shape_kind(kind.name) is shape_kind(kind.code) is kind
    assert shape_kind(np.int64(kind.code)) is kind


@pytest.mark.parametrize("key", ["cube", "Sphere", 7, -1, True, None, 1.0])
def test_an_unknown_kind_is_refused_with_the_registered_ones(key):
    with pytest.raises(InputError) as error:
        shape_kind(key, field="sample.shape")
    assert error.value.field == "sample.shape"
    for kind in SHAPE_KINDS:
        assert repr(kind.name) in error.value.allowed
        assert f"({kind.code})" in error.value.allowed


def test_what_each_kind_says_today():
    """Polyhedra go through the feature kernels, shorten the step to their own speeds and
    type pairs by features; spheres and aggregates share the member-sphere geometry."""
    assert [k.narrow_phase for k in SHAPE_KINDS] == [MEMBER_SPHERES, MEMBER_SPHERES,
                                                     POLYHEDRON_FEATURES, MEMBER_SPHERES]
    assert [k.spins_fast for k in SHAPE_KINDS] == [False, False, True, False]
    assert [k.pair_typing for k in SHAPE_KINDS] == [None, "member_classes", "feature_types",
                                                    None]
    assert [k.plural for k in SHAPE_KINDS] == ["spheres", "aggregates", "polyhedra", "discs"]


def test_a_record_with_an_unknown_family_is_refused():
    with pytest.raises(InputError, match="narrow_phase"):
        dataclasses.replace(SPHERE, narrow_phase="ellipsoid_support")


# -- time-step length -----------------------------------------------------------------------


def test_time_step_length_of_a_sphere_is_its_diameter():
    r = 0.37
    library = ShapeLibrary.from_spheres([r])
    assert SPHERE.time_step_length(library, np.array([0])) == 2.0 * r


def test_time_step_length_of_an_aggregate_is_its_smallest_member_diameter():
    aggregate = SphereAggregate.from_spheres(
        np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.45, 0.0]]),
        np.array([0.3, 0.1, 0.2]))
    library = ShapeLibrary.from_aggregates([aggregate])
    assert AGGREGATE.time_step_length(library, np.array([0])) == pytest.approx(0.2, rel=1e-15)


def test_time_step_length_of_a_cube_is_its_side():
    a = 0.7
    library = ShapeLibrary.from_polyhedra([cube(a)])
    assert POLYHEDRON.time_step_length(library, np.array([0])) == pytest.approx(a, rel=1e-12)


def test_time_step_length_of_a_mixed_library_is_the_smallest_kind():
    library = ShapeLibrary.from_polyhedra([cube(2.0), cube(1.0)]).concatenate(
        ShapeLibrary.from_spheres([3.0, 0.8]))
    assert POLYHEDRON.time_step_length(library, np.array([0, 1])) == pytest.approx(1.0)
    assert POLYHEDRON.time_step_length(library, np.array([0])) == pytest.approx(2.0)
    assert SPHERE.time_step_length(library, np.array([2, 3])) == 1.6
    assert library_time_step_length(library) == pytest.approx(1.0)


# -- helpers --------------------------------------------------------------------------------


def test_kinds_present_and_family_masks():
    codes = np.array([2, 0, 2, 0])
    assert kinds_present(codes) == (SPHERE, POLYHEDRON)
    np.testing.assert_array_equal(family_mask(codes, POLYHEDRON_FEATURES),
                                  [True, False, True, False])
    np.testing.assert_array_equal(family_mask(codes, MEMBER_SPHERES),
                                  [False, True, False, True])
    with pytest.raises(InputError, match="family"):
        family_mask(codes, "ellipsoids")
    with pytest.raises(InputError) as error:
        kinds_present([0, 5], field="library.kind")
    assert error.value.field == "library.kind"


def test_a_library_with_an_unregistered_code_is_refused():
    with pytest.raises(InputError) as error:
        ShapeLibrary(kind=[9], sphere_start=[0], sphere_count=[1], sphere_offsets=np.zeros((1, 3)),
                     sphere_radii=[1.0], volume=[1.0], principal_inertia=np.ones((1, 3)),
                     bounding_radius=[1.0])
    assert error.value.field == "kind[0]" and "'polyhedron' (2)" in error.value.allowed


# -- the tables of the other layers follow the registry --------------------------------------


def test_every_kind_has_a_sample_maker_and_a_drawer():
    from grainlab.prep.sample_shapes import SAMPLE_SHAPES
    from grainlab.report.shape_drawing import SHAPE_KIND_DRAWERS

    assert tuple(SAMPLE_SHAPES) == SHAPE_KIND_NAMES
    assert all(SAMPLE_SHAPES[k.name].kind is k for k in SHAPE_KINDS)
    assert tuple(SHAPE_KIND_DRAWERS) == SHAPE_KIND_NAMES


def test_every_family_has_a_compile_run_and_a_part():
    from grainlab.cli.precompile import FAMILY_PARTS, FAMILY_TINY_RUNS, PARTS

    assert set(FAMILY_TINY_RUNS) == set(NARROW_PHASE_FAMILIES)
    assert set(FAMILY_PARTS) == set(NARROW_PHASE_FAMILIES)
    assert set(FAMILY_PARTS.values()) <= set(PARTS)


def test_the_config_allows_the_registered_shapes_and_names_them():
    from grainlab.lab.run_config import RunConfig

    for name in SHAPE_KIND_NAMES:
        assert RunConfig.model_validate({"sample": {"shape": name}}).sample.shape == name
    for bad in ("cube", 2, None):
        with pytest.raises(InputError) as error:
            RunConfig.model_validate({"sample": {"shape": bad}})
        assert error.value.field == "sample.shape"
        assert error.value.allowed == "one of 'sphere', 'aggregate', 'polyhedron', 'disc'"


def test_a_hypothetical_kind_registered_for_samples_reaches_the_config(monkeypatch):
    """The config reads the makers' table when it validates, not a copy of the names."""
    from grainlab.lab.run_config import RunConfig
    from grainlab.prep import sample_shapes

    cube_kind = dataclasses.replace(POLYHEDRON, name="cube", code=3, plural="cubes")
    maker = dataclasses.replace(sample_shapes.SAMPLE_SHAPES["polyhedron"], kind=cube_kind)
    monkeypatch.setitem(sample_shapes.SAMPLE_SHAPES, "cube", maker)
    assert RunConfig.model_validate({"sample": {"shape": "cube"}}).sample.shape == "cube"
    with pytest.raises(InputError) as error:
        RunConfig.model_validate({"sample": {"shape": "cylinder"}})
    assert "'cube'" in error.value.allowed


def test_the_cli_shape_help_lists_every_registered_shape():
    from grainlab.cli.run_options import SHAPE_HELP
    from grainlab.prep.sample_shapes import SAMPLE_SHAPES

    for name, maker in SAMPLE_SHAPES.items():
        assert f"{name} ({maker.description})" in SHAPE_HELP


def test_a_library_takes_its_kind_of_the_right_family_only():
    """from_aggregates and from_polyhedra write the kind they are given (aggregates and
    polyhedra unless told); a kind of the other family is refused naming the field."""
    pair = SphereAggregate.from_spheres(np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]]),
                                        np.array([0.4, 0.4]))
    assert ShapeLibrary.from_aggregates([pair]).kind.tolist() == [AGGREGATE.code]
    assert ShapeLibrary.from_aggregates([pair], SPHERE).kind.tolist() == [SPHERE.code]
    assert ShapeLibrary.from_polyhedra([cube(1.0)]).kind.tolist() == [POLYHEDRON.code]
    for make, shape, kind in ((ShapeLibrary.from_aggregates, pair, POLYHEDRON),
                              (ShapeLibrary.from_polyhedra, cube(1.0), AGGREGATE)):
        with pytest.raises(InputError) as error:
            make([shape], kind)
        assert error.value.field == "kind" and error.value.value == kind.name
    with pytest.raises(InputError, match="kind"):  # a record not in the registry
        ShapeLibrary.from_aggregates([pair], dataclasses.replace(AGGREGATE, code=99))
