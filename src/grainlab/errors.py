"""Errors and warnings that grainlab raises to its users.

Every error names the offending field, the value it received and what is allowed, so that a
message read at the command line is enough to fix the input. The CLI turns any
:class:`GrainlabError` into a one-paragraph message and a non-zero exit status, never a
traceback.
"""

from __future__ import annotations

from typing import Any


class GrainlabError(Exception):
    """Base class of every error grainlab raises on purpose."""


class InputError(GrainlabError, ValueError):
    """A user-supplied value is outside what is allowed.

    Parameters
    ----------
    field:
        Name of the input field, as the user wrote it (``"radii[3]"``, ``"--alpha"``).
    value:
        The value received.
    allowed:
        What would have been accepted, in words (``"a positive number of metres"``).
    """

    def __init__(self, field: str, value: Any, allowed: str):
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field} = {_shown(value)} is not allowed: expected {allowed}.")


class CellTooThin(InputError):
    """A periodic cell narrower, across a pair of faces, than three interaction ranges of its
    detection (2 r_max + alert): a pair would touch through two images. Raised by the
    detection before anything of the step reaches the bodies; a lab test stops its stage on
    it (the cell got too thin for its particles)."""


def _shown(value: Any) -> str:
    """``value`` as a user would type it: numbers plain (``3.5``, not ``np.float64(3.5)``),
    text quoted, booleans as TOML and the command line spell them (``true``)."""
    if hasattr(value, "item") and getattr(value, "shape", None) == ():
        value = value.item()  # a NumPy scalar
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))  # 200.0 typed as 200
    return repr(value)


class GeometryError(GrainlabError, ValueError):
    """A packing geometry is inconsistent (overlapping particles, a cell that does not tile)."""


class ConvergenceError(GrainlabError, RuntimeError):
    """An iterative solve did not converge; the message gives the residual reached."""


class SolverDivergence(ConvergenceError):
    """An iterative solve diverged: its error or its iterate became non-finite, or its error
    grew past a bound. The message names the method, what it reached and the setting that
    would help; nothing non-finite is returned as an answer."""


class StrengthReached(GrainlabError, RuntimeError):
    """A specimen has no stiffness state left to carry further load: its strength is reached
    (e.g. the self-consistent overall stiffness of seed 001 eqs. 2.31–2.32 has ceased to
    exist). The element-test driver ends the test with ``status = "failure"``; the message
    says what was lost."""


class GrainlabWarning(UserWarning):
    """Base class of grainlab's warnings."""


class RattlerWarning(GrainlabWarning):
    """A particle carries no contact and takes no part in the load-bearing network."""
