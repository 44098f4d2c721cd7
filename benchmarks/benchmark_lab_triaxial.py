"""Benchmark: the full 1000-sphere triaxial test (seed 002's protocol) in grainlab, then the
same test in YADE on the same machine, in one run of this script; prints wall times, their
ratio and the mechanics side by side.

grainlab: ``grainlab triaxial`` defaults — N spheres, diameters uniform by volume in
[1, 2] mm, density 2600 kg/m^3, loose random start, frictionless isotropic compaction to
sigma0 = 10 kPa until quasi-static, then mu = 0.4, lateral walls at sigma0, top wall at the
strain rate of I = 1e-3, to eps_q = 0.5 (contact dynamics, NLGS tolerance 1e-4).
YADE: benchmarks/yade/triaxial_spheres.py (same N, sizes, density, friction, sigma0, strain
rate, target; soft contacts at kappa = 1e4, damping 0.2), run with
``OMP_WAIT_POLICY=PASSIVE yade -j THREADS`` (skipped when ``yade`` is not installed).

    .venv/bin/python benchmarks/benchmark_lab_triaxial.py [N] [EPS_Q] [--no-yade]
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba

from grainlab.lab.discrete_run import start_run
from grainlab.lab.run_config import RunConfig

HERE = Path(__file__).resolve().parent


def grainlab_run(n: int, eps_q: float, folder: Path) -> dict:
    config = RunConfig.model_validate({
        "sample": {"n_particles": n}, "test": {"kind": "triaxial", "eps_q_max": eps_q},
        "output": {"checkpoint_every": 0}})
    run = start_run(folder, config, overwrite=True)
    stage_ends = []
    stage_ended = run.test.on_stage_end

    def timed_stage_end(test):
        stage_ends.append(time.perf_counter())
        stage_ended(test)

    run.test.on_stage_end = timed_stage_end
    start = time.perf_counter()
    result = run.run()
    total = time.perf_counter() - start
    compaction_time = stage_ends[0] - start if stage_ends else float("nan")
    table = result.table
    compaction = table[table["stage"] == "compaction"]
    shear = table[table["stage"] != "compaction"]
    stages = result.metadata["outcome"]["stages"]
    late = shear[shear["eps_q"] >= 0.6 * shear["eps_q"].max()]
    figures = {}
    for name, part, seconds, steps in (
            ("compaction", compaction, compaction_time, stages[0]["steps"]),
            ("shear", shear, total - compaction_time, stages[1]["steps"])):
        # rows every record_every steps: per-step means from the recorded steps
        sweeps = part["solver_iterations"].mean()
        updates = (part["solver_iterations"] * part["n_contacts"]).mean() * steps
        figures[f"{name}: wall time [s], steps, sweeps/step, contacts, updates/s"] = (
            f"{seconds:.1f}, {steps}, {sweeps:.0f}, {part['n_contacts'].mean():.0f}, "
            f"{updates / seconds:.3g}")
    return {
        "wall time [s]": total,
        **figures,
        "packing fraction after compaction": compaction["packing_fraction"].iloc[-1],
        "z after compaction (with rattlers, particle contacts)": compaction["z"].iloc[-1],
        "z after compaction (no rattlers, particle contacts)":
            compaction["z_no_rattlers"].iloc[-1],
        "z_m after compaction (no rattlers, wall contacts counted)":
            compaction["z_mechanical"].iloc[-1],
        "peak q/p": shear["q_over_trace"].max(),
        "residual q/p (last 40 % of eps_q)": late["q_over_trace"].mean(),
        "residual packing fraction": late["packing_fraction"].mean(),
        "residual z (with rattlers; no rattlers)":
            f"{late['z'].mean():.3f}; {late['z_no_rattlers'].mean():.3f}",
        "max inertia number in shear": shear["inertia_number"].max(),
        "max overlap / <d>": table["max_overlap_over_d"].max(),
        "non-converged steps": result.metadata["outcome"]["unconverged_steps"],
    }


def yade_run(n: int, eps_q: float, folder: Path, threads: int,
             options: tuple[str, ...] = ()) -> dict | None:
    """benchmarks/yade/triaxial_spheres.py under ``yade -j threads`` with its ``options``
    (e.g. ``("--kappa", "1e3")``): the wall time and its RESULT lines (None without
    ``yade``)."""
    if shutil.which("yade") is None:
        return None
    env = {**os.environ, "OMP_WAIT_POLICY": "PASSIVE"}
    command = ["yade", "-j", str(threads), "-n", "-x", str(HERE / "yade" / "triaxial_spheres.py"),
               "--n", str(n), "--eps-q-target", str(eps_q), "--csv", str(folder / "yade.csv"),
               *options]
    start = time.perf_counter()
    out = subprocess.run(command, env=env, capture_output=True, text=True, cwd=folder)
    total = time.perf_counter() - start
    summary: dict = {"wall time [s]": total}
    lines = [line for line in out.stdout.splitlines() if line.lstrip().startswith("RESULT")]
    summary["summary"] = "\n    " + "\n    ".join(re.sub(r"^\s*RESULT\s*", "", x)
                                                   for x in lines)
    if out.returncode != 0:
        summary["error"] = out.stderr[-500:]
    return summary


def main(argv: list[str]) -> None:
    args = [a for a in argv if not a.startswith("--")]
    n = int(args[0]) if args else 1000
    eps_q = float(args[1]) if len(args) > 1 else 0.5
    threads = numba.get_num_threads()
    print(f"triaxial test, {n} spheres to eps_q = {eps_q}; numba threads {threads} "
          f"({numba.threading_layer() if threads else ''})", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        ours = grainlab_run(n, eps_q, Path(tmp) / "grainlab")
        print("grainlab (contact dynamics):")
        for key, value in ours.items():
            print(f"  {key}: {value:.4g}" if isinstance(value, float) else f"  {key}: {value}")
        theirs = None if "--no-yade" in argv else yade_run(n, eps_q, Path(tmp), threads)
    if theirs is None:
        print("YADE: not run (not installed or --no-yade)")
        return
    print(f"YADE (-j {threads}, OMP_WAIT_POLICY=PASSIVE):")
    for key, value in theirs.items():
        print(f"  {key}: {value:.4g}" if isinstance(value, float) else f"  {key}: {value}")
    ratio = theirs["wall time [s]"] / ours["wall time [s]"]
    print(f"wall time YADE / grainlab = {ratio:.2f} (same machine, same run of this script)")


if __name__ == "__main__":
    main(sys.argv[1:])
