"""Test-suite options: ``--validate`` runs the slow validation runs (STYLE.md 11).

With pytest-xdist workers (``make test`` runs ``-n auto``), the kernels are first compiled
once, split over two processes (``grainlab compile --part ...``), before the workers get
their first test (they start and collect meanwhile): each worker would otherwise compile every
kernel it meets for itself, and compilation is most of a cold run (measured: 550 s cold
against 235 s with the cache warm, two workers, two cores). ``GRAINLAB_NO_PRECOMPILE=1``
skips it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

NUMERICS_TARGET = os.environ.get("GRAINLAB_TEST_TARGET", "baseline")
"""The processor features the suite's numerical libraries may use: ``baseline`` (the default)
or ``native`` (the host's own, as a user's run). ``GRAINLAB_TEST_TARGET=native`` runs the
suite as a user's machine computes; every test but the recorded-trajectory regressions
(marked ``recorded_trajectory``) must pass either way."""

BASELINE_NUMERICS = {
    # NumPy's loops at its x86-64-v2 baseline: its AVX2 and AVX-512 loops of tanh, sin, exp,
    # ..., and its vectorised sorts (the order of equal keys) differ from the baseline in
    # the last bits, and differ between processors
    "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR AVX AVX2 F16C FMA3 "
                                "AVX512F AVX512CD AVX512_SKX AVX512_CLX AVX512_CNL",
    # OpenBLAS's kernels for one processor family (an x86-64-v2 one): its dgemm and
    # factorisations take other sums per processor family (Haswell, SkylakeX, Zen)
    "OPENBLAS_CORETYPE": "Nehalem",
}
"""The environment that gives the suite one outcome on every x86-64 processor (with
:data:`NUMERICS_TARGET` ``baseline``): NumPy and OpenBLAS pick their loops and kernels by the
processor at run time, and their last bits differ between processors. grainlab's compiled
kernels need no pin: they are compiled without fast-math, so LLVM neither contracts a*b + c into
a fused multiply-add nor reorders a sum, and give the same bits for any target
(``NUMBA_CPU_NAME=generic`` or the host's; docs/explanations/one-outcome.md, "One outcome on
every processor"). Set before NumPy loads, so that the workers and every child process inherit
it."""

if NUMERICS_TARGET == "baseline":
    if "numpy" in sys.modules:
        warnings.warn("NumPy was imported before tests/conftest.py: its loops are the host's, "
                      "not the baseline's (BASELINE_NUMERICS)", stacklevel=1)
    for _name, _value in BASELINE_NUMERICS.items():
        os.environ.setdefault(_name, _value)
elif NUMERICS_TARGET != "native":
    raise SystemExit(f"GRAINLAB_TEST_TARGET={NUMERICS_TARGET!r}: expected 'baseline' or "
                     "'native'")

import pytest  # noqa: E402

PRECOMPILE_PARTS = ("discrete,theories", "dem,polyhedra")
"""The compilation split over two processes of about equal work (measured cold on two cores,
one part after the other: discrete 108 s, dem 98 s, polyhedra 58 s, theories 50 s; these two
processes ended together in 170 s, where discrete | dem,polyhedra | theories in three processes
took 205 s: a third process only shares the same two cores). dem before polyhedra: the
polyhedra part also runs contact dynamics, whose sweep kernel (~25 s) the discrete part has
cached by the time the dem part is done, where the two processes otherwise compiled it at the
same time; and the dem part compiles the polyhedra's narrow phase for it."""


_PRECOMPILING: list[tuple[str, subprocess.Popen]] = []
"""The compile processes started in :func:`pytest_configure`, awaited before the first test
is handed out (:func:`pytest_runtestloop`)."""


def pytest_configure(config):
    workers = getattr(config.option, "numprocesses", None)
    if not workers or os.environ.get("PYTEST_XDIST_WORKER") is not None \
            or os.environ.get("GRAINLAB_NO_PRECOMPILE") == "1":
        return
    _PRECOMPILING.extend(
        (part, subprocess.Popen([sys.executable, "-m", "grainlab.cli.main", "compile",
                                 "--part", part], stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, text=True))
        for part in PRECOMPILE_PARTS)


@pytest.hookimpl(hookwrapper=True, tryfirst=True)
def pytest_runtestloop(session):
    """Wait for the compile processes before any test runs. The workers start and collect
    meanwhile (each imports every test module, some 15 s of a core, taken while the last
    compile process runs alone); they get their first test once the kernels are cached."""
    while _PRECOMPILING:
        part, process = _PRECOMPILING.pop(0)
        _, errors = process.communicate()
        if process.returncode != 0:  # the tests compile what they need themselves
            print(f"grainlab compile --part {part} failed:\n{errors}", file=sys.stderr)
    yield


PERTURBED_FOLDERS = ("lab", "cli", "report", "study", "test_readme.py", "test_examples.py")
"""Where ``GRAINLAB_TEST_PERTURB=1`` moves the samples (the tests that run lab tests)."""
_RUNNING = {"path": None}


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _RUNNING["path"] = item.path  # module fixtures are made inside their first test's protocol
    yield


@pytest.fixture(scope="session", autouse=True)
def _another_trajectory():
    """With ``GRAINLAB_TEST_PERTURB=1``, every body state made from a library
    (:meth:`~grainlab.engine.state.BodyState.from_library`) in the tests that run lab tests
    (:data:`PERTURBED_FOLDERS`) has its positions scaled by 1 + 2^-45: a difference in the
    last bits, as another processor's, that takes a jammed packing along another trajectory.
    A probe for tests that need one particular trajectory (docs/explanations/one-outcome.md,
    "One outcome on every processor"); a run and its resumed twin start from the same moved
    state, so bit-for-bit resumption still holds."""
    if os.environ.get("GRAINLAB_TEST_PERTURB") != "1":
        yield
        return
    import numpy as np

    from grainlab.engine.state import BodyState

    made = BodyState.from_library.__func__

    def moved(cls, library, shape_ids, positions, *args, **kwargs):
        path = _RUNNING["path"]
        if path is not None and any(part in PERTURBED_FOLDERS for part in path.parts):
            positions = np.asarray(positions, dtype=np.float64) * (1.0 + 2.0**-45)
        return made(cls, library, shape_ids, positions, *args, **kwargs)

    BodyState.from_library = classmethod(moved)
    yield
    BodyState.from_library = classmethod(made)


def pytest_addoption(parser):
    parser.addoption(
        "--validate", action="store_true", default=False,
        help="also run the slow validation runs against published values",
    )


def pytest_collection_modifyitems(config, items):
    # the long tests first: xdist hands tests out in this order, and a long test started
    # last keeps one worker busy while the other has nothing left (longest first)
    items.sort(key=lambda item: item.get_closest_marker("long") is None)
    if NUMERICS_TARGET != "baseline":
        skip = pytest.mark.skip(reason="a recorded trajectory, reproduced bit for bit by the "
                                       "baseline numerics only (GRAINLAB_TEST_TARGET=baseline)")
        for item in items:
            if "recorded_trajectory" in item.keywords:
                item.add_marker(skip)
    if config.getoption("--validate"):
        return
    skip = pytest.mark.skip(reason="validation run: use pytest --validate")
    for item in items:
        if "validate" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def register_shape_kind(monkeypatch):
    """``register(kind)``: a :class:`~grainlab.engine.shape_kinds.ShapeKind` record added to
    the registry for one test (:data:`~grainlab.engine.shape_kinds.SHAPE_KINDS`, the names
    and the lookups by name and code, restored after it): what reads the registry when it
    runs sees the kind, what copied it at import does not."""
    from grainlab.engine import shape_kinds

    def register(kind):
        kinds = (*shape_kinds.SHAPE_KINDS, kind)
        monkeypatch.setattr(shape_kinds, "SHAPE_KINDS", kinds)
        monkeypatch.setattr(shape_kinds, "SHAPE_KIND_NAMES", tuple(k.name for k in kinds))
        monkeypatch.setitem(shape_kinds._BY_NAME, kind.name, kind)
        monkeypatch.setitem(shape_kinds._BY_CODE, kind.code, kind)
        return kind

    return register
