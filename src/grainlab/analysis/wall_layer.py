"""The wall layer and the core of a sample in a box of walls.

Particles next to a flat wall pack in layers against it: the packing fraction, the number of
neighbours and the contact types of the first one or two diameters differ from the bulk that
seeds 002 and 003 describe (their 12 000-40 000 particles are almost all bulk; at 500 particles
about half the centres lie within one diameter of a wall). Every descriptor of the study is
therefore also measured over the **core**: the particles whose centre lies at least a distance
``margin`` inside every wall of the box,

    core = { i : lower_a + margin <= x_a^i <= upper_a - margin for every axis a },

with the core's volume V_core = prod_a (L_a - 2 margin).

* :func:`packing_profile`: the packing fraction against the distance h of the centres to the
  nearest wall, sum of the volumes of the particles whose centre lies in a shell
  h in [h_k, h_k+1) over the shell's volume V(h >= h_k) - V(h >= h_k+1), with
  V(h >= s) = prod_a max(L_a - 2 s, 0). A bulk packing is flat; the wall layer shows as the
  first shells' departure from the plateau. Each particle's volume counts in its centre's
  shell, so a shell thinner than a particle can read above 1 where the centres pile up (the
  first layer, at h ~ the radius): only the plateau is a packing fraction.
* :func:`solid_profile`: the solid fraction of shells of points at a distance h from the
  nearest wall (from :func:`solid_in_box`): a packing fraction at every h. The margin is
  chosen where it has reached its plateau (:data:`CORE_MARGIN`; the study report draws it).
* :func:`core_network`: the contacts of the core particles as they see them, for the
  statistics of contacts (fabric, forces, sliding, contact types, partial stresses). Each
  core particle claims half of each of its contacts: a pair between two core particles is
  listed twice, a pair with one core end once, and the volume is 2 V_core, so that every
  average over contacts weights a contact by its share of core ends, and the stress
  (1/(2 V_core)) sum f (x) l is the mean stress of the core particles, sum over the core of
  their particle stresses (seed 002 eq. 3, particle form, wall contacts included) over V_core.
* :func:`solid_in_box`: the solid inside the core's box, sum_i v_i w_i, w_i the part of
  particle i inside the box, read from its volume-equivalent sphere (disc in 2D) of radius
  r_i = (3 v_i / (4 pi))^(1/3): w_i = prod_a f(lo_a, hi_a), f the part of the sphere between
  two planes of axis a (the spherical caps, pi h^2 (3 r - h) / 3 of height h; circular
  segments in 2D). Exact for a sphere cut by one face, and at an edge or corner through its
  centre; a particle cut by two faces off its centre is read to the product's few percent.
  Any shape of the same volume and centroid gives the same mean where the centres are spread
  evenly across the box's faces, so the equivalent sphere carries no bias for polyhedra or
  aggregates; and the part inside, unlike a count of centres, does not jump where the box's
  face falls between two layers of centres.
* :class:`CoreConnectivity`: packing fraction solid_in_box / V_core, z and z_c counted from
  the core particles' own contacts (2 x claimed pairs / N_core, every neighbour counted), and
  the rattlers of the whole network (walls counted as supports) among the core.

* :func:`core_by_margin`: the core's packing fraction, z and z_c at several margins: where
  the margin cuts through the wall layer (the first layer's centres pile up at h below the
  largest radius, the shell behind it is depleted) the values depart from the bulk's; past
  the layer they scatter about it.

For a simple cubic lattice of spheres of diameter d in a box that fits it, a margin of a whole
or half number of diameters gives a core packing fraction of pi/6 exactly, and a whole number
z = 6 (``tests/analysis/test_wall_layer.py``).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import pandas as pd

from grainlab.analysis.compute import Compute
from grainlab.analysis.connectivity import find_rattlers, wall_interactions
from grainlab.analysis.contact_network import ContactNetwork
from grainlab.errors import InputError

CORE_MARGIN = 1.5
"""Default margin of the core, in mean volume-equivalent diameters <d_v>: past the first
layer (centres at h < r_max, 0.75-1 <d> for the seeds' size ratios) and the depleted shell
behind it (docs/benchmarks/studies.md, "The core's margin", for the profiles and the margins
it was read from)."""


def mean_diameter(network: ContactNetwork) -> float:
    """<d_v> [m]: the mean volume-equivalent diameter (6 v / pi)^(1/3) (2D: (4 a / pi)^(1/2))."""
    if network.dimension == 3:
        return float(np.mean(np.cbrt(6.0 * network.volumes / np.pi)))
    return float(np.mean(np.sqrt(4.0 * network.volumes / np.pi)))


def _box(network: ContactNetwork) -> tuple[np.ndarray, np.ndarray]:
    if not network.has_box:
        raise InputError("network", "a network without a box",
                         "a network held by walls (box_lower, box_upper)")
    return network.box_lower, network.box_upper


def wall_distances(network: ContactNetwork) -> np.ndarray:
    """(N,) distance of each centre to the nearest wall of the box [m]."""
    lower, upper = _box(network)
    x = network.positions
    return np.min(np.minimum(x - lower, upper - x), axis=1)


def region_volume(network: ContactNetwork, margin: float) -> float:
    """V(h >= margin) = prod_a max(L_a - 2 margin, 0) [m^3] (area in 2D)."""
    lower, upper = _box(network)
    return float(np.prod(np.maximum(upper - lower - 2.0 * margin, 0.0)))


def core_mask(network: ContactNetwork, margin: float) -> np.ndarray:
    """(N,) True for the particles whose centre is at least ``margin`` [m] from every wall."""
    if not (np.isfinite(margin) and margin >= 0.0):
        raise InputError("margin", margin, "a distance >= 0 [m]")
    return wall_distances(network) >= margin


def _part_between(lo: np.ndarray, hi: np.ndarray, r: np.ndarray, dimension: int) -> np.ndarray:
    """The part of a sphere (disc in 2D) of radius ``r`` between two planes at signed
    distances ``lo`` < ``hi`` from its centre [-] (0 to 1)."""

    def below(s: np.ndarray) -> np.ndarray:  # the part on the side s of a plane at s
        t = np.clip(s / r, -1.0, 1.0)
        if dimension == 3:
            return 0.25 * (1.0 + t) ** 2 * (2.0 - t)  # cap of height r (1 + t)
        return (np.arccos(-t) + t * np.sqrt(1.0 - t * t)) / np.pi  # segment, same height

    return np.clip(below(hi) - below(lo), 0.0, 1.0)


def solid_in_box(network: ContactNetwork, lower: np.ndarray, upper: np.ndarray) -> float:
    """sum_i v_i w_i [m^3]: the solid inside the box [``lower``, ``upper``] (module
    docstring; w_i from each particle's volume-equivalent sphere, disc in 2D)."""
    v = network.volumes
    if network.dimension == 3:
        r = np.cbrt(3.0 * v / (4.0 * np.pi))
    else:
        r = np.sqrt(v / np.pi)
    x = network.positions
    w = np.ones(v.shape)
    for a in range(x.shape[1]):
        w *= _part_between(lower[a] - x[:, a], upper[a] - x[:, a], r, network.dimension)
    return float(v @ w)


def packing_profile(network: ContactNetwork, bin_width: float,
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Packing fraction against the distance to the nearest wall (module docstring).

    Returns the (K + 1,) shell edges h_k [m] (from 0 to the box's half-width, in steps of
    ``bin_width`` [m]) and the (K,) packing fraction of each shell [-] (NaN for an empty
    shell volume)."""
    edges = _shell_edges(network, bin_width)
    h = wall_distances(network)
    solid, _ = np.histogram(h, bins=edges, weights=network.volumes)
    shells = -np.diff([region_volume(network, s) for s in edges])
    with np.errstate(invalid="ignore", divide="ignore"):
        fraction = np.where(shells > 0, solid / shells, np.nan)
    return edges, fraction


def solid_profile(network: ContactNetwork, bin_width: float,
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The solid fraction against the distance h of a point to the nearest wall: the solid
    of the shell of points h in [h_k, h_k+1) (:func:`solid_in_box` of the box h >= h_k less
    that of h >= h_k+1, each particle read as its volume-equivalent sphere) over the shell's
    volume. A packing fraction at every h, which the first layer's pile-up and the depleted
    shell behind it modulate for two to three diameters before the bulk's plateau; the
    core's packing fraction is this profile's mean over h >= margin.

    Returns the (K + 1,) shell edges h_k [m] (from 0 to the box's half-width, in steps of
    ``bin_width`` [m]) and the (K,) solid fraction of each shell [-] (NaN for an empty shell
    volume)."""
    edges = _shell_edges(network, bin_width)
    lower, upper = _box(network)
    solid = np.array([solid_in_box(network, lower + h, upper - h) for h in edges])
    shells = -np.diff([region_volume(network, h) for h in edges])
    with np.errstate(invalid="ignore", divide="ignore"):
        fraction = np.where(shells > 0, -np.diff(solid) / shells, np.nan)
    return edges, fraction


def _shell_edges(network: ContactNetwork, bin_width: float) -> np.ndarray:
    if not (np.isfinite(bin_width) and bin_width > 0.0):
        raise InputError("bin_width", bin_width, "a shell width > 0 [m]")
    lower, upper = _box(network)
    half = 0.5 * float(np.min(upper - lower))
    edges = np.arange(0.0, half + bin_width, bin_width)
    edges = edges[edges <= half + 1e-12 * half]
    return edges if edges.size >= 2 else np.array([0.0, half])


def core_network(network: ContactNetwork, core: np.ndarray,
                 core_volume: float) -> ContactNetwork | None:
    """The contacts of the core particles as they claim them (module docstring): pairs listed
    once per core end, the wall contacts of core particles listed twice (the wall claims
    nothing), volume 2 ``core_volume`` [m^3]. None when no contact touches the core.
    Particles keep their indices (the particle arrays are the network's)."""
    if not core_volume > 0.0:
        raise InputError("core_volume", core_volume, "the core's volume, > 0 [m^3]")
    pairs = network.pair_particles
    ends = core[pairs[:, 0]].astype(np.int64) + core[pairs[:, 1]]
    if not np.any(ends):
        return None
    pair_index = np.repeat(np.arange(network.n_pairs), ends)
    order = np.argsort(network.point_pairs, kind="stable")  # points grouped by pair
    counts = network.pair_point_counts
    offsets = np.concatenate([[0], np.cumsum(counts)])
    lengths = counts[pair_index]
    starts = np.repeat(offsets[pair_index] - np.cumsum(lengths) + lengths, lengths)
    points = order[starts + np.arange(int(lengths.sum()))]
    walls = {}
    if network.wall_particles is not None:
        w = np.repeat(np.flatnonzero(core[network.wall_particles]), 2)
        walls = {"wall_particles": network.wall_particles[w],
                 "wall_points": network.wall_points[w],
                 "wall_normals": network.wall_normals[w],
                 "wall_forces": network.wall_forces[w]}
    return ContactNetwork(
        positions=network.positions, volumes=network.volumes, volume=2.0 * core_volume,
        pair_particles=pairs[pair_index], pair_branches=network.pair_branches[pair_index],
        point_pairs=np.repeat(np.arange(pair_index.size), lengths),
        point_positions=network.point_positions[points],
        point_normals=network.point_normals[points], point_forces=network.point_forces[points],
        pair_types=None if network.pair_types is None else network.pair_types[pair_index],
        type_names=network.type_names, type_points=network.type_points,
        friction_coefficient=network.friction_coefficient,
        point_sliding=None if network.point_sliding is None
        else network.point_sliding[points],
        box_lower=network.box_lower, box_upper=network.box_upper,
        state=dict(network.state), **walls)


class CoreConnectivity(Compute):
    """Packing fraction, z, z_c and rattlers of the core (module docstring).

    Parameters
    ----------
    margin:
        Distance of the core from every wall, in mean volume-equivalent diameters <d_v>
        (:func:`mean_diameter`); default :data:`CORE_MARGIN`.
    min_contacts:
        The rattler rule of :class:`~grainlab.analysis.connectivity.Connectivity` (walls
        count as supports).

    Properties after :meth:`compute`: ``margin`` [m], ``core`` ((N,) bool), ``core_volume``
    [m^3], ``packing_fraction``, ``coordination_number``, ``connectivity_number``,
    ``rattler_fraction``, ``coordination_number_no_rattlers``,
    ``connectivity_number_no_rattlers`` (NaN with an empty core).
    """

    def __init__(self, margin: float = CORE_MARGIN, min_contacts: int = 2) -> None:
        super().__init__()
        if not (np.isfinite(margin) and margin >= 0.0):
            raise InputError("margin", margin, "a distance >= 0 in mean diameters")
        self.margin_diameters = float(margin)
        self.min_contacts = int(min_contacts)

    def _compute(self, network: ContactNetwork) -> None:
        margin = self.margin_diameters * mean_diameter(network)
        core = core_mask(network, margin)
        volume = region_volume(network, margin)
        n_core = int(core.sum())
        active = network.active_pairs()
        pairs = network.pair_particles
        if network.type_points:
            points = np.asarray(network.type_points, dtype=float)[network.pair_types]
        else:
            points = np.bincount(network.point_pairs, network.active_points().astype(float),
                                 minlength=network.n_pairs)
        ends = np.where(active, core[pairs[:, 0]].astype(float) + core[pairs[:, 1]], 0.0)
        rattlers = find_rattlers(network.n_particles, pairs[active], self.min_contacts,
                                 wall_interactions(network))
        kept = ~rattlers
        kept_ends = np.where(active & kept[pairs[:, 0]] & kept[pairs[:, 1]],
                             (core & kept)[pairs[:, 0]].astype(float) + (core & kept)[pairs[:, 1]],
                             0.0)
        n_kept = int((core & kept).sum())

        def ratio(a: float, b: float) -> float:
            return float(a / b) if b > 0 else float("nan")

        self._store(
            margin=margin, core=core, core_volume=volume, n_core=n_core,
            # no centre in the core: nothing measured there (not a packing fraction of 0)
            packing_fraction=ratio(solid_in_box(network, network.box_lower + margin,
                                                network.box_upper - margin), volume)
            if n_core else float("nan"),
            coordination_number=ratio(ends.sum(), n_core),
            connectivity_number=ratio(ends @ points, n_core),
            rattler_fraction=ratio(int((core & rattlers).sum()), n_core),
            coordination_number_no_rattlers=ratio(kept_ends.sum(), n_kept),
            connectivity_number_no_rattlers=ratio(kept_ends @ points, n_kept),
        )

    @property
    def margin(self) -> float:
        """The core's distance from every wall [m]."""
        return self._get("margin")

    @property
    def core(self) -> np.ndarray:
        """(N,) True for the core particles."""
        return self._get("core")

    @property
    def core_volume(self) -> float:
        """V_core = prod_a (L_a - 2 margin) [m^3]."""
        return self._get("core_volume")

    @property
    def packing_fraction(self) -> float:
        """The solid inside the core's box over V_core, :func:`solid_in_box` [-]."""
        return self._get("packing_fraction")

    @property
    def coordination_number(self) -> float:
        """z of the core: loaded pairs of the core particles (every neighbour) x 2 claimed
        halves / N_core [-]."""
        return self._get("coordination_number")

    @property
    def connectivity_number(self) -> float:
        """z_c of the core: the claimed halves weighted by their contact points / N_core [-]."""
        return self._get("connectivity_number")

    @property
    def n_core(self) -> int:
        """The number of core particles."""
        return int(self._get("n_core"))

    def descriptors(self) -> dict[str, float]:
        """Flat dict, each name with ``_core``: packing_fraction, coordination_number,
        connectivity_number, rattler_fraction, coordination_number_no_rattlers,
        connectivity_number_no_rattlers; n_core and core_margin [m]."""
        out = {f"{name}_core": float(self._get(name)) for name in (
            "packing_fraction", "coordination_number", "connectivity_number",
            "rattler_fraction", "coordination_number_no_rattlers",
            "connectivity_number_no_rattlers")}
        out["n_core"] = float(self._get("n_core"))
        out["core_margin"] = float(self._get("margin"))
        return out


def core_by_margin(network: ContactNetwork, margins: Iterable[float],
                   min_contacts: int = 2) -> pd.DataFrame:
    """The core at each of ``margins`` [mean diameters <d>] (module docstring): a DataFrame
    with ``margin`` [<d>], ``n_core``, ``packing_fraction``, ``coordination_number``,
    ``connectivity_number`` (NaN where the core is empty)."""
    rows = []
    for margin in margins:
        core = CoreConnectivity(float(margin), min_contacts).compute(network)
        rows.append({"margin": float(margin), "n_core": core.n_core,
                     "packing_fraction": core.packing_fraction,
                     "coordination_number": core.coordination_number,
                     "connectivity_number": core.connectivity_number})
    return pd.DataFrame(rows)
