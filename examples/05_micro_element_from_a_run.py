"""A discrete triaxial run and the micro-element model of its own packing, side by side.

(The command ``grainlab theory-vs-sim triaxial`` does the same on one specimen in one go,
with one results table and one figure; this script shows the steps.)

The model is built from the run's snapshot at the start of shear (the end of the compaction
stage: one micro-element per sphere with its contacting neighbours, periodic-image contacts
kept, the run's contact forces as the initial state), with the run's contact law (linear
springs k_n = kappa sigma0 <d>, k_s = stiffness_ratio k_n, friction mu of the shear stage),
and driven by the run's own load path from its shear stage on (lateral stresses held at
sigma0, the axial strain rising, shear strains zero, the run's stop criterion), cut into
--steps steps. Prints the initial stresses (snapshot, model, run) and q/p
(q = sigma_1 - sigma_3, p = trace/3) and the volumetric strain at a few axial strains for
the run and for each distribution law.

Run:  .venv/bin/python -m grainlab.cli.main triaxial --no-progress --boundary periodic \\
          --solver dem --law linear -n 150 --size-ratio 1.5 --eps-q 0.1 --sigma0 1e5 \\
          --mu 0.4 --inertia 0.001 --record-every 5 --snapshot-every 100000 --seed 1 -o RUN
      .venv/bin/python examples/05_micro_element_from_a_run.py RUN [--steps 200]
          [--laws homogeneous,maxwellian-average,maxwellian]

Given a folder without a run (``python examples/05_micro_element_from_a_run.py OUT``), it
first makes a small one there (150 rigid spheres, contact dynamics, to eps_q 0.02) with
:data:`SMALL_RUN`, so that the example runs on its own in about a minute; the model's springs
are then the soft-contact defaults of the run's settings (kappa, stiffness_ratio), given to
grains the run held rigid.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from grainlab.analysis.contact_stress import stress_from_network
from grainlab.analysis.snapshot_files import read_snapshots
from grainlab.contact.spring_contact import SpringContactLaw
from grainlab.errors import GrainlabError
from grainlab.lab.element_test import run_element_test
from grainlab.lab.run_path import element_path, run_load_path
from grainlab.micromech.micro_element.from_snapshot import micro_elements_from_snapshot
from grainlab.micromech.micro_element.model import MicroElementModel
from grainlab.result.test_result import read_test_result

SMALL_RUN = ("triaxial", "--no-progress", "--boundary", "periodic", "-n", "150",
             "--size-ratio", "1.5", "--eps-q", "0.02", "--sigma0", "1e5", "--mu", "0.4",
             "--inertia", "0.01",
             "--record-every", "5", "--snapshot-every", "100000", "--seed", "1")
"""The discrete run made when the folder given holds none (grainlab's command line)."""

STRAINS = (0.002, 0.005, 0.01, 0.02, 0.04, 0.06, 0.08)
"""Axial strains (from the start of shear) at which the responses are printed [-]."""


def shear_start(run: Path):
    """The snapshot taken at the end of the compaction stage."""
    for network in read_snapshots(run / "snapshots.h5"):
        if network.state.get("stage") == "compaction":
            start = network
    return start


def run_law(run: Path, result, network) -> SpringContactLaw:
    """The run's linear springs (docs: k_n = kappa sigma0 <d>) and shear-stage friction."""
    settings = result.metadata["parameters"]["settings"]
    dem = settings["dem"]
    sigma0 = result.metadata["parameters"]["config"]["test"]["sigma0"]
    diameters = (6.0 * np.asarray(network.volumes) / math.pi) ** (1.0 / 3.0)
    kn = dem["normal_stiffness"] or dem["kappa"] * sigma0 * float(np.mean(diameters))
    mu = settings["shear"]["friction"]
    return SpringContactLaw(friction_angle=math.atan(mu), normal_stiffness=kn,
                            shear_stiffness=dem["stiffness_ratio"] * kn)


def at_strains(eps: np.ndarray, columns: dict[str, np.ndarray]) -> list[tuple[str, int]]:
    """Lines "strain: q/p, eps_vol" at the rows nearest to STRAINS, with the row indices."""
    rows = []
    for target in STRAINS:
        if target > eps.max() + 1e-12:
            break
        k = int(np.argmin(np.abs(eps - target)))
        rows.append((f"{eps[k]:.4f}: q/p {columns['qp'][k]:.3f} eps_vol "
                     f"{columns['ev'][k]:+.4f}", k))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--laws", default="homogeneous,maxwellian-average")
    args = parser.parse_args()
    if not (args.run / "results.h5").exists():
        args.run = args.run / "run"
        subprocess.run([sys.executable, "-m", "grainlab.cli.main", *SMALL_RUN, "-o",
                        str(args.run)], check=True)
    result = read_test_result(args.run / "results.h5")
    table = result.table
    shear = table[table["stage"] == "shear"]
    before = table[table["stage"] == "compaction"].iloc[-1]
    eps = shear["eps_zz"].to_numpy()  # the run counts the shear stage's strains from its start
    ev = shear["eps_vol"].to_numpy()
    network = shear_start(args.run)
    law = run_law(args.run, result, network)
    snapshot_stress = stress_from_network(network)
    print(f"snapshot: {network.n_particles} spheres, {network.n_pairs} loaded pairs, "
          f"k_n {law.normal_stiffness:.4g} N/m, k_s {law.shear_stiffness:.4g} N/m, "
          f"mu {law.friction_coefficient:.3g}")
    print("run's row at the snapshot [Pa]:", np.round([before[f"sigma_{c}"] for c in
                                                       ("xx", "yy", "zz")], 2))
    print("snapshot's (1/V) sum f l [Pa]:", np.round(np.diag(snapshot_stress), 2))
    print("discrete run, axial strain from the start of shear (lateral stress):")
    lateral = 0.5 * (shear["sigma_xx"] + shear["sigma_yy"]).to_numpy()
    for line, k in at_strains(eps, {"qp": (shear["q"] / shear["p"]).to_numpy(), "ev": ev}):
        print("   ", line, f"(sigma_lateral {lateral[k]:.4g} Pa)")
    structure = micro_elements_from_snapshot(network, periodic="keep")
    for name in args.laws.split(","):
        distribution = "homogeneous" if name == "homogeneous" else "maxwellian"
        reference = "average" if name == "maxwellian-average" else "overall"
        model = MicroElementModel(structure, law, distribution=distribution,
                                  maxwellian_reference=reference)
        tensor = model.stress_tensor()
        error = np.abs(tensor - snapshot_stress).max() / np.abs(snapshot_stress).max()
        print(f"model ({name}): {structure.n_elements} micro-elements, z "
              f"{structure.coordination_number:.3f}; initial stress "
              f"{np.round(np.diag(tensor), 2)} Pa, |model - snapshot| / |snapshot| "
              f"{error:.1e}")
        path = element_path(run_load_path(result.metadata), "shear", args.steps)
        try:
            test = run_element_test(model, path)
        except GrainlabError as failure:
            print("    failed:", failure)
            continue
        answer, outcome = test.table, test.metadata["outcome"]
        m_eps = answer["eps_zz"].to_numpy()
        ratio = (answer["q"] / answer["p"]).to_numpy()
        print(f"    {outcome['status']} ({outcome.get('reason', '')}); reached axial strain "
              f"{m_eps.max():.4f}, peak q/p {ratio.max():.3f} (run: "
              f"{(shear['q'] / shear['p']).max():.3f})")
        for line in at_strains(m_eps, {"qp": (answer["q"] / answer["p"]).to_numpy(),
                                       "ev": answer["eps_vol"].to_numpy()}):
            print("   ", line[0])


if __name__ == "__main__":
    main()
