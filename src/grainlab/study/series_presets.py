"""The shape series of seeds 002 and 003 as studies (STYLE.md 9: presets are data).

* ``angularity`` (Azéma, Radjaï & Dubois 2013, seed 002, Table I): spheres (S1) and random
  convex polyhedra of n_f = 596, 176, 96, 46, 30, 20, 8 faces (S2 ... S8), diameters uniform by
  volume in [d_min, 2 d_min]; the shape parameter is the packing's mean angularity <alpha>
  [rad] (Table I's values; the figures use each sample's measured mean, which the sample
  description carries).
* ``nonconvexity`` (Azéma, Radjaï, Saint-Cyr, Delenne & Sornay 2013, seed 003): aggregates of
  four overlapping spheres of non-convexity eta = 0, 0.1, ..., 0.7 (eta = 0 is the sphere),
  radii uniform by volume in [R_min, 3 R_min].

Both use the papers' protocol: one sphere packing built layer by layer per seed
(``sample.preparation = "deposition"``) in which every sample's particles are inscribed;
frictionless isotropic compaction at sigma0 with the left, bottom and back walls fixed and the
other three at sigma0; then triaxial compression with mu = 0.4 between particles, frictionless
walls and an inertia number I <= 1e-3, with contact-network snapshots through the residual
window. ``length = "full"`` runs to the papers' strain (eps_q = 0.9, residual window [0.6, 0.9]
for 002 and [0.5, 0.9] for 003); ``"short"`` (the default: a study in minutes on a laptop) to
eps_q = 0.3 with the window [0.2, 0.3], which shows the trends of the peak and of the start of
the softening, not the papers' residual state; ``"smoke"`` to eps_q = 0.05, a check of the
whole chain in about a minute (:data:`LENGTHS`).

>>> spec = series_spec("angularity", n_particles=50)
>>> spec.names[:3], spec.sample_config("S8").sample.n_faces
(['S1', 'S2', 'S3'], 8)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from grainlab.errors import InputError
from grainlab.geometry.polyhedron import TABLE_I
from grainlab.lab.cell_thickness import (
    SHEAR_SHORTENING,
    mean_cube_uniform_by_volume,
    particles_for_the_shear,
)
from grainlab.prep.sample_shapes import circumscribed_volume_fraction, sample_shape
from grainlab.study.study_spec import StudySpec


@dataclass(frozen=True)
class StudyLength:
    """How far a preset study goes: the samples are sheared to ``eps_q_max`` and read in the
    residual ``window`` (eps_q) of each series; ``particles`` per sample by default, the
    ``height_ratio`` (height / width) of the deposited packing, about ``snapshots_per_window``
    contact-network snapshots in the window, and the polyhedron ``templates`` drawn once and
    reused in random orientations (0: every particle its own, as the paper); the ``boundary``
    (:data:`BOUNDARIES`) a study of this length runs in unless told otherwise."""

    eps_q_max: float
    window: dict[str, tuple[float, float]]
    particles: int
    height_ratio: float
    snapshots_per_window: int
    templates: int
    text: str
    boundary: str = "walls"


LENGTHS = {
    "smoke": StudyLength(0.05, {"angularity": (0.03, 0.05), "nonconvexity": (0.03, 0.05)},
                         40, 1.5, 5, 3,
                         "to eps_q = 0.05, window [0.03, 0.05]: the whole chain (deposition, "
                         "compaction, shear, snapshots, summary, figures) in about a minute; "
                         "the window sits before the peak, so its values are no residual "
                         "state"),
    "short": StudyLength(0.3, {"angularity": (0.2, 0.3), "nonconvexity": (0.2, 0.3)},
                         100, 1.5, 30, 12,
                         "to eps_q = 0.3, window [0.2, 0.3] (minutes): the trends of the peak "
                         "and of the start of the softening"),
    "full": StudyLength(0.9, {"angularity": (0.6, 0.9), "nonconvexity": (0.5, 0.9)},
                        1000, 2.0, 20, 0,
                        "the papers' strain, eps_q = 0.9, window [0.6, 0.9] (002) or "
                        "[0.5, 0.9] (003) (hours at 1000 particles)",
                        boundary="periodic"),
}
"""The lengths of a preset study. Particles: a study in minutes, and the papers' protocol at
the size a 2-core machine runs in hours (the papers used 40 000 polyhedra and 12 000
aggregates). Height ratio: a lab specimen's 2 for the papers' strain (in walls; a periodic
cell takes :func:`cell_height_ratio`). The triaxial compression shortens the box by
exp(-eps_zz), eps_zz <= 2/3 eps_q (0.57 measured at eps_q = 0.9): to eps_q = 0.9, a cube of
500 or 1000 aggregates with seed 003's radii (up to 3 R_min) would end three of its largest
particles high, where they lock in one or two layers (such a run is refused before it
starts: at 500 particles eps_q <= 0.41 for eta = 0.7); the papers' 12 000 to 40 000
particles had the room. A short study's few particles need 1.5 to reach eps_q = 0.3.
Templates: drawing a hull of few faces takes ~0.25 s. Boundary: a smoke or short study runs
in the papers' box of walls, which a few particles fill in seconds; a full one in a periodic
cell, whose values are the bulk's, as the papers' 12 000 to 40 000 particles give: in walls
about half the centres of 500 particles, and 29 % of 4000, lie within a diameter of a wall
(docs/explanations/studies.md, "The walls and the core"; the size check measures how the core
values approach the cell's). A periodic cell needs more particles for a smoke study's room
(292 and 641 for eta = 0 and 0.7: three minutes, against 19 s in walls)."""

ETAS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7)
"""Seed 003's eight packings."""


BOUNDARIES = {
    "walls": "a box of six walls, the papers' (the particles along the walls are a large share "
             "of a small sample: the study's core values leave them out)",
    "periodic": "a periodic cell: no wall layer, every particle in the bulk; each sample a "
                "loose packing of its own shapes drawn with the same seed, compacted in the "
                "cell (not inscribed in one deposited sphere packing); as many particles as "
                "the study asks, more for a sample whose cell would get thinner than the "
                "contact detection allows (its largest particles against their volume)",
}
"""The boundaries a preset study runs in (``boundary``), in words."""

ALERT_ESTIMATE = 0.05
"""The alert distance a sample's cell is sized for, in smallest diameters d_min [-]: the
contact dynamics' default, 0.1 of the smallest member sphere's radius, is at most 0.05 d_min
(:func:`~grainlab.lab.cell_thickness.particles_for_the_shear`)."""


def cell_height_ratio(length: str) -> float:
    """Height / width [-] of a preset's periodic cell: exp(2/3 eps_q_max), at which the cell's
    sides after the compaction and its height at the end of the shear are equally narrow
    (:mod:`grainlab.lab.cell_thickness`): the fewest particles for the room the detection
    needs (1.82 for the papers' strain, 1.22 to eps_q = 0.3).

    >>> round(cell_height_ratio("full"), 3)
    1.822
    """
    return round(math.exp(SHEAR_SHORTENING * LENGTHS[length].eps_q_max), 3)


def cell_particles(sample: dict[str, Any], length: str, size_ratio: float) -> int:
    """The particles [-] a periodic cell of ``sample``'s shapes (a preset sample's
    ``sample`` table: ``shape`` and its parameters) needs at ``length``, from the shapes'
    mean volume in their circumscribed spheres, the preset's sizes (uniform by volume in
    [d_min, ``size_ratio`` d_min]) and a cell of :func:`cell_height_ratio`
    (:func:`~grainlab.lab.cell_thickness.particles_for_the_shear`).

    >>> cell_particles({"shape": "sphere"}, "full", 2.0)
    264
    """
    shape = sample.get("shape", "sphere")
    parameters = {key: sample[key] for key in sample_shape(shape).parameters if key in sample}
    fraction = circumscribed_volume_fraction(shape, **parameters)
    mean_volume = fraction * math.pi / 6.0 * mean_cube_uniform_by_volume(1.0, size_ratio)
    return particles_for_the_shear(mean_volume, size_ratio, ALERT_ESTIMATE,
                                   cell_height_ratio(length), LENGTHS[length].eps_q_max)


def with_room(samples: list[dict], n_particles: int, length: str, size_ratio: float
              ) -> list[dict]:
    """``samples`` with ``sample.n_particles`` raised, for each sample whose cell would get
    too thin with ``n_particles``, to :func:`cell_particles` (the others keep
    ``n_particles``: the study's count is a floor)."""
    out = []
    for sample in samples:
        table = sample["set"].get("sample", {})
        needed = cell_particles(table, length, size_ratio)
        if needed > n_particles:
            sample = {**sample, "set": {**sample["set"],
                                        "sample": {**table, "n_particles": needed}}}
        out.append(sample)
    return out


def _protocol(n_particles: int, length: str, seed: int, size_ratio: float,
              snapshots: int, boundary: str = "walls") -> dict[str, Any]:
    """The papers' protocol as a base run config (module docstring); in a periodic cell
    (``boundary = "periodic"``) the samples are loose packings compacted in the cell, with
    the same compaction and shear, in a cell of :func:`cell_height_ratio` (as narrow at the
    end of the shear, which shortens it, as at its start)."""
    eps_q_max = LENGTHS[length].eps_q_max
    sample = {"n_particles": n_particles, "size_ratio": size_ratio, "seed": seed,
              "preparation": "deposition", "wall_friction": 0.0,
              "height_ratio": LENGTHS[length].height_ratio}
    if _boundary(boundary) == "periodic":
        del sample["wall_friction"]
        sample.update(boundary="periodic", preparation="loose",
                      height_ratio=cell_height_ratio(length))
    return {
        "sample": sample,
        "test": {"kind": "triaxial", "eps_q_max": eps_q_max},
        "solver": {"compaction": {"friction": 0.0}, "shear": {"friction": 0.4,
                                                              "inertia_number": 1e-3}},
        "output": {"snapshot_every": snapshots, "record_every": 10,
                   "snapshot_eps_q": peak_snapshot_strains(length)},
    }


PEAK_SNAPSHOT_STEP = 0.005
"""Deviatoric strain between the snapshots taken in the early shear [-] (``output.
snapshot_eps_q``), up to :data:`PEAK_SNAPSHOT_UNTIL`: the peak state (seed 002 Fig. 20,
seed 003 Fig. 23) is read from the snapshot nearest the smoothed peak, which lies at eps_q
0.03-0.08 in these series; the snapshots of ``snapshot_every``, spaced for the residual
window, fell up to 0.06 from it (measured: S1 in a periodic cell, peak at 0.044, nearest
snapshot at 0.10)."""
PEAK_SNAPSHOT_UNTIL = 0.15
"""The last of those strains [-]."""


def peak_snapshot_strains(length: str) -> list[float]:
    """The strains of the early shear's snapshots (:data:`PEAK_SNAPSHOT_STEP`) below the
    length's residual window; none for a smoke study, whose window holds its peak.

    >>> peak_snapshot_strains("full")[:3], len(peak_snapshot_strains("full"))
    ([0.005, 0.01, 0.015], 30)
    """
    if length == "smoke":
        return []
    until = min(PEAK_SNAPSHOT_UNTIL, min(lo for lo, _ in LENGTHS[length].window.values()))
    count = round(until / PEAK_SNAPSHOT_STEP)
    return [round(PEAK_SNAPSHOT_STEP * k, 6) for k in range(1, count + 1)]


def _snapshot_every(n_particles: int, length: str) -> int:
    """Steps between snapshots: about :attr:`StudyLength.snapshots_per_window` in the window
    (the steps per unit of eps_q grow roughly as the box's height in diameters, N^(1/3))."""
    steps_per_strain = 1100.0 * (n_particles / 60.0) ** (1.0 / 3.0)
    lo, hi = LENGTHS[length].window["angularity"]
    return max(1, int(steps_per_strain * (hi - lo) / LENGTHS[length].snapshots_per_window))


SHEAR_SWEEPS_BY_FACES = {596: 4000}
"""The shear's sweep cap (``solver.shear.max_iterations``) for the polyhedra whose small faces
need more than the default's 2000 sweeps per step: S2's (596 faces, each about 0.07 <d>
across) face-face contacts put up to eight nearly equal constraints within a face, which
Gauss-Seidel resolves slowly. Measured on the full series in a periodic cell (1000
particles, seed 0): at 2000 sweeps 101 of S2's 2101 shear steps ended at the cap (2.05 %), at
4000 1 of 2124 (its sweeps per step: median 1237, 95th percentile 1942); S3 (176 faces), at a
median of 858, ended 58 of its 2718 shear steps at 2000 (0.74 % of its run's steps). LMGC90's
users run up to 5000."""


def angularity_series(*, n_particles: int | None = None, length: str = "short",
                      seed: int = 0, templates: int | None = None,
                      boundary: str | None = None, replicas: int = 1,
                      replicated: tuple[str, ...] | None = None) -> StudySpec:
    """Seed 002's eight samples S1 ... S8 (module docstring). ``templates``: polyhedra drawn
    once and reused in random orientations (0: every particle its own, as the paper; default:
    the length's, :data:`LENGTHS`); ``boundary``: one of :data:`BOUNDARIES` (default: the
    length's); ``replicas`` and ``replicated``: :func:`with_replicas`."""
    length = _length(length)
    boundary = _boundary(LENGTHS[length].boundary if boundary is None else boundary)
    n = n_particles or LENGTHS[length].particles
    if templates is None:
        templates = LENGTHS[length].templates
    base = _protocol(n, length, seed, 2.0, _snapshot_every(n, length), boundary)
    samples = [{"name": "S1", "value": 0.0, "set": {"sample": {"shape": "sphere"}}}]
    for k, faces in enumerate(sorted(TABLE_I, reverse=True)):
        changes = {"sample": {"shape": "polyhedron", "n_faces": faces, "templates": templates}}
        if faces in SHEAR_SWEEPS_BY_FACES:
            changes["solver"] = {"shear": {"max_iterations": SHEAR_SWEEPS_BY_FACES[faces]}}
        samples.append({"name": f"S{k + 2}", "value": TABLE_I[faces], "set": changes})
    if _boundary(boundary) == "periodic":
        samples = with_room(samples, n, length, 2.0)
    samples = with_replicas(samples, seed, replicas, replicated, REPLICATED["angularity"])
    return _series("angularity", "mean_angularity", "<alpha>",
                   "Seed 002: spheres and polyhedra of 596 ... 8 faces", length, n, base,
                   samples, boundary)


def nonconvexity_series(*, n_particles: int | None = None, length: str = "short",
                        seed: int = 0, boundary: str | None = None, replicas: int = 1,
                        replicated: tuple[str, ...] | None = None) -> StudySpec:
    """Seed 003's eight samples eta = 0 ... 0.7 (module docstring); ``boundary``: one of
    :data:`BOUNDARIES` (default: the length's); ``replicas`` and ``replicated``:
    :func:`with_replicas`."""
    length = _length(length)
    boundary = _boundary(LENGTHS[length].boundary if boundary is None else boundary)
    n = n_particles or LENGTHS[length].particles
    base = _protocol(n, length, seed, 3.0, _snapshot_every(n, length), boundary)
    samples = []
    for eta in ETAS:
        shape = {"shape": "sphere"} if eta == 0.0 else {"shape": "aggregate", "eta": eta}
        samples.append({"name": f"eta-{eta:.1f}", "value": eta, "set": {"sample": shape}})
    if _boundary(boundary) == "periodic":
        samples = with_room(samples, n, length, 3.0)
    samples = with_replicas(samples, seed, replicas, replicated, REPLICATED["nonconvexity"])
    return _series("nonconvexity", "eta", "eta",
                   "Seed 003: aggregates of four spheres, eta = 0 ... 0.7", length, n, base,
                   samples, boundary)


REPLICATED = {"angularity": ("S1", "S4", "S8"),
              "nonconvexity": ("eta-0.0", "eta-0.3", "eta-0.7")}
"""The samples of each series repeated with other packing seeds by default (``replicas`` >
1): both ends and the middle of the series, so that every trend has error bars from
independent samples."""


def with_replicas(samples: list[dict], seed: int, replicas: int,
                  replicated: tuple[str, ...] | None, default: tuple[str, ...]) -> list[dict]:
    """``samples`` and, after them, ``replicas - 1`` repeats of each ``replicated`` sample
    (default ``default``) with the packing seeds seed + 1, seed + 2, ...: named
    ``<name>-seed<s>``, the same shape and value, marked ``replica_of`` the sample (the
    summary pools them: :func:`~grainlab.study.study_summary.pooled_replicas`). One replica
    (the default) adds nothing.

    >>> samples = [{"name": "S1", "value": 0.0, "set": {"sample": {"shape": "sphere"}}}]
    >>> [(s["name"], s["set"]["sample"].get("seed")) for s in
    ...  with_replicas(samples, 4, 3, None, ("S1",))]
    [('S1', None), ('S1-seed5', 5), ('S1-seed6', 6)]
    """
    if int(replicas) < 1:
        raise InputError("replicas", replicas, "a whole number of packings >= 1 per sample")
    names = [s["name"] for s in samples]
    chosen = tuple(default if replicated is None else replicated)
    for name in chosen:
        if name not in names:
            raise InputError("replicated", name, "samples of the series: " + ", ".join(names))
    out = list(samples)
    for k in range(1, int(replicas)):
        for sample in samples:
            if sample["name"] in chosen:
                table = {**sample["set"], "sample": {**sample["set"].get("sample", {}),
                                                     "seed": seed + k}}
                out.append({"name": f"{sample['name']}-seed{seed + k}",
                            "value": sample["value"], "set": table,
                            "replica_of": sample["name"]})
    return out


def _series(name: str, parameter: str, symbol: str, text: str, length: str, n: int,
            base: dict, samples: list[dict], boundary: str = "walls") -> StudySpec:
    """The study of a preset series: its window at ``length``, described by ``text``."""
    where = ", in a periodic cell" if boundary == "periodic" else ""
    counts = sorted({s["set"].get("sample", {}).get("n_particles", n) for s in samples})
    if counts != [n]:
        where = f", more where a cell needs the room (up to {counts[-1]}){where}"
    return StudySpec.model_validate({
        "study": {"name": name, "parameter": parameter, "symbol": symbol,
                  "window": LENGTHS[length].window[name],
                  "description": f"{text} ({length} length, {n} particles per sample{where})"},
        "base": base, "samples": samples})


SERIES: dict[str, Callable[..., StudySpec]] = {
    "angularity": angularity_series, "nonconvexity": nonconvexity_series}
"""The preset series by name."""


def series_spec(name: str, **options: Any) -> StudySpec:
    """The preset series ``name`` (:data:`SERIES`) with its options."""
    if name not in SERIES:
        raise InputError("series", name, "one of " + ", ".join(SERIES))
    return SERIES[name](**options)


def _boundary(boundary: str) -> str:
    if boundary not in BOUNDARIES:
        raise InputError("boundary", boundary, "one of " + ", ".join(BOUNDARIES))
    return boundary


def _length(length: str) -> str:
    if length not in LENGTHS:
        raise InputError("length", length, "one of " + ", ".join(LENGTHS))
    return length
