"""The load path of a discrete run, for an element specimen built from that run's packing.

A discrete run records its :class:`~grainlab.lab.load_path.LoadPath` in its results'
metadata (``load_path``); its stages say what is controlled and how far it goes, in few
steps (the engine's own time steps do the work). :func:`element_path` takes the stages from
a given one on (e.g. the shear after the compaction the packing was snapshotted at) and cuts
each into more steps for an element test (:func:`~grainlab.lab.element_test.run_element_test`):
the same controls, the same total strain and the same stress targets, with the stop criteria
kept.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from grainlab.errors import InputError
from grainlab.lab.load_path import LoadPath, LoadStage


def run_load_path(metadata: Mapping[str, Any]) -> LoadPath:
    """The :class:`LoadPath` recorded in a run's results metadata (``load_path``)."""
    data = metadata.get("load_path") if isinstance(metadata, Mapping) else None
    if not isinstance(data, Mapping):
        raise InputError("metadata['load_path']", type(data).__name__,
                         "the load path of a run's results (results.h5 metadata)")
    stages = [{k: v for k, v in s.items() if k != "boundary"} for s in data["stages"]]
    dimension = data.get("dimension", stages[0]["dimension"] if stages else 3)
    return LoadPath.from_dict({**data, "dimension": dimension, "stages": stages})


def _refined(stage: LoadStage, factor: int) -> LoadStage:
    """``stage`` in ``factor`` times as many steps (module docstring)."""
    if stage.stress_mode == "schedule":
        raise InputError(f"stage {stage.name!r}: stress_mode", stage.stress_mode,
                         "'increment' or 'target' to be cut into more steps")
    values = tuple(v / factor if kind == "strain" or stage.stress_mode == "increment" else v
                   for v, kind in zip(stage.values, stage.control, strict=True))
    return replace(stage, n_steps=stage.n_steps * factor, values=values,
                   rotation_per_step=stage.rotation_per_step / factor)


def element_path(path: LoadPath, first_stage: str, steps_per_step: int) -> LoadPath:
    """The stages of ``path`` from the one named ``first_stage`` on, each step cut into
    ``steps_per_step`` steps (strain and stress increments divided, stress targets kept).

    >>> from grainlab.lab.presets import triaxial_compression
    >>> path = triaxial_compression(confining=1e5, axial_strain=0.1, n_steps=1,
    ...                             consolidation_steps=2)
    >>> shear = element_path(path, "shear", 100).stages[0]
    >>> shear.n_steps, shear.values[2]
    (100, 0.001)
    """
    names = [s.name for s in path.stages]
    if first_stage not in names:
        raise InputError("first_stage", first_stage, "one of the path's stages: "
                         + ", ".join(names))
    if isinstance(steps_per_step, bool) or not isinstance(steps_per_step, int) or \
            steps_per_step < 1:
        raise InputError("steps_per_step", steps_per_step, "an integer >= 1")
    stages = path.stages[names.index(first_stage):]
    return LoadPath(path.name, path.dimension,
                    tuple(_refined(s, steps_per_step) for s in stages),
                    f"{path.description} (from stage {first_stage!r}, each step cut into "
                    f"{steps_per_step})")
