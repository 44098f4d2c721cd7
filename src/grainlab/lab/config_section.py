"""A table of a run's config (:class:`ConfigSection`, a pydantic model that refuses unknown
keys and non-finite numbers) and the tables made from a frozen settings dataclass
(:func:`settings_table`: a key per field, typed strictly, its bounds and default those the
field declares with :func:`~grainlab.lab.setting_bounds.bounded`).

A settings field of type ``float`` takes a number and refuses ``true``/``false`` and text
(``StrictFloat``; an integer is read as a number), ``int`` an integer only, ``bool`` only
``true``/``false``, ``str`` with choices one of them (``Literal``).

>>> from grainlab.lab.soft_contact_settings import SoftContactSettings
>>> table = settings_table("DemConfig", SoftContactSettings, "[solver.dem]")
>>> table(kappa=2e3).frozen() == SoftContactSettings(kappa=2e3)
True
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictBool,
    StrictFloat,
    StrictInt,
    StrictStr,
    create_model,
)

from grainlab.lab.setting_bounds import SettingField, setting_fields

STRICT_TYPES: dict[type, Any] = {float: StrictFloat, int: StrictInt, bool: StrictBool,
                                 str: StrictStr}
"""The config type of a settings field's Python type."""


class ConfigSection(BaseModel):
    """A table of a run's config: unknown keys, NaN and infinities refused."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)
    frozen_as: ClassVar[type | None] = None
    """The frozen settings object a table stands for (None: a table read by key)."""

    def frozen(self) -> Any:
        """This table as its frozen settings object (:attr:`frozen_as`, built from its keys)."""
        if self.frozen_as is None:
            raise TypeError(f"{type(self).__name__} stands for no settings object")
        return self.frozen_as(**self.model_dump())

    def settings(self) -> Any:
        """The frozen settings object of this table (:meth:`frozen`)."""
        return self.frozen()


def config_type(setting: SettingField) -> Any:
    """The pydantic type of one settings field: ``Literal`` of its choices, else the strict
    type of its Python type (:data:`STRICT_TYPES`)."""
    if setting.bounds.choices:
        return Literal[setting.bounds.choices]
    if setting.type not in STRICT_TYPES:
        raise TypeError(f"a settings field of type {setting.type!r} ({setting.name}): a "
                        "config key takes " + ", ".join(t.__name__ for t in STRICT_TYPES))
    return STRICT_TYPES[setting.type]


def settings_table(name: str, settings_type: type, doc: str) -> type[ConfigSection]:
    """The pydantic model ``name`` of a config table standing for ``settings_type`` (a frozen
    dataclass): a key per field, in its order, typed by :func:`config_type`, with the bounds
    and default the field declares (module docstring)."""
    keys = {}
    for setting in setting_fields(settings_type):
        bounds = setting.bounds
        keys[setting.name] = (config_type(setting), Field(
            setting.default, description=bounds.note or None, **bounds.limits()))
    table = create_model(name, __base__=ConfigSection, __doc__=doc, __module__=__name__,
                         **keys)
    table.frozen_as = settings_type
    return table


def units(settings_type: type, prefix: str) -> dict[str, str]:
    """``{prefix + key: unit}`` of the fields of ``settings_type`` that carry a unit."""
    return {f"{prefix}{s.name}": s.bounds.unit for s in setting_fields(settings_type)
            if s.bounds.unit}
