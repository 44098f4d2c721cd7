"""Run the peers' periodic triaxial test in LIGGGHTS or YADE and read back its figures.

Plain Python 3 (standard library only; no grainlab import). The peers' decks are in this
folder: ``liggghts_periodic_triaxial.in`` and ``yade_periodic_triaxial.py`` (see README.md).
grainlab's benchmark imports this module::

    sys.path.insert(0, str(REPO / "benchmarks" / "peers"))
    import run_peers
    res = run_peers.run_liggghts(n=4000, threads=2)     # None (reason printed) if no binary
    res = run_peers.run_yade(n=4000, threads=2)

Each run returns a dict: ``peer``, ``version``, ``threads`` (MPI ranks for LIGGGHTS, OpenMP
threads for YADE), ``n``, ``steps`` (both phases), ``wall_s`` (wall time of the two phases'
time stepping, as the peer measures it: set-up and cloud excluded), ``particle_steps_per_s``
(n x steps / wall_s), ``peak_q_over_p``, ``residual_q_over_p``, ``phi`` and ``z`` (packing
fraction and coordination number z = 2 C / N at the end of the compaction), and more
(``steps1``, ``wall1_s``, ``steps2``, ``wall2_s``, the end state, the lateral stresses,
every row, the command, the load average).

q/p here is grainlab's: ``q_over_trace`` = (s1 - s3)/(3 p) = (s1 - s3)/(s1 + 2 s3), with
s1 the axial and s3 the mean lateral stress of each row, averaged over the row's interval
of eps_1; ``peak_eta`` / ``residual_eta`` give (s1 - s3)/p (= 3 q_over_trace). Peak: the
largest row; residual: the mean of the rows with eps_1 in the last ``RESIDUAL_SHARE`` (40 %)
of the axial strain reached (``residual_eps1_from``).

Command line (runs one peer, prints the dict as JSON)::

    python3 benchmarks/peers/run_peers.py liggghts --n 1000 --threads 2 --eps1 0.05
    python3 benchmarks/peers/run_peers.py yade --n 4000 --threads 1 --json /tmp/yade.json
    python3 benchmarks/peers/run_peers.py liggghts --n 1000 -- gp=100 seed=15485863
    python3 benchmarks/peers/run_peers.py yade --n 1000 -- --seed 2
    python3 benchmarks/peers/run_peers.py liggghts --parse LOGFILE        # a saved output
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
LIGGGHTS_DECK = HERE / "liggghts_periodic_triaxial.in"
YADE_SCRIPT = HERE / "yade_periodic_triaxial.py"
RESIDUAL_SHARE = 0.4
"""Residual q/p: mean of the rows in the last 40 % of the axial strain reached."""
Q_OVER_P = "q_over_trace = (s1 - s3)/(3 p), grainlab's q/p; eta = (s1 - s3)/p = 3 q_over_trace"

_KV = re.compile(r"([\w()]+)=(\S+)")


def _num(text: str) -> Any:
    try:
        value = float(text.rstrip(","))
    except ValueError:
        return text
    return int(value) if value.is_integer() and "." not in text and "e" not in text else value


def _fields(line: str) -> dict[str, Any]:
    return {k: _num(v) for k, v in _KV.findall(line)}


def parse_output(text: str, peer: str) -> dict[str, Any]:
    """The figures of one run from its screen output (the SETUP, PHASE1, ROWHEAD/ROW,
    PHASE2 and RESULT lines that both decks print). Raises ValueError when the run did not
    reach its end (no RESULT line)."""
    phase1 = phase2 = result = None
    header: list[str] = []
    rows: list[dict[str, float]] = []
    version = None
    setup: dict[str, Any] = {}
    for line in text.splitlines():
        if line.startswith("LIGGGHTS (Version"):
            m = re.search(r"Version\s+(\S+\s+[\d.]+)", line)
            version = m.group(1) if m else line.strip()
        elif line.startswith("SETUP"):
            setup.update(_fields(line))
            if "version" in setup and peer == "yade":
                version = f"YADE {setup['version']}"
        elif line.startswith("PHASE1"):
            phase1 = _fields(line)
        elif line.startswith("PHASE2"):
            phase2 = _fields(line)
        elif line.startswith("RESULT"):
            result = _fields(line)
        elif line.startswith("ROWHEAD"):
            header = line.split()[1:]
        elif line.startswith("ROW ") and header:
            values = line.split()[1:]
            if len(values) == len(header):
                rows.append({k: float(v) for k, v in zip(header, values, strict=True)})
    if result is None or phase1 is None or phase2 is None:
        raise ValueError(f"{peer}: the output has no RESULT line (the run did not finish)")
    shear = rows[1:]
    out: dict[str, Any] = {
        "peer": peer, "version": version, "threads": None, "n": result["N"],
        "steps": result["steps"], "wall_s": result["wall_s"],
        "particle_steps_per_s": result["N"] * result["steps"] / result["wall_s"],
        "peak_q_over_p": None, "residual_q_over_p": None,
        "phi": phase1["phi"], "z": phase1["z"],
        "q_over_p_definition": Q_OVER_P,
        "steps1": phase1["steps"], "wall1_s": phase1["wall_s"],
        "steps2": phase2["steps"], "wall2_s": phase2["wall_s"],
        "particle_steps_per_s_phase1": result["N"] * phase1["steps"] / phase1["wall_s"],
        "particle_steps_per_s_phase2": result["N"] * phase2["steps"] / phase2["wall_s"],
        "z_nr": phase1.get("z_nr"),
        "eps1_end": phase2.get("eps_1"), "eps_v_end": phase2.get("eps_v"),
        "phi_end": phase2.get("phi"), "z_end": phase2.get("z"), "z_nr_end": phase2.get("z_nr"),
        "dt": setup.get("dt"), "edot": setup.get("edot"), "d_mean": setup.get("d_mean(number)"),
        "rows": rows,
    }
    if shear:
        peak = max(shear, key=lambda r: r["q_over_trace"])
        e_end = shear[-1]["eps_1"]
        e_from = (1.0 - RESIDUAL_SHARE) * e_end
        window = [r for r in shear if r["eps_1"] >= e_from - 1e-9] or shear[-1:]
        lateral = [v for r in shear for v in (r["sx_over_s0"], r["sy_over_s0"])]
        out.update({
            "peak_q_over_p": peak["q_over_trace"], "peak_eps1": peak["eps_1"],
            "peak_eta": peak["eta"],
            "residual_q_over_p": sum(r["q_over_trace"] for r in window) / len(window),
            "residual_eta": sum(r["eta"] for r in window) / len(window),
            "residual_eps1_from": e_from, "residual_rows": len(window),
            "lateral_stress_over_sigma0": {"mean": sum(lateral) / len(lateral),
                                           "min": min(lateral), "max": max(lateral)},
        })
    return out


def _run(cmd: list[str], env: dict[str, str] | None, timeout: float | None,
         log: str | Path | None) -> tuple[str | None, tuple, tuple]:
    """Run ``cmd`` in a scratch folder; (its output or None with a printed reason, load
    averages before and after)."""
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="grainlab_peer_") as tmp:
        try:
            proc = subprocess.run(cmd, cwd=tmp, env=env, stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, timeout=timeout, check=False)
        except subprocess.TimeoutExpired as exc:
            if log:
                Path(log).write_text((exc.stdout or b"").decode(errors="replace"))
            print(f"peer run stopped after {timeout} s: {' '.join(cmd)}")
            return None, load0, os.getloadavg()
    text = proc.stdout.decode(errors="replace")
    if log:
        Path(log).write_text(text)
    if proc.returncode != 0:
        tail = "\n".join(text.splitlines()[-15:])
        print(f"peer run failed (exit {proc.returncode}): {' '.join(cmd)}\n{tail}")
        return None, load0, os.getloadavg()
    return text, load0, os.getloadavg()


def _finish(run: tuple, peer: str, threads: int, cmd: list[str], seconds: float) -> dict | None:
    text, load0, load1 = run
    if text is None:
        return None
    try:
        res = parse_output(text, peer)
    except ValueError as exc:
        print(exc)
        return None
    res["threads"] = threads
    res["command"] = " ".join(cmd)
    res["process_s"] = seconds
    res["load_average_1min"] = {"start": load0[0], "end": load1[0], "cpus": os.cpu_count()}
    return res


def run_liggghts(n: int = 4000, threads: int = 1, eps1: float = 0.3,
                 variables: dict[str, Any] | None = None, binary: str = "liggghts",
                 timeout: float | None = None, log: str | Path | None = None,
                 mpi_yield: bool = True) -> dict | None:
    """Run the LIGGGHTS deck with ``threads`` MPI ranks (1: no mpirun); ``variables``: more
    ``-var NAME VALUE`` pairs. ``mpi_yield``: Open MPI's ``--mca mpi_yield_when_idle 1``
    (a rank waiting for a message yields its core instead of spinning: on a machine whose
    cores are shared with other processes the spinning rank otherwise steals the time of
    the rank it waits for). Returns the figures (:func:`parse_output`), or None with a
    printed reason (binary or mpirun missing, failure, timeout)."""
    exe = shutil.which(binary)
    if exe is None:
        print(f"LIGGGHTS not run: no '{binary}' on PATH (Debian: apt-get install liggghts)")
        return None
    cmd = [exe, "-in", str(LIGGGHTS_DECK), "-log", "none", "-var", "N", str(n),
           "-var", "eps1", repr(float(eps1))]
    for k, v in (variables or {}).items():
        cmd += ["-var", str(k), str(v)]
    if threads > 1:
        mpirun = shutil.which("mpirun")
        if mpirun is None:
            print("LIGGGHTS not run with several ranks: no 'mpirun' on PATH")
            return None
        root = ["--allow-run-as-root"] if hasattr(os, "geteuid") and os.geteuid() == 0 else []
        yield_ = ["--mca", "mpi_yield_when_idle", "1"] if mpi_yield else []
        cmd = [mpirun, "-np", str(threads), *root, *yield_, *cmd]
    started = time.perf_counter()
    run = _run(cmd, None, timeout, log)
    return _finish(run, "liggghts", threads, cmd, time.perf_counter() - started)


def run_yade(n: int = 4000, threads: int = 1, eps1: float = 0.3,
             args: list[str] | None = None, binary: str = "yade", omp_passive: bool = True,
             timeout: float | None = None, log: str | Path | None = None,
             process_s: float | None = None) -> dict | None:
    """Run the YADE script with ``threads`` OpenMP threads (``yade -j``); ``args``: more
    script options (``--seed 2`` ...). ``omp_passive``: OMP_WAIT_POLICY=PASSIVE (YADE's
    threads then sleep instead of spinning while they wait: much faster on a machine whose
    cores are busy, benchmarks/yade/README.md). ``process_s``: stop each YADE process after
    about that many seconds of time stepping, save a checkpoint and go on in a new process
    (``--checkpoint``/``--resume``) until the test ends; ``timeout`` then applies to each
    process. The wall times are those of the time stepping, summed over the processes.
    Returns the figures or None with a printed reason."""
    exe = shutil.which(binary)
    if exe is None:
        print(f"YADE not run: no '{binary}' on PATH (Debian: apt-get install yade)")
        return None
    env = dict(os.environ)
    if omp_passive:
        env["OMP_WAIT_POLICY"] = "PASSIVE"
    base = [exe, "-j", str(threads), "-n", "-x", str(YADE_SCRIPT)]
    first = [*base, "--n", str(n), "--eps1", repr(float(eps1)), *(args or [])]
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="grainlab_yade_ckpt_") as tmp:
        ckpt = str(Path(tmp) / "checkpoint.bin.gz")
        extra = ["--checkpoint", ckpt, "--max-process-wall", str(process_s)] if process_s else []
        cmd, texts, loads = [*first, *extra], [], []
        for _ in range(1000):
            text, load0, load1 = _run(cmd, env, timeout, None)
            loads.append((load0, load1))
            if text is None:
                if log:
                    Path(log).write_text("\n".join(texts))
                return None
            texts.append(text)
            if "\nCHECKPOINT " not in text:
                break
            cmd = [*base, "--resume", ckpt, *extra]
    text = "\n".join(texts)
    if log:
        Path(log).write_text(text)
    res = _finish((text, loads[0][0], loads[-1][1]), "yade", threads, first,
                  time.perf_counter() - started)
    if res is not None:
        res["omp_wait_policy"] = env.get("OMP_WAIT_POLICY")
        res["processes"] = len(texts)
    return res


def summary(res: dict) -> str:
    """One line of the figures of a run."""
    return (f"{res['peer']} ({res['version']}) threads={res['threads']} N={res['n']}: "
            f"{res['steps']} steps in {res['wall_s']:.1f} s "
            f"({res['particle_steps_per_s']:.3g} particle-steps/s; compaction "
            f"{res['steps1']} steps {res['wall1_s']:.1f} s, triaxial {res['steps2']} steps "
            f"{res['wall2_s']:.1f} s), phi={res['phi']:.4f} z={res['z']:.3f} after compaction, "
            f"peak q/p={res['peak_q_over_p']:.4f} (eta {res['peak_eta']:.3f}) at "
            f"eps_1={res['peak_eps1']:.3f}, residual q/p={res['residual_q_over_p']:.4f} "
            f"(eta {res['residual_eta']:.3f})")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("peer", choices=["liggghts", "yade"])
    ap.add_argument("--parse", metavar="LOGFILE", default=None,
                    help="read the figures of a saved screen output of that peer, run nothing")
    ap.add_argument("--n", type=int, default=4000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--eps1", type=float, default=0.3)
    ap.add_argument("--timeout", type=float, default=None, help="seconds")
    ap.add_argument("--log", default=None, help="save the peer's screen output here")
    ap.add_argument("--json", default=None, help="write the result here")
    ap.add_argument("--rows", action="store_true", help="keep the rows in the printed JSON")
    ap.add_argument("--no-yield", action="store_true",
                    help="liggghts: no --mca mpi_yield_when_idle 1 (ranks spin while waiting)")
    ap.add_argument("--process-s", type=float, default=None,
                    help="yade: checkpoint and restart every that many seconds of stepping")
    a, extra = ap.parse_known_args(argv)
    # anything else: LIGGGHTS NAME=VALUE variables or YADE script options (after --)
    extra = [x for x in extra if x != "--"]
    if a.parse:
        res = parse_output(Path(a.parse).read_text(), a.peer)
    elif a.peer == "liggghts":
        res = run_liggghts(a.n, a.threads, a.eps1, dict(x.split("=", 1) for x in extra),
                           timeout=a.timeout, log=a.log, mpi_yield=not a.no_yield)
    else:
        res = run_yade(a.n, a.threads, a.eps1, extra, timeout=a.timeout, log=a.log,
                       process_s=a.process_s)
    if res is None:
        return 1
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1))
    shown = res if a.rows else {k: v for k, v in res.items() if k != "rows"}
    print(json.dumps(shown, indent=1))
    if "peak_eta" in res:
        print(summary(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
