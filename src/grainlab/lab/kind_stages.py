"""The stages a run's test kind asks for after its compaction: the lab's presets
(:mod:`grainlab.lab.presets`) from a run's ``[test]`` table, in 3D or, for a sample of discs,
in 2D (vertical axis y; :mod:`grainlab.engine.planar`)."""

from __future__ import annotations

from typing import Any

from grainlab.errors import InputError
from grainlab.lab.load_path import LoadStage, StopCriterion
from grainlab.lab.presets import (
    circular_octahedral,
    cubical_constant_sigma3,
    cyclic_shear,
    oedometer,
    triaxial_compression,
    triaxial_extension,
    true_triaxial,
)


def until_eps_q(stage, eps_q_max: float):
    """``stage`` ended by eps_q >= ``eps_q_max`` (its own strain target set beyond it)."""
    stop = (StopCriterion("eps_q", eps_q_max, ends="stage"),)
    return type(stage)(**{**stage.__dict__, "stop": stop})


PLANAR_KINDS = ("compaction", "triaxial", "extension", "oedometer", "simple_shear")
"""The test kinds a 2D sample (discs) runs: biaxial compression and extension, the 1D
compression and the simple shear of the plane."""


def kind_stages(t: Any, dimension: int = 3) -> tuple[tuple, str, str]:
    """The stages after the compaction of the test ``t`` (a run's ``[test]`` table), the
    path's name and what they do, in words (a 2D sample: the kinds of
    :data:`PLANAR_KINDS`, vertical axis y)."""
    if dimension == 2 and t.kind not in PLANAR_KINDS:
        raise InputError("test.kind", t.kind, "one of " + ", ".join(PLANAR_KINDS)
                         + " with discs (a 2D sample)")
    if t.kind in ("triaxial", "extension"):
        preset = triaxial_compression if t.kind == "triaxial" else triaxial_extension
        stage = preset(confining=t.sigma0, axial_strain=t.eps_q_max, n_steps=1,
                       consolidation_steps=0, dimension=dimension).stages[0]
        name = "triaxial_compression" if t.kind == "triaxial" else "triaxial_extension"
        test = "triaxial" if dimension == 3 else "biaxial"
        return ((until_eps_q(stage, t.eps_q_max),), name,
                f"{test} {'compression' if t.kind == 'triaxial' else 'extension'} at "
                f"lateral stress {t.sigma0:g} Pa to eps_q = {t.eps_q_max:g}")
    if t.kind == "oedometer":
        path = oedometer(strain_final=t.axial_strain, n_steps=1,
                         unload_strain=t.unload_strain or None, dimension=dimension)
        return (path.stages, "oedometer", f"1-D compression by {t.axial_strain:g}"
                + (f", unloading by {t.unload_strain:g}" if t.unload_strain else ""))
    if t.kind == "simple_shear" and dimension == 2:
        stage = LoadStage.from_components(
            "shear", 1, 2, strain={"xx": 0.0, "xy": t.gamma_max}, stress={"yy": t.sigma0},
            stress_mode="target")
        return ((stage,), "simple_shear",
                f"simple shear gamma_xy to {t.gamma_max:g} at sigma_yy = {t.sigma0:g} Pa")
    if t.kind == "true_triaxial":
        # the strain along the deviator direction goes beyond eps_q_max; eps_q ends it
        stage = true_triaxial(p=t.sigma0, b=t.b, n_steps=1, strain=2.0 * t.eps_q_max,
                              consolidation_steps=0).stages[0]
        return ((until_eps_q(stage, t.eps_q_max),), "true_triaxial",
                f"true triaxial at p = {t.sigma0:g} Pa and b = {t.b:g} to eps_q = "
                f"{t.eps_q_max:g}")
    if t.kind == "cubical":
        # the driven strain (b eps_xx + eps_zz)/sqrt(1 + b^2) goes beyond eps_q_max
        stage = cubical_constant_sigma3(confining=t.sigma0, b=t.b, n_steps=1,
                                        strain=2.0 * t.eps_q_max,
                                        consolidation_steps=0).stages[0]
        return ((until_eps_q(stage, t.eps_q_max),), "cubical_constant_sigma3",
                f"cubical test at sigma_3 = {t.sigma0:g} Pa and b = {t.b:g} to eps_q = "
                f"{t.eps_q_max:g}")
    if t.kind == "simple_shear":
        stage = LoadStage.from_components(
            "shear", 1, 3, strain={"xx": 0.0, "yy": 0.0, "yz": 0.0, "xz": t.gamma_max,
                                   "xy": 0.0},
            stress={"zz": t.sigma0}, stress_mode="target")
        return ((stage,), "simple_shear",
                f"simple shear gamma_xz to {t.gamma_max:g} at sigma_zz = {t.sigma0:g} Pa")
    if t.kind == "circular":
        path = circular_octahedral(p=t.sigma0, radius_q=t.q_ratio * t.sigma0,
                                   n_steps=t.circle_points, consolidation_steps=0,
                                   approach_steps=1)
        return (path.stages, "circular_octahedral",
                f"a full turn on the octahedral plane at p = {t.sigma0:g} Pa, q = "
                f"{t.q_ratio * t.sigma0:g} Pa")
    path = cyclic_shear(amplitude=t.amplitude, n_cycles=t.n_cycles, steps_per_quarter=1,
                        vertical_stress=t.sigma0, k0_consolidation_steps=0)
    return (path.stages, "cyclic_shear",
            f"{t.n_cycles} cycles of gamma_xz = +-{t.amplitude:g} at sigma_zz = "
            f"{t.sigma0:g} Pa")


def renamed(stages, name: str):
    """``stages`` under one ``name`` (the compaction's)."""
    return tuple(type(s)(**{**s.__dict__, "name": name}) for s in stages)
