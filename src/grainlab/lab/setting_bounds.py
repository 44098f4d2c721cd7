"""What a field of a frozen settings object allows, declared once on the field itself
(:func:`bounded`): its default, its open or closed bounds, its unit, its choices. A config
table is made from these (:func:`~grainlab.lab.config_section.settings_table`), so a
solver's settings are written once, in its settings dataclass.

>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Spring:
...     stiffness: float = bounded(1e5, gt=0, unit="N/m")
...     model: str = bounded("linear", choices=("linear", "hertz_mindlin"))
>>> [(s.name, s.type, s.default, s.bounds.unit) for s in setting_fields(Spring)]
[('stiffness', <class 'float'>, 100000.0, 'N/m'), ('model', <class 'str'>, 'linear', '')]
>>> setting_fields(Spring)[0].bounds.limits()
{'gt': 0}
"""

from __future__ import annotations

import typing
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

BOUNDS = "bounds"
"""The key of a field's ``metadata`` that holds its :class:`Bounds`."""


@dataclass(frozen=True)
class Bounds:
    """What one settings field allows: ``gt``/``ge`` (above, open or closed), ``lt``/``le``
    (below), ``unit`` (SI, "" for a number without one), ``choices`` (the words a text
    field takes; empty: any), ``note`` (words an error message adds)."""

    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    unit: str = ""
    choices: tuple[str, ...] = ()
    note: str = ""

    def limits(self) -> dict[str, float]:
        """The bounds given, as keywords (``{"gt": 0, "le": 1}``)."""
        return {name: value for name in ("gt", "ge", "lt", "le")
                if (value := getattr(self, name)) is not None}


def bounded(default: Any, *, gt: float | None = None, ge: float | None = None,
            lt: float | None = None, le: float | None = None, unit: str = "",
            choices: tuple[str, ...] = (), note: str = "") -> Any:
    """A dataclass field of ``default`` that carries what it allows (:class:`Bounds`)."""
    return field(default=default, metadata={BOUNDS: Bounds(gt, ge, lt, le, unit,
                                                           tuple(choices), note)})


@dataclass(frozen=True)
class SettingField:
    """One field of a settings dataclass: its name, Python type (``float``, ``int``,
    ``bool``, ``str``), default and :class:`Bounds` (none given: an empty one)."""

    name: str
    type: type
    default: Any
    bounds: Bounds


def setting_fields(settings_type: type) -> tuple[SettingField, ...]:
    """The fields of the frozen dataclass ``settings_type``, in its order; a field without a
    plain default is a ``TypeError`` (a config table gives every key a default)."""
    hints = typing.get_type_hints(settings_type)
    out = []
    for item in fields(settings_type):
        if item.default is MISSING:
            raise TypeError(f"{settings_type.__name__}.{item.name} has no default")
        out.append(SettingField(item.name, hints[item.name], item.default,
                                item.metadata.get(BOUNDS, Bounds())))
    return tuple(out)
