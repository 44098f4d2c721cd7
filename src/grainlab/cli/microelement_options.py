"""Options, parsing and model set-up shared by the ``grainlab microelement`` commands."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from grainlab.errors import ConvergenceError, InputError
from grainlab.lab.element_test import run_element_test
from grainlab.lab.load_path import LoadPath
from grainlab.lab.micro_element_setup import (
    STRUCTURE_NAMES,
    build_model,
    build_structure,
    disc_thickness,
    structure_defaults,
)
from grainlab.micromech.micro_element.model import MicroElementModel
from grainlab.micromech.micro_element.structure import MicroElementStructure
from grainlab.result.test_result import TestResult

console = Console()



class Law(StrEnum):
    """Contact laws."""

    linear = "linear"
    hertz = "hertz"


class Distribution(StrEnum):
    """Distributive laws of strain (seed 001 eqs. 2.30, 2.32–2.35)."""

    homogeneous = "homogeneous"
    maxwellian = "maxwellian"
    maxwellian_average = "maxwellian-average"
    maxwellian_first_order = "maxwellian-first-order"


class Spin(StrEnum):
    """Particle spin (seed 001 §2.4.1)."""

    none = "none"
    micro_element = "micro-element"
    uniform = "uniform"


STRUCTURE_HELP = (
    "idealized (Chang 1991 §4.2: 30 micro-elements of 8 spheres), binary (§4.1: 12 binary "
    "units, Hertz-Mindlin), chang2d (ch. 3: random periodic packing of 25 discs, 2D; made "
    "in seconds to minutes) or a FILE: a contact-network snapshot (.h5) or a periodic disc "
    "packing (.toml/.csv, see `grainlab packing2d show --help`)."
)
STRUCTURE_OPTION = typer.Option("idealized", "--structure", help=STRUCTURE_HELP)
SEED_OPTION = typer.Option(1, help="Seed of the random structures (idealized, chang2d).")
LAW_OPTION = typer.Option(
    None, help="Contact law: linear springs (--kn, --ks) or hertz (Hertz-Mindlin, "
    "--shear-modulus, --poisson-ratio) [default: the structure's: hertz for binary, else "
    "linear].")
KN_OPTION = typer.Option(None, "--kn", help="Normal contact stiffness k_n [N/m] (linear law) "
                         "[default: 1e5; 2e5 for 2D packings].")
KS_OPTION = typer.Option(None, "--ks", help="Shear contact stiffness k_s [N/m] (linear law) "
                         "[default: k_n].")
PHI_OPTION = typer.Option(None, "--friction-angle", help="Interparticle friction angle "
                          "phi_mu [deg] [default: 25].")
G_OPTION = typer.Option(None, "--shear-modulus", help="Grain shear modulus G_mu [Pa] "
                        "(hertz) [default: 29e9, quartz].")
NU_OPTION = typer.Option(None, "--poisson-ratio", help="Grain Poisson ratio nu_mu (hertz) "
                         "[default: 0.2].")
THICKNESS_OPTION = typer.Option(None, "--thickness", help="2D only: disc thickness t [m]; the "
                                "2D model uses k/t per unit thickness so that stresses are "
                                "in Pa [default: the mean disc diameter].")
DISTRIBUTION_OPTION = typer.Option(
    Distribution.homogeneous, help="How the overall strain is shared among micro-elements: "
    "homogeneous (eq. 2.30), maxwellian (eqs. 2.32-2.35 with the overall stiffness C in "
    "eq. 2.32 as printed, solved self-consistently), maxwellian-average (the average "
    "stiffness C_bar in eq. 2.32) or maxwellian-first-order (C_bar, the series of eq. 2.35 "
    "cut after its first-order term: G^n = (V^n/V)(2I - C_bar^-1 C^n); the reading that "
    "gives the report's cubical strengths, see docs/validation/micro-element-report.md).")
AFFINE_OPTION = typer.Option(True, "--non-affine/--affine", help="Let each centre particle "
                             "move to balance its contact forces (eq. 2.14), or not.")
SPIN_OPTION = typer.Option(None, help="Particle spin: none, micro-element or uniform "
                           "[default: uniform for binary units, else none].")
GEOMETRY_OPTION = typer.Option(True, "--large-strain/--small-strain", help="Update branch "
                               "vectors and volumes after every increment, or keep them.")
SIGMA0_OPTION = typer.Option(None, "--sigma0", help="Isotropic consolidation stress [Pa] "
                             "before the test [default: 100e3; 203e3 for 2D packings].")
STEPS_OPTION = typer.Option(200, "--steps", help="Steps of the default load path (its "
                            "n_steps); keep it small for a quick look.")
SET_OPTION = typer.Option(
    None, "--set", help="KEY=VALUE passed to the preset, repeatable (e.g. --set "
    "axial_strain=0.01 --set drained=false); numbers, true/false and none are converted, "
    "anything else is passed as text. See `presets` for the keys.")


# -- parsing --------------------------------------------------------------------------------------
def parse_value(text: str) -> Any:
    """'12' -> 12, '1e-3' -> 0.001, 'true'/'false' -> bool, 'none' -> None, else the text.

    >>> [parse_value(v) for v in ("200", "0.5", "False", "none", "height")]
    [200, 0.5, False, None, 'height']
    """
    value = text.strip()
    lowered = value.lower()
    if lowered in ("true", "yes", "on"):
        return True
    if lowered in ("false", "no", "off"):
        return False
    if lowered in ("none", "null"):
        return None
    try:
        return int(value)
    except ValueError:
        pass
    try:
        return float(value)
    except ValueError:
        return value


def parse_sets(items: Sequence[str] | None) -> dict[str, Any]:
    """``["a=1", "b=x"]`` -> ``{"a": 1, "b": "x"}`` (values by :func:`parse_value`)."""
    out: dict[str, Any] = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise InputError("--set", item, "KEY=VALUE with KEY a preset parameter, e.g. "
                             "n_steps=50")
        out[key] = parse_value(value)
    return out


def parse_list(option: str, text: str, low: float = -math.inf,
               high: float = math.inf) -> list[float]:
    """'0,0.2,1' or 'start:stop:step' (stop included) -> floats in [low, high].

    >>> parse_list("--b", "0:1:0.5")
    [0.0, 0.5, 1.0]
    """
    try:
        if ":" in text:
            start, stop, step = (float(v) for v in text.split(":"))
            if not step > 0:
                raise ValueError
            values = [float(v) for v in np.arange(start, stop + step * 1e-9, step)]
        else:
            values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(option, text, "comma-separated numbers or start:stop:step") from None
    if not values or not all(math.isfinite(v) and low <= v <= high for v in values):
        raise InputError(option, text, f"numbers in [{low:g}, {high:g}]")
    return values


# -- the specimen ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class ModelOptions:
    """Command-line options of the model (``None``: the structure's default)."""

    law: str | None = None
    normal_stiffness: float | None = None
    shear_stiffness: float | None = None
    friction_angle_deg: float | None = None
    shear_modulus: float | None = None
    poisson_ratio: float | None = None
    thickness: float | None = None
    sigma0: float | None = None
    distribution: str = "homogeneous"
    maxwellian_reference: str = "overall"
    non_affine: bool = True
    spin: str | None = None
    update_geometry: bool = True

    def build(self, structure: MicroElementStructure) -> MicroElementModel:
        """A consolidated model (:func:`build_model`)."""
        return build_model(structure, **asdict(self))

    def describe(self, structure: MicroElementStructure) -> dict[str, Any]:
        """The options with the structure's defaults filled in (plain data)."""
        defaults = structure_defaults(structure)
        law = self.law or defaults.law
        out: dict[str, Any] = {
            "law": law,
            "friction_angle_deg": _or(self.friction_angle_deg, defaults.friction_angle_deg),
            "sigma0_Pa": _or(self.sigma0, defaults.sigma0),
            "distribution": self.distribution, "non_affine": self.non_affine,
            "spin": self.spin or defaults.spin, "update_geometry": self.update_geometry,
        }
        if structure.initial_forces is not None:  # a snapshot taken with its forces
            out.update(sigma0_Pa=None, initial_state="the snapshot's contact forces")
        if self.distribution == "maxwellian":
            out["maxwellian_reference"] = self.maxwellian_reference
        if law == "hertz":
            out.update(shear_modulus_Pa=_or(self.shear_modulus, defaults.shear_modulus),
                       poisson_ratio=_or(self.poisson_ratio, defaults.poisson_ratio))
        else:
            kn = float(_or(self.normal_stiffness, defaults.normal_stiffness))
            out.update(normal_stiffness_N_per_m=kn, shear_stiffness_N_per_m=float(
                _or(self.shear_stiffness, defaults.shear_stiffness_ratio * kn)))
            if structure.dimension == 2:
                out["thickness_m"] = float(_or(self.thickness, disc_thickness(structure)))
        return out


def _or(value: Any, default: Any) -> Any:
    return default if value is None else value


def _options(law, kn, ks, friction_angle, shear_modulus, poisson_ratio, thickness, sigma0,
             distribution, non_affine, spin, large_strain) -> ModelOptions:
    return ModelOptions(
        law=None if law is None else Law(law).value, normal_stiffness=kn, shear_stiffness=ks,
        friction_angle_deg=friction_angle, shear_modulus=shear_modulus,
        poisson_ratio=poisson_ratio, thickness=thickness, sigma0=sigma0,
        distribution="maxwellian" if distribution == Distribution.maxwellian_average
        else Distribution(distribution).value,
        maxwellian_reference="average" if distribution == Distribution.maxwellian_average
        else "overall", non_affine=non_affine,
        spin=None if spin is None else Spin(spin).value, update_geometry=large_strain)


def load_structure(name: str, seed: int, **options: Any) -> MicroElementStructure:
    """:func:`build_structure` with a status line while slow structures are made."""
    if name == "chang2d":
        with console.status(f"making the random packing of chang2d (seed {seed}): seconds to "
                            "minutes..."):
            return build_structure(name, seed, **options)
    return build_structure(name, seed, **options)


def _structure_label(name: str) -> str:
    return name if name in STRUCTURE_NAMES else Path(name).stem


def _setup(structure_name: str, seed: int, structure: MicroElementStructure,
           options: ModelOptions, **extra: Any) -> dict[str, Any]:
    return {"command": "grainlab microelement", "structure": structure_name, "seed": seed,
            "model": options.describe(structure), **extra}


# -- running --------------------------------------------------------------------------------------
@contextmanager
def _progress(description: str, total: int):
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task(description, total=total)
        yield bar, task


def _run(model: MicroElementModel, path: LoadPath, report: Callable[[int], None]) -> TestResult:
    """Run one test, relaying progress and printing the driver's warnings as notes."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = run_element_test(model, path, progress=lambda done, total: report(done))
        except np.linalg.LinAlgError as error:
            raise ConvergenceError(
                f"the model's linear algebra failed during {path.name!r} ({error}): the "
                "specimen has most likely lost its stiffness; try smaller steps") from None
    for warning in caught:
        console.print(f"[yellow]note:[/] {warning.message}")
    return result


