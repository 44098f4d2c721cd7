"""Contacts of a periodic disc packing: which discs touch, across which periodic image.

Two discs i and j (j possibly a periodic image of i) are in contact when the gap
g = |x_j + n.A - x_i| - (r_i + r_j) satisfies |g| <= tol (r_i + r_j), with the relative
tolerance ``tol`` stated by the caller (default 1e-6). A gap below -tol (r_i + r_j) is an overlap
and an error. Each contact is listed once, however the cell is drawn, so contacts on the border
of a drawn cell are never counted twice (seed 000, Fig. 4(b) and the remark after eq. 5).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from grainlab.errors import GeometryError, InputError, RattlerWarning
from grainlab.geometry.disc_packing import DiscPacking2D

DEFAULT_CONTACT_TOLERANCE = 1e-6
"""Relative gap tolerance: |gap| <= tol * (r_i + r_j) counts as touching."""


@dataclass(frozen=True, eq=False)
class DiscContacts:
    """The contacts of a periodic disc packing, one row per contact.

    Attributes
    ----------
    particle_i, particle_j:
        (m,) indices of the two discs; the contact joins disc i in the reference cell to the
        image of disc j shifted by ``image``.
    image:
        (m, 2) integer lattice shift of disc j.
    branch:
        (m, 2) branch vectors l = x_j + n.A - x_i [m], from i to j.
    normal:
        (m, 2) unit normals n = l / |l|, pointing from i to j.
    gap:
        (m,) gaps [m] (within the tolerance of zero).
    radius_i, radius_j:
        (m,) radii of the two discs [m].
    """

    particle_i: np.ndarray
    particle_j: np.ndarray
    image: np.ndarray
    branch: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    radius_i: np.ndarray
    radius_j: np.ndarray

    @property
    def n_contacts(self) -> int:
        """Number of contacts in the cell."""
        return int(self.particle_i.shape[0])

    @property
    def tangent(self) -> np.ndarray:
        """(m, 2) unit tangents t, the normals turned by +90 degrees (n x t = +1)."""
        return np.column_stack([-self.normal[:, 1], self.normal[:, 0]])

    @property
    def contact_point_offset_i(self) -> np.ndarray:
        """(m, 2) vectors from the centre of disc i to the contact point, r_i n [m]."""
        return self.radius_i[:, None] * self.normal

    def per_particle(self, n_particles: int) -> np.ndarray:
        """(N,) number of contacts of each particle (a self-image contact counts twice)."""
        return np.bincount(self.particle_i, minlength=n_particles) + np.bincount(
            self.particle_j, minlength=n_particles
        )

    def coordination_number(self, n_particles: int) -> float:
        """Mean number of contacts per particle, 2 m / N [-]."""
        return 2.0 * self.n_contacts / n_particles


def find_disc_contacts(
    packing: DiscPacking2D,
    tolerance: float = DEFAULT_CONTACT_TOLERANCE,
    warn_rattlers: bool = True,
) -> DiscContacts:
    """Find every contact of a periodic disc packing.

    Parameters
    ----------
    packing:
        The packing.
    tolerance:
        Relative gap tolerance (see the module docstring), in (0, 0.1].
    warn_rattlers:
        Warn (:class:`~grainlab.errors.RattlerWarning`) naming each disc with no contact.

    Raises
    ------
    GeometryError
        Two discs overlap by more than the tolerance; the message names both and the overlap.

    >>> from grainlab.prep.regular_packings import named_packing
    >>> find_disc_contacts(named_packing("hexagonal")).n_contacts
    3
    """
    if not (0.0 < tolerance <= 0.1):
        raise InputError("tolerance", tolerance, "a relative gap tolerance in (0, 0.1]")
    radii, centres = packing.radii, packing.centres
    reach = 2.0 * radii.max() * (1.0 + tolerance)
    rows: list[tuple[int, int, int, int]] = []
    n = packing.n_particles
    for i in range(n):
        for j in range(i, n):
            images, offsets = packing.cell.images_near(centres[j] - centres[i], reach)
            separation = centres[j] + offsets - centres[i]
            distance = np.linalg.norm(separation, axis=1)
            contact_distance = radii[i] + radii[j]
            gap = distance - contact_distance
            for k in np.flatnonzero(gap <= tolerance * contact_distance):
                n1, n2 = images[k]
                if i == j and (n1 < 0 or (n1 == 0 and n2 <= 0)):
                    continue  # self-images: keep one of each +/- pair, never the disc itself
                if gap[k] < -tolerance * contact_distance:
                    where = f" (periodic image {int(n1)}, {int(n2)})" if (n1 or n2) else ""
                    raise GeometryError(
                        f"Discs {packing.labels[i]} and {packing.labels[j]}{where} overlap by "
                        f"{-gap[k]:.6g} m ({-gap[k] / contact_distance:.3g} of the sum of radii; "
                        f"allowed: {tolerance:g}). Move them apart or raise the contact tolerance."
                    )
                rows.append((i, j, int(n1), int(n2)))
    idx_i = np.array([r[0] for r in rows], dtype=int)
    idx_j = np.array([r[1] for r in rows], dtype=int)
    img = np.array([r[2:] for r in rows], dtype=int).reshape(-1, 2)
    branch = centres[idx_j] + img @ packing.cell.lattice - centres[idx_i]
    length = np.linalg.norm(branch, axis=1)
    contacts = DiscContacts(
        particle_i=idx_i,
        particle_j=idx_j,
        image=img,
        branch=branch,
        normal=branch / length[:, None] if rows else np.zeros((0, 2)),
        gap=length - radii[idx_i] - radii[idx_j],
        radius_i=radii[idx_i],
        radius_j=radii[idx_j],
    )
    if warn_rattlers:
        for k in np.flatnonzero(contacts.per_particle(n) == 0):
            warnings.warn(
                f"Disc {packing.labels[k]} of {packing.name!r} touches no other disc "
                "(a rattler): it carries no force and the theory ignores it.",
                RattlerWarning,
                stacklevel=2,
            )
    return contacts
