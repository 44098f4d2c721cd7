"""Benchmark: every microstructure descriptor of one snapshot of 10^6 contact points.

Prints the time of each analysis (stress, connectivity, fabric, angular distributions, force
statistics, friction) and of the whole :class:`SnapshotAnalysis` on a synthetic 3D network of
one million single-point contacts (about 333 000 particles), and the contact points analysed
per second.

    .venv/bin/python benchmarks/benchmark_analysis_snapshot.py [N_POINTS]
"""

from __future__ import annotations

import sys
import time

from grainlab.analysis.angular_distributions import AngularDistributions
from grainlab.analysis.connectivity import Connectivity
from grainlab.analysis.contact_stress import StressState
from grainlab.analysis.fabric import Fabric
from grainlab.analysis.force_statistics import ForceStatistics
from grainlab.analysis.friction import Friction
from grainlab.analysis.snapshot_analysis import SnapshotAnalysis
from grainlab.analysis.synthetic import synthetic_network


def timed(function) -> float:
    start = time.perf_counter()
    function()
    return time.perf_counter() - start


def main(n_points: int = 1_000_000) -> None:
    network = synthetic_network(n_points, a_c=0.2, a_fn=0.3, a_ft=0.1, seed=0)
    print(f"synthetic network: {network.n_points} contact points, {network.n_particles} "
          f"particles")
    for name, compute in (
        ("stress (both forms)", StressState()), ("connectivity + rattlers", Connectivity()),
        ("fabric, both frames", Fabric()), ("angular distributions", AngularDistributions()),
        ("force statistics", ForceStatistics()), ("friction", Friction()),
    ):
        print(f"{name:>26}: {timed(lambda c=compute: c.compute(network)):7.3f} s")
    total = timed(lambda: SnapshotAnalysis().compute(network))
    print(f"{'whole snapshot analysis':>26}: {total:7.3f} s "
          f"({network.n_points / total:.3g} contact points/s)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000)
