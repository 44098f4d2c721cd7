"""The threading layer grainlab gives Numba (grainlab._numba_setup): TBB where the ``tbb``
wheel's library lies, in child processes too; a user's NUMBA_THREADING_LAYER wins."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

PROBE = """
import numpy as np
import grainlab
import numba
from numba import njit, prange

@njit(parallel=True)
def ones(a):
    for i in prange(a.size):
        a[i] = 1.0

ones(np.zeros(4))
print(numba.threading_layer())
"""


def layer_in_a_new_process(**environment: str) -> str:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_THREADING")}
    env.update(environment)
    done = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True,
                          text=True, check=True, timeout=120)
    return done.stdout.strip().splitlines()[-1]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the wheel's library path")
def test_tbb_where_its_wheel_is_installed():
    wheel = (Path(sys.prefix) / "lib" / "libtbb.so.12").exists()
    layer = layer_in_a_new_process()
    assert layer == "tbb" if wheel else layer in ("tbb", "workqueue")


def test_the_users_layer_wins():
    assert layer_in_a_new_process(NUMBA_THREADING_LAYER="workqueue") == "workqueue"
