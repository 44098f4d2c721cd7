"""A study's results, small enough to keep in a repository or send to a reader: the study's
definition, its summary tables, its report (Markdown, HTML, figures, the comparison with its
paper) and where they came from, without the run folders' checkpoints, snapshots and results
tables (hundreds of MiB for a series at 1000 particles).

``publish(folder, dest)`` copies from a study folder (``study.toml``):

* ``study.toml`` and ``summary.csv`` (one row per run, every column);
* ``report/``: ``report.md``, ``report.html``, the figures and ``against_the_paper.csv``;
* ``PROVENANCE.md``: when and with what it was made (grainlab's version and source commit
  where the package runs from a git checkout, the libraries, the processor and its cores),
  and each run's outcome and cost (wall time, steps, capped share) from the summary.

From a size check (``size_check.csv``; :mod:`grainlab.study.size_check`) it copies the
check's table, report and figures, and publishes each of its studies into a subfolder of the
same name. The destination's files of those names are replaced; nothing else in it is
touched.
"""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd

from grainlab.errors import InputError
from grainlab.result.test_result import software_versions
from grainlab.study.study_runner import SPEC

REPORT_FILES = (".md", ".html", ".png", ".csv", ".svg")
"""What a study's ``report/`` folder publishes."""

SIZE_CHECK_FILES = ("size_check.csv", "size_check.md", "size_check_margins.csv")


def source_commit(where: Path | None = None) -> str:
    """The git commit of the grainlab source that runs (``where``: a folder of the package,
    by default this module's), with "+changes" where the package's files in the working tree
    differ from it (data or docs elsewhere in the checkout do not count); "unknown" outside
    a git checkout."""
    where = Path(where) if where is not None else Path(__file__).resolve().parent
    package = where.parent
    try:
        commit = subprocess.run(["git", "-C", str(where), "rev-parse", "HEAD"],
                                capture_output=True, text=True, timeout=10, check=True)
        dirty = subprocess.run(["git", "-C", str(where), "status", "--porcelain",
                                "--untracked-files=no", "--", str(package)],
                               capture_output=True, text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return commit.stdout.strip() + ("+changes" if dirty.stdout.strip() else "")


def _provenance(folder: Path, summary: pd.DataFrame | None) -> str:
    versions = software_versions()
    lines = [f"# Provenance of {folder.name}", "",
             f"- published {datetime.now(UTC):%Y-%m-%d %H:%M} UTC from `{folder}`",
             f"- grainlab {versions['grainlab']}, source commit {source_commit()}",
             "- " + ", ".join(f"{k} {v}" for k, v in versions.items() if k != "grainlab"),
             f"- machine: {platform.processor() or platform.machine()}, "
             f"{os.cpu_count()} cores, {platform.system()} {platform.release()}", ""]
    if summary is not None and len(summary):
        lines += ["| run | seed | outcome | wall time [s] | steps | capped steps |",
                  "|---|---|---|---|---|---|"]
        for _, row in summary.iterrows():
            seed = pd.to_numeric(row.get("seed"), errors="coerce")
            seed = "" if pd.isna(seed) else f"{int(seed)}"
            capped = row.get("capped_share", float("nan"))
            lines.append(
                f"| {row['name']} | {seed} | {row.get('status', '')} | "
                f"{row.get('wall_time', float('nan')):.0f} | {row.get('steps', '')} | "
                + ("-" if pd.isna(capped) else f"{capped:.2%}") + " |")
        total = pd.to_numeric(summary.get("wall_time"), errors="coerce").sum()
        lines += ["", f"Wall time of the runs: {total:.0f} s in all (each run on one worker; "
                      "the runs of a study share the machine's cores).", ""]
    return "\n".join(lines)


def _copy(source: Path, dest: Path) -> None:
    dest.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(source, dest)


def publish(folder: str | Path, dest: str | Path) -> Path:
    """Copy the study or size check in ``folder`` into ``dest`` (module docstring); returns
    ``dest``."""
    folder, dest = Path(folder).resolve(), Path(dest).resolve()
    if dest == folder or folder in dest.parents:
        raise InputError("dest", str(dest), "a folder outside the study folder")
    if (folder / "size_check.csv").exists():
        for name in SIZE_CHECK_FILES:
            if (folder / name).exists():
                _copy(folder / name, dest / name)
        for figure in sorted(folder.glob("size_check-*.png")):
            _copy(figure, dest / figure.name)
        for sub in sorted(p for p in folder.iterdir() if (p / SPEC).exists()):
            publish(sub, dest / sub.name)
        return dest
    if not (folder / SPEC).exists():
        raise InputError("FOLDER", str(folder), f"a study folder (with a {SPEC}) or a size "
                         "check (with a size_check.csv)")
    _copy(folder / SPEC, dest / SPEC)
    summary = None
    if (folder / "summary.csv").exists():
        _copy(folder / "summary.csv", dest / "summary.csv")
        summary = pd.read_csv(folder / "summary.csv")
    report = folder / "report"
    if report.is_dir():
        for path in sorted(report.iterdir()):
            if path.is_file() and path.suffix in REPORT_FILES:
                _copy(path, dest / "report" / path.name)
    (dest / "PROVENANCE.md").write_text(_provenance(folder, summary) + "\n", encoding="utf-8")
    return dest
