"""Reference YADE run: triaxial compression of a packing of random convex polyhedra.

Written for YADE 2023.02a (Debian package, command ``yade``, built with CGAL: the Polyhedra
module). Run it as a YADE script; its options go after the script name and reach it through
``sys.argv``::

    yade -j 1 -n -x benchmarks/yade/triaxial_polyhedra.py [options]
    yade -j 1 -n -x benchmarks/yade/triaxial_polyhedra.py --n 20 --eps-q-target 0.1
    yade -n -x benchmarks/yade/triaxial_polyhedra.py --help

(``-j 1``: one thread, see "Units" below for why; ``-n``: no GUI; ``-x``: exit when the
script ends; ``OMP_WAIT_POLICY=PASSIVE`` in front of ``yade`` on a busy machine. Expect
some 10-40 ms per step for 20-30 particles: N = 1000 to eps_q = 0.5 is out of reach.)
This is a YADE script, not a grainlab module: it needs YADE's Python (with numpy), not the
project's venv. It is the YADE counterpart of ``benchmarks/benchmark_lab_triaxial_polyhedra.py``
(seed 002, Azema et al. 2013) and follows ``triaxial_spheres.py`` wherever the shapes allow.

What it does (defaults in brackets; options and output in SI units; YADE itself works in
the length unit ``--length-unit`` [1 mm], kg and s, see below):

1. Shapes: each particle is the convex hull of n_v = (n_f + 4)/2 points uniform on a sphere
   (n_f = ``--faces`` [30] triangular faces, n_v = 17), drawn with numpy from ``--seed``.
   A hull is kept when its extents along its principal axes of inertia L >= l >= h satisfy
   h/L >= ``--min-axis-ratio`` [0.9] (hence h/l >= 0.9 too; grainlab's reading of seed
   002's criterion), otherwise it is drawn again. The generating sphere has the particle's
   circumscribed diameter d.
2. Loose cloud: ``pack.SpherePack().makeCloud`` of N [1000] spheres of diameters d in
   [d_min, ratio*d_min] [1 mm, 2 mm], uniform by volume fraction (``distributeMass=True``;
   sizes are deterministic quantiles, positions random with ``--seed``), in a cube where the
   spheres fill ``--phi-cloud`` [0.3] (the polyhedra about 0.6 of that); one polyhedron is
   inscribed in each sphere (``polyhedra_utils.polyhedra(material, v=...)``), so none
   overlap. Density 2600, no gravity.
3. Walls: YADE has no Box-Polyhedra contact geometry (no ``Ig2_Box_Polyhedra_*``), so the
   ``aabbWalls`` boxes and the ``TriaxialStressController`` of the sphere script cannot be
   used. The box is six ``Wall`` bodies (infinite planes, ``utils.wall``) in contact with the
   polyhedra through ``Ig2_Wall_Polyhedra_PolyhedraGeom`` and the same volumetric law,
   moved by a stress controller written here (``PyRunner`` every ``--servo-every`` [1]
   step): each wall moves along its normal with speed v = v_max clip(g (s_goal - s)/sigma0,
   -1, 1) (inward when its stress s = wall force / current face area is below the goal),
   g = ``--servo-gain`` [1]; in the compaction v_max drops from ``--comp-rate`` to
   ``--comp-rate-final`` [5 /s] x half the box size once the wall carries sigma0/2 (with
   the fast cap the stiff walls oscillated by about 5 % around sigma0).
4. Isotropic compaction to sigma0 [10 kPa] WITHOUT friction, v_max = ``--comp-rate``
   [50 /s] x half the box size, until quasi-static: unbalanced force < ``--unb`` [0.01] and
   each of the six wall stresses within ``--stress-tol`` [1 %] of sigma0 (checked every
   ``--check-every`` [1000] steps).
5. Friction mu [0.4] between polyhedra (``setContactFriction``; walls stay frictionless),
   then triaxial compression: top/bottom walls (y axis) at a constant true axial strain rate,
   the four lateral walls servo-controlled at sigma0 (v_max = ``--lat-rate`` [10] x axial
   strain rate x box width), until eps_q = eps_1 - eps_3 reaches ``--eps-q-target`` [0.5].

Contact law: YADE's volumetric law (``PolyhedraMat`` / ``Ip2_PolyhedraMat_PolyhedraMat_
PolyhedraPhys`` / ``Law2_PolyhedraGeom_PolyhedraPhys_Volumetric``): normal force
F_n = k_n V_o, with V_o the volume of the intersection of the two polyhedra, and an
incremental linear tangential spring k_s with a Coulomb limit; no contact viscosity. YADE
sets k_n = E/2 [N/m^3] and k_s = E nu/2 [N/m] for two identical materials. The stiffness
number is kappa = k_n d_mean / sigma0 (``--kappa`` [1e5]): a contact carrying
f = sigma0 d_mean^2 overlaps by V_o = d_mean^3 / kappa, i.e. a face-face contact by a depth
d_mean/(kappa a) (a = contact area / d_mean^2 ~ 0.1) and a vertex-face contact by about
(1/kappa)^(1/3) d_mean (2 % at kappa = 1e5, 1 % at 1e6). E = 2 kappa sigma0 / d_mean. With
kappa = 1e5 a full face-face contact of mean face area has k_n A_f / (sigma0 d_mean) = 8e3,
close to the sphere reference's 1e4; dt goes as kappa^-1/2. k_s is set
relative to the stiffness of a face-face contact, k_n A_f (A_f: mean face area):
k_s = ``--kt-kn`` [0.5] k_n A_f, i.e. nu = k_s / k_n. Walls: same material but
frictionless. Global (Cundall) damping 0.2 in ``NewtonIntegrator``. Time step:
dt = ``--dt-safety`` [0.3] sqrt(m_min / (k_n A_max)) with A_max the largest face area
(the stiffest face-face contact) and m_min the smallest particle mass.
Axial strain rate: eps_dot = I / (d_mean sqrt(rho / sigma0)) with the inertia number I =
``--inertia`` [1e-3] and d_mean the number-mean circumscribed diameter (as grainlab), or
``--strain-rate`` directly.

Units: with mm-sized polyhedra in SI units YADE 2023.02a aborted after some 10^4 steps
(``malloc(): unaligned fastbin chunk detected``, heap corruption in the CGAL-based contact
code, with 1 and 2 threads); it has absolute geometric tolerances. YADE therefore works in
the length unit U = ``--length-unit``: lengths L/U, density rho U^3, stresses sigma U
(kg and s unchanged, so times, masses and k_s in N/m are the same); the script converts its
output back to SI. The same heap corruption may still occur (it did not in the runs here
after the change); run with ``-j 1`` to be safe.

Conventions (as ``triaxial_spheres.py``): compression positive for stresses and strains;
axis 1 = y (axial), 3 = lateral (x and z averaged). Strains are logarithmic from the box
dimensions (wall positions) at the start of the triaxial phase: eps_1 = ln(h0/h),
eps_3 = [ln(w0/w) + ln(D0/D)]/2, eps_vol = eps_1 + 2 eps_3, eps_q = eps_1 - eps_3. Stresses
are wall force / current face area (mean of the two opposite walls). p = (s1 + 2 s3)/3,
q_over_3 = (s1 - s3)/3 (seed 002's q, with the 1/3) and q_over_trace = q_over_3 / p (the
seeds' q/p), the column names of grainlab's results (grainlab.result.columns). Packing
fraction = sum of the polyhedron volumes / box volume.

Output: a CSV (``--csv``) with one row about every ``--record-every`` [0.01] of eps_q:
instantaneous state (strains, wall stresses, p, q_over_3, q/p, packing fraction, coordination
numbers, largest overlap, unbalanced force, inertia number) and q/p averaged over the samples
(every ``--sample-every`` [20] steps) since the previous row (``qp_avg``). Peak and residual
q/p are computed from ``qp_avg`` (the instantaneous peak is printed too). Residual: mean
over eps_q in [0.3, 0.5] if the run reaches 0.5, else over the last 30 % of eps_q reached.

Coordination numbers: z = 2 C_pp / N over force-carrying polyhedron-polyhedron contacts
(one YADE interaction per pair, whatever its type); rattlers: particles with fewer than
``--min-contacts`` [2] force-carrying contacts (walls included), removed repeatedly;
z_nr = 2 C_pp(non-rattlers) / N(non-rattlers); z_walls_nr also counts the contacts with the
walls. Overlaps: ``PolyhedraGeom.equivalentPenetrationDepth`` (overlap volume / equivalent
cross-section) of the contacts, largest and mean, over d_mean.

A final summary (lines starting ``RESULT``) gives wall times of the compaction and triaxial
phases, numbers of steps, peak and residual q/p, packing fraction, z and overlaps.
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
import numpy as np
from yade import O, log, pack, polyhedra_utils, utils
from yade.minieigenHP import Vector3
from yade.wrapper import (
    Bo1_Polyhedra_Aabb,
    Bo1_Wall_Aabb,
    ForceResetter,
    Ig2_Polyhedra_Polyhedra_PolyhedraGeom,
    Ig2_Wall_Polyhedra_PolyhedraGeom,
    InsertionSortCollider,
    InteractionLoop,
    Ip2_PolyhedraMat_PolyhedraMat_PolyhedraPhys,
    Law2_PolyhedraGeom_PolyhedraPhys_Volumetric,
    NewtonIntegrator,
    Polyhedra,
    PolyhedraMat,
    PyRunner,
)


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="yade -j 2 -n -x triaxial_polyhedra.py",
                                 description="YADE reference triaxial test on polyhedra.")
    ap.add_argument("--n", type=int, default=1000, help="number of polyhedra")
    ap.add_argument("--faces", type=int, default=30, help="faces per polyhedron (even, >= 4)")
    ap.add_argument("--min-axis-ratio", type=float, default=0.9,
                    help="keep a hull when h/L >= this (0: keep all)")
    ap.add_argument("--dmin", type=float, default=1e-3,
                    help="smallest circumscribed diameter [m]")
    ap.add_argument("--dratio", type=float, default=2.0, help="d_max / d_min")
    ap.add_argument("--rho", type=float, default=2600.0, help="grain density [kg/m3]")
    ap.add_argument("--sigma0", type=float, default=1e4, help="confining stress [Pa]")
    ap.add_argument("--kappa", type=float, default=1e5,
                    help="stiffness number k_n d_mean / sigma0 (k_n in N/m3)")
    ap.add_argument("--kt-kn", type=float, default=0.5,
                    help="k_s / (k_n * mean face area)")
    ap.add_argument("--mu", type=float, default=0.4, help="interparticle friction (triaxial)")
    ap.add_argument("--damping", type=float, default=0.2, help="NewtonIntegrator damping")
    ap.add_argument("--dt-safety", type=float, default=0.3,
                    help="dt = this * sqrt(m_min / (k_n * largest face area))")
    ap.add_argument("--inertia", type=float, default=1e-3,
                    help="target inertia number at p = sigma0 (sets the axial strain rate)")
    ap.add_argument("--strain-rate", type=float, default=None,
                    help="axial strain rate [1/s] (overrides --inertia)")
    ap.add_argument("--eps-q-target", type=float, default=0.5, help="stop at this eps_q")
    ap.add_argument("--record-every", type=float, default=0.01, help="CSV row every d(eps_q)")
    ap.add_argument("--sample-every", type=int, default=20, help="steps between samples")
    ap.add_argument("--csv", default="triaxial_polyhedra_yade.csv", help="CSV output path")
    ap.add_argument("--seed", type=int, default=1, help="seed of makeCloud and of the shapes")
    ap.add_argument("--phi-cloud", type=float, default=0.3,
                    help="solid fraction of the circumscribed spheres in the cloud")
    ap.add_argument("--comp-rate", type=float, default=50.0,
                    help="max strain rate of the walls during compaction [1/s]")
    ap.add_argument("--lat-rate", type=float, default=10.0,
                    help="lateral wall speed cap in the triaxial phase, in axial strain rates")
    ap.add_argument("--comp-rate-final", type=float, default=5.0,
                    help="max strain rate of a wall loaded above sigma0/2 in compaction [1/s]")
    ap.add_argument("--servo-gain", type=float, default=1.0,
                    help="wall speed = v_max * clip(gain * stress error / sigma0, -1, 1)")
    ap.add_argument("--servo-every", type=int, default=1, help="steps between wall updates")
    ap.add_argument("--unb", type=float, default=0.01, help="unbalanced force threshold")
    ap.add_argument("--stress-tol", type=float, default=0.01,
                    help="relative stress tolerance for the end of compaction")
    ap.add_argument("--check-every", type=int, default=1000,
                    help="steps between checks of the compaction criteria")
    ap.add_argument("--min-contacts", type=int, default=2, help="rattler threshold")
    ap.add_argument("--length-unit", type=float, default=1e-3,
                    help="YADE's length unit [m] (model units: length/this, density*this^3, "
                         "stress*this; output in SI)")
    ap.add_argument("--max-wall", type=float, default=7200.0,
                    help="abort a phase after this many seconds of wall time")
    ap.add_argument("--progress-every", type=float, default=30.0,
                    help="seconds between progress lines")
    return ap.parse_args(argv)


A = parse_args(sys.argv[1:])
# YADE 2023.02a warns "Unhandled switch case:0, function do_intersect" for every polyhedron
# pair without a stored separating plane (a harmless missing `case 0`); silence it
log.setLevel("Polyhedra_support.cpp", log.ERROR)
# YADE's polyhedra code has absolute geometric tolerances and crashed (heap corruption in
# CGAL) with mm-sized particles in SI units: YADE works in a length unit U (mm by default),
# kg and s; lengths L/U, density rho U^3, stresses sigma U. The output is converted to SI.
U = A.length_unit
SI_DMIN, SI_RHO, SI_SIGMA0 = A.dmin, A.rho, A.sigma0
A.dmin, A.rho, A.sigma0 = A.dmin / U, A.rho * U ** 3, A.sigma0 * U
PA = 1.0 / U            # model stress -> Pa
if A.faces < 4 or A.faces % 2:
    raise SystemExit(f"--faces must be even and >= 4, got {A.faces}")


def say(*a):
    print(*a, flush=True)


def load_line():
    l1, l5, l15 = os.getloadavg()
    return f"{l1:.2f} {l5:.2f} {l15:.2f} on {os.cpu_count()} CPUs"


# ---------------------------------------------------------------- 1. shapes and loose cloud
T_START = time.perf_counter()
D_MIN, D_MAX = A.dmin, A.dratio * A.dmin
N_V = (A.faces + 4) // 2
RNG = np.random.default_rng(A.seed)


def unit_shape():
    """Points on the unit sphere whose hull passes the axis-ratio test; (points, h/L, tries)."""
    for tries in range(1, 10001):
        pts = RNG.normal(size=(N_V, 3))
        pts /= np.linalg.norm(pts, axis=1)[:, None]
        shape = Polyhedra(v=[Vector3(*p) for p in pts])
        shape.GetVolume()                      # builds the hull, vertices in principal axes
        local = np.array([[c for c in v] for v in shape.v], dtype=float)
        ext = np.sort(local.max(axis=0) - local.min(axis=0))
        if len(local) == N_V and ext[0] / ext[2] >= A.min_axis_ratio:
            return pts, ext[0] / ext[2], tries
    raise SystemExit(f"no hull of {N_V} points with h/L >= {A.min_axis_ratio} in 10000 tries")


sp = pack.SpherePack()
# expected volume of the circumscribed spheres, number density ~ d^-3 on [D_MIN, D_MAX]
_mean_d3 = (D_MAX - D_MIN) / (0.5 * (D_MIN ** -2 - D_MAX ** -2))
L0 = (A.n * math.pi / 6.0 * _mean_d3 / A.phi_cloud) ** (1.0 / 3.0)
n_made = sp.makeCloud(Vector3(0, 0, 0), Vector3(L0, L0, L0), -1, 0, A.n, False, 0.5,
                      [D_MIN, D_MAX], [0.0, 1.0], True, A.seed)
if n_made != A.n or abs(sp.appliedPsdScaling - 1.0) > 1e-12:
    raise SystemExit(f"makeCloud made {n_made} spheres with PSD scaling {sp.appliedPsdScaling}")

# the material is made stiff once the sizes are known (E depends on d_mean); placeholder now
MAT = PolyhedraMat(young=1.0, poisson=0.0, frictionAngle=0.0, density=A.rho, label="grains")
WALL_MAT = PolyhedraMat(young=1.0, poisson=0.0, frictionAngle=0.0, density=0.0, label="walls")
O.materials.append(MAT)
O.materials.append(WALL_MAT)
# walls first: ids 0..5 = left, right, bottom, top, back, front
WALL_IDS = O.bodies.append([
    utils.wall(0.0, axis=0, sense=1, material=WALL_MAT),
    utils.wall(L0, axis=0, sense=-1, material=WALL_MAT),
    utils.wall(0.0, axis=1, sense=1, material=WALL_MAT),
    utils.wall(L0, axis=1, sense=-1, material=WALL_MAT),
    utils.wall(0.0, axis=2, sense=1, material=WALL_MAT),
    utils.wall(L0, axis=2, sense=-1, material=WALL_MAT),
])
assert list(WALL_IDS) == [0, 1, 2, 3, 4, 5], WALL_IDS
LEFT, RIGHT, BOTTOM, TOP, BACK, FRONT = WALL_IDS
AXIS = {LEFT: 0, RIGHT: 0, BOTTOM: 1, TOP: 1, BACK: 2, FRONT: 2}
INWARD = {LEFT: 1.0, RIGHT: -1.0, BOTTOM: 1.0, TOP: -1.0, BACK: 1.0, FRONT: -1.0}

bodies, diameters, ratios, tries_all = [], [], [], 0
for c, r in sp:
    pts, ratio, tries = unit_shape()
    tries_all += tries
    verts = [Vector3(*(np.array([c[0], c[1], c[2]]) + r * p)) for p in pts]
    bodies.append(polyhedra_utils.polyhedra(MAT, v=verts))
    diameters.append(2.0 * r)
    ratios.append(ratio)
GRAIN_IDS = O.bodies.append(bodies)
N = len(GRAIN_IDS)
DIAM = dict(zip(GRAIN_IDS, diameters, strict=True))
VOLUMES = [O.bodies[i].shape.GetVolume() for i in GRAIN_IDS]
V_SOLID = sum(VOLUMES)
D_MEAN = sum(diameters) / N                                      # number-mean circumscribed d
D_MEAN_V = sum(d * v for d, v in zip(diameters, VOLUMES, strict=True)) / V_SOLID
FACE_AREAS = []
for i in GRAIN_IDS:
    tri = O.bodies[i].shape.GetSurfaceTriangulation()
    vv = O.bodies[i].shape.v
    for k in range(0, len(tri), 3):
        a, b, cc = (np.array([x for x in vv[tri[k + j]]]) for j in range(3))
        FACE_AREAS.append(0.5 * np.linalg.norm(np.cross(b - a, cc - a)))
A_MEAN, A_MAX = float(np.mean(FACE_AREAS)), float(np.max(FACE_AREAS))
N_FACES_MEAN = len(FACE_AREAS) / N
IS_WALL = set(WALL_IDS)

KN = A.kappa * A.sigma0 / D_MEAN            # N/m^3
KS = A.kt_kn * KN * A_MEAN                  # N/m
E = 2.0 * KN
for m in (MAT, WALL_MAT):
    m.young = E
    m.poisson = KS / KN

SAMPLER = PyRunner(iterPeriod=A.sample_every, command="sample()", dead=True)
SERVO = PyRunner(iterPeriod=A.servo_every, command="servo()")
newton = NewtonIntegrator(damping=A.damping, gravity=(0, 0, 0), label="newton")
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Polyhedra_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop([Ig2_Polyhedra_Polyhedra_PolyhedraGeom(), Ig2_Wall_Polyhedra_PolyhedraGeom()],
                    [Ip2_PolyhedraMat_PolyhedraMat_PolyhedraPhys()],
                    [Law2_PolyhedraGeom_PolyhedraPhys_Volumetric()]),
    SERVO,
    SAMPLER,
    newton,
]
M_MIN = A.rho * min(VOLUMES)
K_MAX = KN * A_MAX
O.dt = A.dt_safety * math.sqrt(M_MIN / K_MAX)

if A.strain_rate is not None:
    EPS_DOT = A.strain_rate
else:
    EPS_DOT = A.inertia / (D_MEAN * math.sqrt(A.rho / A.sigma0))
I0 = EPS_DOT * D_MEAN * math.sqrt(A.rho / A.sigma0)
T_CLOUD = time.perf_counter() - T_START

say(f"SETUP load average (1, 5, 15 min) at start: {load_line()}")
say(f"SETUP yade threads={O.numThreads}  N={N}  n_f={A.faces} (n_v={N_V}, mean faces "
    f"{N_FACES_MEAN:.2f})  d=[{min(diameters) * U:.4g}, {max(diameters) * U:.4g}] m  "
    f"d_mean(number)={D_MEAN * U:.5g} m  d_mean(volume)={D_MEAN_V * U:.5g} m  "
    f"(YADE length unit {U:g} m)")
say(f"SETUP shapes: h/L in [{min(ratios):.3f}, {max(ratios):.3f}] (mean "
    f"{sum(ratios) / N:.3f}), {tries_all / N:.2f} draws per kept hull; mean volume / "
    f"circumscribed sphere volume {V_SOLID / sum(math.pi / 6 * d ** 3 for d in diameters):.3f}")
say(f"SETUP solid volume={V_SOLID * U ** 3:.6g} m3  cloud cube L0={L0 * U:.5g} m "
    f"(phi={V_SOLID / L0 ** 3:.3f})  cloud made in {T_CLOUD:.2f} s")
say(f"SETUP kappa=k_n d_mean/sigma0={A.kappa:.4g}  k_n={KN / U ** 2:.4g} N/m3  "
    f"face area mean {A_MEAN * U ** 2:.4g} max {A_MAX * U ** 2:.4g} m2 -> face-face k_n A: "
    f"mean {KN * A_MEAN:.4g} max {K_MAX:.4g} N/m "
    f"(k/(sigma0 d_mean) {KN * A_MEAN / (A.sigma0 * D_MEAN):.4g})  k_s={KS:.4g} N/m")
say(f"SETUP dt={O.dt:.4g} s ({A.dt_safety:.2f} x sqrt(m_min/(k_n A_max))="
    f"{math.sqrt(M_MIN / K_MAX):.4g} s)  damping={A.damping:.2f}")
say(f"SETUP triaxial: axial strain rate={EPS_DOT:.5g} /s  inertia number at sigma0: I={I0:.4g}"
    f"  mu={A.mu:.3g}  target eps_q={A.eps_q_target:.3g}")


# ---------------------------------------------------------------- helpers
def box_dims():
    """Width (x), height (y), depth (z) from the wall positions."""
    b = O.bodies
    return (b[RIGHT].state.pos[0] - b[LEFT].state.pos[0],
            b[TOP].state.pos[1] - b[BOTTOM].state.pos[1],
            b[FRONT].state.pos[2] - b[BACK].state.pos[2])


def each_wall_stress():
    """Compressive stress on each wall {id: s} (force along the inward normal / face area)."""
    w, h, d = box_dims()
    area = {0: h * d, 1: w * d, 2: w * h}
    f = O.forces.f
    return {i: -INWARD[i] * f(i, True)[AXIS[i]] / area[AXIS[i]] for i in WALL_IDS}


def wall_stresses():
    """Compressive wall stresses (sx, sy, sz), each the mean of the two opposite walls."""
    s = each_wall_stress()
    return (0.5 * (s[LEFT] + s[RIGHT]), 0.5 * (s[BOTTOM] + s[TOP]), 0.5 * (s[BACK] + s[FRONT]))


def packing_fraction():
    w, h, d = box_dims()
    return V_SOLID / (w * h * d)


# wall control: CTRL["mode"][wall] = "stress" (servo to sigma0) or "rate" (axial strain rate)
CTRL = {"mode": {i: "stress" for i in WALL_IDS}, "vmax": {i: 0.0 for i in WALL_IDS},
        "vslow": {i: 0.0 for i in WALL_IDS}}


def servo():
    """PyRunner: set the wall velocities (stress servo or constant true strain rate)."""
    s = each_wall_stress()
    dims = box_dims()
    for i in WALL_IDS:
        ax = AXIS[i]
        if CTRL["mode"][i] == "rate":
            v_in = 0.5 * EPS_DOT * dims[ax]
        else:
            # fast while the wall is (nearly) unloaded, slow near the goal (no limit cycle)
            vmax = CTRL["vmax"][i] if s[i] < 0.5 * A.sigma0 else CTRL["vslow"][i]
            err = A.servo_gain * (A.sigma0 - s[i]) / A.sigma0
            v_in = vmax * max(-1.0, min(1.0, err))
        vel = Vector3(0, 0, 0)
        vel[ax] = INWARD[i] * v_in
        O.bodies[i].state.vel = vel


builtins.servo = servo       # PyRunner commands are evaluated in YADE's global namespace


def contact_stats(min_contacts):
    """(z, z_nr, rattler fraction, z_walls_nr) over force-carrying contacts
    (:func:`contact_counts.contact_stats`)."""
    return contact_counts.contact_stats(O.interactions, GRAIN_IDS, IS_WALL, min_contacts)


def overlaps():
    """(largest, mean) equivalent penetration depth / d_mean over force-carrying contacts
    between polyhedra, and the largest one with a wall."""
    pp, pw = [], []
    for it in O.interactions:
        if not it.isReal or it.phys.normalForce.squaredNorm() == 0.0:
            continue
        dep = it.geom.equivalentPenetrationDepth / D_MEAN
        (pw if it.id1 in IS_WALL or it.id2 in IS_WALL else pp).append(dep)
    return (max(pp) if pp else 0.0, sum(pp) / len(pp) if pp else 0.0,
            max(pw) if pw else 0.0)


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
for _i in WALL_IDS:
    CTRL["vmax"][_i] = 0.5 * A.comp_rate * L0
    CTRL["vslow"][_i] = 0.5 * A.comp_rate_final * L0
say(f"COMPACTION start: frictionless, sigma0={SI_SIGMA0:g} Pa, "
    f"wall speed cap {0.5 * A.comp_rate * L0 * U:.4g} m/s")
t0 = time.perf_counter()
it0 = O.iter
prog = Progress()
while True:
    O.run(A.check_every, True)
    unb = utils.unbalancedForce()
    s_each = each_wall_stress()
    err = max(abs(si - A.sigma0) / A.sigma0 for si in s_each.values())
    wall = time.perf_counter() - t0
    if unb < A.unb and err < A.stress_tol:
        break
    phi = packing_fraction()
    w_, h_, d_ = box_dims()
    for _i in WALL_IDS:      # keep the speed cap at comp-rate of the current box
        CTRL["vmax"][_i] = 0.5 * A.comp_rate * (w_, h_, d_)[AXIS[_i]]
        CTRL["vslow"][_i] = 0.5 * A.comp_rate_final * (w_, h_, d_)[AXIS[_i]]
    if prog.due():
        s = wall_stresses()
        say(f"  compaction iter={O.iter} t_wall={wall:.0f} s  phi={phi:.4f}  "
            f"s=({s[0] * PA:.4g}, {s[1] * PA:.4g}, {s[2] * PA:.4g}) Pa  max err={err:.3g}  "
            f"unb={unb:.3g}")
    if phi > 0.9:
        raise SystemExit(f"compaction failed: packing fraction {phi:.3g} > 0.9 (grains escaped?)")
    if wall > A.max_wall:
        raise SystemExit(f"compaction did not converge within --max-wall={A.max_wall:g} s")
T_COMP = time.perf_counter() - t0
STEPS_COMP = O.iter - it0
PHI_COMP = packing_fraction()
Z_COMP = contact_stats(A.min_contacts)
Z_COMP_ISO = contact_stats(4)
OV_COMP = overlaps()
s = wall_stresses()
say(f"COMPACTION done: wall time {T_COMP:.2f} s, {STEPS_COMP} steps "
    f"({STEPS_COMP / T_COMP:.1f} steps/s), simulated time {STEPS_COMP * O.dt:.4g} s")
say(f"COMPACTION state: phi={PHI_COMP:.4f}  unb={unb:.3g}  "
    f"s=({s[0] * PA:.5g}, {s[1] * PA:.5g}, {s[2] * PA:.5g}) Pa  z={Z_COMP[0]:.3f}  "
    f"z_nr(min {A.min_contacts})={Z_COMP[1]:.3f} rattlers={Z_COMP[2]:.3f} "
    f"z_walls_nr={Z_COMP[3]:.3f};  min 4: z_nr={Z_COMP_ISO[1]:.3f} "
    f"rattlers={Z_COMP_ISO[2]:.3f} z_walls_nr={Z_COMP_ISO[3]:.3f}")
say(f"COMPACTION overlaps (equivalent depth / d_mean): largest {OV_COMP[0]:.4g}, "
    f"mean {OV_COMP[1]:.4g}, largest with a wall {OV_COMP[2]:.4g}")

# ---------------------------------------------------------------- 3. triaxial compression
utils.setContactFriction(math.atan(A.mu))   # polyhedra and their contacts; walls keep 0
W0, H0, D0 = box_dims()
for _i in WALL_IDS:
    CTRL["mode"][_i] = "rate" if AXIS[_i] == 1 else "stress"
    CTRL["vmax"][_i] = CTRL["vslow"][_i] = 0.5 * A.lat_rate * EPS_DOT * max(W0, D0)

COLUMNS = ["iter", "time", "eps_1", "eps_3", "eps_vol", "eps_q", "sigma_1", "sigma_3",
           "sigma_x", "sigma_z", "p", "q_over_3", "q_over_trace", "qp_avg", "n_samples", "phi",
           "z", "z_no_rattlers", "rattler_fraction", "z_walls_no_rattlers",
           "max_overlap_over_d", "mean_overlap_over_d", "unbalanced", "inertia_number"]
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


def write_row(e, s, qp_avg, n):
    sx, sy, sz = s
    s1, s3 = sy, 0.5 * (sx + sz)
    p = (s1 + 2 * s3) / 3.0
    q = (s1 - s3) / 3.0
    z, z_nr, rat, z_nr_w = contact_stats(A.min_contacts)
    ov = overlaps()
    row = [O.iter, O.time - ST["time0"], e[0], e[1], e[2], e[3], s1 * PA, s3 * PA, sx * PA,
           sz * PA, p * PA, q * PA, q / p,
           qp_avg, n, packing_fraction(), z, z_nr, rat, z_nr_w, ov[0], ov[1],
           utils.unbalancedForce(),
           EPS_DOT * D_MEAN * math.sqrt(A.rho / p) if p > 0 else float("nan")]
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
            f"phi={r['phi']:.4f} z={r['z']:.3f} s3={s3 * PA:.5g} Pa")
    if e[3] >= A.eps_q_target or time.perf_counter() - ST["t0"] > A.max_wall:
        ST["done"] = True
        O.pause()


builtins.sample = sample

say(f"TRIAXIAL start: box w={W0 * U:.5g} h={H0 * U:.5g} d={D0 * U:.5g} m, csv={A.csv}")
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
ov_max = max(r["max_overlap_over_d"] for r in ROWS)

say(f"TRIAXIAL done: wall time {T_TRIAX:.2f} s, {STEPS_TRIAX} steps "
    f"({STEPS_TRIAX / T_TRIAX:.1f} steps/s), simulated time {STEPS_TRIAX * O.dt:.4g} s, "
    f"eps_q={eq_final:.4f}")
for m in MARKS:
    if m in ST["marks"]:
        tw, ns = ST["marks"][m]
        say(f"  to eps_q={m:.1f}: {tw:.1f} s wall, {ns} steps, {tw / m:.1f} s per unit eps_q")
say(f"RESULT threads={O.numThreads} N={N} n_f={A.faces} seed={A.seed} kappa={A.kappa:g} "
    f"k_n={KN / U ** 2:.4g} N/m3 k_s={KS:.4g} N/m dt={O.dt:.4g} strain_rate={EPS_DOT:.5g} "
    f"I0={I0:.4g}")
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
say(f"RESULT overlaps (equivalent depth / d_mean): after compaction largest {OV_COMP[0]:.4g} "
    f"mean {OV_COMP[1]:.4g} (walls {OV_COMP[2]:.4g}); largest in the triaxial rows {ov_max:.4g}")
say(f"RESULT load average (1, 5, 15 min) at the end: {load_line()}")
say(f"RESULT total wall time {time.perf_counter() - T_START:.2f} s (cloud {T_CLOUD:.2f} s + "
    f"compaction {T_COMP:.2f} s + triaxial {T_TRIAX:.2f} s)")
