"""The sizes the discrete wing's layout is held to, over source folders: files over 800 lines,
functions over 100 lines, compiled kernels (``@njit``/``@jit``) over 30 parameters and Python
functions over 15 (``self`` counted), with the largest of each.

    .venv/bin/python benchmarks/code_sizes.py src/grainlab/engine src/grainlab/lab src/grainlab/cli
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

LIMITS = {"file_lines": 800, "function_lines": 100, "kernel_parameters": 30,
          "python_parameters": 15}
"""The limits (docs/explanations/discrete-engine.md, "The engine's layout")."""


def _compiled(node: ast.FunctionDef) -> bool:
    """Whether a Numba decorator compiles the function."""
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        if getattr(target, "id", getattr(target, "attr", "")) in ("njit", "jit"):
            return True
    return False


def _parameters(node: ast.FunctionDef) -> int:
    a = node.args
    return (len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + bool(a.vararg)
            + bool(a.kwarg))


def folder_sizes(folder: Path) -> dict[str, list[tuple[int, str]]]:
    """(size, where) of everything over its limit in ``folder``, by kind of limit, largest
    first, and the largest of each kind under ``largest_<kind>``."""
    found: dict[str, list[tuple[int, str]]] = {kind: [] for kind in LIMITS}
    largest = {kind: (0, "") for kind in LIMITS}

    def count(kind: str, size: int, where: str) -> None:
        largest[kind] = max(largest[kind], (size, where))
        if size > LIMITS[kind]:
            found[kind].append((size, where))

    for path in sorted(folder.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        count("file_lines", len(text.splitlines()), str(path.relative_to(folder)))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                where = f"{path.relative_to(folder)}:{node.name}"
                count("function_lines", node.end_lineno - node.lineno + 1, where)
                kind = "kernel_parameters" if _compiled(node) else "python_parameters"
                count(kind, _parameters(node), where)
    for kind in LIMITS:
        found[kind].sort(reverse=True)
        found[f"largest_{kind}"] = [largest[kind]]
    return found


def main(folders: list[str]) -> None:
    for name in folders:
        sizes = folder_sizes(Path(name))
        print(f"== {name}")
        for kind, limit in LIMITS.items():
            size, where = sizes[f"largest_{kind}"][0]
            over = ", ".join(f"{w} ({s})" for s, w in sizes[kind]) or "none"
            print(f"   {kind} > {limit}: {over}; largest {size} ({where})")


if __name__ == "__main__":
    main(sys.argv[1:] or ["src/grainlab/engine", "src/grainlab/lab", "src/grainlab/cli"])
