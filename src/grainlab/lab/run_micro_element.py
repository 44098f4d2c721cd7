"""Seed 001's micro-element model of a discrete run's own packing, ready to follow the run's
load path.

A discrete run (:mod:`grainlab.lab.discrete_run`) snapshots its contact network at the end of
every stage. :func:`compaction_snapshot` takes the one at the end of the compaction, the
state the loading starts from; :func:`run_micro_element_model` builds from it one
micro-element per particle with the run's contact forces as the initial state
(:func:`~grainlab.micromech.micro_element.from_snapshot.micro_elements_from_snapshot`: in a
periodic cell the periodic-image contacts kept, the packing complete; in a box of walls each
particle's unbalanced force given to a contact with a fixed wall, so that the model's stress
is the stress on the walls, as the run measures it), and gives it the run's contact law
(:func:`run_contact_law`):

* soft-contact DEM with linear springs: k_n of the run (``normal_stiffness``, or
  kappa sigma0 <d>), k_s = ``stiffness_ratio`` k_n;
* soft-contact DEM with Hertz-Mindlin: the grains' E (``young_modulus``, or
  (1 - nu^2) sigma0 kappa^(3/2)) and nu, G = E / (2 (1 + nu)) (seed 001 eq. 2.6);
* contact dynamics (rigid grains): the springs the DEM would give the same run (the
  ``[solver.dem]`` defaults of its config, kappa = 1e4 unless told otherwise): a stiffness
  the run never had, so the model's strains at small stress differences are the springs',
  not the run's;

with the interparticle friction of the loading stages (mu = tan phi_mu). <d> is the mean
volume-equivalent diameter of the snapshot's particles (the particles are spheres to the
model). :func:`model_path` is the run's recorded load path from the first stage after the
compaction, each step cut into more (:func:`~grainlab.lab.run_path.element_path`).

Distribution laws (:data:`DISTRIBUTION_READINGS`, the names of ``grainlab microelement
--distribution``): ``homogeneous`` (eq. 2.30), ``maxwellian`` (eq. 2.32 as printed, the
overall C, self-consistent), ``maxwellian-average`` (eq. 2.32 with C_bar) and
``maxwellian-first-order`` (C_bar, eq. 2.35 cut after its first-order term); see
docs/explanations/micro-element.md.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.snapshot_files import read_snapshots
from grainlab.contact.spring_contact import SpringContactLaw
from grainlab.errors import InputError
from grainlab.lab.boundary_registry import DEFAULT_BOUNDARY, boundary_record
from grainlab.lab.load_path import LoadPath
from grainlab.lab.run_config import RunConfig
from grainlab.lab.run_path import element_path
from grainlab.lab.soft_contact_settings import SoftContactSettings
from grainlab.micromech.micro_element.from_snapshot import micro_elements_from_snapshot
from grainlab.micromech.micro_element.model import MicroElementModel
from grainlab.micromech.micro_element.structures import radius_from_volume
from grainlab.result.test_result import TestResult

COMPACTION = "compaction"
"""The stage whose end the model starts from."""

MODEL_KEYS = ("solver.dem.law", "solver.dem.kappa", "solver.dem.normal_stiffness",
              "solver.dem.young_modulus", "solver.dem.poisson_ratio",
              "solver.dem.stiffness_ratio")
"""The config keys the model's contact law reads (:func:`run_contact_law`), whatever the
run's solver: a contact-dynamics run ignores them, its model does not."""

DISTRIBUTION_READINGS: dict[str, dict[str, str]] = {
    "homogeneous": {"distribution": "homogeneous"},
    "maxwellian": {"distribution": "maxwellian", "maxwellian_reference": "overall"},
    "maxwellian-average": {"distribution": "maxwellian", "maxwellian_reference": "average"},
    "maxwellian-first-order": {"distribution": "maxwellian-first-order"},
}
"""The distribution laws of strain a model of a run can take (module docstring), as the
keywords of :class:`~grainlab.micromech.micro_element.model.MicroElementModel`."""


def check_distributions(names: list[str] | tuple[str, ...], field: str = "--distribution"
                        ) -> tuple[str, ...]:
    """``names`` without repeats, each one of :data:`DISTRIBUTION_READINGS`.

    >>> check_distributions(["homogeneous", "maxwellian", "homogeneous"])
    ('homogeneous', 'maxwellian')
    """
    if not names:
        raise InputError(field, "none", "at least one of " + ", ".join(DISTRIBUTION_READINGS))
    for name in names:
        if name not in DISTRIBUTION_READINGS:
            raise InputError(field, name, "one of " + ", ".join(DISTRIBUTION_READINGS))
    return tuple(dict.fromkeys(names))


def compaction_snapshot(snapshots: str | Path) -> ContactNetwork:
    """The last snapshot of ``snapshots`` (a run's snapshots.h5) taken in the compaction:
    the one at its end (the run snapshots the state each stage ends in)."""
    found = None
    path = Path(snapshots)
    if path.is_file():
        for network in read_snapshots(path):
            if network.state.get("stage") == COMPACTION:
                found = network
    if found is None:
        raise InputError("snapshots", str(path), "a run's snapshots.h5 holding the snapshot "
                         "at the end of its compaction (output.snapshot_every > 0)")
    return found


def _parameters(result: TestResult) -> dict[str, Any]:
    parameters = result.metadata.get("parameters", {})
    if not isinstance(parameters.get("settings"), dict) or \
            not isinstance(parameters.get("config"), dict):
        raise InputError("result", result.metadata.get("title", "?"),
                         "the result of a discrete run (its settings and config in metadata)")
    return parameters


def mean_diameter(network: ContactNetwork) -> float:
    """<d> [m]: the mean volume-equivalent diameter of the snapshot's particles."""
    return float(np.mean(2.0 * radius_from_volume(np.asarray(network.volumes),
                                                  network.dimension)))


def _disc_thickness(result: TestResult) -> float:
    """The thickness t [m] of a 2D run's discs (its specimen's ``thickness``)."""
    t = result.metadata.get("specimen", {}).get("thickness")
    if not isinstance(t, int | float) or not t > 0.0:
        raise InputError("specimen.thickness", t, "the discs' thickness > 0 m of a 2D run "
                         "(a sample of discs records it)")
    return float(t)


def run_contact_law(result: TestResult, network: ContactNetwork) -> SpringContactLaw:
    """The model's contact law for a run (module docstring): the run's springs (or those the
    DEM would give it) and the friction of its loading; a 2D run's springs per unit
    thickness, k / t [N/m^2] (its network's forces are per unit thickness:
    :mod:`grainlab.engine.planar`)."""
    parameters = _parameters(result)
    settings = parameters["settings"]
    sigma0 = float(parameters["config"]["test"]["sigma0"])
    dem = settings.get("dem") or parameters["config"].get("solver", {}).get("dem", {})
    soft = SoftContactSettings(**{k: v for k, v in dem.items()
                                  if k in SoftContactSettings.__dataclass_fields__})
    law = soft.law_at(sigma0, mean_diameter(network))
    friction = math.atan(float(settings["shear"]["friction"]))
    per_thickness = _disc_thickness(result) if network.dimension == 2 else 1.0
    if law.model == "linear":
        k_n = law.normal_stiffness / per_thickness
        return SpringContactLaw(friction_angle=friction, normal_stiffness=k_n,
                                shear_stiffness=law.stiffness_ratio * k_n)
    if network.dimension == 2:
        raise InputError("solver.dem.law", law.model, "linear for the model of a run of "
                         "discs (2D): the model's 2D springs are linear, per unit thickness")
    nu = law.poisson_ratio
    return SpringContactLaw(friction_angle=friction,
                            shear_modulus=law.young_modulus / (2.0 * (1.0 + nu)),
                            poisson_ratio=nu)


def run_micro_element_model(result: TestResult, network: ContactNetwork,
                            distribution: str = "homogeneous") -> MicroElementModel:
    """The micro-element model of ``network`` (the run's snapshot at the end of its
    compaction) with the run's law (module docstring) and the reading ``distribution``
    (:data:`DISTRIBUTION_READINGS`); its stress is the snapshot's contact-force stress."""
    check_distributions([distribution], "distribution")
    walls = "drop" if boundary_record(_boundary(result)).periodic else "balance"
    structure = micro_elements_from_snapshot(network, periodic="keep", walls=walls)
    return MicroElementModel(structure, run_contact_law(result, network),
                             **DISTRIBUTION_READINGS[distribution])


def _boundary(result: TestResult) -> str:
    return str(_parameters(result)["config"].get("sample", {}).get("boundary",
                                                                    DEFAULT_BOUNDARY))


def first_loading_stage(path: LoadPath) -> str:
    """The name of the first stage after the compaction."""
    names = [stage.name for stage in path.stages]
    later = names[names.index(COMPACTION) + 1:] if COMPACTION in names else names
    if not later:
        raise InputError("load path", path.name, "a path with a stage after the compaction")
    return later[0]


def model_path(result: TestResult, model_steps: int) -> LoadPath:
    """The run's load path (module docstring) from its first stage after the compaction on,
    cut so that the
    model takes about ``model_steps`` steps in all (at least one per step of the run's path).
    """
    if isinstance(model_steps, bool) or not isinstance(model_steps, int) or model_steps < 1:
        raise InputError("--model-steps", model_steps, "an integer >= 1")
    path = RunConfig.model_validate(_parameters(result)["config"]).load_path()
    first = first_loading_stage(path)
    names = [stage.name for stage in path.stages]
    steps = sum(stage.n_steps for stage in path.stages[names.index(first):])
    return element_path(path, first, max(1, math.ceil(model_steps / max(steps, 1))))
