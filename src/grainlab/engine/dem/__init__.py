"""Soft-contact discrete elements (explicit velocity Verlet with force laws of
:mod:`grainlab.contact`): one sub-step loop (:mod:`~grainlab.engine.dem.substep_loop`) given a
contact list's force pass (member spheres: :mod:`~grainlab.engine.dem.soft_contact_kernels`;
polyhedra: :mod:`~grainlab.engine.dem.soft_polyhedra_kernels`) and the boundary's compiled
faces, the stable sub-step and the soft step's report.

May import: the engine's neutral modules (bodies, :mod:`~grainlab.engine.step_report`,
:mod:`~grainlab.engine.solver`, :mod:`~grainlab.engine.simulation`), detection and the
boundaries; never :mod:`grainlab.engine.nscd`.
"""
