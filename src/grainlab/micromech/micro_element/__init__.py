"""Seed 001's micromechanical constitutive model (contact -> micro-element -> unit)."""

from grainlab.micromech.micro_element.model import MicroElementModel, exponential_series
from grainlab.micromech.micro_element.structure import MicroElementStructure

__all__ = ["MicroElementModel", "MicroElementStructure", "exponential_series"]
