"""Geometry: shapes, periodic cells, packings of particles and their tessellations.

Pure functions and frozen value objects on numpy arrays; nothing here knows about forces.
"""

from grainlab.geometry.disc_contacts import DiscContacts, find_disc_contacts
from grainlab.geometry.disc_packing import DiscPacking2D
from grainlab.geometry.periodic_cell import PeriodicCell2D
from grainlab.geometry.power_tessellation import PowerTessellation, power_tessellation
from grainlab.geometry.rotation import rotation_matrix_2d
from grainlab.geometry.triclinic_cell import TriclinicCell

__all__ = [
    "DiscContacts",
    "DiscPacking2D",
    "PeriodicCell2D",
    "PowerTessellation",
    "TriclinicCell",
    "find_disc_contacts",
    "power_tessellation",
    "rotation_matrix_2d",
]
