"""Contact detection: the cell-list broad phase, the narrow phase of each shape pair
(spheres, sphere aggregates, convex polyhedra) and detection in the periodic triclinic cell by
ghost images (Numba kernels over plain arrays).

May import: the engine's body modules (:mod:`~grainlab.engine.state`,
:mod:`~grainlab.engine.quaternion`, :mod:`~grainlab.engine.shape_kinds`) and lower layers;
never a boundary or a solver.
"""
