"""Incremental stress–strain theory of regular packings of multi-sized discs (seed 000)."""

from grainlab.micromech.regular_packing.alpha_sweep import run_alpha_sweep, value_at_ratio
from grainlab.micromech.regular_packing.model import RegularPackingModel, RegularPackingState
from grainlab.micromech.regular_packing.stress_path import RotatedStressPath
from grainlab.micromech.regular_packing.stress_path_test import (
    consolidate_isotropically,
    run_rotated_stress_path,
)

__all__ = [
    "RegularPackingModel",
    "RegularPackingState",
    "RotatedStressPath",
    "consolidate_isotropically",
    "run_alpha_sweep",
    "run_rotated_stress_path",
    "value_at_ratio",
]
