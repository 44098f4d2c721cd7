"""Reference pages written from the package's own registries when the site builds, so that no
key or column is described twice: the run config's keys (the pydantic models of
:mod:`grainlab.lab.run_config`: type, default, bounds, and the command-line option that sets
each with its help) and the test-result columns (:data:`grainlab.result.columns.COLUMNS`)."""

from __future__ import annotations

import inspect
import typing
from pathlib import Path

from pydantic import BaseModel

from grainlab.cli.run_options import RUN_OPTIONS
from grainlab.lab.run_config import RunConfig
from grainlab.result.columns import COLUMNS

BOUND_SIGNS = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}


def _cell(text: object) -> str:
    return str(text).replace("|", r"\|").replace("\n", " ")


def _kind(annotation) -> str:
    if typing.get_origin(annotation) is typing.Literal:
        return "one of " + ", ".join(f"`{a!r}`" for a in typing.get_args(annotation))
    name = getattr(annotation, "__name__", None)
    return f"`{name}`" if name else f"`{annotation}`".replace("typing.", "")


def _bounds(field) -> str:
    found = []
    for item in field.metadata:
        for attribute, sign in BOUND_SIGNS.items():
            value = getattr(item, attribute, None)
            if value is not None:
                found.append(f"{sign} {value:g}" if isinstance(value, float) else
                             f"{sign} {value}")
    return ", ".join(found)


def _default(field) -> str:
    if field.default_factory is not None:
        return "(table)"
    value = field.default
    return "(required)" if value is ... else f"`{value!r}`"


def _options() -> dict[str, list[tuple[str, str]]]:
    """Per config key, the command-line options that set it and their help."""
    found: dict[str, list[tuple[str, str]]] = {}
    for option in RUN_OPTIONS:
        for key in {option.key, option.compaction_key} - {None}:
            entry = (option.typed, option.help)
            if entry not in found.setdefault(key, []):
                found[key].append(entry)
    return found


def _tables(model: type[BaseModel], prefix: str, options, out: list[str]) -> None:
    rows, nested = [], []
    for name, field in model.model_fields.items():
        key = f"{prefix}.{name}" if prefix else name
        annotation = field.annotation
        if inspect.isclass(annotation) and issubclass(annotation, BaseModel):
            nested.append((key, annotation))
            continue
        set_by = "; ".join(f"`{typed}`: {_cell(help_)}" for typed, help_ in
                           options.get(key, []))
        rows.append(f"| `{key}` | {_kind(annotation)} | {_default(field)} | "
                    f"{_bounds(field)} | {set_by} |")
    if rows:
        out.append(f"## `[{prefix}]`\n" if prefix else "## top level\n")
        doc = inspect.getdoc(model) or ""
        if doc:
            out.append(_cell(doc.split("\n\n")[0]) + "\n")
        out.append("| key | type | default | bounds | command-line option and help |")
        out.append("|---|---|---|---|---|")
        out.extend(rows)
        out.append("")
    for key, annotation in nested:
        _tables(annotation, key, options, out)


def write_config_reference(path: Path) -> None:
    """Every key of a run's config.toml, table by table."""
    out: list[str] = []
    _tables(RunConfig, "", _options(), out)
    path.write_text("\n".join(out), encoding="utf-8")


def write_columns_reference(path: Path) -> None:
    """Every standard column of a test result: name, unit, meaning."""
    rows = ["| column | unit | meaning |", "|---|---|---|"]
    rows += [f"| `{name}` | {_cell(column.unit)} | {_cell(column.meaning)} |"
             for name, column in COLUMNS.items()]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")


RUN_FILES = ("`config.toml` (the config, every key), `results.csv` and `results.h5` (one row "
             "per record: the columns of the result-columns page), `snapshots.h5` (contact "
             "networks, for `grainlab analyse`), `checkpoint.h5` (for `grainlab resume`), "
             "`run.log`, `report/report.md` (`grainlab report`)")
FIGURES = {"oedometer": "`curves.png`: K0 and the vertical stress against the vertical "
                        "strain, by stage",
           "simple_shear": "`curves.png` (q/p, volumetric strain and packing fraction "
                           "against eps_q) and `simple_shear.png` (tau/sigma_v against "
                           "gamma, Hill's proposition, eq. 4.8 and the angles of seed 001 "
                           "Fig. 4.16)",
           "compaction": "`curves.png`: the packing fraction against time"}
LIMITS = {"oedometer": " In the periodic cell only with soft grains (`--solver dem`): rigid "
                       "grains cannot follow a compression whose every component is "
                       "strain-controlled there; the box of walls runs it with both solvers."}


def write_lab_tests_reference(path: Path) -> None:
    """One section per lab test of a discrete run: what it does at the defaults, the
    boundaries and dimensions that run it, the keys and options that set its targets, what
    it writes (from :mod:`grainlab.lab.kind_stages`, :data:`grainlab.lab.run_config.
    PERIODIC_ONLY` and :data:`grainlab.lab.option_scope.TEST_TARGETS`)."""
    from grainlab.lab.kind_stages import PLANAR_KINDS, kind_stages
    from grainlab.lab.option_scope import TEST_TARGETS
    from grainlab.lab.run_config import PERIODIC_ONLY, TEST_KINDS

    options = _options()
    out = []
    for kind in TEST_KINDS:
        config = RunConfig.model_validate({"test": {"kind": kind},
                                           "sample": {"boundary": "periodic"}})
        out.append(f"## `{kind}`\n")
        words = "an isotropic compaction to sigma0 and nothing after it" \
            if kind == "compaction" else kind_stages(config.test)[2]
        out.append(f"**What it does** (at the defaults): isotropic compaction to sigma0 until "
                   f"quasi-static, then {words}." if kind != "compaction" else
                   f"**What it does**: {words} (until quasi-static).")
        if kind in PLANAR_KINDS and kind != "compaction":
            out.append(f" With discs (2D, vertical axis y): {kind_stages(config.test, 2)[2]}.")
        out.append("\n")
        boundaries = "the periodic cell only (`--boundary periodic`)" if kind in \
            PERIODIC_ONLY else "a box of walls (default) or the periodic cell"
        out.append(f"**Where it runs**: {boundaries}; "
                   + ("spheres, aggregates, polyhedra and discs." if kind in PLANAR_KINDS
                      else "spheres, aggregates and polyhedra (3D only).")
                   + LIMITS.get(kind, ""))
        out.append("\n")
        targets = [key for key, kinds in TEST_TARGETS.items() if kind in kinds]
        rows = ["| key | option | help |", "|---|---|---|"]
        for key in ["test.sigma0", *targets]:
            for typed, help_ in options.get(key, [("", "")]):
                rows.append(f"| `{key}` | `{typed}` | {_cell(help_)} |")
        out.append("**Its targets**:\n")
        out.extend(rows)
        flag = " --boundary periodic" if kind in PERIODIC_ONLY else ""
        out.append(f"\n**Command**: `grainlab test {kind}{flag} --out RUN` (the other "
                   "options: the command-line page; the keys: the run-config page).\n")
        out.append(f"**What it writes** into RUN: {RUN_FILES}; "
                   + FIGURES.get(kind, "`curves.png`: q/p, volumetric strain and packing "
                                       "fraction against eps_q") + ".\n")
    path.write_text("\n".join(out), encoding="utf-8")
