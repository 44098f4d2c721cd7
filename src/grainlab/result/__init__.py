"""The test-result format shared by every specimen: the column registry, the stress and
strain invariants, and :class:`TestResult` with its files.

The lowest layer beside ``geometry``: it imports numpy, pandas and h5py only, so the engine,
the theories and the analysis layer all write the same columns.
"""

from grainlab.result.columns import COLUMNS, Column, unit_of
from grainlab.result.invariants import strain_invariants, stress_invariants
from grainlab.result.test_result import TestResult, read_test_result

__all__ = [
    "COLUMNS",
    "Column",
    "TestResult",
    "read_test_result",
    "strain_invariants",
    "stress_invariants",
    "unit_of",
]
