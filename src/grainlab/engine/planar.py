"""2D samples in the 3D engine: discs that move in a plane (seed 001 ch. 3; seed 000).

A disc (:data:`~grainlab.engine.shape_kinds.DISC`) is a cylinder of length t, the sample's
**thickness** [m], seen end-on: its contact geometry is that of a sphere of the same radius
whose centre stays in the plane z = z_0, and its mass and inertia are the cylinder's,

    m = rho pi r^2 t          [kg]          I_zz = m r^2 / 2          [kg m^2]

(:meth:`~grainlab.engine.state.ShapeLibrary.from_discs`; the library stores the volume
pi r^2 t and I_zz per unit density on all three principal axes, so that no gyroscopic term
couples the axes). A disc has two translations (x, y) and one rotation (about z).

**Why no solver or kernel knows about it.** Planar motion is kept exactly, not enforced:
every body starts in the plane z = z_0 with v_z = 0, omega_x = omega_y = 0 and a rotation
about z (checked by :func:`check_planar` when the bodies are made); gravity lies in the
plane. Then every contact normal and branch vector has an exact zero z component (centre
differences), every tangential direction is either in the plane or exactly e_z
(:func:`~grainlab.engine.step_report.contact_frames` picks the axis least aligned with n, and
for an in-plane n that is e_z or an in-plane axis), every torque r x f lies along z, and the
products and sums that would carry a z component are products with exact zeros. So z,
v_z, omega_x and omega_y stay exactly 0 in both solvers and both boundaries, with no branch
in any kernel (YADE blocks the degrees of freedom instead; LMGC90 has 2D kernels of its
own). :func:`planar_drift` measures what a run left out of the plane; the tests require
exactly zero.

**Boundaries.** The sample's box or cell spans z_0 +- t/2: its volume is the area times t,
so that every stress the engine computes (sum f (x) l / V, wall reactions over their faces
of area L t) is a stress in Pa of discs of thickness t; with forces per disc [N] and
stiffnesses per disc [N/m] (seed 001's k_n = 200 kN/m), a thicker disc means a lower stress
for the same forces. The two z walls of a box are out of reach
(:class:`~grainlab.engine.boundaries.wall_box.WallBox` ``planar``), and a periodic cell is
periodic in x and y only (its z column is t; no body meets a z image;
:class:`~grainlab.engine.detect.periodic_detection.PeriodicDetection` ``planar``).

The default thickness of a sample of discs is their mean diameter (a disc as thick as it is
wide), as the micro-element model's (:func:`grainlab.lab.micro_element_setup.disc_thickness`).
"""

from __future__ import annotations

import numpy as np

from grainlab.errors import InputError

PLANE_NORMAL_AXIS = 2
"""The axis normal to the plane of a 2D sample (z)."""


def check_planar(positions: np.ndarray, orientations: np.ndarray, velocities: np.ndarray,
                 angular_velocities: np.ndarray) -> None:
    """An :class:`~grainlab.errors.InputError` naming the first body off the plane: its z
    unlike body 0's, v_z != 0, omega_x or omega_y != 0, or a rotation about another axis
    than z (quaternion x or y != 0)."""
    arrays = {"positions": positions, "velocities": velocities,
              "angular_velocities": angular_velocities, "orientations": orientations}
    off_plane = {
        "positions": (positions[:, 2] != positions[0, 2] if positions.shape[0] else
                      np.zeros(0, dtype=bool), "the z of body 0: discs move in one plane"),
        "velocities": (velocities[:, 2] != 0.0, "v_z = 0: discs move in the plane"),
        "angular_velocities": (np.any(angular_velocities[:, :2] != 0.0, axis=1),
                               "omega_x = omega_y = 0: discs turn about z only"),
        "orientations": (np.any(orientations[:, 1:3] != 0.0, axis=1),
                         "a rotation about z, (w, 0, 0, z)"),
    }
    for name, (bad, allowed) in off_plane.items():
        rows = np.flatnonzero(bad)
        if rows.size:
            k = int(rows[0])
            raise InputError(f"{name}[{k}]", arrays[name][k].tolist(), allowed)


def planar_drift(positions: np.ndarray, velocities: np.ndarray,
                 angular_velocities: np.ndarray, plane_z: float) -> float:
    """The largest departure from planar motion: max over the bodies of |z - z_0| [m],
    |v_z| [m/s] and |omega_x|, |omega_y| [rad/s] (mixed units: zero is the only value that
    means anything, and the engine keeps it exactly)."""
    if positions.shape[0] == 0:
        return 0.0
    return float(max(np.max(np.abs(positions[:, 2] - plane_z)),
                     np.max(np.abs(velocities[:, 2])),
                     np.max(np.abs(angular_velocities[:, :2]))))
