"""The layers of ARCHITECTURE.md: a lower layer never imports a higher one.

Every ``import grainlab.X`` / ``from grainlab.X import ...`` anywhere in a module counts,
at the top or inside a function (a lazy import that dodges a layer is still a dependency) or
under ``if TYPE_CHECKING:``. Examples in docstrings do not count. The package's own
``__init__`` (the public face) and the small shared modules (errors, checks, version, numba
set-up, vector-loop building blocks), which import no layer, are outside the order.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parents[1] / "src" / "grainlab"

LAYERS = ("result", "geometry", "contact", "analysis", "engine", "micromech", "prep", "lab",
          "report", "study", "cli")
"""Lowest first: a module of layer k may import layers 0..k only."""

SHARED = ("errors", "_validate", "_version", "_numba_setup", "_kernel_cache", "_vector_loops",
          "_live_progress")
"""Top-level modules every layer may import; they import no layer themselves."""

KNOWN_EXCEPTIONS = {
    # the discrete run writes ParaView frames (output.vtk_every, export_checkpoint_vtk) with
    # the VTK writer of the report layer
    ("grainlab.lab.discrete_run", "grainlab.report.vtk_export"),
}
"""Upward imports that remain, each to be removed here when its module is moved."""


def module_name(path: Path, source: Path = SOURCE) -> str:
    """Dotted name of the module at ``path`` in the package folder ``source``."""
    parts = path.relative_to(source.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path, source: Path = SOURCE) -> set[str]:
    """Every grainlab module the file imports, wherever the import statement sits."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = module_name(path, source).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the file's package
                base = package[:len(package) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            if name == "grainlab":  # from grainlab import lab, ...
                found.update(f"grainlab.{alias.name}" for alias in node.names)
            else:
                found.add(name)
    return {name for name in found if name == "grainlab" or name.startswith("grainlab.")}


def layer_of(module: str) -> str | None:
    """The layer (sub-package) of a grainlab module; None for shared modules and the root."""
    parts = module.split(".")
    if len(parts) < 2 or parts[1] in SHARED:
        return None
    if parts[1] not in LAYERS:
        raise AssertionError(f"{module} belongs to no layer: add its package to LAYERS")
    return parts[1]


def upward_imports(source: Path = SOURCE) -> set[tuple[str, str]]:
    """(importing module, imported module) for every import of a higher layer, of the root
    package from a layer, or of a layer from a shared module."""
    found = set()
    for path in sorted(source.rglob("*.py")):
        module = module_name(path, source)
        if module == "grainlab":
            continue
        own = layer_of(module)
        for target in imported_modules(path, source):
            if target == "grainlab":
                found.add((module, target))
                continue
            layer = layer_of(target)
            if layer is None:
                continue
            if own is None or LAYERS.index(layer) > LAYERS.index(own):
                found.add((module, target))
    return found


def test_no_layer_imports_a_higher_one():
    upward = upward_imports() - KNOWN_EXCEPTIONS
    assert not upward, "imports of higher layers:\n" + "\n".join(
        f"  {module} -> {target}" for module, target in sorted(upward))


def test_known_exceptions_are_still_there():
    """A removed exception must leave the list, so that it cannot come back unnoticed."""
    assert upward_imports() >= KNOWN_EXCEPTIONS


@pytest.mark.parametrize("code, target", [
    ("from grainlab.lab.presets import preset\n", "grainlab.lab.presets"),
    ("def f():\n    from grainlab.lab import test_result\n", "grainlab.lab"),
    ("import grainlab.prep.loose_sample as ls\n", "grainlab.prep.loose_sample"),
    ("from grainlab import lab\n", "grainlab.lab"),
    ("from ..prep import loose_sample\n", "grainlab.prep"),
])
def test_the_scan_finds_upward_imports_wherever_they_sit(tmp_path, code, target):
    engine = tmp_path / "grainlab" / "engine"
    engine.mkdir(parents=True)
    (engine / "module.py").write_text(code, encoding="utf-8")
    assert upward_imports(tmp_path / "grainlab") == {("grainlab.engine.module", target)}


ENGINE = SOURCE / "engine"

ENGINE_BODIES = ("state", "shape_kinds", "quaternion", "gyroscopic", "body_order", "planar")
"""The engine's top-level body modules: they import no engine sub-package."""

ENGINE_RANKS = {"bodies": 0, "detect": 1, "boundaries": 2, "run": 3, "nscd": 4, "dem": 4}
"""The engine's own layers (grainlab/engine/__init__.py), lowest first: a module may import
its own rank and lower ones, and the two solvers (rank 4) never each other."""


def engine_part(module: str) -> str | None:
    """The engine layer of a grainlab module (None outside the engine)."""
    parts = module.split(".")
    if len(parts) < 3 or parts[1] != "engine":
        return None
    if parts[2] in ENGINE_RANKS:
        return parts[2]
    return "bodies" if parts[2] in ENGINE_BODIES else "run"


def engine_imports(source: Path = SOURCE, *, typing_only: bool = True) -> dict[str, set[str]]:
    """Each engine module -> the engine modules it imports (wherever the import sits; with
    ``typing_only`` False, not those under ``if TYPE_CHECKING:``, which never run)."""
    graph = {}
    for path in sorted((source / "engine").rglob("*.py")):
        module = module_name(path, source)
        found = imported_modules(path, source)
        if not typing_only:
            found -= typing_imports(path, source)
        graph[module] = {target for target in found if engine_part(target) is not None}
    return graph


def typing_imports(path: Path, source: Path = SOURCE) -> set[str]:
    """The grainlab modules imported only under ``if TYPE_CHECKING:`` in the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    inside, outside = set(), set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            for statement in node.body:
                if isinstance(statement, ast.ImportFrom) and statement.module:
                    inside.add(statement.module)
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module in inside and \
                node.col_offset == 0:
            outside.add(node.module)
    return inside - outside


def test_the_engine_layers_hold():
    wrong = []
    for module, targets in engine_imports().items():
        own = engine_part(module)
        for target in targets:
            part = engine_part(target)
            if module.endswith("__init__") or target in ("grainlab.engine",):
                continue
            if ENGINE_RANKS[part] > ENGINE_RANKS[own] or \
                    (ENGINE_RANKS[part] == ENGINE_RANKS[own] == 4 and part != own):
                wrong.append(f"  {module} ({own}) -> {target} ({part})")
    assert not wrong, "engine imports against its layers:\n" + "\n".join(sorted(wrong))


def test_the_engine_has_no_import_cycle():
    """No engine module imports, when it runs, one that imports it back. An import for type
    annotations alone may close a loop (the shape-kind registry's functions take the
    library the registry's kinds build), since it never runs; the layers above count it."""
    graph = engine_imports(typing_only=False)
    state = {}

    def visit(module, trail):
        if state.get(module) == "done":
            return
        if state.get(module) == "open":
            raise AssertionError("import cycle: " + " -> ".join([*trail, module]))
        state[module] = "open"
        for target in sorted(graph.get(module, ())):
            visit(target, [*trail, module])
        state[module] = "done"

    for module in sorted(graph):
        visit(module, [])


def test_the_engine_scan_sees_a_solver_importing_the_other(tmp_path):
    for folder in ("engine/nscd", "engine/dem"):
        (tmp_path / "grainlab" / folder).mkdir(parents=True)
    (tmp_path / "grainlab" / "engine" / "dem" / "soft.py").write_text(
        "def f():\n    from grainlab.engine.nscd.sweep import g\n", encoding="utf-8")
    assert engine_imports(tmp_path / "grainlab")["grainlab.engine.dem.soft"] == \
        {"grainlab.engine.nscd.sweep"}
    assert engine_part("grainlab.engine.nscd.sweep") == "nscd"
    assert engine_part("grainlab.engine.state") == "bodies"
    assert engine_part("grainlab.engine.simulation") == "run"
