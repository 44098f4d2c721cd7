"""Seed 001's micromechanical model: contact -> micro-element -> representative unit.

Notation (seed 001 ch. 2, Table 2.1; compression positive, SI units; E micro-elements with up
to M contacts in d dimensions):

* contact m of micro-element n: branch vector L (centre to neighbour), normal n = L/|L|,
  stiffness K = k_n n n + k_r (I - n n) (eq. 2.5), force f the centre exerts on the neighbour;
* strain of a micro-element: the asymmetric eps^n (eq. 2.9), whose skew part is the spin of the
  particles relative to the micro-element; spring approach d_delta = eps^n L + d_delta*
  (eqs. 2.12–2.13) with the non-affine move of the centre particle
  d_delta* = T eps^n, T = -[sum_m K]^-1 [sum_m K L] (eq. 2.14; Table 2.1 prints it without the
  minus and subtracts it in eq. 2.15 — the same thing: the centre moves to balance its contact
  forces, which softens the micro-element). Micro-elements of one contact (binary units) and
  ``non_affine=False`` use the uniform strain (T = 0);
* micro-element stress sigma^n = (1/(2 V^n)) sum_m f (x) L (eq. 2.16; each contact belongs to
  two micro-elements), stiffness C^n (eq. 2.18) as a (d^2 x d^2) matrix on the full tensors;
* particle spin (the skew part of the strain, eq. 2.9): with ``spin="none"`` (default) the
  particles turn with the micro-element (no skew strain; the strain is the symmetric Cauchy
  strain of eq. 2.10) and the skew part of the stress, a measure of moment imbalance, is only
  reported. ``spin="micro-element"`` lets each micro-element's particles take the one rotation
  that makes its stress increment symmetric (no couple stress, §2.4.1), condensed into a
  symmetric Voigt stiffness C^n per micro-element; this holds for the linearised increment
  (sliding contacts can leave a moment imbalance, reported). ``spin="uniform"`` gives every
  micro-element the same spin, from the overall skew stress (needs the homogeneous
  distribution). A binary unit must not use "micro-element": its single contact would lose all
  shear stiffness to a free spin (nu = 1/4 instead of eq. 4.1);
* representative unit (eqs. 2.20–2.35): C_bar = sum (V^n/V) C^n; the distributive law of
  strain G^n, homogeneous (eq. 2.30: every micro-element takes the overall strain) or
  Maxwellian in stiffness space (eqs. 2.32–2.35: v^n = C_bar^-1 (C^n - C_bar),
  G^n = A Exp(-v^n) V^n/V, A^-1 = sum (V^n/V) Exp(-v^n), the exponential summed as a series to
  a stated order with a convergence check) or that series cut after its first-order term
  with C_bar (G^n = (V^n/V)(2I - C_bar^-1 C^n), :mod:`first_order_law`); overall tangent
  C = sum_n C^n G^n (eq. 2.31) and
  local strains eps^n = (V/V^n) G^n eps (eq. 2.27, G acting on strain fractions).

After every increment the structure is updated: contact forces, sliding, separation and bonds;
branch vectors (L shortens by the symmetric strain and the centre's move) and volumes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from grainlab.contact.spring_contact import SpringContactLaw, SpringState, force_vectors
from grainlab.errors import ConvergenceError, InputError, StrengthReached
from grainlab.micromech.micro_element.distribution_kernels import (
    exponential_series_batch,
    maxwellian_tensors,
    relative_stiffness,
)
from grainlab.micromech.micro_element.first_order_law import (
    first_order_tensors,
    strain_share_eigenvalues,
)
from grainlab.micromech.micro_element.from_snapshot import spring_state_from_forces
from grainlab.micromech.micro_element.kernels import (
    condense_local_stiffness,
    contact_census,
    dyad_sum,
    move_structure,
    stretch,
    unit_vectors,
)
from grainlab.micromech.micro_element.structure import MicroElementStructure
from grainlab.micromech.micro_element.tensor_basis import bases

DISTRIBUTIONS = ("homogeneous", "maxwellian", "maxwellian-first-order")
"""Distributive laws of strain: eq. 2.30; eqs. 2.32–2.35 (the series summed to convergence);
eqs. 2.32–2.35 with C_bar and the series cut after its first-order term (Table 2.1)."""
MAXWELLIAN_REFERENCES = ("overall", "average")
"""Stiffness whose inverse scales the heterogeneity v^n of eq. 2.32: the overall tangent C
(as printed; self-consistent, iterated) or the volume average C_bar of eq. 2.24."""


def exponential_series(v: np.ndarray, order: int, norm: float | None = None
                       ) -> tuple[np.ndarray, float]:
    """Exp(-v) = I - v + v^2/2! - ... (seed 001 eq. 2.35) for a batch of square matrices
    (..., k, k), summed to ``order`` on v / 2^s and squared back s times (scaling and squaring,
    s chosen so that |v| / 2^s <= 1/2, which keeps the alternating series free of
    cancellation); returns the result and the relative size of the last series term (largest
    |entry| of the last term over the largest |entry| of the sum, over the batch: the
    convergence check). ``norm``: the largest absolute row sum of the batch, when known.
    Compiled:
    :func:`~grainlab.micromech.micro_element.distribution_kernels.exponential_series_batch`."""
    v = np.asarray(v, dtype=float)
    k = v.shape[-1]
    if norm is None:
        norm = float(np.max(np.abs(v).sum(axis=-1))) if v.size else 0.0
    squarings = max(0, int(np.ceil(np.log2(norm))) + 1) if norm > 0.5 else 0
    total, term_max, total_max = exponential_series_batch(v.reshape(-1, k, k), order,
                                                          squarings)
    last = term_max / max(total_max, 1e-300) if order >= 1 else 0.0
    return total.reshape(v.shape), last


@dataclass
class MicroElementState:
    """Mutable state of the model (arrays over micro-elements and contacts)."""

    contacts: SpringState
    branches: np.ndarray
    volumes: np.ndarray
    mask: np.ndarray
    strain: np.ndarray  # cumulative overall Voigt strain since the model was built
    residual_stress: np.ndarray  # Voigt stress of the last increment's residual forces
    overall_stiffness: np.ndarray | None = None  # last self-consistent C (warm start) [Pa]


DIVERGED_RESIDUAL = 1e3
"""Stress residual, relative to the target, beyond which :meth:`MicroElementModel.solve_stress`
reports divergence instead of iterating on [-]."""
SELF_CONSISTENT_RELAXATION = 0.5
"""Mixing factor beta of the Anderson-accelerated fixed point on the overall C [-]."""
SELF_CONSISTENT_HISTORY = 6
"""Number of past iterates the Anderson mixing combines [-]."""
SELF_CONSISTENT_TOLERANCE = 1e-9
"""|C(G(C)) - C|, relative to |C_bar|, that ends the fixed-point iteration [-]."""
SELF_CONSISTENT_MAX_ITERATIONS = 300
SELF_CONSISTENT_COLLAPSE = 1e-6
"""Smallest eigenvalue of an iterate, relative to |C_bar|, below which the unit has lost its
stiffness in some direction [-]."""


class MicroElementModel:
    """The representative unit of seed 001 as a lab specimen.

    Parameters
    ----------
    structure:
        The micro-elements.
    law:
        The contact law (constant or Hertz–Mindlin springs, Coulomb, separation, bonds).
    distribution:
        ``"homogeneous"`` (eq. 2.30), ``"maxwellian"`` (eqs. 2.32–2.35) or
        ``"maxwellian-first-order"``: Table 2.1's H^n = f(C^n, C_bar) with the series of
        eq. 2.35 cut after its first-order term, G^n = (V^n/V)(2I - C_bar^-1 C^n)
        (:func:`~grainlab.micromech.micro_element.first_order_law.first_order_tensors`;
        ``maxwellian_reference`` and the series options do not apply).
    non_affine:
        Include the centre particle's equilibrium move (eq. 2.14).
    series_order:
        Terms of the Exp series (eq. 2.35); the last term's relative size is checked.
    series_tolerance:
        Largest relative size of the last series term before a :class:`ConvergenceError`.
    spin:
        Particle spin balanced per ``"micro-element"`` or ``"uniform"`` (module docstring).
    update_geometry:
        Update branch vectors and volumes after every increment (large strain); ``False``
        keeps the initial geometry (small-strain theory).
    maxwellian_reference:
        ``"overall"`` (default, eq. 2.32 as printed): v^n = C^-1 (C^n - C_bar) with the
        overall tangent C = sum C^n G^n (eq. 2.31), which itself depends on v^n; solved as a
        fixed point (:meth:`_self_consistent`). ``"average"``: C_bar in place of C (explicit).
    """

    def __init__(
        self,
        structure: MicroElementStructure,
        law: SpringContactLaw,
        distribution: str = "homogeneous",
        non_affine: bool = True,
        series_order: int = 16,
        series_tolerance: float = 1e-12,
        spin: str = "none",
        update_geometry: bool = True,
        maxwellian_reference: str = "overall",
    ) -> None:
        if distribution not in DISTRIBUTIONS:
            raise InputError("distribution", distribution, " or ".join(DISTRIBUTIONS))
        if spin not in ("none", "micro-element", "uniform"):
            raise InputError("spin", spin, "'none', 'micro-element' or 'uniform'")
        if spin == "uniform" and distribution != "homogeneous":
            raise InputError("spin", spin, "'micro-element' with the Maxwellian distribution "
                             "(a uniform spin needs the homogeneous distribution)")
        if maxwellian_reference not in MAXWELLIAN_REFERENCES:
            raise InputError("maxwellian_reference", maxwellian_reference,
                             " or ".join(MAXWELLIAN_REFERENCES))
        self.maxwellian_reference = maxwellian_reference
        self.spin = spin
        self.update_geometry = bool(update_geometry)
        if not (1 <= int(series_order) <= 40):
            raise InputError("series_order", series_order, "an integer in [1, 40]")
        self.structure = structure
        self.law = law
        self.distribution = distribution
        self.non_affine = bool(non_affine)
        self.series_order = int(series_order)
        self.series_tolerance = float(series_tolerance)
        self.dimension = structure.dimension
        shape = structure.mask.shape
        radius = 2 * structure.centre_radii[:, None] * structure.neighbour_radii / (
            structure.centre_radii[:, None] + structure.neighbour_radii)
        self.contact_radius = radius  # equivalent radius 2 r1 r2/(r1 + r2) of eq. 2.6
        self.state = MicroElementState(
            contacts=law.initial_state(shape, self.dimension),
            branches=np.array(structure.branches),
            volumes=np.array(structure.volumes),
            mask=np.array(structure.mask),
            strain=np.zeros(6 if self.dimension == 3 else 3),
            residual_stress=np.zeros(6 if self.dimension == 3 else 3),
        )
        if structure.initial_forces is not None:  # a simulated packing, with its forces
            self.state.contacts = spring_state_from_forces(
                law, structure.initial_forces, self.state.branches, self.state.mask, radius)
        self.force_floor = 0.0
        self._cache: dict[str, Any] | None = None
        self._derived: dict[str, np.ndarray] = {}

    def _invalidate(self) -> None:
        """Forget everything derived from the state (after the state changed)."""
        self._cache = None
        self._derived = {}

    # -- geometry -----------------------------------------------------------------------------
    @property
    def normals(self) -> np.ndarray:
        """(E, M, d) current unit contact normals (zero on padding)."""
        if "normals" not in self._derived:
            self._derived["normals"] = unit_vectors(self.state.branches)[0]
        return self._derived["normals"]

    @property
    def volume(self) -> float:
        """V = sum V^n [m^3]."""
        return float(self.state.volumes.sum())

    # -- the constitutive chain ---------------------------------------------------------------
    def _local(self) -> dict[str, Any]:
        """Contact stiffness, non-affine T (the stretch maps P = delta L + T), local stiffness
        and condensation."""
        if self._cache is not None:
            return self._cache
        d = self.dimension
        st = self.state
        c = st.contacts
        shear_mag = unit_vectors(c.shear_force)[1]
        kn, kr = self.law.stiffness(c.normal_force, shear_mag, self.contact_radius,
                                    self.force_floor, touching=c.normal_approach >= 0.0)
        # Compiled per micro-element (kernels.py): T, C^n on full tensors, the blocks
        # [S' ; W'] C [S W] and, with spin="micro-element", spin = -C_ww^+ C_ws and
        # C^n = C_ss + C_sw spin (otherwise C^n = C_ss and spin = 0).
        t, blocks, spin, c_local = condense_local_stiffness(
            st.branches, st.mask, kn, kr, st.volumes, self.non_affine, self.spin)
        n_s = bases(d)[0].shape[1]
        if self.spin == "uniform":  # one spin for all, from the volume-averaged stiffness
            c_sw, c_ws = blocks[:, :n_s, n_s:], blocks[:, n_s:, :n_s]
            c_ww = blocks[:, n_s:, n_s:]
            weights = st.volumes / st.volumes.sum()
            spin_all = -np.linalg.pinv(np.einsum("e,eab->ab", weights, c_ww), rcond=1e-12) @ (
                np.einsum("e,eab->ab", weights, c_ws))
            spin = np.broadcast_to(spin_all, c_ws.shape).copy()
            c_local = blocks[:, :n_s, :n_s] + c_sw @ spin
        self._cache = {"t": t, "spin": spin, "c_local": c_local}
        return self._cache

    def _distribution(self) -> dict[str, Any]:
        """Distribution tensors G^n (E, k, k) and the overall tangent."""
        local = self._local()
        if "g" in local:
            return local
        c_local = local["c_local"]
        weights = self.state.volumes / self.volume
        c_bar = np.tensordot(weights, c_local, axes=1)
        k = c_bar.shape[0]
        if self.distribution == "homogeneous":
            g = weights[:, None, None] * np.eye(k)[None]
            tangent, last = c_bar, 0.0
        elif self.distribution == "maxwellian-first-order":
            g, tangent = first_order_tensors(c_local, c_bar, weights)
            last = 0.0
        elif self.maxwellian_reference == "average":
            g, tangent, last = self._maxwellian(c_local, c_bar, c_bar, weights, shift=False)
        else:
            if "failure" in local:
                raise StrengthReached(local["failure"])
            try:
                g, tangent, last, iterations = self._self_consistent(c_local, c_bar, weights)
            except StrengthReached as lost:
                local["failure"] = str(lost)
                raise
            local.update(reference_iterations=iterations)
        local.update(g=g, tangent=0.5 * (tangent + tangent.T), c_bar=c_bar,
                     series_last_term=last, tangent_raw=tangent)
        return local

    def _maxwellian(self, c_local: np.ndarray, c_bar: np.ndarray, reference: np.ndarray,
                    weights: np.ndarray, shift: bool) -> tuple[np.ndarray, np.ndarray, float]:
        """G^n = A Exp(-v^n) V^n/V with v^n = reference^-1 (C^n - C_bar) (eqs. 2.32–2.35),
        the overall tangent sum_n C^n G^n (eq. 2.31) [Pa] and the last series term.

        ``shift`` subtracts the smallest real eigenvalue s over all v^n before the series:
        Exp(-(v - s I)) = e^s Exp(-v), a common scalar that A cancels exactly, so that strongly
        heterogeneous units (a reference much softer than C_bar) cannot overflow."""
        v, norm = relative_stiffness(c_local, c_bar, np.linalg.pinv(reference, rcond=1e-12))
        if shift:
            v = v - float(np.min(np.linalg.eigvals(v).real)) * np.eye(v.shape[-1])
            norm = float(np.abs(v).sum(axis=-1).max(initial=0.0))
        exp_v, last = exponential_series(v, self.series_order, norm=norm)
        if last > self.series_tolerance:
            raise ConvergenceError(
                f"The Maxwellian distribution series (eq. 2.35) has not converged at order "
                f"{self.series_order}: last term {last:.2e} of the sum (allowed "
                f"{self.series_tolerance:g}). Raise series_order or use the homogeneous law."
            )
        a = np.linalg.pinv(np.tensordot(weights, exp_v, axes=1), rcond=1e-12)
        g, tangent = maxwellian_tensors(a, exp_v, weights, c_local)  # eqs. 2.34, 2.31
        return g, tangent, last

    def _self_consistent(self, c_local: np.ndarray, c_bar: np.ndarray, weights: np.ndarray,
                         ) -> tuple[np.ndarray, np.ndarray, float, int]:
        """Eqs. 2.31–2.35 with the overall C in v^n (eq. 2.32 as printed): the fixed point
        C = sum_n C^n G^n(C). Returns G, the overall tangent, the last series term and the
        iterations; raises :class:`StrengthReached` when the unit has no self-consistent C.

        The iteration starts from the C of the previous increment (continuation along the
        load path; C_bar the first time, and again if the warm start fails) and is
        Anderson-accelerated (mixing ``SELF_CONSISTENT_RELAXATION`` over the last
        ``SELF_CONSISTENT_HISTORY`` iterates; a mixed iterate that is not positive definite
        is replaced by the plain damped step) until |C(G(C)) - C| <=
        ``SELF_CONSISTENT_TOLERANCE`` |C_bar|. A softer C concentrates the strain more on
        soft micro-elements, which softens C further: as micro-elements lose their stiffness
        the branch of solutions followed from the isotropic state ends (the fixed point
        disappears, the iteration drifts towards C = 0). That is the unit's failure: it is
        reported when the iteration ends on a C that is not positive definite or does not
        converge in ``SELF_CONSISTENT_MAX_ITERATIONS``. Solving the fixed point only
        approximately (the previous version returned the last iterate) made the failure
        point depend on the step size; solved tightly it converges with the step."""
        starts = [c_bar]
        if self.state.overall_stiffness is not None:
            starts.insert(0, self.state.overall_stiffness)
        reason = ""
        for start in starts:
            solution, reason = self._fixed_point(c_local, c_bar, weights, start)
            if solution is not None:
                g, tangent, last, iterations = solution
                self.state.overall_stiffness = 0.5 * (tangent + tangent.T)
                return g, tangent, last, iterations
        raise StrengthReached(
            "the self-consistent overall stiffness of eqs. 2.31-2.32 (Maxwellian law with the "
            f"overall C) has no solution: {reason} (the unit has failed)")

    def _fixed_point(self, c_local: np.ndarray, c_bar: np.ndarray, weights: np.ndarray,
                     start: np.ndarray) -> tuple[tuple | None, str]:
        """Anderson-accelerated C = sum C^n G^n(C) from ``start`` (see
        :meth:`_self_consistent`); ((G, tangent, last term, iterations), "") or (None, why)."""
        k = c_bar.shape[0]
        upper = np.triu_indices(k)
        scale = float(np.linalg.norm(c_bar))
        beta = SELF_CONSISTENT_RELAXATION

        def matrix(x: np.ndarray) -> np.ndarray:
            m = np.zeros((k, k))
            m[upper] = x
            return m + np.triu(m, 1).T

        x = np.array(start)[upper]
        past_x: list[np.ndarray] = []
        past_r: list[np.ndarray] = []
        for iteration in range(1, SELF_CONSISTENT_MAX_ITERATIONS + 1):
            g, tangent, last = self._maxwellian(c_local, c_bar, matrix(x), weights,
                                                shift=True)
            image = 0.5 * (tangent + tangent.T)
            lowest = float(np.linalg.eigvalsh(image)[0])
            if lowest <= SELF_CONSISTENT_COLLAPSE * scale:
                return None, (f"the iterate lost its positive definiteness (smallest eigenvalue "
                              f"{lowest:.3g} Pa, |C_bar| {scale:.3g} Pa)")
            residual = image[upper] - x
            if np.linalg.norm(residual) <= SELF_CONSISTENT_TOLERANCE * scale:
                return (g, tangent, last, iteration), ""
            past_x = [*past_x, x][-SELF_CONSISTENT_HISTORY:]
            past_r = [*past_r, residual][-SELF_CONSISTENT_HISTORY:]
            step = x + beta * residual
            if len(past_r) > 1:
                d_r = np.diff(np.array(past_r), axis=0).T
                d_x = np.diff(np.array(past_x), axis=0).T
                gamma = np.linalg.lstsq(d_r, residual, rcond=None)[0]
                mixed = step - (d_x + beta * d_r) @ gamma
                if np.linalg.eigvalsh(matrix(mixed))[0] > SELF_CONSISTENT_COLLAPSE * scale:
                    step = mixed
                else:
                    past_x, past_r = [], []
            x = step
        return None, (f"no fixed point within {SELF_CONSISTENT_MAX_ITERATIONS} iterations "
                      f"(last change {np.linalg.norm(residual) / scale:.3g} of |C_bar|)")

    def distribution_tensors(self) -> np.ndarray:
        """(E, k, k) distribution tensors G^n of eq. 2.27 (they sum to the identity, eq. 2.28)."""
        return self._distribution()["g"]

    def local_stiffness(self) -> np.ndarray:
        """(E, k, k) condensed micro-element stiffness C^n (Voigt, engineering shears) [Pa]."""
        return self._local()["c_local"]

    # -- specimen protocol --------------------------------------------------------------------
    def tangent(self) -> np.ndarray:
        """Overall Voigt tangent C = sum C^n G^n (eq. 2.31) [Pa] (symmetrised; the raw one is
        symmetric for the homogeneous law)."""
        return self._distribution()["tangent"]

    def stress(self) -> np.ndarray:
        """Overall Voigt stress (1/V) sum_n V^n sigma^n = (1/2V) sum f (x) L [Pa]."""
        return self._voigt(self.stress_tensor())

    def stress_tensor(self) -> np.ndarray:
        """Overall (d, d) stress tensor including any skew part [Pa]."""
        if "stress" not in self._derived:
            st = self.state
            self._derived["stress"] = dyad_sum(
                st.contacts.normal_force, self.normals, st.contacts.shear_force, st.branches,
                st.mask) / (2.0 * self.volume)
        return self._derived["stress"].copy()

    def micro_element_stresses(self) -> np.ndarray:
        """(E, d, d) stress of each micro-element (eq. 2.16) [Pa]."""
        f = force_vectors(self.state.contacts, self.normals)
        f = np.where(self.state.mask[..., None], f, 0.0)
        return np.einsum("emi,emj->eij", f, self.state.branches) / (
            2.0 * self.state.volumes)[:, None, None]

    def strain(self) -> np.ndarray:
        """Cumulative overall Voigt strain [-] since the model was built."""
        return self.state.strain.copy()

    def _voigt(self, tensor: np.ndarray) -> np.ndarray:
        _, _, s_dual, _ = bases(self.dimension)
        return s_dual @ np.asarray(tensor).reshape(-1)

    def apply_strain(self, strain_increment: np.ndarray) -> None:
        """Distribute an overall Voigt strain increment to the micro-elements (eq. 2.27),
        move their contacts (eqs. 2.13–2.15) and update forces and structure."""
        d_eps = np.asarray(strain_increment, dtype=float)
        info = self._distribution()
        st = self.state
        weights = st.volumes / self.volume
        s, w, _, _ = bases(self.dimension)
        # Compiled per micro-element (kernels.py): eps^n = G^n eps / (V^n/V), the spin, the
        # approaches P (S eps^n + W spin) and the branch translations (approach minus the
        # spin part), and the volumetric strain trace(S eps^n).
        approach, translation, volumetric = stretch(
            info["g"], d_eps, weights, info["spin"], s, w, st.branches, st.mask, info["t"],
            self.spin != "none")
        new_contacts, residual = self.law.update(
            st.contacts, approach, self.normals, self.contact_radius, st.mask, self.force_floor)
        # Geometry: branches shorten by the symmetric strain and the centre's move (approach
        # minus the spin part); volumes shrink by the volumetric strain (compression +).
        if self.update_geometry:
            st.branches, st.volumes = move_structure(st.branches, st.mask, translation,
                                                     st.volumes, volumetric)
        st.contacts = new_contacts
        st.strain = st.strain + d_eps
        st.residual_stress = self._voigt(dyad_sum(None, None, residual, st.branches, st.mask)
                                         / (2.0 * self.volume))
        self._invalidate()

    def descriptors(self) -> dict[str, Any]:
        """Counts of sliding, open and bonded contacts, coordination, mobilisation, D."""
        st = self.state
        c = st.contacts
        n_contacts, n_sliding, n_open, n_bonded, n_closed, mobilisation = contact_census(
            st.mask, c.normal_force, c.shear_force, c.sliding, c.bonded,
            self.law.friction_coefficient)
        try:
            info = self._distribution()
            lowest = float(np.linalg.eigvalsh(info["tangent"])[0])
        except StrengthReached:  # the failed state of a test: no tangent to describe
            info, lowest = {"series_last_term": math.nan}, math.nan
        return {
            "n_sliding": int(n_sliding),
            "n_open": int(n_open),
            "n_bonded": int(n_bonded),
            "sliding_fraction": float(n_sliding / max(n_contacts, 1)),
            "mean_mobilisation": (float(mobilisation / n_closed) if n_closed else math.nan)
            if n_contacts else 0.0,
            "coordination_number": float(n_closed / st.volumes.size),
            "void_ratio": self.volume / self.structure.solid_volume() - 1.0,
            "min_eigenvalue_tangent": lowest,
            "series_last_term": float(info["series_last_term"]),
            "self_consistent_iterations": int(info.get("reference_iterations", 0)),
            "stress_asymmetry": self._asymmetry(),
            **self._strain_share(info),
        }

    def _strain_share(self, info: dict[str, Any]) -> dict[str, float]:
        """For the first-order law, whose G^n need not be positive definite: the lowest
        eigenvalue of (V/V^n) G^n over the micro-elements [-] (1: the overall strain, < 0: a
        micro-element strains against it) and the fraction of micro-elements with a negative
        one [-]; nothing for the other laws."""
        if self.distribution != "maxwellian-first-order":
            return {}
        if "c_bar" not in info:
            return {"strain_share_lowest_eigenvalue": math.nan,
                    "strain_share_negative_fraction": math.nan}
        lowest = strain_share_eigenvalues(info["c_local"], info["c_bar"])[:, 0]
        return {"strain_share_lowest_eigenvalue": float(lowest.min(initial=math.inf)),
                "strain_share_negative_fraction": float(np.mean(lowest < 0.0))}

    def _asymmetry(self) -> float:
        """|skew part| / |stress| of the overall stress tensor [-]."""
        t = self.stress_tensor()
        return float(np.linalg.norm(t - t.T) / 2 / max(np.linalg.norm(t), 1e-300))

    def describe(self) -> dict[str, Any]:
        """The specimen as plain data for metadata."""
        s = self.structure
        return {
            "kind": "micro-element model (seed 001)",
            "structure": s.name,
            "structure_description": s.description,
            "n_micro_elements": s.n_elements,
            "coordination_number": s.coordination_number,
            "void_ratio": s.void_ratio(),
            "dimension": s.dimension,
            "distribution": self.distribution,
            "non_affine": self.non_affine,
            "spin": self.spin,
            "update_geometry": self.update_geometry,
            "series_order": self.series_order,
            "maxwellian_reference": self.maxwellian_reference,
            "contact_law": self.law.describe(),
        }

    # -- preparation --------------------------------------------------------------------------
    def consolidate_isotropically(
        self, pressure: float, steps: int = 10, tolerance: float = 1e-9,
        max_iterations: int = 50,
    ) -> None:
        """Load from zero force to the isotropic stress ``pressure`` [Pa]: every stress
        component controlled, equilibrium iterated at each of ``steps`` equal increments;
        then the cumulative strain is reset to zero (strains of a test count from here). With
        the self-consistent Maxwellian law the first increment, from zero force, is distributed
        homogeneously (no self-consistent stiffness exists while every contact is open).

        Raises
        ------
        ConvergenceError
            The structure cannot carry the isotropic stress (e.g. too few contacts).
        StrengthReached
            The distribution law has no stiffness for the structure on the way (the
            self-consistent law on some structures).
        """
        if not pressure > 0:
            raise InputError("pressure", pressure, "a positive isotropic stress in Pa")
        k = 6 if self.dimension == 3 else 3
        unit = np.zeros(k)
        unit[: self.dimension] = 1.0
        mean_radius = float(np.mean(self.structure.centre_radii))
        area = mean_radius**2 if self.dimension == 3 else mean_radius
        self.force_floor = 1e-3 * pressure * area if self.law.hertzian else 0.0
        self._invalidate()
        distribution = self.distribution
        if self.distribution == "maxwellian" and self.maxwellian_reference == "overall" and \
                self.state.overall_stiffness is None:
            # At zero contact force every contact is open: the micro-element stiffnesses are
            # singular and no self-consistent C exists (measured: none on the idealized
            # material, seeds 1-12). The first increment is distributed homogeneously.
            self.distribution = "homogeneous"
        try:
            for step in range(1, steps + 1):
                try:
                    self.solve_stress(unit * pressure * step / steps, tolerance, max_iterations)
                except StrengthReached as lost:
                    raise StrengthReached(
                        f"in the isotropic consolidation, at {pressure * step / steps:.6g} Pa "
                        f"(step {step} of {steps}): {lost}") from None
                self.force_floor = 0.0 if step >= 1 and not self.law.hertzian else (
                    self.force_floor)
                self.distribution = distribution
                self._invalidate()
        finally:
            self.distribution = distribution
            self.force_floor = 0.0
            self._invalidate()
        self.state.strain = np.zeros(k)

    def solve_stress(self, target: np.ndarray, tolerance: float = 1e-9,
                     max_iterations: int = 50) -> int:
        """Strain the specimen until its Voigt stress equals ``target`` [Pa] (all components
        stress-controlled, Newton iterations with the tangent); returns the iterations."""
        target = np.asarray(target, dtype=float)
        scale = max(float(np.linalg.norm(target)), 1e-300)
        for iteration in range(max_iterations):
            residual = target - self.stress()
            if np.linalg.norm(residual) <= tolerance * scale:
                return iteration
            tangent = self.tangent()
            if not (np.all(np.isfinite(residual)) and np.all(np.isfinite(tangent))
                    and np.linalg.norm(residual) <= DIVERGED_RESIDUAL * scale):
                raise ConvergenceError(
                    f"The iterations towards the stress {np.round(target, 6).tolist()} Pa "
                    f"diverged (iteration {iteration}, residual "
                    f"{np.linalg.norm(residual) / scale:.3g} of the stress): the "
                    f"'{self.distribution}' distribution gives this structure no stable "
                    "stiffness there (for the first-order law: its tangent is not positive "
                    "definite). Use another distribution law.")
            try:
                step = np.linalg.solve(tangent, residual)
            except np.linalg.LinAlgError:
                step = np.linalg.lstsq(tangent, residual, rcond=None)[0]
            self.apply_strain(step)
        raise ConvergenceError(
            f"No equilibrium with the stress {np.round(target, 6).tolist()} Pa after "
            f"{max_iterations} iterations (residual "
            f"{np.linalg.norm(target - self.stress()) / scale:.2e} of the stress): the structure "
            "cannot carry it."
        )
