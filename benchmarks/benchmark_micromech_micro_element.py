"""Benchmark: seed 001's micro-element model on a drained triaxial path.

Times a 1000-increment triaxial compression (lateral stress held by the mixed-control driver)
on the idealized material of 30 micro-elements and on 10 000 micro-elements (1667 random
micro-elements in 6 orientations), homogeneous and Maxwellian distributions; prints seconds per
test, increments per second and micro-element updates per second.

    .venv/bin/python benchmarks/benchmark_micromech_micro_element.py [--large N_RANDOM]
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

from grainlab.contact.spring_contact import SpringContactLaw
from grainlab.lab.element_test import run_element_test
from grainlab.lab.presets import preset
from grainlab.micromech.micro_element import MicroElementModel
from grainlab.micromech.micro_element.structures import idealized_material


def run(n_random: int, distribution: str, n_steps: int = 1000) -> tuple[float, int, str]:
    structure = idealized_material(seed=1, n_random=n_random)
    law = SpringContactLaw(normal_stiffness=1e5, shear_stiffness=1e5,
                           friction_angle=np.radians(25.0))
    model = MicroElementModel(structure, law, distribution=distribution)
    model.consolidate_isotropically(100e3)
    path = preset("triaxial_compression", confining=100e3, axial_strain=0.003, n_steps=n_steps,
                  consolidation_steps=0)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_element_test(model, path)
    return time.perf_counter() - start, structure.n_elements, result.outcome["status"]


def main() -> None:
    large = 1667
    if "--large" in sys.argv:
        large = int(sys.argv[sys.argv.index("--large") + 1])
    print(f"{'micro-elements':>15} {'distribution':>13} {'increments':>10} {'seconds':>8} "
          f"{'increments/s':>13} {'element-increments/s':>21} {'outcome':>10}")
    for n_random in (5, large):
        for distribution in ("homogeneous", "maxwellian"):
            seconds, n_elements, status = run(n_random, distribution)
            print(f"{n_elements:15d} {distribution:>13} {1000:10d} {seconds:8.2f} "
                  f"{1000 / seconds:13.0f} {1000 * n_elements / seconds:21.3g} {status:>10}")


if __name__ == "__main__":
    main()
