"""Numba settings applied before any compiled kernel runs, and the form of the arrays the
kernels take (:func:`kernel_input`).

The threading layer is TBB where its library loads, else ``workqueue``; never OpenMP. Measured
on a 2-core machine (shared/research/engine_tech.md §1.1 and
benchmarks/benchmark_engine_soft_contact.py): OpenMP's spinning workers collapse when another
process holds a core (7x slower), ``workqueue`` stays robust but starts a parallel loop in
~0.17 ms, TBB in ~0.02 ms and is as robust. The soft-contact sub-steps start two parallel
loops each, so TBB decides whether threads pay below ~10^4 spheres (4096 spheres on 2
threads: TBB 4.7e6, workqueue 2.4e6, one thread 2.8e6 particle-steps/s).

TBB comes as the ``tbb`` wheel (a dependency), whose library lies in ``sys.prefix/lib``,
where the dynamic loader does not look: it is loaded here by its path first, so that Numba's
own ``libtbb.so.12`` finds it loaded. A user's ``NUMBA_THREADING_LAYER`` environment variable
wins.
"""

from __future__ import annotations

import ctypes
import os
import sys
from pathlib import Path

import numpy as np

TBB_LIBRARIES = {"linux": "libtbb.so.12", "darwin": "libtbb.12.dylib", "win32": "tbb12.dll"}
"""The TBB library's file name per platform (as Numba looks for it)."""


def _load_tbb() -> bool:
    """Load the TBB library of the ``tbb`` wheel (or the system's); whether one loaded."""
    name = TBB_LIBRARIES.get(sys.platform)
    if name is None:
        return False
    for candidate in (Path(sys.prefix) / "lib" / name, Path(sys.prefix) / "Library" / "bin" /
                      name, name):
        if isinstance(candidate, Path) and not candidate.exists():
            continue
        try:
            ctypes.CDLL(str(candidate), mode=getattr(ctypes, "RTLD_GLOBAL", 0))
            return True
        except OSError:
            continue
    return False


_LAYER = os.environ.get("NUMBA_THREADING_LAYER")
# loaded in every process that may pick TBB, child processes too (they inherit the variables)
_TBB = _LAYER in (None, "default", "tbb", "safe", "threadsafe") and _load_tbb()
if _LAYER is None:
    os.environ["NUMBA_THREADING_LAYER"] = "default"
    os.environ["NUMBA_THREADING_LAYER_PRIORITY"] = (
        "tbb workqueue omp" if _TBB else "workqueue tbb omp")

import llvmlite.binding as llvm  # noqa: E402
import numba  # noqa: E402  (after the environment it reads)

VECTORIZE_SCEV_CHECKS = 256
"""How many run-time checks on index arithmetic LLVM's loop vectorizer may add to a loop
(its default, 16, is too few for the soft-contact force pass of :mod:`grainlab.engine.
sphere_rows`, whose rows read and write a dozen arrays: the loop stayed scalar, 2.2x slower).
The checks run once per loop entry; they change no result."""

llvm.set_option("grainlab", f"-vectorize-scev-check-threshold={VECTORIZE_SCEV_CHECKS}")

from grainlab._kernel_cache import install as _stamp_kernel_caches  # noqa: E402

_stamp_kernel_caches()  # cached kernels recompile when a module they import changes

numba.config.THREADING_LAYER = os.environ["NUMBA_THREADING_LAYER"]
if "NUMBA_THREADING_LAYER_PRIORITY" in os.environ:
    numba.config.THREADING_LAYER_PRIORITY = os.environ["NUMBA_THREADING_LAYER_PRIORITY"].split()


def threading_layer() -> str:
    """The threading layer Numba uses (or will use at its first parallel loop: the first of
    its priority list)."""
    try:
        return numba.threading_layer()
    except ValueError:  # no parallel loop has run yet
        layer = numba.config.THREADING_LAYER
        return numba.config.THREADING_LAYER_PRIORITY[0] if layer == "default" else layer


def kernel_input(array: np.ndarray, dtype: type | None = None) -> np.ndarray:
    """``array`` as a compiled kernel takes an input it only reads: C-contiguous and read-only
    (a read-only view, no copy unless the type or layout must change; the caller's array keeps
    its flags). Numba compiles a kernel once per layout and read-only flag of its arguments:
    frozen arrays and working copies of them would otherwise each have their own compilation
    (~20 s for the micro-element condensation)."""
    view = np.ascontiguousarray(array, dtype=dtype).view()
    view.setflags(write=False)
    return view
