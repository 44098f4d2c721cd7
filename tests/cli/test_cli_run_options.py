"""The discrete-run commands are built from one table of options (:mod:`grainlab.cli.run_options`):
each command offers exactly the options the table declares for it, its ``--help`` lists
them, an option declared for another command only is refused at the command line, and each
config option's help states the config's one default."""

from __future__ import annotations

import pytest
import typer.main
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.cli.run_options import (
    COMMANDS,
    RUN_OPTIONS,
    config_default_text,
    option_named,
    options_of,
)
from grainlab.lab.run_config import RunConfig, flat_keys

runner = CliRunner()
CLICK = typer.main.get_command(app)
KIND_ARGUMENT = {"test": ["triaxial"], "compare": ["triaxial"], "theory-vs-sim": ["triaxial"]}
"""The KIND a command needs before its options."""


def _flags(parameter) -> set[str]:
    return {*parameter.opts, *parameter.secondary_opts}


def _declared_flags(option) -> set[str]:
    return {part for flag in option.flags for part in flag.split("/")}


@pytest.mark.parametrize("command", COMMANDS)
def test_a_command_offers_exactly_the_options_of_the_table(command):
    offered = {parameter.name: parameter for parameter in CLICK.commands[command].params}
    declared = {option.name: option for option in options_of(command)}
    assert set(offered) == set(declared)
    for name, option in declared.items():
        parameter = offered[name]
        if option.argument:
            assert parameter.required
            continue
        assert _flags(parameter) == _declared_flags(option), name
        assert parameter.help == option.help_text(), name
        assert parameter.hidden == option.hidden, name
        assert parameter.default == option.default, name  # None: the config's default


@pytest.mark.parametrize("command", COMMANDS)
def test_the_help_lists_every_option_declared_and_no_hidden_one(command):
    shown = runner.invoke(app, [command, "--help"], env={"COLUMNS": "200"})
    assert shown.exit_code == 0, shown.output
    for option in options_of(command):
        if option.argument:
            continue
        long_flag = next(f for f in sorted(_declared_flags(option)) if f.startswith("--"))
        if option.hidden:
            assert f"{long_flag} " not in shown.output, long_flag
        else:
            assert long_flag in shown.output, long_flag
            first_words = " ".join(option.help.split()[:3])
            assert first_words in " ".join(shown.output.split()), (long_flag, first_words)


def _undeclared(command: str) -> list[str]:
    declared = set().union(*(_declared_flags(o) for o in options_of(command)))
    others = set().union(*(_declared_flags(o) for o in RUN_OPTIONS if not o.argument))
    return sorted(f for f in others - declared if f.startswith("--"))


@pytest.mark.parametrize("command", COMMANDS)
def test_an_option_not_declared_for_a_command_is_refused(command):
    undeclared = _undeclared(command)
    if command != "test":  # test takes every option but compare's refused --solver twin
        assert undeclared
    for flag in undeclared:
        result = runner.invoke(app, [command, *KIND_ARGUMENT.get(command, []), flag, "1",
                                     "--out", "never-written"])
        assert result.exit_code == 2, (flag, result.output)
        assert "No such option" in result.output, (flag, result.output)


def test_the_options_each_command_takes_differ_as_its_test_needs():
    # what only the loading reads is not offered by the compaction
    compaction = {option.name for option in options_of("compaction")}
    assert not {"mu", "inertia", "eps_q", "max_iterations"} & compaction
    assert "eps_q" not in {o.name for o in options_of("oedometer")}
    assert "axial_strain" not in {o.name for o in options_of("triaxial")}
    # compare runs both solvers from one sample it makes: no --solver, no sample files
    assert option_named("compare", "solver").hidden
    assert option_named("compare", "solver").key is None
    assert "particle_file" not in {o.name for o in options_of("compare")}


def test_every_config_option_sets_a_key_of_the_config_and_shows_its_default():
    keys = flat_keys(RunConfig().model_dump())
    for option in RUN_OPTIONS:
        for key in (option.key, option.compaction_key):
            if key is not None:
                assert key in keys, (option.name, key)
        if option.key is not None and not option.is_file:
            assert option.help_text().endswith(config_default_text(option.key))
    assert config_default_text("sample.n_particles") == "[default: 1000]"
    assert config_default_text("solver.compaction.tolerance") == "[default: 0.0001]"


def test_a_compactions_tolerance_sets_the_compactions_numerics():
    assert option_named("compaction", "tolerance").key_in("compaction") \
        == "solver.compaction.tolerance"
    shear = option_named("test", "tolerance")
    assert shear.key_in("triaxial") == "solver.shear.tolerance"
    assert shear.key_in("compaction") == "solver.compaction.tolerance"
    assert option_named("test", "mu").key_in("compaction") == "solver.shear.friction"


@pytest.mark.parametrize("command", COMMANDS)
def test_a_command_takes_each_option_once(command):
    names = [option.name for option in options_of(command)]
    assert len(names) == len(set(names))
    flags = [flag for option in options_of(command) for flag in _declared_flags(option)]
    assert len(flags) == len(set(flags))
