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
the softening, not the papers' residual state.

>>> spec = series_spec("angularity", n_particles=50)
>>> spec.names[:3], spec.sample_config("S8").sample.n_faces
(['S1', 'S2', 'S3'], 8)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from grainlab.errors import InputError
from grainlab.geometry.polyhedron import TABLE_I
from grainlab.study.study_spec import StudySpec

LENGTHS = {
    "short": {"eps_q_max": 0.3, "window": {"angularity": (0.2, 0.3),
                                           "nonconvexity": (0.2, 0.3)}},
    "full": {"eps_q_max": 0.9, "window": {"angularity": (0.6, 0.9),
                                          "nonconvexity": (0.5, 0.9)}},
}
"""How far the samples are sheared (eps_q) and the residual window of each series."""

SHORT_PARTICLES = 100
FULL_PARTICLES = 1000
"""Default particles per sample: a study in minutes, and the papers' protocol at the size a
2-core machine runs in hours (the papers used 40 000 polyhedra and 12 000 aggregates)."""

HEIGHT_RATIO = {"short": 1.5, "full": 2.0}
"""Height / width of the deposited packing (a lab specimen's 2 for the papers' strain). The
triaxial compression shortens the box by about exp(-eps_q): to eps_q = 0.9, a cube of 500 or
1000 aggregates with seed 003's radii (up to 3 R_min) would end three of its largest
particles high, where they lock in one or two layers (such a run is refused before it starts:
at 500 particles eps_q <= 0.41 for eta = 0.7); the papers' 12 000 to 40 000 particles had the
room. A short study's few particles need 1.5 to reach eps_q = 0.3."""

ETAS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7)
"""Seed 003's eight packings."""


def _protocol(n_particles: int, length: str, seed: int, size_ratio: float,
              snapshots: int) -> dict[str, Any]:
    """The papers' protocol as a base run config (module docstring)."""
    eps_q_max = LENGTHS[length]["eps_q_max"]
    return {
        "sample": {"n_particles": n_particles, "size_ratio": size_ratio, "seed": seed,
                   "preparation": "deposition", "wall_friction": 0.0,
                   "height_ratio": HEIGHT_RATIO[length]},
        "test": {"kind": "triaxial", "eps_q_max": eps_q_max},
        "solver": {"compaction": {"friction": 0.0}, "shear": {"friction": 0.4,
                                                              "inertia_number": 1e-3}},
        "output": {"snapshot_every": snapshots, "record_every": 10},
    }


def _snapshot_every(n_particles: int, length: str) -> int:
    """Steps between snapshots: about 30 in a short run's window, 20 in a full one's (the
    steps per unit of eps_q grow roughly as the box's height in diameters, N^(1/3))."""
    steps_per_strain = 1100.0 * (n_particles / 60.0) ** (1.0 / 3.0)
    lo, hi = LENGTHS[length]["window"]["angularity"]
    per_window = 30 if length == "short" else 20
    return max(1, int(steps_per_strain * (hi - lo) / per_window))


def angularity_series(*, n_particles: int | None = None, length: str = "short",
                      seed: int = 0, templates: int | None = None) -> StudySpec:
    """Seed 002's eight samples S1 ... S8 (module docstring). ``templates``: polyhedra drawn
    once and reused in random orientations (0: every particle its own, as the paper; a short
    study takes 12 by default, since drawing a hull of few faces takes ~0.25 s)."""
    length = _length(length)
    n = n_particles or (SHORT_PARTICLES if length == "short" else FULL_PARTICLES)
    if templates is None:
        templates = 12 if length == "short" else 0
    base = _protocol(n, length, seed, 2.0, _snapshot_every(n, length))
    samples = [{"name": "S1", "value": 0.0, "set": {"sample": {"shape": "sphere"}}}]
    for k, faces in enumerate(sorted(TABLE_I, reverse=True)):
        samples.append({"name": f"S{k + 2}", "value": TABLE_I[faces],
                        "set": {"sample": {"shape": "polyhedron", "n_faces": faces,
                                           "templates": templates}}})
    return _series("angularity", "mean_angularity", "<alpha>",
                   "Seed 002: spheres and polyhedra of 596 ... 8 faces", length, n, base,
                   samples)


def nonconvexity_series(*, n_particles: int | None = None, length: str = "short",
                        seed: int = 0) -> StudySpec:
    """Seed 003's eight samples eta = 0 ... 0.7 (module docstring)."""
    length = _length(length)
    n = n_particles or (SHORT_PARTICLES if length == "short" else FULL_PARTICLES)
    base = _protocol(n, length, seed, 3.0, _snapshot_every(n, length))
    samples = []
    for eta in ETAS:
        shape = {"shape": "sphere"} if eta == 0.0 else {"shape": "aggregate", "eta": eta}
        samples.append({"name": f"eta-{eta:.1f}", "value": eta, "set": {"sample": shape}})
    return _series("nonconvexity", "eta", "eta",
                   "Seed 003: aggregates of four spheres, eta = 0 ... 0.7", length, n, base,
                   samples)


def _series(name: str, parameter: str, symbol: str, text: str, length: str, n: int,
            base: dict, samples: list[dict]) -> StudySpec:
    """The study of a preset series: its window at ``length``, described by ``text``."""
    return StudySpec.model_validate({
        "study": {"name": name, "parameter": parameter, "symbol": symbol,
                  "window": LENGTHS[length]["window"][name],
                  "description": f"{text} ({length} length, {n} particles per sample)"},
        "base": base, "samples": samples})


SERIES: dict[str, Callable[..., StudySpec]] = {
    "angularity": angularity_series, "nonconvexity": nonconvexity_series}
"""The preset series by name."""


def series_spec(name: str, **options: Any) -> StudySpec:
    """The preset series ``name`` (:data:`SERIES`) with its options."""
    if name not in SERIES:
        raise InputError("series", name, "one of " + ", ".join(SERIES))
    return SERIES[name](**options)


def _length(length: str) -> str:
    if length not in LENGTHS:
        raise InputError("length", length, "one of " + ", ".join(LENGTHS))
    return length
