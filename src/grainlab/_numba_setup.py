"""Numba settings applied before any compiled kernel runs.

The threading layer defaults to ``workqueue``: on a shared 2-core machine OpenMP's spinning
workers collapse when another process holds a core (measured 7x slower), while workqueue stays
within ~15 % of the best idle figure (shared/research/engine_tech.md §1.1). A user's
``NUMBA_THREADING_LAYER`` environment variable wins.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numba

if "NUMBA_THREADING_LAYER" in os.environ:
    numba.config.THREADING_LAYER = os.environ["NUMBA_THREADING_LAYER"]
