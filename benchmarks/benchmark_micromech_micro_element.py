"""Benchmark: seed 001's micro-element model on a drained triaxial path.

Times a 1000-increment triaxial compression (lateral stress held by the mixed-control driver)
on the idealized material of 30 micro-elements and on 10 002 micro-elements (1667 random
micro-elements in 6 orientations), homogeneous and Maxwellian distributions (with C_bar,
``maxwellian-average``, and self-consistent, ``maxwellian``: the latter fails after a few
hundred increments, so its rates are per increment actually run; and the first-order C_bar
law, ``maxwellian-first-order``, which can fail too); prints wall and
process CPU seconds per test (CPU counts every thread: on a shared machine it is the steadier
figure), increments per second, micro-element updates per second and the load average.
Numba compilation is excluded (one short warm-up run per size and distribution).

    .venv/bin/python benchmarks/benchmark_micromech_micro_element.py
        [--large N_RANDOM] [--only small|large]
        [--distribution homogeneous|maxwellian-average|maxwellian|maxwellian-first-order]
        [--repeat R]
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

from grainlab.contact.spring_contact import SpringContactLaw
from grainlab.lab.element_test import run_element_test
from grainlab.lab.presets import preset
from grainlab.micromech.micro_element import MicroElementModel
from grainlab.micromech.micro_element.structures import idealized_material

DISTRIBUTIONS = {"homogeneous": ("homogeneous", "overall"),
                 "maxwellian-average": ("maxwellian", "average"),
                 "maxwellian": ("maxwellian", "overall"),
                 "maxwellian-first-order": ("maxwellian-first-order", "overall")}


def run(n_random: int, distribution: str, n_steps: int = 1000
        ) -> tuple[float, float, int, str, int]:
    """(wall s, CPU s, micro-elements, outcome, increments run) of one triaxial test of
    ``n_steps``."""
    structure = idealized_material(seed=1, n_random=n_random)
    law = SpringContactLaw(normal_stiffness=1e5, shear_stiffness=1e5,
                           friction_angle=np.radians(25.0))
    law_name, reference = DISTRIBUTIONS[distribution]
    model = MicroElementModel(structure, law, distribution=law_name,
                              maxwellian_reference=reference)
    model.consolidate_isotropically(100e3)
    path = preset("triaxial_compression", confining=100e3, axial_strain=0.003 * n_steps / 1000,
                  n_steps=n_steps, consolidation_steps=0)
    start, cpu = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_element_test(model, path)
    return (time.perf_counter() - start, time.process_time() - cpu, structure.n_elements,
            result.outcome["status"], len(result.table) - 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--large", type=int, default=1667, help="random micro-elements (x6)")
    parser.add_argument("--only", choices=("small", "large"))
    parser.add_argument("--distribution", choices=tuple(DISTRIBUTIONS))
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    sizes = {"small": 5, "large": args.large}
    names = [args.only] if args.only else ["small", "large"]
    distributions = ([args.distribution] if args.distribution
                     else list(DISTRIBUTIONS))
    print(f"{'micro-elements':>15} {'distribution':>18} {'increments':>10} {'wall s':>8} "
          f"{'CPU s':>8} {'increments/s':>13} {'element-increments/s':>21} {'outcome':>10} "
          f"{'load (1 min)':>13}")
    for name in names:
        for distribution in distributions:
            run(sizes[name], distribution, n_steps=3)  # compile (or load the cache)
            for _ in range(args.repeat):
                wall, cpu, n_elements, status, done = run(sizes[name], distribution)
                load = os.getloadavg()[0]
                print(f"{n_elements:15d} {distribution:>18} {done:10d} {wall:8.2f} {cpu:8.2f} "
                      f"{done / wall:13.0f} {done * n_elements / wall:21.3g} {status:>10} "
                      f"{load:13.2f}", flush=True)


if __name__ == "__main__":
    main()
