"""Small-strain moduli of an isotropic packing of equal elastic spheres (seed 001 §4.1).

Closed forms of seed 001 (eqs. 4.1–4.6), for Hertz–Mindlin contacts (alpha = 1/3,
C1 = 3^(1/3), E_mu = G_mu/(1 - nu_mu), k_r/k_n = C2 = 2(1 - nu_mu)/(2 - nu_mu)):

* nu = nu_mu / (10 - 6 nu_mu)                                  (eq. 4.1)
* G = F(z) P(E_mu) sigma_c^alpha, F(z) = z^(1-alpha)/10,
  P(E_mu) = C1 (2 + C2) E_mu^(1-alpha)                         (eqs. 4.2, 4.3, 4.5)
* z = (M / 3V) r^3 = n_bar / (4 pi (1 + e)), M/V the double-counted contacts per volume (4.4).

Under the uniform-strain hypothesis the same packing has the shear modulus
G = (M r^2 / (2V)) (2 k_n + 3 k_r) / 15 ... which with the Hertzian k_n at the contact force
f = sigma_c r^2 / z (from sigma_c = (1/(6V)) M f 2r) becomes
G_uniform = (1/5) (2 + 3 C2) C1 z^(1-alpha) E_mu^(1-alpha) sigma_c^alpha.
The OCR'd eq. 4.5 gives (1/10)(2 + C2) in place of (1/5)(2 + 3 C2): the two differ by
2 (2 + 3 C2)/(2 + C2) (about 3.2 for nu_mu = 0.2). Both are offered; the model reproduces the
uniform-strain value exactly (tests), and eq. 4.1 holds for both.
"""

from __future__ import annotations

import numpy as np

from grainlab._validate import in_range, positive
from grainlab.contact.spring_contact import HERTZ_ALPHA, HERTZ_C1, mindlin_c2


def poisson_ratio_eq41(grain_poisson_ratio: float) -> float:
    """nu = nu_mu / (10 - 6 nu_mu) [-] (seed 001 eq. 4.1).

    >>> round(poisson_ratio_eq41(0.2), 6)
    0.022727
    """
    nu = in_range("grain_poisson_ratio", grain_poisson_ratio, 0.0, 0.5, closed="[)")
    return nu / (10.0 - 6.0 * nu)


def packing_parameter_z(coordination_number: float, void_ratio: float) -> float:
    """z = n_bar / (4 pi (1 + e)) [-] (seed 001 eq. 4.4)."""
    positive("coordination_number", coordination_number)
    in_range("void_ratio", void_ratio, 0.0, np.inf, closed="[)")
    return coordination_number / (4.0 * np.pi * (1.0 + void_ratio))


def shear_modulus_eq42(
    z: float, grain_shear_modulus: float, grain_poisson_ratio: float, confining_stress: float,
    alpha: float = HERTZ_ALPHA, c1: float = HERTZ_C1,
) -> float:
    """G = F(z) P(E_mu) sigma_c^alpha as printed in seed 001 eqs. 4.2–4.6 [Pa]."""
    e_mu = positive("grain_shear_modulus", grain_shear_modulus, "Pa") / (1.0 - grain_poisson_ratio)
    c2 = mindlin_c2(grain_poisson_ratio)
    f_z = z ** (1.0 - alpha) / 10.0
    p_e = c1 * (2.0 + c2) * e_mu ** (1.0 - alpha)
    return f_z * p_e * positive("confining_stress", confining_stress, "Pa") ** alpha


def shear_modulus_uniform_strain(
    z: float, grain_shear_modulus: float, grain_poisson_ratio: float, confining_stress: float,
) -> float:
    """Uniform-strain shear modulus of the isotropic Hertz–Mindlin packing [Pa]:
    (1/5)(2 + 3 C2) C1 z^(2/3) E_mu^(2/3) sigma_c^(1/3) (derivation in the module docstring)."""
    e_mu = positive("grain_shear_modulus", grain_shear_modulus, "Pa") / (1.0 - grain_poisson_ratio)
    c2 = mindlin_c2(grain_poisson_ratio)
    a = HERTZ_ALPHA
    return (0.2 * (2.0 + 3.0 * c2) * HERTZ_C1 * z ** (1 - a) * e_mu ** (1 - a)
            * positive("confining_stress", confining_stress, "Pa") ** a)
