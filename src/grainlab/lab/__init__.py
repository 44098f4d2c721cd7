"""The laboratory: load paths, test protocols and the test-result format."""

from grainlab.lab.columns import STANDARD_COLUMNS
from grainlab.lab.test_result import TestResult, read_test_result

__all__ = ["STANDARD_COLUMNS", "TestResult", "read_test_result"]
