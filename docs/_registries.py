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


SMALL_TARGETS = {"triaxial": {"eps_q_max": 0.1}, "extension": {"eps_q_max": 0.1},
                 "oedometer": {"axial_strain": 0.01, "unload_strain": 0.005},
                 "true_triaxial": {"b": 0.5, "eps_q_max": 0.1},
                 "cubical": {"b": 0.5, "eps_q_max": 0.1}, "simple_shear": {"gamma_max": 0.2},
                 "circular": {"q_ratio": 0.3, "circle_points": 8},
                 "cyclic_shear": {"amplitude": 0.01, "n_cycles": 2}}
"""Each test's targets on its page's small run (200 spheres: seconds each)."""

NOTEBOOK_HEADER = """---
file_format: mystnb
kernelspec:
  name: python3
  display_name: Python 3
---
"""


def lab_test_section(kind: str) -> list[str]:
    """What the lab test ``kind`` does at the defaults, the boundaries and dimensions that run
    it and its limits, the keys and options that set its targets, its command and what it
    writes (from :mod:`grainlab.lab.kind_stages`, :data:`grainlab.lab.run_config.
    PERIODIC_ONLY` and :data:`grainlab.lab.option_scope.TEST_TARGETS`): markdown lines."""
    from grainlab.lab.kind_stages import PLANAR_KINDS, kind_stages
    from grainlab.lab.option_scope import TEST_TARGETS
    from grainlab.lab.run_config import PERIODIC_ONLY

    config = RunConfig.model_validate({"test": {"kind": kind},
                                       "sample": {"boundary": "periodic"}})
    out = []
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
    options = _options()
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
    return out


def lab_test_run_cells(kind: str) -> list[str]:
    """A small run of ``kind`` and the figures it writes, as MyST code cells."""
    test = {"kind": kind, "sigma0": 1e4, **SMALL_TARGETS.get(kind, {})}
    return [
        "## A small run\n",
        "200 spheres in the periodic cell by soft DEM (κ = 1e3), the shear at an inertia "
        "number ≤ 2e-4, with small targets so that the page runs in seconds; the outcome "
        "says how each stage ended, and the figures are those the run writes.\n",
        "```{code-cell} python",
        "%matplotlib inline",
        "import tempfile",
        "from pathlib import Path",
        "",
        "from IPython.display import Image, display",
        "",
        "from grainlab.lab.discrete_run import start_run",
        "from grainlab.lab.run_config import RunConfig",
        "from grainlab.report.run_summary import write_run_figures",
        "",
        "config = RunConfig.model_validate({",
        '    "sample": {"shape": "sphere", "n_particles": 200, "seed": 1, '
        '"boundary": "periodic"},',
        f'    "test": {test!r},',
        '    "solver": {"method": "dem", "dem": {"kappa": 1e3},',
        '               "shear": {"inertia_number": 2e-4}},',
        '    "output": {"record_every": 5, "snapshot_every": 0, "vtk_every": 0}})',
        'folder = Path(tempfile.mkdtemp(prefix="grainlab-lab-test-")) / "run"',
        "result = start_run(folder, config).run()",
        'print(result.metadata["outcome"]["summary"])',
        "```\n",
        "```{code-cell} python",
        "for figure in write_run_figures(folder, result):",
        "    display(Image(filename=figure))",
        "```\n",
    ]


def write_lab_tests_reference(path: Path, pages: Path | None = None) -> None:
    """The lab tests of a discrete run: a section per test in ``path``
    (:func:`lab_test_section`); and, given ``pages`` (a folder), a page per test,
    ``pages/<kind>.md``: its section and a small run of it executed as the site builds
    (:func:`lab_test_run_cells`)."""
    from grainlab.lab.run_config import TEST_KINDS

    out = []
    for kind in TEST_KINDS:
        out.append(f"## `{kind}`\n")
        out.extend(lab_test_section(kind))
    path.write_text("\n".join(out), encoding="utf-8")
    if pages is None:
        return
    pages.mkdir(parents=True, exist_ok=True)
    for kind in TEST_KINDS:
        page = [NOTEBOOK_HEADER, f"# The `{kind}` test\n", *lab_test_section(kind),
                *lab_test_run_cells(kind)]
        (pages / f"{kind}.md").write_text("\n".join(page), encoding="utf-8")
