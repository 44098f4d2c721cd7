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

SHARED = ("errors", "_validate", "_version", "_numba_setup", "_vector_loops")
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
