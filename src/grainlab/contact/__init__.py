"""Contact laws: force–displacement relations at one contact, shared by engine and theories.

Pure functions of arrays plus small frozen parameter objects. Forces and stiffnesses in 2D are
per unit length of the cylinders (N/m and N/m^2), as in seed 000.

The engine's laws are here too, each written once as a scalar function compiled inline
(``@njit(inline="always")``) into every kernel that applies it: the soft solver's normal laws
(:func:`~grainlab.contact.soft_contact_law.contact_law`), its tangential spring with the
Coulomb cap (:mod:`~grainlab.contact.tangential_spring`) and rolling resistance
(:mod:`~grainlab.contact.rolling_resistance`); contact dynamics' Coulomb cone, its projection,
one contact's local solve and natural-map residual (:mod:`~grainlab.contact.coulomb_cone`);
the velocity of a contact point (:mod:`~grainlab.contact.contact_kinematics`). They import
Numba and the vector-loop building blocks (:mod:`grainlab._vector_loops`), no other layer
above geometry.
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
