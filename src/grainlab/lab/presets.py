"""Preset load paths of the laboratory (seed 001 §4.2; STYLE.md 9: presets are data).

Each preset is a function returning a :class:`~grainlab.lab.load_path.LoadPath`; conventions
(frames, components, units) are those of :mod:`grainlab.lab.load_path`.

>>> path = triaxial_compression(confining=1e5, axial_strain=0.01, n_steps=10)
>>> [s.name for s in path.stages], path.dimension
(['consolidation', 'shear'], 3)
>>> path.stages[1].control
('stress', 'stress', 'strain', 'strain', 'strain', 'strain')
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from grainlab.errors import InputError
from grainlab.lab.load_path import (
    LoadPath,
    LoadStage,
    _choice,
    _dimension,
    _finite,
    _integer,
    _positive,
)


def _vertical(dimension: int) -> str:
    return "zz" if dimension == 3 else "yy"


def _laterals(dimension: int) -> tuple[str, ...]:
    return ("xx", "yy") if dimension == 3 else ("xx",)


def _shears(dimension: int) -> tuple[str, ...]:
    return ("yz", "xz", "xy") if dimension == 3 else ("xy",)


def _isotropic_stage(name: str, pressure: float, n_steps: int, dimension: int) -> LoadStage:
    """All normal stresses to ``pressure`` [Pa], shear stresses to 0 (stress targets)."""
    stress = {c: pressure for c in (*_laterals(dimension), _vertical(dimension))}
    stress.update({c: 0.0 for c in _shears(dimension)})
    return LoadStage.from_components(name, n_steps, dimension, stress=stress,
                                     stress_mode="target")


def _k0_stage(vertical_stress: float, n_steps: int, dimension: int) -> LoadStage:
    """One-dimensional (K0) consolidation: vertical stress target, every other strain 0."""
    return LoadStage.from_components(
        "k0_consolidation", n_steps, dimension,
        strain={c: 0.0 for c in (*_laterals(dimension), *_shears(dimension))},
        stress={_vertical(dimension): vertical_stress}, stress_mode="target")


def isotropic_compression(*, p_final: float, n_steps: int, dimension: int = 3) -> LoadPath:
    """Isotropic compression to the mean stress ``p_final`` [Pa]: every normal stress is
    stress-controlled towards ``p_final``, every shear stress towards 0 (linear targets)."""
    p_final = _positive("p_final", p_final, "Pa")
    dim = _dimension("dimension", dimension)
    return LoadPath("isotropic_compression", dim,
                    (_isotropic_stage("isotropic", p_final, n_steps, dim),),
                    f"all normal stresses to {p_final:g} Pa, shear stresses 0")


def oedometer(
    *,
    strain_final: float,
    n_steps: int,
    unload_to_stress: float | None = None,
    unload_strain: float | None = None,
    unload_steps: int | None = None,
    dimension: int = 3,
) -> LoadPath:
    """One-dimensional (oedometric, K0) compression with optional unloading (seed 001 §4.2.1).

    Stage ``"loading"``: vertical strain (z in 3D, y in 2D) increases by ``strain_final`` [-]
    in ``n_steps`` equal increments; every lateral normal strain and every shear strain is 0.
    Optional stage ``"unloading"`` (``unload_steps``, default ``n_steps``), lateral and shear
    strains still 0: either the vertical stress goes linearly to ``unload_to_stress`` [Pa]
    (stress target), or the vertical strain decreases by ``unload_strain`` [-] (strain
    control). K0 = sigma_h/sigma_v against OCR = sigma_v,max/sigma_v:
    :func:`grainlab.lab.derived.k0_series`.
    """
    strain_final = _positive("strain_final", strain_final)
    dim = _dimension("dimension", dimension)
    v = _vertical(dim)
    n = _integer("n_steps", n_steps, 1)
    others = (*_laterals(dim), *_shears(dim))
    stages = [LoadStage.from_components(
        "loading", n, dim, strain={v: strain_final / n, **{c: 0.0 for c in others}})]
    if unload_to_stress is not None and unload_strain is not None:
        raise InputError("unload_strain", unload_strain,
                         "None when unload_to_stress is given (one unloading control)")
    m = n if unload_steps is None else _integer("unload_steps", unload_steps, 1)
    if unload_to_stress is not None:
        target = _positive("unload_to_stress", unload_to_stress, "Pa")
        stages.append(LoadStage.from_components(
            "unloading", m, dim, strain={c: 0.0 for c in others}, stress={v: target},
            stress_mode="target"))
    elif unload_strain is not None:
        amount = _positive("unload_strain", unload_strain)
        stages.append(LoadStage.from_components(
            "unloading", m, dim, strain={v: -amount / m, **{c: 0.0 for c in others}}))
    return LoadPath("oedometer", dim, tuple(stages),
                    f"vertical ({v}) strain-controlled, lateral and shear strains 0")


def _triaxial(name: str, confining: float, axial_strain: float, n_steps: int, drained: bool,
              consolidation_steps: int, sign: float, dimension: int = 3) -> LoadPath:
    confining = _positive("confining", confining, "Pa")
    axial_strain = _positive("axial_strain", axial_strain)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("consolidation_steps", consolidation_steps, 0)
    dim = _dimension("dimension", dimension)
    if not isinstance(drained, bool):
        raise InputError("drained", drained, "True or False")
    d_axial = sign * axial_strain / n
    shears = {c: 0.0 for c in _shears(dim)}
    vertical, laterals = _vertical(dim), _laterals(dim)
    if drained:
        shear = LoadStage.from_components(
            "shear", n, dim, strain={vertical: d_axial, **shears},
            stress={c: confining for c in laterals}, stress_mode="target")
    else:
        shear = LoadStage.from_components(
            "shear", n, dim,
            strain={vertical: d_axial, **{c: -d_axial / len(laterals) for c in laterals},
                    **shears})
    stages = ([_isotropic_stage("consolidation", confining, m, dim)] if m else []) + [shear]
    return LoadPath(name, dim, tuple(stages),
                    f"confining {confining:g} Pa, axial ({vertical[0]}) strain "
                    f"{sign * axial_strain:g}, "
                    + ("drained" if drained else "undrained (isochoric)"))


def triaxial_compression(
    *,
    confining: float,
    axial_strain: float,
    n_steps: int,
    drained: bool = True,
    consolidation_steps: int = 10,
    dimension: int = 3,
) -> LoadPath:
    """Conventional triaxial compression (3D; axis z), or biaxial compression in 2D (axis y,
    sigma_xx held; undrained: eps_xx = -eps_yy).

    Stage ``"consolidation"`` (skipped when ``consolidation_steps=0``): isotropic to
    ``confining`` [Pa]. Stage ``"shear"``: eps_zz increases by ``axial_strain`` [-] in
    ``n_steps`` increments, shear strains 0, and

    * drained: sigma_xx = sigma_yy = ``confining`` (stress targets, held);
    * undrained: constant volume, eps_xx = eps_yy = -eps_zz/2 (strain-controlled). The table
      then holds effective stresses; with the total lateral stress held at ``confining`` the
      excess pore pressure is u = confining - sigma_xx.
    """
    return _triaxial("triaxial_compression", confining, axial_strain, n_steps, drained,
                     consolidation_steps, 1.0, dimension)


def triaxial_extension(
    *,
    confining: float,
    axial_strain: float,
    n_steps: int,
    drained: bool = True,
    consolidation_steps: int = 10,
    dimension: int = 3,
) -> LoadPath:
    """Triaxial extension by reduced axial stress (3D; axis z; biaxial in 2D, axis y).

    As :func:`triaxial_compression` but eps_zz *decreases* by ``axial_strain`` [-] (given
    positive) while the lateral stresses stay at ``confining``: sigma_zz becomes the minor
    principal stress (b = 1). Undrained: eps_xx = eps_yy = -eps_zz/2.
    """
    return _triaxial("triaxial_extension", confining, axial_strain, n_steps, drained,
                     consolidation_steps, -1.0, dimension)


def true_triaxial_direction(b: float) -> np.ndarray:
    """Unit direction (n_x, n_y, n_z) of the principal stress increments that keeps the mean
    stress and b constant, with z major, x intermediate, y minor.

    From d1 + d2 + d3 = 0 and d2 - d3 = b (d1 - d3) with d1 = 1:
    d3 = -(1 + b)/(2 - b), d2 = (2b - 1)/(2 - b), i.e. (d1, d2, d3) proportional to
    (2 - b, 2b - 1, -(1 + b)); along it sigma_1 - sigma_3 grows by 3/|d| per unit length.

    >>> np.round(true_triaxial_direction(0.0) * np.sqrt(6), 12).tolist()  # (x, y, z)
    [-1.0, -1.0, 2.0]
    """
    b = _finite("b", b)
    if not 0.0 <= b <= 1.0:
        raise InputError("b", b, "a number in [0, 1]")
    d = np.array([2.0 * b - 1.0, -(1.0 + b), 2.0 - b])
    return d / np.linalg.norm(d)


def true_triaxial(
    *,
    p: float,
    b: float,
    n_steps: int,
    strain: float | None = None,
    q_final: float | None = None,
    consolidation_steps: int = 10,
) -> LoadPath:
    """Cubical (true) triaxial test at constant mean stress p and constant b (seed 001
    §4.2.2, eq. 4.7: b = (sigma_2 - sigma_3)/(sigma_1 - sigma_3)); 3D, z major, x
    intermediate, y minor principal axis, shear stresses 0.

    Stage ``"consolidation"``: isotropic to ``p`` [Pa]. Stage ``"shear"`` controls, through
    an orthogonal ``component_basis`` on (xx, yy, zz), the generalised components along
    n_d = :func:`true_triaxial_direction` (b), n_p = (1, 1, 1)/sqrt(3) and n_p x n_d:

    * sigma . n_p = sqrt(3) p and sigma . (n_p x n_d) = 0 (stress targets), so p and b stay
      exactly constant;
    * along n_d either the conjugate strain eps . n_d grows by ``strain`` [-] (strain
      control, which can follow a softening branch past the peak) or the stress goes to
      ``q_final`` = sigma_1 - sigma_3 [Pa] (stress target: sigma . n_d = q_final |d|/3).

    Give exactly one of ``strain`` and ``q_final``.
    """
    p = _positive("p", p, "Pa")
    n_d = true_triaxial_direction(b)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("consolidation_steps", consolidation_steps, 0)
    if (strain is None) == (q_final is None):
        raise InputError("strain", strain, "exactly one of strain and q_final to be given")
    n_p = np.ones(3) / np.sqrt(3.0)
    q3 = np.vstack([n_d, n_p, np.cross(n_p, n_d)])
    basis = np.eye(6)
    basis[:3, :3] = q3
    d_norm = np.linalg.norm([2.0 * b - 1.0, -(1.0 + b), 2.0 - b])
    stress = ["stress", "stress", "stress", "stress", "stress"]
    if strain is not None:
        control = ("strain", *stress)
        values = (_positive("strain", strain) / n, math.sqrt(3.0) * p, 0.0, 0.0, 0.0, 0.0)
    else:
        control = ("stress", *stress)
        values = (_positive("q_final", q_final, "Pa") * d_norm / 3.0, math.sqrt(3.0) * p,
                  0.0, 0.0, 0.0, 0.0)
    shear = LoadStage("shear", n, 3, control, values, stress_mode="target",
                      component_basis=tuple(map(tuple, basis)))
    stages = ([_isotropic_stage("consolidation", p, m, 3)] if m else []) + [shear]
    return LoadPath("true_triaxial", 3, tuple(stages),
                    f"p = {p:g} Pa and b = {b:g} held; z major, x intermediate, y minor")


def cubical_constant_sigma3_basis(b: float) -> np.ndarray:
    """Orthonormal rows (u_strain, u_3, u_b) on the principal stresses (x, y, z) of the
    cubical test at constant sigma_3 (z major, x intermediate, y minor):

    * u_3 = (0, 1, 0): sigma . u_3 = sigma_3;
    * u_b = (1, 0, -b)/sqrt(1 + b^2): b = (sigma_2 - sigma_3)/(sigma_1 - sigma_3) is
      sigma_xx - (1 - b) sigma_yy - b sigma_zz = 0, i.e. with sigma_yy = sigma_3,
      sigma . u_b = (1 - b) sigma_3 / sqrt(1 + b^2);
    * u_strain = (b, 0, 1)/sqrt(1 + b^2), orthogonal to both: its conjugate strain
      (b eps_xx + eps_zz)/sqrt(1 + b^2) drives the test (eps_zz at b = 0).

    >>> np.round(cubical_constant_sigma3_basis(1.0) * np.sqrt(2), 12).tolist()
    [[1.0, 0.0, 1.0], [0.0, 1.414213562373, 0.0], [1.0, 0.0, -1.0]]
    """
    b = _finite("b", b)
    if not 0.0 <= b <= 1.0:
        raise InputError("b", b, "a number in [0, 1]")
    norm = math.sqrt(1.0 + b * b)
    return np.array([[b / norm, 0.0, 1.0 / norm], [0.0, 1.0, 0.0], [1.0 / norm, 0.0, -b / norm]])


def cubical_constant_sigma3(
    *,
    confining: float,
    b: float,
    strain: float,
    n_steps: int,
    consolidation_steps: int = 10,
) -> LoadPath:
    """Cubical (true) triaxial test at constant minor stress sigma_3 and constant b (the
    protocol of Lade & Duncan's cubical tests, with which seed 001 §4.2.2 compares; eq. 4.7:
    b = (sigma_2 - sigma_3)/(sigma_1 - sigma_3)); 3D, z major, x intermediate, y minor
    principal axis, shear stresses 0. b = 0 is triaxial compression, b = 1 the report's
    "extension" (sigma_1 = sigma_2 > sigma_3 held), not reduced-axial-stress extension.

    Stage ``"consolidation"`` (skipped with 0 steps): isotropic to ``confining`` [Pa]. Stage
    ``"shear"`` controls, through an orthogonal ``component_basis`` on (xx, yy, zz) with the
    rows of :func:`cubical_constant_sigma3_basis` (b):

    * sigma_yy = ``confining`` and sigma_xx - (1 - b) sigma_yy - b sigma_zz = 0 (stress
      targets), so sigma_3 and b stay constant while p grows;
    * the strain (b eps_xx + eps_zz)/sqrt(1 + b^2) grows by ``strain`` [-] in ``n_steps``
      increments (strain control: a softening branch past the peak can be followed).
    """
    confining = _positive("confining", confining, "Pa")
    rows = cubical_constant_sigma3_basis(b)
    b = float(b)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("consolidation_steps", consolidation_steps, 0)
    amount = _positive("strain", strain)
    basis = np.eye(6)
    basis[:3, :3] = rows
    control = ("strain", "stress", "stress", "stress", "stress", "stress")
    values = (amount / n, confining, (1.0 - b) * confining / math.sqrt(1.0 + b * b),
              0.0, 0.0, 0.0)
    shear = LoadStage("shear", n, 3, control, values, stress_mode="target",
                      component_basis=tuple(map(tuple, basis)))
    stages = ([_isotropic_stage("consolidation", confining, m, 3)] if m else []) + [shear]
    return LoadPath("cubical_constant_sigma3", 3, tuple(stages),
                    f"sigma_3 = {confining:g} Pa and b = {b:g} held; z major, x intermediate, "
                    "y minor")


def octahedral_stress(p: float, q: float, alpha: float) -> np.ndarray:
    """Voigt stress (3D) [Pa] at mean stress ``p``, deviator q = sqrt(3 J2) and angle
    ``alpha`` [rad] on the octahedral plane, measured from the projection of the z axis
    towards that of the x axis (alpha = 0: triaxial compression along z):
    sigma_zz = p + 2q/3 cos(alpha), sigma_xx = p + 2q/3 cos(alpha - 2 pi/3),
    sigma_yy = p + 2q/3 cos(alpha + 2 pi/3); shear stresses 0. The point lies at distance
    sqrt(2/3) q from the hydrostatic axis.

    >>> np.round(octahedral_stress(1.0, 3.0, 0.0), 12).tolist()
    [0.0, 0.0, 3.0, 0.0, 0.0, 0.0]
    """
    r = 2.0 * q / 3.0
    return np.array([p + r * math.cos(alpha - 2 * math.pi / 3),
                     p + r * math.cos(alpha + 2 * math.pi / 3),
                     p + r * math.cos(alpha), 0.0, 0.0, 0.0])


def circular_octahedral(
    *,
    p: float,
    radius_q: float,
    n_steps: int,
    alpha0: float = 0.0,
    consolidation_steps: int = 10,
    approach_steps: int = 10,
) -> LoadPath:
    """Circular stress path on the octahedral plane (seed 001 §4.2.3), 3D, fixed principal
    axes x, y, z (shear stresses 0, every component stress-controlled).

    Stages: ``"consolidation"`` isotropic to ``p`` [Pa] (skipped when 0 steps);
    ``"approach"``: radially at constant p to the point (p, ``radius_q``, ``alpha0``) of
    :func:`octahedral_stress`; ``"circle"``: ``n_steps`` targets (a schedule) at constant p
    and q = sqrt(3 J2) = ``radius_q`` [Pa], alpha = alpha0 + 2 pi k / n_steps, a full turn.
    """
    p = _positive("p", p, "Pa")
    radius_q = _positive("radius_q", radius_q, "Pa")
    n = _integer("n_steps", n_steps, 3)
    alpha0 = _finite("alpha0", alpha0, "rad")
    m = _integer("consolidation_steps", consolidation_steps, 0)
    a = _integer("approach_steps", approach_steps, 1)
    everything = ("stress",) * 6
    start = octahedral_stress(p, radius_q, alpha0)
    schedule = tuple(tuple(octahedral_stress(p, radius_q, alpha0 + 2 * math.pi * k / n))
                     for k in range(1, n + 1))
    stages = [_isotropic_stage("consolidation", p, m, 3)] if m else []
    stages.append(LoadStage("approach", a, 3, everything, tuple(start), stress_mode="target"))
    stages.append(LoadStage("circle", n, 3, everything, (0.0,) * 6, stress_mode="schedule",
                            schedule=schedule))
    return LoadPath("circular_octahedral", 3, tuple(stages),
                    f"p = {p:g} Pa, q = {radius_q:g} Pa, a full turn of the Lode angle")


def simple_shear(
    *,
    gamma_final: float,
    n_steps: int,
    vertical_stress: float,
    k0_consolidation_steps: int = 20,
    constant: str = "vertical_stress",
    dimension: int = 3,
) -> LoadPath:
    """Strain-controlled direct simple shear after K0 consolidation (seed 001 §4.2.4).

    Stage ``"k0_consolidation"`` (skipped with 0 steps): vertical stress (z in 3D, y in 2D)
    linearly to ``vertical_stress`` [Pa], every other strain 0. Stage ``"shear"``: the
    engineering shear strain gamma_xz (3D) / gamma_xy (2D) grows by ``gamma_final`` [-] in
    ``n_steps`` increments; lateral normal strains and the other shear strains are 0, and
    ``constant="vertical_stress"`` holds the vertical stress at ``vertical_stress``, while
    ``constant="height"`` holds the vertical strain (constant volume).
    """
    gamma_final = _positive("gamma_final", gamma_final)
    sigma_v = _positive("vertical_stress", vertical_stress, "Pa")
    dim = _dimension("dimension", dimension)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("k0_consolidation_steps", k0_consolidation_steps, 0)
    _choice("constant", constant, ("vertical_stress", "height"))
    shear = _shear_stage("shear", n, dim, gamma_final / n, sigma_v, constant)
    stages = ([_k0_stage(sigma_v, m, dim)] if m else []) + [shear]
    return LoadPath("simple_shear", dim, tuple(stages),
                    f"gamma_{_shear_component(dim)} to {gamma_final:g}, constant {constant}")


def _shear_component(dimension: int) -> str:
    return "xz" if dimension == 3 else "xy"


def _shear_stage(name: str, n_steps: int, dimension: int, d_gamma: float,
                 sigma_v: float | None, constant: str) -> LoadStage:
    s = _shear_component(dimension)
    v = _vertical(dimension)
    strain = {c: 0.0 for c in (*_laterals(dimension), *_shears(dimension))}
    strain[s] = d_gamma
    if constant == "vertical_stress" and sigma_v is not None:
        return LoadStage.from_components(name, n_steps, dimension, strain=strain,
                                         stress={v: sigma_v}, stress_mode="target")
    return LoadStage.from_components(name, n_steps, dimension, strain={**strain, v: 0.0})


def biaxial(
    *, confining: float, strain: float, n_steps: int, consolidation_steps: int = 10
) -> LoadPath:
    """Biaxial compression (2D): stage ``"consolidation"`` isotropic to ``confining`` [Pa];
    stage ``"shear"``: eps_yy grows by ``strain`` [-] in ``n_steps`` increments, sigma_xx held
    at ``confining``, gamma_xy = 0."""
    confining = _positive("confining", confining, "Pa")
    strain = _positive("strain", strain)
    n = _integer("n_steps", n_steps, 1)
    m = _integer("consolidation_steps", consolidation_steps, 0)
    shear = LoadStage.from_components("shear", n, 2, strain={"yy": strain / n, "xy": 0.0},
                                      stress={"xx": confining}, stress_mode="target")
    stages = ([_isotropic_stage("consolidation", confining, m, 2)] if m else []) + [shear]
    return LoadPath("biaxial", 2, tuple(stages),
                    f"sigma_xx = {confining:g} Pa held, eps_yy to {strain:g}")


def cyclic_shear(
    *,
    amplitude: float,
    n_cycles: int,
    steps_per_quarter: int,
    vertical_stress: float | None = None,
    k0_consolidation_steps: int = 20,
    constant: str = "vertical_stress",
    dimension: int = 3,
) -> LoadPath:
    """Strain-controlled cyclic simple shear, gamma_xz (3D) / gamma_xy (2D) between
    +-``amplitude`` [-].

    Optional K0 consolidation to ``vertical_stress`` [Pa] first (as :func:`simple_shear`,
    and then the vertical stress or the height held per ``constant``); without
    ``vertical_stress`` the vertical strain is held (every strain controlled). Cycle k is
    three stages named ``"cycle_k"``: 0 -> +amplitude (``steps_per_quarter`` steps),
    -> -amplitude (2 ``steps_per_quarter``), -> 0 (``steps_per_quarter``); lateral strains
    and the other shears are 0. Per-cycle modulus and damping:
    :func:`grainlab.lab.derived.cyclic_shear_response`.
    """
    amplitude = _positive("amplitude", amplitude)
    cycles = _integer("n_cycles", n_cycles, 1)
    quarter = _integer("steps_per_quarter", steps_per_quarter, 1)
    dim = _dimension("dimension", dimension)
    m = _integer("k0_consolidation_steps", k0_consolidation_steps, 0)
    _choice("constant", constant, ("vertical_stress", "height"))
    sigma_v = None if vertical_stress is None else _positive("vertical_stress",
                                                              vertical_stress, "Pa")
    stages = [_k0_stage(sigma_v, m, dim)] if sigma_v is not None and m else []
    d = amplitude / quarter
    for k in range(1, cycles + 1):
        for steps, sign in ((quarter, 1.0), (2 * quarter, -1.0), (quarter, 1.0)):
            stages.append(_shear_stage(f"cycle_{k}", steps, dim, sign * d, sigma_v, constant))
    return LoadPath("cyclic_shear", dim, tuple(stages),
                    f"{cycles} cycles of gamma_{_shear_component(dim)} = +-{amplitude:g}")


# -- registry -----------------------------------------------------------------------------------
_PRESETS: dict[str, tuple[Callable[..., LoadPath], str]] = {
    "isotropic_compression": (isotropic_compression,
                              "all normal stresses to p_final, shear stresses 0"),
    "oedometer": (oedometer, "vertical strain, zero lateral strain, optional unloading (K0)"),
    "triaxial_compression": (triaxial_compression,
                             "eps_zz up at constant lateral stress (or constant volume)"),
    "triaxial_extension": (triaxial_extension,
                           "eps_zz down at constant lateral stress (or constant volume)"),
    "true_triaxial": (true_triaxial, "cubical test at constant p and b (strain or q_final)"),
    "cubical_constant_sigma3": (cubical_constant_sigma3,
                                "cubical test at constant sigma_3 and b (Lade & Duncan)"),
    "circular_octahedral": (circular_octahedral,
                            "full circle on the octahedral plane at constant p and q"),
    "simple_shear": (simple_shear,
                     "K0 consolidation, then gamma at constant vertical stress or height"),
    "biaxial": (biaxial, "2D: eps_yy up at constant sigma_xx"),
    "cyclic_shear": (cyclic_shear, "strain-controlled cycles of gamma between +-amplitude"),
}


def preset_names() -> tuple[str, ...]:
    """Names of the preset load paths.

    >>> "oedometer" in preset_names()
    True
    """
    return tuple(_PRESETS)


def preset_description(name: str) -> str:
    """One-line description of a preset."""
    if name not in _PRESETS:
        raise InputError("preset", name, "one of " + ", ".join(_PRESETS))
    return _PRESETS[name][1]


def preset(name: str, **parameters: Any) -> LoadPath:
    """Build the preset ``name`` with keyword ``parameters`` (each checked against the
    preset's signature, so a misspelt name is an error).

    >>> preset("isotropic_compression", p_final=1e5, n_steps=4).n_steps
    4
    """
    if name not in _PRESETS:
        raise InputError("preset", name, "one of " + ", ".join(_PRESETS))
    function = _PRESETS[name][0]
    accepted = inspect.signature(function).parameters
    for key in parameters:
        if key not in accepted:
            raise InputError(f"{name}: {key}", parameters[key],
                             "a parameter among " + ", ".join(accepted))
    missing = [k for k, v in accepted.items()
               if v.default is inspect.Parameter.empty and k not in parameters]
    if missing:
        raise InputError(f"{name}: parameters", sorted(parameters),
                         "also " + ", ".join(missing))
    return function(**parameters)
