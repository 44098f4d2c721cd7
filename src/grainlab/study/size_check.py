"""The size check of a preset series: which of a study's numbers are physics and which are
the box. The same samples of one series run at
several sizes in a box of walls and in a periodic cell; the values over the core (the
particles away from the walls: :mod:`grainlab.analysis.wall_layer`) must approach, as the box
grows, the cell's, which has no wall layer at all, while the whole-box values, the wall layer
included, need not.

A size check is a folder holding one study per boundary and size, each the series preset
(:mod:`grainlab.study.series_presets`) run for the checked samples only
(``<boundary>-<N>``: ``walls-500``, ``walls-1000``, ``periodic-1000``...), so that every run
resumes where it stopped, as a study does, and any of them can be opened as a study.

The table (:func:`size_check_table`) has one row per sample, quantity, boundary and size: the
whole-box and core values with their standard deviations over the residual window (none for
an initial state), and the paper's value for that sample where its paper gives one
(:data:`~grainlab.report.paper_comparison.PAPER_CLAIMS`);
:func:`~grainlab.report.size_check_report.convergence_verdicts` reads it quantity by
quantity: how far the core and the whole box sit from the cell at each size,
whether the core reaches the cell within their error bars, and where the cell's value lands
against the paper's; :func:`~grainlab.report.size_check_report.write_size_check_report`
writes the check's report. :func:`margin_table` measures the walls' cores after the
compaction at several margins (:func:`~grainlab.analysis.wall_layer.core_by_margin`): a core
whose edge cuts through the wall layer departs from the bulk, so the report shows where the
values settle. The check's studies are read with the analysis settings of the preset (the
core margin: :data:`~grainlab.study.study_runner.ANALYSED_AS_ASKED`).

>>> plan = SizeCheckPlan("angularity", ("S1",), walls=(500, 1000), periodic=(1000,))
>>> [run.folder_name for run in plan.runs]
['walls-500', 'walls-1000', 'periodic-1000']
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed, wait
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from grainlab.errors import InputError
from grainlab.report.paper_comparison import PAPER_CLAIMS, PaperClaim
from grainlab.study.sample_task import STOP_FILE, sample_state
from grainlab.study.series_presets import LENGTHS, SERIES, series_spec
from grainlab.study.study_runner import (
    LocalSampleCluster,
    Study,
    StudyInterrupted,
    StudyOutcome,
)

DEFAULT_SAMPLES = {"angularity": ("S1", "S5"), "nonconvexity": ("eta-0.0", "eta-0.4")}
"""The samples a size check runs by default: the spheres and one shape near the middle of the
series (seed 002's S5, <alpha> = 0.5, where nu0 peaks; seed 003's eta = 0.4)."""

PEAK = PaperClaim("(q/p)+", "q_over_trace_peak", None, "", 0.0)
"""The smoothed peak of q/p, checked for size though no paper value is read for it."""

TABLE = "size_check.csv"

MARGINS = (1.0, 1.25, 1.5, 2.0, 2.5)
"""The core margins [mean diameters] at which :func:`margin_table` reads each box."""

MARGIN_TABLE = "size_check_margins.csv"


@dataclass(frozen=True)
class SizeRun:
    """One study of a size check: its ``boundary`` ("walls" or "periodic") and particles per
    sample ``n``."""

    boundary: str
    n: int

    @property
    def folder_name(self) -> str:
        return f"{self.boundary}-{self.n}"


@dataclass(frozen=True)
class SizeCheckPlan:
    """Which ``samples`` of the preset ``series`` run at which sizes: ``walls`` and
    ``periodic`` (particles per sample), to ``length`` (:data:`LENGTHS`) with packing
    ``seed``."""

    series: str
    samples: tuple[str, ...]
    walls: tuple[int, ...] = (500, 1000, 2000)
    periodic: tuple[int, ...] = (1000,)
    length: str = "full"
    seed: int = 0
    cell_from: Path | None = None
    """A study folder of the same series in a periodic cell (a series run with ``--boundary
    periodic``) whose samples of the checked names are the check's cell: run there, read
    from there, and no cell of the check's own (``periodic`` is then the series' size). Its
    settings for those samples must be the ones the check would give its own cell."""

    def __post_init__(self) -> None:
        if self.series not in SERIES:
            raise InputError("series", self.series, "one of " + ", ".join(SERIES))
        if self.length not in LENGTHS:
            raise InputError("length", self.length, "one of " + ", ".join(LENGTHS))
        known = series_spec(self.series, n_particles=2).names
        for name in self.samples:
            if name not in known:
                raise InputError("samples", name, f"samples of {self.series}: "
                                 + ", ".join(known))
        if not self.samples:
            raise InputError("samples", "", "at least one sample name")
        for field, sizes in (("walls", self.walls), ("periodic", self.periodic)):
            for n in sizes:
                if int(n) < 2:
                    raise InputError(field, n, "particle counts of at least 2")
        if self.cell_from is not None:
            object.__setattr__(self, "cell_from", Path(self.cell_from))
            object.__setattr__(self, "periodic", (self._cell_source_size(),))
        if not self.periodic:
            raise InputError("periodic", "", "at least one size in the periodic cell (the "
                             "reference the walls' core values must approach)")

    def _cell_source_size(self) -> int:
        """The particles per sample of the :attr:`cell_from` series, after checking that its
        samples of the checked names have the settings the check would give its own cell."""
        from grainlab.study.reproduction import settings_differences
        from grainlab.study.study_runner import SPEC
        from grainlab.study.study_spec import StudySpec

        source = Path(self.cell_from)
        if not (source / SPEC).is_file():
            raise InputError("cell_from", str(source), f"a study folder (with a {SPEC}) of "
                             f"the {self.series} series in a periodic cell")
        found = StudySpec.read(source / SPEC)
        missing = [name for name in self.samples if name not in found.names]
        if missing:
            raise InputError("cell_from", str(source), "a study holding the checked samples "
                             f"({', '.join(self.samples)}); it lacks {', '.join(missing)}")
        n = int(found.base.get("sample", {}).get("n_particles", 0))
        wanted = series_spec(self.series, n_particles=n, length=self.length, seed=self.seed,
                             boundary="periodic")
        differ = settings_differences(found, wanted, names=self.samples)
        # a cell has no walls and no core: the core margin it was summarised with is moot
        differ["study"] = [key for key in differ.get("study", [])
                           if not key.startswith("core_margin")]
        differ = {name: keys for name, keys in differ.items() if keys}
        if differ:
            raise InputError("cell_from", str(source), "a series run with the check's "
                             "settings (the same length, seed and a periodic cell); differs: "
                             + "; ".join(f"{name}: {', '.join(keys)}"
                                         for name, keys in differ.items()))
        return n

    @property
    def runs(self) -> list[SizeRun]:
        return ([SizeRun("walls", int(n)) for n in self.walls]
                + [SizeRun("periodic", int(n)) for n in self.periodic])

    @property
    def tolerances(self) -> dict[str, float]:
        """The paper's reading tolerance per quantity (:data:`PAPER_CLAIMS`): the slack of a
        value without error bars (an initial state) against the cell's."""
        return {claim.quantity: claim.tolerance for claim in _claims(self.series)}

    def study_folder(self, folder: str | Path, run: SizeRun) -> Path:
        """Where the study of ``run`` lives: its subfolder of the check's ``folder``, or the
        :attr:`cell_from` series for the cell."""
        if run.boundary == "periodic" and self.cell_from is not None:
            return Path(self.cell_from)
        return Path(folder) / run.folder_name

    def study(self, folder: str | Path, run: SizeRun) -> Study:
        """The study of ``run`` (:meth:`study_folder`; created or opened as it is)."""
        path = self.study_folder(folder, run)
        if run.boundary == "periodic" and self.cell_from is not None:
            return Study.open(path)
        spec = series_spec(self.series, n_particles=run.n, length=self.length, seed=self.seed,
                           boundary=run.boundary)
        return Study.create(path, spec)


def run_size_check(folder: str | Path, plan: SizeCheckPlan, *, scheduler: str | None = None,
                   workers: int | None = None, threads: int = 1, progress: bool = True,
                   on_end: Callable[[str, StudyOutcome], None] | None = None,
                   ) -> dict[str, StudyOutcome]:
    """Run (or go on with) every study of ``plan`` in ``folder``, each for the plan's samples
    only; returns each run's outcome by folder name (``on_end(name, outcome)`` is called as
    each study ends).

    On one local worker (``workers = 1``, or a single core) the studies run one after
    another, the smallest first, each with its display, and a run that stops (interrupted, a
    failed sample) stops the check there. With more workers, or a scheduler's address, the
    studies that have samples left run at the same time on one cluster (their samples
    spread over its workers): the check takes about as long as its longest run instead of
    their sum. Ctrl-C then asks every running sample to
    checkpoint (each study's stop file) and raises
    :class:`~grainlab.study.study_runner.StudyInterrupted`. Run it again to go on."""
    studies = [(run, plan.study(folder, run))
               for run in sorted(plan.runs, key=lambda r: (r.n, r.boundary))]
    left = [(run, study) for run, study in studies
            if any(study.states()[name] != "ended" for name in plan.samples)]
    tasks = len(left) * len(plan.samples)
    slots = workers or max(1, (os.cpu_count() or 1) // max(1, int(threads)))
    outcomes: dict[str, StudyOutcome] = {}
    if scheduler is None and (slots <= 1 or len(left) <= 1):
        for run, study in studies:
            outcome = study.run(workers=workers, threads=threads, progress=progress,
                                only=list(plan.samples))
            outcomes[run.folder_name] = outcome
            if on_end is not None:
                on_end(run.folder_name, outcome)
            if not outcome.complete:
                break
        return outcomes
    for run, study in studies:
        if (run, study) not in left:
            outcomes[run.folder_name] = study.run(threads=threads, progress=False,
                                                  only=list(plan.samples))  # all ended
            if on_end is not None:
                on_end(run.folder_name, outcomes[run.folder_name])
    cluster = LocalSampleCluster(min(slots, tasks), threads) if scheduler is None else None
    address = scheduler or cluster.cluster.scheduler_address
    try:
        with ThreadPoolExecutor(max_workers=len(left)) as pool:
            running = {pool.submit(study.run, scheduler=address, threads=threads,
                                   progress=False, only=list(plan.samples)): (run, study)
                       for run, study in left}
            try:
                for future in as_completed(running):
                    run = running[future][0]
                    outcomes[run.folder_name] = future.result()
                    if on_end is not None:
                        on_end(run.folder_name, outcomes[run.folder_name])
            except BaseException:  # Ctrl-C, or a study that raised: the others checkpoint
                for _, study in left:
                    (study.folder / STOP_FILE).touch()
                wait(running)
                raise
    except KeyboardInterrupt:
        raise StudyInterrupted(
            "size check interrupted; every sample that was running checkpointed (or resumes "
            "from its last checkpoint); go on with the same command") from None
    finally:
        if cluster is not None:
            cluster.close()
    return outcomes


def _claims(series: str) -> tuple[PaperClaim, ...]:
    """The quantities the check compares: the paper's claims, with the peak first where the
    paper makes none of it."""
    parameter = series_spec(series, n_particles=2).study.parameter
    claims = PAPER_CLAIMS.get(parameter, ())
    return claims if any(c.column == PEAK.column for c in claims) else (PEAK, *claims)


def paper_value(claim: PaperClaim, index: int, count: int, parameter: float) -> float:
    """The paper's value of ``claim`` for the sample at ``index`` of a series of ``count``
    samples with shape parameter ``parameter``: its first or last sample's value, the others'
    level, or the peak value near the peak's location; NaN where the paper gives none."""
    if index == 0 and claim.first is not None:
        return claim.first
    if index == count - 1 and claim.last is not None:
        return claim.last
    if index > 0 and claim.rest is not None:
        return claim.rest
    if (claim.peak is not None and claim.peak_at is not None
            and abs(parameter - claim.peak_at) <= claim.peak_tolerance):
        return claim.peak
    return math.nan


def _number(row: pd.Series, column: str | None) -> float:
    if column is None or column not in row.index:
        return math.nan
    value = pd.to_numeric(row[column], errors="coerce")
    return float(value) if pd.notna(value) else math.nan


def size_check_table(folder: str | Path, plan: SizeCheckPlan) -> pd.DataFrame:
    """One row per ended sample, quantity and run of ``plan`` in ``folder`` (module
    docstring): ``sample``, ``quantity``, ``column``, ``boundary``, ``n``, ``whole``,
    ``whole_std``, ``core``, ``core_std``, ``paper``, ``capped_share``, ``wall_time`` [s].
    Each run's study summary is written again from its ended samples
    (:func:`~grainlab.study.study_summary.study_summary`); in a cell the core is the whole
    packing. Written to ``size_check.csv`` in ``folder``."""
    from grainlab.study.study_summary import study_summary

    folder = Path(folder)
    claims = _claims(plan.series)
    rows = []
    for run in plan.runs:
        path = plan.study_folder(folder, run)
        if not path.is_dir():
            continue
        study = plan.study(folder, run)  # as held, with the check's analysis settings
        if not any(sample_state(study.sample_folder(name)) == "ended"
                   for name in plan.samples):
            continue
        table = study_summary(study)
        names = study.spec.names
        for _, row in table.iterrows():
            if row["name"] not in plan.samples:
                continue
            index = names.index(row["name"])
            value = _number(row, "measured")
            for claim in claims:
                whole = _number(row, claim.column)
                core_column = claim.core_column if run.boundary == "walls" else claim.column
                core = _number(row, core_column)
                rows.append({
                    "sample": row["name"], "quantity": claim.quantity,
                    "column": claim.column, "boundary": run.boundary, "n": run.n,
                    "whole": whole, "whole_std": _number(row, f"{claim.column}_std"),
                    "core": core, "core_std": _number(row, f"{core_column}_std")
                    if core_column else math.nan,
                    "paper": paper_value(claim, index, len(names), value),
                    "capped_share": _number(row, "capped_share"),
                    "wall_time": _number(row, "wall_time")})
    out = pd.DataFrame(rows, columns=["sample", "quantity", "column", "boundary", "n",
                                      "whole", "whole_std", "core", "core_std", "paper",
                                      "capped_share", "wall_time"])
    folder.mkdir(parents=True, exist_ok=True)
    out.to_csv(folder / TABLE, index=False)
    return out


def margin_table(folder: str | Path, plan: SizeCheckPlan,
                 margins: tuple[float, ...] = MARGINS) -> pd.DataFrame:
    """The core of every ended walls run of ``plan`` after its compaction (its last
    compaction snapshot, from the run's snapshots or, once slimmed, its digest) at each of
    ``margins`` [mean diameters]: one row per sample, size and margin with ``sample``, ``n``,
    ``margin``, ``n_core``, ``packing_fraction``, ``coordination_number``,
    ``connectivity_number``. Written to ``size_check_margins.csv`` in ``folder``."""
    from grainlab.analysis.wall_layer import core_by_margin
    from grainlab.lab.run_digest import compacted_snapshot

    folder = Path(folder)
    parts = []
    for run in plan.runs:
        path = plan.study_folder(folder, run)
        if run.boundary != "walls" or not path.is_dir():
            continue
        study = Study.open(path)
        for name in plan.samples:
            run_folder = study.sample_folder(name)
            if sample_state(run_folder) != "ended":
                continue
            compacted = compacted_snapshot(run_folder)
            if compacted is None or not compacted.has_box:
                continue
            part = core_by_margin(compacted, margins)
            part.insert(0, "n", run.n)
            part.insert(0, "sample", name)
            parts.append(part)
    columns = ["sample", "n", "margin", "n_core", "packing_fraction", "coordination_number",
               "connectivity_number"]
    out = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=columns)
    folder.mkdir(parents=True, exist_ok=True)
    out.to_csv(folder / MARGIN_TABLE, index=False)
    return out
