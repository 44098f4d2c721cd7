"""The config a discrete-run command asks for: ``--config``'s file (or the defaults), the test
and the options given over it (:mod:`grainlab.cli.run_options`), an option that would do
nothing refused (:mod:`grainlab.lab.option_scope`), and every refusal naming what the user
typed: the option (``--mu``) or the config key and its file.

The options given are carried as ``{config key: (option as typed, value)}``
(:func:`given_options`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape

from grainlab.cli.inputs import input_file
from grainlab.cli.run_options import options_of
from grainlab.errors import InputError
from grainlab.lab.run_config import RunConfig

console = Console()

Given = dict[str, tuple[str, Any]]
"""The options given: ``{config key: (option as typed, value)}``."""


def sample_source(command: str, options: dict[str, Any]) -> dict[str, Any]:
    """``options`` with the files of how the sample is made checked (one that does not exist
    is refused by name) and written as text; a file given implies ``--preparation file``."""
    options = dict(options)
    files = [option for option in options_of(command)
             if option.is_file and options.get(option.name) is not None]
    for option in files:
        options[option.name] = str(input_file(option.typed, options[option.name]))
    if files and options.get("preparation") is None:
        options["preparation"] = "file"
    return options


def given_options(command: str, kind: str, options: dict[str, Any]) -> Given:
    """The options of ``command`` given (not None) that set a config key, as
    ``{key: (option as typed, value)}``; the key is the compaction's own for a compaction
    (``--tolerance``, ``--max-iterations``). The other options (the folder, ``--config``,
    switches) are left out."""
    table = {option.name: option for option in options_of(command)}
    given: Given = {}
    for name, value in options.items():
        option = table[name]
        if option.key is not None and value is not None:
            given[option.key_in(kind)] = (option.typed, value)
    return given


def command_config(kind: str, config_file: Path | None, options: dict[str, Any],
                   command: str = "test") -> tuple[RunConfig, Given]:
    """The config ``command`` asks for: ``--config``'s file (or the defaults), the test
    ``kind`` and the options given (by parameter name, :func:`given_options`) over it; and
    the options given. A refused value is an :class:`InputError` naming the option as typed
    (:func:`as_typed`)."""
    if config_file is not None:
        input_file("--config", config_file)
        try:
            config = RunConfig.read(config_file)
        except InputError as error:
            raise as_typed(error, {}, config_file) from None
    else:
        config = RunConfig()
    given = given_options(command, kind, options)
    overrides: dict[str, dict[str, Any]] = {"test": {"kind": kind}}
    for key, (_, value) in given.items():
        *tables, name = key.split(".")
        table = overrides
        for part in tables:
            table = table.setdefault(part, {})
        table[name] = value
    try:
        return config.with_updates(overrides), given
    except InputError as error:
        raise as_typed(error, given, config_file) from None


def asked_config(kind: str, config_file: Path | None, options: dict[str, Any],
                 command: str = "test") -> tuple[RunConfig, Given]:
    """:func:`command_config` for a run of one solver, an option that would do nothing in it
    refused (:func:`refuse_inert_options`)."""
    config, given = command_config(kind, config_file, options, command)
    for note in refuse_inert_options([config], given, config_file):
        console.print(f"[bold yellow]note:[/] {escape(note)}", soft_wrap=True)
    return config, given


def refuse_inert_options(configs: list[RunConfig], given: Given,
                         config_file: Path | None) -> list[str]:
    """Refuse an option given that none of the runs of ``configs`` reads
    (:mod:`grainlab.lab.option_scope`): an :class:`InputError` naming it as typed, and why it
    would do nothing. A key of ``--config``'s file that differs from its default and that no
    run reads is not refused (a file may serve several commands): returned, in words, for a
    note."""
    from grainlab.lab.option_scope import inert_settings
    from grainlab.lab.run_config import flat_keys

    keys = list(given)
    if config_file is not None:
        written = flat_keys(RunConfig.read(config_file).model_dump())
        default = flat_keys(RunConfig().model_dump())
        keys += [key for key, value in written.items()
                 if value != default.get(key) and key not in keys]
    inert = [inert_settings(config, keys) for config in configs]
    notes = []
    for key in keys:
        if not all(key in each for each in inert):
            continue
        value: Any = configs[0]
        for name in key.split("."):
            value = getattr(value, name)
        if key in given:
            error = InputError(key, value, f"not given: it does nothing here ({inert[0][key]})")
            raise as_typed(error, given, config_file)
        notes.append(f"{key} = {value!r} (in {config_file}) does nothing here: {inert[0][key]}")
    return notes


def as_typed(error: InputError, given: Given, config_file: Path | None) -> InputError:
    """``error`` naming what the user typed: the option (``--mu``) when the value came from
    the command line, else the config key and its file (``solver.shear.friction (in
    c.toml)``)."""
    field = error.field
    if field == "config":
        return InputError("--config", error.value, error.allowed)
    if field in given:
        return InputError(given[field][0], error.value, error.allowed)
    if config_file is not None and field in _CONFIG_KEYS:
        field = f"{field} (in {config_file})"
    return InputError(field, error.value, error.allowed)


def _config_keys(model: Any, prefix: str = "") -> set[str]:
    """Every key of a config model, ``"solver.shear.friction"`` for those of a sub-table."""
    keys = set()
    for name, info in model.model_fields.items():
        if hasattr(info.annotation, "model_fields"):
            keys |= _config_keys(info.annotation, f"{prefix}{name}.")
        else:
            keys.add(f"{prefix}{name}")
    return keys


_CONFIG_KEYS = _config_keys(RunConfig)
