"""What a discrete run says when it ends: its summary in words (:func:`run_summary`) and its
figures (:func:`write_run_figures`), from its test result (the columns of
:mod:`grainlab.result.columns`, the ``stage`` column and the run's metadata).

The summary states the end of the compaction (packing fraction, coordination number z with
and without rattlers, z_c, p, and for polyhedra the share of each contact type), then the
shear (peak q/p and, over the last :data:`~grainlab.lab.solver_comparison.RESIDUAL_SHARE` of
eps_q, the residual q/p, packing fraction, z, and the largest inertia number) or, for an
oedometer, each stage's strain reached against the one asked, sigma_zz and K0 at its end and
what they mean on rigid grains (:data:`RIGID_OEDOMETER`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from grainlab.lab.solver_registry import DEFAULT_SOLVER, solver_record
from grainlab.result.columns import in_dimension
from grainlab.result.test_result import TestResult

RIGID_OEDOMETER = (
    "rigid grains: the sample cannot compress beyond rearrangement, so the oedometer is "
    "degenerate: the vertical stress comes from the overlaps the solver leaves and from the "
    "loading rate, and K0 is not an elastic K0 (deformable contacts: --solver dem)")
"""What the summary of an oedometer run on rigid grains says about its meaning."""


def asked_test(result: TestResult) -> dict[str, Any]:
    """The [test] table of the run's config (kind, sigma0, targets): the test asked."""
    return result.metadata["parameters"]["config"]["test"]


def write_run_figures(folder: Path, result: TestResult) -> list[Path]:
    """Write the run's figures into ``folder`` and return their paths: curves.png (K0 and
    sigma_zz against eps_zz by stage for an oedometer; q/p, volumetric strain and packing
    fraction against eps_q for the shear stages, or the packing fraction against time for a
    compaction) and simple_shear.png for a simple shear (seed 001 Figs. 4.15-4.16)."""
    from grainlab.report.curves import save_figure

    kind = asked_test(result)["kind"]
    if kind == "oedometer":
        from grainlab.report.element_test_figures import oedometer_stages_figure

        return [save_figure(oedometer_stages_figure(result), folder / "curves.png", dpi=120)]
    from grainlab.report.run_curves import discrete_curves_figure

    figures = [save_figure(discrete_curves_figure(result), folder / "curves.png", dpi=120)]
    if kind == "simple_shear":
        from grainlab.report.element_test_figures import simple_shear_figure

        # tau/sigma_v, Hill's proposition, eq. 4.8 and the angles of seed 001 Fig. 4.16
        figures.append(save_figure(simple_shear_figure(result), folder / "simple_shear.png",
                                   dpi=120))
    return figures


def type_fractions(row) -> str:
    """``", contact types fv 0.120 ee ..."`` from the ``fraction_<type>`` columns of a row
    (polyhedra); "" without them."""
    names = [k for k in row.index if str(k).startswith("fraction_")]
    if not names:
        return ""
    return ", contact types " + " ".join(f"{k[len('fraction_'):]} {row[k]:.3f}"
                                         for k in names)


def oedometer_summary(result: TestResult) -> list[str]:
    """Loading and unloading: strains reached against those asked, the vertical stress
    (sigma_zz; sigma_yy in 2D) [Pa] and K0 at the end of each, and what they mean on rigid
    grains."""
    table, asked = result.table, asked_test(result)
    steps = {s["name"]: s["steps"] for s in result.metadata["outcome"]["stages"]}
    loading = table[table["stage"] == "loading"]
    unloading = table[table["stage"] == "unloading"]
    eps, sigma = (in_dimension(c, table.columns) for c in ("eps_zz", "sigma_zz"))
    lines = []
    if len(loading):
        end = loading.iloc[-1]
        lines.append(f"loading: to {eps} {end[eps]:.6g} (asked "
                     f"{asked['axial_strain']:g}) in {steps.get('loading', '?')} steps; at the "
                     f"end of loading {sigma} {end[sigma]:.4g} Pa, K0 {end['K0']:.4f}")
    if len(unloading) and len(loading):
        end, top = unloading.iloc[-1], loading.iloc[-1]
        lines.append(f"unloading: by {top[eps] - end[eps]:.6g} (asked "
                     f"{asked['unload_strain']:g}) to {eps} {end[eps]:.6g} in "
                     f"{steps.get('unloading', '?')} steps; at the end of unloading {sigma} "
                     f"{end[sigma]:.4g} Pa, K0 {end['K0']:.4f}")
    solver = result.metadata["parameters"]["config"].get("solver", {})
    if not solver_record(solver.get("method", DEFAULT_SOLVER)).deformable:
        lines.append(f"note: {RIGID_OEDOMETER}")
    return lines


def run_summary(result: TestResult) -> list[str]:
    """The run's summary, one line each (module docstring): first ``TITLE: N rows, S steps``,
    then the end of the compaction, then the shear or the oedometer's stages."""
    from grainlab.lab.solver_comparison import RESIDUAL_SHARE, residual_rows

    table = result.table
    last = table.iloc[-1]
    lines = [f"{result.metadata['title']}: {len(table)} rows, {int(last['step'])} steps"]
    shear = table[table["stage"] != "compaction"]
    compaction = table[table["stage"] == "compaction"]
    if len(compaction):
        c = compaction.iloc[-1]
        lines.append(f"end of compaction: packing fraction {c['packing_fraction']:.4f}, "
                     f"z {c['z']:.3f} (no rattlers {c['z_no_rattlers']:.3f}), "
                     f"z_c {c['z_c']:.3f}, p {c['p']:.4g} Pa{type_fractions(c)}")
    if asked_test(result)["kind"] == "oedometer":
        lines += oedometer_summary(result)
    elif len(shear) > 2:
        peak = shear["q_over_trace"].max()
        late = residual_rows(shear)
        lines.append(f"shear: peak q/p {peak:.4f}; over the last {100 * RESIDUAL_SHARE:g} % "
                     f"of eps_q: q/p {late['q_over_trace'].mean():.4f}, packing fraction "
                     f"{late['packing_fraction'].mean():.4f}, z {late['z'].mean():.3f}; "
                     f"max inertia number {shear['inertia_number'].max():.2e}"
                     f"{type_fractions(late.mean(numeric_only=True))}")
    return lines
