"""The frictional contact problem on its own: u = W r + q with Coulomb's law at each contact,
solved by every method of :func:`grainlab.engine.nscd.plain_problem_methods.solve`
(docs/explanations/contact-problem.md, "The contact problem on its own").

1. A sphere resting on a plane tilted by 20 deg (mu = 0.5 > tan 20 deg, so it sticks): the
   problem written by hand (W = I / m for a point mass), the impulse known in closed form,
   r = -m q (it cancels the free velocity).
2. A pile of 27 spheres dropped into a box by the contact-dynamics engine: the step's problem
   taken out of the engine (``keep_problem``), written to an FCLib HDF5 file and read back,
   then solved by every method from zero, with the natural-map error of Acary, Bremond &
   Huber (||F(r)|| / ||q||) and the sweeps each took.

Run:  .venv/bin/python examples/03_contact_problem_solvers.py [OUTPUT_FOLDER]

Writes OUTPUT_FOLDER/pile_step.hdf5 (default: a temporary folder); a few seconds once the
kernels are compiled.
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from grainlab.engine.boundaries.wall_box import WallBox
from grainlab.engine.nscd.contact_dynamics import ContactDynamicsStep
from grainlab.engine.nscd.contact_problem import (
    FrictionalContactProblem,
    natural_map_error,
    read_fclib,
    write_fclib,
)
from grainlab.engine.nscd.plain_problem_methods import METHODS, solve
from grainlab.engine.state import BodyState, ShapeLibrary

G = 9.81  # m/s^2
STEP = 1e-4  # s
CAPS = {"nlgs": 2000, "psor": 2000, "apgd": 20000, "jacobi": 20000, "nlgs-subspace": 2000}
"""Iterations allowed per method: the gradient and Jacobi methods take more, cheaper ones."""


def sphere_on_an_incline(mass: float = 0.01, tilt_deg: float = 20.0,
                         mu: float = 0.5) -> None:
    """One contact, closed form: a sticking sphere's impulse cancels its free velocity."""
    tilt = math.radians(tilt_deg)
    # local frame (n, t, s): gravity's impulse over one step, seen from the plane
    q = STEP * G * np.array([-math.cos(tilt), math.sin(tilt), 0.0])
    problem = FrictionalContactProblem(sp.identity(3) / mass, q, [mu])
    exact = -mass * q + 0.0  # + 0.0: no negative zero in the print
    print(f"sphere on a {tilt_deg:g} deg incline, mu = {mu:g} (sticks: tan = "
          f"{math.tan(tilt):.3f}); exact r = {np.round(exact, 9).tolist()} N s")
    for method in METHODS:
        solution = solve(problem, method, tolerance=1e-12, max_iterations=CAPS[method])
        gap = float(np.abs(solution.reactions - exact).max() / np.abs(exact).max())
        print(f"  {method:13s} r = {np.round(solution.reactions, 9).tolist()}, relative "
              f"difference {gap:.1e}, error {solution.error:.1e} in {solution.iterations} "
              "iterations")


def pile_step(n_side: int = 3, steps: int = 200, seed: int = 2):
    """A step of a pile of n_side^3 spheres (radius 0.5 and 0.4 mm) that has fallen into a
    fixed box, with its contact problem kept (the engine's own solution beside it)."""
    rng = np.random.default_rng(seed)
    radius = 0.5e-3
    grid = np.stack(np.meshgrid(*[np.arange(n_side)] * 3, indexing="ij"), -1).reshape(-1, 3)
    positions = (grid + 0.5) * 2.2 * radius + rng.uniform(-0.05, 0.05, grid.shape) * radius
    library = ShapeLibrary.from_spheres([radius, 0.8 * radius])
    state = BodyState.from_library(library, rng.integers(0, 2, len(positions)), positions,
                                   density=2600.0)
    box = WallBox(np.zeros(3), np.full(3, n_side * 2.2 * radius), friction=0.3)
    engine = ContactDynamicsStep(dt=STEP, gravity=(0.0, 0.0, -G), friction=0.4,
                                 tolerance=1e-7, max_iterations=5000, seed=seed)
    for _ in range(steps):
        engine.step(state, library, box)
    engine.keep_problem = True
    return engine.step(state, library, box)


def main(folder: Path) -> None:
    sphere_on_an_incline()
    report = pile_step()
    path = folder / "pile_step.hdf5"
    write_fclib(report.problem, path, title="a pile of 27 spheres, one step",
                reactions=report.impulses.ravel())
    stored = read_fclib(path)
    problem = stored.problem
    print(f"\npile step: {problem.n_contacts} contacts, written to and read from {path}; the "
          f"engine's impulses: error {natural_map_error(problem, stored.reactions):.1e}")
    print(f"  {'method':13s} {'iterations':>10s} {'error':>9s} {'seconds':>8s}  largest "
          f"difference from NLGS's impulses / largest impulse")
    reference = solve(problem, "nlgs", tolerance=1e-10, max_iterations=CAPS["nlgs"])
    scale = float(np.abs(reference.reactions).max())
    for method in METHODS:
        solution = solve(problem, method, tolerance=1e-8, max_iterations=CAPS[method])
        difference = float(np.abs(solution.reactions - reference.reactions).max()) / scale
        print(f"  {method:13s} {solution.iterations:10d} {solution.error:9.1e} "
              f"{solution.seconds:8.4f}  {difference:.1e}"
              + ("" if solution.converged else "  (not converged)"))


if __name__ == "__main__":
    if len(sys.argv) > 1:
        out = Path(sys.argv[1])
        out.mkdir(parents=True, exist_ok=True)
        main(out)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            main(Path(tmp))
