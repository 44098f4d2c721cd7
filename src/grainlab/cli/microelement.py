"""``grainlab microelement``: element tests on seed 001's micro-element model.

Commands: ``presets`` (the load paths), ``run`` (one path on one structure), ``sweep-b``
(cubical tests at several b), ``circular`` (circular stress paths on the octahedral plane) and
``cyclic`` (cyclic simple shear at several amplitudes). Each writes test results (CSV and HDF5)
and the figures of seed 001 that fit the test.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import typer
from rich.console import Console
from rich.table import Table

from grainlab._validate import seed as check_seed
from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import output_folder
from grainlab.cli.microelement_options import (
    AFFINE_OPTION,
    DISTRIBUTION_OPTION,
    G_OPTION,
    GEOMETRY_OPTION,
    KN_OPTION,
    KS_OPTION,
    LAW_OPTION,
    NU_OPTION,
    PHI_OPTION,
    SEED_OPTION,
    SET_OPTION,
    SIGMA0_OPTION,
    SPIN_OPTION,
    STEPS_OPTION,
    STRUCTURE_HELP,
    STRUCTURE_OPTION,
    THICKNESS_OPTION,
    Distribution,
    Law,
    Spin,
    _options,
    _progress,
    _run,
    _setup,
    _structure_label,
    load_structure,
    parse_list,
    parse_sets,
)
from grainlab.cli.microelement_snapshot import (
    PERIODIC_OPTION,
    SNAPSHOT_FORCES_OPTION,
    SNAPSHOT_INDEX_OPTION,
    WALLS_OPTION,
    PeriodicContacts,
    WallContacts,
    snapshot_options,
)
from grainlab.errors import InputError
from grainlab.lab import presets as preset_functions
from grainlab.lab.derived import (
    cyclic_shear_response,
    failure_point,
    fit_kappa,
    k0_series,
    mobilised_friction_angle,
    octahedral_coordinates,
    peak_friction_angle,
    principal_angles,
)
from grainlab.lab.load_path import LoadPath
from grainlab.lab.micro_element_setup import (
    THREE_D_ONLY,
    TWO_D_ONLY,
    default_path_parameters,
    mean_stress,
    reference_strain,
)
from grainlab.lab.presets import preset, preset_description, preset_names
from grainlab.micromech.micro_element.model import MicroElementModel
from grainlab.report.curves import save_figure
from grainlab.report.element_test_figures import (
    b_sweep_figure,
    circular_path_figure,
    cyclic_figure,
    hysteresis_figure,
    k0_figure,
    simple_shear_figure,
    strain_octahedral_coordinates,
    triaxial_figure,
    vertical_strain_column,
)
from grainlab.result.test_result import TestResult

app = typer.Typer(
    help=(
        "Element tests on the micromechanical model of Chang 1991 (micro-elements: a "
        "centre particle and its neighbours, linked to the whole by a distribution law). "
        "Pick a structure (`--structure idealized|binary|chang2d|FILE`), a contact law and a "
        "load path; get a test result (CSV/HDF5) and the figures of Chang 1991. Start with "
        "`grainlab microelement presets`, then `grainlab microelement run`."
    ),
    no_args_is_help=True,
    rich_markup_mode="markdown",
)

console = Console()


def _path(name: str, model: MicroElementModel, steps: int, sets: dict[str, Any],
          fixed: dict[str, Any] | None = None) -> tuple[LoadPath, dict[str, Any]]:
    """The preset with the default parameters, the user's --set and the command's own."""
    for key in fixed or {}:
        if key in sets:
            raise InputError(f"--set {key}", sets[key], "no value: this command sets "
                             f"{key} itself (see its options)")
    parameters = {**default_path_parameters(name, model, steps), **sets, **(fixed or {})}
    return preset(name, **parameters), parameters


def _jsonable(parameters: dict[str, Any]) -> dict[str, Any]:
    return {k: (v if isinstance(v, str | bool | int | float) or v is None else str(v))
            for k, v in parameters.items()}


def _derived(result: TestResult, name: str) -> TestResult:
    """Derived columns of one test in the test-result format (friction angle, eta = q/p, K0 and
    OCR, octahedral coordinates, simple-shear angles), aligned with the result's rows."""
    table = result.table
    columns: dict[str, Any] = {"increment": table["increment"], "stage": table["stage"]}
    units: dict[str, str] = {}
    columns["phi_mobilised"] = mobilised_friction_angle(table["sigma_1"], table["sigma_3"])
    units["phi_mobilised"] = "rad"
    columns["eta"] = (table["q"] / table["p"].where(table["p"] > 0.0)).to_numpy()
    units["eta"] = "-"
    if name == "oedometer":
        series = k0_series(table)
        for column in series.columns:
            columns[column] = series[column].to_numpy()
            units[column] = "Pa" if column.startswith("sigma") else "-"
    if "sigma_zz" in table:
        c = octahedral_coordinates(table["sigma_xx"], table["sigma_yy"], table["sigma_zz"])
        for column in ("oct_x", "oct_y", "q_equivalent"):
            columns[column] = c[column].to_numpy()
            units[column] = "Pa"
        for column in ("alpha", "lode_angle"):
            columns[column] = c[column].to_numpy()
            units[column] = "rad"
        columns["eps_oct_x"], columns["eps_oct_y"] = strain_octahedral_coordinates(table)
        units.update(eps_oct_x="-", eps_oct_y="-")
    if name == "simple_shear":
        angles = principal_angles(table)
        for column in angles.columns:
            columns[column] = angles[column].to_numpy()
            units[column] = "-" if column == "tau_over_sigma_v" else "rad"
    frame = pd.DataFrame(columns)
    return TestResult.create(frame, specimen=result.specimen, load_path=result.load_path,
                             parameters={"derived_from": "the result table of the same test"},
                             outcome=result.outcome, units=units,
                             dimension=int(result.metadata.get("dimension", 3)),
                             title=f"{result.metadata.get('title', '')}: derived outputs")


FIGURES: dict[str, tuple[str, Callable[[TestResult], Any]]] = {
    "isotropic_compression": ("triaxial.png", triaxial_figure),
    "oedometer": ("k0.png", k0_figure),
    "triaxial_compression": ("triaxial.png", triaxial_figure),
    "triaxial_extension": ("triaxial.png", triaxial_figure),
    "true_triaxial": ("triaxial.png", triaxial_figure),
    "cubical_constant_sigma3": ("triaxial.png", triaxial_figure),
    "biaxial": ("biaxial.png", triaxial_figure),
    "circular_octahedral": ("circular_path.png", circular_path_figure),
    "simple_shear": ("simple_shear.png", simple_shear_figure),
    "cyclic_shear": ("hysteresis.png", hysteresis_figure),
}
"""The figure written by ``run`` for each preset (file name, function)."""


def _outcome_line(result: TestResult) -> str:
    outcome = result.outcome
    status = outcome.get("status")
    words = "specimen failure (strength reached)" if status == "failure" else status
    text = (f"[bold]{result.metadata.get('title', '')}[/]: {words} after "
            f"{outcome.get('steps_completed')} steps")
    if outcome.get("status") == "failure":
        text += f" (stage {outcome.get('stage')!r}, step {outcome.get('step')}): " \
                f"{outcome.get('reason')}"
    if outcome.get("unconverged_steps"):
        text += f"; {outcome['unconverged_steps']} step(s) above the stress tolerance"
    return text


def _print_summary(result: TestResult, name: str) -> None:
    table = result.table
    console.print(_outcome_line(result))
    vertical = vertical_strain_column(table)
    try:
        phi, row = peak_friction_angle(table)
        console.print(f"peak mobilised friction angle: {math.degrees(phi):.2f} deg at row {row} "
                      f"({vertical} = {100 * table[vertical].iloc[row]:.4g} %)")
    except InputError:
        pass
    if name == "oedometer":
        series = k0_series(table)
        loading = np.flatnonzero((table["stage"] == "loading").to_numpy())
        if loading.size:
            console.print(f"K0 at the end of loading: {series['K0'].iloc[loading[-1]]:.4f} "
                          f"(sigma_v = {series['sigma_v'].iloc[loading[-1]] / 1e3:.4g} kPa)")
        if (table["stage"] == "unloading").any():
            console.print(f"K0 at the end of unloading: {series['K0'].iloc[-1]:.4f} at "
                          f"OCR = {series['OCR'].iloc[-1]:.4g}")
    if name == "simple_shear":
        rows = (table["stage"] == "shear").to_numpy()
        angles = principal_angles(table)[rows]
        if rows.any():
            ratio = angles["tau_over_sigma_v"].to_numpy(dtype=float)
            k = int(np.nanargmax(ratio))
            try:
                kappa = f"{fit_kappa(ratio, angles['psi']):.3f}"
            except InputError:
                kappa = "n/a"
            console.print(f"peak tau/sigma_v = {ratio[k]:.4f} (beta there = "
                          f"{math.degrees(angles['beta'].iloc[k]):.1f} deg); kappa of "
                          f"tau/sigma_v = kappa tan psi: {kappa}")
    if name == "cyclic_shear":
        try:
            loops = cyclic_shear_response(table)
        except InputError:
            loops = None
        if loops is not None:
            for _, loop in loops.iterrows():
                console.print(f"cycle {int(loop['cycle'])}: G_s = "
                              f"{loop['secant_modulus'] / 1e6:.5g} MPa, damping "
                              f"{100 * loop['damping_ratio']:.3g} %")
    last = table.iloc[-1]
    console.print(f"last row: p = {last['p'] / 1e3:.5g} kPa, q = {last['q'] / 1e3:.5g} kPa, "
                  f"{vertical} = {100 * last[vertical]:.4g} %, eps_vol = "
                  f"{100 * last['eps_vol']:.4g} %")


# -- commands -------------------------------------------------------------------------------------
@app.command("presets")
@friendly_errors
def presets_command() -> None:
    """List the load paths (presets) with what they do and the parameters `--set` can change.

    Strains are compression positive and dimensionless; stresses in Pa; angles (alpha0) in
    radians. The `run` command fills every parameter with a default suited to the structure
    (see `run --help`); `--set KEY=VALUE` overrides one.
    """
    table = Table(title="Load paths of `grainlab microelement run --path NAME`")
    table.add_column("name", no_wrap=True)
    for column in ("structures", "what it does", "parameters (--set KEY=VALUE)"):
        table.add_column(column)
    for name in preset_names():
        dims = "3D" if name in THREE_D_ONLY else "2D" if name in TWO_D_ONLY else "2D, 3D"
        function = getattr(preset_functions, name)
        keys = [k for k in inspect.signature(function).parameters if k != "dimension"]
        table.add_row(name, dims, preset_description(name), ", ".join(keys))
    console.print(table)


@app.command("run")
@friendly_errors
def run_command(
    path: str = typer.Option("triaxial_compression", "--path", help="The load path: a preset "
                             "name (`grainlab microelement presets` lists them)."),
    sets: list[str] | None = SET_OPTION,
    structure: str = STRUCTURE_OPTION,
    seed: int = SEED_OPTION,
    law: Law | None = LAW_OPTION,
    kn: float | None = KN_OPTION,
    ks: float | None = KS_OPTION,
    friction_angle: float | None = PHI_OPTION,
    shear_modulus: float | None = G_OPTION,
    poisson_ratio: float | None = NU_OPTION,
    thickness: float | None = THICKNESS_OPTION,
    distribution: Distribution = DISTRIBUTION_OPTION,
    non_affine: bool = AFFINE_OPTION,
    spin: Spin | None = SPIN_OPTION,
    large_strain: bool = GEOMETRY_OPTION,
    sigma0: float | None = SIGMA0_OPTION,
    steps: int = STEPS_OPTION,
    out: Path | None = typer.Option(None, help="Output folder [default: "
                                    "microelement-PATH-STRUCTURE]."),
    snapshot_forces: bool = SNAPSHOT_FORCES_OPTION,
    snapshot_index: int = SNAPSHOT_INDEX_OPTION,
    periodic_contacts: PeriodicContacts = PERIODIC_OPTION,
    wall_contacts: WallContacts = WALLS_OPTION,
) -> None:
    """Run one load path on one structure and write the test result, derived outputs and
    the figure of Chang 1991 that fits the path.

    A snapshot of a discrete run (`--structure RUN/snapshots.h5`) starts from the run's
    contact forces (its stress) unless --consolidate is given; the path's defaults then
    scale with that stress.

    The specimen is consolidated isotropically to sigma0, then loaded along the preset with
    defaults scaled to it (stresses ~ sigma0, strains ~ sigma0 / stiffness): e.g.
    `--path oedometer` loads and unloads (K0 against OCR, Figs. 3.3, 4.6),
    `--path triaxial_compression` (Fig. 4.9), `--path biaxial` on a 2D structure (Figs.
    3.4-3.6), `--path simple_shear` (Figs. 4.15-4.16), `--path circular_octahedral`
    (Fig. 4.14). Change any preset parameter with `--set KEY=VALUE`.

    Writes into OUT: result.csv/.h5 (one row per step: stresses, strains, principal values,
    sliding and open contacts, ...), derived.csv/.h5 (friction angle, q/p, K0/OCR, octahedral
    coordinates, simple-shear angles), and the figure. Prints the outcome, the peak friction
    angle, K0 at the ends of loading and unloading, kappa of simple shear, ...
    """
    options = _options(law, kn, ks, friction_angle, shear_modulus, poisson_ratio, thickness,
                       sigma0, distribution, non_affine, spin, large_strain)
    user = parse_sets(sets)
    if path not in preset_names():
        raise InputError("--path", path, "one of " + ", ".join(preset_names()))
    check_seed("--seed", seed)
    if out is not None:
        output_folder("--out", out)
    specimen = load_structure(structure, seed, **snapshot_options(
        structure, snapshot_forces, snapshot_index, periodic_contacts, wall_contacts))
    model = options.build(specimen)
    eps_ref = reference_strain(model)
    load_path, parameters = _path(path, model, steps, user)
    out = output_folder("--out", out or Path(f"microelement-{path}-"
                                            f"{_structure_label(structure)}"))
    with _progress(f"{path} on {_structure_label(structure)}", load_path.n_steps) as (bar, task):
        result = _run(model, load_path, lambda done: bar.update(task, completed=done))
    result.metadata["setup"] = _setup(structure, seed, specimen, options, preset=path,
                                      preset_parameters=_jsonable(parameters),
                                      reference_strain=eps_ref)
    csv_path, _ = result.save(out, "result")
    _derived(result, path).save(out, "derived")
    figure_name, figure = FIGURES[path]
    save_figure(figure(result), out / figure_name)
    _print_summary(result, path)
    console.print(f"wrote {csv_path.name}, result.h5, derived.csv/.h5 and {figure_name} "
                  f"in {out}/")


SWEEP_PATHS = {"constant-sigma3": "cubical_constant_sigma3", "constant-p": "true_triaxial"}
"""The cubical paths of ``sweep-b --path``: what is held besides b, and the preset."""


@app.command("sweep-b")
@friendly_errors
def sweep_b_command(
    cubical_path: str = typer.Option(
        "constant-sigma3", "--path", help="What is held besides b: constant-sigma3 (the "
        "minor stress sigma_3 = sigma0, Lade & Duncan's cubical tests, with which Chang 1991 "
        "compares; b = 1 is its 'extension') or constant-p (the mean stress p = sigma0)."),
    b: str = typer.Option("0,0.2,0.4,0.6,0.8,1", "--b", help="Values of b = (sigma_2 - "
                          "sigma_3)/(sigma_1 - sigma_3): '0,0.5,1' or start:stop:step."),
    sets: list[str] | None = SET_OPTION,
    structure: str = STRUCTURE_OPTION,
    seed: int = SEED_OPTION,
    law: Law | None = LAW_OPTION,
    kn: float | None = KN_OPTION,
    ks: float | None = KS_OPTION,
    friction_angle: float | None = PHI_OPTION,
    shear_modulus: float | None = G_OPTION,
    poisson_ratio: float | None = NU_OPTION,
    distribution: Distribution = DISTRIBUTION_OPTION,
    non_affine: bool = AFFINE_OPTION,
    spin: Spin | None = SPIN_OPTION,
    large_strain: bool = GEOMETRY_OPTION,
    sigma0: float | None = SIGMA0_OPTION,
    steps: int = typer.Option(100, "--steps", help="Steps of each test (the preset's n_steps)."),
    out: Path = typer.Option(Path("microelement-b-sweep"), help="Output folder."),
) -> None:
    """Cubical (true) triaxial tests at constant minor stress sigma_3 = sigma0 (`--path
    constant-sigma3`, preset cubical_constant_sigma3) or constant mean stress p = sigma0
    (`--path constant-p`, preset true_triaxial), one per b (Chang 1991 §4.2.2): z major, x
    intermediate, y minor principal axis.

    Writes one result per b (b0.csv/.h5, b0.5.csv/.h5, ...), a summary (summary.csv/.h5: per
    b the peak friction angle, the failure point on the octahedral plane and the strain
    increment there), b_sweep.png (Figs. 4.11-4.13: peak angle against b; failure points with
    the Mohr-Coulomb, Matsuoka-Nakai and Lade-Duncan surfaces through the triaxial-compression
    angle; strain-increment directions at failure) and stress_strain.png (Fig. 4.9).
    `--set strain=...` changes the deviator strain of every test.
    """
    if cubical_path not in SWEEP_PATHS:
        raise InputError("--path", cubical_path, "one of " + ", ".join(SWEEP_PATHS))
    preset_name = SWEEP_PATHS[cubical_path]
    values = parse_list("--b", b, 0.0, 1.0)
    options = _options(law, kn, ks, friction_angle, shear_modulus, poisson_ratio, None,
                       sigma0, distribution, non_affine, spin, large_strain)
    user = parse_sets(sets)
    check_seed("--seed", seed)
    output_folder("--out", out)
    specimen = load_structure(structure, seed)
    if specimen.dimension != 3:
        raise InputError("--structure", structure, "a 3D structure (cubical tests)")
    models = [options.build(specimen) for _ in values]
    paths = [_path(preset_name, m, steps, user, {"b": v}) for m, v in zip(models, values,
                                                                              strict=True)]
    results: list[TestResult] = []
    total = sum(p.n_steps for p, _ in paths)
    with _progress(f"{preset_name} at {len(values)} values of b", total) as (bar, task):
        offset = 0
        for model, (load_path, _) in zip(models, paths, strict=True):
            results.append(_run(model, load_path, lambda done, o=offset: bar.update(
                task, completed=o + done)))
            offset += load_path.n_steps
    setup = _setup(structure, seed, specimen, options, preset=preset_name,
                   preset_parameters=_jsonable({k: v for k, v in paths[0][1].items()
                                                if k != "b"}))
    for value, result in zip(values, results, strict=True):
        result.metadata["setup"] = setup
        result.save(out, f"b{value:g}")
    summary = b_sweep_summary(values, results, setup, preset_name)
    summary.save(out, "summary")
    save_figure(b_sweep_figure(summary), out / "b_sweep.png")
    save_figure(triaxial_figure(results, [f"b = {v:g}" for v in values]),
                out / "stress_strain.png")
    view = Table(title=f"Peak friction angle against b, {cubical_path} (at the peak: "
                 "converged?, eps_zz, direction of the strain increment on the octahedral "
                 "plane)")
    for column in ("b", "status", "peak phi [deg]", "converged", "eps_zz [%]",
                   "d_eps angle [deg]"):
        view.add_column(column, justify="right")
    for _, row in summary.table.iterrows():
        view.add_row(f"{row['b']:g}", str(row["status"]), f"{np.degrees(row['phi_peak']):.2f}",
                     "yes" if row["converged_at_failure"] else "no",
                     f"{100 * row['eps_zz_at_failure']:.4g}",
                     f"{np.degrees(row['deps_direction']):.1f}")
    console.print(view)
    console.print(f"wrote summary.csv/.h5, one result per b, b_sweep.png and stress_strain.png "
                  f"in {out}/")


SUMMARY_UNITS = {
    "b": "-", "b_at_failure": "-", "phi_peak": "rad", "phi_peak_deg": "deg",
    "failure_row": "-", "converged_at_failure": "-", "status": "-", "oct_x_over_p": "-",
    "oct_y_over_p": "-",
    "lode_angle": "rad", "alpha": "rad", "eps_zz_at_failure": "-", "deps_xx": "-",
    "deps_yy": "-", "deps_zz": "-", "deps_vol": "-", "deps_oct_x": "-", "deps_oct_y": "-",
    "deps_direction": "rad",
}
"""Units of the b-sweep summary columns."""


def b_sweep_summary(b_values: Sequence[float], results: Sequence[TestResult],
                    setup: dict[str, Any] | None = None,
                    preset_name: str = "true_triaxial") -> TestResult:
    """One row per b: the failure point (peak mobilised friction angle,
    :func:`grainlab.lab.derived.failure_point`) and the strain increment of the step that
    reached it (``converged_at_failure``: whether the driver met its stress tolerance on that
    row; ``deps_*``; on the octahedral plane ``deps_oct_x`` = (de_x - de_y)/sqrt 2,
    ``deps_oct_y`` = (2 de_z - de_x - de_y)/sqrt 6, ``deps_direction`` = atan2 of the two,
    the angle from the z projection as ``alpha`` of the stresses). ``preset_name``: the
    cubical path of the tests (``true_triaxial`` or ``cubical_constant_sigma3``)."""
    rows = []
    for b, result in zip(b_values, results, strict=True):
        table = result.table
        point = failure_point(table)
        row = int(point["row"])
        before = max(row - 1, 0)
        d = {c: float(table[c].iloc[row] - table[c].iloc[before])
             for c in ("eps_xx", "eps_yy", "eps_zz")}
        dx = (d["eps_xx"] - d["eps_yy"]) / math.sqrt(2.0)
        dy = (2.0 * d["eps_zz"] - d["eps_xx"] - d["eps_yy"]) / math.sqrt(6.0)
        rows.append({
            "b": float(b), "b_at_failure": point["b"], "phi_peak": point["phi"],
            "phi_peak_deg": math.degrees(point["phi"]), "failure_row": row,
            "converged_at_failure": bool(table["converged"].iloc[row])
            if "converged" in table else True,
            "status": str(result.outcome.get("status", "")),
            "oct_x_over_p": point["oct_x / p"], "oct_y_over_p": point["oct_y / p"],
            "lode_angle": point["lode_angle"], "alpha": point["alpha"],
            "eps_zz_at_failure": float(table["eps_zz"].iloc[row]),
            "deps_xx": d["eps_xx"], "deps_yy": d["eps_yy"], "deps_zz": d["eps_zz"],
            "deps_vol": d["eps_xx"] + d["eps_yy"] + d["eps_zz"],
            "deps_oct_x": dx, "deps_oct_y": dy, "deps_direction": math.atan2(dx, dy),
        })
    specimen = results[0].specimen if results else {}
    return TestResult.create(
        pd.DataFrame(rows, columns=list(SUMMARY_UNITS)), specimen=specimen,
        load_path={"name": "b_sweep", "preset": preset_name,
                   "b_values": [float(v) for v in b_values]},
        parameters={"setup": setup or {}}, outcome={"status": "completed", "n_tests": len(rows)},
        units=SUMMARY_UNITS, dimension=3, title="peak friction angle against b")


@app.command("circular")
@friendly_errors
def circular_command(
    alphas: str = typer.Option("0", "--alphas", help="Starting angles alpha0 on the "
                               "octahedral plane [deg] (0: triaxial compression along z, 60: "
                               "extension): '0,30,60' or start:stop:step."),
    radius: str = typer.Option("0.5", "--radius", help="Radii of the circles as q/p (q = "
                               "sqrt(3 J2)): '0.3,0.6'. Every alpha0 is run with every radius."),
    sets: list[str] | None = SET_OPTION,
    structure: str = STRUCTURE_OPTION,
    seed: int = SEED_OPTION,
    law: Law | None = LAW_OPTION,
    kn: float | None = KN_OPTION,
    ks: float | None = KS_OPTION,
    friction_angle: float | None = PHI_OPTION,
    shear_modulus: float | None = G_OPTION,
    poisson_ratio: float | None = NU_OPTION,
    distribution: Distribution = DISTRIBUTION_OPTION,
    non_affine: bool = AFFINE_OPTION,
    spin: Spin | None = SPIN_OPTION,
    large_strain: bool = GEOMETRY_OPTION,
    sigma0: float | None = SIGMA0_OPTION,
    steps: int = STEPS_OPTION,
    out: Path = typer.Option(Path("microelement-circular"), help="Output folder."),
) -> None:
    """Circular stress paths on the octahedral plane at constant p = sigma0 and constant q
    (Chang 1991 §4.2.3): a radial approach to (q, alpha0), then one full turn in --steps steps.

    Writes one result per circle (alpha0_r0.5.csv/.h5, ...), summary.csv/.h5 (final strains,
    largest deviatoric strain) and circular_path.png (Fig. 4.14: stress path and strain path
    on the octahedral plane).
    """
    angles = parse_list("--alphas", alphas, -360.0, 360.0)
    radii = parse_list("--radius", radius, 1e-9, 10.0)
    options = _options(law, kn, ks, friction_angle, shear_modulus, poisson_ratio, None,
                       sigma0, distribution, non_affine, spin, large_strain)
    user = parse_sets(sets)
    check_seed("--seed", seed)
    output_folder("--out", out)
    specimen = load_structure(structure, seed)
    if specimen.dimension != 3:
        raise InputError("--structure", structure, "a 3D structure (octahedral plane)")
    cases = [(a, r) for a in angles for r in radii]
    runs = []
    for a, r in cases:
        model = options.build(specimen)
        p = mean_stress(model)
        load_path, parameters = _path("circular_octahedral", model, steps, user,
                                      {"alpha0": math.radians(a), "radius_q": r * p})
        runs.append((model, load_path, parameters))
    results = []
    with _progress(f"{len(cases)} circular path(s)", sum(r[1].n_steps for r in runs)) as (
            bar, task):
        offset = 0
        for model, load_path, _ in runs:
            results.append(_run(model, load_path, lambda done, o=offset: bar.update(
                task, completed=o + done)))
            offset += load_path.n_steps
    rows = []
    labels = []
    for (a, r), result, (_, _, parameters) in zip(cases, results, runs, strict=True):
        result.metadata["setup"] = _setup(structure, seed, specimen, options,
                                          preset="circular_octahedral",
                                          preset_parameters=_jsonable(parameters))
        result.save(out, f"alpha{a:g}_r{r:g}")
        table = result.table
        ex, ey = strain_octahedral_coordinates(table)
        last = table.iloc[-1]
        rows.append({"alpha0_deg": a, "radius_q_over_p": r,
                     "status": str(result.outcome.get("status")),
                     "steps_completed": int(result.outcome.get("steps_completed", 0)),
                     "eps_xx": float(last["eps_xx"]), "eps_yy": float(last["eps_yy"]),
                     "eps_zz": float(last["eps_zz"]), "eps_vol": float(last["eps_vol"]),
                     "max_deviatoric_strain": float(np.nanmax(np.hypot(ex, ey)))})
        labels.append(f"alpha0 = {a:g} deg, q/p = {r:g}")
    summary = TestResult.create(
        pd.DataFrame(rows), specimen=results[0].specimen,
        load_path={"name": "circular_sweep", "preset": "circular_octahedral"},
        parameters={"setup": results[0].metadata["setup"]},
        outcome={"status": "completed", "n_tests": len(rows)},
        units={"alpha0_deg": "deg", "radius_q_over_p": "-", "status": "-",
               "steps_completed": "-", "max_deviatoric_strain": "-"},
        dimension=3, title="circular stress paths")
    summary.save(out, "summary")
    save_figure(circular_path_figure(results, labels), out / "circular_path.png")
    for row in rows:
        console.print(f"alpha0 = {row['alpha0_deg']:g} deg, q/p = {row['radius_q_over_p']:g}: "
                      f"{row['status']} ({row['steps_completed']} steps); final eps_zz = "
                      f"{100 * row['eps_zz']:.4g} %, eps_vol = {100 * row['eps_vol']:.4g} %")
    console.print(f"wrote summary.csv/.h5, one result per circle and circular_path.png in "
                  f"{out}/")


@app.command("cyclic")
@friendly_errors
def cyclic_command(
    amplitudes: str = typer.Option("1e-6,1e-5,1e-4,1e-3", "--amplitudes", help="Shear-strain "
                                   "amplitudes gamma [-] (not %): '1e-5,1e-4' or "
                                   "start:stop:step."),
    cycles: int = typer.Option(2, "--cycles", help="Cycles per amplitude; the last one is "
                               "reported."),
    steps_per_quarter: int = typer.Option(10, "--steps-per-quarter", help="Steps from 0 to "
                                          "the amplitude (a cycle has 4 times as many)."),
    sets: list[str] | None = SET_OPTION,
    structure: str = typer.Option("binary", "--structure", help=STRUCTURE_HELP + " [default: "
                                  "binary, as in Chang 1991 §4.1.3]"),
    seed: int = SEED_OPTION,
    law: Law | None = LAW_OPTION,
    kn: float | None = KN_OPTION,
    ks: float | None = KS_OPTION,
    friction_angle: float | None = PHI_OPTION,
    shear_modulus: float | None = G_OPTION,
    poisson_ratio: float | None = NU_OPTION,
    thickness: float | None = THICKNESS_OPTION,
    distribution: Distribution = DISTRIBUTION_OPTION,
    non_affine: bool = AFFINE_OPTION,
    spin: Spin | None = SPIN_OPTION,
    large_strain: bool = GEOMETRY_OPTION,
    sigma0: float | None = SIGMA0_OPTION,
    out: Path = typer.Option(Path("microelement-cyclic"), help="Output folder."),
) -> None:
    """Strain-controlled cyclic simple shear at several amplitudes, the vertical stress held
    at sigma0 (Chang 1991 §4.1.3): secant modulus and damping against amplitude.

    G_max is the tangent shear modulus of the consolidated specimen before cycling; G_s the
    secant modulus and D = W_loop / (4 pi W_elastic) the damping ratio of the last cycle.
    Writes one result per amplitude (gamma1e-05.csv/.h5, ...), summary.csv/.h5 and cyclic.png
    (Figs. 4.3-4.4: G_s/G_max and damping against amplitude).
    """
    values = parse_list("--amplitudes", amplitudes, 1e-12, 1.0)
    for option, value in (("--cycles", cycles), ("--steps-per-quarter", steps_per_quarter)):
        if value < 1:
            raise InputError(option, value, "an integer >= 1")
    options = _options(law, kn, ks, friction_angle, shear_modulus, poisson_ratio, thickness,
                       sigma0, distribution, non_affine, spin, large_strain)
    user = parse_sets(sets)
    check_seed("--seed", seed)
    output_folder("--out", out)
    specimen = load_structure(structure, seed)
    runs = []
    g_max = math.nan
    for amplitude in values:
        model = options.build(specimen)
        shear = 4 if model.dimension == 3 else 2  # gamma_xz (3D), gamma_xy (2D) in Voigt order
        g_max = float(model.tangent()[shear, shear])
        load_path, parameters = _path("cyclic_shear", model, 8 * steps_per_quarter, user,
                                      {"amplitude": amplitude, "n_cycles": cycles,
                                       "steps_per_quarter": steps_per_quarter})
        runs.append((model, load_path, parameters))
    results = []
    with _progress(f"cyclic shear at {len(values)} amplitudes",
                   sum(r[1].n_steps for r in runs)) as (bar, task):
        offset = 0
        for model, load_path, _ in runs:
            results.append(_run(model, load_path, lambda done, o=offset: bar.update(
                task, completed=o + done)))
            offset += load_path.n_steps
    rows = []
    for amplitude, result, (_, _, parameters) in zip(values, results, runs, strict=True):
        result.metadata["setup"] = _setup(structure, seed, specimen, options,
                                          preset="cyclic_shear",
                                          preset_parameters=_jsonable(parameters), g_max=g_max)
        result.save(out, f"gamma{amplitude:g}")
        row: dict[str, Any] = {"amplitude": amplitude,
                               "status": str(result.outcome.get("status"))}
        try:
            loop = cyclic_shear_response(result.table).iloc[-1]
            row.update(cycle=int(loop["cycle"]), gamma_amplitude=float(loop["gamma_amplitude"]),
                       tau_amplitude=float(loop["tau_amplitude"]),
                       secant_modulus=float(loop["secant_modulus"]), g_max=g_max,
                       modulus_ratio=float(loop["secant_modulus"]) / g_max,
                       damping_ratio=float(loop["damping_ratio"]))
        except InputError:
            row.update(cycle=0, gamma_amplitude=amplitude, tau_amplitude=math.nan,
                       secant_modulus=math.nan, g_max=g_max, modulus_ratio=math.nan,
                       damping_ratio=math.nan)
        rows.append(row)
    summary = TestResult.create(
        pd.DataFrame(rows), specimen=results[0].specimen,
        load_path={"name": "cyclic_sweep", "preset": "cyclic_shear"},
        parameters={"setup": results[0].metadata["setup"]},
        outcome={"status": "completed", "n_tests": len(rows)},
        units={"amplitude": "-", "status": "-", "cycle": "-", "gamma_amplitude": "-",
               "tau_amplitude": "Pa", "secant_modulus": "Pa", "g_max": "Pa",
               "modulus_ratio": "-", "damping_ratio": "-"},
        dimension=int(results[0].metadata.get("dimension", 3)),
        title="secant modulus and damping against amplitude")
    summary.save(out, "summary")
    save_figure(cyclic_figure(summary), out / "cyclic.png")
    view = Table(title=f"Cyclic simple shear (G_max = {g_max / 1e6:.5g} MPa)")
    for column in ("amplitude", "status", "G_s [MPa]", "G_s/G_max", "damping [%]"):
        view.add_column(column, justify="right")
    for row in rows:
        view.add_row(f"{row['amplitude']:g}", row["status"],
                     f"{row['secant_modulus'] / 1e6:.5g}", f"{row['modulus_ratio']:.4f}",
                     f"{100 * row['damping_ratio']:.3g}")
    console.print(view)
    console.print(f"wrote summary.csv/.h5, one result per amplitude and cyclic.png in {out}/")
