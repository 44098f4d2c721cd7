"""The regular-packing specimen: contacts, their stiffness, the stress and the stiffness D.

Kinematics (seed 000 eq. 7): the strain is uniform over the model tessellation, so the
deformation of the spring at contact c (the two end displacements du^am + du^bm of eq. 6–7
added) is the strain acting on the branch vector, du^c = eps l^c, with l^c from particle i to
particle j. In Voigt form, with eps = [eps_xx, eps_yy, gamma_xy] (compression positive),
du^c = B^c eps, B^c = [[l_x, 0, l_y/2], [0, l_y, l_x/2]].

Statics (seed 000 eqs. 2–5): the average stress sums the force dyads of both particles of every
contact, sigma = (1/V) sum_c f^c (x) l^c; its symmetric part in Voigt form is
(1/V) sum_c B^cT f^c, with f^c = f_n n + f_t t the force exerted by i on j.

Stiffness (seed 000 eqs. 13–16, indices as corrected in MISSION.md): with the local stiffness
K^c = c_n n n + c_t t t (eq. 16 rotated to the global frame by L^c), eq. 14 summed over both ends
of each contact gives D = (1/V) sum_c B^cT K^c B^c, i.e. D_ijkl = (1/V) sum_c l_j K_ik l_l made
symmetric in (ij) and (kl); it is symmetric (D_ijkl = D_klij) and, in the Voigt form of eq. 15,
a symmetric 3x3 matrix mapping [eps_xx, eps_yy, gamma_xy] to [sigma_xx, sigma_yy, sigma_xy].
(Writing eq. 14 with the half-length vectors r^am and the full contact stiffness would weight
each contact by r_i^2 + r_j^2 instead of (r_i + r_j)^2; the branch form is the one in which the
two half-springs of a contact carry the same force.)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from grainlab.analysis.contact_network import ContactNetwork
from grainlab.analysis.contact_stress import stress_from_contact_dyads
from grainlab.contact.law2d import ContactLaw2D, ContactState2D
from grainlab.contact.modified_hertz_mindlin import equivalent_radius
from grainlab.errors import InputError
from grainlab.geometry.disc_contacts import (
    DEFAULT_CONTACT_TOLERANCE,
    DiscContacts,
    find_disc_contacts,
)
from grainlab.geometry.disc_packing import DiscPacking2D


@dataclass(frozen=True)
class RegularPackingState:
    """State of the specimen: contact forces and history, and the strain reached.

    Attributes
    ----------
    contacts:
        Forces and history of every contact (arrays of shape (m,)).
    strain:
        Voigt strain [eps_xx, eps_yy, gamma_xy] [-] since the unloaded state, compression
        positive.
    """

    contacts: ContactState2D
    strain: np.ndarray


@dataclass(frozen=True, eq=False)
class RegularPackingModel:
    """A periodic disc packing with a contact law: seed 000's specimen.

    Parameters
    ----------
    packing:
        The packing (its periodic cell is the model tessellation).
    law:
        A 2D contact law (:class:`~grainlab.contact.ModifiedHertzMindlin2D` or
        :class:`~grainlab.contact.LinearSpring2D`).
    contact_tolerance:
        Relative gap tolerance used to find contacts.

    >>> from grainlab.prep.regular_packings import named_packing
    >>> from grainlab.contact import LinearSpring2D
    >>> model = RegularPackingModel(named_packing("hexagonal"), LinearSpring2D(1e8, 5e7))
    >>> model.n_contacts
    3
    """

    packing: DiscPacking2D
    law: ContactLaw2D
    contact_tolerance: float = DEFAULT_CONTACT_TOLERANCE
    contacts: DiscContacts = field(init=False, repr=False)
    equivalent_radius: np.ndarray = field(init=False, repr=False)
    strain_to_displacement: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        contacts = find_disc_contacts(self.packing, self.contact_tolerance)
        if contacts.n_contacts == 0:
            raise InputError(
                "packing", self.packing.name, "a packing whose discs touch (it has no contact)"
            )
        object.__setattr__(self, "contacts", contacts)
        object.__setattr__(
            self, "equivalent_radius", equivalent_radius(contacts.radius_i, contacts.radius_j)
        )
        lx, ly = contacts.branch[:, 0], contacts.branch[:, 1]
        zeros = np.zeros_like(lx)
        # B^c maps Voigt strain to the spring deformation du = eps l (m, 2, 3).
        strain_to_displacement = np.stack(
            [np.stack([lx, zeros, ly / 2], axis=1), np.stack([zeros, ly, lx / 2], axis=1)],
            axis=1,
        )
        object.__setattr__(self, "strain_to_displacement", strain_to_displacement)


    @property
    def n_contacts(self) -> int:
        """Number of contacts in the model tessellation."""
        return self.contacts.n_contacts

    @property
    def area(self) -> float:
        """Area V of the model tessellation [m^2]."""
        return self.packing.cell.area

    def unloaded_state(self) -> RegularPackingState:
        """Every contact just touching, no force, no strain."""
        zeros = np.zeros(self.n_contacts)
        return RegularPackingState(
            ContactState2D(zeros, zeros.copy(), zeros.copy(), np.zeros(self.n_contacts, bool)),
            np.zeros(3),
        )

    def state_from_forces(
        self, normal_force: np.ndarray, tangential_force: np.ndarray, strain: np.ndarray
    ) -> RegularPackingState:
        """A state with given contact forces [N/m] (history consistent with the law)."""
        normal = np.asarray(normal_force, dtype=float)
        approach = self.law.normal_approach(normal, self.equivalent_radius)
        mu = self.law.friction_coefficient
        tangential = np.asarray(tangential_force, dtype=float)
        sliding = (normal > 0) & (np.abs(tangential) >= (1 - 1e-9) * mu * normal)
        return RegularPackingState(
            ContactState2D(approach, normal, tangential, sliding), np.asarray(strain, float)
        )

    # -- statics ------------------------------------------------------------------------------
    def force_vectors(self, state: RegularPackingState) -> np.ndarray:
        """(m, 2) contact forces exerted by particle i on particle j [N/m], global frame."""
        c = state.contacts
        return c.normal_force[:, None] * self.contacts.normal + (
            c.tangential_force[:, None] * self.contacts.tangent
        )

    def stress_tensor(self, state: RegularPackingState) -> np.ndarray:
        """Full 2x2 average stress [Pa] (seed 000 eq. 5); its skew part measures the moment
        imbalance of the particles."""
        return stress_from_contact_dyads(self.force_vectors(state), self.contacts.branch, self.area)

    def stress(self, state: RegularPackingState) -> np.ndarray:
        """Voigt stress [sigma_xx, sigma_yy, sigma_xy] [Pa] (symmetric part), compression +."""
        s = self.stress_tensor(state)
        return np.array([s[0, 0], s[1, 1], 0.5 * (s[0, 1] + s[1, 0])])

    def particle_residuals(self, state: RegularPackingState) -> tuple[np.ndarray, np.ndarray]:
        """Out-of-balance force (N, 2) [N/m] and moment (N,) [N m/m] on every particle.

        Seed 000 notes that the volume-averaged theory does not guarantee the equilibrium of
        individual particles; these residuals show by how much it is missed.
        """
        n = self.packing.n_particles
        f = self.force_vectors(state)
        i, j = self.contacts.particle_i, self.contacts.particle_j
        force = np.zeros((n, 2))
        np.add.at(force, j, f)
        np.add.at(force, i, -f)
        # Moment about each centre: r x f with r = +r_i n on i (force -f), -r_j n on j (force f);
        # both give -r f_t with n x t = +1.
        ft = state.contacts.tangential_force
        moment = np.zeros(n)
        np.add.at(moment, i, -self.contacts.radius_i * ft)
        np.add.at(moment, j, -self.contacts.radius_j * ft)
        return force, moment

    # -- kinematics and stiffness -------------------------------------------------------------
    def deformation(self, strain_increment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Normal and tangential spring deformations (m,) [m] for a Voigt strain increment."""
        du = self.strain_to_displacement @ np.asarray(strain_increment, dtype=float)
        return (
            np.einsum("ci,ci->c", du, self.contacts.normal),
            np.einsum("ci,ci->c", du, self.contacts.tangent),
        )

    def update(
        self, state: RegularPackingState, strain_increment: np.ndarray
    ) -> RegularPackingState:
        """State after a uniform strain increment (eq. 7), integrating the contact law."""
        d_normal, d_tangential = self.deformation(strain_increment)
        contacts = self.law.update(state.contacts, d_normal, d_tangential, self.equivalent_radius)
        return RegularPackingState(contacts, state.strain + strain_increment)

    def contact_stiffness(
        self, state: RegularPackingState, force_floor: float = 0.0
    ) -> tuple[np.ndarray, np.ndarray]:
        """(c_n, c_t) of every contact [N/m^2] at the current forces (eqs. 16–18).

        ``force_floor`` [N/m] evaluates the law at no less than that normal force on contacts
        that are closed or just touching, so that a Hertzian packing has a stiffness at zero
        load (used only to start the isotropic loading).
        """
        c = state.contacts
        normal = c.normal_force
        if force_floor > 0.0:
            normal = np.where(c.normal_approach >= 0.0, np.maximum(normal, force_floor), 0.0)
        return self.law.tangent_stiffness(normal, c.tangential_force, self.equivalent_radius)

    def stiffness_matrix(
        self, state: RegularPackingState, force_floor: float = 0.0
    ) -> np.ndarray:
        """Symmetric Voigt stiffness D (3, 3) [Pa] of seed 000 eq. 15 (1/V included).

        dsigma = D deps with sigma = [sigma_xx, sigma_yy, sigma_xy] and
        eps = [eps_xx, eps_yy, gamma_xy].
        """
        kn, kt = self.contact_stiffness(state, force_floor)
        n, t = self.contacts.normal, self.contacts.tangent
        local = kn[:, None, None] * np.einsum("ci,cj->cij", n, n) + kt[:, None, None] * (
            np.einsum("ci,cj->cij", t, t)
        )
        b = self.strain_to_displacement
        return np.einsum("cia,cij,cjb->ab", b, local, b) / self.area

    def solver_stiffness(self, state: RegularPackingState, force_floor: float = 0.0) -> np.ndarray:
        """Tangent for the equilibrium iterations: :meth:`stiffness_matrix`, except that a
        sliding contact follows the Coulomb bound (df_t = +/- mu df_n), which makes it
        non-symmetric; it loses invertibility when the packing reaches its strength."""
        kn, kt = self.contact_stiffness(state, force_floor)
        n, t = self.contacts.normal, self.contacts.tangent
        c = state.contacts
        slide_sign = np.where(c.sliding, np.sign(c.tangential_force), 0.0)
        mu = self.law.friction_coefficient
        local = (
            kn[:, None, None] * np.einsum("ci,cj->cij", n, n)
            + kt[:, None, None] * np.einsum("ci,cj->cij", t, t)
            + (slide_sign * mu * kn)[:, None, None] * np.einsum("ci,cj->cij", t, n)
        )
        b = self.strain_to_displacement
        return np.einsum("cia,cij,cjb->ab", b, local, b) / self.area

    def contact_network(self, state: RegularPackingState) -> ContactNetwork:
        """The specimen's contacts and forces as a 2D contact network (one point per contact,
        at x_i + r_i n) for the microstructure analyses."""
        p, c = self.packing, self.contacts
        return ContactNetwork(
            positions=p.centres,
            volumes=np.pi * p.radii**2,
            volume=self.area,
            pair_particles=np.column_stack([c.particle_i, c.particle_j]),
            pair_branches=c.branch,
            point_pairs=np.arange(c.n_contacts),
            point_positions=p.centres[c.particle_i] + c.contact_point_offset_i,
            point_normals=c.normal,
            point_forces=self.force_vectors(state),
            friction_coefficient=self.law.friction_coefficient,
            point_sliding=state.contacts.sliding,
            state={"packing": p.name, "strain_voigt": state.strain.tolist()},
        )

    def describe(self) -> dict:
        """The specimen as plain data for test-result metadata."""
        p = self.packing
        return {
            "kind": "regular packing theory (seed 000)",
            "packing": p.name,
            "lattice_m": p.cell.lattice.tolist(),
            "centres_m": p.centres.tolist(),
            "radii_m": p.radii.tolist(),
            "labels": list(p.labels),
            "void_ratio": p.void_ratio,
            "coordination_number": self.contacts.coordination_number(p.n_particles),
            "n_contacts": self.n_contacts,
            "contact_tolerance": self.contact_tolerance,
            "contact_law": self.law.describe(),
        }
