"""``grainlab packing2d``: regular packings of discs and seed 000's stress–strain theory."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from enum import StrEnum
from pathlib import Path

import numpy as np
import typer
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from grainlab._validate import in_range
from grainlab.cli.errors import friendly_errors
from grainlab.cli.inputs import figure_file, output_file, output_folder
from grainlab.contact.linear_spring import LinearSpring2D
from grainlab.contact.modified_hertz_mindlin import PAPER_SHEAR_MODULUS, ModifiedHertzMindlin2D
from grainlab.errors import InputError
from grainlab.geometry.disc_contacts import DEFAULT_CONTACT_TOLERANCE, find_disc_contacts
from grainlab.geometry.disc_packing import DiscPacking2D
from grainlab.geometry.power_tessellation import power_tessellation
from grainlab.micromech.regular_packing import (
    RegularPackingModel,
    RotatedStressPath,
    run_alpha_sweep,
    run_rotated_stress_path,
)
from grainlab.micromech.regular_packing.stress_path import PAPER_CONFINING_STRESS
from grainlab.prep.packing_files import read_packing
from grainlab.prep.regular_packings import (
    TABLE_1,
    named_packing,
    packing_description,
    packing_names,
)
from grainlab.report.curves import save_figure
from grainlab.report.packing_figures import (
    contact_force_figure,
    noncoaxiality_figure,
    strain_ratio_figure,
    stress_ratio_strain_figure,
    tessellation_figure,
)

app = typer.Typer(
    help=(
        "Regular packings of discs (cylinders) and the incremental stress-strain theory of "
        "Chang, Misra & Xue (1989): void ratio, coordination, radical-plane tessellation, "
        "stiffness, and stress paths with rotated principal axes."
    ),
    no_args_is_help=True,
    rich_markup_mode="markdown",
)
console = Console()


class Law(StrEnum):
    """Contact laws offered at the command line."""

    hertz_mindlin = "hertz-mindlin"
    linear = "linear"


class Control(StrEnum):
    """What the stress path holds constant."""

    sigma3 = "sigma3"
    p = "p"


PACKING_HELP = (
    "A named packing (square, rhombic, hexagonal, A, B, C, D) or a .toml/.csv packing file "
    "(lattice vectors, centres, radii in metres; see `grainlab packing2d show --help`)."
)


def load_packing(packing: str) -> DiscPacking2D:
    """A named packing, or one read from a file when ``packing`` is a path."""
    path = Path(packing)
    if path.suffix.lower() in (".toml", ".csv"):
        return read_packing(path)
    return named_packing(packing)


_TYPED = {
    "normal_stiffness": "--kn", "tangential_stiffness": "--ks",
    "shear_modulus": "--shear-modulus", "poisson_ratio": "--poisson-ratio", "psi": "--psi",
    "confining_stress": "--sigma0", "ratio_step": "--ratio-step", "max_ratio": "--max-ratio",
    "tolerance": "--tolerance",
}
"""Options named by the model's parameter names when the model refuses them (same units;
the angles, typed in degrees, are checked before: :func:`check_angles`)."""


@contextmanager
def options_as_typed() -> Iterator[None]:
    """Inside, an :class:`InputError` naming a model parameter names its option instead."""
    try:
        yield
    except InputError as error:
        if error.field not in _TYPED:
            raise
        raise InputError(_TYPED[error.field], error.value, error.allowed) from None


def check_angles(friction_angle: float, alpha: float | None = None) -> None:
    """The angles as typed, in degrees: friction in (0, 90), alpha in [-90, 90]."""
    in_range("--friction-angle", friction_angle, 0.0, 90.0, "deg")
    if alpha is not None:
        in_range("--alpha", alpha, -90.0, 90.0, "deg", closed="[]")


def make_law(
    law: Law, friction_angle: float, shear_modulus: float, poisson_ratio: float, psi: float,
    kn: float | None, ks: float | None,
):
    """Build the contact law from command-line options (angles in degrees)."""
    phi = np.radians(friction_angle)
    if law is Law.linear:
        if kn is None:
            raise InputError("--kn", kn, "a normal stiffness in N/m^2 with --law linear")
        return LinearSpring2D(kn, kn if ks is None else ks, phi)
    return ModifiedHertzMindlin2D(shear_modulus, poisson_ratio, psi, phi)


@app.command("table")
@friendly_errors
def table_command(
    csv: Path | None = typer.Option(None, help="Also write the table to this CSV file."),
    tolerance: float = typer.Option(
        DEFAULT_CONTACT_TOLERANCE, help="Relative gap below which discs count as touching."
    ),
) -> None:
    """Print Table 1 of Chang, Misra & Xue 1989 (void ratio, coordination number) for every
    named packing, beside the paper's values."""
    if csv is not None:
        output_file("--csv", csv)
    table = Table(title="Regular packings of Chang, Misra & Xue 1989 (Table 1: A-D)")
    for column in ("packing", "e", "e (paper)", "CN", "CN (paper)", "contacts per disc"):
        table.add_column(column)
    lines = ["packing,void_ratio,void_ratio_paper,coordination_number,"
             "coordination_number_paper,contacts_per_disc,description"]
    for name in packing_names():
        packing = named_packing(name)
        contacts = find_disc_contacts(packing, tolerance)
        cn = contacts.coordination_number(packing.n_particles)
        per = " ".join(
            f"{label}:{k}" for label, k in zip(
                packing.labels, contacts.per_particle(packing.n_particles), strict=True)
        )
        paper_e, paper_cn = TABLE_1.get(name, (None, None))
        table.add_row(
            name, f"{packing.void_ratio:.5f}", "" if paper_e is None else f"{paper_e:.4f}",
            f"{cn:.2f}", "" if paper_cn is None else f"{paper_cn:.2f}", per,
        )
        lines.append(
            f"{name},{packing.void_ratio!r},{'' if paper_e is None else paper_e},{cn!r},"
            f"{'' if paper_cn is None else paper_cn},{per},"
            f"\"{packing_description(name)}\""
        )
    console.print(table)
    for name in packing_names():
        console.print(f"  {name}: {packing_description(name)}")
    if csv is not None:
        csv.parent.mkdir(parents=True, exist_ok=True)
        csv.write_text("\n".join(lines) + "\n", encoding="utf-8")
        console.print(f"wrote {csv}")


@app.command("show")
@friendly_errors
def show_command(
    packing: str = typer.Argument(..., help=PACKING_HELP),
    out: Path = typer.Option(Path("tessellation.png"), help="Figure to write (.png/.pdf/.svg)."),
    tolerance: float = typer.Option(DEFAULT_CONTACT_TOLERANCE, help="Relative contact gap."),
) -> None:
    """Describe one packing (cell, discs, contacts, power cells) and draw its tessellation.

    A packing file in TOML gives `name`, `lattice = [[a1x, a1y], [a2x, a2y]]` and one
    `[[particles]]` table per disc with `x`, `y`, `radius` (and optional `label`), in metres.
    In CSV: columns kind,x,y,radius,label with two `lattice` rows and one `particle` row per disc.
    """
    figure_file("--out", out)
    p = load_packing(packing)
    with options_as_typed():
        contacts = find_disc_contacts(p, tolerance)
    tessellation = power_tessellation(p)
    console.print(
        f"[bold]{p.name}[/]: {p.n_particles} discs, cell area {p.cell.area:.6g} m^2, "
        f"void ratio {p.void_ratio:.5f}, coordination number "
        f"{contacts.coordination_number(p.n_particles):.4f}"
    )
    table = Table()
    for column in ("disc", "x [m]", "y [m]", "radius [m]", "contacts", "cell area [m^2]",
                   "local e"):
        table.add_column(column)
    local = tessellation.local_void_ratios(p.radii)
    counts = contacts.per_particle(p.n_particles)
    for k in range(p.n_particles):
        table.add_row(p.labels[k], f"{p.centres[k, 0]:.6g}", f"{p.centres[k, 1]:.6g}",
                      f"{p.radii[k]:.6g}", str(counts[k]), f"{tessellation.areas[k]:.6g}",
                      f"{local[k]:.4f}")
    console.print(table)
    save_figure(tessellation_figure(p), out)
    console.print(f"wrote {out}")


def _common_model(packing, law, friction_angle, shear_modulus, poisson_ratio, psi, kn, ks,
                  tolerance):
    return RegularPackingModel(
        load_packing(packing),
        make_law(law, friction_angle, shear_modulus, poisson_ratio, psi, kn, ks),
        tolerance,
    )


LAW_OPTION = typer.Option(Law.hertz_mindlin, help="Contact law: the modified "
                          "Hertz-Mindlin of Chang, Misra & Xue 1989 (eqs. 17-19) or linear "
                          "springs (--kn, --ks).")
PHI_OPTION = typer.Option(15.0, help="Interparticle friction angle phi_mu [deg].")
G_OPTION = typer.Option(PAPER_SHEAR_MODULUS, help="Equivalent shear modulus G~ [Pa] "
                        "(Hertz-Mindlin).")
NU_OPTION = typer.Option(0.1, help="Poisson ratio nu (Hertz-Mindlin).")
PSI_OPTION = typer.Option(2.5, help="Psi of eq. 18 (1 = Mindlin).")
KN_OPTION = typer.Option(None, help="Normal stiffness per unit length [N/m^2] (linear law).")
KS_OPTION = typer.Option(None, help="Tangential stiffness [N/m^2] (linear law; default kn).")
SIGMA0_OPTION = typer.Option(PAPER_CONFINING_STRESS, help="Initial isotropic stress [Pa].")
CONTROL_OPTION = typer.Option(Control.sigma3, help="Hold sigma_3 (sigma3) or the mean "
                              "stress (p) at sigma0 while sigma_1/sigma_3 grows.")
STEP_OPTION = typer.Option(0.05, help="Stress-ratio increment between records.")
MAX_RATIO_OPTION = typer.Option(10.0, help="Stop at this sigma_1/sigma_3 if not failed.")
TOL_OPTION = typer.Option(DEFAULT_CONTACT_TOLERANCE, help="Relative contact gap tolerance.")


@app.command("load")
@friendly_errors
def load_command(
    packing: str = typer.Option("C", help=PACKING_HELP),
    alpha: float = typer.Option(
        30.0, help="Direction of sigma_1 from the Y axis, counter-clockwise [deg], in "
        "[-90, 90]."
    ),
    out: Path | None = typer.Option(
        None, help="Output folder [default: packing2d-PACKING-alphaALPHA]"
    ),
    law: Law = LAW_OPTION,
    friction_angle: float = PHI_OPTION,
    shear_modulus: float = G_OPTION,
    poisson_ratio: float = NU_OPTION,
    psi: float = PSI_OPTION,
    kn: float | None = KN_OPTION,
    ks: float | None = KS_OPTION,
    sigma0: float = SIGMA0_OPTION,
    control: Control = CONTROL_OPTION,
    ratio_step: float = STEP_OPTION,
    max_ratio: float = MAX_RATIO_OPTION,
    tolerance: float = TOL_OPTION,
) -> None:
    """Load a packing from the isotropic state sigma0 along a stress path whose major
    principal axis is at ALPHA from the Y axis, until failure; write the test result
    (result.csv, result.h5) and Figs. 7 and 10 of Chang, Misra & Xue 1989."""
    check_angles(friction_angle, alpha)
    if out is not None:
        output_folder("--out", out)
    with options_as_typed():
        model = _common_model(packing, law, friction_angle, shear_modulus, poisson_ratio, psi,
                              kn, ks, tolerance)
        path = RotatedStressPath(np.radians(alpha), sigma0, control.value, ratio_step,
                                 max_ratio)
    out = output_folder("--out", out or Path(f"packing2d-{model.packing.name}-alpha{alpha:g}"))
    with Progress(console=console, transient=True) as bar:
        task = bar.add_task(f"packing {model.packing.name}, alpha {alpha:g} deg", total=1.0)
        result = run_rotated_stress_path(
            model, path, progress=lambda f: bar.update(task, completed=f)
        )
    report_load(model, result, out)


def report_load(model, result, out: Path) -> None:
    csv_path, h5_path = result.save(out)
    save_figure(stress_ratio_strain_figure(result), out / "fig7_stress_ratio_strains.png")
    save_figure(contact_force_figure(model, result), out / "fig10_contact_forces.png")
    last = result.table.iloc[-1]
    status = result.outcome["status"]
    if status == "failure":  # the specimen's strength, not a fault of the program
        ratio = result.outcome.get("failure_stress_ratio")
        words = "specimen failure (strength reached" + (
            f" at sigma_1/sigma_3 = {ratio:.4g})" if ratio is not None else ")")
    else:
        words = status
    console.print(f"[bold]{result.metadata['title']}[/]: {words} — {result.outcome['reason']}")
    console.print(
        f"last record: sigma_1/sigma_3 = {last['stress_ratio']:.4g}, eps_xx = "
        f"{last['eps_xx']:.4g}, eps_yy = {last['eps_yy']:.4g}, gamma_xy = {last['gamma_xy']:.4g}"
        f", non-coaxiality = {last['noncoaxiality_deg']:.3g} deg, "
        f"max particle force residual = {result.table['max_force_residual'].max():.3g} "
        "(x mean contact force)"
    )
    console.print(f"wrote {csv_path}, {h5_path} and figures in {out}/")


def parse_alphas(text: str) -> list[float]:
    """'0,15,30' or 'start:stop:step' (stop included) [deg] -> list of degrees."""
    try:
        if ":" in text:
            start, stop, step = (float(v) for v in text.split(":"))
            if step <= 0:
                raise ValueError
            values = list(np.arange(start, stop + step * 1e-9, step))
        else:
            values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError("--alphas", text, "comma-separated degrees or start:stop:step") from None
    if not values or any(abs(v) > 90 for v in values):
        raise InputError("--alphas", text, "angles in [-90, 90] degrees")
    return values


@app.command("sweep")
@friendly_errors
def sweep_command(
    packing: str = typer.Option("C", help=PACKING_HELP),
    alphas: str = typer.Option("0:90:15", help="Loading directions [deg]: '0,30,45' or "
                               "start:stop:step."),
    reference_ratio: float = typer.Option(
        1.5, help="sigma_1/sigma_3 at which strain ratios and non-coaxiality are read."
    ),
    out: Path | None = typer.Option(None, help="Output folder [default: packing2d-PACKING-sweep]"),
    law: Law = LAW_OPTION,
    friction_angle: float = PHI_OPTION,
    shear_modulus: float = G_OPTION,
    poisson_ratio: float = NU_OPTION,
    psi: float = PSI_OPTION,
    kn: float | None = KN_OPTION,
    ks: float | None = KS_OPTION,
    sigma0: float = SIGMA0_OPTION,
    control: Control = CONTROL_OPTION,
    ratio_step: float = STEP_OPTION,
    max_ratio: float = MAX_RATIO_OPTION,
    tolerance: float = TOL_OPTION,
) -> None:
    """Run the stress path for several loading directions alpha and draw Figs. 7-9
    of Chang, Misra & Xue 1989: strains, strain ratios gamma_xy/eps_x and eps_x/eps_y, and
    non-coaxiality against alpha."""
    check_angles(friction_angle)
    angles = parse_alphas(alphas)
    if out is not None:
        output_folder("--out", out)
    with options_as_typed():
        model = _common_model(packing, law, friction_angle, shear_modulus, poisson_ratio, psi,
                              kn, ks, tolerance)
        path = RotatedStressPath(0.0, sigma0, control.value, ratio_step, max_ratio)
    out = output_folder("--out", out or Path(f"packing2d-{model.packing.name}-sweep"))
    with Progress(console=console, transient=True) as bar:
        task = bar.add_task(f"packing {model.packing.name}: {len(angles)} directions",
                            total=len(angles))
        summary, results = run_alpha_sweep(
            model, np.radians(angles), path, reference_ratio,
            progress=lambda done, total: bar.update(task, completed=done),
        )
    summary.save(out, "summary")
    for angle, result in zip(angles, results, strict=True):
        result.save(out, f"alpha{angle:g}")
    save_figure(stress_ratio_strain_figure(results), out / "fig7_stress_ratio_strains.png")
    save_figure(strain_ratio_figure(summary), out / "fig8_strain_ratios.png")
    save_figure(noncoaxiality_figure(summary), out / "fig9_noncoaxiality.png")
    table = Table(title=summary.metadata["title"])
    shown = {
        "alpha_deg": ("alpha [deg]", "{:.4g}"), "failure_stress_ratio": ("failure R", "{:.4g}"),
        "eps_xx": ("eps_x [%]", "{:.4f}"), "eps_yy": ("eps_y [%]", "{:.4f}"),
        "gamma_xy": ("gamma_xy [%]", "{:.4f}"), "gamma_xy_over_eps_xx": ("gamma/eps_x", "{:.3g}"),
        "eps_xx_over_eps_yy": ("eps_x/eps_y", "{:.3g}"),
        "noncoaxiality_deg": ("non-coax. [deg]", "{:.3g}"),
        "initial_noncoaxiality_deg": ("initial non-coax.", "{:.3g}"),
    }
    percent = {"eps_xx", "eps_yy", "gamma_xy"}
    for label, _ in shown.values():
        table.add_column(label, justify="right")
    for _, row in summary.table.iterrows():
        table.add_row(*(
            fmt.format(100 * row[c] if c in percent else row[c]) for c, (_, fmt) in shown.items()
        ))
    console.print(table)
    console.print(f"wrote summary.csv/.h5, one result per alpha and figures in {out}/")
