"""Seed 001's micro-element model from names and a few numbers: structures, laws, load paths.

The command line (``grainlab microelement``) and scripts build a consolidated specimen in two
calls::

    structure = build_structure("idealized", seed=1)
    model = build_model(structure)                 # the defaults below, consolidated
    parameters = default_path_parameters("triaxial_compression", model)

Structures (:func:`build_structure`)
------------------------------------
==============  ==========================================================================
name            structure
==============  ==========================================================================
``idealized``   seed 001 §4.2: 30 micro-elements of 8 spheres (:func:`idealized_material`)
``binary``      seed 001 §4.1: 12 binary units along the icosahedron axes
                (:func:`binary_units`; r = 0.2 mm, e = 0.7, n_bar = 7)
``chang2d``     seed 001 ch. 3: micro-elements of the random periodic packing of 12 + 13
                discs (:func:`chang_periodic_discs` -> :func:`from_disc_packing`); making
                the packing takes seconds to minutes, depending on the seed
FILE ``.h5``    a contact-network snapshot file of a discrete run (:func:`read_snapshot`
                -> :func:`micro_elements_from_snapshot`): one micro-element per particle,
                the run's contact forces as the initial state (no consolidation);
                ``forces=False``: :func:`from_contact_network`, consolidated from zero
FILE ``.toml``  a periodic disc packing, or a ``.csv`` one (:func:`read_packing` ->
                :func:`from_disc_packing`)
==============  ==========================================================================

Defaults per structure (:func:`structure_defaults`, seed 001 §3 and §4)
-----------------------------------------------------------------------
=============  =======================================================  =====  ==========
structure      contact law                                              phi    sigma0
=============  =======================================================  =====  ==========
idealized      linear, k_n = k_s = 1e5 N/m (§4.2)                       25°    100 kPa
binary         Hertz–Mindlin, G = 29 GPa, nu = 0.2 (quartz, §4.1)       25°    100 kPa
chang2d        linear, k_n = 200 kN/m = 2e5 N/m, k_s/k_n = 1 (§3)       25°    203 kPa
=============  =======================================================  =====  ==========

Distribution law: homogeneous (eq. 2.30) for every structure unless told otherwise. Under it
the unit never fails (contacts near the major principal axis stay elastic). With
``distribution="maxwellian"`` and its default reference, the overall C of eq. 2.32
(self-consistent), the unit fails, at angles below the report's (a lower bound; it needs steps
of <= 0.005 eps_ref to converge). ``distribution="maxwellian-first-order"`` (C_bar, the series
of eq. 2.35 cut after its first-order term) gives the report's cubical strengths at constant
sigma_3, with defects (G^n not positive definite, dependence on the step and the seed); see
docs/validation/micro-element-report.md for the four readings side by side.

A snapshot file takes the ``idealized`` defaults in 3D and the ``chang2d`` ones in 2D; a
packing file those of ``chang2d``. A structure that carries its snapshot's forces
(``initial_forces``) is not consolidated: sigma0 does not apply to it.

Units in 2D. A 2D structure holds areas [m^2], so its stress sum (1/2A) sum f L is a force per
unit thickness over an area: the springs must be given per unit thickness [N/m^2] for the
stresses to come out in Pa. :func:`build_model` takes the stiffness of one contact [N/m] of
discs of thickness t and uses k/t (``thickness``; default: the mean diameter of the centre
discs, so that a disc is as thick as it is wide). With t = 1 m a k_n of 200 kN/m would give
strains of order one at 203 kPa.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainlab.analysis.snapshot_files import read_snapshot
from grainlab.contact.spring_contact import SpringContactLaw
from grainlab.errors import InputError
from grainlab.lab.presets import preset_names
from grainlab.micromech.micro_element.from_snapshot import micro_elements_from_snapshot
from grainlab.micromech.micro_element.model import DISTRIBUTIONS, MicroElementModel
from grainlab.micromech.micro_element.structure import MicroElementStructure
from grainlab.micromech.micro_element.structures import (
    binary_units,
    chang_periodic_discs,
    from_contact_network,
    from_disc_packing,
    idealized_material,
)
from grainlab.prep.packing_files import read_packing

STRUCTURE_NAMES = ("idealized", "binary", "chang2d")
"""Named structures of :func:`build_structure` (a file path is the other choice)."""

SNAPSHOT_SUFFIXES = (".h5", ".hdf5")
PACKING_SUFFIXES = (".toml", ".csv")
LAWS = ("linear", "hertz")
SPINS = ("none", "micro-element", "uniform")

CONSOLIDATION_TOLERANCE = 1e-6
"""Relative stress error accepted at the end of the isotropic consolidation [-] (that of
:func:`grainlab.lab.element_test.run_element_test`; tighter values can stall on the
geometry updates of 2D packings without making the stress any better)."""

SIMPLE_SHEAR_VERTICAL_RATIO = 1.344
"""Seed 001 §4.2.4 consolidates one-dimensionally to 134.4 kPa before simple shear: 1.344
times the 100 kPa of the idealized material's isotropic state."""


@dataclass(frozen=True)
class StructureDefaults:
    """Contact law and isotropic stress a structure is used with unless told otherwise.

    Attributes
    ----------
    law:
        ``"linear"`` (constant springs) or ``"hertz"`` (Hertz–Mindlin).
    normal_stiffness:
        k_n [N/m] of one contact (linear law).
    shear_stiffness_ratio:
        k_s / k_n [-] (linear law).
    shear_modulus, poisson_ratio:
        Grain G_mu [Pa] and nu_mu [-] (Hertz–Mindlin).
    friction_angle_deg:
        phi_mu [deg].
    sigma0:
        Isotropic consolidation stress [Pa].
    spin:
        Particle spin option of :class:`MicroElementModel`.
    distribution:
        Distribution law of :class:`MicroElementModel` (``"maxwellian"`` uses the
        self-consistent reference of eq. 2.32 unless told otherwise).
    source:
        Where the numbers come from.
    """

    law: str
    normal_stiffness: float
    shear_stiffness_ratio: float
    shear_modulus: float
    poisson_ratio: float
    friction_angle_deg: float
    sigma0: float
    spin: str
    source: str
    distribution: str = "homogeneous"


DEFAULTS = {
    "idealized": StructureDefaults("linear", 1e5, 1.0, 29e9, 0.2, 25.0, 100e3, "none",
                                   "seed 001 §4.2 (k_n = k_s = 1e5 N/m, phi_mu = 25 deg)"),
    "binary": StructureDefaults("hertz", 1e5, 1.0, 29e9, 0.2, 25.0, 100e3, "uniform",
                                "seed 001 §4.1 (Hertz-Mindlin, quartz G = 29 GPa, nu = 0.2)"),
    "chang2d": StructureDefaults("linear", 2e5, 1.0, 29e9, 0.2, 25.0, 203e3, "none",
                                 "seed 001 ch. 3 (k_n = 200 kN/m, k_s/k_n = 1, "
                                 "sigma0 = 203 kPa)"),
}

_BINARY_DEFAULTS = {"directions": "icosahedron", "radius": 0.2e-3, "void_ratio": 0.7,
                    "coordination_number": 7.0}
_NETWORK_OPTIONS = ("index", "volumes", "active_only", "threshold")
_SNAPSHOT_OPTIONS = ("index", "volumes", "periodic", "walls", "wall_threshold", "forces")
"""Options of a snapshot file taken with its forces (``forces=True``, the default)."""
_PACKING_OPTIONS = ("tolerance",)


def _check_options(where: str, options: dict[str, Any], allowed: tuple[str, ...]) -> None:
    for key, value in options.items():
        if key not in allowed:
            raise InputError(f"{where} option {key!r}", value,
                             "one of " + ", ".join(allowed) if allowed else "no options")


def _keyword_names(function: Callable[..., Any], skip: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(k for k in inspect.signature(function).parameters if k not in skip)


def build_structure(name: str, seed: int = 1, **options: Any) -> MicroElementStructure:
    """The micro-elements of a named structure or of a file (module docstring table).

    Parameters
    ----------
    name:
        ``"idealized"``, ``"binary"``, ``"chang2d"`` or the path of a snapshot file
        (``.h5``) or a packing file (``.toml``/``.csv``).
    seed:
        Seed of the random structures (idealized, chang2d); unused otherwise.
    options:
        Keyword arguments of the generator, each checked by name: idealized
        ``n_random, n_neighbours, radius, void_ratio``; binary ``directions, radius,
        void_ratio, coordination_number, dimension``; chang2d ``n_large, r_large, n_small,
        r_small, max_rattlers, max_attempts``; snapshot file ``index`` (default -1, the last)
        and ``forces`` (default True: the run's contact forces are the initial state,
        :func:`micro_elements_from_snapshot` with ``periodic`` "keep"/"drop", ``walls``
        "drop"/"balance", ``volumes``, ``wall_threshold``; False: geometry only,
        :func:`from_contact_network` with ``volumes, active_only, threshold``, consolidated
        by :func:`build_model`); packing file ``tolerance``.

    Raises
    ------
    InputError
        Unknown name, missing or unreadable file, unknown option (the field is named).

    >>> build_structure("idealized", seed=1).n_elements
    30
    """
    if not isinstance(name, str | Path) or not str(name).strip():
        raise InputError("--structure", name, _structure_choices())
    key = str(name).strip()
    if key == "idealized":
        _check_options("idealized", options, _keyword_names(idealized_material, ("seed",)))
        return idealized_material(seed=seed, **options)
    if key == "binary":
        _check_options("binary", options, tuple(_keyword_names(binary_units, ())))
        return binary_units(**{**_BINARY_DEFAULTS, **options})
    if key == "chang2d":
        _check_options("chang2d", options, _keyword_names(chang_periodic_discs, ("seed",)))
        return from_disc_packing(chang_periodic_discs(seed=seed, **options))
    path = Path(key)
    suffix = path.suffix.lower()
    if suffix not in SNAPSHOT_SUFFIXES + PACKING_SUFFIXES:
        raise InputError("--structure", key, _structure_choices())
    if not path.is_file():
        raise InputError("--structure", key, "an existing file (" + _structure_choices() + ")")
    if suffix in SNAPSHOT_SUFFIXES:
        forces = options.pop("forces", True)
        if not isinstance(forces, bool | np.bool_):
            raise InputError("snapshot file option 'forces'", forces, "True or False")
        _check_options("snapshot file", options,
                       _SNAPSHOT_OPTIONS if forces else _NETWORK_OPTIONS)
        index = options.pop("index", -1)
        if isinstance(index, bool) or not isinstance(index, int):
            raise InputError("snapshot file option 'index'", index, "an integer")
        if forces:
            return micro_elements_from_snapshot(read_snapshot(path, index), **options)
        return from_contact_network(read_snapshot(path, index), **options)
    _check_options("packing file", options, _PACKING_OPTIONS)
    return from_disc_packing(read_packing(path), **options)


def _structure_choices() -> str:
    return ("idealized, binary, chang2d, a snapshot file (.h5) or a packing file "
            "(.toml, .csv)")


def structure_kind(structure: MicroElementStructure) -> str:
    """The key of :data:`DEFAULTS` a structure takes its defaults from (module docstring)."""
    generator = structure.description.get("generator")
    if generator == "binary_units":
        return "binary"
    if generator == "idealized_material":
        return "idealized"
    return "chang2d" if structure.dimension == 2 else "idealized"


def structure_defaults(structure: MicroElementStructure) -> StructureDefaults:
    """The :class:`StructureDefaults` of a structure (see :func:`structure_kind`).

    >>> structure_defaults(build_structure("binary")).law
    'hertz'
    """
    return DEFAULTS[structure_kind(structure)]


def _positive(field: str, value: Any, unit: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(field, value, f"a positive number in {unit}") from None
    if not (math.isfinite(number) and number > 0.0):
        raise InputError(field, value, f"a positive number in {unit}")
    return number


def build_law(
    structure: MicroElementStructure,
    *,
    law: str | None = None,
    normal_stiffness: float | None = None,
    shear_stiffness: float | None = None,
    friction_angle_deg: float | None = None,
    shear_modulus: float | None = None,
    poisson_ratio: float | None = None,
    thickness: float | None = None,
) -> SpringContactLaw:
    """The contact law for ``structure``: given values, else :func:`structure_defaults`.

    Linear springs take ``normal_stiffness`` k_n and ``shear_stiffness`` k_s [N/m] (default
    k_s = (k_s/k_n of the defaults) k_n); Hertz–Mindlin takes ``shear_modulus`` [Pa] and
    ``poisson_ratio`` [-] of the grains (3D only). ``friction_angle_deg`` phi_mu in degrees.
    In 2D the spring stiffnesses are divided by the disc ``thickness`` [m] (module docstring;
    default: the mean centre-disc diameter).

    Raises
    ------
    InputError
        Options of the other law given (e.g. ``--kn`` with ``--law hertz``), Hertz in 2D,
        non-positive numbers.
    """
    defaults = structure_defaults(structure)
    law = defaults.law if law is None else law
    if law not in LAWS:
        raise InputError("--law", law, "'linear' or 'hertz'")
    phi = defaults.friction_angle_deg if friction_angle_deg is None else friction_angle_deg
    try:
        phi_value = float(phi)
    except (TypeError, ValueError):
        phi_value = math.nan
    if not 0.0 <= phi_value < 90.0:
        raise InputError("--friction-angle", phi, "an angle in [0, 90) degrees")
    friction = math.radians(phi_value)
    if law == "hertz":
        for field, value in (("--kn", normal_stiffness), ("--ks", shear_stiffness),
                             ("--thickness", thickness)):
            if value is not None:
                raise InputError(field, value, "no value with --law hertz (give "
                                 "--shear-modulus and --poisson-ratio)")
        if structure.dimension != 3:
            raise InputError("--law", law, "'linear' for a 2D structure (Hertz-Mindlin is a "
                             "law of spheres)")
        g = _positive("--shear-modulus", defaults.shear_modulus if shear_modulus is None
                      else shear_modulus, "Pa")
        nu = defaults.poisson_ratio if poisson_ratio is None else poisson_ratio
        try:
            nu_value = float(nu)
        except (TypeError, ValueError):
            nu_value = math.nan
        if not 0.0 <= nu_value < 0.5:
            raise InputError("--poisson-ratio", nu, "a number in [0, 0.5)")
        return SpringContactLaw(friction_angle=friction, shear_modulus=g,
                                poisson_ratio=nu_value)
    for field, value in (("--shear-modulus", shear_modulus),
                         ("--poisson-ratio", poisson_ratio)):
        if value is not None:
            raise InputError(field, value, "no value with --law linear (give --kn and --ks)")
    kn = _positive("--kn", defaults.normal_stiffness if normal_stiffness is None
                   else normal_stiffness, "N/m")
    if shear_stiffness is None:
        ks = defaults.shear_stiffness_ratio * kn
    else:
        try:
            ks = float(shear_stiffness)
        except (TypeError, ValueError):
            ks = math.nan
        if not (math.isfinite(ks) and ks >= 0.0):
            raise InputError("--ks", shear_stiffness, "a number >= 0 in N/m")
    if structure.dimension == 2:
        t = disc_thickness(structure) if thickness is None else _positive(
            "--thickness", thickness, "m")
        kn, ks = kn / t, ks / t
    elif thickness is not None:
        raise InputError("--thickness", thickness, "no value for a 3D structure")
    return SpringContactLaw(friction_angle=friction, normal_stiffness=kn, shear_stiffness=ks)


def disc_thickness(structure: MicroElementStructure) -> float:
    """Default thickness of the discs of a 2D structure: twice the mean centre radius [m]."""
    return float(2.0 * np.mean(structure.centre_radii))


def build_model(
    structure: MicroElementStructure,
    *,
    law: str | None = None,
    normal_stiffness: float | None = None,
    shear_stiffness: float | None = None,
    friction_angle_deg: float | None = None,
    shear_modulus: float | None = None,
    poisson_ratio: float | None = None,
    thickness: float | None = None,
    sigma0: float | None = None,
    distribution: str | None = None,
    non_affine: bool = True,
    spin: str | None = None,
    update_geometry: bool = True,
    maxwellian_reference: str = "overall",
) -> MicroElementModel:
    """A :class:`MicroElementModel` of ``structure`` consolidated isotropically to
    ``sigma0`` [Pa] (default: :func:`structure_defaults`), or, for a structure that carries
    its simulation's contact forces (``initial_forces``, a snapshot file), starting from
    them (``sigma0`` must then be None).

    Law options as :func:`build_law`. ``distribution`` ``"homogeneous"`` (eq. 2.30) or
    ``"maxwellian"`` (eqs. 2.32–2.35; default: :func:`structure_defaults`, homogeneous) with
    ``maxwellian_reference`` ``"overall"`` (eq. 2.32 as printed, self-consistent) or
    ``"average"`` (C_bar), or ``"maxwellian-first-order"`` (C_bar and the series of eq. 2.35
    cut after its first-order term, G^n = (V^n/V)(2I - C_bar^-1 C^n); the reading that gives
    the report's cubical strengths); ``non_affine`` the
    centre particle's move (eq. 2.14); ``spin`` ``"none"``, ``"micro-element"`` or
    ``"uniform"`` (default ``"uniform"`` for binary units, which need it, ``"none"``
    otherwise); ``update_geometry`` large-strain updates.

    Raises
    ------
    InputError
        Bad options (field named), a binary structure without the uniform spin.
    ConvergenceError
        The structure cannot carry the isotropic stress.

    >>> model = build_model(build_structure("idealized"))
    >>> round(float(model.stress()[2]))
    100000
    """
    defaults = structure_defaults(structure)
    spin = defaults.spin if spin is None else spin
    distribution = defaults.distribution if distribution is None else distribution
    if spin not in SPINS:
        raise InputError("--spin", spin, "one of " + ", ".join(SPINS))
    if structure_kind(structure) == "binary" and spin != "uniform":
        raise InputError("--spin", spin, "'uniform' for binary units (a single contact with a "
                         "free spin loses its shear stiffness)")
    if distribution not in DISTRIBUTIONS:
        raise InputError("--distribution", distribution, " or ".join(DISTRIBUTIONS))
    if structure_kind(structure) == "binary" and distribution != "homogeneous":
        raise InputError("--distribution", distribution, "'homogeneous' for binary units (they "
                         "need the uniform spin, which needs the homogeneous distribution)")
    if spin == "uniform" and distribution != "homogeneous":
        raise InputError("--spin", spin, "'none' or 'micro-element' with the Maxwellian "
                         "distribution (a uniform spin needs the homogeneous one)")
    loaded = structure.initial_forces is not None
    if loaded and sigma0 is not None:
        raise InputError("--sigma0", sigma0, "no value for a structure that starts from its "
                         "snapshot's contact forces (take the snapshot without its forces to "
                         "consolidate it)")
    pressure = _positive("--sigma0", defaults.sigma0 if sigma0 is None else sigma0, "Pa")
    contact_law = build_law(
        structure, law=law, normal_stiffness=normal_stiffness, shear_stiffness=shear_stiffness,
        friction_angle_deg=friction_angle_deg, shear_modulus=shear_modulus,
        poisson_ratio=poisson_ratio, thickness=thickness)
    model = MicroElementModel(structure, contact_law, distribution=distribution,
                              non_affine=bool(non_affine), spin=spin,
                              update_geometry=bool(update_geometry),
                              maxwellian_reference=maxwellian_reference)
    if not loaded:
        model.consolidate_isotropically(pressure, tolerance=CONSOLIDATION_TOLERANCE)
    return model


def mean_stress(model: MicroElementModel) -> float:
    """Mean normal stress p of the model's current state [Pa]."""
    d = model.dimension
    return float(np.sum(model.stress()[:d]) / d)


def reference_strain(model: MicroElementModel) -> float:
    """eps_ref = p / M [-]: the current mean stress over the mean normal diagonal stiffness
    of the tangent, the strain at which the structure's response is of the order of its
    stress. Default strains of :func:`default_path_parameters` are multiples of it, so that
    they suit any stiffness.

    >>> 1e-4 < reference_strain(build_model(build_structure("idealized"))) < 1e-3
    True
    """
    d = model.dimension
    modulus = float(np.mean(np.diag(model.tangent())[:d]))
    if not modulus > 0.0:
        raise InputError("tangent", modulus, "a positive normal stiffness of the structure")
    return mean_stress(model) / modulus


THREE_D_ONLY = ("triaxial_compression", "triaxial_extension", "true_triaxial",
                "cubical_constant_sigma3", "circular_octahedral")
TWO_D_ONLY = ("biaxial",)


def default_path_parameters(name: str, model: MicroElementModel,
                            n_steps: int = 200) -> dict[str, Any]:
    """Parameters of the preset ``name`` for a short run on the consolidated ``model``.

    Stresses are multiples of the model's mean stress p (its sigma0), strains multiples of
    :func:`reference_strain` eps_ref; every stage starts from the consolidated state (no
    consolidation stage). ``n_steps`` steps in all:

    =========================  ===============================================================
    preset                     defaults
    =========================  ===============================================================
    isotropic_compression      p_final = 2 p
    oedometer                  vertical strain 15 eps_ref in n/2 steps, then unloading to
                               sigma_v = p in n/2 steps (K0 against OCR)
    triaxial_compression/      confining p, axial strain 30 eps_ref, drained
    triaxial_extension
    true_triaxial              p, b = 0.5, strain 30 eps_ref along the deviator direction
    cubical_constant_sigma3    sigma_3 = p, b = 0.5, strain 30 eps_ref
    biaxial (2D)               confining p, vertical strain 30 eps_ref
    circular_octahedral        p, q = 0.5 p, one turn in n steps after 20 approach steps
    simple_shear               K0 to sigma_v = 1.344 p (20 steps; seed 001 §4.2.4), then
                               gamma = 60 eps_ref in n steps
    cyclic_shear               amplitude eps_ref, 2 cycles, n/8 steps per quarter cycle,
                               sigma_v = p held
    =========================  ===============================================================

    Presets taking ``dimension`` get the model's.
    """
    if name not in preset_names():
        raise InputError("--path", name, "one of " + ", ".join(preset_names()))
    d = model.dimension
    if d == 2 and name in THREE_D_ONLY:
        raise InputError("--path", name, "a preset for a 2D structure: " + ", ".join(
            n for n in preset_names() if n not in THREE_D_ONLY))
    if d == 3 and name in TWO_D_ONLY:
        raise InputError("--path", name, "a preset for a 3D structure: " + ", ".join(
            n for n in preset_names() if n not in TWO_D_ONLY))
    if isinstance(n_steps, bool) or not isinstance(n_steps, int) or n_steps < 8:
        raise InputError("n_steps (--steps)", n_steps, "an integer >= 8")
    p = mean_stress(model)
    eps = reference_strain(model)
    half = n_steps // 2
    table: dict[str, dict[str, Any]] = {
        "isotropic_compression": {"p_final": 2.0 * p, "n_steps": n_steps, "dimension": d},
        "oedometer": {"strain_final": 15.0 * eps, "n_steps": half, "unload_to_stress": p,
                      "unload_steps": n_steps - half, "dimension": d},
        "triaxial_compression": {"confining": p, "axial_strain": 30.0 * eps,
                                 "n_steps": n_steps, "consolidation_steps": 0},
        "triaxial_extension": {"confining": p, "axial_strain": 30.0 * eps, "n_steps": n_steps,
                               "consolidation_steps": 0},
        "true_triaxial": {"p": p, "b": 0.5, "strain": 30.0 * eps, "n_steps": n_steps,
                          "consolidation_steps": 0},
        "cubical_constant_sigma3": {"confining": p, "b": 0.5, "strain": 30.0 * eps,
                                    "n_steps": n_steps, "consolidation_steps": 0},
        "biaxial": {"confining": p, "strain": 30.0 * eps, "n_steps": n_steps,
                    "consolidation_steps": 0},
        "circular_octahedral": {"p": p, "radius_q": 0.5 * p, "n_steps": n_steps,
                                "alpha0": 0.0, "consolidation_steps": 0,
                                "approach_steps": 20},
        "simple_shear": {"gamma_final": 60.0 * eps, "n_steps": n_steps,
                         "vertical_stress": SIMPLE_SHEAR_VERTICAL_RATIO * p,
                         "k0_consolidation_steps": 20, "dimension": d},
        "cyclic_shear": {"amplitude": eps, "n_cycles": 2,
                         "steps_per_quarter": max(1, n_steps // 8), "vertical_stress": p,
                         "k0_consolidation_steps": 0, "dimension": d},
    }
    return dict(table[name])
