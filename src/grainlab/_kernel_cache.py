"""Numba's cache of compiled kernels, kept fresh against every module a kernel's module imports.

A cached kernel holds the machine code of the compiled functions it calls, but Numba checks
only the source of the file that defines it: after an edit of a callee in another module (the
polyhedra's manifold called by the narrow phase's pair kernel, a contact law called by a force
pass), or an upgrade that rewrites some files and not others, the cache runs the old callee
and gives other numbers without a word. Here the freshness stamp of a kernel of grainlab is
the content hash of its own file and of every grainlab module that file imports, directly or
through others (the import statements anywhere in the files, read from their lines once per
process and again when a file changes): an edit anywhere in that closure recompiles the
kernel on its next use.

The stamp replaces Numba's own for the files of the packages in :data:`PACKAGES` (grainlab;
tests add their own); Numba's three file-backed places stay (``NUMBA_CACHE_DIR``, the
``__pycache__`` beside the source, the user-wide cache where that is read-only). Installed by
:func:`install`, from :mod:`grainlab._numba_setup`, before any kernel is defined.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
import warnings
from pathlib import Path

_THIS_MODULE = Path(__file__).resolve()

PACKAGES: dict[str, Path] = {"grainlab": _THIS_MODULE.parent}
"""Package name -> its folder: the kernels whose stamp covers their imports."""


def _package_of(path: str) -> tuple[str, Path] | None:
    resolved = Path(path).resolve()
    for name, folder in PACKAGES.items():
        if resolved.is_relative_to(folder):
            return name, folder
    return None


def _module_file(module: str, name: str, folder: Path) -> Path | None:
    """The file of module ``module`` (dotted) of package ``name`` in ``folder``, or None."""
    parts = module.split(".")
    if parts[0] != name:
        return None
    base = folder.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


_FROM_IMPORT = re.compile(r"^[ \t]*from[ \t]+(\.*)([\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n#;]+)",
                          re.M)
_IMPORT = re.compile(r"^[ \t]*import[ \t]+([^\n#;]+)", re.M)


def _names(text: str) -> list[str]:
    """The names of an import list (``a as b, c`` or a parenthesised one)."""
    names = []
    for part in text.strip().strip("()").split(","):
        words = part.split()
        if words:
            names.append(words[0])
    return names


@functools.cache
def _imported(path: str, mtime_ns: int, size: int, name: str, folder: Path) -> tuple[str, ...]:
    """The files of package ``name`` that the file at ``path`` imports (any import statement
    in it, at any indentation, absolute or relative, ``from m import n`` counting m and m.n
    where that is a module; read from its lines, a superset of what runs: a name in a string
    that looks like an import only adds a file); memoized on the file's modification time and
    size."""
    source = Path(path).read_text(encoding="utf-8").replace("\\\n", " ")
    here = Path(path).resolve().relative_to(folder).with_suffix("").parts
    package = [name, *here[:-1]]  # the package a relative import starts from
    modules: set[str] = set()
    for match in _IMPORT.finditer(source):
        modules.update(_names(match.group(1)))
    for match in _FROM_IMPORT.finditer(source):
        dots, module, names = match.groups()
        if dots:
            stem = package[:len(package) - (len(dots) - 1)]
            base = ".".join(stem + ([module] if module else []))
        else:
            base = module
        modules.add(base)
        modules.update(f"{base}.{n}" for n in _names(names))
    files = {_module_file(m, name, folder) for m in modules}
    return tuple(sorted(str(f) for f in files if f is not None))


def _imports_of(path: str, name: str, folder: Path) -> tuple[str, ...]:
    stat = os.stat(path)
    return _imported(path, stat.st_mtime_ns, stat.st_size, name, folder)


def import_closure(path: str | Path) -> list[Path]:
    """The file at ``path`` and every file of its package that it imports, directly or
    through others, sorted (the file alone outside :data:`PACKAGES`)."""
    path = str(Path(path).resolve())
    package = _package_of(path)
    if package is None:
        return [Path(path)]
    seen, todo = {path}, [path]
    while todo:
        for other in _imports_of(todo.pop(), *package):
            if other not in seen:
                seen.add(other)
                todo.append(other)
    return sorted(Path(p) for p in seen)


@functools.cache
def _content_hash(path: str, mtime_ns: int, size: int) -> bytes:
    return hashlib.sha256(Path(path).read_bytes()).digest()


def dependency_stamp(path: str | Path) -> str:
    """The freshness stamp of the kernels defined in the file at ``path``: a SHA-256 over the
    content hashes of :func:`import_closure` (file names relative to the package folder, so
    that a moved checkout keeps its cache)."""
    package = _package_of(str(path))
    digest = hashlib.sha256()
    for file in import_closure(path):
        if file == _THIS_MODULE:
            continue  # this module compiles nothing: its edits leave every kernel as it was
        stat = os.stat(file)
        label = str(file.relative_to(package[1])) if package else file.name
        digest.update(label.encode())
        digest.update(_content_hash(str(file), stat.st_mtime_ns, stat.st_size))
    return digest.hexdigest()


def install() -> None:
    """Put the stamped locators first in Numba's cache lookup (once)."""
    import numba
    from numba.core import caching

    class _ImportsStamped:
        """A file-backed locator whose stamp is :func:`dependency_stamp`, for the files of
        :data:`PACKAGES` only."""

        def get_source_stamp(self):
            return dependency_stamp(self._py_file)

        @classmethod
        def from_function(cls, py_func, py_file):
            if not os.path.exists(py_file) or _package_of(py_file) is None:
                return None
            return super().from_function(py_func, py_file)

    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    if impl is None or not isinstance(getattr(impl, "_locator_classes", None), list):
        warnings.warn(f"numba {numba.__version__}: no cache locator list found; a cached kernel "
                      "is checked against its own file only (delete the __pycache__ folders "
                      "after editing a module it calls)", RuntimeWarning, stacklevel=2)
        return
    locators = impl._locator_classes
    if any(getattr(c, "grainlab_stamp", False) for c in locators):
        return
    stamped = [type(f"ImportsStamped{base.__name__}", (_ImportsStamped, base),
                    {"grainlab_stamp": True})
               for base in (caching.UserProvidedCacheLocator, caching.InTreeCacheLocator,
                            caching.UserWideCacheLocator)]
    locators[:0] = stamped
