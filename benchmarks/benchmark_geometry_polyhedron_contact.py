"""Benchmark: narrow-phase pair tests per second for convex polyhedra of n_f = 8, 30, 96, 596.

For each n_f: 8 random polyhedra (seed 002, circumscribed diameter d = 1 mm), P pairs of them
in random orientations along random directions, each pair far from the others. The centre
distance of every pair is set (a few vectorised secant steps, not timed) so that its signed
distance is a target drawn uniformly in [-0.005 d, 0.05 d]: touching or near pairs, as the
broad phase hands them over in a dense packing (about 1 in 10 of these are beyond the alert).
The alert distance is 0.045 d (0.1 x the inradius, the engine's default). Prints, per n_f,
the median time of ``NarrowPhase.detect`` over the P candidate pairs (world transform, signed
distance, manifold), the pair tests per second, the median CPU time per pair (process time:
less disturbed than the wall time on a loaded machine), the contact points per pair and the type
proportions.

    .venv/bin/python benchmarks/benchmark_geometry_polyhedron_contact.py [n_f ...] [--pairs P]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numba
import numpy as np

from grainlab.engine.detect.narrow_phase import POLYHEDRON_CONTACT_TYPE_NAMES, NarrowPhase
from grainlab.engine.state import BodyState, ShapeLibrary
from grainlab.geometry.polyhedron import random_polyhedron

D = 1e-3  # m
SPACING = 10 * D  # m between pairs


def near_pairs(n_faces: int, n_pairs: int, seed: int = 0):
    """Library, state and pair list of n_pairs touching/near pairs (module docstring)."""
    rng = np.random.default_rng(seed)
    shapes = [random_polyhedron(n_faces, rng, circumscribed_diameter=D) for _ in range(8)]
    library = ShapeLibrary.from_polyhedra(shapes)
    ids = rng.integers(0, len(shapes), size=2 * n_pairs)
    quats = rng.normal(size=(2 * n_pairs, 4))
    quats /= np.linalg.norm(quats, axis=1)[:, None]
    u = rng.normal(size=(n_pairs, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    side = int(np.ceil(n_pairs ** (1 / 3)))
    grid = np.stack(np.unravel_index(np.arange(n_pairs), (side, side, side)), axis=1)
    anchors = SPACING * grid.astype(float)
    target = rng.uniform(-0.005 * D, 0.05 * D, n_pairs)
    distance = np.full(n_pairs, 0.95 * D)
    pairs = np.stack([2 * np.arange(n_pairs), 2 * np.arange(n_pairs) + 1], axis=1)
    probe = NarrowPhase(alert=0.5 * D)
    for _ in range(8):  # secant steps on the centre distance
        positions = np.empty((2 * n_pairs, 3))
        positions[0::2] = anchors
        positions[1::2] = anchors + distance[:, None] * u
        state = BodyState.from_library(library, ids, positions, 2600.0, orientations=quats)
        contacts = probe.detect(state, library, pairs)
        gap = np.full(n_pairs, np.inf)
        slope = np.ones(n_pairs)
        k = contacts.body_i // 2
        np.minimum.at(gap, k, contacts.gap)
        first = np.unique(k, return_index=True)[1]
        slope[k[first]] = np.maximum(np.einsum("ij,ij->i", contacts.normal[first], u[k[first]]),
                                     0.2)
        distance += np.where(np.isfinite(gap), (target - gap) / slope, -0.05 * D)
    return library, state, pairs


def main(faces: list[int], n_pairs: int, repeats: int = 7) -> None:
    print(f"polyhedron narrow phase, {n_pairs} pairs per n_f, gaps in [-0.005, 0.05] d, "
          f"alert 0.045 d, {numba.get_num_threads()} threads (pair loop serial)")
    print(f"{'n_f':>5} {'n_v':>4} {'time/call':>10} {'pairs/s':>10} {'us/pair':>8} "
          f"{'cpu us/pair':>11} {'in contact':>10} {'points/pair':>11}  types fv/ee/fe/ff")
    for n_faces in faces:
        library, state, pairs = near_pairs(n_faces, n_pairs)
        narrow = NarrowPhase(alert=0.045 * D)
        narrow.detect(state, library, pairs)  # compile or load the cache, grow the buffers
        times, cpu = [], []
        for _ in range(repeats):
            start, start_cpu = time.perf_counter(), time.process_time()
            contacts = narrow.detect(state, library, pairs)
            times.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
        t = statistics.median(times)
        touching = np.unique(contacts.body_i)
        first = np.unique(contacts.body_i, return_index=True)[1]
        types = np.bincount(contacts.contact_type[first], minlength=5)[1:]
        share = "/".join(f"{x / max(types.sum(), 1):.2f}" for x in types)
        print(f"{n_faces:5d} {int(library.vertex_count[0]):4d} {1e3 * t:8.2f} ms "
              f"{n_pairs / t:10.3g} {1e6 * t / n_pairs:8.2f} "
              f"{1e6 * statistics.median(cpu) / n_pairs:11.2f} {touching.size / n_pairs:10.2f} "
              f"{contacts.n_contacts / max(touching.size, 1):11.2f}  {share} "
              f"({', '.join(POLYHEDRON_CONTACT_TYPE_NAMES[1:])})")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("faces", nargs="*", type=int, default=[8, 30, 96, 596])
    parser.add_argument("--pairs", type=int, default=2000)
    args = parser.parse_args()
    main(args.faces, args.pairs)
