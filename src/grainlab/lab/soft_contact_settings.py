"""The soft-contact (DEM) settings of a discrete test: which law, how stiff, how damped
(:class:`SoftContactSettings`, the ``[solver.dem]`` table of a run's config).

The stiffness is given either by material constants (``young_modulus`` for Hertz-Mindlin,
``normal_stiffness`` for linear springs) or, when they are 0, by the stiffness number
``kappa`` at the test's confining stress sigma0 and the sample's mean diameter <d>
(:meth:`~grainlab.contact.soft_contact_law.SoftContactLaw.from_kappa`: k_n = kappa sigma0 <d>,
or E = (1 - nu^2) sigma0 kappa^(3/2)). The default, linear springs at kappa = 1e4, gives
quasi-rigid grains (mean overlap about 1e-4 <d>), as the contact-dynamics solver assumes:
both methods then describe the same material.

>>> settings = SoftContactSettings()
>>> law = settings.law_at(confining_stress=1e4, mean_diameter=1e-3)
>>> law.model, law.normal_stiffness
('linear', 100000.0)
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from grainlab._validate import at_least, positive
from grainlab.contact.soft_contact_law import LAW_NAMES, SoftContactLaw
from grainlab.errors import InputError
from grainlab.lab.setting_bounds import bounded


@dataclass(frozen=True)
class SoftContactSettings:
    """How the soft-contact solver models the contacts (module docstring).

    Each field carries what it allows (:func:`~grainlab.lab.setting_bounds.bounded`): the
    ``[solver.dem]`` table of a run's config is made from them.

    Attributes
    ----------
    law:
        ``"linear"`` (spring-dashpot) or ``"hertz_mindlin"``.
    kappa:
        Stiffness number (> 0), used when the law's own constant is 0.
    normal_stiffness:
        k_n [N/m] of linear springs (0: from kappa).
    young_modulus:
        E [Pa] of Hertz-Mindlin grains (0: from kappa).
    poisson_ratio, stiffness_ratio, restitution, rolling_friction, local_damping,
    time_step_fraction, rigid_walls:
        As :class:`~grainlab.contact.soft_contact_law.SoftContactLaw`.
    """

    law: str = bounded("linear", choices=LAW_NAMES)
    kappa: float = bounded(1e4, gt=0)
    normal_stiffness: float = bounded(0.0, ge=0, unit="N/m")
    young_modulus: float = bounded(0.0, ge=0, unit="Pa")
    poisson_ratio: float = bounded(0.25, gt=-1, lt=0.5)
    stiffness_ratio: float = bounded(0.5, gt=0)
    restitution: float = bounded(0.5, gt=0, le=1)
    rolling_friction: float = bounded(0.0, ge=0)
    local_damping: float = bounded(0.0, ge=0, lt=1)
    time_step_fraction: float = bounded(0.2, gt=0, le=1)
    rigid_walls: bool = bounded(False)

    def __post_init__(self) -> None:
        if self.law not in LAW_NAMES:
            raise InputError("law", self.law, " or ".join(f'"{n}"' for n in LAW_NAMES))
        positive("kappa", self.kappa)
        at_least("normal_stiffness", self.normal_stiffness, strict=False)
        at_least("young_modulus", self.young_modulus, strict=False)
        self.law_at(1.0, 1.0)  # every other value checked by the law itself

    def _options(self) -> dict[str, Any]:
        return {"restitution": self.restitution, "rolling_friction": self.rolling_friction,
                "local_damping": self.local_damping,
                "time_step_fraction": self.time_step_fraction, "rigid_walls": self.rigid_walls}

    def law_at(self, confining_stress: float, mean_diameter: float) -> SoftContactLaw:
        """The contact law for sigma0 [Pa] and <d> [m] (module docstring)."""
        options = self._options()
        if self.law == "linear":
            options["stiffness_ratio"] = self.stiffness_ratio
            if self.normal_stiffness > 0.0:
                return SoftContactLaw.linear(self.normal_stiffness, **options)
        else:
            options["poisson_ratio"] = self.poisson_ratio
            if self.young_modulus > 0.0:
                return SoftContactLaw.hertz_mindlin(self.young_modulus, **options)
        return SoftContactLaw.from_kappa(self.law, self.kappa, confining_stress,
                                         mean_diameter, **options)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (the keys of ``[solver.dem]``)."""
        return asdict(self)
