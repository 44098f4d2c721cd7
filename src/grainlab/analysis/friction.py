"""Friction mobilisation of a contact network (seed 002 §III.B before eq. 28; seed 003 §V.B,
eqs. 33–34, Figs. 19–20).

**Contact frame.** At an active contact point (f_n = f . n > 0) with tangential force
f_t = f - f_n n, Coulomb's law reads |f_t| <= mu f_n.

* The point is *sliding* when |f_t| >= (1 - tol) mu f_n, with a relative tolerance ``tol``
  (default 1e-3) for forces that sit on the Coulomb cone up to solver round-off; solver flags
  ``network.point_sliding``, when present, decide instead (``use_solver_flags=True``).
  S = (sliding active points) / (active points). With mu = 0 every active point is sliding.
* Mobilisation of a point: I_c = |f_t| / (mu f_n) in [0, 1]; mean index
  I_mu = <|f_t|> / <mu f_n> over the active points.
* S by contact type (seed 003 Fig. 20): ``sliding_proportion_by_type[g]`` = (sliding active
  points of pairs of type g) / (all active points), which partitions S
  (sum over g = S); ``sliding_fraction_within_type[g]`` = (sliding active points of type g) /
  (active points of type g).

**Branch frame.** For an active interaction with resultant F (sum of its point forces), branch
unit vector n' = l/|l| and mean point normal n_bar (the normalised mean of its points' normals):
f_n = F . n_bar (the pair's normal force), f_n' = F . n' (radial force) and
|f_t'| = |F - f_n' n'| (orthoradial force). If the pair obeys Coulomb's law with its normal
n_bar, |F|^2 = f_n'^2 + f_t'^2 <= (1 + mu^2) f_n^2, hence |f_t'| <= mu' f_n' with

    mu' = (f_n / f_n') sqrt((1 + mu^2) - (f_n' / f_n)^2)           (form "derived").

Seeds 002 (text before eq. 28) and 003 (eq. 33) print
mu' = (f_n'/f_n) sqrt((1 + mu^2) - (f_n/f_n')^2), i.e. the same expression with f_n and f_n'
exchanged (form "printed"). Both equal mu when n_bar is along the branch (f_n = f_n'), but only
the derived form follows from the argument above: for a frictionless contact whose normal makes
60 deg with the branch, the derived form gives mu' = sqrt(3) = |f_t'|/f_n' (on the cone, as it
must be), the printed one an imaginary value. The derived form is the default; the printed one
is available (``branch_form="printed"``) to reproduce the papers literally.

Pairs with f_n <= 0, f_n' <= 0 or a negative square-root argument (Coulomb violated at the pair
level, possible for multi-point pairs) are excluded from the branch-frame index and counted
(``n_pairs_excluded``). I' = <|f_t'|> / <mu' f_n'> over the remaining active pairs.
"""

from __future__ import annotations

import numpy as np

from grainlab.analysis.compute import Compute
from grainlab.errors import InputError

BRANCH_FORMS = ("derived", "printed")
_ROUND_OFF = 1e-9  # square-root arguments in [-1e-9, 0) are round-off of 0 (f_n' = f_n, mu = 0)


def branch_friction_coefficient(
    normal: np.ndarray, radial: np.ndarray, mu: float, form: str = "derived"
) -> tuple[np.ndarray, np.ndarray]:
    """Friction coefficient mu' of the branch frame (seed 002 §III.B; seed 003 eq. 33).

    Parameters
    ----------
    normal:
        (P,) normal forces f_n of the pairs [N].
    radial:
        (P,) radial forces f_n' [N].
    mu:
        Contact friction coefficient [-].
    form:
        ``"derived"``: (f_n/f_n') sqrt((1 + mu^2) - (f_n'/f_n)^2); ``"printed"``: the papers'
        (f_n'/f_n) sqrt((1 + mu^2) - (f_n/f_n')^2) (module docstring).

    Returns
    -------
    mu_prime, valid:
        (P,) mu' (NaN where not valid) and (P,) True where f_n > 0, f_n' > 0 and the
        square-root argument is >= 0 (arguments in [-1e-9, 0) are taken as round-off of 0).

    >>> branch_friction_coefficient(np.array([2.0, 1.0]), np.array([2.0, 0.5]), 0.0)[0]
    array([0.        , 1.73205081])
    """
    if form not in BRANCH_FORMS:
        raise InputError("branch_form", form, f"one of {BRANCH_FORMS}")
    normal = np.asarray(normal, dtype=float)
    radial = np.asarray(radial, dtype=float)
    positive = (normal > 0) & (radial > 0)
    safe_n = np.where(positive, normal, 1.0)
    safe_r = np.where(positive, radial, 1.0)
    if form == "derived":
        prefactor, inner = safe_n / safe_r, safe_r / safe_n
    else:
        prefactor, inner = safe_r / safe_n, safe_n / safe_r
    argument = (1.0 + mu * mu) - inner * inner
    valid = positive & (argument >= -_ROUND_OFF)
    argument = np.maximum(argument, 0.0)
    mu_prime = np.full(normal.shape, np.nan)
    mu_prime[valid] = prefactor[valid] * np.sqrt(argument[valid])
    return mu_prime, valid


def _ratio(numerator: float, denominator: float) -> float:
    return float(numerator / denominator) if denominator != 0 else float("nan")


def _sum_by_pair(network, values: np.ndarray) -> np.ndarray:
    """(P, d) sums over each pair's points of (C, d) values."""
    out = np.empty((network.n_pairs, values.shape[1]))
    for axis in range(values.shape[1]):
        out[:, axis] = np.bincount(network.point_pairs, values[:, axis],
                                   minlength=network.n_pairs)
    return out


class Friction(Compute):
    """Sliding proportion and friction mobilisation in the contact and branch frames
    (module docstring; seed 002 text before eq. 28, seed 003 eqs. 33–34 and Figs. 19–20).

    Parameters
    ----------
    tolerance:
        Relative tolerance tol of the sliding test |f_t| >= (1 - tol) mu f_n [-], in [0, 1);
        default 1e-3.
    use_solver_flags:
        If True (default) and the network carries ``point_sliding``, those flags decide which
        active points slide; otherwise the Coulomb test above does.
    branch_form:
        ``"derived"`` (default) or ``"printed"`` form of mu' (module docstring).

    Requires ``network.friction_coefficient``; raises :class:`~grainlab.errors.InputError`
    naming ``friction_coefficient`` when it is None.

    Properties after :meth:`compute`:

    * ``sliding`` (C,) bool, sliding active points; ``sliding_proportion`` S;
    * ``sliding_proportion_by_type`` and ``sliding_fraction_within_type`` ({type: value});
    * ``contact_mobilisation`` (C,) I_c = |f_t|/(mu f_n), NaN at inactive points or mu = 0;
    * ``mobilisation_index`` I_mu = <|f_t|>/<mu f_n> (contact frame);
    * ``branch_friction`` (P,) mu', ``pair_mobilisation`` (P,) |f_t'|/(mu' f_n'), NaN for
      inactive or excluded pairs; ``mean_branch_friction`` <mu'> (seed 003 eq. 33's mu_bar);
    * ``mobilisation_index_branch`` I' = <|f_t'|>/<mu' f_n'>; ``n_pairs_excluded``.

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], volumes=[3.0] * 3, volume=30.0,
    ...     pair_particles=[[0, 1], [0, 2]], pair_branches=[[2.0, 0.0], [0.0, 2.0]],
    ...     point_pairs=[0, 1], point_positions=[[1.0, 0.0], [0.0, 1.0]],
    ...     point_normals=[[1.0, 0.0], [0.0, 1.0]], point_forces=[[1.0, 0.5], [0.1, 1.0]],
    ...     friction_coefficient=0.5)
    >>> fr = Friction().compute(net)
    >>> fr.sliding.tolist(), fr.sliding_proportion, round(fr.mobilisation_index, 3)
    ([True, False], 0.5, 0.6)
    """

    def __init__(self, tolerance: float = 1e-3, use_solver_flags: bool = True,
                 branch_form: str = "derived") -> None:
        super().__init__()
        if not (0.0 <= tolerance < 1.0):
            raise InputError("tolerance", tolerance, "a relative tolerance in [0, 1)")
        if branch_form not in BRANCH_FORMS:
            raise InputError("branch_form", branch_form, f"one of {BRANCH_FORMS}")
        self.tolerance = float(tolerance)
        self.use_solver_flags = bool(use_solver_flags)
        self.branch_form = branch_form

    def _compute(self, network) -> None:
        mu = network.friction_coefficient
        if mu is None:
            raise InputError("friction_coefficient", None,
                             "the interparticle friction coefficient mu >= 0 on the network")
        mu = float(mu)
        # -- contact frame --------------------------------------------------------------------
        active = network.active_points()
        f_n = network.point_normal_forces
        f_t = np.linalg.norm(network.point_tangential_forces, axis=1)
        if self.use_solver_flags and network.point_sliding is not None:
            sliding = active & network.point_sliding
        else:
            sliding = active & (f_t >= (1.0 - self.tolerance) * mu * f_n)
        n_active = int(active.sum())
        mobilisation = np.full(network.n_points, np.nan)
        if mu > 0:
            mobilisation[active] = f_t[active] / (mu * f_n[active])
        by_type: dict[str, float] = {}
        within_type: dict[str, float] = {}
        if network.pair_types is not None:
            k = len(network.type_names)
            point_types = network.pair_types[network.point_pairs]
            n_sliding = np.bincount(point_types[sliding], minlength=k)
            n_type = np.bincount(point_types[active], minlength=k)
            for code, name in enumerate(network.type_names):
                by_type[name] = _ratio(n_sliding[code], n_active)
                within_type[name] = _ratio(n_sliding[code], n_type[code])
        # -- branch frame ---------------------------------------------------------------------
        active_pairs = network.active_pairs()
        forces = network.pair_forces
        normals = _sum_by_pair(network, network.point_normals)
        normal_length = np.linalg.norm(normals, axis=1)
        lengths = np.linalg.norm(network.pair_branches, axis=1)
        usable = active_pairs & (normal_length > 0) & (lengths > 0)
        normals = normals / np.where(usable, normal_length, 1.0)[:, None]
        branch_units = network.pair_branches / np.where(lengths > 0, lengths, 1.0)[:, None]
        pair_normal = np.einsum("pi,pi->p", forces, normals)
        radial = np.einsum("pi,pi->p", forces, branch_units)
        orthoradial = np.linalg.norm(forces - radial[:, None] * branch_units, axis=1)
        mu_prime, valid = branch_friction_coefficient(pair_normal, radial, mu, self.branch_form)
        valid &= usable
        mu_prime[~valid] = np.nan
        limit = mu_prime * np.where(valid, radial, np.nan)
        pair_mobilisation = np.full(network.n_pairs, np.nan)
        positive_limit = valid & (np.nan_to_num(limit) > 0)
        pair_mobilisation[positive_limit] = orthoradial[positive_limit] / limit[positive_limit]
        n_valid = int(valid.sum())
        self._store(
            sliding=sliding,
            sliding_proportion=_ratio(int(sliding.sum()), n_active),
            sliding_proportion_by_type=by_type,
            sliding_fraction_within_type=within_type,
            contact_mobilisation=mobilisation,
            mobilisation_index=_ratio(float(f_t[active].sum()), mu * float(f_n[active].sum())),
            branch_friction=mu_prime,
            pair_mobilisation=pair_mobilisation,
            mean_branch_friction=_ratio(float(mu_prime[valid].sum()), n_valid),
            mobilisation_index_branch=_ratio(float(orthoradial[valid].sum()),
                                             float(limit[valid].sum())),
            n_pairs_excluded=int(active_pairs.sum()) - n_valid,
        )

    @property
    def sliding(self) -> np.ndarray:
        """(C,) True at sliding active points."""
        return self._get("sliding")

    @property
    def sliding_proportion(self) -> float:
        """S = sliding active points / active points [-]."""
        return self._get("sliding_proportion")

    @property
    def sliding_proportion_by_type(self) -> dict[str, float]:
        """{type: sliding active points of the type / all active points}; sums to S."""
        return self._get("sliding_proportion_by_type")

    @property
    def sliding_fraction_within_type(self) -> dict[str, float]:
        """{type: sliding active points of the type / active points of the type}."""
        return self._get("sliding_fraction_within_type")

    @property
    def contact_mobilisation(self) -> np.ndarray:
        """(C,) I_c = |f_t| / (mu f_n) [-]; NaN at inactive points or when mu = 0."""
        return self._get("contact_mobilisation")

    @property
    def mobilisation_index(self) -> float:
        """I_mu = <|f_t|> / <mu f_n> over active points [-] (contact frame)."""
        return self._get("mobilisation_index")

    @property
    def branch_friction(self) -> np.ndarray:
        """(P,) mu' of each pair [-]; NaN for inactive or excluded pairs."""
        return self._get("branch_friction")

    @property
    def pair_mobilisation(self) -> np.ndarray:
        """(P,) I'_c = |f_t'| / (mu' f_n') [-]; NaN for inactive or excluded pairs."""
        return self._get("pair_mobilisation")

    @property
    def mean_branch_friction(self) -> float:
        """<mu'> over the included active pairs [-] (seed 003 eq. 33's mu_bar)."""
        return self._get("mean_branch_friction")

    @property
    def mobilisation_index_branch(self) -> float:
        """I' = <|f_t'|> / <mu' f_n'> over the included active pairs [-] (branch frame)."""
        return self._get("mobilisation_index_branch")

    @property
    def n_pairs_excluded(self) -> int:
        """Active pairs left out of the branch-frame index (f_n <= 0, f_n' <= 0, or a negative
        square-root argument)."""
        return self._get("n_pairs_excluded")

    def descriptors(self) -> dict[str, float]:
        """Flat dict: sliding_proportion, mobilisation_index, mobilisation_index_branch,
        mean_branch_friction, n_pairs_excluded_branch and sliding_proportion_<type>."""
        out = {
            "sliding_proportion": self.sliding_proportion,
            "mobilisation_index": self.mobilisation_index,
            "mobilisation_index_branch": self.mobilisation_index_branch,
            "mean_branch_friction": self.mean_branch_friction,
            "n_pairs_excluded_branch": float(self.n_pairs_excluded),
        }
        out.update({f"sliding_proportion_{name}": value
                    for name, value in self.sliding_proportion_by_type.items()})
        return out
