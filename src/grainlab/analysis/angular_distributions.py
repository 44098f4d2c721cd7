"""Angular distributions of contact orientations, forces and branch lengths (seed 002 Fig. 14).

For a contact network under a (general) load, the orientation of each entry of the contact frame
(normal n) or branch frame (n' = l/|l|) is measured by its angle theta from the major principal
stress direction e1 (see :class:`~grainlab.analysis.fabric.Fabric`). Because n and -n describe the
same contact (swapping the two particles turns (n, f, l) into (-n, -f, -l)), orientations are
folded:

* 3D: theta = arccos |n . e1| in [0, pi/2]; ``n_bins`` equal bins in theta. A bin
  [theta_a, theta_b] covers the solid angle dOmega = 4 pi (cos theta_a - cos theta_b) [sr] of
  both hemispheres, and P = N_bin / (N_c dOmega) is a density per steradian (seed 002 eq. 21),
  1/(4 pi) for isotropic contacts and sum P dOmega = 1.
* 2D: theta = angle of n from e1 counter-clockwise (towards e2), folded into [0, pi); a bin
  covers 2 dtheta [rad] (itself and its opposite), P = N_bin / (N_c 2 dtheta), 1/(2 pi) when
  isotropic.

Per-bin means (seed 002 eqs. 22–25): ``f_n`` <f_n>(theta) [N], ``f_t`` <f_t>(theta) the mean
tangential force magnitude [N], ``l_n`` <l_n>(theta) [m], ``l_t`` <l_t>(theta) [m] (l . t, t along
the tangential force); and the signed meridional components ``f_t_meridional`` = <f . m> and
``l_t_meridional`` = <l . m>, with m = -dn/dtheta the unit tangent pointing towards the
compression axis (decreasing theta). The harmonic model (seed 002 eq. 26) describes the
meridional components: friction mobilised against the deviatoric strain points towards the
axis, so a_ft > 0 and <f_t>(theta) = <f_n> a_ft sin 2 theta, which in 2D changes sign at
theta = pi/2 while a magnitude cannot. Empty bins give NaN means.

Harmonic curves at the bin centres, with the anisotropies of :class:`Fabric` (Y = 3cos^2 theta - 1
in 3D, cos 2 theta in 2D; 1/(4 pi) becomes 1/(2 pi) in 2D):

P = (1 + a_c Y)/(4 pi),  <l_n>(theta) = <l_n>(1 + a_ln Y),  <l_t>(theta) = <l_n> a_lt sin 2 theta,
<f_n>(theta) = <f_n>(1 + a_fn Y),  <f_t>(theta) = <f_n> a_ft sin 2 theta,

and in the branch frame with a'_c, a_ln', a_fn', a_ft' and the means over active pairs (the
branch-frame table uses the same column names for the primed quantities; it has no l_t).

Normalisation: eq. 26 calls <f_n> "the mean normal force", but its own product
P(theta) <f_n>(theta) averages to <f_n>(1 + <Y^2> a_c a_fn), <Y^2> = 4/5 in 3D (1/2 in 2D).
The curves here use <f_n> / (1 + <Y^2> a_c a_fn) (and <l_n> / (1 + <Y^2> a_c a_ln) for the
lengths), so that the model reproduces the measured means; with a_c = 0.3 and a_fn = 0.4 the
literal form lies about 10 % above the data at every angle.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from grainlab.analysis.compute import Compute
from grainlab.analysis.fabric import FRAME_LEVELS, Fabric, FrameComponents
from grainlab.errors import InputError


def folded_angles(frame: FrameComponents, directions: np.ndarray) -> dict[str, np.ndarray]:
    """Angle of each entry from e1 and its meridional components (see the module docstring).

    ``directions`` holds the principal stress directions as columns (e1 first). Returns
    ``theta`` (m,) [rad] (3D: [0, pi/2]; 2D: [0, pi)), ``f_t_meridional`` and
    ``l_t_meridional`` (m,) — f . m and l . m with m = -dn/dtheta after folding (0 where n is
    along e1 in 3D, where m is undefined).
    """
    n, f, br = frame.normals, frame.forces, frame.branches
    e1 = directions[:, 0]
    cos = n @ e1
    if frame.dimension == 3:
        sign = np.where(cos < 0.0, -1.0, 1.0)
        c = np.clip(np.abs(cos), 0.0, 1.0)
        theta = np.arccos(c)
        s = np.sin(theta)
        # m = (e1 - cos(theta) n_folded) / sin(theta); n_folded = sign n, f_folded = sign f.
        f_e1 = sign * (f @ e1)
        l_e1 = sign * (br @ e1)
        ok = s > 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            f_m = np.where(ok, (f_e1 - c * frame.normal_forces) / s, 0.0)
            l_m = np.where(ok, (l_e1 - c * frame.normal_lengths) / s, 0.0)
        return {"theta": theta, "f_t_meridional": f_m, "l_t_meridional": l_m}
    e2 = directions[:, 1]  # e1 rotated by +90 degrees (Fabric's frames are right-handed)
    angle = np.arctan2(n @ e2, cos)  # (-pi, pi]
    flip = (angle < 0.0) | (angle >= np.pi)
    theta = np.where(flip, angle + np.pi, angle)
    theta = np.where(theta >= np.pi, theta - np.pi, theta)
    sign = np.where(flip, -1.0, 1.0)
    # m = -dn/dtheta = sin(theta) e1 - cos(theta) e2 for the folded n.
    m1, m2 = np.sin(theta), -np.cos(theta)
    f_m = sign * (m1 * (f @ e1) + m2 * (f @ e2))
    l_m = sign * (m1 * (br @ e1) + m2 * (br @ e2))
    return {"theta": theta, "f_t_meridional": f_m, "l_t_meridional": l_m}


def _binned_table(frame: FrameComponents, directions: np.ndarray, n_bins: int,
                  harmonic: dict[str, float], with_lt: bool) -> pd.DataFrame:
    d = frame.dimension
    folded = folded_angles(frame, directions)
    top = 0.5 * np.pi if d == 3 else np.pi
    edges = np.linspace(0.0, top, n_bins + 1)
    index = np.minimum((folded["theta"] / (top / n_bins)).astype(np.int64), n_bins - 1)
    count = np.bincount(index, minlength=n_bins).astype(float)
    total = float(frame.size)
    if d == 3:
        measure = 4.0 * np.pi * (np.cos(edges[:-1]) - np.cos(edges[1:]))
        iso = 1.0 / (4.0 * np.pi)
    else:
        measure = 2.0 * np.diff(edges)
        iso = 1.0 / (2.0 * np.pi)
    centre = 0.5 * (edges[:-1] + edges[1:])
    shape = 3.0 * np.cos(centre) ** 2 - 1.0 if d == 3 else np.cos(2.0 * centre)
    sin2 = np.sin(2.0 * centre)
    # Prefactors such that the model's P-weighted means equal the measured ones: the mean of
    # P(theta) <x>(theta) is x_bar (1 + <Y^2> a_c a_x), <Y^2> = 4/5 (3D) or 1/2 (2D).
    y2 = 0.8 if d == 3 else 0.5
    f_bar = harmonic["f_n"] / (1.0 + y2 * harmonic["a_c"] * harmonic["a_fn"])
    l_bar = harmonic["l_n"] / (1.0 + y2 * harmonic["a_c"] * harmonic["a_ln"])

    def mean(values: np.ndarray) -> np.ndarray:
        sums = np.bincount(index, weights=values, minlength=n_bins)
        out = np.full(n_bins, np.nan)
        np.divide(sums, count, out=out, where=count > 0)
        return out

    table = {
        "theta_deg": np.degrees(centre),
        "theta_lo_deg": np.degrees(edges[:-1]),
        "theta_hi_deg": np.degrees(edges[1:]),
        "solid_angle": measure,
        "count": count.astype(np.int64),
        "P": count / (total * measure) if total else np.full(n_bins, np.nan),
        "P_harmonic": iso * (1.0 + harmonic["a_c"] * shape),
        "f_n": mean(frame.normal_forces),
        "f_n_harmonic": f_bar * (1.0 + harmonic["a_fn"] * shape),
        "f_t": mean(frame.tangential_forces),
        "f_t_meridional": mean(folded["f_t_meridional"]),
        "f_t_harmonic": f_bar * harmonic["a_ft"] * sin2,
        "l_n": mean(frame.normal_lengths),
        "l_n_harmonic": l_bar * (1.0 + harmonic["a_ln"] * shape),
    }
    if with_lt:
        table["l_t"] = mean(frame.tangential_lengths)
        table["l_t_meridional"] = mean(folded["l_t_meridional"])
        table["l_t_harmonic"] = l_bar * harmonic["a_lt"] * sin2
    return pd.DataFrame(table)


class AngularDistributions(Compute):
    """Binned angular densities and means about the major principal stress direction, with the
    harmonic curves of seed 002 eq. 26 (Fig. 14), in the contact and branch frames.

    Parameters
    ----------
    n_bins:
        Number of equal bins of theta in [0, pi/2] (3D) or [0, pi) (2D).
    frame_level:
        Passed to :class:`~grainlab.analysis.fabric.Fabric` (``"points"`` or ``"pairs"``).

    Properties after :meth:`compute`: :attr:`contact_frame` and :attr:`branch_frame`, pandas
    DataFrames with one row per bin and columns ``theta_deg`` (bin centre), ``theta_lo_deg``,
    ``theta_hi_deg``, ``solid_angle`` [sr; rad in 2D], ``count``, ``P`` [1/sr; 1/rad in 2D],
    ``P_harmonic``, ``f_n``, ``f_n_harmonic``, ``f_t``, ``f_t_meridional``, ``f_t_harmonic`` [N],
    ``l_n``, ``l_n_harmonic`` [m] and (contact frame only) ``l_t``, ``l_t_meridional``,
    ``l_t_harmonic`` [m]; :attr:`fabric`, the :class:`Fabric` whose stress axes and
    anisotropies were used. For a polar plot use theta and theta + pi (and the mirror images).

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0, 0, 0], [0, 0, 2], [2, 0, 0]], volumes=[4.2] * 3, volume=60.0,
    ...     pair_particles=[[0, 1], [0, 2]], pair_branches=[[0, 0, 2], [2, 0, 0]],
    ...     point_pairs=[0, 1], point_positions=[[0, 0, 1], [1, 0, 0]],
    ...     point_normals=[[0, 0, 1], [1, 0, 0]], point_forces=[[0, 0, 3], [1, 0, 0]])
    >>> table = AngularDistributions(n_bins=2).compute(net).contact_frame
    >>> table[["theta_deg", "count", "f_n"]].to_numpy().tolist()
    [[22.5, 1.0, 3.0], [67.5, 1.0, 1.0]]
    """

    def __init__(self, n_bins: int = 18, frame_level: str = "points") -> None:
        super().__init__()
        if not (isinstance(n_bins, int | np.integer) and n_bins >= 1):
            raise InputError("n_bins", n_bins, "a positive integer number of bins")
        if frame_level not in FRAME_LEVELS:
            raise InputError("frame_level", frame_level, f"one of {FRAME_LEVELS}")
        self.n_bins = int(n_bins)
        self.frame_level = frame_level

    def _compute(self, network) -> None:
        fabric = Fabric(self.frame_level).compute(network)
        a = fabric.anisotropies
        directions = fabric.stress_directions
        contact = _binned_table(
            fabric.contact_components, directions, self.n_bins,
            {"a_c": a["a_c"], "a_ln": a["a_ln"], "a_lt": a["a_lt"], "a_fn": a["a_fn"],
             "a_ft": a["a_ft"], "f_n": fabric.mean_normal_force,
             "l_n": fabric.mean_normal_length}, with_lt=True)
        branch = _binned_table(
            fabric.branch_components, directions, self.n_bins,
            {"a_c": a["a_c_branch"], "a_ln": a["a_ln_branch"], "a_fn": a["a_fn_branch"],
             "a_ft": a["a_ft_branch"], "f_n": fabric.mean_radial_force,
             "l_n": fabric.mean_branch_length}, with_lt=False)
        self._store(contact_frame=contact, branch_frame=branch, fabric=fabric)

    @property
    def contact_frame(self) -> pd.DataFrame:
        """Per-bin table of the contact frame (n, t) (see the class docstring)."""
        return self._get("contact_frame")

    @property
    def branch_frame(self) -> pd.DataFrame:
        """Per-bin table of the branch frame (n', t'); f_n is the radial force f_n', f_t the
        orthoradial f_t', l_n the branch length |l|."""
        return self._get("branch_frame")

    @property
    def fabric(self) -> Fabric:
        """The :class:`Fabric` computed on the same network (stress axes, anisotropies)."""
        return self._get("fabric")
