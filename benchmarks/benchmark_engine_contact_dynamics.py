"""Benchmark: one contact-dynamics step (:class:`ContactDynamicsStep`) and its NLGS kernel on
N = 10^3, 10^4, 10^5 polydisperse spheres, serial and coloured (parallel) sweeps, 1 and 2
Numba threads.

Configuration. Diameters uniform in [d, 2d] (d = 1 mm, density 2500 kg/m^3), packing fraction
0.63: the spheres start on a jittered simple-cubic lattice at 0.7 x their radii, which grow to
full size in 30 stages of Gauss-Seidel overlap removal (walls clamp the centres). This is a
dense random packing with ~3.4 contacts per sphere within the alert distance (0.05 d) and
small overlaps (median ~0.01 d), not a jammed one. It stands under gravity in a
:class:`WallBox`: fixed floor and sides, a stress-controlled top wall (sigma = rho g H / 2,
mass = 1 % of the particles'), Coulomb mu = 0.3, h = 1e-4 s, theta = 0.5, tolerance 1e-5,
at most 200 sweeps per step (from 10^4 spheres on, such a packing needs more than 1000 sweeps
to reach 1e-5: the steps are then flagged not converged, which does not change the cost of a
sweep).

Per N and variant (sweep "serial" or "coloured", 1 or 2 threads), the step runs from the same
state a few warm-up steps (compilation, warm start), then a few timed steps. Printed:
contacts C and colours; sweeps per step; the time per step split into the NLGS kernel, the
colouring, the broad and narrow phases and the rest of the Python launcher (frames, inertia,
warm-start look-up, keys...); contact updates per second (C x sweeps / kernel time, the
kernel's set-up -- Delassus blocks, gathering -- and convergence checks included); ns per
contact update; steps per second and particle-steps
per second. Near-linear growth shows as a near-constant ns per contact update and us per
particle-step. Per N, the memory of a simulation taking two steps (state, solver, warm start
and every array a step allocates from Python; tracemalloc), in all and per sphere.

    .venv/bin/python benchmarks/benchmark_engine_contact_dynamics.py [N ...]
"""

from __future__ import annotations

import copy
import os
import sys
import time
import tracemalloc
from collections import defaultdict
from unittest import mock

import numba
import numpy as np
from numba import njit

import grainlab.engine.nscd.contact_dynamics as cd
from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.detect.broad_phase import CellListBroadPhase
from grainlab.engine.state import BodyState, ShapeLibrary

D = 1e-3  # m, smallest diameter
DENSITY = 2500.0  # kg/m^3
FRACTION = 0.63
DT = 1e-4  # s
G = 9.81  # m/s^2
FRICTION = 0.3
MAX_SWEEPS = 200
STEPS = {1_000: (3, 5), 10_000: (3, 3), 100_000: (2, 2)}  # N: (warm-up, timed) steps


@njit(cache=True)
def _relax(x, radii, pairs, lo, hi, sweeps):
    """Gauss-Seidel overlap removal over the candidate ``pairs``: each overlapping pair is
    pushed apart symmetrically along its centre line, then centres are clamped into the box."""
    for _ in range(sweeps):
        for p in range(pairs.shape[0]):
            i, j = pairs[p, 0], pairs[p, 1]
            dx, dy, dz = x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2]
            dist = np.sqrt(dx * dx + dy * dy + dz * dz)
            overlap = radii[i] + radii[j] - dist
            if overlap > 0.0 and dist > 0.0:
                f = 0.5 * overlap / dist
                x[i, 0] -= f * dx
                x[i, 1] -= f * dy
                x[i, 2] -= f * dz
                x[j, 0] += f * dx
                x[j, 1] += f * dy
                x[j, 2] += f * dz
        for i in range(x.shape[0]):
            for a in range(3):
                x[i, a] = min(max(x[i, a], lo[a] + radii[i]), hi[a] - radii[i])


def dense_packing(n: int, seed: int = 0, stages: int = 30):
    """Centres (n, 3) [m], radii (n,) [m] and box corners of the module docstring's packing."""
    rng = np.random.default_rng(seed)
    radii = 0.5 * rng.uniform(D, 2.0 * D, n)
    m = int(np.ceil(n ** (1.0 / 3.0)))
    layers = int(np.ceil(n / m**2))
    volume = 4.0 / 3.0 * np.pi * np.sum(radii**3) / FRACTION
    spacing = (volume / (m * m * layers)) ** (1.0 / 3.0)
    index = np.arange(n)
    grid = np.stack([index % m, (index // m) % m, index // (m * m)], axis=1)
    lo, hi = np.zeros(3), np.array([m, m, layers]) * spacing
    x = (grid + 0.5 + 0.1 * rng.uniform(-1.0, 1.0, (n, 3))) * spacing
    broad = CellListBroadPhase(alert=0.4 * D)
    for stage in range(stages + 1):
        r = radii * (0.7 + 0.3 * stage / stages)
        for _ in range(1 if stage < stages else 10):
            _relax(x, r, broad.find_pairs(x, r, lo, hi), lo, hi, 12)
    return x, radii, lo, hi


def sample(n: int):
    """Library, state and wall box of the benchmark configuration."""
    x, radii, lo, hi = dense_packing(n)
    library = ShapeLibrary.from_spheres(radii)
    state = BodyState.from_library(library, np.arange(n), x, density=DENSITY)
    box = WallBox(lo, hi, friction=FRICTION, wall_mass=0.01 * float(state.masses.sum()))
    box.set_control("z+", "stress", 0.5 * DENSITY * FRACTION * G * (hi[2] - lo[2]))
    return library, state, box


class _Clock:
    """Accumulated wall time [s] of wrapped callables, by name."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)

    def wrap(self, name, function):
        def timed(*args, **kwargs):
            start = time.perf_counter()
            out = function(*args, **kwargs)
            self.seconds[name] += time.perf_counter() - start
            return out
        return timed


def run(library, state0, box0, sweep: str, threads: int) -> dict:
    """Warm-up and timed steps of one variant; returns the figures of one table row."""
    numba.set_num_threads(threads)
    state, box = copy.deepcopy(state0), copy.deepcopy(box0)
    step = cd.ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=FRICTION,
                                  sweep=sweep, max_iterations=MAX_SWEEPS)
    warm_up, timed = STEPS.get(state.n_bodies, (3, 3))
    for _ in range(warm_up):
        step.step(state, library, box)
    clock = _Clock()
    phases = step._phases(library)
    broad, narrow = phases.broad, phases.narrow
    with mock.patch.object(cd, "nlgs_kernel", clock.wrap("kernel", cd.nlgs_kernel)), \
            mock.patch.object(cd, "nlgs_coloured_kernel",
                              clock.wrap("kernel", cd.nlgs_coloured_kernel)), \
            mock.patch.object(cd, "colour_contacts", clock.wrap("colour", cd.colour_contacts)), \
            mock.patch.object(broad, "find_pairs", clock.wrap("broad", broad.find_pairs)), \
            mock.patch.object(narrow, "detect", clock.wrap("narrow", narrow.detect)):
        contacts = sweeps = 0
        start = time.perf_counter()
        for _ in range(timed):
            report = step.step(state, library, box)
            contacts += report.n_contacts
            sweeps += report.iterations
        total = time.perf_counter() - start
    seconds = clock.seconds
    colours = -1
    if sweep == "coloured":
        colours = cd.colour_contacts(report.contacts.body_i, report.contacts.body_j,
                                     box.inverse_masses(), state.n_bodies).n_colours
    updates = contacts / timed * sweeps
    return {
        "contacts": contacts / timed, "colours": colours, "sweeps": sweeps / timed,
        "step": total / timed, "kernel": seconds["kernel"] / timed,
        "colour": seconds["colour"] / timed, "broad": seconds["broad"] / timed,
        "narrow": seconds["narrow"] / timed,
        "launcher": (total - sum(seconds.values())) / timed,
        "updates_per_s": updates / seconds["kernel"],
        "converged": report.converged, "overlap": report.max_overlap,
    }


def step_memory(library, state0, box0) -> float:
    """Peak memory [bytes] of a simulation of ``state0`` that takes two steps (coloured
    sweeps): the state, the wall box, the solver and its warm start, and every array a step
    allocates from Python (tracemalloc: NumPy's allocations; the compiled kernels' own
    temporaries are not counted)."""
    tracemalloc.start()
    try:
        state, box = copy.deepcopy(state0), copy.deepcopy(box0)
        step = cd.ContactDynamicsStep(dt=DT, gravity=(0.0, 0.0, -G), friction=FRICTION,
                                      max_iterations=MAX_SWEEPS)
        for _ in range(2):
            step.step(state, library, box)
        return float(tracemalloc.get_traced_memory()[1])
    finally:
        tracemalloc.stop()


def main(sizes: list[int]) -> None:
    max_threads = numba.config.NUMBA_NUM_THREADS
    thread_counts = [t for t in (1, 2) if t <= max_threads]
    print(f"contact dynamics step, spheres d in U[{D * 1e3:g}, {2 * D * 1e3:g}] mm, packing "
          f"fraction {FRACTION}, h = {DT:g} s, mu = {FRICTION}, tolerance 1e-5, at most "
          f"{MAX_SWEEPS} sweeps; {numba.config.THREADING_LAYER} layer, {os.cpu_count()} CPUs, "
          f"load average {os.getloadavg()[0]:.2f}")
    print("per step: sweeps; times in ms: kernel = NLGS kernel (set-up and convergence checks "
          "included), col = colouring, bp/np = broad/narrow phase, py = rest of the launcher; "
          "upd/s = contacts x sweeps / kernel time")
    header = (f"{'N':>7} {'sweep':>8} {'thr':>3} {'C':>8} {'C/N':>5} {'col':>4} "
              f"{'sweeps':>6} {'kernel':>8} {'col':>6} {'bp':>6} {'np':>6} {'py':>7} "
              f"{'upd/s':>8} {'ns/upd':>6} {'steps/s':>8} {'p-steps/s':>9} {'us/p-st':>7}")
    print(header)
    per_particle_step: dict[int, float] = {}
    for n in sizes:
        start = time.perf_counter()
        library, state, box = sample(n)
        setup = time.perf_counter() - start
        for sweep in ("serial", "coloured"):
            for threads in thread_counts:
                r = run(library, state, box, sweep, threads)
                if sweep == "coloured" and threads == max(thread_counts):
                    per_particle_step[n] = r["kernel"] / r["sweeps"] / n
                flag = "" if r["converged"] else "  (not converged)"
                print(f"{n:>7} {sweep:>8} {threads:>3} {r['contacts']:>8.0f} "
                      f"{r['contacts'] / n:>5.2f} {r['colours'] if r['colours'] >= 0 else '-':>4} "
                      f"{r['sweeps']:>6.0f} {1e3 * r['kernel']:>8.1f} {1e3 * r['colour']:>6.2f} "
                      f"{1e3 * r['broad']:>6.1f} {1e3 * r['narrow']:>6.1f} "
                      f"{1e3 * r['launcher']:>7.1f} {r['updates_per_s']:>8.3g} "
                      f"{1e9 / r['updates_per_s']:>6.1f} {1.0 / r['step']:>8.3g} "
                      f"{n / r['step']:>9.3g} {1e6 * r['step'] / n:>7.2f}{flag}")
        print(f"{'':>7} (packing built in {setup:.1f} s; max overlap after the steps "
              f"{r['overlap'] / D:.3f} d; load average {os.getloadavg()[0]:.2f})")
        memory = step_memory(library, state, box)
        print(f"{'':>7} memory: {memory / 2**20:.1f} MiB at its peak, {memory / n:.0f} bytes "
              f"per sphere ({memory / r['contacts']:.0f} per contact; NumPy arrays of the "
              f"state, the solver and a step, tracemalloc)")
    numba.set_num_threads(max_threads)
    small, large = min(per_particle_step, default=0), max(per_particle_step, default=0)
    if large >= 100 * small > 0:
        ratio = per_particle_step[large] / per_particle_step[small]
        print(f"target, kernel time per particle and sweep at N = {large} within "
              f"{TARGET_GROWTH:g} x N = {small}'s (coloured, {max(thread_counts)} threads): "
              f"{'met' if ratio <= TARGET_GROWTH else 'missed'} ({ratio:.2f} x)")


TARGET_GROWTH = 1.5
"""How much more a particle-step may cost at 10^5 spheres than at 10^3 (per sweep: the
sweeps a step are capped alike, so this is the memory's share)."""


if __name__ == "__main__":
    main([int(float(a)) for a in sys.argv[1:]] or [1_000, 10_000, 100_000])
