"""Speed of the soft-contact DEM step (grainlab.engine.dem.soft_contact): particle-steps per second
against N, on a dense packing of the peers' test's spheres in a periodic cell.

The packing: N spheres of diameter 1.5 mm (the mean of the peers' test's [1, 2] mm) on a
simple cubic lattice compressed by 0.1 % of d (every sphere touches its six neighbours: the
contact count of a dense frictionless packing), with random velocities of 1 cm/s; Hertz-Mindlin
E = 1e9 Pa, nu = 0.25, e = 0.5, mu = 0.4, the sub-step 0.2 x the Rayleigh time (the peers'
test's settings). Each simulation step is 100 sub-steps. Printed per N: sub-step, rows of the
neighbour list per particle, list builds per 100 sub-steps, particle-steps per second, and the
memory of the solver's per-row and per-body arrays per particle; the threads used (from
soft_contact.PARALLEL_BODIES bodies on, all of Numba's: NUMBA_NUM_THREADS=1 for one) and the
threading layer.

    python benchmarks/benchmark_engine_soft_contact.py            # N = 1000, 4096, 10648
    python benchmarks/benchmark_engine_soft_contact.py --sides 10 22 47   # up to 1e5
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from grainlab._numba_setup import threading_layer
from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.boundaries.periodic_boundary import PeriodicCell
from grainlab.engine.dem import soft_contact
from grainlab.engine.dem.soft_contact import SoftContactStep
from grainlab.engine.state import BodyState, ShapeLibrary

DIAMETER = 1.5e-3
DENSITY = 2600.0


def lattice(side: int, seed: int = 0):
    """``side``^3 spheres on a compressed simple cubic lattice in a periodic cell."""
    rng = np.random.default_rng(seed)
    spacing = DIAMETER * 0.999
    grid = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    library = ShapeLibrary.from_spheres([0.5 * DIAMETER])
    state = BodyState.from_library(library, np.zeros(len(grid), dtype=np.int64),
                                   (grid + 0.5) * spacing, DENSITY)
    state.velocities[:] = rng.normal(scale=0.01, size=state.velocities.shape)
    cell = PeriodicCell(np.eye(3) * side * spacing)
    return library, state, cell


def measure(side: int, steps: int) -> dict:
    library, state, cell = lattice(side)
    law = SoftContactLaw.hertz_mindlin(1e9, 0.25, restitution=0.5)
    solver = SoftContactStep(law, dt=1.0, friction=0.4)
    solver.dt = 100 * solver.stable_substep(state, library)
    solver.step(state, library, cell)  # compile, first list
    builds = solver.n_detections
    start = time.perf_counter()
    for _ in range(steps):
        solver.step(state, library, cell)
    elapsed = time.perf_counter() - start
    n = state.n_bodies
    substeps = steps * solver.last_substeps
    rows = solver._rows.body_j.shape[0]  # the rows of the list in use
    # per row: the list, the outputs, the histories, the vector pass's springs scratch (6)
    row_bytes = rows * (8 * (2 + 3 + 3 + 2 + 3 + 1 + 3 + 3 + 3 + 3 + 3 + 1 + 3 + 3 + 3 + 1 + 3 + 6
                             + 6))
    body_bytes = n * 8 * (3 + 4 + 3 + 3 + 1 + 3 + 3 + 3 + 1 + 1)
    return {"n": n, "substep": solver.substep, "rows_per_particle": rows / n,
            "threads": numba.get_num_threads() if soft_contact.threads_pay(n) else 1,
            "builds_per_100": 100.0 * (solver.n_detections - builds) / substeps,
            "particle_steps_per_s": n * substeps / elapsed,
            "bytes_per_particle": (row_bytes + body_bytes) / n}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sides", type=int, nargs="+", default=[10, 16, 22])
    parser.add_argument("--steps", type=int, default=5, help="steps of 100 sub-steps each")
    args = parser.parse_args()
    print(f"threading layer {threading_layer()}")
    print(f"{'N':>8} {'thr':>4} {'substep [s]':>12} {'rows/part':>10} {'builds/100':>11} "
          f"{'particle-steps/s':>17} {'bytes/part':>11}")
    for side in args.sides:
        r = measure(side, args.steps)
        print(f"{r['n']:8d} {r['threads']:4d} {r['substep']:12.3e} {r['rows_per_particle']:10.2f} "
              f"{r['builds_per_100']:11.2f} {r['particle_steps_per_s']:17.3e} "
              f"{r['bytes_per_particle']:11.0f}")


if __name__ == "__main__":
    main()
