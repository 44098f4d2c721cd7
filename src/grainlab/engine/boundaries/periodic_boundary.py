"""The periodic deformable cell: a boundary without walls (research/cd_engines.md; YADE's
``Cell``, LAMMPS ``fix deform``, LMGC90's periodic boxes).

The sample fills a triclinic cell h (3, 3) [m] whose COLUMNS are the cell vectors, repeated
without end: body j has images at x_j + h m for every integer vector m, and a body near a face
touches the images of the bodies near the opposite face
(:mod:`grainlab.engine.detect.periodic_detection`: every face, edge and corner, every shape).

Kinematics (total velocities, as YADE's ``homoDeform``). Positions are never wrapped: each body
follows a continuous trajectory, and a contact k is with the image of body j translated by
h m_k (m_k its image vector, found at each detection). The cell deforms at the rate
hdot = L h (L the velocity gradient [1/s]); an image moves with its body and with the cell,
v_j + hdot m_k, which enters the contact problem as a known velocity of the image or, for
stress-controlled components, as unknowns solved with the contacts. Over a step of length dt
with parameter theta the cell moves like the bodies: h_m = h + (1 - theta) dt hdot_old at the
detection configuration, h_new = h_m + theta dt hdot_new. When the cell's rate changes, the
particles' velocities take up the change of the mean field before the step,
v_i += (hdot_new - hdot_old) h_m^-1 (x_i - x_c) (x_c the centre of mass, so momentum is
kept and the origin does not matter): a free homogeneous deformation then moves every
particle affinely, x_i = h s_i with constant fractional coordinates s_i.

Control. Each stage sets (:meth:`PeriodicCell.set_control`):

* ``fixed_gradient`` L_0 (3, 3) [1/s]: the prescribed part of the velocity gradient;
* D stress-controlled degrees of freedom e_d [1/s], each with a direction ``gradients[d]``
  (3, 3) (L = L_0 + sum_d e_d G_d) and a target ``targets[d]`` [Pa] of its conjugate
  stress c_d = -G_d : sigma (sigma the stress from contacts, compression positive, so
  that c . e is the stress power per unit volume).

A stress-controlled degree of freedom is an overdamped servo solved with the contacts, as
the walls of :class:`~grainlab.engine.boundaries.wall_box.WallBox` are:

    e_d = G e_max (c*_d + J_d - c_d) / sigma_ref,          -4 e_max <= e_d <= e_max

with G = :data:`SERVO_GAIN` (20), e_max [1/s] the stage's largest strain rate (from the bound
on the inertia number) and sigma_ref [Pa] the stage's reference stress: the cell compresses
at e_max when nothing holds it. The proportional term alone leaves a lasting error where the
component must move (a lateral stress following a dilating sample at 0.5 e_max would sit
2.5 % of sigma_ref off its target); the integral term J_d takes it up, dJ_d/dt =
(e_max / :data:`INTEGRAL_STRAIN`) (c*_d - c_d) with c_d the stress the image contacts carried
over the last step, bounded by |J_d| <= 4 sigma_ref / G (what the largest outward rate needs),
so that a stress-controlled component holds its target on average within a strain of about
0.5 %. The bounds are symmetric (+-4 e_max) for a component whose target is not
compressive. In the contact problem c_d is the stress the contacts with
images transmit across the cell, c_d = -(1/V) sum_k G_d : (f_k (x) h m_k), which equals the
stress from all contacts in static equilibrium; so e_d has the free value
G e_max c*_d / sigma_ref and the inverse mass kappa_d = G e_max / (sigma_ref V dt) against
the generalised impulse (G_d h m_k) . P_k of each contact with an image
(:func:`~grainlab.engine.nscd.contact_update._apply_to_cell`).

Large shear. When the cell becomes too skewed (a cell vector's projection on another beyond
``max_skew`` (0.5) of its length), it is re-mapped to the least skewed cell of the same
lattice, h <- h M (M integer, det 1; :meth:`~grainlab.geometry.triclinic_cell.TriclinicCell.
reduced`): the periodic medium is the same, no particle moves, only the image vectors of
the contacts change (m <- M^-1 m), so shear can go on without end without the cell getting
thin. The re-maps are kept (``remap``, the product of the M) so that the deformation
gradient F = h remap^-1 h_0^-1 stays continuous. The strains a test records are the natural
strains, the step strains summed (``strain``): what a stage controls, and the logarithmic
strain of F on coaxial paths.

A **planar** cell holds a 2D sample of discs (:mod:`grainlab.engine.planar`): its third
column is (0, 0, t), t the discs' thickness, so that its volume is the area times t; it is
periodic in x and y only (the detection's ``planar``), and its velocity gradients (prescribed
and stress-controlled) have no z row or column: the cell deforms in its plane.

>>> import numpy as np
>>> cell = PeriodicCell(np.diag([1.0, 2.0, 4.0]))
>>> round(cell.volume, 12), cell.widths.tolist()
(8.0, [1.0, 2.0, 4.0])
"""

from __future__ import annotations

import numpy as np

from grainlab.engine.boundaries.boundary import BoundaryConstraints, BoundaryMotion, DetectionPhases
from grainlab.engine.detect.narrow_phase import Contacts
from grainlab.engine.detect.periodic_detection import PeriodicDetection
from grainlab.errors import InputError
from grainlab.geometry.triclinic_cell import TriclinicCell

SERVO_GAIN = 20.0
"""Gain G of the stress-controlled degrees of freedom (as the servo walls'): speed G e_max per
unit relative stress error (c*_d - c_d) / sigma_ref."""
INTEGRAL_STRAIN = 0.005
"""Strain [-] over which the servo's integral term takes up a lasting stress error."""
OUTWARD_RATE_FACTOR = 4.0
"""A stress-controlled degree of freedom expands at most this many times e_max."""
MAX_SKEW = 0.5
"""Re-map the cell when |c_b . c_a| > MAX_SKEW |c_a|^2 for two cell vectors."""


def _matrix(name: str, value, shape=(3, 3)) -> np.ndarray:
    array = np.array(value, dtype=np.float64)
    if array.shape != shape or not np.all(np.isfinite(array)):
        raise InputError(name, np.asarray(value).tolist(), f"a finite {shape} array")
    return array


def _check_in_plane(name: str, matrix: np.ndarray, diagonal: bool = False) -> None:
    """An InputError naming ``name`` unless the z row and column of ``matrix`` (3, 3) are
    zero (``diagonal``: but for its zz entry, > 0)."""
    row, column = matrix[2, :2], matrix[:2, 2]
    z = matrix[2, 2]
    if np.any(row != 0.0) or np.any(column != 0.0) or (z <= 0.0 if diagonal else z != 0.0):
        raise InputError(name, matrix.tolist(),
                         "no z row or column in a planar cell (a 2D sample deforms in its "
                         "plane)" + ("; its zz entry the discs' thickness > 0" if diagonal
                                     else ""))


class PeriodicCell:
    """A periodic deformable cell (module docstring).

    Parameters
    ----------
    matrix:
        Cell h (3, 3) [m], columns the cell vectors, det > 0.
    max_skew:
        Re-map threshold (module docstring); inf: never re-map.
    planar:
        A 2D sample's cell (module docstring).
    """

    periodic = True
    """The sample fills the cell and its images
    (:class:`~grainlab.engine.boundaries.boundary.Boundary`)."""

    @classmethod
    def around(cls, side, wall_friction: float = 0.0, particle_mass: float = 0.0,
               planar: bool = False) -> PeriodicCell:
        """The cell diag(``side``) ((3,) [m]) a loose sample fills; its centres lie at least a
        radius inside every face, so no pair overlaps across the faces. A cell has no walls:
        ``wall_friction`` and ``particle_mass`` are not used; ``planar``: a 2D sample's cell
        (``side[2]`` the discs' thickness)."""
        return cls(np.diag(np.asarray(side, dtype=np.float64)), planar=planar)

    def __init__(self, matrix, max_skew: float = MAX_SKEW, planar: bool = False) -> None:
        self.planar = bool(planar)
        h = _matrix("cell matrix", matrix)
        if self.planar:
            _check_in_plane("cell matrix", h, diagonal=True)
        self.geometry = TriclinicCell(h)
        self.rate = np.zeros((3, 3))
        self.carried = np.zeros((3, 3))
        self.remap = np.eye(3)
        self.max_skew = float(max_skew)
        if not self.max_skew > 0.0:
            raise InputError("max_skew", max_skew, "a number > 0 (inf: never re-map)")
        self.reference = self.matrix.copy()
        self.boundary_stress = np.zeros((3, 3))
        self.image_matrix = self.matrix.copy()
        """The cell in whose lattice basis the last step's image vectors are given: the cell at
        the end of that step before any re-map (the same lattice as ``matrix``; measures of the
        step reach the images at x_j + image_matrix m)."""
        self.step_strain = np.zeros((3, 3))
        """Strain increment of the last step [-]: -sym((h_new - h_old) h_mid^-1), h_mid the
        mean of the two cells (compression positive; second-order accurate in the step)."""
        self.strain = np.zeros((3, 3))
        """The step strains summed since the reference [-] (the natural strain, time integral
        of the rate of deformation: the logarithmic strain on coaxial paths, gamma = int
        gammadot dt in a simple shear)."""
        self.n_remaps = 0
        self.set_control(np.zeros((3, 3)))
        self._detection: PeriodicDetection | None = None
        self._step: tuple[np.ndarray, np.ndarray] | None = None

    # -- geometry --------------------------------------------------------------------------------
    @property
    def matrix(self) -> np.ndarray:
        """h (3, 3) [m]."""
        return self.geometry.matrix

    @property
    def volume(self) -> float:
        """det h [m^3]."""
        return self.geometry.volume

    @property
    def widths(self) -> np.ndarray:
        """(3,) distances between opposite faces [m]."""
        return self.geometry.widths

    @property
    def lengths(self) -> np.ndarray:
        """(3,) the cell's widths [m] (where a wall box has its edge lengths)."""
        return self.widths

    @property
    def gradient(self) -> np.ndarray:
        """Velocity gradient L = hdot h^-1 (3, 3) [1/s] at the end of the last step."""
        return self.rate @ np.linalg.inv(self.matrix)

    def deformation_gradient(self) -> np.ndarray:
        """F = h remap^-1 h_0^-1 (3, 3) from the reference cell h_0 (``reference``)."""
        unmapped = self.matrix @ np.linalg.inv(self.remap)
        return unmapped @ np.linalg.inv(self.reference)

    def set_reference(self) -> None:
        """Strains are measured from the cell now."""
        self.reference = self.matrix @ np.linalg.inv(self.remap)
        self.strain = np.zeros((3, 3))

    # -- control ---------------------------------------------------------------------------------
    def set_control(self, fixed_gradient, gradients=None, targets=None,
                    reference_stress: float = 1.0, max_rate: float = 0.0,
                    gain: float = SERVO_GAIN) -> None:
        """Prescribed velocity gradient ``fixed_gradient`` (3, 3) [1/s] and D stress-controlled
        degrees of freedom: directions ``gradients`` (D, 3, 3), conjugate stress ``targets``
        (D,) [Pa], servo reference stress [Pa] > 0, largest rate ``max_rate`` e_max [1/s]
        and ``gain`` (module docstring). Values of degrees of freedom kept from the last
        control where the directions are unchanged."""
        fixed = _matrix("fixed_gradient", fixed_gradient)
        directions = np.zeros((0, 3, 3)) if gradients is None else \
            np.array(gradients, dtype=np.float64).reshape(-1, 3, 3)
        if self.planar:
            _check_in_plane("fixed_gradient", fixed)
            for d, direction in enumerate(directions):
                _check_in_plane(f"gradients[{d}]", direction)
        goals = np.zeros(0) if targets is None else \
            np.array(targets, dtype=np.float64).reshape(-1)
        if goals.shape[0] != directions.shape[0] or not np.all(np.isfinite(directions)) \
                or not np.all(np.isfinite(goals)):
            raise InputError("targets", goals.tolist(),
                             f"one finite stress in Pa per direction ({directions.shape[0]})")
        if directions.shape[0] and not (reference_stress > 0.0 and max_rate > 0.0
                                        and gain > 0.0):
            raise InputError("cell servo", (reference_stress, max_rate, gain),
                             "reference stress, largest rate and gain all > 0")
        old = getattr(self, "gradients", np.zeros((0, 3, 3)))
        kept = hasattr(self, "dofs") and old.shape == directions.shape and \
            np.array_equal(old, directions)
        self.fixed_gradient = fixed
        self.gradients = directions
        self.targets = goals
        self.reference_stress = float(reference_stress)
        self.max_rate = float(max_rate)
        self.gain = float(gain)
        if not kept:
            self.dofs = np.zeros(directions.shape[0])
            self.integral = np.zeros(directions.shape[0])
        outward = OUTWARD_RATE_FACTOR * self.max_rate
        inward = np.where(goals > 0.0, self.max_rate, outward)
        self.bounds = np.column_stack([np.full(goals.shape[0], -outward), inward])

    def conjugate_stress(self, stress: np.ndarray) -> np.ndarray:
        """(D,) c_d = -G_d : sigma [Pa] of a stress (3, 3) [Pa] (compression positive)."""
        return -np.einsum("dab,ab->d", self.gradients, np.asarray(stress))

    # -- the boundary protocol (grainlab.engine.boundaries.boundary) -------------------------------
    def constraints(self, dt: float, theta: float) -> BoundaryConstraints:
        """The cell over a step (module docstring): h_m, the prescribed hdot, the free degrees
        of freedom and the change of the mean field the particles take up."""
        h_m = self.matrix + (1.0 - theta) * dt * self.rate
        volume = float(np.linalg.det(h_m))
        predicted = self.fixed_gradient @ h_m + np.einsum(
            "d,dab->ab", self.dofs, self.gradients) @ h_m
        affine = (predicted - self.carried) @ np.linalg.inv(h_m)
        self._step = (h_m, predicted)
        n = self.gradients.shape[0]
        basis = np.einsum("dab,bc->dac", self.gradients, h_m)
        scale = self.gain * self.max_rate / self.reference_stress if n else 0.0
        free = scale * (self.targets + self.integral)
        inv_mass = np.full(n, scale / (volume * dt)) if n else np.zeros(0)
        reach = np.abs(self.fixed_gradient) + np.einsum(
            "d,dab->ab", np.abs(self.bounds).max(axis=1, initial=0.0) if n else np.zeros(0),
            np.abs(self.gradients))
        speed = float(np.linalg.norm(reach @ np.abs(h_m), axis=0).max())
        return BoundaryConstraints(
            cell_fixed=self.fixed_gradient @ h_m, cell_basis=basis, cell_inv_mass=inv_mass,
            cell_free=free, cell_bounds=self.bounds.copy(), cell_matrix=h_m,
            affine_change=affine, speed=speed)

    def detect(self, predicted, library, phases: DetectionPhases,
               constraints: BoundaryConstraints) -> tuple[Contacts, np.ndarray]:
        """Contacts through every face, edge and corner of the cell at the detection
        configuration (:class:`~grainlab.engine.detect.periodic_detection.PeriodicDetection`)."""
        if self._detection is None or self._detection.alert != phases.alert:
            self._detection = PeriodicDetection(alert=phases.alert, planar=self.planar)
        found = self._detection.detect(predicted, library,
                                       TriclinicCell(constraints.cell_matrix),
                                       sphere_rows=phases.sphere_rows)
        return found.contacts, found.images

    def finish_step(self, motion: BoundaryMotion) -> None:
        """Move the cell to the end of the step, record the stress its image contacts carry
        (``boundary_stress``, compression positive, [Pa]; the solver's mean stress of all
        the contacts over the step when it gives one) and re-map it if too skewed."""
        if self._step is None:
            raise InputError("periodic cell", "finish_step", "a call of constraints first")
        h_m, predicted = self._step
        self._step = None
        if motion.stress is not None:
            self.boundary_stress = np.array(motion.stress, dtype=np.float64)
        else:
            images = motion.images
            crossing = np.any(images != 0.0, axis=1)
            shifts = images[crossing] @ h_m.T
            moment = np.einsum("ci,cj->ij", motion.forces[crossing], shifts)
            self.boundary_stress = 0.5 * (moment + moment.T) / float(np.linalg.det(h_m))
        self.rate = np.array(motion.cell_rate, dtype=np.float64)
        self.dofs = np.array(motion.cell_dofs, dtype=np.float64)
        # with an explicit solver's stress, the integral only learns while a prescribed part
        # of the rate deforms the sample: without one the servo holds its target alone, and
        # the integral would only wind up the stress's vibrations
        learns = motion.stress is None or bool(np.any(self.fixed_gradient != 0.0))
        if self.targets.size and learns:
            error = self.targets - self.conjugate_stress(self.boundary_stress)
            bound = OUTWARD_RATE_FACTOR / self.gain * self.reference_stress
            self.integral = np.clip(
                self.integral + motion.dt * self.max_rate / INTEGRAL_STRAIN * error,
                -bound, bound)
        self.carried = predicted
        before = self.matrix
        self.geometry = TriclinicCell(h_m + motion.theta * motion.dt * self.rate)
        self.image_matrix = self.matrix.copy()
        increment = (self.matrix - before) @ np.linalg.inv(0.5 * (self.matrix + before))
        self.step_strain = -0.5 * (increment + increment.T)
        self.strain = self.strain + self.step_strain
        self.remap_if_skewed()

    def remap_if_skewed(self) -> bool:
        """Re-map a cell skewed beyond ``max_skew`` (module docstring); True if it was."""
        if not np.isfinite(self.max_skew):
            return False
        reduced, change = self.geometry.reduced(self.max_skew)
        if np.array_equal(change, np.eye(3)):
            return False
        self.geometry = reduced
        self.rate = self.rate @ change
        self.carried = self.carried @ change
        self.remap = self.remap @ change
        self.n_remaps += 1
        return True

    def health_arrays(self) -> dict[str, np.ndarray]:
        """The cell and its rate must stay finite."""
        return {"cell matrix": self.matrix, "cell rate": self.rate}

    # -- persistence -----------------------------------------------------------------------------
    def to_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays that restore the cell with :meth:`from_arrays` (checkpoints)."""
        return {
            "matrix": self.matrix.copy(), "rate": self.rate.copy(),
            "carried": self.carried.copy(), "remap": self.remap.copy(),
            "reference": self.reference.copy(), "max_skew": np.array(self.max_skew),
            "fixed_gradient": self.fixed_gradient.copy(), "gradients": self.gradients.copy(),
            "targets": self.targets.copy(), "dofs": self.dofs.copy(),
            "integral": self.integral.copy(),
            "servo": np.array([self.reference_stress, self.max_rate, self.gain]),
            "boundary_stress": self.boundary_stress.copy(),
            "n_remaps": np.array(self.n_remaps), "step_strain": self.step_strain.copy(),
            "strain": self.strain.copy(), "image_matrix": self.image_matrix.copy(),
            "planar": np.array(int(self.planar)),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> PeriodicCell:
        """Inverse of :meth:`to_arrays`."""
        cell = cls(arrays["matrix"], max_skew=float(arrays["max_skew"]),
                   planar=bool(int(arrays.get("planar", 0))))
        servo = np.asarray(arrays["servo"], dtype=np.float64)
        cell.set_control(arrays["fixed_gradient"], arrays["gradients"], arrays["targets"],
                         float(servo[0]), float(servo[1]), float(servo[2]))
        cell.dofs = np.array(arrays["dofs"], dtype=np.float64)
        cell.integral = np.array(arrays["integral"], dtype=np.float64)
        cell.rate = np.array(arrays["rate"], dtype=np.float64)
        cell.carried = np.array(arrays["carried"], dtype=np.float64)
        cell.remap = np.array(arrays["remap"], dtype=np.float64)
        cell.reference = np.array(arrays["reference"], dtype=np.float64)
        cell.boundary_stress = np.array(arrays["boundary_stress"], dtype=np.float64)
        cell.n_remaps = int(arrays["n_remaps"])
        cell.step_strain = np.array(arrays["step_strain"], dtype=np.float64)
        cell.strain = np.array(arrays["strain"], dtype=np.float64)
        cell.image_matrix = np.array(arrays["image_matrix"], dtype=np.float64)
        return cell
