"""Every descriptor of one contact-network snapshot, in one compute object.

Runs the stress, connectivity, fabric (both frames), angular distributions, force statistics,
friction (when the network knows mu) and partial-stress (when it knows contact types) analyses
and gathers their scalar descriptors into one flat dictionary, the row of a results table.

A network held by walls (``box_lower``, ``box_upper``) is analysed twice: over the whole
box (wall contacts in the stress and the rattler rule) and over its core, the particles at
least ``core_margin`` mean diameters from every wall (:mod:`grainlab.analysis.wall_layer`),
whose descriptors carry the suffix ``_core`` (``coordination_number`` and
``coordination_number_core``, ``a_c`` and ``a_c_core``, ...).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainlab.analysis.angular_distributions import AngularDistributions
from grainlab.analysis.compute import Compute
from grainlab.analysis.connectivity import Connectivity
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.contact_stress import StressState
from grainlab.analysis.fabric import Fabric
from grainlab.analysis.force_statistics import ForceStatistics
from grainlab.analysis.friction import Friction
from grainlab.analysis.partial_stress import PartialStresses
from grainlab.analysis.wall_layer import CORE_MARGIN, CoreConnectivity, core_network


def harmonic_mobilisation(
    anisotropies: dict[str, float], mu: float, mu_branch: float, dimension: int
) -> dict[str, float]:
    """Friction-mobilisation index from the tangential force anisotropy (seed 002 eq. 28,
    seed 003 eq. 34): averaging |<f_t>(theta)| = <f_n> a_ft |sin 2 theta| over the directions
    of a nearly isotropic fabric gives I = c a_ft / mu_bar with c = <|sin 2 theta|>, 2/3 over
    the sphere and 2/pi over the circle. (The OCR'd eq. 28 prints 5/2 for c; the integral it
    describes gives 2/3.) mu_bar = mu in the contact frame, <mu'> in the branch frame."""
    c = 2.0 / 3.0 if dimension == 3 else 2.0 / np.pi
    out = {}
    if mu and mu > 0:
        out["mobilisation_index_harmonic"] = c * anisotropies["a_ft"] / mu
    if mu_branch and np.isfinite(mu_branch) and mu_branch > 0:
        out["mobilisation_index_branch_harmonic"] = c * anisotropies["a_ft_branch"] / mu_branch
    return out


_CONNECTIVITY_NAMES = ("packing_fraction", "coordination_number", "connectivity_number",
                       "connectivity_ratio", "rattler_fraction")
"""Descriptors of the whole-box connectivity: the core's come from CoreConnectivity, not from
the claimed network (whose particle count is the box's)."""
_CORE_FROM_CLAIMS = ("connectivity_ratio",)


class SnapshotAnalysis(Compute):
    """All microstructure descriptors of one snapshot (seeds 002 and 003).

    Parameters
    ----------
    min_contacts:
        Rattler rule: particles with fewer active interactions are removed recursively.
    frame_level:
        ``"points"`` (each contact point is a contact of the contact frame) or ``"pairs"``
        (pair resultants with the pair's mean normal, the view of seed 002's polyhedra).
    friction_tolerance:
        A contact slides when |f_t| >= (1 - tolerance) mu f_n.
    n_force_bins, n_angle_bins:
        Bins of the force PDFs and of the angular distributions.
    force_linear_edges, force_log_edges:
        Fixed (n_force_bins + 1,) edges of the force PDFs' linear and log bins of f / <f>
        [-] (:class:`~grainlab.analysis.force_statistics.ForceStatistics`); None: each
        snapshot's own range.
    core_margin:
        Margin of the core in mean volume-equivalent diameters (module docstring); None: no
        core analysis. A network without a box has none either.

    >>> from grainlab.analysis.synthetic import synthetic_network
    >>> analysis = SnapshotAnalysis().compute(synthetic_network(2000, a_c=0.2, seed=1))
    >>> round(analysis.descriptors["coordination_number"], 1)  # 2 x 2000 pairs / 667 particles
    6.0
    """

    def __init__(
        self,
        min_contacts: int = 2,
        frame_level: str = "points",
        friction_tolerance: float = 1e-3,
        n_force_bins: int = 40,
        n_angle_bins: int = 18,
        force_linear_edges: np.ndarray | None = None,
        force_log_edges: np.ndarray | None = None,
        core_margin: float | None = CORE_MARGIN,
    ) -> None:
        super().__init__()
        self.min_contacts = min_contacts
        self.frame_level = frame_level
        self.friction_tolerance = friction_tolerance
        self.n_force_bins = n_force_bins
        self.n_angle_bins = n_angle_bins
        self.force_linear_edges = force_linear_edges
        self.force_log_edges = force_log_edges
        self.core_margin = core_margin

    def _compute(self, network: ContactNetwork) -> None:
        parts, descriptors = self._analyse(network)
        core: dict[str, Any] = {"core_connectivity": None, "core_parts": None}
        if self.core_margin is not None and network.has_box:
            connectivity = CoreConnectivity(self.core_margin, self.min_contacts)
            connectivity.compute(network)
            core["core_connectivity"] = connectivity
            descriptors.update(connectivity.descriptors())
            claimed = None
            if connectivity.core_volume > 0:
                claimed = core_network(network, connectivity.core, connectivity.core_volume)
            if claimed is not None:
                core_parts, core_descriptors = self._analyse(claimed)
                core["core_parts"] = core_parts
                for name, value in core_descriptors.items():
                    if name in _CORE_FROM_CLAIMS or name.startswith("k_") \
                            or not name.startswith(_CONNECTIVITY_NAMES):
                        descriptors[f"{name}_core"] = value
        self._store(network=network, descriptors=descriptors, **parts, **core)

    def _analyse(self, network: ContactNetwork) -> tuple[dict[str, Any], dict[str, Any]]:
        """The analyses of one network and their descriptors."""
        parts: dict[str, Any] = {
            "stress": StressState().compute(network),
            "connectivity": Connectivity(min_contacts=self.min_contacts).compute(network),
            "angular": AngularDistributions(n_bins=self.n_angle_bins,
                                            frame_level=self.frame_level).compute(network),
            "forces": ForceStatistics(n_bins=self.n_force_bins,
                                      linear_edges=self.force_linear_edges,
                                      log_edges=self.force_log_edges).compute(network),
            "friction": None,
            "partial": None,
        }
        parts["fabric"] = parts["angular"].fabric  # computed once, shared
        if network.friction_coefficient is not None:
            parts["friction"] = Friction(tolerance=self.friction_tolerance).compute(network)
        if network.pair_types is not None and network.type_names:
            parts["partial"] = PartialStresses().compute(network)
        descriptors: dict[str, Any] = {}
        for name in ("stress", "connectivity", "fabric", "forces", "friction", "partial"):
            if parts[name] is not None:
                descriptors.update(parts[name].descriptors())
        if parts["friction"] is not None:
            descriptors.update(harmonic_mobilisation(
                parts["fabric"].anisotropies, network.friction_coefficient,
                parts["friction"].mean_branch_friction, network.dimension,
            ))
        return parts, descriptors

    @property
    def network(self) -> ContactNetwork:
        """The analysed network."""
        return self._get("network")

    @property
    def descriptors(self) -> dict[str, Any]:
        """Every scalar descriptor, flat (the row of a results table)."""
        return self._get("descriptors")

    @property
    def stress(self) -> StressState:
        """Stress from contacts (both forms), invariants, principal values and directions."""
        return self._get("stress")

    @property
    def connectivity(self) -> Connectivity:
        """Packing fraction, z, z_c, rattlers, contact-type proportions."""
        return self._get("connectivity")

    @property
    def fabric(self) -> Fabric:
        """Fabric, branch and force tensors and anisotropies in both frames."""
        return self._get("fabric")

    @property
    def angular(self) -> AngularDistributions:
        """Angular distributions and their harmonic fits, both frames."""
        return self._get("angular")

    @property
    def forces(self) -> ForceStatistics:
        """Force PDFs and the length–force correlation."""
        return self._get("forces")

    @property
    def friction(self) -> Friction | None:
        """Sliding proportion and friction mobilisation (None without mu)."""
        return self._get("friction")

    @property
    def core_connectivity(self) -> CoreConnectivity | None:
        """Packing fraction, z, z_c and rattlers of the core (None without a box)."""
        return self._get("core_connectivity")

    @property
    def core_parts(self) -> dict[str, Any] | None:
        """The analyses of the core's claimed contacts ("stress", "angular", "fabric",
        "forces", "friction", "partial"), or None without a core."""
        return self._get("core_parts")

    @property
    def partial(self) -> PartialStresses | None:
        """Partial stresses by contact type (None without contact types)."""
        return self._get("partial")
