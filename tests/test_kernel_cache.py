"""The compiled-kernel cache is checked against every module a kernel's module imports
(grainlab._kernel_cache): a kernel whose callee changed in another file is compiled again, an
unchanged one is loaded from the cache."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

from grainlab import _kernel_cache
from grainlab._kernel_cache import dependency_stamp, import_closure

SOURCE = Path(_kernel_cache.__file__).resolve().parent


def test_the_pair_kernels_cache_covers_the_geometry_they_compile_in():
    # the case that ran stale: the narrow phase's pair kernel compiles the manifold and the
    # signed distance of the geometry layer into its own cache
    closure = import_closure(SOURCE / "engine" / "detect" / "polyhedron_narrow_phase.py")
    for needed in ("geometry/polyhedron_manifold.py", "geometry/polyhedron_contact.py",
                   "engine/quaternion.py"):
        assert SOURCE / needed in closure, needed
    assert SOURCE / "report" / "study_report.py" not in closure  # only what it imports


def _package(root: Path) -> Path:
    """A package ``kcachepkg``: a.py's kernel calls b.py's function, c.py stands apart."""
    folder = root / "kcachepkg"
    folder.mkdir()
    (folder / "__init__.py").write_text("")
    (folder / "a.py").write_text(textwrap.dedent("""
        from numba import njit

        from .b import value


        @njit(cache=True)
        def kernel(x):
            return x * value()
        """))
    (folder / "b.py").write_text("from numba import njit\n\n\n@njit\ndef value():\n"
                                 "    return 1.0\n")
    (folder / "c.py").write_text("VALUE = 1\n")
    return folder


def test_the_stamp_follows_the_imports_and_only_them(tmp_path, monkeypatch):
    folder = _package(tmp_path)
    monkeypatch.setitem(_kernel_cache.PACKAGES, "kcachepkg", folder.resolve())
    a = folder / "a.py"
    assert import_closure(a) == sorted([a.resolve(), (folder / "b.py").resolve()])
    before = dependency_stamp(a)
    (folder / "c.py").write_text("VALUE = 2\n")  # not imported by a.py
    assert dependency_stamp(a) == before
    (folder / "b.py").write_text("from numba import njit\n\n\n@njit\ndef value():\n"
                                 "    return 2.0\n")
    assert dependency_stamp(a) != before


RUN = """
import json, sys
from pathlib import Path
from grainlab import _kernel_cache
root = Path(sys.argv[1])
_kernel_cache.PACKAGES["kcachepkg"] = (root / "kcachepkg").resolve()
sys.path.insert(0, str(root))
from kcachepkg.a import kernel
value = kernel(3.0)
print(json.dumps({"value": value, "hits": sum(kernel.stats.cache_hits.values()),
                  "misses": sum(kernel.stats.cache_misses.values())}))
"""


def _run(root: Path, cache: Path) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    done = subprocess.run([sys.executable, "-c", RUN, str(root)], env=env, check=True,
                          capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_kernel_whose_callee_changed_in_another_file_is_compiled_again(tmp_path):
    folder = _package(tmp_path)
    cache = tmp_path / "numba-cache"
    first = _run(tmp_path, cache)
    assert first == {"value": 3.0, "hits": 0, "misses": 1}
    assert _run(tmp_path, cache) == {"value": 3.0, "hits": 1, "misses": 0}  # from the cache
    (folder / "b.py").write_text("from numba import njit\n\n\n@njit\ndef value():\n"
                                 "    return 2.0\n")
    # Numba's own check (a.py unchanged) would load the kernel with the old callee: 3.0
    assert _run(tmp_path, cache) == {"value": 6.0, "hits": 0, "misses": 1}
