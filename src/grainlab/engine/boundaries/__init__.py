"""The discrete sample's boundaries: the wall box (six servo- or strain-controlled
walls) and the periodic triclinic cell (its velocity gradient and stress servo), behind the
:class:`~grainlab.engine.boundaries.boundary.Boundary` protocol the solvers call.

May import: the engine's body modules and :mod:`grainlab.engine.detect`; never a solver
(:mod:`~grainlab.engine.nscd`, :mod:`~grainlab.engine.dem`).
"""
