"""Microstructure of a contact network (seeds 002 and 003), per snapshot and over a run.

Reads one data class, :class:`ContactNetwork` (arrays of particles, interactions and contact
points); never imports the engine. Every analysis is a compute object: parameters at
construction, data in ``compute(network)``, results as properties.
"""

from grainlab.analysis.angular_distributions import AngularDistributions
from grainlab.analysis.compute import Compute, NotComputedError
from grainlab.analysis.connectivity import Connectivity, find_rattlers, packing_fraction
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.contact_stress import (
    StressState,
    principal_stresses,
    principal_stresses_2d,
    stress_from_contact_dyads,
    stress_from_internal_moments,
    stress_from_network,
)
from grainlab.analysis.fabric import Fabric
from grainlab.analysis.force_statistics import ForceStatistics
from grainlab.analysis.friction import Friction
from grainlab.analysis.partial_stress import PartialStresses
from grainlab.analysis.snapshot_analysis import SnapshotAnalysis
from grainlab.analysis.snapshot_files import (
    append_snapshot,
    read_snapshot,
    read_snapshots,
    write_snapshots,
)
from grainlab.analysis.synthetic import synthetic_network
from grainlab.analysis.trajectory import TrajectoryAnalysis
from grainlab.analysis.window_average import StrainWindow, WindowAverage

__all__ = [
    "AngularDistributions",
    "Compute",
    "Connectivity",
    "ContactNetwork",
    "Fabric",
    "ForceStatistics",
    "Friction",
    "NotComputedError",
    "PartialStresses",
    "SnapshotAnalysis",
    "StrainWindow",
    "StressState",
    "TrajectoryAnalysis",
    "WindowAverage",
    "append_snapshot",
    "find_rattlers",
    "packing_fraction",
    "principal_stresses",
    "principal_stresses_2d",
    "read_snapshot",
    "read_snapshots",
    "stress_from_contact_dyads",
    "stress_from_internal_moments",
    "stress_from_network",
    "synthetic_network",
    "write_snapshots",
]
