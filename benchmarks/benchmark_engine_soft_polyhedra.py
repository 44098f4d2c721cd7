"""Speed of the soft-contact DEM step on convex polyhedra (grainlab.engine.dem.soft_polyhedra):
sub-steps per second of N polyhedra resting in a wall box under gravity.

The packing: N random polyhedra of seed 002 (n_f faces, each its own shape, circumscribed
diameters uniform by volume in [1, 2] mm, density 2600 kg/m^3) dropped from a loose sample
(packing fraction 0.3) onto the floor of a fixed wall box under gravity, linear springs
k_n = 50 N/m (overlaps about 1e-3 <d> under the column's weight), e = 0.3, mu = 0.4, local
damping 0.3, settled for 0.2 s; then timed over steps of 100 sub-steps each. Printed per run:
the sub-step, pairs of the neighbour list and penetrating manifold points per particle, list
builds per 100 sub-steps, sub-steps per second and particle-steps per second.

    python benchmarks/benchmark_engine_soft_polyhedra.py               # N = 100, n_f = 30
    python benchmarks/benchmark_engine_soft_polyhedra.py --faces 8 30 96 --n 100
"""

from __future__ import annotations

import argparse
import time

from grainlab.contact.soft_contact_law import SoftContactLaw
from grainlab.engine.dem.soft_contact import SoftContactStep
from grainlab.prep.loose_sample import loose_sample

SETTLE = 0.2  # s of deposition before the timing


def measure(n: int, faces: int, steps: int, seed: int = 1) -> dict:
    sample = loose_sample(shape="polyhedron", n_particles=n, n_faces=faces, d_min=1e-3,
                          size_ratio=2.0, packing_fraction=0.3, seed=seed)
    law = SoftContactLaw.linear(50.0, restitution=0.3, local_damping=0.3)
    solver = SoftContactStep(law, dt=1e-3, gravity=(0.0, 0.0, -9.81), friction=0.4)
    state, library, box = sample.state, sample.library, sample.boundary
    for _ in range(round(SETTLE / solver.dt)):
        report = solver.step(state, library, box)
    solver.dt = 100 * solver.substep
    builds, substeps = solver.n_detections, solver.n_substeps
    start = time.perf_counter()
    for _ in range(steps):
        report = solver.step(state, library, box)
    elapsed = time.perf_counter() - start
    substeps = solver.n_substeps - substeps
    return {"n": n, "faces": faces, "substep": solver.substep,
            "pairs_per_particle": solver._rows.keys.size / n,  # the live pair list
            "points_per_particle": report.n_contacts / n,
            "builds_per_100": 100.0 * (solver.n_detections - builds) / substeps,
            "substeps_per_s": substeps / elapsed,
            "particle_steps_per_s": n * substeps / elapsed}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[100])
    parser.add_argument("--faces", type=int, nargs="+", default=[30])
    parser.add_argument("--steps", type=int, default=10, help="steps of 100 sub-steps each")
    args = parser.parse_args()
    print(f"{'N':>6} {'n_f':>5} {'substep [s]':>12} {'pairs/part':>11} {'points/part':>12} "
          f"{'builds/100':>11} {'substeps/s':>11} {'particle-steps/s':>17}")
    for n in args.n:
        for faces in args.faces:
            r = measure(n, faces, args.steps)
            print(f"{r['n']:6d} {r['faces']:5d} {r['substep']:12.3e} "
                  f"{r['pairs_per_particle']:11.2f} {r['points_per_particle']:12.2f} "
                  f"{r['builds_per_100']:11.2f} {r['substeps_per_s']:11.0f} "
                  f"{r['particle_steps_per_s']:17.3e}")


if __name__ == "__main__":
    main()
