"""Soft-contact discrete elements (explicit velocity Verlet with force laws of
:mod:`grainlab.contact`): the force pass, the integration sub-steps of spheres, aggregates and
polyhedra, the stable sub-step and the soft step's report.

May import: the engine's neutral modules (bodies, :mod:`~grainlab.engine.step_report`,
:mod:`~grainlab.engine.solver`, :mod:`~grainlab.engine.simulation`), detection and the
boundaries; never :mod:`grainlab.engine.nscd`.
"""
