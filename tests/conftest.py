"""Test-suite options: ``--validate`` runs the slow validation runs (STYLE.md 11)."""

from __future__ import annotations

import pytest


def pytest_addoption(parser):
    parser.addoption(
        "--validate", action="store_true", default=False,
        help="also run the slow validation runs against published values",
    )


def pytest_collection_modifyitems(config, items):
    if config.getoption("--validate"):
        return
    skip = pytest.mark.skip(reason="validation run: use pytest --validate")
    for item in items:
        if "validate" in item.keywords:
            item.add_marker(skip)
