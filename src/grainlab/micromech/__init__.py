"""Micromechanical theories: specimens whose response is predicted from contact laws and
packing geometry (seed 000's regular packings; seed 001's micro-element model to come)."""

from grainlab.micromech.regular_packing import (
    RegularPackingModel,
    RegularPackingState,
    RotatedStressPath,
    run_rotated_stress_path,
)

__all__ = [
    "RegularPackingModel",
    "RegularPackingState",
    "RotatedStressPath",
    "run_rotated_stress_path",
]
