"""Load paths on a box of walls: the lab's mixed controls translated to wall controls
(seeds 002/003 §II.B; STYLE.md 9).

A discrete sample in a wall box controls the three normal components of its control frame
(the lab frame: a box cannot rotate or shear). Each normal component of a
:class:`~grainlab.lab.load_path.LoadStage` becomes, for the two walls of its axis:

* strain-controlled with increment e != 0 per step: a constant logarithmic strain rate
  d eps/dt = sign(e) eps_dot, the upper wall ("+" side) moving at eps_dot L(t) and the lower
  one fixed (seed 002: "top wall at constant velocity"); the stage ends when the axis has
  strained by n_steps x e since the stage began, its last step cut short to end on that
  strain (:class:`~grainlab.lab.discrete_test.DiscreteTest`). The rate follows from the bound on the
  inertia number, eps_dot = I_max sqrt(p_ref / rho) / <d> (p_ref: the stage's confining
  stress);
* strain-controlled with e = 0: both walls fixed;
* stress-controlled: the lower wall fixed, the upper one stress-controlled at the target
  (seed 002: "3 walls fixed, 3 walls at stress sigma0"; two opposite stress-controlled walls
  would let the whole box drift) (``stress_mode="target"``:
  the stage's value; ``"increment"`` with value 0: the stress held from the previous stage).

Shear components must be controlled at 0 (strain or stress: a box of walls does not shear)
and the frame must not rotate; anything else is refused with a message naming the
component. A stage with no moving strain control (isotropic compaction) ends when the sample
is quasi-static (:class:`QuasiStaticCriteria`). Stop criteria of the stage (e.g. ``eps_q``
above 0.5) end it early.

>>> from grainlab.lab.presets import triaxial_compression
>>> path = triaxial_compression(confining=1e4, axial_strain=0.3, n_steps=1,
...                             consolidation_steps=0)
>>> stage = wall_stages(path)[0]
>>> stage.modes, stage.targets
(('stress', 'stress', 'strain'), (10000.0, 10000.0, 0.3))
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from grainlab._validate import in_range
from grainlab.errors import InputError
from grainlab.lab.load_path import LoadPath, StopCriterion
from grainlab.lab.specimen import voigt_labels

AXES = ("x", "y", "z")


@dataclass(frozen=True)
class QuasiStaticCriteria:
    """When a stress-controlled stage has reached equilibrium (all must hold at a record):

    * ``stress_tolerance``: |sigma_wall - target| / target on every stress-controlled axis,
      and |p_contacts - p_walls| / p_walls (contacts and walls agree);
    * ``unbalanced_force``: mean |net force| of the particles / mean normal contact force;
    * ``kinetic_energy``: E_k / (N p <d>^3), kinetic energy per particle over the work scale
      (of order I^2 for particle speeds I <d> sqrt(p / rho): 1e-6 is I ~ 1e-3). E_k leaves
      out the spin of the bodies that bear no load (no contact with a positive normal force):
      in a frictionless compaction a non-spherical rattler keeps the spin it was given, for
      thousands of steps, though it exchanges no force with the packing (the results'
      ``kinetic_energy`` column is the whole energy).

    ``unbalanced_force`` and ``kinetic_energy`` may be ``inf``: not checked. The peers' test
    (benchmarks/peers/README.md) ends its compaction as LIGGGHTS and YADE scripts commonly
    do, on the stresses and the unbalanced force alone (``kinetic_energy = inf``). In a
    frictionless Hertz packing the kinetic energy ratio then still reads 1e-6 to 3e-5: the
    packing creeps (packing fraction 0.6609 to 0.6624 over 70 000 more sub-steps of 4000
    spheres), and the default 1e-6 waits for a record where it dips.

    >>> QuasiStaticCriteria(kinetic_energy=float("inf")).kinetic_energy
    inf
    >>> try:
    ...     QuasiStaticCriteria(unbalanced_force=0.0)
    ... except InputError as error:
    ...     print(error.allowed)
    a number > 0 (inf: not checked)
    """

    stress_tolerance: float = 0.01
    unbalanced_force: float = 0.01
    kinetic_energy: float = 1e-6

    def __post_init__(self) -> None:
        in_range("stress_tolerance", self.stress_tolerance, 0.0, 1.0)
        for name in ("unbalanced_force", "kinetic_energy"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) \
                    or not value > 0.0:
                raise InputError(name, value, "a number > 0 (inf: not checked)")

    def met(self, row: dict, targets: dict[int, float]) -> bool:
        """True when the recorded ``row`` satisfies every criterion; ``targets`` maps the
        stress-controlled axes to their stresses [Pa]."""
        for axis, target in targets.items():
            wall = row[f"wall_sigma_{AXES[axis] * 2}"]
            if abs(wall - target) > self.stress_tolerance * target:
                return False
        walls = [row[f"wall_sigma_{a * 2}"] for a in AXES if f"wall_sigma_{a * 2}" in row]
        wall_p = sum(walls) / len(walls)  # the walls' mean stress (2D: the side walls')
        if not wall_p > 0 or abs(row["p"] - wall_p) > self.stress_tolerance * wall_p:
            return False
        return (row["unbalanced_force_ratio"] <= self.unbalanced_force
                and row["kinetic_energy_ratio"] <= self.kinetic_energy)

    def to_dict(self) -> dict:
        """Plain data."""
        return {"stress_tolerance": self.stress_tolerance,
                "unbalanced_force": self.unbalanced_force,
                "kinetic_energy": self.kinetic_energy}


@dataclass(frozen=True)
class WallStage:
    """One stage on a wall box.

    Attributes
    ----------
    name:
        Stage name (the ``stage`` column).
    modes:
        Per axis x, y, z: ``"stress"``, ``"strain"`` (moving at the inertia-bound rate) or
        ``"fixed"``.
    targets:
        Per axis: the stress [Pa] (``"stress"``; NaN: hold the stress reached), the signed
        total logarithmic strain of the stage [-] (``"strain"``), 0 (``"fixed"``).
    stop:
        Extra stop criteria on recorded columns.
    dimension:
        The path's: 3, or 2 for a 2D sample's box (its z walls fixed, its vertical axis y).
    """

    name: str
    modes: tuple[str, str, str]
    targets: tuple[float, float, float]
    stop: tuple[StopCriterion, ...] = ()
    dimension: int = 3

    @property
    def moving_axes(self) -> tuple[int, ...]:
        """Axes whose walls move at a prescribed strain rate."""
        return tuple(a for a in range(3) if self.modes[a] == "strain")

    @property
    def oedometric(self) -> bool:
        """One-dimensional compression or extension: the vertical axis (z; y in 2D)
        strain-controlled, the others fixed (K0 = sigma_h / sigma_v is reported)."""
        return self.modes == (("fixed", "fixed", "strain") if self.dimension == 3 else
                              ("fixed", "strain", "fixed"))

    @property
    def stress_axes(self) -> tuple[int, ...]:
        """Stress-controlled axes."""
        return tuple(a for a in range(3) if self.modes[a] == "stress")

    def to_dict(self) -> dict:
        """Plain data."""
        return {"name": self.name, "modes": list(self.modes), "targets": list(self.targets),
                "stop": [c.to_dict() for c in self.stop], "dimension": self.dimension}


def wall_stages(path: LoadPath) -> list[WallStage]:
    """The :class:`WallStage` list of a ``path`` (module docstring); a 2D path drives the x
    and y walls of a planar box (:mod:`grainlab.engine.planar`), its z walls fixed."""
    dimension = path.dimension
    labels = voigt_labels(dimension)
    stages: list[WallStage] = []
    held = [math.nan, math.nan, math.nan]
    for stage in path.stages:
        where = f"stage {stage.name!r}"
        if stage.rotation_per_step != 0.0 or stage.rotation_start != 0.0:
            raise InputError(f"{where}: rotation", stage.rotation_start,
                             "no rotation of the control frame on a box of walls")
        if stage.component_basis is not None:
            raise InputError(f"{where}: component_basis", "given",
                             "None on a box of walls (controls along its axes only)")
        for i in range(dimension, len(labels)):
            if stage.values[i] != 0.0:
                raise InputError(f"{where}: {labels[i]}", (stage.control[i], stage.values[i]),
                                 "strain or stress controlled at 0: a box of walls does not "
                                 "shear")
        modes, targets = [], []
        for a in range(dimension):
            value = stage.values[a]
            if stage.control[a] == "strain":
                if value == 0.0:
                    modes.append("fixed")
                    targets.append(0.0)
                else:
                    modes.append("strain")
                    targets.append(value * stage.n_steps)
            else:
                if stage.stress_mode == "target":
                    if value <= 0.0:
                        raise InputError(f"{where}: sigma_{AXES[a] * 2}", value,
                                         "a compressive stress target > 0 Pa")
                    held[a] = value
                elif stage.stress_mode != "increment" or value != 0.0:
                    raise InputError(f"{where}: stress_mode", stage.stress_mode,
                                     "'target', or 'increment' with 0 (hold) on a wall box")
                modes.append("stress")
                targets.append(held[a])
        modes += ["fixed"] * (3 - dimension)  # a planar box's z walls
        targets += [0.0] * (3 - dimension)
        stages.append(WallStage(stage.name, tuple(modes), tuple(targets), tuple(stage.stop),
                                dimension))
    return stages
