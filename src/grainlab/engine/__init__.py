"""The discrete engine: bodies as structure-of-arrays state, a shape library, contact
detection, the sample's boundaries and two solvers; compute kernels are Numba functions over
plain arrays.

Layout, lowest first (``tests/test_layers.py`` holds the engine to it):

* the **bodies** (top-level modules): :mod:`~grainlab.engine.state` (bodies and shape
  library), :mod:`~grainlab.engine.shape_kinds` (what each kind of shape means to the engine),
  :mod:`~grainlab.engine.quaternion`, :mod:`~grainlab.engine.gyroscopic` and
  :mod:`~grainlab.engine.body_order`; they import no sub-package;
* :mod:`~grainlab.engine.detect`: the broad phase, the narrow phase of each shape pair and
  detection in the periodic cell; it imports the bodies only;
* :mod:`~grainlab.engine.boundaries`: the wall box and the periodic cell behind one
  protocol; they import the bodies and detection;
* the **solver-neutral run** (top-level modules): :mod:`~grainlab.engine.step_report` (what a
  step reports, contact frames and keys), :mod:`~grainlab.engine.solver` (the protocol),
  :mod:`~grainlab.engine.discrete_sample`, :mod:`~grainlab.engine.simulation` and
  :mod:`~grainlab.engine.sample_measures`; they never import a solver;
* the two solvers, which never import each other: :mod:`~grainlab.engine.nscd` (contact
  dynamics: Moreau-Jean with nonlinear Gauss-Seidel) and :mod:`~grainlab.engine.dem` (soft
  contacts, explicit sub-steps).

No module of the engine imports a module that imports it back (no cycles, lazy imports
included).
"""
