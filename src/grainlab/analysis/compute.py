"""The compute-object pattern of every analysis (STYLE.md 5).

Parameters go to the constructor, data to :meth:`Compute.compute`, and results are read as
properties, which raise a clear :class:`NotComputedError` before ``compute`` has run.
"""

from __future__ import annotations

from typing import Any

from grainlab.errors import GrainlabError


class NotComputedError(GrainlabError, AttributeError):
    """A result was read before ``compute()`` ran."""


class Compute:
    """Base class: subclasses implement ``_compute(network)`` and store results with
    :meth:`_store`; properties read them with :meth:`_get`."""

    def __init__(self) -> None:
        self._results: dict[str, Any] = {}

    def compute(self, network) -> Compute:
        """Analyse ``network`` (a :class:`~grainlab.analysis.ContactNetwork`); returns self."""
        self._results = {}
        self._compute(network)
        return self

    def _compute(self, network) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _store(self, **results: Any) -> None:
        self._results.update(results)

    def _get(self, name: str) -> Any:
        if name not in self._results:
            raise NotComputedError(
                f"{type(self).__name__}.{name} is not available: call compute(network) first."
            )
        return self._results[name]

    @property
    def computed(self) -> bool:
        """True once :meth:`compute` has run."""
        return bool(self._results)
