"""The soft contact laws' damping against their restitution (STYLE.md 11): every coefficient of
restitution in (0, 1] has its damping, on the overdamped branch of the linear law too, checked
against a direct integration of the isolated contact; values outside (0, 1] are refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from grainlab.contact.soft_contact_law import (
    STIFF_GAMMA,
    SoftContactLaw,
    damping_ratio,
    hertz_restitution,
    linear_restitution,
    stiff_hertz_restitution,
    tsuji_beta,
)
from grainlab.errors import InputError

GAMMA_PER_BETA = 2.0 * math.sqrt(5.0 / 6.0) * math.sqrt(1.5)
"""gamma of :func:`hertz_restitution` per |beta| of :func:`tsuji_beta`."""


def integrated_linear_restitution(zeta: float) -> float:
    """The rebound of delta'' = -max(0, delta + 2 zeta delta') from delta = 0, delta' = 1
    (unit mass and stiffness): the contact ends where the force vanishes on the way out."""

    def motion(_, y):
        return [y[1], -max(0.0, y[0] + 2.0 * zeta * y[1])]

    def released(_, y):
        return y[0] + 2.0 * zeta * y[1] if y[1] < 0.0 else 1.0

    released.terminal, released.direction = True, -1.0
    path = solve_ivp(motion, (0.0, 1e4), [0.0, 1.0], rtol=1e-11, atol=1e-14,
                     events=released)
    return float(-path.y[1, -1])


@pytest.mark.parametrize("zeta", [0.3, 1.0, 1.5, 4.0])
def test_the_linear_restitution_is_that_of_the_integrated_contact(zeta):
    assert linear_restitution(zeta) == pytest.approx(integrated_linear_restitution(zeta),
                                                     rel=1e-7)


@pytest.mark.parametrize("restitution", [1.0, 0.9, 0.5, 0.2, 0.14, 0.13, 0.1, 0.05, 0.01, 1e-4])
def test_every_linear_restitution_has_its_damping_ratio(restitution):
    zeta = damping_ratio(restitution)
    assert linear_restitution(zeta) == pytest.approx(restitution, rel=1e-9)
    # below e^-2 (critical damping) the contact is overdamped: no floor at e = 0.135
    assert (zeta > 1.0) == (restitution < math.exp(-2.0))


def test_lower_restitutions_need_more_damping():
    values = [damping_ratio(e) for e in (0.2, 0.1, 0.05, 0.02)]
    assert np.all(np.diff(values) > 0.0)


@pytest.mark.parametrize("restitution", [0.9, 0.5, 0.1, 0.05, 0.01, 0.002, 1e-4])
def test_every_hertz_restitution_has_its_tsuji_beta(restitution):
    gamma = -tsuji_beta(restitution) * GAMMA_PER_BETA
    rebound = hertz_restitution(gamma) if gamma <= STIFF_GAMMA \
        else stiff_hertz_restitution(gamma)
    assert rebound == pytest.approx(restitution, rel=1e-6)


def test_the_stiff_integration_continues_the_fixed_step_one():
    assert stiff_hertz_restitution(STIFF_GAMMA) == pytest.approx(
        hertz_restitution(STIFF_GAMMA), rel=1e-4)


@pytest.mark.parametrize("value", [0.0, -0.2, 1.5, math.nan])
def test_a_restitution_outside_zero_to_one_is_refused_naming_the_field(value):
    for function in (damping_ratio, tsuji_beta):
        with pytest.raises(InputError, match=r"restitution .* \(0, 1\]"):
            function(value)
    with pytest.raises(InputError, match="restitution"):
        SoftContactLaw.linear(1e4, restitution=value)
