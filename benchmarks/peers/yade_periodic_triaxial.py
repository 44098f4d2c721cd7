"""Peers' test in YADE: periodic-cell triaxial compression of a polydisperse sphere packing
with Hertz-Mindlin contacts (the same test as ``liggghts_periodic_triaxial.in``).

Written for YADE 2023.02a (Debian package ``yade``, command ``yade``). A YADE script, not a
grainlab module: it runs under YADE's own Python. Options go after the script name::

    yade -j 2 -n -x benchmarks/peers/yade_periodic_triaxial.py
    yade -j 1 -n -x benchmarks/peers/yade_periodic_triaxial.py --n 1000 --eps1 0.05
    yade -n -x benchmarks/peers/yade_periodic_triaxial.py --help

(``-j``: OpenMP threads; ``-n``: no GUI; ``-x``: exit at the end. On a machine whose cores
are busy with other processes put ``OMP_WAIT_POLICY=PASSIVE`` in front of ``yade -j 2``, see
benchmarks/yade/README.md.)

The test (defaults in brackets, SI units, compression positive in the output):

1. Cloud: ``makeCloud`` of N [4000] spheres in a periodic cube at solid fraction
   ``--phi-cloud`` [0.1], diameters uniform by volume fraction in [d_min, 2 d_min]
   [1 mm, 2 mm] (``distributeMass``: number density ~ d^-3, deterministic sizes, random
   positions, ``--seed``), density 2600 kg/m^3, no gravity.
2. Contacts: ``FrictMat`` (E [1e9 Pa], nu [0.25]) with ``Ip2_FrictMat_FrictMat_MindlinPhys``
   (en [0.5]: Tsuji's viscous damping from the restitution coefficient) and
   ``Law2_ScGeom_MindlinPhys_Mindlin``; no global damping (``NewtonIntegrator(damping=0)``).
   dt = ``--dt-factor`` [0.2] x the Rayleigh time of the smallest sphere,
   T_R = pi R sqrt(rho/G) / (0.1631 nu + 0.8766), G = E / (2 (1 + nu)).
3. Phase 1: frictionless isotropic compaction to sigma0 [100 kPa] by the cell
   (``PeriTriaxController``, stress on the three axes; the cell strain rate is capped at
   ``--cgas`` [100 /s] while p < ``--pgas`` sigma0 [1e-3], at ``--crate`` [20 /s] after),
   checked every ``--check-every`` [1000] steps until each axis stress is within ``--stol``
   [1 %] of sigma0 and ``unbalancedForce()`` < ``--unb`` [0.01]. ``globUpdate=1``: the
   controller reads the stress (``getStress``) on every step; with its default (5) it
   predicts the stress between readings, and with Hertz contacts here the cell then
   flipped between +cap and -cap on alternate steps and stopped 3 % short of sigma0.
4. Phase 2: friction mu [0.4] (``setContactFriction``), axial (z) compression at the
   constant true strain rate edot = I / (d_mean sqrt(rho/sigma0)) (I = ``--inertia``
   [1e-3], d_mean: number mean diameter) to eps_1 = ``--eps1`` [0.3], x and y held at sigma0
   by the same controller (``stressMask=3``; lateral cell strain rate capped at
   ``--lateral-cap`` [20 /s]). The cell's velocity gradient moves the particles with the
   affine field (``Cell.homoDeform = 2``). The number of steps per row and the rate are
   chosen exactly as in the LIGGGHTS deck: about ``--rec`` [0.01] of eps_1 per row, the
   rate adjusted by < 0.1 % to land on eps1.

Output lines (the same as the LIGGGHTS deck; ``run_peers.py`` parses both): SETUP, COMPACT
(progress), PHASE1, ROWHEAD/ROW (one row per interval: stresses averaged over the interval,
sampled every ``--sample-every`` [10] steps), PHASE2, RESULT. q/p is given two ways:
q_over_trace = (s1 - s3)/(3 p) (grainlab's) and eta = (s1 - s3)/p. z = 2 C / N over all
interactions (geometric contacts, as LIGGGHTS' ``compute contact/atom``); the PHASE1 and
PHASE2 lines also give z_nr, the coordination of force-carrying contacts without rattlers
(fewer than 2 contacts, removed repeatedly; ``benchmarks/yade/contact_counts.py``).
"""

import argparse
import builtins
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(sys.argv[0])), "..", "yade"))
import contact_counts
from yade import O, pack, utils
from yade.minieigenHP import Matrix3, Vector3
from yade.wrapper import (
    Bo1_Sphere_Aabb,
    ForceResetter,
    FrictMat,
    Ig2_Sphere_Sphere_ScGeom,
    InsertionSortCollider,
    InteractionLoop,
    Ip2_FrictMat_FrictMat_MindlinPhys,
    Law2_ScGeom_MindlinPhys_Mindlin,
    NewtonIntegrator,
    PeriTriaxController,
    PyRunner,
)


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="yade -j 2 -n -x yade_periodic_triaxial.py",
                                 description="Peers' periodic triaxial test (Hertz-Mindlin).")
    ap.add_argument("--n", type=int, default=4000, help="number of spheres")
    ap.add_argument("--dmin", type=float, default=1e-3, help="smallest diameter [m]")
    ap.add_argument("--dratio", type=float, default=2.0, help="d_max / d_min")
    ap.add_argument("--rho", type=float, default=2600.0, help="grain density [kg/m3]")
    ap.add_argument("--young", type=float, default=1e9, help="Young's modulus E [Pa]")
    ap.add_argument("--nu", type=float, default=0.25, help="Poisson's ratio")
    ap.add_argument("--en", type=float, default=0.5, help="normal restitution coefficient")
    ap.add_argument("--mu", type=float, default=0.4, help="friction coefficient (phase 2)")
    ap.add_argument("--sigma0", type=float, default=1e5, help="confining stress [Pa]")
    ap.add_argument("--inertia", type=float, default=1e-3, help="inertia number (phase 2)")
    ap.add_argument("--eps1", type=float, default=0.3, help="final axial strain")
    ap.add_argument("--rec", type=float, default=0.01, help="eps_1 per row (about)")
    ap.add_argument("--dt-factor", type=float, default=0.2, help="dt / Rayleigh time")
    ap.add_argument("--phi-cloud", type=float, default=0.1, help="solid fraction of the cloud")
    ap.add_argument("--seed", type=int, default=1, help="makeCloud seed")
    ap.add_argument("--crate", type=float, default=20.0, help="compaction rate cap [1/s]")
    ap.add_argument("--cgas", type=float, default=100.0, help="rate cap in the loose gas [1/s]")
    ap.add_argument("--pgas", type=float, default=1e-3, help="gas while p < pgas sigma0")
    ap.add_argument("--check-every", type=int, default=1000, help="steps between checks")
    ap.add_argument("--stol", type=float, default=0.01, help="relative stress tolerance")
    ap.add_argument("--unb", type=float, default=0.01, help="unbalanced force threshold")
    ap.add_argument("--max-steps1", type=int, default=1000000, help="phase 1 step limit")
    ap.add_argument("--lateral-cap", type=float, default=20.0,
                    help="lateral strain rate cap in phase 2 [1/s]")
    ap.add_argument("--glob-update", type=int, default=1,
                    help="PeriTriaxController.globUpdate (steps between stress updates; "
                         "with more than 1 the cell oscillated at its rate cap, see the README)")
    ap.add_argument("--sample-every", type=int, default=10, help="steps between stress samples")
    ap.add_argument("--max-wall", type=float, default=3600.0, help="abort a phase after [s]")
    ap.add_argument("--checkpoint", default=None,
                    help="with --max-process-wall: save the simulation here (O.save, plus "
                         "FILE.json) and stop once this process has run that long")
    ap.add_argument("--max-process-wall", type=float, default=0.0,
                    help="seconds of time stepping in this process before a checkpoint "
                         "(0: no limit); checked at the end of each check or row")
    ap.add_argument("--resume", default=None,
                    help="go on from a checkpoint (its options are used, except the three "
                         "checkpoint options)")
    return ap.parse_args(argv)


A = parse_args(sys.argv[1:])
if A.resume:
    with open(A.resume + ".json") as f:
        _saved = json.load(f)
    for k, v in _saved["args"].items():
        if k not in ("checkpoint", "max_process_wall", "resume"):
            setattr(A, k, v)
else:
    _saved = None


def say(*a):
    print(*a, flush=True)


D_MIN, D_MAX = A.dmin, A.dratio * A.dmin
G = A.young / (2.0 * (1.0 + A.nu))
T_R = math.pi * 0.5 * A.dmin * math.sqrt(A.rho / G) / (0.1631 * A.nu + 0.8766)

if _saved is None:
    # ------------------------------------------------------------ cloud
    _mean_d3 = (D_MAX - D_MIN) / (0.5 * (D_MIN ** -2 - D_MAX ** -2))
    V_SOLID_EXPECTED = A.n * math.pi / 6.0 * _mean_d3
    L0 = (V_SOLID_EXPECTED / A.phi_cloud) ** (1.0 / 3.0)
    O.periodic = True
    O.cell.hSize = Matrix3(L0, 0, 0, 0, L0, 0, 0, 0, L0)
    O.materials.append(FrictMat(young=A.young, poisson=A.nu, frictionAngle=0.0,
                                density=A.rho, label="grains"))
    sp = pack.SpherePack()
    n_made = sp.makeCloud(Vector3(0, 0, 0), Vector3(L0, L0, L0), -1, 0, A.n, True, 0.5,
                          [D_MIN, D_MAX], [0.0, 1.0], True, A.seed)
    if n_made != A.n or abs(sp.appliedPsdScaling - 1.0) > 1e-12:
        raise SystemExit(f"makeCloud made {n_made} spheres, PSD scaling {sp.appliedPsdScaling}")
    O.bodies.append([utils.sphere(c, r, material="grains") for c, r in sp])
    O.dt = A.dt_factor * T_R
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                        [Ip2_FrictMat_FrictMat_MindlinPhys(en=A.en)],
                        [Law2_ScGeom_MindlinPhys_Mindlin()]),
        PeriTriaxController(stressMask=7, goal=Vector3(-A.sigma0, -A.sigma0, -A.sigma0),
                            maxStrainRate=Vector3(A.cgas, A.cgas, A.cgas),
                            maxUnbalanced=A.unb, relStressTol=A.stol,
                            absStressTol=A.stol * A.sigma0, globUpdate=A.glob_update,
                            dynCell=False, label="triax"),
        PyRunner(iterPeriod=10, command="gas_cap()", label="gascap"),
        PyRunner(iterPeriod=A.sample_every, command="sample()", dead=True, label="sampler"),
        NewtonIntegrator(damping=0.0, gravity=(0, 0, 0)),
    ]
    L0_CLOUD = L0
    ST = {"phase": 1, "steps1": 0, "t1": 0.0, "t2": 0.0, "rows": 0, "processes": 1, "L0": L0}
else:
    O.load(A.resume)
    ST = _saved["state"]
    ST["processes"] += 1
    L0_CLOUD = ST["L0"]

ENG = {e.label: e for e in O.engines if e.label}
triax, GAS, SAMPLER = ENG["triax"], ENG["gascap"], ENG["sampler"]
IDS = [b.id for b in O.bodies]
RADII = [b.shape.radius for b in O.bodies]
N = len(IDS)
V_SOLID = sum(4.0 / 3.0 * math.pi * r ** 3 for r in RADII)
D_MEAN = 2.0 * sum(RADII) / N
EDOT0 = A.inertia / (D_MEAN * math.sqrt(A.rho / A.sigma0))
NROWS = max(1, round(A.eps1 / A.rec))
NREC = max(1, round(A.eps1 / (NROWS * EDOT0 * O.dt)))
NSTEPS2 = NROWS * NREC
EDOT = A.eps1 / (NSTEPS2 * O.dt)
T_PROCESS = 0.0          # time stepping done by this process

import yade.config  # noqa: E402

if _saved is None:
    say(f"SETUP yade version={yade.config.version} threads={O.numThreads} N={N} "
        f"d=[{2 * min(RADII):.6g}, {2 * max(RADII):.6g}] m d_mean(number)={D_MEAN:.6g} m "
        f"solid_volume={V_SOLID:.6g} m3 L0={L0_CLOUD:.6g} m "
        f"phi_cloud={V_SOLID / O.cell.volume:.4f}")
    say(f"SETUP rho={A.rho} kg/m3 E={A.young} Pa nu={A.nu} G={G} Pa en={A.en} "
        f"mu_phase2={A.mu} sigma0={A.sigma0} Pa")
    say(f"SETUP T_Rayleigh(dmin)={T_R:.6g} s dt={O.dt:.6g} s ({A.dt_factor} T_R)")
    say(f"SETUP phase2 edot={EDOT:.6g} 1/s "
        f"I={EDOT * D_MEAN * math.sqrt(A.rho / A.sigma0):.6g} eps1={A.eps1} rows={NROWS} "
        f"steps_per_row={NREC} steps={NSTEPS2}")
else:
    say(f"RESUME from {A.resume}: phase {ST['phase']}, iteration {O.iter}, process "
        f"{ST['processes']}, threads={O.numThreads}")


# ---------------------------------------------------------------- measures
def stresses():
    """Compression-positive diagonal of the Love-Weber stress (sx, sy, sz)."""
    s = utils.getStress()
    return -s[0, 0], -s[1, 1], -s[2, 2]


def phi():
    return V_SOLID / O.cell.volume


def z_all():
    return utils.avgNumInteractions()


def z_nr():
    return contact_counts.contact_stats(O.interactions, IDS, set(), 2)[1]


def gas_cap():
    """Phase 1: strain-rate cap cgas while p < pgas sigma0, crate afterwards. p from the
    controller's last stress reading (``stressTensor``; its ``stress`` also holds the
    prediction it adds after each step, which alone exceeded pgas sigma0 in the gas)."""
    p = -triax.stressTensor.trace() / 3.0
    cap = A.cgas if p < A.pgas * A.sigma0 else A.crate
    triax.maxStrainRate = Vector3(cap, cap, cap)


ACC = {"sum": [0.0, 0.0, 0.0], "n": 0}


def sample():
    sx, sy, sz = stresses()
    ACC["sum"][0] += sx
    ACC["sum"][1] += sy
    ACC["sum"][2] += sz
    ACC["n"] += 1


builtins.gas_cap = gas_cap
builtins.sample = sample


def timed_run(steps):
    global T_PROCESS
    t0 = time.perf_counter()
    O.run(steps, True)
    dt = time.perf_counter() - t0
    T_PROCESS += dt
    return dt


def checkpoint_if_due():
    """Save and stop when this process has stepped for --max-process-wall seconds."""
    if not (A.checkpoint and A.max_process_wall > 0 and T_PROCESS >= A.max_process_wall):
        return
    t0 = time.perf_counter()
    O.save(A.checkpoint)
    with open(A.checkpoint + ".json", "w") as f:
        json.dump({"args": vars(A), "state": ST}, f)
    say(f"CHECKPOINT path={A.checkpoint} phase={ST['phase']} iteration={O.iter} "
        f"save_s={time.perf_counter() - t0:.3g}")
    sys.exit(0)


# ---------------------------------------------------------------- phase 1
if ST["phase"] == 1:
    while True:
        ST["t1"] += timed_run(A.check_every)
        ST["steps1"] += A.check_every
        s = stresses()
        unb = utils.unbalancedForce()
        say(f"COMPACT steps={ST['steps1']} wall_s={ST['t1']:.6g} phi={phi():.6f} "
            f"z={z_all():.4f} s=({s[0]:.6g}, {s[1]:.6g}, {s[2]:.6g}) Pa unbalanced={unb:.4g}")
        if max(abs(si / A.sigma0 - 1.0) for si in s) < A.stol and unb < A.unb:
            break
        if ST["steps1"] >= A.max_steps1 or ST["t1"] > A.max_wall:
            raise SystemExit("phase 1 did not converge")
        checkpoint_if_due()
    ST.update({"phi1": phi(), "z1": z_all(), "z_nr1": z_nr()})
    say(f"PHASE1 steps={ST['steps1']} wall_s={ST['t1']:.6g} "
        f"particle_steps_per_s={N * ST['steps1'] / ST['t1']:.6g} phi={ST['phi1']:.6f} "
        f"z={ST['z1']:.4f} z_nr={ST['z_nr1']:.4f} s=({s[0]:.6g}, {s[1]:.6g}, {s[2]:.6g}) Pa "
        f"unbalanced={unb:.4g}")

    # -------------------------------------------------------- start of phase 2
    GAS.dead = True
    utils.setContactFriction(math.atan(A.mu))
    ST["H0"] = list(O.cell.size)
    ST["V0"] = O.cell.volume
    triax.stressMask = 3
    # z: strain-controlled, goal beyond the target so that the rate stays at its cap (edot);
    # the run stops after NSTEPS2 steps
    triax.goal = Vector3(-A.sigma0, -A.sigma0, triax.strain[2] - A.eps1 - 0.1)
    triax.maxStrainRate = Vector3(A.lateral_cap, A.lateral_cap, EDOT)
    ST["phase"] = 2
    say("ROWHEAD step eps_1 eps_v sigma_1 sigma_3 p q_over_trace eta q_over_trace_inst phi z "
        "sx_over_s0 sy_over_s0 inertia_number")
    ST["row0"] = stresses()
    SAMPLER.dead = False


# ---------------------------------------------------------------- phase 2
def row(step, s_avg):
    sx_, sy_, sz_ = s_avg
    s1, s3 = sz_, 0.5 * (sx_ + sy_)
    p = (s1 + 2 * s3) / 3.0
    si = stresses()
    qpi = (si[2] - 0.5 * (si[0] + si[1])) / (si[0] + si[1] + si[2])
    e1 = math.log(ST["H0"][2] / O.cell.size[2])
    ev = math.log(ST["V0"] / O.cell.volume)
    inertia = EDOT * D_MEAN * math.sqrt(A.rho / p) if p > 0 else 0.0
    say(f"ROW {step} {e1:.10g} {ev:.10g} {s1:.10g} {s3:.10g} {p:.10g} "
        f"{(s1 - s3) / (3 * p):.10g} {(s1 - s3) / p:.10g} {qpi:.10g} {phi():.10g} "
        f"{z_all():.6g} {sx_ / A.sigma0:.10g} {sy_ / A.sigma0:.10g} {inertia:.6g}")


if ST["rows"] == 0:
    row(0, ST["row0"])
while ST["rows"] < NROWS:
    ACC["sum"], ACC["n"] = [0.0, 0.0, 0.0], 0
    ST["t2"] += timed_run(NREC)
    ST["rows"] += 1
    n = max(ACC["n"], 1)
    row(ST["rows"] * NREC, [v / n for v in ACC["sum"]])
    if ST["t2"] > A.max_wall:
        raise SystemExit("phase 2 exceeded --max-wall")
    if ST["rows"] < NROWS:
        checkpoint_if_due()
T1, T2, steps1 = ST["t1"], ST["t2"], ST["steps1"]
e1 = math.log(ST["H0"][2] / O.cell.size[2])
ev = math.log(ST["V0"] / O.cell.volume)
say(f"PHASE2 steps={NSTEPS2} wall_s={T2:.6g} particle_steps_per_s={N * NSTEPS2 / T2:.6g} "
    f"eps_1={e1:.6g} eps_v={ev:.6g} phi={phi():.6f} z={z_all():.4f} z_nr={z_nr():.4f}")
say(f"RESULT peer=yade N={N} steps1={steps1} wall1_s={T1:.6g} steps2={NSTEPS2} "
    f"wall2_s={T2:.6g} steps={steps1 + NSTEPS2} wall_s={T1 + T2:.6g} "
    f"particle_steps_per_s={N * (steps1 + NSTEPS2) / (T1 + T2):.6g} phi1={ST['phi1']:.6f} "
    f"z1={ST['z1']:.4f} processes={ST['processes']}")
