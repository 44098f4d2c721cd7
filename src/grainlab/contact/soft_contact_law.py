"""Soft (deformable) contact laws of the explicit DEM solver: linear spring-dashpot and
Hertz-Mindlin, with Coulomb friction, optional rolling resistance (STYLE.md 3, 10).

One contact between body i and body j (j's image in a periodic cell) with overlap
delta = -g > 0 [m] (g the gap), unit normal n from i to j, effective radius
R* = r_i r_j / (r_i + r_j) (a plane: R* = r_j) and effective mass m* = m_i m_j / (m_i + m_j)
(a wall: m* = m_j). U = (U_n, U_T) is the velocity of j relative to i at the contact point
(U_n > 0: separating). The force on j (minus on i) is F = F_n n + F_T with

* **linear** (Cundall & Strack 1979; TRUBALL, YADE's default, seed 001 eq. 2.5 with constant
  k_n, k_s): F_n = k_n delta - c_n U_n, tangential stiffness k_t = ``stiffness_ratio`` k_n,
  damping c = 2 zeta sqrt(m* k), zeta the critical-damping ratio that gives the coefficient
  of restitution e of an isolated contact (:func:`damping_ratio`);
* **Hertz-Mindlin** (no-slip Mindlin tangential stiffness with history, as LIGGGHTS'
  ``model hertz tangential history`` and YADE's ``MindlinPhys``): with
  1/E* = (1 - nu_1^2) / E_1 + (1 - nu_2^2) / E_2 and 1/G* = (2 - nu_1) / G_1 + (2 - nu_2) / G_2
  (G = E / (2 (1 + nu)); two grains of one material: E* = E / (2 (1 - nu^2)),
  G* = E / (4 (2 - nu) (1 + nu)); a wall is of the grains' material, or rigid with
  ``rigid_walls``: E* = E / (1 - nu^2), G* = E / (2 (2 - nu) (1 + nu))) and
  a = sqrt(R* delta) [m]:
  F_n = (4/3) E* sqrt(R*) delta^(3/2) - c_n U_n, tangent stiffnesses S_n = 2 E* a and
  k_t = S_t = 8 G* a, damping c = -2 sqrt(5/6) beta sqrt(S m*) (the form of Tsuji, Tanaka &
  Ishida 1992 as LIGGGHTS writes it: c grows as delta^(1/4) and the restitution e does not
  depend on the impact speed), beta < 0 found for the e set (:func:`tsuji_beta`).

The normal force is never attractive: F_n = max(0, F_n) (a dashpot cannot pull the grains
together as they separate). The contact then ends before the overlap closes, so the damping
of both laws is found from e for such a force (the textbook formulas, which assume a pull at
the end, give e too high: 0.58 for 0.5 with linear springs); an isolated impact restitutes
e as set. The tangential spring carries an elastic force F_e (3,) [N] from the step the
contact formed: each step it is turned with the contact frame (its normal part removed and its
length kept, then turned about n by the mean spin of the two bodies about n; no spurious force
under a rigid rotation of the pair), then loaded incrementally, dF_e = -k_t U_T dt with the
stiffness of the moment (Mindlin's no-slip law with history as YADE's ``MindlinPhys``; storing
the displacement instead and taking F = -k_t(delta) xi, as LIGGGHTS does, makes energy when
k_t falls during the rebound: a sphere hitting a plane 2 degrees from the normal came back
with 1.004 of its tangential speed). F_T = F_e - c_t U_T and, when |F_T| > mu F_n, F_T is
scaled back onto the Coulomb limit and F_e set to the force that gives it (F_T + c_t U_T).

Rolling resistance (optional, mu_r > 0; the elastic-plastic spring of Iwashita & Oda 1998
and Ai et al. 2011, LIGGGHTS' ``epsd2``): a moment M_r (3,) [N m] on j (minus on i) with
rolling stiffness k_r = 2.25 k_n mu_r^2 R*^2 (k_n: the normal tangent stiffness),
dM_r = -k_r (omega_j - omega_i)_T dt, |M_r| <= mu_r R* F_n.

Stiffness number (Roux & Combe 2002; Agnolin & Roux 2007): the level of confining stress
sigma0 [Pa] against the grains' stiffness, kappa = k_n / (sigma0 <d>) for linear springs and
kappa = (E / ((1 - nu^2) sigma0))^(2/3) for Hertz. The mean overlap of a packing under sigma0
is of order <d> / kappa: kappa >= 1e4 gives quasi-rigid grains, whose macroscopic response
(q/p, packing fraction, fabric) no longer depends on kappa; at kappa = 1e3 the packing is a
little denser and stiffer in its elastic range, below 1e2 the grains' deformation dominates.

>>> law = SoftContactLaw.hertz_mindlin(young_modulus=1e9, poisson_ratio=0.25, restitution=0.5)
>>> round(law.effective_young_modulus, 1), round(law.effective_shear_modulus, 1)
(533333333.3, 114285714.3)
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np
from numba import njit
from scipy.integrate import solve_ivp

from grainlab._validate import at_least, in_range, positive
from grainlab._vector_loops import root
from grainlab.errors import InputError

LINEAR = 0
"""Code of the linear spring-dashpot law in :attr:`SoftContactLaw.code`."""
HERTZ_MINDLIN = 1
"""Code of the Hertz-Mindlin law."""
LAW_NAMES = ("linear", "hertz_mindlin")
"""Names of the law codes, in code order."""
RAYLEIGH_FRACTION = 0.2
"""Default time step of Hertz-Mindlin: this fraction of the Rayleigh time of the smallest
grain (LIGGGHTS' and YADE's users' rule)."""
COLLISION_FRACTION = 0.2
"""Default time step of linear springs: this fraction of the collision time
pi sqrt(m / (2 k)) of two of the lightest grains on the stiffer spring."""


@njit(inline="always")
def contact_law(code, params, overlap, r_eff, m_eff):
    """Normal elastic force F_n,e [N], normal tangent stiffness S_n [N/m], tangential stiffness
    k_t [N/m] and damping coefficients c_n, c_t [N s/m] of one contact with ``overlap``
    delta > 0 [m], effective radius ``r_eff`` [m] and mass ``m_eff`` [kg] (module docstring;
    ``params``: a row of :attr:`SoftContactLaw.params`). Square roots as LLVM's intrinsic
    (the same results as ``math.sqrt``), so that the law vectorizes
    (:mod:`grainlab.engine.dem.sphere_rows`)."""
    if code == LINEAR:
        k_n = params[0]
        c_n = 2.0 * params[2] * root(m_eff * k_n)
        return k_n * overlap, k_n, params[1] * k_n, c_n, params[3] * c_n
    e_star, g_star, beta = params[0], params[1], params[2]
    a = root(r_eff * overlap)
    s_n = 2.0 * e_star * a
    c_n = -2.0 * root(5.0 / 6.0) * beta * root(s_n * m_eff)
    # c_t / c_n = sqrt(k_t / S_n), a constant of the law (params[3]): one square root less
    return 2.0 / 3.0 * s_n * overlap, s_n, 8.0 * g_star * a, c_n, params[3] * c_n


def linear_restitution(zeta: float) -> float:
    """Coefficient of restitution of an isolated linear spring-dashpot contact of damping
    ratio ``zeta`` whose force is never attractive (Schwager & Poeschel 2007): the contact
    ends when k delta - c U_n reaches 0, and e = -U_n(t*) / U_n(0).

    * Underdamped (zeta < 1): omega_d t* = pi - atan(2 zeta sqrt(1 - zeta^2) /
      (1 - 2 zeta^2)).
    * Critically damped and overdamped (zeta >= 1): delta(t) = U (e^(-a w t) - e^(-b w t)) /
      ((b - a) w) with b = zeta + sqrt(zeta^2 - 1) and a = 1 / b; the force
      m delta'' vanishes at the inflection, e^((b - a) w t*) = b^2 / a^2, where
      e = a^2 e^(-a w t*) (e^-2 = 0.1353 at zeta = 1, about 1 / (4 zeta^2) for large zeta):
      e > 0 for every finite zeta, so every e in (0, 1] has its zeta.
    """
    if zeta <= 0.0:
        return 1.0
    if zeta >= 1.0:
        b = zeta + math.sqrt(zeta * zeta - 1.0)
        a = 1.0 / b
        # w t* = 4 ln b / (b - a), and 2 / 1 at b = 1 (critical)
        scaled = 2.0 if b - a == 0.0 else 4.0 * math.log(b) / (b - a)
        return a * a * math.exp(-a * scaled)
    root = math.sqrt(1.0 - zeta * zeta)
    phase = math.pi - math.atan2(2.0 * zeta * root, 1.0 - 2.0 * zeta * zeta)
    # U_n(t) / U_n(0) = e^{-zeta w t} (cos(w_d t) - zeta / root sin(w_d t)), w_d t = phase
    decay = math.exp(-zeta / root * phase)
    return -decay * (math.cos(phase) - zeta / root * math.sin(phase))


@njit(cache=True)
def hertz_restitution(gamma: float) -> float:
    """Coefficient of restitution of an isolated Hertz contact with the damping of the module
    docstring, its force never attractive, in units where m* = 1, (4/3) E* sqrt(R*) = 1 and
    the impact speed is 1 (e does not depend on the speed): x'' = -max(0, x^(3/2) +
    gamma x^(1/4) x'), gamma = 2 sqrt(5/6) |beta| sqrt(3/2); RK4 until the force vanishes."""
    h = 2e-4
    x, v = 0.0, 1.0  # overlap and its rate

    def acceleration(x, v):
        if x <= 0.0:
            return 0.0
        return -max(0.0, x**1.5 + gamma * x**0.25 * v)

    for _ in range(1_000_000):
        k1x, k1v = v, acceleration(x, v)
        k2x, k2v = v + 0.5 * h * k1v, acceleration(x + 0.5 * h * k1x, v + 0.5 * h * k1v)
        k3x, k3v = v + 0.5 * h * k2v, acceleration(x + 0.5 * h * k2x, v + 0.5 * h * k2v)
        k4x, k4v = v + h * k3v, acceleration(x + h * k3x, v + h * k3v)
        x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x)
        v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
        if v < 0.0 and (x <= 0.0 or x**1.5 + gamma * x**0.25 * v <= 0.0):
            return -v
    return -v


STIFF_GAMMA = 20.0
"""Largest gamma (:func:`hertz_restitution`) integrated with its fixed step; beyond it (e below
:func:`hertz_restitution` (20) = 0.0030) the rebound lasts ~gamma^1.2 time units, and
:func:`stiff_hertz_restitution` integrates with an adaptive step."""


def stiff_hertz_restitution(gamma: float) -> float:
    """:func:`hertz_restitution` for a large gamma (> :data:`STIFF_GAMMA`): the same equation
    by SciPy's LSODA with a terminal event where the force vanishes on the rebound
    (relative tolerance 1e-11). There e approaches 1.25 / gamma^2 from below (1.2418 / gamma^2
    at gamma = 50, 1.24996 / gamma^2 at 1000)."""

    def motion(_, y):
        x, v = y
        if x <= 0.0:
            return [v, 0.0]
        return [v, -max(0.0, x**1.5 + gamma * x**0.25 * v)]

    def released(_, y):
        x, v = y
        if v >= 0.0:
            return 1.0
        return x**1.5 + gamma * x**0.25 * v if x > 0.0 else -1.0

    released.terminal = True
    released.direction = -1.0
    path = solve_ivp(motion, (0.0, math.inf), [0.0, 1.0], method="LSODA", rtol=1e-11,
                     atol=1e-14, events=released)
    return float(-path.y[1, -1])


def _bisect(function, target: float, low: float, high: float, halvings: int = 60) -> float:
    """The x in [low, high] where the decreasing ``function`` reaches ``target``."""
    for _ in range(halvings):
        middle = 0.5 * (low + high)
        if function(middle) > target:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


@lru_cache(maxsize=64)
def damping_ratio(restitution: float) -> float:
    """zeta of the linear law giving ``restitution`` e in (0, 1] (:func:`linear_restitution`;
    0 for e = 1): the spring-dashpot's zeta = -ln e / sqrt(pi^2 + ln^2 e) corrected for a force
    that never pulls; below e^-2 = 0.1353 (zeta = 1) on the overdamped branch, where
    1 <= zeta <= 1 / (2 sqrt(e)) (e < 1 / (4 zeta^2) there)."""
    e = _restitution(restitution)
    if e >= 1.0:
        return 0.0
    if e >= linear_restitution(1.0):
        return _bisect(linear_restitution, e, 0.0, 1.0)
    return _bisect(linear_restitution, e, 1.0, max(1.0, 0.5 / math.sqrt(e)))


@lru_cache(maxsize=64)
def tsuji_beta(restitution: float) -> float:
    """beta (< 0) of the Hertz-Mindlin damping giving ``restitution`` e in (0, 1]
    (:func:`hertz_restitution`; 0 for e = 1). The Antypov & Elliott value
    ln e / sqrt(ln^2 e + pi^2) is exact only with a force that may pull at the end of the
    impact; with one that never pulls (here) it gives e too high (0.55 for 0.5). Below
    e(:data:`STIFF_GAMMA`) = 0.0030, gamma lies in [sqrt(1.2 / e), sqrt(1.25 / e)]
    (:func:`stiff_hertz_restitution`)."""
    e = _restitution(restitution)
    if e >= 1.0:
        return 0.0
    scale = 2.0 * math.sqrt(5.0 / 6.0) * math.sqrt(1.5)
    if e >= hertz_restitution(STIFF_GAMMA):
        gamma = _bisect(lambda g: hertz_restitution(g), e, 0.0, STIFF_GAMMA)
    else:
        gamma = _bisect(stiff_hertz_restitution, e, max(STIFF_GAMMA, math.sqrt(1.2 / e)),
                        max(STIFF_GAMMA, math.sqrt(1.25 / e)), 40)
    return -gamma / scale


def _restitution(value: float) -> float:
    """``value`` as a coefficient of restitution in (0, 1], else :class:`InputError`."""
    return in_range("restitution", value, 0.0, 1.0, closed="(]")


@dataclass(frozen=True)
class SoftContactLaw:
    """Parameters of a soft contact law (module docstring). Build it with
    :meth:`linear` or :meth:`hertz_mindlin` (material constants) or :meth:`from_kappa`
    (the stiffness number).

    Attributes
    ----------
    model:
        ``"linear"`` or ``"hertz_mindlin"``.
    normal_stiffness:
        k_n [N/m] (linear).
    stiffness_ratio:
        k_t / k_n (linear), > 0.
    young_modulus, poisson_ratio:
        E [Pa] and nu (Hertz-Mindlin), nu in (-1, 0.5).
    restitution:
        Coefficient of restitution e of a normal impact, in (0, 1].
    rolling_friction:
        mu_r >= 0 (0: none), a length ratio: the moment limit is mu_r R* F_n.
    local_damping:
        alpha in [0, 1): the non-viscous damping of YADE and PFC, F <- F - alpha |F|
        sign(v) per component of each body's net force and moment (0: none; it is not
        physical and serves quasi-static runs only).
    time_step_fraction:
        The time step as a fraction of the Rayleigh time (Hertz-Mindlin) or of the collision
        time pi sqrt(m / (2 k)) (linear) of the lightest grains, in (0, 1].
    rigid_walls:
        Hertz-Mindlin: walls infinitely stiff (default False: walls of the grains'
        material). Linear springs: walls take the grains' k_n, k_t either way.
    """

    model: str
    normal_stiffness: float = 0.0
    stiffness_ratio: float = 0.5
    young_modulus: float = 0.0
    poisson_ratio: float = 0.25
    restitution: float = 0.5
    rolling_friction: float = 0.0
    local_damping: float = 0.0
    time_step_fraction: float = 0.2
    rigid_walls: bool = False

    def __post_init__(self) -> None:
        if self.model not in LAW_NAMES:
            raise InputError("model", self.model, " or ".join(f'"{n}"' for n in LAW_NAMES))
        if self.model == "linear":
            positive("normal_stiffness", self.normal_stiffness, "N/m")
            positive("stiffness_ratio", self.stiffness_ratio)
        else:
            positive("young_modulus", self.young_modulus, "Pa")
            in_range("poisson_ratio", self.poisson_ratio, -1.0, 0.5)
        in_range("restitution", self.restitution, 0.0, 1.0, closed="(]")
        at_least("rolling_friction", self.rolling_friction, strict=False)
        in_range("local_damping", self.local_damping, 0.0, 1.0, closed="[)")
        in_range("time_step_fraction", self.time_step_fraction, 0.0, 1.0, closed="(]")

    # -- constructors --------------------------------------------------------------------------
    @classmethod
    def linear(cls, normal_stiffness: float, stiffness_ratio: float = 0.5,
               restitution: float = 0.5, **options) -> SoftContactLaw:
        """Linear springs k_n [N/m], k_t = ``stiffness_ratio`` k_n, with restitution e."""
        return cls("linear", normal_stiffness=normal_stiffness,
                   stiffness_ratio=stiffness_ratio, restitution=restitution,
                   time_step_fraction=options.pop("time_step_fraction",
                                                  COLLISION_FRACTION), **options)

    @classmethod
    def hertz_mindlin(cls, young_modulus: float, poisson_ratio: float = 0.25,
                      restitution: float = 0.5, **options) -> SoftContactLaw:
        """Hertz-Mindlin grains of Young's modulus E [Pa] and Poisson's ratio nu."""
        return cls("hertz_mindlin", young_modulus=young_modulus,
                   poisson_ratio=poisson_ratio, restitution=restitution,
                   time_step_fraction=options.pop("time_step_fraction", RAYLEIGH_FRACTION),
                   **options)

    @classmethod
    def from_kappa(cls, model: str, kappa: float, confining_stress: float,
                   mean_diameter: float, **options) -> SoftContactLaw:
        """The law whose stiffness number at ``confining_stress`` sigma0 [Pa] and
        ``mean_diameter`` <d> [m] is ``kappa`` (module docstring): k_n = kappa sigma0 <d>
        (linear) or E = (1 - nu^2) sigma0 kappa^(3/2) (Hertz-Mindlin)."""
        kappa = positive("kappa", kappa)
        sigma0 = positive("confining_stress", confining_stress, "Pa")
        diameter = positive("mean_diameter", mean_diameter, "m")
        if model == "linear":
            return cls.linear(kappa * sigma0 * diameter, **options)
        if model == "hertz_mindlin":
            nu = options.pop("poisson_ratio", 0.25)
            return cls.hertz_mindlin((1.0 - nu * nu) * sigma0 * kappa**1.5, nu, **options)
        raise InputError("model", model, " or ".join(f'"{n}"' for n in LAW_NAMES))

    # -- derived -------------------------------------------------------------------------------
    @property
    def code(self) -> int:
        """:data:`LINEAR` or :data:`HERTZ_MINDLIN`."""
        return LAW_NAMES.index(self.model)

    @property
    def effective_young_modulus(self) -> float:
        """E* = E / (2 (1 - nu^2)) [Pa] of two grains of this material."""
        return self.young_modulus / (2.0 * (1.0 - self.poisson_ratio**2))

    @property
    def effective_shear_modulus(self) -> float:
        """G* = E / (4 (2 - nu) (1 + nu)) [Pa] of two grains of this material."""
        nu = self.poisson_ratio
        return self.young_modulus / (4.0 * (2.0 - nu) * (1.0 + nu))

    @property
    def params(self) -> np.ndarray:
        """(2, 4) the compiled law's parameters, row 0 between grains and row 1 with a wall:
        (k_n, k_t/k_n, zeta, c_t/c_n) or (E*, G*, beta, c_t/c_n), with c_t/c_n =
        sqrt(k_t / S_n) the same at every overlap (k_t/k_n, or 4 G*/E* for Hertz-Mindlin)."""
        if self.model == "linear":
            ratio = self.stiffness_ratio
            row = [self.normal_stiffness, ratio, damping_ratio(self.restitution),
                   math.sqrt(ratio)]
            return np.array([row, row])
        beta = tsuji_beta(self.restitution)
        e_star, g_star = self.effective_young_modulus, self.effective_shear_modulus
        ratio = math.sqrt(4.0 * g_star / e_star)
        wall = 2.0 if self.rigid_walls else 1.0
        return np.array([[e_star, g_star, beta, ratio],
                         [wall * e_star, wall * g_star, beta, ratio]])

    def kappa(self, confining_stress: float, mean_diameter: float) -> float:
        """The stiffness number at sigma0 [Pa] and <d> [m] (module docstring)."""
        if self.model == "linear":
            return self.normal_stiffness / (confining_stress * mean_diameter)
        modulus = self.young_modulus / (1.0 - self.poisson_ratio**2)
        return (modulus / confining_stress) ** (2.0 / 3.0)

    def rayleigh_time(self, radius: float, density: float) -> float:
        """T_R = pi R sqrt(rho / G) / (0.1631 nu + 0.8766) [s] of a sphere of radius R [m]
        and density rho [kg/m^3] (Hertz-Mindlin; G = E / (2 (1 + nu)))."""
        nu = self.poisson_ratio
        shear = self.young_modulus / (2.0 * (1.0 + nu))
        return math.pi * radius * math.sqrt(density / shear) / (0.1631 * nu + 0.8766)

    def time_step(self, lightest_mass: float, smallest_radius: float, density: float) -> float:
        """The springs' rule for the explicit time step [s]: :attr:`time_step_fraction` of the
        Rayleigh time of the smallest grain (radius [m], density [kg/m^3]), or of the
        collision time pi sqrt(m / (2 max(k_n, k_t))) of two grains of the lightest mass [kg]
        (0.2 of it is 0.44 sqrt(m / k)). It does not see the dashpots, which the explicit
        scheme takes with the half-step velocity: the solver also keeps the sub-step within
        their bound (:mod:`grainlab.engine.dem.soft_stability`; a lattice of twelve-fold
        contacts at e = 0.5 is unstable at this step alone)."""
        if self.model == "hertz_mindlin":
            return self.time_step_fraction * self.rayleigh_time(smallest_radius, density)
        stiffest = self.normal_stiffness * max(1.0, self.stiffness_ratio)
        return self.time_step_fraction * math.pi * math.sqrt(0.5 * lightest_mass / stiffest)

    def describe(self) -> dict:
        """Parameters as plain data (metadata, checkpoints)."""
        return asdict(self)


def hertz_impact(law: SoftContactLaw, effective_radius: float, effective_mass: float,
                 speed: float, wall: bool = False) -> dict[str, float]:
    """Closed form of an undamped Hertz normal impact at relative ``speed`` [m/s]: largest
    overlap delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5) [m], peak force
    (4/3) E* sqrt(R*) delta_max^(3/2) [N] and contact duration
    2.8683 (m*^2 / (R* E*^2 v))^(1/5) [s] (Johnson 1985, sec. 11.2); ``wall``: against a
    wall (E* of :attr:`SoftContactLaw.params` row 1)."""
    e_star = float(law.params[1 if wall else 0, 0])
    delta = (15.0 * effective_mass * speed**2 / (16.0 * e_star * math.sqrt(effective_radius))
             ) ** 0.4
    return {
        "max_overlap": delta,
        "peak_force": 4.0 / 3.0 * e_star * math.sqrt(effective_radius) * delta**1.5,
        "duration": 2.8683 * (effective_mass**2 / (effective_radius * e_star**2 * speed)) ** 0.2,
    }
