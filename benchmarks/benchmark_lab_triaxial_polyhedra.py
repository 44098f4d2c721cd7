"""Benchmark: the full triaxial test on N seed 002 random polyhedra (default 1000, n_f = 30)
with ``grainlab triaxial --shape polyhedron`` defaults; prints the wall time, the steps, and
the mechanics seed 002 reports: packing fraction, z and z_c (eq. 14) and the contact-type
proportions after frictionless compaction and in the residual state, peak and residual q/p.

Protocol (seed 002 §II.B): circumscribed diameters uniform by volume in [1, 2] mm, density
2600 kg/m^3, loose random start, frictionless isotropic compaction to sigma0 = 10 kPa until
quasi-static, then mu = 0.4, lateral walls at sigma0, top wall at the strain rate of
I = 1e-3, to eps_q (0.5 by default); contact dynamics with the lab's solver settings (the
step growing while the overlaps stay small: grainlab.lab.step_control). The compaction ends as
the sphere benchmark's does (``--kinetic-energy inf``: the walls' stresses and the unbalanced
force, YADE's criterion; ``--kinetic-energy 1e-6`` for grainlab's default).

Targets printed for the test of 1000 polyhedra of 30 faces to eps_q = 0.5: at most 600 s (it
was 900 s before the frictional solver's target; 1166 s measured), at most 2 % of each
stage's steps ended at the sweep cap; the script exits with status 1 when one is missed.

    PYTHONPATH=src .venv/bin/python benchmarks/benchmark_lab_triaxial_polyhedra.py \
        [--n 1000] [--faces 30] [--eps-q 0.5] [--templates 0] [--max-iterations N] \
        [--kinetic-energy inf] [--seed 0] [--out FOLDER]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numba

from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig

TYPES = ("fv", "ee", "fe", "ff")

TARGET_SECONDS = 600.0
"""The speed target of 1000 polyhedra of 30 faces to eps_q = 0.5 on 2 threads [s]."""
TARGET_CAPPED = 0.02
"""The largest share of a stage's steps that may end at the sweep cap."""


def _r(value, digits: int = 3) -> float:
    return round(float(value), digits)


def polyhedra_run(n: int, faces: int, eps_q: float, templates: int,
                  max_iterations: int | None, seed: int, folder: Path,
                  kinetic_energy: float = float("inf")) -> tuple[dict, float]:
    shear = {} if max_iterations is None else {"max_iterations": max_iterations}
    config = RunConfig.model_validate({
        "sample": {"shape": "polyhedron", "n_particles": n, "n_faces": faces,
                   "templates": templates, "seed": seed},
        "test": {"kind": "triaxial", "eps_q_max": eps_q,
                 "quasi_static": {"kinetic_energy": kinetic_energy}},
        "solver": {"shear": shear},
        "output": {"checkpoint_every": 0}})
    start = time.perf_counter()
    run = start_run(folder, config, overwrite=True)
    built = time.perf_counter() - start
    result = run.run()
    total = time.perf_counter() - start
    table = result.table
    compaction = table[table["stage"] == "compaction"]
    shear = table[table["stage"] != "compaction"]
    stages = result.metadata["outcome"]["stages"]
    late = shear[shear["eps_q"] >= 0.6 * shear["eps_q"].max()]
    end = compaction.iloc[-1]
    summary = {
        "wall time [s] (sample built in)": f"{total:.1f} ({built:.1f})",
        "steps (compaction, shear)": tuple(s["steps"] for s in stages),
        "capped share (compaction, shear)": tuple(
            _r(s["capped_steps"] / max(s["steps"], 1), 4) for s in stages),
        "stage ends": tuple(s["reason"] for s in stages),
        "mean angularity <alpha> [rad]": run.test.sample.description["mean_angularity"],
        "packing fraction after compaction": end["packing_fraction"],
        "z0, z0 no rattlers": (_r(end["z"], 3), _r(end["z_no_rattlers"], 3)),
        "z_c0 (eq. 14), no rattlers, solver points": (
            _r(end["z_c"], 3), _r(end["z_c_no_rattlers"], 3), _r(end["z_c_points"], 3)),
        "core (centres >= <d> from the walls) z0, z_c0": (_r(end["z_core"], 3),
                                                          _r(end["z_c_core"], 3)),
        "z_mechanical (solver points, walls included, no rattlers)": _r(end["z_mechanical"],
                                                                        3),
        "contact types after compaction (fv, ee, fe, ff)": tuple(
            _r(end[f"fraction_{t}"], 3) for t in TYPES),
    }
    if len(shear):
        summary.update({
            "peak q/p (at eps_q)": (_r(shear["q_over_trace"].max(), 4),
                                    _r(shear["eps_q"][shear["q_over_trace"].idxmax()], 4)),
            "residual q/p (last 40 % of eps_q)": late["q_over_trace"].mean(),
            "residual packing fraction": late["packing_fraction"].mean(),
            "residual z, z_c": (_r(late["z"].mean(), 3), _r(late["z_c"].mean(), 3)),
            "residual core z, z_c": (_r(late["z_core"].mean(), 3),
                                     _r(late["z_c_core"].mean(), 3)),
            "residual contact types (fv, ee, fe, ff)": tuple(
                _r(late[f"fraction_{t}"].mean(), 3) for t in TYPES),
            "max inertia number in shear": shear["inertia_number"].max(),
        })
    summary.update({
        "max overlap / <d>": table["max_overlap_over_d"].max(),
        "non-converged steps": result.metadata["outcome"]["unconverged_steps"],
    })
    return summary, total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000, help="number of polyhedra [1000]")
    parser.add_argument("--faces", type=int, default=30, help="faces per polyhedron [30]")
    parser.add_argument("--eps-q", type=float, default=0.5, help="deviatoric strain [0.5]")
    parser.add_argument("--templates", type=int, default=0,
                        help="0: every particle its own shape; K: K shapes reused [0]")
    parser.add_argument("--max-iterations", type=int, default=None,
                        help="the shear's NLGS sweep cap [the lab's]")
    parser.add_argument("--kinetic-energy", type=float, default=float("inf"),
                        help="the compaction's kinetic energy criterion (inf: not checked)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None,
                        help="keep the run folder here (default: a temporary folder)")
    args = parser.parse_args()
    threads = numba.get_num_threads()
    print(f"triaxial test, {args.n} polyhedra of {args.faces} faces to eps_q = {args.eps_q}; "
          f"numba threads {threads}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.out if args.out is not None else Path(tmp) / "run"
        summary, seconds = polyhedra_run(args.n, args.faces, args.eps_q, args.templates,
                                         args.max_iterations, args.seed, folder,
                                         args.kinetic_energy)
    for key, value in summary.items():
        print(f"  {key}: {value:.4g}" if isinstance(value, float) else f"  {key}: {value}")
    if (args.n, args.faces, args.eps_q) != (1000, 30, 0.5):
        return  # the targets are the test's
    capped = max(summary["capped share (compaction, shear)"])
    verdicts = [
        f"at most {TARGET_SECONDS:g} s ({threads} threads): "
        f"{'met' if seconds <= TARGET_SECONDS else 'missed'} ({seconds:.0f} s)",
        f"at most {TARGET_CAPPED:.0%} of a stage's steps capped: "
        f"{'met' if capped <= TARGET_CAPPED else 'missed'} ({capped:.1%})"]
    for line in verdicts:
        print("target, " + line)
    missed = [line for line in verdicts if ": missed" in line]
    if missed:  # a missed target is not a passed benchmark
        raise SystemExit(f"{len(missed)} of {len(verdicts)} targets missed")


if __name__ == "__main__":
    main()
