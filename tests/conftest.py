"""Test-suite options: ``--validate`` runs the slow validation runs (STYLE.md 11).

With pytest-xdist workers (``make test`` runs ``-n auto``), the kernels are first compiled
once, split over three processes (``grainlab compile --part ...``), before the workers start:
each worker would otherwise compile every kernel it meets for itself, and compilation is most
of a cold run (measured: 550 s cold against 235 s with the cache warm, two workers, two
cores). ``GRAINLAB_NO_PRECOMPILE=1`` skips it.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PRECOMPILE_PARTS = ("discrete", "dem,polyhedra", "theories")
"""The compilation split over three processes (measured cold, one after the other: discrete
108 s, polyhedra 58 s, dem 98 s, theories 50 s; three processes on two cores end in about
half their sum, where two ended with the longer half, 171 s). dem before polyhedra: the
polyhedra part also runs contact dynamics, whose sweep kernel (~25 s) the discrete process
has cached by the time the dem part is done, where the two processes otherwise compiled it
at the same time; and the dem part compiles the polyhedra's narrow phase for it."""


def pytest_configure(config):
    workers = getattr(config.option, "numprocesses", None)
    if not workers or os.environ.get("PYTEST_XDIST_WORKER") is not None \
            or os.environ.get("GRAINLAB_NO_PRECOMPILE") == "1":
        return
    processes = [subprocess.Popen([sys.executable, "-m", "grainlab.cli.main", "compile",
                                   "--part", part], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True)
                 for part in PRECOMPILE_PARTS]
    for part, process in zip(PRECOMPILE_PARTS, processes, strict=True):
        _, errors = process.communicate()
        if process.returncode != 0:  # the tests compile what they need themselves
            print(f"grainlab compile --part {part} failed:\n{errors}", file=sys.stderr)


def pytest_addoption(parser):
    parser.addoption(
        "--validate", action="store_true", default=False,
        help="also run the slow validation runs against published values",
    )


def pytest_collection_modifyitems(config, items):
    # the long tests first: xdist hands tests out in this order, and a long test started
    # last keeps one worker busy while the other has nothing left (longest first)
    items.sort(key=lambda item: item.get_closest_marker("long") is None)
    if config.getoption("--validate"):
        return
    skip = pytest.mark.skip(reason="validation run: use pytest --validate")
    for item in items:
        if "validate" in item.keywords:
            item.add_marker(skip)
