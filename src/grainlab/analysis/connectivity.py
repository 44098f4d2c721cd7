"""Packing fraction, coordination and connectivity numbers, rattlers and contact types.

For a network of N particles with P_a active interactions (particle pairs with at least one
contact point carrying f_n > 0) and C_a active contact points (seed 002 eqs. 13–14; seed 003
eq. 13):

* packing fraction rho = sum_i v_i / V;
* coordination number z = 2 P_a / N (mean number of loaded neighbours per particle);
* connectivity number z_c = 2 C_a / N (mean number of loaded contact points per particle);
  where the network stores each pair as one resultant standing for ``type_points[type]``
  points (polyhedra), C_a sums those over the active pairs — seed 002 eq. 14;
* proportions k_gamma = P_a,gamma / P_a of the contact types gamma of the network's
  ``type_names`` (fv, ee, fe, ff for polyhedra; s, ds, d, t, q for aggregates) and the mean
  number m_gamma of active points per active pair of type gamma, so that
  z_c / z = sum_gamma k_gamma m_gamma — seed 002 eq. 13, z_c/z = k_ee + k_fv + 2 k_fe + 3 k_ff,
  and seed 003 eq. 13, Z_c/Z = k_s + 2 (k_ds + k_d) + 3 k_t + 4 k_q, are this identity with
  the nominal m_gamma.

**Rattlers.** A particle with fewer than ``min_contacts`` active interactions cannot be in
stable equilibrium and carries no load. Removing it lowers the counts of its neighbours, which
may then fall below ``min_contacts`` themselves: the rattlers are found *recursively* until no
count changes — the set removed is the complement of the (``min_contacts``)-core of the graph
of active interactions. An interaction of a particle with its own periodic image (a pair
(i, i)) counts twice, once for each image that touches i. A wall holds a particle as a
neighbour would: each wall a particle touches with a loaded point counts as one interaction of
that particle, and walls are never removed, so that a particle held by two walls and one
neighbour is not a rattler. (z and z_c count particle contacts only, as the papers'.)
The rattler-free numbers count only
active interactions (and their active points) between two non-rattlers and divide by the number
of non-rattlers.
"""

from __future__ import annotations

import numpy as np

from grainlab.analysis.compute import Compute
from grainlab.errors import InputError


def packing_fraction(network) -> float:
    """sum of particle volumes / sample volume [-] (areas in 2D).

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0.0, 0.0], [2.0, 0.0]], volumes=[1.0, 2.0], volume=10.0,
    ...     pair_particles=[[0, 1]], pair_branches=[[2.0, 0.0]], point_pairs=[0],
    ...     point_positions=[[1.0, 0.0]], point_normals=[[1.0, 0.0]], point_forces=[[1.0, 0.0]])
    >>> packing_fraction(net)
    0.3
    """
    return float(network.volumes.sum() / network.volume)


def wall_interactions(network) -> np.ndarray:
    """(N,) number of walls each particle touches with a loaded point (0 without walls)."""
    counts = np.zeros(network.n_particles, dtype=np.int64)
    if not network.n_wall_points:
        return counts
    loaded = np.einsum("wi,wi->w", network.wall_forces, network.wall_normals) > 0.0
    keys = np.unique(network.wall_particles[loaded] * 64 + network.wall_ids[loaded])
    np.add.at(counts, keys // 64, 1)
    return counts


def find_rattlers(n_particles: int, pairs: np.ndarray, min_contacts: int = 2,
                  fixed_counts: np.ndarray | None = None) -> np.ndarray:
    """(N,) bool mask of rattlers: particles left with fewer than ``min_contacts`` interactions
    after recursively removing rattlers (the complement of the ``min_contacts``-core).

    Parameters
    ----------
    n_particles:
        Number of particles N.
    pairs:
        (P, 2) particle indices of the interactions to count (usually the active ones); a pair
        (i, i) counts twice for i.
    min_contacts:
        A particle with fewer interactions than this is a rattler.
    fixed_counts:
        (N,) interactions with supports that are never removed (walls), or None.

    Linear in N + P: counts are decremented only along the interactions of the particles
    removed in the previous sweep (a peeling of the graph, sweep by sweep).

    >>> chain = np.array([[0, 1], [1, 2], [2, 0], [2, 3], [3, 4]])  # triangle + tail 3-4
    >>> find_rattlers(6, chain).astype(int)
    array([0, 0, 0, 1, 1, 1])
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    n_pairs = pairs.shape[0]
    # half-edges: (end, other end, interaction), grouped by end (CSR)
    ends = np.concatenate([pairs[:, 0], pairs[:, 1]])
    others = np.concatenate([pairs[:, 1], pairs[:, 0]])
    edge_of = np.concatenate([np.arange(n_pairs), np.arange(n_pairs)])
    order = np.argsort(ends, kind="stable")
    others, edge_of = others[order], edge_of[order]
    counts = np.bincount(ends, minlength=n_particles)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    if fixed_counts is not None:  # supports that are never removed: counted, not peeled
        counts = counts + np.asarray(fixed_counts, dtype=np.int64)
    edge_alive = np.ones(n_pairs, dtype=bool)
    rattler = counts < min_contacts
    frontier = np.flatnonzero(rattler)
    while frontier.size:
        lengths = offsets[frontier + 1] - offsets[frontier]
        total = int(lengths.sum())
        if total == 0:
            break
        starts = np.repeat(offsets[frontier] - np.cumsum(lengths) + lengths, lengths)
        half = starts + np.arange(total)
        edges, neighbours = edge_of[half], others[half]
        live = edge_alive[edges]
        edges, neighbours = edges[live], neighbours[live]
        edge_alive[edges] = False
        np.subtract.at(counts, neighbours, 1)
        candidates = neighbours[~rattler[neighbours]]
        frontier = np.unique(candidates[counts[candidates] < min_contacts])
        rattler[frontier] = True
    return rattler


def _ratio(numerator: float, denominator: float) -> float:
    return float(numerator / denominator) if denominator != 0 else float("nan")


class Connectivity(Compute):
    """Packing fraction, z, z_c, rattlers and contact-type proportions of a contact network
    (seed 002 eqs. 13–14; seed 003 eq. 13). See the module docstring for the definitions and
    the rattler rule.

    Parameters
    ----------
    min_contacts:
        A particle with fewer active interactions than this (after recursive removal) is a
        rattler; default 2. An integer >= 1.
    wall_supports:
        Count the walls a particle touches as its interactions in the rattler rule (module
        docstring); default True. False: particle contacts only (the rule of the results
        table's ``z_no_rattlers`` and ``rattler_fraction`` columns, kept as they were recorded).

    Properties after :meth:`compute`: ``packing_fraction``, ``coordination_number`` (z),
    ``connectivity_number`` (z_c), ``rattlers`` ((N,) bool), ``rattler_fraction``,
    ``coordination_number_no_rattlers``, ``connectivity_number_no_rattlers``,
    ``type_proportions`` ({name: k_gamma}, empty without contact types),
    ``points_per_pair_by_type`` ({name: m_gamma}, NaN for a type with no active pair) and
    ``connectivity_ratio`` (z_c / z). Ratios over an empty set are NaN.

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0.0, 0.0], [2.0, 0.0], [4.0, 0.0]], volumes=[3.0] * 3, volume=30.0,
    ...     pair_particles=[[0, 1], [1, 2]], pair_branches=[[2.0, 0.0], [2.0, 0.0]],
    ...     point_pairs=[0, 0, 1], point_positions=[[1.0, 0.5], [1.0, -0.5], [3.0, 0.0]],
    ...     point_normals=[[1.0, 0.0]] * 3, point_forces=[[1.0, 0.0]] * 3,
    ...     pair_types=[1, 0], type_names=("s", "d"))
    >>> c = Connectivity().compute(net)
    >>> c.coordination_number, c.connectivity_number, c.type_proportions
    (1.3333333333333333, 2.0, {'s': 0.5, 'd': 0.5})
    >>> c.rattlers.tolist()  # the ends have one neighbour; then the middle one has none
    [True, True, True]
    """

    def __init__(self, min_contacts: int = 2, wall_supports: bool = True) -> None:
        super().__init__()
        self.wall_supports = bool(wall_supports)
        if isinstance(min_contacts, bool) or not isinstance(min_contacts, int | np.integer) \
                or min_contacts < 1:
            raise InputError("min_contacts", min_contacts, "an integer >= 1")
        self.min_contacts = int(min_contacts)

    def _compute(self, network) -> None:
        n = network.n_particles
        active_points = network.active_points()
        active_pairs = network.active_pairs()
        if network.type_points:  # one resultant per pair, standing for m_type points
            points_per_pair = np.where(active_pairs, np.asarray(network.type_points,
                                                                dtype=np.int64)[
                network.pair_types], 0)
        else:
            points_per_pair = np.bincount(network.point_pairs, active_points.astype(np.int64),
                                          minlength=network.n_pairs)
        pairs = network.pair_particles[active_pairs]
        n_active_pairs = int(active_pairs.sum())
        n_active_points = int(points_per_pair[active_pairs].sum())
        rattlers = find_rattlers(n, pairs, self.min_contacts,
                                 wall_interactions(network) if self.wall_supports else None)
        kept = ~rattlers[network.pair_particles[:, 0]] & ~rattlers[network.pair_particles[:, 1]]
        kept &= active_pairs
        n_kept = n - int(rattlers.sum())
        proportions: dict[str, float] = {}
        points_by_type: dict[str, float] = {}
        if network.pair_types is not None:
            k = len(network.type_names)
            types = network.pair_types[active_pairs]
            pair_count = np.bincount(types, minlength=k)
            point_count = np.bincount(types, points_per_pair[active_pairs], minlength=k)
            for code, name in enumerate(network.type_names):
                proportions[name] = _ratio(pair_count[code], n_active_pairs)
                points_by_type[name] = _ratio(point_count[code], pair_count[code])
        self._store(
            packing_fraction=packing_fraction(network),
            coordination_number=_ratio(2.0 * n_active_pairs, n),
            connectivity_number=_ratio(2.0 * n_active_points, n),
            connectivity_ratio=_ratio(n_active_points, n_active_pairs),
            rattlers=rattlers,
            rattler_fraction=_ratio(int(rattlers.sum()), n),
            coordination_number_no_rattlers=_ratio(2.0 * int(kept.sum()), n_kept),
            connectivity_number_no_rattlers=_ratio(2.0 * int(points_per_pair[kept].sum()),
                                                   n_kept),
            type_proportions=proportions,
            points_per_pair_by_type=points_by_type,
        )

    @property
    def packing_fraction(self) -> float:
        """sum_i v_i / V [-]."""
        return self._get("packing_fraction")

    @property
    def coordination_number(self) -> float:
        """z = 2 P_active / N [-]."""
        return self._get("coordination_number")

    @property
    def connectivity_number(self) -> float:
        """z_c = 2 C_active / N [-]."""
        return self._get("connectivity_number")

    @property
    def connectivity_ratio(self) -> float:
        """z_c / z = C_active / P_active = sum_gamma k_gamma m_gamma [-]."""
        return self._get("connectivity_ratio")

    @property
    def rattlers(self) -> np.ndarray:
        """(N,) True for rattlers (recursive rule, module docstring)."""
        return self._get("rattlers")

    @property
    def rattler_fraction(self) -> float:
        """Number of rattlers / N [-]."""
        return self._get("rattler_fraction")

    @property
    def coordination_number_no_rattlers(self) -> float:
        """2 x (active interactions between non-rattlers) / (number of non-rattlers) [-]."""
        return self._get("coordination_number_no_rattlers")

    @property
    def connectivity_number_no_rattlers(self) -> float:
        """2 x (their active points) / (number of non-rattlers) [-]."""
        return self._get("connectivity_number_no_rattlers")

    @property
    def type_proportions(self) -> dict[str, float]:
        """{type name: k_gamma}, proportions among active pairs (sum 1); empty without types."""
        return self._get("type_proportions")

    @property
    def points_per_pair_by_type(self) -> dict[str, float]:
        """{type name: m_gamma}, mean number of active points per active pair of the type."""
        return self._get("points_per_pair_by_type")

    def descriptors(self) -> dict[str, float]:
        """Flat dict: packing_fraction, coordination_number, connectivity_number,
        connectivity_ratio, rattler_fraction, coordination_number_no_rattlers,
        connectivity_number_no_rattlers and k_<type> for each contact type."""
        out = {name: self._get(name) for name in (
            "packing_fraction", "coordination_number", "connectivity_number",
            "connectivity_ratio", "rattler_fraction", "coordination_number_no_rattlers",
            "connectivity_number_no_rattlers")}
        out.update({f"k_{name}": value for name, value in self.type_proportions.items()})
        return out
