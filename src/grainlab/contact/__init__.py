"""Contact laws: force–displacement relations at one contact, shared by engine and theories.

Pure functions of arrays plus small frozen parameter objects. Forces and stiffnesses in 2D are
per unit length of the cylinders (N/m and N/m^2), as in seed 000.
"""

from grainlab.contact.coulomb import coulomb_limit, friction_mobilisation, is_sliding
from grainlab.contact.law2d import ContactLaw2D, ContactState2D
from grainlab.contact.linear_spring import LinearSpring2D
from grainlab.contact.modified_hertz_mindlin import ModifiedHertzMindlin2D, equivalent_radius

__all__ = [
    "ContactLaw2D",
    "ContactState2D",
    "LinearSpring2D",
    "ModifiedHertzMindlin2D",
    "coulomb_limit",
    "equivalent_radius",
    "friction_mobilisation",
    "is_sliding",
]
