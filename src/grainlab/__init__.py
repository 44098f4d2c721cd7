"""grainlab — a virtual laboratory for granular materials.

Describe particles (shape, size, friction, stiffness), run the tests a soil or powder laboratory
runs, on a discrete simulation of the packing or on a micromechanical theory of it, and read the
answer in one test-result format.

Layers, lowest first (a lower layer never imports a higher one; ``tests/test_layers.py``):
``result`` (the test-result format) → ``geometry`` → ``contact`` → ``analysis`` → ``engine`` →
``micromech`` → ``prep`` → ``lab`` → ``report`` → ``cli``.

Quick start::

    >>> import grainlab as gl
    >>> packing = gl.named_packing("C")
    >>> round(packing.void_ratio, 4)
    0.1388
"""

import grainlab._numba_setup  # noqa: F401  (threading layer, before any kernel)
from grainlab._version import __version__
from grainlab.errors import (
    ConvergenceError,
    GeometryError,
    GrainlabError,
    GrainlabWarning,
    InputError,
    SolverDivergence,
)
from grainlab.geometry.disc_packing import DiscPacking2D
from grainlab.prep.regular_packings import named_packing, packing_names
from grainlab.result import TestResult, read_test_result

__all__ = [
    "ConvergenceError",
    "DiscPacking2D",
    "GeometryError",
    "GrainlabError",
    "GrainlabWarning",
    "InputError",
    "SolverDivergence",
    "TestResult",
    "__version__",
    "named_packing",
    "packing_names",
    "read_test_result",
]
