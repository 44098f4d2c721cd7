"""Partial stresses carried by each contact type (seed 002 eq. 29; seed 003 eq. 26).

Restricting the contact form of the stress (seed 002 eq. 3) to the points of the pairs of one
contact type gamma,

    sigma_gamma = (1/V) sum_{c in pairs of type gamma} f^c (x) l^c      [Pa],

gives tensors that sum to the total stress, sigma = sum_gamma sigma_gamma. Each type's share
of the shear stress is measured along the principal directions e_1 (major) and e_minor (e_3 in
3D, e_2 in 2D) of the *total* symmetric stress and normalised by its trace, the seeds' q/p
(``q_over_trace`` of :mod:`grainlab.result.columns`):

    q_gamma / tr(sigma) = (e_1 . sigma_gamma . e_1 - e_minor . sigma_gamma . e_minor) / tr(sigma)

(3D: (...)/3/p, 2D: (...)/2/p), so that sum_gamma q_gamma / tr(sigma) = ``q_over_trace`` of
:class:`~grainlab.analysis.contact_stress.StressState` (seed 002 Fig. 22, seed 003 Fig. 18).
In a network held by walls the wall contacts are one more share, ``wall``
(:func:`~grainlab.analysis.contact_stress.wall_stress`), and the total, p and the principal
directions are those of particle and wall contacts together, so that the shares still sum to
the sample's q/p.
"""

from __future__ import annotations

import numpy as np

from grainlab.analysis.compute import Compute
from grainlab.analysis.contact_stress import principal_stresses, stress_from_network, wall_stress
from grainlab.errors import InputError


def partial_stress_tensors(network) -> dict[str, np.ndarray]:
    """{type name: (d, d) full (not symmetrised) partial stress sigma_gamma [Pa]}, one entry per
    name of ``network.type_names`` (zeros for a type without pairs).

    Raises :class:`~grainlab.errors.InputError` naming ``pair_types`` if the network has none.
    """
    if network.pair_types is None:
        raise InputError("pair_types", None, "contact-type codes of the pairs (with type_names)")
    d = network.dimension
    k = len(network.type_names)
    codes = network.pair_types[network.point_pairs]
    forces, branches = network.point_forces, network.point_branches
    tensors = np.empty((k, d, d))
    for a in range(d):
        for b in range(d):
            tensors[:, a, b] = np.bincount(codes, forces[:, a] * branches[:, b], minlength=k)
    tensors /= network.volume
    return {name: tensors[code] for code, name in enumerate(network.type_names)}


class PartialStresses(Compute):
    """Partial stress tensors by contact type and their normalised shear stresses
    q_gamma / tr(sigma) (module docstring; seed 002 eq. 29, seed 003 eq. 26).

    Properties after :meth:`compute`: ``tensors`` ({type: (d, d) full tensor [Pa]}),
    ``tensor`` (the total, their sum), ``p`` (total mean stress tr(sigma)/d [Pa]),
    ``q_over_trace`` ({type: q_gamma / tr(sigma) [-]}, NaN when p = 0).

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], volumes=[3.0] * 3, volume=8.0,
    ...     pair_particles=[[0, 1], [0, 2]], pair_branches=[[2.0, 0.0], [0.0, 2.0]],
    ...     point_pairs=[0, 1], point_positions=[[1.0, 0.0], [0.0, 1.0]],
    ...     point_normals=[[1.0, 0.0], [0.0, 1.0]], point_forces=[[12.0, 0.0], [0.0, 4.0]],
    ...     pair_types=[0, 1], type_names=("s", "d"))
    >>> PartialStresses().compute(net).q_over_trace
    {'s': 0.75, 'd': -0.25}
    """

    def _compute(self, network) -> None:
        tensors = partial_stress_tensors(network)
        if network.n_wall_points:
            tensors["wall"] = wall_stress(network)
        total = stress_from_network(network)
        d = network.dimension
        sym = 0.5 * (total + total.T)
        _, directions = principal_stresses(sym)
        major, minor = directions[:, 0], directions[:, -1]
        p = float(np.trace(sym)) / d
        q_over_trace = {}
        for name, tensor in tensors.items():
            q = major @ tensor @ major - minor @ tensor @ minor
            q_over_trace[name] = float(q / (d * p)) if p != 0 else float("nan")
        self._store(tensors=tensors, tensor=total, p=p, q_over_trace=q_over_trace)

    @property
    def tensors(self) -> dict[str, np.ndarray]:
        """{type name: (d, d) partial stress sigma_gamma [Pa]} (full, not symmetrised), and
        ``wall`` for the wall contacts' share where the network has them."""
        return self._get("tensors")

    @property
    def tensor(self) -> np.ndarray:
        """(d, d) total stress (1/V) sum_c f^c (x) l^c [Pa], not symmetrised."""
        return self._get("tensor")

    @property
    def p(self) -> float:
        """Total mean stress tr(sigma)/d [Pa]."""
        return self._get("p")

    @property
    def q_over_trace(self) -> dict[str, float]:
        """{type name: q_gamma / tr(sigma) [-]}, along the total stress's principal
        directions."""
        return self._get("q_over_trace")

    def descriptors(self) -> dict[str, float]:
        """Flat dict: q_over_trace_<type> for each contact type."""
        return {f"q_over_trace_{name}": value for name, value in self.q_over_trace.items()}
