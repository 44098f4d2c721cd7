"""Fabric, branch and force tensors and their anisotropies, in the contact and branch frames.

The stress of a granular sample, sigma = (1/V) sum_c f^c (x) l^c (seed 002 eq. 3), is carried by
the orientations of the contacts, the lengths of the branch vectors and the forces. Following
seed 002 (Sec. III B and Appendix A) and seed 003 (eqs. 14–25, 31–36), each active contact is
described in a local frame and the angular averages of its components are condensed into
symmetric second-order tensors, whose anisotropies add up (to first order) to q/p.

Local frames (every vector is in the global frame; compression positive)
-------------------------------------------------------------------------
Contact frame (n, t), one entry per active contact point c (f_n > 0):

* n: the point's unit normal (from the first particle of the pair to the second);
* f_n = f . n > 0 [N]; the tangential force f - f_n n has magnitude f_t >= 0 [N] and t is the
  unit vector along it. Where f_t <= 1e-9 |f| (frictionless or unloaded in shear) t is the unit
  tangential part of the branch vector, l - (l . n) n, and where that vanishes too (spheres) any
  unit vector perpendicular to n. Those choices only fix l_t, whose tensor chi_lt they then
  leave invariant for spheres (l_t = 0) and make l_t t the full tangential branch vector
  otherwise;
* l_n = l . n, l_t = l . t [m], l the branch vector of the point's pair (the s component of l,
  along n x t, is dropped as in seed 002 eq. 16–19).

With ``frame_level="pairs"`` the contact frame has one entry per active pair (the polyhedra view
of seed 002, where a face-face contact is one contact): n is the normalised mean of the unit
normals of the pair's active points (the branch direction if they cancel), f the pair
resultant (all its points), and f_n, f_t, t, l_n, l_t as above.

Branch frame (n', t'), one entry per active pair (at least one point with f_n > 0):

* n' = l / |l|; F the pair resultant force; f_n' = F . n' (radial), f_t' = |F - f_n' n'|
  (orthoradial), t' along F - f_n' n' (any perpendicular if it vanishes); l_n' = |l|, l_t' = 0.

Tensors (seed 002 eq. A1, as discrete averages over the N_c entries of a frame)
--------------------------------------------------------------------------------
F = <n n>, chi_ln = <l_n n n>/<l_n>, chi_lt = <l_t sym(n t)>/<l_n>,
chi_fn = <f_n n n>/<f_n>, chi_ft = <f_t sym(n t)>/<f_n>, chi_l = chi_ln + chi_lt,
chi_f = chi_fn + chi_ft, with sym(n t) = (n t + t n)/2. By construction tr F = tr chi_ln =
tr chi_fn = tr chi_l = tr chi_f = 1 and tr chi_lt = tr chi_ft = 0; chi_lt' = 0.

Anisotropies (seed 002 eq. A2) in the principal frame of the stress
-------------------------------------------------------------------
Let e1 be the major (most compressive) principal direction of sym(sigma) and e_m the minor one
(e3 in 3D, e2 in 2D), delta(X) = X(e1, e1) - X(e_m, e_m) and k = 5/2 in 3D, 2 in 2D
(Rothenburg & Bathurst 1989: P(theta) = (1 + a_c cos 2 theta)/(2 pi)). Then

a_c = k delta(F)/tr F,            a_ln = k delta(chi_ln)/tr chi_ln - a_c,
a_lt = k delta(chi_l)/tr chi_l - a_c - a_ln,
a_fn = k delta(chi_fn)/tr chi_fn - a_c,  a_ft = k delta(chi_f)/tr chi_f - a_c - a_fn,

and the same in the branch frame (a'_c, a_ln', a_fn', a_ft'; a_lt' does not exist). A2 projects
every tensor on the stress axes instead of its own principal axes: this is the same under the
coaxiality A2 assumes, and under a general loading it keeps the decomposition additive
(:attr:`Fabric.misalignment_deg` says how far each tensor's own major axis is from e1). The
magnitude-only variant replaces k delta(X)/tr X by k c |dev X|/tr X, c = sqrt(3/2) in 3D and
sqrt(2) in 2D, equal to the former under axial symmetry (3D) or always (2D, when coaxial).

First-order shear strength (seed 002 eq. 27; seed 003 eq. 35): q/p = 2/5 (a_c + a_ln + a_lt +
a_fn + a_ft) = 2/5 (a'_c + a_ln' + a_fn' + a_ft') in 3D, with q = (sigma1 - sigma3)/3 and
p = tr sigma / 3; in 2D q/p = (sum)/2 with q = (sigma1 - sigma2)/2, p = (sigma1 + sigma2)/2.
Second order (seed 002 eq. B1, seed 003 eq. 36, 3D only) adds 4/105 (a_c a_fn + a_c a_ln +
a_ln a_fn) + 16/105 (a_c a_ft + a_c a_lt + a_ln a_ft + a_lt a_fn).

Note: with the A2 anisotropies, a_c + a_ln + a_lt + a_fn + a_ft = k [delta(chi_l) + delta(chi_f)]
- a_c exactly; for equal spheres (l = L n) chi_l = F and sigma / tr sigma = chi_f, so eqs. 27a
and 27b return the measured q/p exactly and B1 adds its cross terms on top of an exact value.
B1 is a statement about the harmonic parameters of eq. 26, not about A2 estimates.

Partial anisotropies by contact type gamma (branch frame; seed 002 eq. 30, seed 003 eq. 26):
the sums restricted to pairs of type gamma, normalised by the TOTAL count and means, so that
the partial tensors and anisotropies add up to the totals: a'_c,g = k delta(F'_g),
a_ln',g = k delta(chi_ln'_g) - a'_c,g, a_fn',g = k delta(chi_fn'_g) - a'_c,g,
a_ft',g = k delta(chi_ft'_g); q_g/p = 2/5 (a'_c,g + a_ln',g + a_fn',g + a_ft',g) (1/2 in 2D).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainlab.analysis.compute import Compute
from grainlab.analysis.contact_stress import stress_from_contact_dyads
from grainlab.errors import InputError

FRAME_LEVELS = ("points", "pairs")

#: Relative size below which a tangential force (or tangential branch part) counts as zero.
TANGENT_TOLERANCE = 1e-9

CONTACT_TENSORS = ("F", "chi_ln", "chi_lt", "chi_fn", "chi_ft", "chi_l", "chi_f")
BRANCH_TENSORS = ("F_branch", "chi_ln_branch", "chi_fn_branch", "chi_ft_branch", "chi_f_branch")
CONTACT_ANISOTROPIES = ("a_c", "a_ln", "a_lt", "a_fn", "a_ft")
BRANCH_ANISOTROPIES = ("a_c_branch", "a_ln_branch", "a_fn_branch", "a_ft_branch")


# -- local frames ----------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class FrameComponents:
    """Per-entry components of a local frame (contact frame or branch frame).

    Attributes (m entries, dimension d)
    -----------------------------------
    normals:
        (m, d) unit n (contact frame) or n' = l/|l| (branch frame).
    tangents:
        (m, d) unit t or t', perpendicular to the normal (see the module docstring).
    forces:
        (m, d) force vector f (point force, or pair resultant F) [N].
    branches:
        (m, d) branch vector l of the entry's pair [m].
    normal_forces, tangential_forces:
        (m,) f_n = f . n and f_t = |f - f_n n| >= 0 [N].
    normal_lengths, tangential_lengths:
        (m,) l_n = l . n and l_t = l . t [m].
    pairs:
        (m,) index of the entry's pair in the network.
    """

    normals: np.ndarray
    tangents: np.ndarray
    forces: np.ndarray
    branches: np.ndarray
    normal_forces: np.ndarray
    tangential_forces: np.ndarray
    normal_lengths: np.ndarray
    tangential_lengths: np.ndarray
    pairs: np.ndarray

    @property
    def size(self) -> int:
        """Number of entries m."""
        return int(self.normals.shape[0])

    @property
    def dimension(self) -> int:
        """2 or 3."""
        return int(self.normals.shape[1])


def _any_perpendicular(normals: np.ndarray) -> np.ndarray:
    """(m, d) unit vectors perpendicular to the unit vectors ``normals``."""
    if normals.shape[1] == 2:
        return np.column_stack([-normals[:, 1], normals[:, 0]])
    helper = np.zeros_like(normals)
    use_x = np.abs(normals[:, 0]) < 0.9
    helper[use_x, 0] = 1.0
    helper[~use_x, 1] = 1.0
    perp = helper - np.einsum("ci,ci->c", helper, normals)[:, None] * normals
    return perp / np.linalg.norm(perp, axis=1)[:, None]


def _unit_rows(vectors: np.ndarray, lengths: np.ndarray, small: np.ndarray) -> np.ndarray:
    """``vectors / lengths`` row by row, zero rows where ``small``."""
    out = np.zeros_like(vectors)
    keep = ~small
    out[keep] = vectors[keep] / lengths[keep, None]
    return out


def _frame(normals: np.ndarray, forces: np.ndarray, branches: np.ndarray,
           pairs: np.ndarray) -> FrameComponents:
    """Components of forces and branches in the frame (n, t) with t along the tangential force
    (else along the tangential branch part, else any perpendicular)."""
    f_n = np.einsum("ci,ci->c", forces, normals)
    f_tan = forces - f_n[:, None] * normals
    f_t = np.linalg.norm(f_tan, axis=1)
    no_force = f_t <= TANGENT_TOLERANCE * np.linalg.norm(forces, axis=1)
    tangents = _unit_rows(f_tan, f_t, no_force)
    f_t = np.where(no_force, 0.0, f_t)
    if np.any(no_force):
        idx = np.flatnonzero(no_force)
        l_sub = branches[idx]
        n_sub = normals[idx]
        l_tan = l_sub - np.einsum("ci,ci->c", l_sub, n_sub)[:, None] * n_sub
        l_t_len = np.linalg.norm(l_tan, axis=1)
        no_branch = l_t_len <= TANGENT_TOLERANCE * np.linalg.norm(l_sub, axis=1)
        t_sub = _unit_rows(l_tan, l_t_len, no_branch)
        if np.any(no_branch):
            t_sub[no_branch] = _any_perpendicular(n_sub[no_branch])
        tangents[idx] = t_sub
    return FrameComponents(
        normals=normals,
        tangents=tangents,
        forces=forces,
        branches=branches,
        normal_forces=f_n,
        tangential_forces=f_t,
        normal_lengths=np.einsum("ci,ci->c", branches, normals),
        tangential_lengths=np.einsum("ci,ci->c", branches, tangents),
        pairs=pairs,
    )


def contact_frame_components(network, level: str = "points") -> FrameComponents:
    """The contact frame (n, t) of the active contacts of ``network`` (a ContactNetwork).

    ``level="points"``: one entry per active contact point (f_n > 0). ``level="pairs"``: one
    entry per active pair, with n the normalised mean normal of its active points (the branch
    direction where those cancel) and f the pair resultant (seed 002's polyhedra view).

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0, 0], [2, 0]], volumes=[3.1, 3.1], volume=20.0,
    ...     pair_particles=[[0, 1]], pair_branches=[[2, 0]], point_pairs=[0],
    ...     point_positions=[[1, 0]], point_normals=[[1, 0]], point_forces=[[5, -1]])
    >>> frame = contact_frame_components(net)
    >>> frame.normal_forces, frame.tangential_forces, frame.tangents
    (array([5.]), array([1.]), array([[ 0., -1.]]))
    """
    if level not in FRAME_LEVELS:
        raise InputError("frame_level", level, f"one of {FRAME_LEVELS}")
    d = network.dimension
    if level == "points":
        active = np.flatnonzero(network.active_points())
        pairs = network.point_pairs[active]
        return _frame(network.point_normals[active], network.point_forces[active],
                      network.pair_branches[pairs], pairs)
    active_points = network.active_points()
    pairs = np.flatnonzero(network.active_pairs())
    normal_sum = np.zeros((network.n_pairs, d))
    for axis in range(d):
        normal_sum[:, axis] = np.bincount(
            network.point_pairs, network.point_normals[:, axis] * active_points,
            minlength=network.n_pairs)
    normal_sum = normal_sum[pairs]
    branches = network.pair_branches[pairs]
    length = np.linalg.norm(normal_sum, axis=1)
    cancelled = length <= 1e-12
    normals = _unit_rows(normal_sum, length, cancelled)
    if np.any(cancelled):
        normals[cancelled] = branches[cancelled] / np.linalg.norm(branches[cancelled],
                                                                 axis=1)[:, None]
    return _frame(normals, network.pair_forces[pairs], branches, pairs)


def branch_frame_components(network) -> FrameComponents:
    """The branch frame (n', t') of the active pairs of ``network``: n' = l/|l|, F the pair
    resultant, f_n' radial and f_t' orthoradial force, l_n' = |l|, l_t' = 0."""
    pairs = np.flatnonzero(network.active_pairs())
    branches = network.pair_branches[pairs]
    length = np.linalg.norm(branches, axis=1)
    if np.any(length <= 0):
        k = int(pairs[np.argmin(length)])
        raise InputError(f"pair_branches[{k}]", branches[np.argmin(length)].tolist(),
                         "a non-zero branch vector for an active pair")
    normals = branches / length[:, None]
    frame = _frame(normals, network.pair_forces[pairs], branches, pairs)
    # l is along n' exactly: remove rounding from l . n' and l . t'.
    return FrameComponents(
        normals=frame.normals, tangents=frame.tangents, forces=frame.forces,
        branches=frame.branches, normal_forces=frame.normal_forces,
        tangential_forces=frame.tangential_forces, normal_lengths=length,
        tangential_lengths=np.zeros_like(length), pairs=frame.pairs)


# -- tensors ---------------------------------------------------------------------------------
def _sym(a: np.ndarray) -> np.ndarray:
    return 0.5 * (a + a.T)


def frame_sums(frame: FrameComponents, mask: np.ndarray | None = None) -> dict:
    """Unnormalised sums over the entries (optionally those where ``mask``) of a frame.

    Returns scalars ``count``, ``l_n`` (sum of l_n), ``f_n`` (sum of f_n) and (d, d) arrays
    ``nn`` = sum n n, ``ln_nn`` = sum l_n n n, ``lt_nt`` = sum l_t sym(n t),
    ``fn_nn`` = sum f_n n n, ``ft_nt`` = sum f_t sym(n t) (matrix products: O(m d^2)).
    """
    n, t = frame.normals, frame.tangents
    l_n, l_t = frame.normal_lengths, frame.tangential_lengths
    f_n, f_t = frame.normal_forces, frame.tangential_forces
    if mask is not None:
        n, t, l_n, l_t, f_n, f_t = (a[mask] for a in (n, t, l_n, l_t, f_n, f_t))
    return {
        "count": float(n.shape[0]),
        "l_n": float(np.sum(l_n)),
        "f_n": float(np.sum(f_n)),
        "nn": n.T @ n,
        "ln_nn": n.T @ (l_n[:, None] * n),
        "lt_nt": _sym(n.T @ (l_t[:, None] * t)),
        "fn_nn": n.T @ (f_n[:, None] * n),
        "ft_nt": _sym(n.T @ (f_t[:, None] * t)),
    }


def _normalised(sums: dict, totals: dict, suffix: str = "",
                with_lt: bool = True) -> dict[str, np.ndarray]:
    """Tensors from ``sums`` divided by the count and means of ``totals`` (seed 002 eq. A1)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = {"F": sums["nn"] / totals["count"], "chi_ln": sums["ln_nn"] / totals["l_n"]}
        if with_lt:
            out["chi_lt"] = sums["lt_nt"] / totals["l_n"]
        out["chi_fn"] = sums["fn_nn"] / totals["f_n"]
        out["chi_ft"] = sums["ft_nt"] / totals["f_n"]
        if with_lt:
            out["chi_l"] = out["chi_ln"] + out["chi_lt"]
        out["chi_f"] = out["chi_fn"] + out["chi_ft"]
    return {name + suffix: value for name, value in out.items()}


def fabric_tensors(frame: FrameComponents, mask: np.ndarray | None = None,
                   totals: dict | None = None) -> dict[str, np.ndarray]:
    """Fabric and force tensors (d, d) of a frame (seed 002 eq. A1): F, chi_ln, chi_lt, chi_fn,
    chi_ft, chi_l, chi_f. With ``mask`` the sums run over those entries only, normalised by
    ``totals`` (a :func:`frame_sums` of the whole frame; by default the masked sums)."""
    sums = frame_sums(frame, mask)
    return _normalised(sums, sums if totals is None else totals)


# -- stress frame and anisotropies -----------------------------------------------------------
def principal_frame(tensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal values (descending: major = most compressive first) and directions (columns)
    of the symmetric part of ``tensor``. Each column has its largest component positive and the
    last column is flipped if needed so that the frame is right-handed."""
    values, vectors = np.linalg.eigh(_sym(np.asarray(tensor, dtype=float)))
    values, vectors = values[::-1], vectors[:, ::-1].copy()
    big = np.argmax(np.abs(vectors), axis=0)
    vectors *= np.sign(vectors[big, np.arange(vectors.shape[1])])
    if np.linalg.det(vectors) < 0:
        vectors[:, -1] *= -1.0
    return values, vectors


def harmonic_factor(dimension: int) -> float:
    """k of seed 002 eq. A2: 5/2 in 3D (spherical harmonics), 2 in 2D (Fourier series)."""
    return 2.5 if dimension == 3 else 2.0


def _safe_ratio(a: float, b: float) -> float:
    """a / b as a float, NaN where b = 0."""
    return float(a) / float(b) if b else float("nan")


def _delta(tensor: np.ndarray, e1: np.ndarray, e_minor: np.ndarray) -> float:
    return float(e1 @ tensor @ e1 - e_minor @ tensor @ e_minor)


def _ratio(tensor: np.ndarray, e1: np.ndarray, e_minor: np.ndarray, k: float) -> float:
    """k delta(X)/tr X (NaN where tr X = 0)."""
    trace = float(np.trace(tensor))
    if not trace:
        return float("nan")
    return k * _delta(tensor, e1, e_minor) / trace


def magnitude_ratio(tensor: np.ndarray, dimension: int) -> float:
    """k c |dev X| / tr X, c = sqrt(3/2) (3D) or sqrt(2) (2D): the coaxiality-free form of
    k (X1 - X_minor)/tr X, equal to it for an axisymmetric 3D or any 2D tensor."""
    x = _sym(np.asarray(tensor, dtype=float))
    trace = float(np.trace(x))
    if not trace:
        return float("nan")
    dev = x - trace / dimension * np.eye(dimension)
    c = np.sqrt(1.5) if dimension == 3 else np.sqrt(2.0)
    return harmonic_factor(dimension) * c * float(np.linalg.norm(dev)) / trace


def anisotropies_from_tensors(tensors: dict, e1: np.ndarray, e_minor: np.ndarray,
                              dimension: int, suffix: str = "") -> dict[str, float]:
    """Anisotropies of seed 002 eq. A2 projected on the stress axes e1 (major) and e_minor.

    ``tensors`` holds F, chi_ln, chi_fn, chi_f and (contact frame) chi_l, with names ending in
    ``suffix``; returns a_c, a_ln, a_fn, a_ft (and a_lt when chi_l is given) + suffix.

    >>> F = np.diag([0.4, 0.3, 0.3]); e = np.eye(3)
    >>> t = {"F": F, "chi_ln": F, "chi_l": F, "chi_fn": F, "chi_f": F}
    >>> round(anisotropies_from_tensors(t, e[0], e[2], 3)["a_c"], 12)
    0.25
    """
    k = harmonic_factor(dimension)
    g = {name[: len(name) - len(suffix)] if suffix else name: value
         for name, value in tensors.items() if name.endswith(suffix)}
    a_c = _ratio(g["F"], e1, e_minor, k)
    out = {"a_c": a_c, "a_ln": _ratio(g["chi_ln"], e1, e_minor, k) - a_c}
    if "chi_l" in g:
        out["a_lt"] = _ratio(g["chi_l"], e1, e_minor, k) - a_c - out["a_ln"]
    out["a_fn"] = _ratio(g["chi_fn"], e1, e_minor, k) - a_c
    out["a_ft"] = _ratio(g["chi_f"], e1, e_minor, k) - a_c - out["a_fn"]
    return {name + suffix: value for name, value in out.items()}


def magnitude_anisotropies(tensors: dict, dimension: int, suffix: str = "") -> dict[str, float]:
    """The magnitude-only variant of :func:`anisotropies_from_tensors` (keys end in ``_mag``):
    each k delta(X)/tr X is replaced by :func:`magnitude_ratio`."""
    g = {name[: len(name) - len(suffix)] if suffix else name: value
         for name, value in tensors.items() if name.endswith(suffix)}
    m = {name: magnitude_ratio(value, dimension) for name, value in g.items()
         if name in ("F", "chi_ln", "chi_l", "chi_fn", "chi_f")}
    out = {"a_c": m["F"], "a_ln": m["chi_ln"] - m["F"]}
    if "chi_l" in m:
        out["a_lt"] = m["chi_l"] - m["chi_ln"]
    out["a_fn"] = m["chi_fn"] - m["F"]
    out["a_ft"] = m["chi_f"] - m["chi_fn"]
    return {name + suffix + "_mag": value for name, value in out.items()}


def misalignment_deg(tensor: np.ndarray, e1: np.ndarray) -> float:
    """Angle [deg] in [0, 90] between the major principal direction of sym(tensor) and e1
    (NaN for a tensor that is not finite)."""
    if not np.all(np.isfinite(tensor)):
        return float("nan")
    _, vectors = np.linalg.eigh(_sym(np.asarray(tensor, dtype=float)))
    cos = min(1.0, abs(float(vectors[:, -1] @ e1)))
    return float(np.degrees(np.arccos(cos)))


def q_over_trace_first_order(anisotropies: list[float] | tuple[float, ...],
                             dimension: int) -> float:
    """Harmonic q/p to first order (seed 002 eq. 27): 2/5 sum a (3D), 1/2 sum a (2D).

    >>> q_over_trace_first_order([0.25, 0.0, 0.0, 0.25, 0.0], 3)
    0.2
    """
    return (0.4 if dimension == 3 else 0.5) * float(np.sum(anisotropies))


def q_over_trace_second_order(a_c: float, a_ln: float, a_lt: float, a_fn: float,
                              a_ft: float) -> float:
    """q/p of seed 002 eq. B1 (seed 003 eq. 36), 3D contact frame, with cross products.

    >>> round(q_over_trace_second_order(0.3, 0.0, 0.0, 0.4, 0.2), 6)  # 0.36 + 0.48/105 + 0.96/105
    0.373714
    """
    return (0.4 * (a_c + a_ln + a_lt + a_fn + a_ft)
            + 4.0 / 105.0 * (a_c * a_fn + a_c * a_ln + a_ln * a_fn)
            + 16.0 / 105.0 * (a_c * a_ft + a_c * a_lt + a_ln * a_ft + a_lt * a_fn))


# -- compute ---------------------------------------------------------------------------------
class Fabric(Compute):
    """Fabric and force anisotropies of a contact network in the contact and branch frames.

    Parameters
    ----------
    frame_level:
        ``"points"`` (default): the contact frame has one entry per active contact point.
        ``"pairs"``: one entry per active pair, built from the pair resultant force and the mean
        normal of the pair's active points (seed 002's view of face contacts between polyhedra).
        The branch frame always has one entry per active pair.

    After :meth:`compute` (see the module docstring for the definitions):

    * :attr:`stress` (d, d) symmetric stress [Pa]; :attr:`principal_stresses` (d,) descending;
      :attr:`stress_directions` (d, d), columns e1 (major, most compressive) ... e_minor;
      :attr:`q_over_trace` measured: (sigma1 - sigma_minor)/tr sigma, the seeds' q/p;
    * :attr:`tensors`: dict name -> (d, d) of ``F chi_ln chi_lt chi_fn chi_ft chi_l chi_f`` and
      ``F_branch chi_ln_branch chi_fn_branch chi_ft_branch chi_f_branch`` (dimensionless);
    * :attr:`anisotropies`: ``a_c a_ln a_lt a_fn a_ft`` and ``a_c_branch a_ln_branch
      a_fn_branch a_ft_branch`` (eq. A2 on the stress axes); :attr:`magnitude_anisotropies`
      the same keys + ``_mag``; :attr:`misalignment_deg` per tensor [deg];
    * :attr:`q_over_trace_harmonic`: ``contact_first_order`` (eq. 27a), ``branch_first_order``
      (27b), ``contact_second_order`` (B1; NaN in 2D);
    * :attr:`partial_anisotropies` (type name -> ``a_c_branch a_ln_branch a_fn_branch
      a_ft_branch pair_fraction``), :attr:`partial_q_over_trace_harmonic` (type -> eq. 30) and
      :attr:`partial_q_over_trace` (type -> measured delta(sigma_gamma)/tr sigma); empty dicts when
      the network has no ``pair_types``;
    * means over the active entries: :attr:`mean_normal_force` <f_n> [N],
      :attr:`mean_radial_force` <f_n'> [N], :attr:`mean_normal_length` <l_n> [m],
      :attr:`mean_branch_length` <|l|> [m]; :meth:`descriptors` flattens everything.

    Without any active contact the tensors and anisotropies are NaN. When the stress is
    isotropic (or nearly so) e1 is undefined and the projected anisotropies follow whatever
    direction the noise picks; the ``_mag`` variants do not depend on it.

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0, 0, 0], [0, 0, 2], [2, 0, 0]], volumes=[4.2] * 3, volume=60.0,
    ...     pair_particles=[[0, 1], [0, 2]], pair_branches=[[0, 0, 2], [2, 0, 0]],
    ...     point_pairs=[0, 1], point_positions=[[0, 0, 1], [1, 0, 0]],
    ...     point_normals=[[0, 0, 1], [1, 0, 0]], point_forces=[[0, 0, 3], [1, 0, 0]])
    >>> fab = Fabric().compute(net)
    >>> fab.stress_directions[:, 0]
    array([0., 0., 1.])
    >>> # F = diag(1/2, 0, 1/2), chi_fn = diag(1/4, 0, 3/4), e_minor = e_y:
    >>> fab.anisotropies["a_c"], round(fab.anisotropies["a_fn"], 12)
    (1.25, 0.625)
    >>> round(fab.q_over_trace, 12), round(fab.q_over_trace_harmonic["contact_first_order"], 12)
    (0.75, 0.75)
    """

    def __init__(self, frame_level: str = "points") -> None:
        super().__init__()
        if frame_level not in FRAME_LEVELS:
            raise InputError("frame_level", frame_level, f"one of {FRAME_LEVELS}")
        self.frame_level = frame_level

    def _compute(self, network) -> None:
        d = network.dimension
        stress = _sym(stress_from_contact_dyads(network.point_forces, network.point_branches,
                                                network.volume))
        values, directions = principal_frame(stress)
        e1, e_minor = directions[:, 0], directions[:, -1]
        trace = float(np.trace(stress))
        q_over_trace = _safe_ratio(values[0] - values[-1], trace)

        contact = contact_frame_components(network, self.frame_level)
        branch = branch_frame_components(network)
        contact_totals = frame_sums(contact)
        branch_totals = frame_sums(branch)
        tensors = _normalised(contact_totals, contact_totals)
        tensors.update(_normalised(branch_totals, branch_totals, "_branch", with_lt=False))

        anis = anisotropies_from_tensors(tensors, e1, e_minor, d)
        anis.update(anisotropies_from_tensors(tensors, e1, e_minor, d, suffix="_branch"))
        mags = magnitude_anisotropies({k: v for k, v in tensors.items()
                                       if not k.endswith("_branch")}, d)
        mags.update(magnitude_anisotropies(tensors, d, suffix="_branch"))
        misalign = {name: misalignment_deg(value, e1) for name, value in tensors.items()}

        first = {
            "contact_first_order": q_over_trace_first_order([anis[k] for k in CONTACT_ANISOTROPIES],
                                                        d),
            "branch_first_order": q_over_trace_first_order([anis[k] for k in BRANCH_ANISOTROPIES],
                                                       d),
            "contact_second_order": (q_over_trace_second_order(*(anis[k] for k in
                                                             CONTACT_ANISOTROPIES))
                                     if d == 3 else float("nan")),
        }

        partial, partial_harmonic, partial_measured = {}, {}, {}
        if network.pair_types is not None:
            k = harmonic_factor(d)
            branch_types = network.pair_types[branch.pairs]
            point_types = network.pair_types[network.point_pairs]
            for code, name in enumerate(network.type_names):
                sums = frame_sums(branch, branch_types == code)
                g = _normalised(sums, branch_totals, with_lt=False)
                a_c = k * _delta(g["F"], e1, e_minor)
                values_g = {
                    "a_c_branch": a_c,
                    "a_ln_branch": k * _delta(g["chi_ln"], e1, e_minor) - a_c,
                    "a_fn_branch": k * _delta(g["chi_fn"], e1, e_minor) - a_c,
                    "a_ft_branch": k * _delta(g["chi_ft"], e1, e_minor),
                }
                partial_harmonic[name] = q_over_trace_first_order(list(values_g.values()), d)
                values_g["pair_fraction"] = _safe_ratio(sums["count"], branch_totals["count"])
                partial[name] = values_g
                sel = point_types == code
                s_g = _sym(stress_from_contact_dyads(network.point_forces[sel],
                                                     network.point_branches[sel],
                                                     network.volume))
                partial_measured[name] = _safe_ratio(_delta(s_g, e1, e_minor), trace)

        means = {
            "mean_normal_force": _safe_ratio(contact_totals["f_n"], contact_totals["count"]),
            "mean_radial_force": _safe_ratio(branch_totals["f_n"], branch_totals["count"]),
            "mean_normal_length": _safe_ratio(contact_totals["l_n"], contact_totals["count"]),
            "mean_branch_length": _safe_ratio(branch_totals["l_n"], branch_totals["count"]),
        }
        self._store(
            stress=stress, principal_stresses=values, stress_directions=directions,
            q_over_trace=q_over_trace, tensors=tensors, anisotropies=anis,
            magnitude_anisotropies=mags, misalignment_deg=misalign, q_over_trace_harmonic=first,
            partial_anisotropies=partial, partial_q_over_trace_harmonic=partial_harmonic,
            partial_q_over_trace=partial_measured, contact_components=contact,
            branch_components=branch, n_contact_entries=contact.size,
            n_branch_entries=branch.size, **means,
        )

    # -- results -----------------------------------------------------------------------------
    @property
    def stress(self) -> np.ndarray:
        """(d, d) symmetric part of sigma = (1/V) sum f (x) l over all points [Pa]."""
        return self._get("stress")

    @property
    def principal_stresses(self) -> np.ndarray:
        """(d,) principal stresses [Pa], descending (sigma1 most compressive)."""
        return self._get("principal_stresses")

    @property
    def stress_directions(self) -> np.ndarray:
        """(d, d) principal stress directions as columns: e1 (major) first, e_minor last."""
        return self._get("stress_directions")

    @property
    def q_over_trace(self) -> float:
        """Measured q/p = (sigma1 - sigma_minor) / tr sigma (3D and 2D definitions agree)."""
        return self._get("q_over_trace")

    @property
    def tensors(self) -> dict[str, np.ndarray]:
        """Fabric and force tensors (d, d), contact frame and ``_branch`` frame (eq. A1)."""
        return self._get("tensors")

    @property
    def anisotropies(self) -> dict[str, float]:
        """a_c, a_ln, a_lt, a_fn, a_ft and a_c_branch, a_ln_branch, a_fn_branch, a_ft_branch."""
        return self._get("anisotropies")

    @property
    def magnitude_anisotropies(self) -> dict[str, float]:
        """The coaxiality-free variants (keys of :attr:`anisotropies` + ``_mag``)."""
        return self._get("magnitude_anisotropies")

    @property
    def misalignment_deg(self) -> dict[str, float]:
        """Angle [deg] between each tensor's major principal direction and e1."""
        return self._get("misalignment_deg")

    @property
    def q_over_trace_harmonic(self) -> dict[str, float]:
        """contact_first_order (eq. 27a), branch_first_order (27b), contact_second_order (B1)."""
        return self._get("q_over_trace_harmonic")

    @property
    def partial_anisotropies(self) -> dict[str, dict[str, float]]:
        """Per contact type: a_c_branch, a_ln_branch, a_fn_branch, a_ft_branch (summing to the
        totals over the types) and pair_fraction."""
        return self._get("partial_anisotropies")

    @property
    def partial_q_over_trace_harmonic(self) -> dict[str, float]:
        """Per contact type: 2/5 (a'_c + a_ln' + a_fn' + a_ft')_gamma (seed 002 eq. 30)."""
        return self._get("partial_q_over_trace_harmonic")

    @property
    def partial_q_over_trace(self) -> dict[str, float]:
        """Per contact type: measured delta(sigma_gamma)/tr sigma on the global stress axes
        (seed 002 eq. 29, seed 003 eq. 26); they add up to :attr:`q_over_trace`."""
        return self._get("partial_q_over_trace")

    @property
    def contact_components(self) -> FrameComponents:
        """The contact-frame entries used (see :func:`contact_frame_components`)."""
        return self._get("contact_components")

    @property
    def branch_components(self) -> FrameComponents:
        """The branch-frame entries used (see :func:`branch_frame_components`)."""
        return self._get("branch_components")

    @property
    def mean_normal_force(self) -> float:
        """<f_n> over the contact-frame entries [N]."""
        return self._get("mean_normal_force")

    @property
    def mean_radial_force(self) -> float:
        """<f_n'> over the active pairs [N]."""
        return self._get("mean_radial_force")

    @property
    def mean_normal_length(self) -> float:
        """<l_n> over the contact-frame entries [m]."""
        return self._get("mean_normal_length")

    @property
    def mean_branch_length(self) -> float:
        """<|l|> over the active pairs [m]."""
        return self._get("mean_branch_length")

    def descriptors(self) -> dict[str, float]:
        """All scalar results as one flat dict, for a results table.

        Keys: ``q_over_trace`` (measured, the seeds' q/p), ``q_over_trace_27a``,
        ``q_over_trace_27b``, ``q_over_trace_B1``, the anisotropies (``a_c`` ...
        ``a_ft_branch``) and their ``_mag`` variants,
        ``misalignment_<tensor>_deg``, the four means, ``n_contact_entries``,
        ``n_branch_entries`` and per contact type t: ``a_c_branch_t``, ``a_ln_branch_t``,
        ``a_fn_branch_t``, ``a_ft_branch_t``, ``pair_fraction_t``, ``q_over_trace_27b_t``,
        ``q_over_trace_t``.
        """
        harmonic = self.q_over_trace_harmonic
        out: dict[str, float] = {
            "q_over_trace": self.q_over_trace,
            "q_over_trace_27a": harmonic["contact_first_order"],
            "q_over_trace_27b": harmonic["branch_first_order"],
            "q_over_trace_B1": harmonic["contact_second_order"],
        }
        out.update(self.anisotropies)
        out.update(self.magnitude_anisotropies)
        out.update({f"misalignment_{k}_deg": v for k, v in self.misalignment_deg.items()})
        for name in ("mean_normal_force", "mean_radial_force", "mean_normal_length",
                     "mean_branch_length", "n_contact_entries", "n_branch_entries"):
            out[name] = self._get(name)
        for type_name, values in self.partial_anisotropies.items():
            out.update({f"{k}_{type_name}": v for k, v in values.items()})
            out[f"q_over_trace_27b_{type_name}"] = self.partial_q_over_trace_harmonic[type_name]
            out[f"q_over_trace_{type_name}"] = self.partial_q_over_trace[type_name]
        return {k: float(v) for k, v in out.items()}
