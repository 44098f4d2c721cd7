"""The stress of a granular sample as the volume average of contact force dyads.

sigma_ij = (1/V) sum_c f_i^c l_j^c  (seed 000 eqs. 2–5 summed over both particles of each
contact; seed 002 eq. 3), with f^c the force that particle i exerts on particle j and l^c the
branch vector from i to j, so that compression is positive. In 2D, V is an area and f a force
per unit length, giving Pa.

Two forms of seed 002 eq. 3 are offered for a :class:`~grainlab.analysis.ContactNetwork`:

* the particle form, :func:`stress_from_internal_moments`: sigma = -(1/V) sum_i M^i with the
  internal moment M^i = sum_{c in i} f^{c->i} (x) (x^c - x^i) of seed 002 eq. 2 (the minus
  sign turns the papers' tension-positive moment into compression-positive stress);
* the contact form, :func:`stress_from_network`: sigma = (1/V) sum_c f^c (x) l^c.

A network held by walls (``wall_particles``, :class:`~grainlab.analysis.ContactNetwork`) adds
its wall contacts to both forms, the wall standing as the first side of the contact: the force
f^w the wall exerts on particle j at the point x^w with the arm x^j - x^w,

    sigma = (1/V) [ sum_c f^c (x) l^c + sum_w f^w (x) (x^j - x^w) ].

The walls hold the sample: in static equilibrium the sum over particle and wall contacts is
exactly -(1/V) sum_w f^w (x) x^w, the wall reactions over the box's faces (sigma_aa = the
force on the wall above on axis a over its area), whereas the particle contacts alone fall
short of it by the share the walls carry.

They agree identically (the contact positions x^c cancel pair by pair), whether or not the
particles are in equilibrium; :class:`StressState` computes both and the invariants of every
test result (:mod:`grainlab.result.invariants`): p, q, q_over_3, the seeds' q/p as
q_over_trace, sin phi and b (seeds 002/003 eqs. 4, 5, 11).
"""

from __future__ import annotations

import numpy as np

from grainlab.analysis.compute import Compute
from grainlab.result.invariants import stress_invariants


def stress_from_contact_dyads(
    forces: np.ndarray, branches: np.ndarray, volume: float
) -> np.ndarray:
    """Full (not symmetrised) stress tensor (d, d) [Pa], compression positive.

    Parameters
    ----------
    forces:
        (m, d) contact forces exerted by the first particle on the second [N, or N/m in 2D].
    branches:
        (m, d) branch vectors from the first to the second particle centre [m].
    volume:
        Sample volume [m^3] (area [m^2] in 2D).

    The antisymmetric part is non-zero only when particles are out of moment equilibrium.

    >>> stress_from_contact_dyads(np.array([[2.0, 0.0]]), np.array([[1.0, 0.0]]), 4.0)
    array([[0.5, 0. ],
           [0. , 0. ]])
    """
    forces = np.asarray(forces, dtype=float)
    branches = np.asarray(branches, dtype=float)
    return forces.T @ branches / volume


def principal_stresses_2d(stress: np.ndarray) -> tuple[float, float, float]:
    """Major and minor principal stresses [Pa] of the symmetric part of a 2D stress, and the
    direction of the major one as an angle from the x axis, counter-clockwise [rad] in
    (-pi/2, pi/2]."""
    s = 0.5 * (np.asarray(stress) + np.asarray(stress).T)
    centre = 0.5 * (s[0, 0] + s[1, 1])
    radius = float(np.hypot(0.5 * (s[0, 0] - s[1, 1]), s[0, 1]))
    angle = 0.5 * np.arctan2(2.0 * s[0, 1], s[0, 0] - s[1, 1])
    return centre + radius, centre - radius, float(angle)


# -- network forms of seed 002 eq. 3 ----------------------------------------------------------
def _first_and_second(network) -> tuple[np.ndarray, np.ndarray]:
    """(C,) indices of the first and second particle of the pair of every contact point."""
    pairs = network.pair_particles[network.point_pairs]
    return pairs[:, 0], pairs[:, 1]


def internal_moments(network) -> np.ndarray:
    """(N, d, d) internal moments M^i [N m] (seed 002 eq. 2; [N] in 2D).

    M^i_ab = sum_{c in i} f^{c->i}_a r^{c,i}_b, where f^{c->i} is the force ON particle i at its
    contact point c and r^{c,i} = x^c - x^i the vector from the particle's centre to the point.
    For the first particle of a pair f^{c->i} = -f^c and x^i its stored position; for the second
    particle f^{c->i} = +f^c and its centre is taken as the image x^first + l (the pair's
    branch vector), so that periodic networks, where x^second != x^first + l, give the moments
    of the particles as they touch. Contact positions must be given consistently with the
    first particle's stored position (as :class:`~grainlab.analysis.ContactNetwork` states).

    Compression makes M^i negative-definite (tension-positive mechanics convention); the
    stress is sigma = -(1/V) sum_i M^i (:func:`stress_from_internal_moments`).

    Vectorised with one ``np.bincount`` per tensor component: O(C + N).
    """
    n, d = network.n_particles, network.dimension
    first, second = _first_and_second(network)
    forces = network.point_forces
    r_first = network.point_positions - network.positions[first]
    r_second = r_first - network.point_branches  # x^c - (x^first + l)
    moments = np.empty((n, d, d))
    for a in range(d):
        for b in range(d):
            moments[:, a, b] = (
                np.bincount(second, forces[:, a] * r_second[:, b], minlength=n)
                - np.bincount(first, forces[:, a] * r_first[:, b], minlength=n)
            )
    if network.n_wall_points:  # the wall's force on its particle at the wall point
        held = network.wall_particles
        arm = network.wall_points - network.positions[held]
        for a in range(d):
            for b in range(d):
                moments[:, a, b] += np.bincount(held, network.wall_forces[:, a] * arm[:, b],
                                                minlength=n)
    return moments


def stress_from_internal_moments(network) -> np.ndarray:
    """Full (not symmetrised) stress tensor (d, d) [Pa], compression positive, from the
    particles' internal moments: sigma = -(1/V) sum_i M^i (seed 002 eq. 3, first form).

    See :func:`internal_moments` for M^i; :func:`particle_stresses` gives the per-particle
    tensors, whose volume-weighted sum is this tensor. Equal to :func:`stress_from_network`.

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0.0, 0.0], [2.0, 0.0]], volumes=[3.14, 3.14], volume=8.0,
    ...     pair_particles=[[0, 1]], pair_branches=[[2.0, 0.0]], point_pairs=[0],
    ...     point_positions=[[1.0, 0.0]], point_normals=[[1.0, 0.0]], point_forces=[[4.0, 0.0]])
    >>> stress_from_internal_moments(net)
    array([[1., 0.],
           [0., 0.]])
    """
    return 0.0 - internal_moments(network).sum(axis=0) / network.volume  # 0.0 -: no -0.0


def particle_stresses(network) -> np.ndarray:
    """(N, d, d) mean stress inside each particle [Pa], compression positive:
    sigma^i = -M^i / v^i with v^i the particle volume (area in 2D).

    Full tensors: they are symmetric only for particles in moment equilibrium. The sample
    stress is their volume-weighted sum, sigma = (1/V) sum_i v^i sigma^i.
    """
    return -internal_moments(network) / network.volumes[:, None, None]


def stress_from_network(network) -> np.ndarray:
    """Full (not symmetrised) stress tensor (d, d) [Pa], compression positive, from the contact
    form of seed 002 eq. 3: sigma = (1/V) sum_c f^c (x) l^c over all contact points, with
    f^c the force the first particle exerts on the second and l^c the pair's branch vector.

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0.0, 0.0], [2.0, 0.0]], volumes=[3.14, 3.14], volume=8.0,
    ...     pair_particles=[[0, 1]], pair_branches=[[2.0, 0.0]], point_pairs=[0],
    ...     point_positions=[[1.0, 0.0]], point_normals=[[1.0, 0.0]], point_forces=[[4.0, 0.0]])
    >>> stress_from_network(net)
    array([[1., 0.],
           [0., 0.]])
    """
    stress = stress_from_contact_dyads(network.point_forces, network.point_branches,
                                       network.volume)
    return stress + wall_stress(network)


def wall_stress(network) -> np.ndarray:
    """(d, d) the wall contacts' share of the contact stress [Pa], not symmetrised:
    (1/V) sum_w f^w (x) (x^j - x^w) (module docstring); zeros without wall contacts."""
    if not network.n_wall_points:
        return np.zeros((network.dimension, network.dimension))
    arm = network.positions[network.wall_particles] - network.wall_points
    return stress_from_contact_dyads(network.wall_forces, arm, network.volume)


def wall_reaction_stress(network) -> np.ndarray:
    """(d, d) -(1/V) sum_w f^w (x) x^w [Pa]: the stress the walls' reactions impose on the
    box (module docstring), equal to :func:`stress_from_network` for a sample in static
    equilibrium; zeros without wall contacts."""
    if not network.n_wall_points:
        return np.zeros((network.dimension, network.dimension))
    return -stress_from_contact_dyads(network.wall_forces, network.wall_points, network.volume)


# -- invariants --------------------------------------------------------------------------------
def principal_stresses(stress: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal values (d,) in descending order (first = major = most compressive) [Pa] and
    principal directions (d, d) as columns, of the symmetric part of ``stress``.

    Each direction is signed so that its largest-magnitude component is positive.

    >>> values, directions = principal_stresses(np.diag([1.0, 3.0, 2.0]))
    >>> values
    array([3., 2., 1.])
    >>> directions[:, 0]
    array([0., 1., 0.])
    """
    s = 0.5 * (np.asarray(stress, dtype=float) + np.asarray(stress, dtype=float).T)
    values, vectors = np.linalg.eigh(s)
    values, vectors = values[::-1], vectors[:, ::-1]
    rows = np.argmax(np.abs(vectors), axis=0)
    signs = np.sign(vectors[rows, np.arange(vectors.shape[1])])
    return values.copy(), vectors * np.where(signs == 0, 1.0, signs)


_AXES = "xyz"


class StressState(Compute):
    """Stress tensor of a contact network and its invariants (seed 002 eqs. 3–5 and 11;
    seed 003 eqs. 4–6 and 12). Compression positive, SI units ([Pa]; in 2D forces per unit
    length and areas, still [Pa]).

    Properties after :meth:`compute`:

    * ``tensor``: symmetric part of the contact form (1/V) sum_c f^c (x) l^c, (d, d);
    * ``tensor_full``: the same, not symmetrised; ``tensor_internal_moments``: the particle
      form -(1/V) sum_i M^i, not symmetrised (equal to ``tensor_full`` up to rounding);
    * ``particle_stresses``: (N, d, d) per-particle tensors -M^i / v^i;
    * ``asymmetry``: |skew(sigma)| / |sigma| (Frobenius norms of the full tensor; 0 for a zero
      tensor), a measure of moment imbalance;
    * ``principal_values`` (d,) descending, sigma_1 major (most compressive) and
      ``principal_directions`` (d, d), the matching unit vectors as columns;
    * ``p`` = tr(sigma)/d;
    * ``q`` = sigma_1 - sigma_minor (the last principal value), the usual deviator;
    * ``q_over_3`` = (sigma_1 - sigma_minor)/3, the q of seeds 002/003 (eq. 5);
    * ``q_over_trace`` = q / tr(sigma), the papers' normalised shear stress q/p: in 3D
      (sigma_1 - sigma_3)/3 / p; in 2D (sigma_1 - sigma_minor)/2 / p;
    * ``sin_phi`` = (sigma_1 - sigma_minor)/(sigma_1 + sigma_minor), the mobilised friction
      angle, equal to seed 002 eq. 11, 3(q/p)/(2 + q/p), under axisymmetric stress
      sigma_2 = sigma_3;
    * ``b`` = (sigma_2 - sigma_3)/(sigma_1 - sigma_3) in 3D (NaN in 2D and at isotropic
      states).

    Ratios with a zero denominator are NaN (:mod:`grainlab.result.invariants`).

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], volumes=[3.14] * 3, volume=8.0,
    ...     pair_particles=[[0, 1], [0, 2]], pair_branches=[[2.0, 0.0], [0.0, 2.0]],
    ...     point_pairs=[0, 1], point_positions=[[1.0, 0.0], [0.0, 1.0]],
    ...     point_normals=[[1.0, 0.0], [0.0, 1.0]], point_forces=[[12.0, 0.0], [0.0, 4.0]])
    >>> state = StressState().compute(net)
    >>> state.principal_values, state.p, state.q_over_trace
    (array([3., 1.]), 2.0, 0.5)
    """

    def _compute(self, network) -> None:
        d = network.dimension
        full = stress_from_network(network)
        moments = internal_moments(network)
        from_moments = 0.0 - moments.sum(axis=0) / network.volume
        sym = 0.5 * (full + full.T)
        skew = 0.5 * (full - full.T)
        norm = float(np.linalg.norm(full))
        values, directions = principal_stresses(sym)
        invariants = stress_invariants(sym)
        self._store(
            tensor=sym,
            tensor_full=full,
            tensor_internal_moments=from_moments,
            particle_stresses=-moments / network.volumes[:, None, None],
            asymmetry=float(np.linalg.norm(skew)) / norm if norm > 0 else 0.0,
            principal_values=values,
            principal_directions=directions,
            p=invariants["p"],
            q=invariants["q"],
            q_over_3=invariants["q_over_3"],
            q_over_trace=invariants["q_over_trace"],
            sin_phi=invariants["sin_phi"],
            b=invariants.get("b", float("nan")),
            invariants=invariants,
            dimension=d,
            wall_share=float(np.trace(wall_stress(network)) / np.trace(full))
            if np.trace(full) != 0 else float("nan"),
        )

    @property
    def tensor(self) -> np.ndarray:
        """(d, d) symmetric stress tensor [Pa], compression positive."""
        return self._get("tensor")

    @property
    def tensor_full(self) -> np.ndarray:
        """(d, d) contact-form stress (1/V) sum_c f^c (x) l^c, not symmetrised [Pa]."""
        return self._get("tensor_full")

    @property
    def tensor_internal_moments(self) -> np.ndarray:
        """(d, d) particle-form stress -(1/V) sum_i M^i, not symmetrised [Pa]."""
        return self._get("tensor_internal_moments")

    @property
    def particle_stresses(self) -> np.ndarray:
        """(N, d, d) per-particle stresses -M^i / v^i [Pa]."""
        return self._get("particle_stresses")

    @property
    def asymmetry(self) -> float:
        """|skew part| / |full tensor| (Frobenius) [-]; 0 for a zero tensor."""
        return self._get("asymmetry")

    @property
    def principal_values(self) -> np.ndarray:
        """(d,) principal stresses, descending (major first) [Pa]."""
        return self._get("principal_values")

    @property
    def principal_directions(self) -> np.ndarray:
        """(d, d) unit principal directions as columns, in the order of principal_values."""
        return self._get("principal_directions")

    @property
    def p(self) -> float:
        """Mean stress tr(sigma)/d [Pa] (seed 002 eq. 4)."""
        return self._get("p")

    @property
    def q(self) -> float:
        """Deviator sigma_1 - sigma_minor [Pa] (without the papers' 1/3)."""
        return self._get("q")

    @property
    def q_over_3(self) -> float:
        """(sigma_1 - sigma_minor)/3 [Pa], the q of seed 002 eq. 5 / seed 003 eq. 6."""
        return self._get("q_over_3")

    @property
    def q_over_trace(self) -> float:
        """Normalised shear stress q / tr(sigma) [-], the seeds' q/p: 3D (sigma_1 - sigma_3)/(3p),
        2D (sigma_1 - sigma_minor)/(2p)."""
        return self._get("q_over_trace")

    @property
    def sin_phi(self) -> float:
        """(sigma_1 - sigma_minor)/(sigma_1 + sigma_minor) [-] (seed 002 eq. 11 when
        sigma_2 = sigma_3)."""
        return self._get("sin_phi")

    @property
    def b(self) -> float:
        """Intermediate principal stress ratio (sigma_2 - sigma_3)/(sigma_1 - sigma_3) [-]
        (3D; NaN in 2D)."""
        return self._get("b")

    def descriptors(self) -> dict[str, float]:
        """Flat dict of scalars, named as in :mod:`grainlab.result.columns`: sigma_xx,
        sigma_yy, (sigma_zz,) sigma_xy, (sigma_xz, sigma_yz,) the invariants of
        :func:`grainlab.result.invariants.stress_invariants` (sigma_1, (sigma_2,) sigma_3, p,
        q, q_over_3, q_over_trace, sin_phi, stress_ratio, (b)), stress_asymmetry and
        wall_share_of_p (the wall contacts' share of tr(sigma), 0 without walls). Keys in
        parentheses exist in 3D only."""
        d = self._get("dimension")
        tensor = self.tensor
        out: dict[str, float] = {}
        for a in range(d):
            out[f"sigma_{_AXES[a]}{_AXES[a]}"] = float(tensor[a, a])
        for a in range(d):
            for b in range(a + 1, d):
                out[f"sigma_{_AXES[a]}{_AXES[b]}"] = float(tensor[a, b])
        out.update(self._get("invariants"))
        out["stress_asymmetry"] = self.asymmetry
        out["wall_share_of_p"] = self._get("wall_share")
        return out
