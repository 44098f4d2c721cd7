"""Microstructure of a contact network: stress from contacts (more descriptors to come).

Reads plain arrays only (contact forces, branch vectors, volumes); it never imports the engine.
"""

from grainlab.analysis.contact_stress import principal_stresses_2d, stress_from_contact_dyads

__all__ = ["principal_stresses_2d", "stress_from_contact_dyads"]
