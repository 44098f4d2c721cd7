"""Non-smooth contact dynamics (Moreau-Jean time stepping with the nonlinear Gauss-Seidel
contact solve; research/cd_engines.md): the per-contact update, the Delassus blocks, the
serial and coloured (parallel) sweeps, the contact colouring and the plain frictional contact
problem with the methods that solve it offline.

May import: the engine's neutral modules (bodies, :mod:`~grainlab.engine.step_report`,
:mod:`~grainlab.engine.solver`, :mod:`~grainlab.engine.simulation`), detection and the
boundaries; never :mod:`grainlab.engine.dem`.
"""
