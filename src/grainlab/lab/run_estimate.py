"""What a discrete run will cost, estimated from its settings before it starts, and a refusal
of settings that cannot run in a useful time.

A stage with a strain-controlled axis moves at the strain rate its bound on the inertia
number allows, rate = I sqrt(sigma0 / rho) / <d> [1/s], so it lasts T = strain / rate [s];
the compaction, from the loose packing fraction phi_0 to about
:data:`~grainlab.lab.cell_thickness.CELL_PACKING_ESTIMATE`, moves each axis by
ln(phi / phi_0) / 3 at its own bound's rate. The simulated time T_total is their sum (the
settling at the end of the compaction left out: the estimate is a lower bound).

* Soft-contact DEM integrates it in sub-steps no longer than the contact law's stable step
  dt_s (:meth:`~grainlab.contact.soft_contact_law.SoftContactLaw.time_step` of the lightest
  grain; the dashpots' bound only shortens it): at least T_total / dt_s sub-steps of N
  particles. Estimated: the 1000-sphere triaxial test to eps_q = 0.5 at kappa = 1e4, 2.5e5
  sub-steps with linear springs (25.7 s on 2 cores), 1.3e6 with Hertz; 200 spheres in a
  periodic cell at kappa = 1e5 to eps_q = 0.3, 5.1e5. Stiffness raises the count as
  sqrt(kappa) (linear) or kappa^(3/4) (Hertz): 30 spheres at kappa = 1e12 to eps_q = 0.01,
  1.5e8 (the run made 37 of its lab steps in 4 minutes).
* Contact dynamics with a given step ``dt`` takes T_total / dt steps (its automatic step
  follows the wall speed, a fixed number of steps per unit strain, and is not bounded here).

A run whose estimate is above :data:`MAX_SUBSTEPS` or :data:`MAX_PARTICLE_SUBSTEPS` (DEM) or
:data:`MAX_STEPS` (CD, given dt) is refused before anything is written, with the estimate
and the setting that sets it.

>>> round(loading_time(0.01, 1e-3, 1e4, 2600.0, 1.5e-3) * 1e3, 2)
7.65
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grainlab.errors import InputError
from grainlab.lab.cell_thickness import CELL_PACKING_ESTIMATE
from grainlab.lab.solver_registry import solver_record

MAX_SUBSTEPS = 5e7
"""Most sub-steps a soft-contact run may be estimated at: 200 times the 1000-sphere triaxial
test at kappa = 1e4 (module docstring); a sub-step of even a few particles costs some
microseconds, so more is hours of work for any sample."""
MAX_PARTICLE_SUBSTEPS = 2e11
"""Most particle-sub-steps (sub-steps x particles) a soft-contact run may be estimated at:
a thousand times the 1000-sphere triaxial test at kappa = 1e4, some 6 hours at the solver's
1e7 particle-sub-steps per second on 2 cores (docs/benchmarks/soft-dem.md)."""
MAX_STEPS = 1e7
"""Most steps a contact-dynamics run with a given ``dt`` may be estimated at (the 1000-sphere
triaxial test takes some 4e3)."""

def loading_time(strain: float, inertia_number: float, confining: float, density: float,
                 mean_diameter: float) -> float:
    """T = strain / (I sqrt(sigma0 / rho) / <d>) [s] (module docstring)."""
    rate = inertia_number * math.sqrt(confining / density) / mean_diameter
    return abs(strain) / rate


def loading_strain(test: Any) -> float:
    """The strain [-] the loading stages of the ``[test]`` table travel (0 for a compaction
    and for the stress-driven circular path)."""
    travel = {"triaxial": test.eps_q_max, "extension": test.eps_q_max,
              "true_triaxial": 2.0 * test.eps_q_max, "cubical": 2.0 * test.eps_q_max,
              "oedometer": test.axial_strain + test.unload_strain,
              "simple_shear": test.gamma_max,
              "cyclic_shear": 4.0 * test.amplitude * test.n_cycles}
    return float(travel.get(test.kind, 0.0))


def simulated_time(config: Any, mean_diameter: float, density: float) -> float:
    """The least simulated time [s] of the run of ``config`` (a
    :class:`~grainlab.lab.run_config.RunConfig`; module docstring)."""
    s, t = config.solver, config.test
    compaction = math.log(CELL_PACKING_ESTIMATE / config.sample.packing_fraction) / 3.0
    total = loading_time(max(compaction, 0.0), s.compaction.inertia_number, t.sigma0,
                         density, mean_diameter)
    if t.kind != "compaction":
        total += loading_time(loading_strain(t), s.shear.inertia_number, t.sigma0, density,
                              mean_diameter)
    return total


def substep(test: Any) -> float:
    """The longest sub-step [s] of a soft-contact ``test``: its contact law's stable step
    for its lightest grain (module docstring)."""
    state, library = test.sample.state, test.sample.library
    radius = float(np.min(library.bounding_radius[state.shape_ids]))
    return test.contact_law.time_step(float(np.min(state.masses)), radius,
                                      float(state.density))


def refuse_endless_run(test: Any, config: Any) -> None:
    """An :class:`InputError` naming the setting that makes the run of ``config`` (its test
    ``test`` built, not run) too long to run (module docstring); nothing when it is not."""
    state = test.sample.state
    total = simulated_time(config, test.sample.mean_diameter, float(state.density))
    record = solver_record(config.solver.method)
    if record.explicit_substeps:
        dt = substep(test)
        substeps = total / dt
        work = substeps * state.n_bodies
        if substeps <= MAX_SUBSTEPS and work <= MAX_PARTICLE_SUBSTEPS:
            return
        key, value = ("solver.method", config.solver.method) \
            if record.stiffness_key is None else record.stiffness_key(config.solver)
        raise InputError(key, value, (
            f"a stiffness the run can reach its end with: the estimate is at least "
            f"{substeps:.3g} sub-steps of {dt:.3g} s over {total:.3g} s of loading for "
            f"{state.n_bodies} particles, {work:.3g} particle-sub-steps (the "
            "1000-sphere triaxial test at kappa = 1e4 takes 2.5e5 sub-steps, 26 s), above the "
            f"{MAX_SUBSTEPS:g} sub-steps or {MAX_PARTICLE_SUBSTEPS:g} particle-sub-steps "
            "allowed; lower the stiffness (kappa 1e3-1e4 makes "
            "grains as good as rigid), or ask a smaller strain or a larger inertia number"))
    if config.solver.dt > 0.0:
        steps = total / config.solver.dt
        if steps > MAX_STEPS:
            raise InputError("solver.dt", config.solver.dt, (
                f"a step the run can reach its end with: {total:.3g} s of loading take at "
                f"least {steps:.3g} steps of it, above the {MAX_STEPS:g} allowed; 0 chooses "
                "the step from the particle sizes and the loading speed"))
