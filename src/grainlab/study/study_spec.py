"""What a study is: a series of discrete runs that differ by one shape parameter, written as a
TOML file a user can read and edit (pydantic models).

A study file has three parts::

    [study]      name, parameter (the shape parameter's name, the x axis of the figures),
                 symbol (how the figures write it), window = [lo, hi] (the residual state:
                 the range of eps_q over which every descriptor is averaged), core_margin
                 (the core's distance from every wall, in mean diameters:
                 grainlab.analysis.wall_layer), peak_window (the eps_q width of the running
                 mean whose maximum is the peak (q/p)+), description
    [base]       a run config (the tables of :class:`~grainlab.lab.run_config.RunConfig`)
                 shared by every sample
    [[samples]]  name (the sample's folder), value (the shape parameter, as the paper gives
                 it), set (the config keys of this sample over [base], as nested tables),
                 replica_of (optional: the sample this one repeats with another seed)

Example (two samples of seed 003's series)::

    [study]
    name = "two aggregates"
    parameter = "eta"
    window = [0.5, 0.9]

    [base.sample]
    shape = "aggregate"
    n_particles = 500
    preparation = "deposition"

    [[samples]]
    name = "eta-0.2"
    value = 0.2
    set = { sample = { eta = 0.2 } }

    [[samples]]
    name = "eta-0.4"
    value = 0.4
    set = { sample = { eta = 0.4 } }

Every sample's config is validated when the study is read: an error names the key as the file
spells it (``samples[1].set.sample.eta``). The preset series of seeds 002 and 003 are in
:mod:`grainlab.study.series_presets`.

>>> spec = StudySpec.model_validate({
...     "study": {"name": "s", "parameter": "eta", "window": [0.1, 0.2]},
...     "base": {"sample": {"shape": "aggregate", "n_particles": 40}},
...     "samples": [{"name": "a", "value": 0.1, "set": {"sample": {"eta": 0.1}}}]})
>>> spec.sample_config("a").sample.eta, spec.sample_config("a").sample.n_particles
(0.1, 40)
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import tomli_w
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from grainlab._validate import read_toml
from grainlab.analysis.wall_layer import CORE_MARGIN
from grainlab.errors import InputError
from grainlab.lab.run_config import RunConfig, current_layout

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._+-]{0,63}$")
"""A sample name is its folder's name: letters, digits and . _ + - (at most 64)."""


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class StudyHeader(_Model):
    """The ``[study]`` table."""

    name: str = Field(min_length=1)
    parameter: str = Field("value", min_length=1)
    symbol: str = ""
    window: tuple[float, float] = (0.5, 0.9)
    core_margin: float = Field(CORE_MARGIN, ge=0.0)
    peak_window: float = Field(0.01, ge=0.0)
    description: str = ""

    @field_validator("window")
    @classmethod
    def _ordered(cls, value: tuple[float, float]) -> tuple[float, float]:
        lo, hi = value
        if not 0.0 <= lo < hi:
            raise ValueError("[lo, hi] with 0 <= lo < hi (a range of eps_q)")
        return value


class StudySample(_Model):
    """One ``[[samples]]`` entry; ``replica_of`` names the sample it repeats with another
    packing seed (the same shape, an independent sample: the summary pools them into one
    point whose error bar is their spread), empty for a sample of its own."""

    name: str
    value: float
    set: dict[str, Any] = Field(default_factory=dict)
    replica_of: str = ""

    @field_validator("name")
    @classmethod
    def _folder_name(cls, value: str) -> str:
        if not _NAME.match(value):
            raise ValueError("a folder name: letters, digits and . _ + - (at most 64, "
                             "not starting with . _ + -)")
        return value


class StudySpec(_Model):
    """A study: its header, the base run config and the samples (module docstring)."""

    study: StudyHeader
    base: dict[str, Any] = Field(default_factory=dict)
    samples: list[StudySample] = Field(min_length=1)

    @classmethod
    def model_validate(cls, obj: Any, **kwargs) -> StudySpec:  # type: ignore[override]
        """Validate plain data; every error (and every sample config that is not a valid run
        config) becomes an :class:`InputError` naming the key as the file spells it."""
        try:
            spec = super().model_validate(obj, **kwargs)
        except ValidationError as error:
            first = error.errors()[0]
            field = _dotted(first["loc"])
            raise InputError(field, first.get("input"), first["msg"]) from None
        spec._check_samples()
        return spec

    def _check_samples(self) -> None:
        seen: set[str] = set()
        for k, sample in enumerate(self.samples):
            if sample.name in seen:
                raise InputError(f"samples[{k}].name", sample.name,
                                 "a name no other sample of the study has")
            seen.add(sample.name)
        for k, sample in enumerate(self.samples):
            if not sample.replica_of:
                continue
            of = [s for s in self.samples if s.name == sample.replica_of]
            if not of or of[0].replica_of or of[0] is sample:
                raise InputError(f"samples[{k}].replica_of", sample.replica_of,
                                 "the name of another sample of the study that is not a "
                                 "replica itself")
            if of[0].value != sample.value:
                raise InputError(f"samples[{k}].value", sample.value,
                                 f"the value of the sample it repeats ({of[0].value:g})")
        try:
            RunConfig.model_validate(self.base)
        except InputError as error:
            raise InputError(f"base.{error.field}", error.value, error.allowed) from None
        for k, sample in enumerate(self.samples):
            try:
                self.sample_config(sample.name)
            except InputError as error:
                where = "set" if _in(sample.set, error.field) else "base"
                field = f"samples[{k}].set.{error.field}" if where == "set" \
                    else f"base.{error.field} (for sample {sample.name!r})"
                raise InputError(field, error.value, error.allowed) from None

    # -- files --------------------------------------------------------------------------------
    @classmethod
    def read(cls, path: str | Path) -> StudySpec:
        """Read a study TOML file (module docstring)."""
        path = Path(path)
        data = read_toml(path, "study file")
        try:
            return cls.model_validate(data)
        except InputError as error:
            raise InputError(f"{error.field} (in {path})", error.value, error.allowed) from None

    def write(self, path: str | Path) -> Path:
        """Write as TOML."""
        path = Path(path)
        data = self.model_dump(mode="json")
        for sample in data["samples"]:  # a sample of its own says nothing of replicas
            if not sample["replica_of"]:
                del sample["replica_of"]
        path.write_text(tomli_w.dumps(data), encoding="utf-8")
        return path

    # -- what it means ------------------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        """The samples' names, in the file's order."""
        return [s.name for s in self.samples]

    def sample(self, name: str) -> StudySample:
        """The sample called ``name``."""
        for s in self.samples:
            if s.name == name:
                return s
        raise InputError("sample", name, "one of " + ", ".join(self.names))

    def sample_config(self, name: str) -> RunConfig:
        """The run config of sample ``name``: [base] with the sample's ``set`` over it."""
        base = RunConfig.model_validate(self.base)
        return base.with_updates(self.sample(name).set)

    @property
    def symbol(self) -> str:
        """How the figures write the shape parameter."""
        return self.study.symbol or self.study.parameter


def _dotted(loc: tuple) -> str:
    """A pydantic location as the file spells it: ``samples[1].set``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def _in(data: dict[str, Any], dotted: str) -> bool:
    """Whether the dotted key (``sample.eta``) is set in the nested ``data`` (in the current
    layout of run configs)."""
    node: Any = current_layout(data)[0]
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return False
        node = node[part]
    return True
