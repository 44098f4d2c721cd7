"""The columns of test-result tables: one name, one unit and one meaning each, for every
specimen (discrete samples, micromechanical models, contact-network analyses).

Conventions: Cauchy stresses averaged over the specimen, compression positive [Pa]; strains
compression positive [-]; ``gamma_ab`` the engineering shear strain 2 eps_ab. In 2D the axes
are x and y, the principal stresses sigma_1 >= sigma_3 (no sigma_2) and p = tr(sigma)/2.

The two deviators of the literature are named apart:

* ``q`` = sigma_1 - sigma_3, the deviator of soil mechanics and of seed 001;
* ``q_over_3`` = (sigma_1 - sigma_3)/3, the q of seeds 002/003 (seed 002 eq. 5).

and the seeds' normalised shear stress "q/p" (seed 002 eqs. 5, 11; seed 003 eq. 6) is
``q_over_trace`` = q / tr(sigma): (q/3)/p in 3D, (sigma_1 - sigma_3)/(sigma_1 + sigma_3) in
2D, where seeds' 2D "q/p" takes q = (sigma_1 - sigma_3)/2 and p = (sigma_1 + sigma_3)/2. It is
the ratio the fabric relations of seed 002 eq. 27 predict. ``eta`` = q/p is the ratio of
critical-state soil mechanics (3 ``q_over_trace`` in 3D, 2 in 2D). No column is called
``q_over_p``: read with either meaning, it would be wrong by a factor of 3.

Strains: ``eps_xx`` ... are small strains for the micromechanical models and logarithmic
strains ln(L0/L) for discrete samples in a box of walls (seed 002 eq. 8); ``eps_vol`` is
their trace (seed 002 eq. 9) and ``eps_q`` = eps_1 - eps_3, the largest minus the smallest
principal strain (seed 002 eq. 10). :mod:`grainlab.result.invariants` computes the
invariant columns for every producer.

Columns a specimen cannot provide are absent; columns not listed here (descriptors of a
particular specimen) carry their unit in the result's metadata.

>>> COLUMNS["q_over_3"].unit, unit_of("eps_vol"), unit_of("not a column")
('Pa', '-', '')
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Column:
    """Unit and meaning of one standard column."""

    unit: str
    meaning: str


def _columns(*rows: tuple[str, str, str]) -> dict[str, Column]:
    return {name: Column(unit, meaning) for name, unit, meaning in rows}


COLUMNS: dict[str, Column] = _columns(
    # bookkeeping
    ("increment", "-", "index of the recorded increment (element tests)"),
    ("stage", "-", "name of the loading stage"),
    ("step", "-", "step within the stage (element tests) or of the simulation (discrete)"),
    ("time", "s", "simulated time (discrete samples)"),
    ("dt", "s", "time step (discrete samples)"),
    # stress
    ("sigma_xx", "Pa", "normal stress on x faces"),
    ("sigma_yy", "Pa", "normal stress on y faces"),
    ("sigma_zz", "Pa", "normal stress on z faces"),
    ("sigma_xy", "Pa", "shear stress xy (symmetric part)"),
    ("sigma_xz", "Pa", "shear stress xz (symmetric part)"),
    ("sigma_yz", "Pa", "shear stress yz (symmetric part)"),
    ("wall_sigma_xx", "Pa", "wall reaction over the face area, x walls (discrete samples)"),
    ("wall_sigma_yy", "Pa", "wall reaction over the face area, y walls (discrete samples)"),
    ("wall_sigma_zz", "Pa", "wall reaction over the face area, z walls (discrete samples)"),
    ("cell_sigma_xx", "Pa", "stress xx the contacts with images carry across the "
                             "periodic cell's faces"),
    ("cell_sigma_yy", "Pa", "stress yy the contacts with images carry across the "
                             "periodic cell's faces"),
    ("cell_sigma_zz", "Pa", "stress zz the contacts with images carry across the "
                             "periodic cell's faces"),
    ("cell_sigma_yz", "Pa", "stress yz the contacts with images carry across the "
                             "periodic cell's faces"),
    ("cell_sigma_xz", "Pa", "stress xz the contacts with images carry across the "
                             "periodic cell's faces"),
    ("cell_sigma_xy", "Pa", "stress xy the contacts with images carry across the "
                             "periodic cell's faces"),
    ("sigma_1", "Pa", "major principal stress"),
    ("sigma_2", "Pa", "intermediate principal stress (3D only)"),
    ("sigma_3", "Pa", "minor principal stress"),
    ("p", "Pa", "mean stress tr(sigma)/d (seed 002 eq. 4)"),
    ("q", "Pa", "deviator sigma_1 - sigma_3"),
    ("q_over_3", "Pa", "(sigma_1 - sigma_3)/3, the q of seeds 002/003 (seed 002 eq. 5)"),
    ("q_over_trace", "-", "q / tr(sigma), the seeds' q/p: (q/3)/p in 3D (seed 002 eqs. 5, "
                          "11), (sigma_1 - sigma_3)/(sigma_1 + sigma_3) in 2D"),
    ("eta", "-", "q/p, the critical-state stress ratio (3 q_over_trace in 3D)"),
    ("sin_phi", "-", "mobilised friction (sigma_1 - sigma_3)/(sigma_1 + sigma_3) (seed 002 "
                     "eq. 11 when sigma_2 = sigma_3)"),
    ("stress_ratio", "-", "principal stress ratio sigma_1/sigma_3"),
    ("b", "-", "intermediate principal stress ratio (sigma_2 - sigma_3)/(sigma_1 - sigma_3) "
               "(3D)"),
    # strain
    ("eps_xx", "-", "normal strain xx (logarithmic for discrete samples)"),
    ("eps_yy", "-", "normal strain yy (logarithmic for discrete samples)"),
    ("eps_zz", "-", "normal strain zz (logarithmic for discrete samples)"),
    ("gamma_xy", "-", "engineering shear strain 2 eps_xy"),
    ("gamma_xz", "-", "engineering shear strain 2 eps_xz"),
    ("gamma_yz", "-", "engineering shear strain 2 eps_yz"),
    ("eps_vol", "-", "volumetric strain, the trace of the strain (seed 002 eq. 9)"),
    ("eps_q", "-", "deviatoric strain eps_1 - eps_3, largest minus smallest principal strain "
                   "(seed 002 eq. 10)"),
    # packing and contacts
    ("void_ratio", "-", "void volume over solid volume"),
    ("packing_fraction", "-", "solid volume over total volume"),
    ("z", "-", "coordination number: 2 x loaded particle pairs / particles (discrete)"),
    ("z_c", "-", "connectivity number (seed 002 eq. 14)"),
    ("z_no_rattlers", "-", "coordination number without rattlers"),
    ("z_c_no_rattlers", "-", "connectivity number without rattlers"),
    ("z_core", "-", "coordination number of the particles >= <d> from every wall"),
    ("K0", "-", "(sigma_xx + sigma_yy) / (2 sigma_zz): lateral over vertical stress of a "
                "one-dimensional (oedometric) stage"),
    ("z_c_core", "-", "connectivity number of the particles >= <d> from every wall"),
    ("z_c_points", "-", "2 x loaded solver points between particles / particles"),
    ("z_mechanical", "-", "mechanical coordination 2 (C_pp + C_pw) / N_m without rattlers"),
    ("rattler_fraction", "-", "fraction of particles left with fewer than 2 loaded pairs "
                              "after removing such particles repeatedly"),
    ("fraction_fv", "-", "proportion of face-vertex pairs among loaded polyhedron pairs"),
    ("fraction_ee", "-", "proportion of edge-edge pairs among loaded polyhedron pairs"),
    ("fraction_fe", "-", "proportion of face-edge pairs among loaded polyhedron pairs"),
    ("fraction_ff", "-", "proportion of face-face pairs among loaded polyhedron pairs"),
    ("n_contacts", "-", "contact points seen by the solver"),
    ("friction", "-", "interparticle friction coefficient of the stage"),
    ("inertia_number", "-", "I = max strain rate <d> sqrt(rho / p)"),
    ("kinetic_energy", "J", "kinetic energy of the particles"),
    ("kinetic_energy_ratio", "-", "kinetic energy over N p <d>^3"),
    ("velocity_zigzag", "-", "change of the contacts' relative velocities over the last "
     "half sub-step, over themselves (soft-contact DEM)"),
    ("unbalanced_force_ratio", "-", "mean net force on a particle over the mean contact force"),
    ("max_overlap_over_d", "-", "largest overlap over the mean diameter"),
    # solvers and drivers
    ("solver_iterations", "-", "contact-solver iterations of the step"),
    ("solver_converged", "-", "1 when the contact solver converged, else 0"),
    ("solver_change", "-", "last relative impulse change of the contact solver"),
    ("solver_residual", "-", "natural-map residual of the contact solver"),
    ("frame_angle", "rad", "rotation of the element test's control frame"),
    ("sub_steps", "-", "sub-steps the element-test driver took for the step"),
    ("iterations", "-", "stress corrections of the step (element tests)"),
    ("stress_error", "-", "relative stress error left after the step (element tests)"),
    ("converged", "-", "whether the element-test step met its stress tolerance"),
)
"""Every standard column: name -> :class:`Column` (unit, meaning)."""


def unit_of(column: str) -> str:
    """Unit of a standard column, or ``""`` for a column grainlab does not know."""
    entry = COLUMNS.get(column)
    return entry.unit if entry is not None else ""


PLANAR_NAMES = {"eps_zz": "eps_yy", "sigma_zz": "sigma_yy", "wall_sigma_zz": "wall_sigma_yy",
                "gamma_xz": "gamma_xy", "sigma_xz": "sigma_xy"}
"""The 2D column of a 3D one that a vertical or a shear in the vertical plane names (the
vertical axis is z in 3D, y in 2D)."""


def in_dimension(column: str, columns) -> str:
    """``column`` as a table of ``columns`` names it: a 3D vertical or shear column becomes
    its 2D one (:data:`PLANAR_NAMES`) in a 2D table (no ``sigma_zz``).

    >>> in_dimension("eps_zz", ["sigma_xx", "sigma_yy", "eps_yy"])
    'eps_yy'
    """
    return PLANAR_NAMES.get(column, column) if "sigma_zz" not in columns else column
