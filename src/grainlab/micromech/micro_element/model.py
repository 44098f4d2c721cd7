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
  a stated order with a convergence check); overall tangent C = sum_n C^n G^n (eq. 2.31) and
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
from grainlab.errors import ConvergenceError, InputError
from grainlab.micromech.micro_element.distribution_kernels import (
    exponential_series_batch,
    maxwellian_tensors,
    relative_stiffness,
)
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

DISTRIBUTIONS = ("homogeneous", "maxwellian")
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


SELF_CONSISTENT_RELAXATION = 0.5
"""Under-relaxation of the fixed-point iteration on the overall C of eq. 2.32 [-]."""
SELF_CONSISTENT_TOLERANCE = 1e-9
"""Change of C, relative to |C_bar|, that ends the fixed-point iteration [-]."""
SELF_CONSISTENT_MAX_ITERATIONS = 200
SELF_CONSISTENT_COLLAPSE = 1e-6
"""Smallest eigenvalue of an iterate, relative to |C_bar|, below which the unit has lost its
stiffness in some direction and the iteration stops [-]."""


class MicroElementModel:
    """The representative unit of seed 001 as a lab specimen.

    Parameters
    ----------
    structure:
        The micro-elements.
    law:
        The contact law (constant or Hertz–Mindlin springs, Coulomb, separation, bonds).
    distribution:
        ``"homogeneous"`` (eq. 2.30) or ``"maxwellian"`` (eqs. 2.32–2.35).
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
        elif self.maxwellian_reference == "average":
            g, tangent, last = self._maxwellian(c_local, c_bar, c_bar, weights, shift=False)
        else:
            g, tangent, last, iterations, converged = self._self_consistent(
                c_local, c_bar, weights)
            local.update(reference_iterations=iterations, reference_converged=converged)
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
                         ) -> tuple[np.ndarray, np.ndarray, float, int, bool]:
        """Eqs. 2.31–2.35 with the overall C in v^n (eq. 2.32 as printed): the fixed point
        C = sum_n C^n G^n(C), iterated from C_bar with under-relaxation (factor
        ``SELF_CONSISTENT_RELAXATION``) until the change is below ``SELF_CONSISTENT_TOLERANCE``
        of |C_bar|. A softer C concentrates the strain more on soft micro-elements, which
        softens C further: when enough micro-elements have lost their stiffness the iterate
        stops being positive definite — the unit has no stiffness left in some direction
        (failure, the peak of a strain-controlled test) and the iteration stops there.
        Returns G, the overall tangent, the last series term, the iterations and whether the
        fixed point was reached (False also at a collapse)."""
        reference = c_bar
        scale = float(np.linalg.norm(c_bar))
        g, tangent, last = self._maxwellian(c_local, c_bar, reference, weights, shift=True)
        for iteration in range(1, SELF_CONSISTENT_MAX_ITERATIONS + 1):
            overall = 0.5 * (tangent + tangent.T)
            change = float(np.linalg.norm(overall - reference))
            if change <= SELF_CONSISTENT_TOLERANCE * scale:
                return g, tangent, last, iteration, True
            if np.linalg.eigvalsh(overall)[0] <= SELF_CONSISTENT_COLLAPSE * scale:
                return g, tangent, last, iteration, False
            reference = reference + SELF_CONSISTENT_RELAXATION * (overall - reference)
            g, tangent, last = self._maxwellian(c_local, c_bar, reference, weights,
                                                shift=True)
        return g, tangent, last, SELF_CONSISTENT_MAX_ITERATIONS, False

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
        info = self._distribution()
        eig = np.linalg.eigvalsh(info["tangent"])
        return {
            "n_sliding": int(n_sliding),
            "n_open": int(n_open),
            "n_bonded": int(n_bonded),
            "sliding_fraction": float(n_sliding / max(n_contacts, 1)),
            "mean_mobilisation": (float(mobilisation / n_closed) if n_closed else math.nan)
            if n_contacts else 0.0,
            "coordination_number": float(n_closed / st.volumes.size),
            "void_ratio": self.volume / self.structure.solid_volume() - 1.0,
            "min_eigenvalue_tangent": float(eig[0]),
            "series_last_term": float(info["series_last_term"]),
            "self_consistent_iterations": int(info.get("reference_iterations", 0)),
            "stress_asymmetry": self._asymmetry(),
        }

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
        then the cumulative strain is reset to zero (strains of a test count from here).

        Raises
        ------
        ConvergenceError
            The structure cannot carry the isotropic stress (e.g. too few contacts).
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
        try:
            for step in range(1, steps + 1):
                self.solve_stress(unit * pressure * step / steps, tolerance, max_iterations)
                self.force_floor = 0.0 if step >= 1 and not self.law.hertzian else (
                    self.force_floor)
        finally:
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
