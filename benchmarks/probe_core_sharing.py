"""Whether the machine's cores are shared right now: the rate two threads get, against twice
one thread's, for a vector loop and for a scalar loop (docs/benchmarks/soft-dem.md, "Where the
spread comes from").

Each loop works on its own data in the first-level cache, so the two threads share nothing;
one fork and join per measurement. On free cores both ratios are ~1. When the two virtual
processors share their cores' execution units with another tenant, the vector loop (which
keeps the vector units full, as grainlab's force and bodies passes do) falls to 0.2-0.85
while the scalar loop (bound by the latency of its additions, as much scalar simulation
code is) stays near 1. Read it before and after a timing to know what the timing measured.

    python benchmarks/probe_core_sharing.py            # one reading
    python benchmarks/probe_core_sharing.py --every 5 --count 12   # a minute of readings
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from numba import njit, prange

VECTOR_ROUNDS, SCALAR_ROUNDS = 1_000_000, 100_000


@njit(cache=True, fastmath=True)
def vector_loop(x, y, rounds):
    """y <- 0.999 y + x^2, ``rounds`` times over 1024 values: vector code."""
    for _ in range(rounds):
        for i in range(x.shape[0]):
            y[i] = y[i] * 0.999 + x[i] * x[i]
    return y[0]


@njit(cache=True)
def scalar_loop(x, rounds):
    """Four chains of dependent additions: scalar code, bound by their latency."""
    a = b = c = d = 0.0
    for _ in range(rounds):
        for i in range(0, x.shape[0], 4):
            a = a * 0.999 + x[i]
            b = b * 0.999 + x[i + 1]
            c = c * 0.999 + x[i + 2]
            d = d * 0.999 + x[i + 3]
    return a + b + c + d


@njit(cache=True, parallel=True, fastmath=True)
def vector_pair(x, y, rounds, out):
    for t in prange(2):
        out[t] = vector_loop(x[t], y[t], rounds)


@njit(cache=True, parallel=True)
def scalar_pair(x, rounds, out):
    for t in prange(2):
        out[t] = scalar_loop(x[t], rounds)


def _seconds(function, *args) -> float:
    start = time.perf_counter()
    function(*args)
    return time.perf_counter() - start


def reading() -> tuple[float, float]:
    """(vector, scalar): two threads' rate / twice one thread's."""
    x, y, out = np.random.default_rng(0).random((2, 1024)), np.zeros((2, 1024)), np.zeros(2)
    vector = _seconds(vector_loop, x[0], y[0], VECTOR_ROUNDS) \
        / _seconds(vector_pair, x, y, VECTOR_ROUNDS, out)
    scalar = _seconds(scalar_loop, x[0], SCALAR_ROUNDS) \
        / _seconds(scalar_pair, x, SCALAR_ROUNDS, out)
    return vector, scalar


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1, help="readings (default 1)")
    parser.add_argument("--every", type=float, default=5.0, help="seconds between readings")
    args = parser.parse_args()
    x, y, out = np.random.default_rng(0).random((2, 1024)), np.zeros((2, 1024)), np.zeros(2)
    vector_pair(x, y, 1, out)  # compiled (or loaded) before any reading
    scalar_pair(x, 1, out)
    vector_loop(x[0], y[0], 1)
    scalar_loop(x[0], 1)
    for k in range(args.count):
        if k:
            time.sleep(args.every)
        vector, scalar = reading()
        print(f"{time.strftime('%H:%M:%S')}  two threads / twice one: vector {vector:.2f}, "
              f"scalar {scalar:.2f}", flush=True)


if __name__ == "__main__":
    main()
