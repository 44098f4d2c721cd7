"""What an ended run folder keeps when its bulky files go (``grainlab study slim``).

A sample at 1000 particles run to eps_q = 0.9 leaves 30-60 MiB of snapshots and checkpoints
in its run folder; its summary row and the report's figures read only a little of them. A
slimmed sample keeps that little in ``samples/NAME/digest/`` and loses the rest, so that a
study's folder can be kept, copied to another machine and gone on with there (the runner
never reruns an ended sample), a series built a few samples at a time:

``digest/row.json``
    the sample's summary row (:func:`~grainlab.study.study_summary.sample_row`) and the
    settings it was computed with (window, core margin, peak window): the summary takes it
    in place of the snapshots, for those settings only;
``digest/window.json``, ``digest/window/<name>.csv``
    the residual window's averaged force PDFs and angular distributions
    (:class:`~grainlab.analysis.window_average.WindowAverage`, the core's contacts), as the
    report draws them;
``digest/snapshots.h5``
    the last snapshot of the compaction (the report's wall profile) and the run's last one
    (its force network).

The results (``results.h5``, ``results.csv``), the config and the log stay; the snapshots, the
checkpoints (with their shape library) and any stored contact problems go. A slimmed sample's
row is frozen as it was computed: a summary asked with other settings leaves its
microstructure out.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from grainlab.analysis.snapshot_files import read_snapshots, write_snapshots
from grainlab.errors import InputError
from grainlab.lab.discrete_run import (
    CHECKPOINT,
    PREVIOUS_CHECKPOINT,
    PROBLEMS,
    RESULTS_H5,
    SNAPSHOTS,
)
from grainlab.lab.shape_library_file import library_files

DIGEST = "digest"
ROW = "row.json"
WINDOW = "window"
BULKY = (SNAPSHOTS, CHECKPOINT, PREVIOUS_CHECKPOINT, PROBLEMS)
"""What slimming removes from an ended run folder, with the checkpoints' shape library files
(:mod:`grainlab.lab.shape_library_file`)."""


def row_settings(window: tuple[float, float], core_margin: float, peak_window: float,
                 microstructure: bool = True) -> dict[str, Any]:
    """The settings a summary row depends on, as stored beside it."""
    return {"window": [float(window[0]), float(window[1])], "core_margin": float(core_margin),
            "peak_window": float(peak_window), "microstructure": bool(microstructure)}


def _plain(value: Any) -> Any:
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.bool_):
        return bool(value)
    raise TypeError(f"not JSON: {type(value).__name__}")


def write_row(folder: str | Path, row: dict[str, Any], settings: dict[str, Any]) -> Path:
    """Keep ``row`` with its ``settings`` (:func:`row_settings`) in the digest of the run
    ``folder``."""
    path = Path(folder) / DIGEST / ROW
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps({"settings": settings, "row": row}, default=_plain, indent=1),
                    encoding="utf-8")
    return path


def read_row(folder: str | Path, settings: dict[str, Any], ignore: tuple[str, ...] = ()
             ) -> dict[str, Any] | None:
    """The kept row of the run ``folder`` if it was computed with ``settings`` (the keys in
    ``ignore`` aside), else None."""
    path = Path(folder) / DIGEST / ROW
    if not path.exists():
        return None
    kept = json.loads(path.read_text(encoding="utf-8"))
    held = {key: value for key, value in (kept.get("settings") or {}).items()
            if key not in ignore}
    asked = {key: value for key, value in settings.items() if key not in ignore}
    return kept["row"] if held == asked else None


def snapshots_for_report(folder: str | Path) -> Path | None:
    """The run's snapshot file, or its digest's once slimmed; None without either."""
    for path in (Path(folder) / SNAPSHOTS, Path(folder) / DIGEST / SNAPSHOTS):
        if path.exists():
            return path
    return None


def compacted_snapshot(folder: str | Path):
    """The run's last compaction snapshot (a ContactNetwork; from its snapshots, or its
    digest's once slimmed), the packing at the end of its compaction; None without one."""
    path = snapshots_for_report(folder)
    if path is None:
        return None
    compacted = None
    for network in read_snapshots(path):
        if network.state.get("stage") == "compaction":
            compacted = network
    return compacted


def write_window(folder: str | Path, window: tuple[float, float], core_margin: float) -> bool:
    """Average the run's snapshots over the residual ``window`` (the core's contacts) and keep
    the distributions in its digest; False when no snapshot lies in the window."""
    from grainlab.analysis.window_average import WindowAverage

    folder = Path(folder)
    try:
        average = WindowAverage(tuple(window), distributions="core",
                                core_margin=core_margin).run(folder / SNAPSHOTS)
    except InputError:
        return False
    tables = folder / DIGEST / WINDOW
    tables.mkdir(parents=True, exist_ok=True)
    for name, table in average.distributions.items():
        table.to_csv(tables / f"{name}.csv", index=False)
    where = "core" if average.last is not None and average.last.core_parts else "whole box"
    (folder / DIGEST / f"{WINDOW}.json").write_text(json.dumps(
        {"window": list(window), "core_margin": float(core_margin),
         "n_snapshots": average.n_snapshots, "where": where,
         "names": sorted(average.distributions)}, indent=1), encoding="utf-8")
    return True


def read_window(folder: str | Path, window: tuple[float, float], core_margin: float
                ) -> tuple[dict[str, pd.DataFrame], int, str] | None:
    """The kept window average of the run ``folder`` over ``window`` with the core
    ``core_margin`` [mean diameters] from the walls (distributions by name, snapshots
    averaged, "core" or "whole box"), else None. A whole-box average (a periodic cell) holds
    for any margin; a digest that does not name its margin was kept at 1, the only margin
    before it was named."""
    path = Path(folder) / DIGEST / f"{WINDOW}.json"
    if not path.exists():
        return None
    kept = json.loads(path.read_text(encoding="utf-8"))
    if not np.allclose(kept["window"], window):
        return None
    if kept["where"] == "core" and not np.isclose(kept.get("core_margin", 1.0), core_margin):
        return None
    tables = {name: pd.read_csv(Path(folder) / DIGEST / WINDOW / f"{name}.csv")
              for name in kept["names"]}
    return tables, int(kept["n_snapshots"]), str(kept["where"])


def write_report_snapshots(folder: str | Path) -> int:
    """Keep the last compaction snapshot and the run's last snapshot in the digest; how many
    were kept."""
    folder = Path(folder)
    compaction = last = None
    for network in read_snapshots(folder / SNAPSHOTS):
        if network.state.get("stage") == "compaction":
            compaction = network
        last = network
    kept = [n for n in (compaction, last) if n is not None]
    if kept and kept[0] is kept[-1]:
        kept = kept[:1]
    if kept:
        (folder / DIGEST).mkdir(exist_ok=True)
        write_snapshots(folder / DIGEST / SNAPSHOTS, kept)
    return len(kept)


def slim_sample(folder: str | Path, row: dict[str, Any], settings: dict[str, Any],
                window: tuple[float, float], core_margin: float) -> int:
    """Digest the ended run ``folder`` (its summary ``row`` computed with ``settings``) and
    remove its bulky files (module docstring); the bytes freed."""
    folder = Path(folder)
    if not (folder / RESULTS_H5).exists():
        raise InputError("sample", str(folder), "an ended run (with results.h5) to slim")
    write_row(folder, row, settings)
    if (folder / SNAPSHOTS).exists():
        write_window(folder, window, core_margin)
        write_report_snapshots(folder)
    freed = 0
    for name in BULKY + tuple(path.name for path in library_files(folder)):
        path = folder / name
        if path.is_dir():
            freed += sum(p.stat().st_size for p in path.rglob("*") if p.is_file())
            shutil.rmtree(path)
        elif path.exists():
            freed += path.stat().st_size
            path.unlink()
    return freed

