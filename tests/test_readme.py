"""Every command of the README, run as typed (at small sizes): the command-line lines of its
bash blocks in order (in independent chains spread over a few tests, each in a scratch
folder), then its Python blocks in one namespace, after the chain whose files they read.

Sizes are shrunk so the whole README runs in about a minute: particle counts to a few dozen,
strain targets to 0.02, step counts and sweeps cut (:data:`SMALLER`). Nothing else is edited:
a README command that no longer exists, takes a renamed option or fails, fails here.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from typer.testing import CliRunner

from grainlab.cli.main import app
from grainlab.lab.run_config import RunConfig

README = Path(__file__).resolve().parents[1] / "README.md"

SMALLER = (
    (re.compile(r"(-n|--n-particles) \d+"), r"\1 24"),
    (re.compile(r"--eps-q [0-9.]+"), "--eps-q 0.02"),
    (re.compile(r"--steps \d+"), "--steps 400"),
    (re.compile(r"--alphas 0:90:15"), "--alphas 0:90:45"),
    (re.compile(r"--synthetic \d+"), "--synthetic 2000"),
    (re.compile(r'"n_particles": \d+'), '"n_particles": 24'),
    (re.compile(r'"eps_q_max": [0-9.]+'), '"eps_q_max": 0.02'),
    (re.compile(r"grainlab theory-b-sweep"),  # one case of the 3D sweep, one law
     "grainlab theory-b-sweep -n 150 --path cubical --b 0.5 --eps-q 0.02 --distribution "
     "homogeneous --model-steps 20"),
    (re.compile(r"grainlab theory-series"),  # one case of seed 001's chapter 3 series
     "grainlab theory-series --seed 1 --test oedometer --phi-mu 25 --axial-strain 0.002 "
     "--distribution homogeneous --model-steps 20"),
)
"""(pattern, replacement) making a README command small."""

FAST_POLYHEDRA = {"solver": {"compaction": {"inertia_number": 0.05,
                                            "time_step_factor": 0.02}},
                  "test": {"quasi_static": {"stress_tolerance": 0.02, "unbalanced_force": 0.02,
                                            "kinetic_energy": float("inf")}}}
"""A quicker compaction for the polyhedra, periodic-cell, compare and DEM commands (a test
setting, passed with --config): a faster loading, and settled at 2 % on the stresses and the
unbalanced force without the kinetic-energy criterion (YADE's end of a compaction)."""


def _blocks(language: str) -> list[str]:
    text = README.read_text(encoding="utf-8")
    return re.findall(rf"^```{language}\n(.*?)^```", text, flags=re.S | re.M)


def _commands() -> list[str]:
    """The grainlab command lines of the README's bash blocks, comments removed."""
    lines = []
    for block in _blocks("bash"):
        for line in block.splitlines():
            line = line.split("#")[0].strip()
            if line.startswith("grainlab "):
                lines.append(line)
    return lines


def _small(text: str) -> str:
    for pattern, replacement in SMALLER:
        text = pattern.sub(replacement, text)
    return text


def _packing_file(folder: Path) -> None:
    """my_packing.toml, the README's own packing file: two discs per cell (packing C)."""
    from grainlab.prep.packing_files import write_packing
    from grainlab.prep.regular_packings import named_packing

    write_packing(named_packing("C"), folder / "my_packing.toml")


def test_the_readme_lists_the_commands_a_new_user_needs():
    commands = _commands()
    for needed in ("grainlab triaxial", "grainlab resume", "grainlab vtk", "grainlab analyse",
                   "grainlab packing2d load", "grainlab microelement run"):
        assert any(c.startswith(needed) for c in commands), needed
    assert len(_blocks("python")) >= 3


SHARDS = 4
"""The README's commands run as this many tests (the workers share them out)."""


def _chains() -> list[list[str]]:
    """The README's command lines in chains, in order: a command that names a folder an earlier
    one wrote (``--out``) runs after it, in its chain; the chains are independent."""
    chains: list[list[str]] = []
    outs: dict[str, int] = {}
    for line in _commands():
        words = shlex.split(line)
        linked = next((index for word in words[1:] for folder, index in outs.items()
                       if word == folder or word.startswith(folder + "/")), None)
        if linked is None:
            chains.append([line])
            linked = len(chains) - 1
        else:
            chains[linked].append(line)
        if "--out" in words:
            outs[words[words.index("--out") + 1]] = linked
    return chains


LEFT_BEHIND = {"runs/tri": ("snapshots.h5", "vtk-checkpoint", "report/report.md"),
               "analysis": ("analysis.csv",),
               "runs/cmp": ("cd/results.h5", "dem/results.h5", "compare.png", "compare.csv"),
               "runs/theory": ("run/results.h5", "theory.png", "theory.csv",
                               "theory-differences.csv")}
"""What the README says some commands leave behind, by their --out folder."""


def test_the_readme_commands_fall_in_independent_chains():
    chains = _chains()
    assert sorted(line for chain in chains for line in chain) == sorted(_commands())
    tri = next(chain for chain in chains if any("--out runs/tri " in f"{c} " for c in chain))
    assert "grainlab resume runs/tri" in tri and "grainlab vtk runs/tri" in tri


@pytest.mark.long
@pytest.mark.parametrize("shard", range(SHARDS))
def test_every_readme_command_runs_as_typed(shard, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _packing_file(tmp_path)
    RunConfig.model_validate(FAST_POLYHEDRA).write(tmp_path / "fast.toml")
    runner = CliRunner()
    lines = [line for index, chain in enumerate(_chains()) if index % SHARDS == shard
             for line in chain]
    for line in lines:
        arguments = shlex.split(_small(line))[1:]
        if "polyhedron" in arguments:  # 3 shapes, a quicker compaction
            if arguments[0] == "compaction":
                arguments[arguments.index("-n") + 1] = "12"
            arguments += ["--config", "fast.toml", "--templates", "3"] \
                if "--templates" not in arguments else ["--config", "fast.toml"]
        if "periodic" in arguments:  # a periodic cell needs three interaction ranges across
            arguments[arguments.index("-n") + 1] = "150"
            arguments += ["--size-ratio", "1.2", "--inertia", "0.01", "--config", "fast.toml"]
            if arguments[0] == "test":
                arguments += ["--gamma", "0.02"]
        if arguments[0] == "study" and arguments[1] in ("angularity", "nonconvexity"):
            arguments += ["--length", "smoke", "--no-progress"]  # a few samples, a short path
            if "--only" not in arguments:
                arguments += ["--only", "eta-0.4"]
        if arguments[0] == "compare":  # both solvers: a quicker compaction
            arguments += ["--config", "fast.toml"]
        if "dem" in arguments:  # soft-contact DEM: softer grains, a quicker compaction
            arguments += ["--config", "fast.toml"]
            if "--kappa" not in arguments and "--young-modulus" not in arguments:
                arguments += ["--kappa", "1e3"]
        if arguments[0] == "triaxial" and "--eps-q" not in arguments:
            arguments += ["--eps-q", "0.02"]  # the default 0.5 would flatten 24 particles
        if arguments[0] in ("triaxial", "compaction", "oedometer", "resume", "test",
                            "compare", "theory-vs-sim"):
            arguments.append("--no-progress")
        result = runner.invoke(app, arguments)
        assert result.exit_code == 0, f"{line}\n{result.output}"
    written = {shlex.split(line)[shlex.split(line).index("--out") + 1] for line in lines
               if "--out" in shlex.split(line)}
    for folder, files in LEFT_BEHIND.items():
        for name in files if folder in written else ():
            assert (tmp_path / folder / name).exists(), f"{folder}/{name}"
    if "runs/tri" not in written:
        return
    # the Python blocks read what the runs/tri chain wrote: they run after it, in its shard
    for block in _blocks("python"):
        code = _small(block)
        if "start_run(" in code:  # the README's run folder is taken by the CLI's run above
            code = code.replace('start_run("runs/tri", config)',
                                'start_run("runs/tri-python", config)')
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    assert (tmp_path / "runs" / "tri-python" / "results.csv").exists()




@pytest.mark.parametrize("command", ["grainlab demo", "make demo", "make test"])
def test_the_readme_gives_the_two_commands(command):
    assert command in README.read_text(encoding="utf-8")
