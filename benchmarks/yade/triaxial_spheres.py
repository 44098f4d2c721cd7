"""Reference YADE run: triaxial compression of a polydisperse sphere packing.

Written for YADE 2023.02a (Debian package, command ``yade``). Run it as a YADE script;
its options go after the script name and reach it through ``sys.argv``::

    yade -j 2 -n -x benchmarks/yade/triaxial_spheres.py [options]
    yade -j 2 -n -x benchmarks/yade/triaxial_spheres.py --eps-q-target 0.2 --csv /tmp/triax.csv
    yade -n -x benchmarks/yade/triaxial_spheres.py --help

(``-j 2``: two OpenMP threads; ``-n``: no GUI; ``-x``: exit when the script ends. On a
machine whose cores are busy with other processes, add ``OMP_WAIT_POLICY=PASSIVE`` in front
of ``yade -j 2``: with the default spinning policy YADE then runs 5-10 times slower.)
This is a YADE script, not a grainlab module: it needs YADE's Python, not the project's venv.

What it does (defaults in brackets; all SI units):

1. Loose cloud: ``pack.SpherePack().makeCloud`` of N [1000] spheres, diameters in
   [d_min, ratio*d_min] [1 mm, 2 mm], uniform by volume fraction (``distributeMass=True``:
   equal solid volume per diameter class, i.e. number density of d proportional to d^-3);
   with ``num`` given YADE draws the sizes deterministically (quantiles), the positions at
   random (``--seed``), in a cube at solid fraction ``--phi-cloud`` [0.2]. Density 2600,
   no gravity. Six frictionless walls (``aabbWalls``, zero thickness).
2. Isotropic compaction to sigma0 [10 kPa] by the walls (``TriaxialStressController``,
   ``internalCompaction=False``, stress control on the three axes; wall speed capped so
   that the compaction strain rate stays below ``--comp-rate`` [5 /s]) WITHOUT interparticle
   friction, until quasi-static: unbalanced force < ``--unb`` [0.01] and each of the three
   wall stresses within ``--stress-tol`` [1 %] of sigma0 (checked every ``--check-every``
   [1000] steps).
3. Interparticle friction mu [0.4] (``setContactFriction``, walls stay frictionless), then
   triaxial compression with the same engine (``stressMask=5``): top/bottom walls (y axis)
   at a constant true (logarithmic) axial strain rate, lateral walls (x, z) at constant
   stress sigma0, until eps_q = eps_1 - eps_3 reaches ``--eps-q-target`` [0.5].

Contact law: linear Cundall-Strack spring with Coulomb friction, no viscous damping in the
contacts (FrictMat / ``Ip2_FrictMat_FrictMat_FrictPhys`` /
``Law2_ScGeom_FrictPhys_CundallStrack``). YADE sets k_n = 2 E R1 R2 / (R1 + R2) = E d_h / 2
(d_h: harmonic mean diameter of the pair), so the stiffness number
kappa = k_n / (sigma0 d) = E / (2 sigma0) for every pair: E = 2 kappa sigma0 with
``--kappa`` [1e4]; k_t = ``--kt-kn`` [0.5] * k_n. Global (Cundall) damping 0.2 in
``NewtonIntegrator``; dt = ``--dt-safety`` [0.5] * ``PWaveTimeStep()``, or with
``--timestepper gsts`` YADE's ``GlobalStiffnessTimeStepper`` (safety ``--gsts-safety``
[0.8], every ``--gsts-interval`` [100] steps, starting from that dt). Linear springs at
another stiffness number: ``--kappa 1e3`` (E = 2 kappa sigma0; k_n/(sigma0 d) = kappa for a
pair of diameter d, hence for a pair of the mean diameter).
Axial strain rate: eps_dot = I / (d_mean sqrt(rho / sigma0)) with the inertia number I =
``--inertia`` [1e-3] and d_mean the number-mean diameter (or ``--strain-rate`` directly).

Conventions: compression positive for stresses and strains; axis 1 = y (axial),
3 = lateral (x and z averaged). Strains are logarithmic from the box dimensions at the
start of the triaxial phase: eps_1 = ln(h0/h), eps_3 = [ln(w0/w) + ln(D0/D)]/2,
eps_vol = eps_1 + 2 eps_3, eps_q = eps_1 - eps_3. Stresses are wall force / current face
area (mean of the two opposite walls). p = (s1 + 2 s3)/3, q_over_3 = (s1 - s3)/3 (seed
002's q, with the 1/3) and q_over_trace = q_over_3 / p (the seeds' q/p), the column names
of grainlab's results (grainlab.result.columns).

Output: a CSV (``--csv``) with one row about every ``--record-every`` [0.01] of eps_q:
instantaneous state (strains, wall stresses, p, q_over_3, q/p, packing fraction, coordination
numbers, unbalanced force, inertia number, largest overlap over the number-mean diameter:
``max_overlap_over_d``, grainlab's column) and q/p averaged over the samples (every
``--sample-every`` [20] steps) since the previous row (``qp_avg``). Peak and residual
q/p are computed from ``qp_avg`` (the instantaneous peak is printed too). Residual: mean
over eps_q in [0.3, 0.5] if the run reaches 0.5, else over the last 30 % of eps_q reached.

Coordination numbers: z = 2 C_ss / N over force-carrying sphere-sphere contacts;
rattlers: spheres with fewer than ``--min-contacts`` [2] force-carrying contacts (walls
included), removed repeatedly; z_nr = 2 C_ss(non-rattlers) / N(non-rattlers);
z_walls_nr = 2 [C_ss + C_sw](non-rattlers) / N(non-rattlers) also counts the sphere-wall
contacts (C_sw), the number to compare with 6 for an isostatic frictionless packing in a
small walled box. At the end of the (frictionless) compaction they are also given with the
rattler threshold 4.

A final summary (lines starting ``RESULT``) gives wall times of the compaction and triaxial
phases, numbers of steps, peak and residual q/p, packing fraction and z.
"""

import argparse
import builtins
import csv
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(sys.argv[0])))
import contact_counts
from yade import O, pack, utils
from yade.minieigenHP import Vector3
from yade.wrapper import (
    Bo1_Box_Aabb,
    Bo1_Sphere_Aabb,
    ForceResetter,
    FrictMat,
    GlobalStiffnessTimeStepper,
    Ig2_Box_Sphere_ScGeom,
    Ig2_Sphere_Sphere_ScGeom,
    InsertionSortCollider,
    InteractionLoop,
    Ip2_FrictMat_FrictMat_FrictPhys,
    Law2_ScGeom_FrictPhys_CundallStrack,
    NewtonIntegrator,
    PyRunner,
    TriaxialStressController,
)


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="yade -j 2 -n -x triaxial_spheres.py",
                                 description="YADE reference triaxial test on spheres.")
    ap.add_argument("--n", type=int, default=1000, help="number of spheres")
    ap.add_argument("--dmin", type=float, default=1e-3, help="smallest diameter [m]")
    ap.add_argument("--dratio", type=float, default=2.0, help="d_max / d_min")
    ap.add_argument("--rho", type=float, default=2600.0, help="grain density [kg/m3]")
    ap.add_argument("--sigma0", type=float, default=1e4, help="confining stress [Pa]")
    ap.add_argument("--kappa", type=float, default=1e4, help="stiffness number k_n/(sigma0 d)")
    ap.add_argument("--kt-kn", type=float, default=0.5, help="tangential/normal stiffness")
    ap.add_argument("--mu", type=float, default=0.4, help="interparticle friction (triaxial)")
    ap.add_argument("--damping", type=float, default=0.2, help="NewtonIntegrator damping")
    ap.add_argument("--dt-safety", type=float, default=0.5, help="dt = this * PWaveTimeStep()")
    ap.add_argument("--timestepper", choices=["pwave", "gsts"], default="pwave",
                    help="pwave: fixed dt = --dt-safety * PWaveTimeStep(); gsts: "
                         "GlobalStiffnessTimeStepper (dt from the contact stiffnesses, "
                         "starting from the pwave value)")
    ap.add_argument("--gsts-safety", type=float, default=0.8,
                    help="GlobalStiffnessTimeStepper.timestepSafetyCoefficient")
    ap.add_argument("--gsts-interval", type=int, default=100,
                    help="GlobalStiffnessTimeStepper.timeStepUpdateInterval [steps]")
    ap.add_argument("--inertia", type=float, default=1e-3,
                    help="target inertia number at p = sigma0 (sets the axial strain rate)")
    ap.add_argument("--strain-rate", type=float, default=None,
                    help="axial strain rate [1/s] (overrides --inertia)")
    ap.add_argument("--eps-q-target", type=float, default=0.5, help="stop at this eps_q")
    ap.add_argument("--record-every", type=float, default=0.01, help="CSV row every d(eps_q)")
    ap.add_argument("--sample-every", type=int, default=20, help="steps between samples")
    ap.add_argument("--csv", default="triaxial_spheres_yade.csv", help="CSV output path")
    ap.add_argument("--seed", type=int, default=1, help="makeCloud seed")
    ap.add_argument("--phi-cloud", type=float, default=0.2, help="solid fraction of the cloud")
    ap.add_argument("--comp-rate", type=float, default=5.0,
                    help="max strain rate of the walls during compaction [1/s]")
    ap.add_argument("--unb", type=float, default=0.01, help="unbalanced force threshold")
    ap.add_argument("--stress-tol", type=float, default=0.01,
                    help="relative stress tolerance for the end of compaction")
    ap.add_argument("--check-every", type=int, default=1000,
                    help="steps between checks of the compaction criteria")
    ap.add_argument("--min-contacts", type=int, default=2, help="rattler threshold")
    ap.add_argument("--max-wall", type=float, default=7200.0,
                    help="abort a phase after this many seconds of wall time")
    ap.add_argument("--progress-every", type=float, default=30.0,
                    help="seconds between progress lines")
    return ap.parse_args(argv)


A = parse_args(sys.argv[1:])


def say(*a):
    print(*a, flush=True)


def load_line():
    l1, l5, l15 = os.getloadavg()
    return f"{l1:.2f} {l5:.2f} {l15:.2f} on {os.cpu_count()} CPUs"


# ---------------------------------------------------------------- 1. loose cloud
T_START = time.perf_counter()
D_MIN, D_MAX = A.dmin, A.dratio * A.dmin
# expected solid volume of N spheres, number density ~ d^-3 on [D_MIN, D_MAX]
_mean_d3 = (D_MAX - D_MIN) / (0.5 * (D_MIN ** -2 - D_MAX ** -2))
V_SOLID_EXPECTED = A.n * math.pi / 6.0 * _mean_d3
L0 = (V_SOLID_EXPECTED / A.phi_cloud) ** (1.0 / 3.0)

E = 2.0 * A.kappa * A.sigma0
O.materials.append(FrictMat(young=E, poisson=A.kt_kn, frictionAngle=0.0, density=A.rho,
                            label="spheres"))
O.materials.append(FrictMat(young=E, poisson=A.kt_kn, frictionAngle=0.0, density=0.0,
                            label="walls"))
# walls first: ids 0..5 = left, right, bottom, top, back, front (TriaxialStressController defaults)
WALL_IDS = O.bodies.append(utils.aabbWalls([Vector3(0, 0, 0), Vector3(L0, L0, L0)],
                                           thickness=0, material="walls"))
assert list(WALL_IDS) == [0, 1, 2, 3, 4, 5], WALL_IDS
LEFT, RIGHT, BOTTOM, TOP, BACK, FRONT = WALL_IDS

sp = pack.SpherePack()
# porosity=0.5 only serves YADE's "does it fit" check (no rescaling of the PSD); the cloud
# fills the L0-cube at solid fraction phi_cloud.
n_made = sp.makeCloud(Vector3(0, 0, 0), Vector3(L0, L0, L0), -1, 0, A.n, False, 0.5,
                      [D_MIN, D_MAX], [0.0, 1.0], True, A.seed)
if n_made != A.n or abs(sp.appliedPsdScaling - 1.0) > 1e-12:
    raise SystemExit(f"makeCloud made {n_made} spheres with PSD scaling {sp.appliedPsdScaling}")
SPHERE_IDS = O.bodies.append([utils.sphere(c, r, material="spheres") for c, r in sp])
RADII = [O.bodies[i].shape.radius for i in SPHERE_IDS]
N = len(SPHERE_IDS)
V_SOLID = sum(4.0 / 3.0 * math.pi * r ** 3 for r in RADII)
D_MEAN = 2.0 * sum(RADII) / N                      # number-mean diameter
D_MEAN_V = sum(2 * r ** 4 for r in RADII) / sum(r ** 3 for r in RADII)  # volume-weighted
IS_WALL = set(WALL_IDS)

triax = TriaxialStressController(
    thickness=0.0, internalCompaction=False, stressMask=7,
    goal1=-A.sigma0, goal2=-A.sigma0, goal3=-A.sigma0,
    max_vel=0.5 * A.comp_rate * L0, label="triax")
SAMPLER = PyRunner(iterPeriod=A.sample_every, command="sample()", dead=True)
newton = NewtonIntegrator(damping=A.damping, gravity=(0, 0, 0), label="newton")
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_FrictPhys()],
                    [Law2_ScGeom_FrictPhys_CundallStrack()]),
    triax,
    SAMPLER,
    newton,
]
O.dt = A.dt_safety * utils.PWaveTimeStep()
if A.timestepper == "gsts":
    GSTS = GlobalStiffnessTimeStepper(active=True, timeStepUpdateInterval=A.gsts_interval,
                                      timestepSafetyCoefficient=A.gsts_safety, defaultDt=O.dt,
                                      label="gsts")
    O.engines = [*O.engines[:3], GSTS, *O.engines[3:]]

if A.strain_rate is not None:
    EPS_DOT = A.strain_rate
else:
    EPS_DOT = A.inertia / (D_MEAN * math.sqrt(A.rho / A.sigma0))
I0 = EPS_DOT * D_MEAN * math.sqrt(A.rho / A.sigma0)
KN_MIN = E * D_MIN / 2.0
KN_MAX = E * D_MAX / 2.0
M_MIN = A.rho * math.pi / 6.0 * D_MIN ** 3
T_CLOUD = time.perf_counter() - T_START

say(f"SETUP load average (1, 5, 15 min) at start: {load_line()}")
say(f"SETUP yade threads={O.numThreads}  N={N}  d=[{2 * min(RADII):.4g}, {2 * max(RADII):.4g}] m"
    f"  d_mean(number)={D_MEAN:.5g} m  d_mean(volume)={D_MEAN_V:.5g} m")
say(f"SETUP solid volume={V_SOLID:.6g} m3  cloud cube L0={L0:.5g} m "
    f"(phi={V_SOLID / L0 ** 3:.3f})  cloud made in {T_CLOUD:.2f} s")
say(f"SETUP E={E:.4g} Pa  kappa=k_n/(sigma0 d)={A.kappa:.4g}  k_n={KN_MIN:.4g} N/m (d_min pair)"
    f" .. {KN_MAX:.4g} N/m (d_max pair)  k_t/k_n={A.kt_kn:.3g}")
say(f"SETUP dt={O.dt:.4g} s ({A.dt_safety:.2f} x PWaveTimeStep; "
    f"sqrt(m_min/kn_min)={math.sqrt(M_MIN / KN_MIN):.4g} s)  damping={A.damping:.2f}"
    + (f"; then GlobalStiffnessTimeStepper (safety {A.gsts_safety:g}, every "
       f"{A.gsts_interval} steps)" if A.timestepper == "gsts" else ""))
say(f"SETUP triaxial: axial strain rate={EPS_DOT:.5g} /s  inertia number at sigma0: I={I0:.4g}"
    f"  mu={A.mu:.3g}  target eps_q={A.eps_q_target:.3g}")


# ---------------------------------------------------------------- helpers
def box_dims():
    """Width (x), height (y), depth (z) from the wall positions (zero-thickness walls)."""
    b = O.bodies
    return (b[RIGHT].state.pos[0] - b[LEFT].state.pos[0],
            b[TOP].state.pos[1] - b[BOTTOM].state.pos[1],
            b[FRONT].state.pos[2] - b[BACK].state.pos[2])


def wall_stresses():
    """Compressive wall stresses (sx, sy, sz), each the mean of the two opposite walls."""
    w, h, d = box_dims()
    f = O.forces.f
    # the grains push the low wall towards -axis and the high wall towards +axis
    sx = 0.5 * (f(RIGHT, True)[0] - f(LEFT, True)[0]) / (h * d)
    sy = 0.5 * (f(TOP, True)[1] - f(BOTTOM, True)[1]) / (w * d)
    sz = 0.5 * (f(FRONT, True)[2] - f(BACK, True)[2]) / (w * h)
    return sx, sy, sz


def packing_fraction():
    w, h, d = box_dims()
    return V_SOLID / (w * h * d)


def contact_stats(min_contacts):
    """(z, z_nr, rattler fraction, z_walls_nr) over force-carrying contacts
    (:func:`contact_counts.contact_stats`)."""
    return contact_counts.contact_stats(O.interactions, SPHERE_IDS, IS_WALL, min_contacts)


def stiffness_check():
    """Realised k_n / (sigma0 d_h) over sphere-sphere contacts and k_n range of both kinds."""
    ss, sw, kap = [], [], []
    for it in O.interactions:
        if not it.isReal:
            continue
        kn = it.phys.kn
        if it.id1 in IS_WALL or it.id2 in IS_WALL:
            sw.append(kn)
        else:
            r1, r2 = O.bodies[it.id1].shape.radius, O.bodies[it.id2].shape.radius
            ss.append(kn)
            kap.append(kn / (A.sigma0 * 4.0 * r1 * r2 / (r1 + r2)))
    return ss, sw, kap


class Progress:
    def __init__(self):
        self.t = time.perf_counter()

    def due(self):
        now = time.perf_counter()
        if now - self.t >= A.progress_every:
            self.t = now
            return True
        return False


# ---------------------------------------------------------------- 2. isotropic compaction
say(f"COMPACTION start: frictionless, sigma0={A.sigma0:g} Pa, "
    f"wall speed cap {triax.max_vel:.4g} m/s")
t0 = time.perf_counter()
it0 = O.iter
prog = Progress()
while True:
    O.run(A.check_every, True)
    unb = utils.unbalancedForce()
    s = wall_stresses()
    err = max(abs(si - A.sigma0) / A.sigma0 for si in s)
    wall = time.perf_counter() - t0
    if unb < A.unb and err < A.stress_tol:
        break
    phi = packing_fraction()
    if prog.due():
        say(f"  compaction iter={O.iter} t_wall={wall:.0f} s  phi={phi:.4f}  "
            f"s=({s[0]:.4g}, {s[1]:.4g}, {s[2]:.4g}) Pa  unb={unb:.3g}")
    if phi > 0.8:
        raise SystemExit(f"compaction failed: packing fraction {phi:.3g} > 0.8 (grains escaped?)")
    if wall > A.max_wall:
        raise SystemExit(f"compaction did not converge within --max-wall={A.max_wall:g} s")
T_COMP = time.perf_counter() - t0
STEPS_COMP = O.iter - it0
PHI_COMP = packing_fraction()
Z_COMP = contact_stats(A.min_contacts)
Z_COMP_ISO = contact_stats(4)
SIMT_COMP = O.time
say(f"COMPACTION done: wall time {T_COMP:.2f} s, {STEPS_COMP} steps "
    f"({STEPS_COMP / T_COMP:.1f} steps/s), simulated time {SIMT_COMP:.4g} s, dt now {O.dt:.4g} s")
say(f"COMPACTION state: phi={PHI_COMP:.4f}  unb={unb:.3g}  "
    f"s=({s[0]:.5g}, {s[1]:.5g}, {s[2]:.5g}) Pa  z={Z_COMP[0]:.3f}  "
    f"z_nr(min {A.min_contacts})={Z_COMP[1]:.3f} rattlers={Z_COMP[2]:.3f} "
    f"z_walls_nr={Z_COMP[3]:.3f};  min 4: z_nr={Z_COMP_ISO[1]:.3f} "
    f"rattlers={Z_COMP_ISO[2]:.3f} z_walls_nr={Z_COMP_ISO[3]:.3f}")
_ss, _sw, _kap = stiffness_check()
say(f"COMPACTION stiffness: sphere-sphere k_n in [{min(_ss):.4g}, {max(_ss):.4g}] N/m "
    f"(mean {sum(_ss) / len(_ss):.4g}), k_n/(sigma0 d_h) in [{min(_kap):.5g}, {max(_kap):.5g}]; "
    f"sphere-wall k_n in [{min(_sw):.4g}, {max(_sw):.4g}] N/m; "
    f"mean k_n/(sigma0 d_mean)={sum(_ss) / len(_ss) / (A.sigma0 * D_MEAN):.4g}")

# ---------------------------------------------------------------- 3. triaxial compression
utils.setContactFriction(math.atan(A.mu))   # spheres and sphere-sphere contacts; walls keep 0
triax.stressMask = 5                         # x and z stress-controlled, y strain-controlled
triax.goal1 = -A.sigma0
triax.goal3 = -A.sigma0
triax.goal2 = -EPS_DOT                       # true strain rate (compression negative)
triax.max_vel = 1.0                          # YADE default cap on the lateral walls

W0, H0, D0 = box_dims()
COLUMNS = ["iter", "time", "eps_1", "eps_3", "eps_vol", "eps_q", "sigma_1", "sigma_3",
           "sigma_x", "sigma_z", "p", "q_over_3", "q_over_trace", "qp_avg", "n_samples", "phi",
           "z", "z_no_rattlers", "rattler_fraction", "z_walls_no_rattlers", "unbalanced",
           "inertia_number", "max_overlap_over_d"]
os.makedirs(os.path.dirname(os.path.abspath(A.csv)), exist_ok=True)
CSV_FILE = open(A.csv, "w", newline="")  # kept open during the run
CSV = csv.writer(CSV_FILE)
CSV.writerow(COLUMNS)
ROWS = []
ST = {"next": 0.0, "sum_qp": 0.0, "n": 0, "t0": time.perf_counter(), "it0": O.iter,
      "time0": O.time, "eps_q": 0.0, "done": False, "prog": Progress(), "marks": {}}
MARKS = [0.1, 0.2, 0.3, 0.4, 0.5]


def strains():
    w, h, d = box_dims()
    e1 = math.log(H0 / h)
    e3 = 0.5 * (math.log(W0 / w) + math.log(D0 / d))
    return e1, e3, e1 + 2 * e3, e1 - e3


def largest_overlap():
    """The largest overlap [m] of the contacts now (sphere-sphere and sphere-wall)."""
    return max((i.geom.penetrationDepth for i in O.interactions if i.isReal), default=0.0)


def write_row(e, s, qp_avg, n):
    sx, sy, sz = s
    s1, s3 = sy, 0.5 * (sx + sz)
    p = (s1 + 2 * s3) / 3.0
    q = (s1 - s3) / 3.0
    z, z_nr, rat, z_nr_w = contact_stats(A.min_contacts)
    row = [O.iter, O.time - ST["time0"], e[0], e[1], e[2], e[3], s1, s3, sx, sz, p, q, q / p,
           qp_avg, n, packing_fraction(), z, z_nr, rat, z_nr_w, utils.unbalancedForce(),
           EPS_DOT * D_MEAN * math.sqrt(A.rho / p) if p > 0 else float("nan"),
           largest_overlap() / D_MEAN]
    ROWS.append(dict(zip(COLUMNS, row, strict=True)))
    CSV.writerow([f"{v:.8g}" if isinstance(v, float) else v for v in row])
    CSV_FILE.flush()


def sample():
    """PyRunner during the triaxial phase: accumulate q/p, write rows, stop at the target."""
    if ST["done"]:
        return
    e = strains()
    s = wall_stresses()
    s1, s3 = s[1], 0.5 * (s[0] + s[2])
    p = (s1 + 2 * s3) / 3.0
    ST["sum_qp"] += (s1 - s3) / 3.0 / p if p > 0 else 0.0
    ST["n"] += 1
    ST["eps_q"] = e[3]
    for m in MARKS:
        if m not in ST["marks"] and e[3] >= m:
            ST["marks"][m] = (time.perf_counter() - ST["t0"], O.iter - ST["it0"])
            say(f"  eps_q={m:.2f} reached: wall {ST['marks'][m][0]:.1f} s, "
                f"{ST['marks'][m][1]} steps")
    if e[3] >= ST["next"] - 1e-12 or e[3] >= A.eps_q_target:
        write_row(e, s, ST["sum_qp"] / ST["n"], ST["n"])
        ST["sum_qp"], ST["n"] = 0.0, 0
        ST["next"] += A.record_every
        while ST["next"] <= e[3]:
            ST["next"] += A.record_every
    if ST["prog"].due():
        r = ROWS[-1]
        say(f"  triax iter={O.iter} t_wall={time.perf_counter() - ST['t0']:.0f} s  "
            f"eps_q={e[3]:.4f} eps_1={e[0]:.4f} eps_vol={e[2]:.4f}  q/p(avg)={r['qp_avg']:.4f} "
            f"phi={r['phi']:.4f} z={r['z']:.3f}")
    if e[3] >= A.eps_q_target or time.perf_counter() - ST["t0"] > A.max_wall:
        ST["done"] = True
        O.pause()


builtins.sample = sample     # PyRunner commands are evaluated in YADE's global namespace

say(f"TRIAXIAL start: box w={W0:.5g} h={H0:.5g} d={D0:.5g} m, csv={A.csv}")
sample()                       # row at eps_q = 0 (end of compaction, friction switched on)
SAMPLER.dead = False
O.run()
O.wait()
T_TRIAX = time.perf_counter() - ST["t0"]
STEPS_TRIAX = O.iter - ST["it0"]
CSV_FILE.close()

# ---------------------------------------------------------------- summary
last = ROWS[-1]
eq_final = last["eps_q"]
peak = max(ROWS[1:], key=lambda r: r["qp_avg"])
peak_inst = max(ROWS, key=lambda r: r["q_over_trace"])
if eq_final >= 0.5 - 1e-9:
    lo, hi = 0.3, 0.5
else:
    lo, hi = 0.7 * eq_final, eq_final
win = [r for r in ROWS[1:] if lo + A.record_every - 1e-9 <= r["eps_q"] <= hi + 1e-9]
if not win:
    win = ROWS[-1:]
resid = sum(r["qp_avg"] * r["n_samples"] for r in win) / sum(r["n_samples"] for r in win)
z_end = contact_stats(A.min_contacts)

say(f"TRIAXIAL done: wall time {T_TRIAX:.2f} s, {STEPS_TRIAX} steps "
    f"({STEPS_TRIAX / T_TRIAX:.1f} steps/s), simulated time {O.time - SIMT_COMP:.4g} s "
    f"(mean dt {(O.time - SIMT_COMP) / max(STEPS_TRIAX, 1):.4g} s), eps_q={eq_final:.4f}")
for m in MARKS:
    if m in ST["marks"]:
        tw, ns = ST["marks"][m]
        say(f"  to eps_q={m:.1f}: {tw:.1f} s wall, {ns} steps, {tw / m:.1f} s per unit eps_q")
say(f"RESULT threads={O.numThreads} N={N} seed={A.seed} kappa={A.kappa:g} E={E:.4g} "
    f"k_n(d_min)={KN_MIN:.4g} dt={O.dt:.4g} timestepper={A.timestepper} "
    f"strain_rate={EPS_DOT:.5g} I0={I0:.4g}")
say(f"RESULT compaction: wall {T_COMP:.2f} s, steps {STEPS_COMP}, phi={PHI_COMP:.4f}, "
    f"z={Z_COMP[0]:.3f}, z_nr={Z_COMP[1]:.3f} (rattlers {Z_COMP[2]:.3f}), "
    f"z_walls_nr={Z_COMP[3]:.3f}; rattler threshold 4: z_nr={Z_COMP_ISO[1]:.3f} "
    f"(rattlers {Z_COMP_ISO[2]:.3f}) z_walls_nr={Z_COMP_ISO[3]:.3f}")
say(f"RESULT triaxial: wall {T_TRIAX:.2f} s, steps {STEPS_TRIAX}, final eps_q={eq_final:.4f} "
    f"eps_1={last['eps_1']:.4f} eps_vol={last['eps_vol']:.4f}")
say(f"RESULT peak q/p (interval mean)={peak['qp_avg']:.4f} at eps_q={peak['eps_q']:.3f}; "
    f"peak q/p (instantaneous)={peak_inst['q_over_trace']:.4f} at eps_q={peak_inst['eps_q']:.3f}")
say(f"RESULT residual q/p={resid:.4f} (mean over eps_q in [{lo:.3f}, {hi:.3f}], "
    f"{len(win)} rows)")
say(f"RESULT final: phi={last['phi']:.4f} z={z_end[0]:.3f} z_nr={z_end[1]:.3f} "
    f"rattlers={z_end[2]:.3f} z_walls_nr={z_end[3]:.3f} "
    f"inertia number={last['inertia_number']:.4g}")
say(f"RESULT largest overlap / <d> in the rows of the triaxial phase="
    f"{max(r['max_overlap_over_d'] for r in ROWS):.4%}")
say(f"RESULT load average (1, 5, 15 min) at the end: {load_line()}")
say(f"RESULT total wall time {time.perf_counter() - T_START:.2f} s (cloud {T_CLOUD:.2f} s + "
    f"compaction {T_COMP:.2f} s + triaxial {T_TRIAX:.2f} s)")
