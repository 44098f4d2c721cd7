"""The discrete engine: bodies as structure-of-arrays state, a shape library, detection
(cell-list broad phase, narrow phase per shape pair) and solvers (Moreau–Jean contact dynamics
with nonlinear Gauss–Seidel); compute kernels are Numba functions over plain arrays.

Modules: :mod:`~grainlab.engine.state`, :mod:`~grainlab.engine.shape_kinds` (what each kind
of shape means to the engine, by name or code), :mod:`~grainlab.engine.discrete_sample` (library,
state and walls together), :mod:`~grainlab.engine.quaternion`,
:mod:`~grainlab.engine.broad_phase`, :mod:`~grainlab.engine.narrow_phase`,
:mod:`~grainlab.engine.periodic_detection` (both in a periodic triclinic cell, by ghosts),
:mod:`~grainlab.engine.contact_dynamics`, :mod:`~grainlab.engine.contact_colouring` and
:mod:`~grainlab.engine.nlgs_parallel` (the coloured, parallel NLGS sweep).
"""
