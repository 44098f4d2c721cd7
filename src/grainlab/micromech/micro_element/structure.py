"""The structure of seed 001's representative unit: a set of micro-elements.

A micro-element is a centre particle and the neighbours it touches (seed 001 §2.2, Fig. 2.2):
its branch vectors L^nm (from the centre to each neighbour), the radii (for Hertzian stiffness
and for gaps) and its volume V^n (the representative unit's volume is V = sum V^n). Arrays are
padded to the largest number of contacts M so that every computation is vectorised over
micro-elements; ``mask`` says which entries are real contacts.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainlab.errors import InputError


@dataclass(frozen=True, eq=False)
class MicroElementStructure:
    """E micro-elements with up to M contacts each, in d = 2 or 3 dimensions (SI units).

    Attributes
    ----------
    branches:
        (E, M, d) branch vectors L^nm from the centre particle to neighbour m [m]; padded
        entries are zero.
    mask:
        (E, M) True where micro-element n has a contact m.
    volumes:
        (E,) micro-element volumes V^n [m^3] (areas [m^2] in 2D).
    centre_radii:
        (E,) radius of each centre particle [m].
    neighbour_radii:
        (E, M) radius of each neighbour [m] (padded entries: any positive value).
    name:
        Label for reports.
    description:
        Plain data on how the structure was made (generator, seed, source).
    initial_forces:
        (E, M, d) force the centre particle exerts on neighbour m [N] (N/m in 2D) at the
        start, or None (default: no force; the model is consolidated from zero force). A
        structure taken from a simulated packing carries the simulation's forces
        (:mod:`~grainlab.micromech.micro_element.from_snapshot`).
    """

    branches: np.ndarray
    mask: np.ndarray
    volumes: np.ndarray
    centre_radii: np.ndarray
    neighbour_radii: np.ndarray
    name: str = "micro-elements"
    description: dict[str, Any] = field(default_factory=dict)
    initial_forces: np.ndarray | None = None

    def __post_init__(self) -> None:
        branches = np.array(self.branches, dtype=float)
        if branches.ndim != 3 or branches.shape[2] not in (2, 3):
            raise InputError("branches", f"array of shape {branches.shape}",
                             "an (E, M, d) array with d = 2 or 3")
        e, m, _ = branches.shape
        mask = np.array(self.mask, dtype=bool)
        if mask.shape != (e, m):
            raise InputError("mask", f"array of shape {mask.shape}", f"shape ({e}, {m})")
        volumes = np.array(self.volumes, dtype=float).reshape(-1)
        if volumes.shape != (e,) or np.any(~(volumes > 0)):
            raise InputError("volumes", volumes.tolist()[:5], f"{e} positive volumes")
        centre = np.array(self.centre_radii, dtype=float).reshape(-1)
        neighbour = np.array(self.neighbour_radii, dtype=float)
        if centre.shape != (e,) or np.any(~(centre > 0)):
            raise InputError("centre_radii", centre.tolist()[:5], f"{e} positive radii")
        if neighbour.shape != (e, m) or np.any(~(neighbour[mask] > 0)):
            raise InputError("neighbour_radii", f"array of shape {neighbour.shape}",
                             f"an ({e}, {m}) array, positive where mask is True")
        lengths = np.linalg.norm(branches, axis=2)
        if np.any(lengths[mask] <= 0) or not np.all(np.isfinite(branches)):
            raise InputError("branches", "zero or non-finite branch vector",
                             "non-zero finite branch vectors where mask is True")
        if np.any(mask.sum(axis=1) == 0):
            k = int(np.argmin(mask.sum(axis=1)))
            raise InputError(f"mask[{k}]", "no contact", "at least one contact per micro-element")
        branches[~mask] = 0.0
        neighbour = np.where(mask, neighbour, 1.0)
        if self.initial_forces is not None:
            forces = np.array(self.initial_forces, dtype=float)
            if forces.shape != branches.shape or not np.all(np.isfinite(forces)):
                raise InputError("initial_forces", f"array of shape {forces.shape}",
                                 f"a finite array of shape {branches.shape} (or None)")
            forces[~mask] = 0.0
            forces.setflags(write=False)
            object.__setattr__(self, "initial_forces", forces)
        for name, value in (("branches", branches), ("mask", mask), ("volumes", volumes),
                            ("centre_radii", centre), ("neighbour_radii", neighbour)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @property
    def dimension(self) -> int:
        """2 or 3."""
        return int(self.branches.shape[2])

    @property
    def n_elements(self) -> int:
        """Number of micro-elements E."""
        return int(self.branches.shape[0])

    @property
    def max_contacts(self) -> int:
        """Largest number of contacts of a micro-element M."""
        return int(self.branches.shape[1])

    @property
    def contact_counts(self) -> np.ndarray:
        """(E,) number of contacts of each micro-element."""
        return self.mask.sum(axis=1)

    @property
    def coordination_number(self) -> float:
        """Mean number of contacts per micro-element (centre particle) [-]."""
        return float(self.contact_counts.mean())

    @property
    def total_volume(self) -> float:
        """V = sum of V^n [m^3]."""
        return float(self.volumes.sum())

    @property
    def normals(self) -> np.ndarray:
        """(E, M, d) unit contact normals L / |L| (spheres and discs); zero where padded."""
        lengths = np.linalg.norm(self.branches, axis=2, keepdims=True)
        return np.divide(self.branches, lengths, out=np.zeros_like(self.branches),
                         where=lengths > 0)

    def solid_volume(self) -> float:
        """Volume of the centre particles [m^3] (areas in 2D)."""
        r = self.centre_radii
        return float(np.sum(4.0 / 3.0 * np.pi * r**3 if self.dimension == 3 else np.pi * r**2))

    def void_ratio(self) -> float:
        """e = V / V_solid - 1, counting each centre particle once [-]."""
        return self.total_volume / self.solid_volume() - 1.0

    def rotated(self, rotation: np.ndarray) -> MicroElementStructure:
        """The structure with every branch vector rotated by the orthogonal matrix R."""
        rotation = np.asarray(rotation, dtype=float)
        d = self.dimension
        if rotation.shape != (d, d) or not np.allclose(rotation @ rotation.T, np.eye(d),
                                                       atol=1e-10):
            raise InputError("rotation", rotation.tolist(), f"an orthogonal {d}x{d} matrix")
        return MicroElementStructure(
            self.branches @ rotation.T, self.mask, self.volumes, self.centre_radii,
            self.neighbour_radii, self.name, {**self.description, "rotated": True},
            None if self.initial_forces is None else self.initial_forces @ rotation.T,
        )
