"""Small soft-contact (DEM) lab runs recorded as regressions (tests/engine/data/README.md):
spheres, aggregates and polyhedra in the servo-wall box, spheres in the servo periodic cell,
each a short compaction cut after a few steps and a little shear, a few hundred sub-steps."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig

_COMMON = {
    "test": {"kind": "triaxial", "sigma0": 1e4, "eps_q_max": 0.2},
    "output": {"record_every": 2, "checkpoint_every": 0, "snapshot_every": 0},
}

CASES = {
    "dem_wall_box_spheres": ({"n_particles": 20, "seed": 3},
                             {"dem": {"kappa": 1e3}}, 40),
    "dem_periodic_cell_spheres": ({"n_particles": 90, "seed": 2, "boundary": "periodic"},
                                  {"dem": {"kappa": 1e3}}, 20),
    "dem_wall_box_polyhedra": ({"shape": "polyhedron", "n_particles": 8, "n_faces": 8,
                                "templates": 2, "seed": 1}, {"dem": {"kappa": 1e2}}, 30),
    "dem_wall_box_aggregates": ({"shape": "aggregate", "n_particles": 10, "seed": 4},
                                {"dem": {"kappa": 1e3}}, 30),
}
"""name: (sample, solver, steps): the compaction is cut after half the steps
(``max_stage_steps``, ``next_stage``), then the shear runs the other half."""


def run_case(name: str, folder: Path) -> pd.DataFrame:
    """The results table of the recorded case ``name`` run in ``folder``."""
    sample, solver, steps = CASES[name]
    config = RunConfig.model_validate({
        **_COMMON, "sample": sample,
        "solver": {"method": "dem", "max_stage_steps": steps // 2,
                   "at_max_stage_steps": "next_stage",
                   "compaction": {"inertia_number": 0.05},
                   "shear": {"inertia_number": 0.01}, **solver}})
    return start_run(folder, config).run(max_steps=steps).table
