"""Force distributions of a contact network (seed 003 Figs. 14 and 16; seed 002 eq. B2).

* Normal forces f_n = f . n of the active contact points (f_n > 0), normalised by their mean:
  P(f_n / <f_n>).
* Radial forces f_n' = F . l / |l| of the active interactions, with F the pair's resultant force
  (sum over its points) and l its branch vector — the "neighbour-force" network of seed 003
  §V.A: P(f_n' / <f_n'>).

Both PDFs are given on linear bins (for log-linear plots) and on logarithmic bins (for log-log
plots), normalised as densities: sum(density x bin width) = 1 over the values binned.

The branch-length / force correlation C_lf of seed 002 eq. (B2) is evaluated as the *centred*
Pearson coefficient of |l| and |F| over the active interactions,

    C_lf = <(l - <l>)(F - <F>)> / sqrt(<(l - <l>)^2> <(F - <F>)^2>).

The OCR'd eq. (B2) shows raw moments, <l f> / sqrt(<l^2> <f^2>), which for two positive
quantities is close to 1 whatever their correlation (it is 1 - O(relative variances)), whereas
the paper reports |C_lf| < 0.05 as evidence of *weak* correlation: only the centred form is
consistent with that statement, so it is the one implemented.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from grainlab.analysis.compute import Compute
from grainlab.errors import InputError


def probability_density(
    values: np.ndarray, n_bins: int, scale: str = "linear", edges: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Histogram density of ``values`` on ``n_bins`` bins.

    Parameters
    ----------
    values:
        (m,) samples (e.g. force ratios f / <f>).
    n_bins:
        Number of bins.
    scale:
        ``"linear"``: equal-width bins on [min(0, min), max]; ``"log"``: bins of equal width in
        log(value) on [min, max] of the positive values only (non-positive values are left
        out of the log histogram and of its normalisation).
    edges:
        Fixed (n_bins + 1,) increasing bin edges (positive for log bins) instead of the
        data's range, so that histograms of several snapshots share their bins (window
        averages). Values outside the edges are left out of the counts but kept in the
        normalisation: sum(density x width) is then the share of the values inside.

    Returns
    -------
    centres, density, edges:
        (n_bins,) bin centres (arithmetic for linear, geometric for log bins), (n_bins,)
        densities with sum(density x width) = 1 over the values binned, (n_bins + 1,) edges.
        All empty when there is nothing to bin (with fixed ``edges``: NaN densities on
        those bins). A range of zero width is widened (by +-0.5 on
        linear bins, by a factor 2 on log bins) so that equal values still give a density.

    >>> centres, density, edges = probability_density(np.array([0.5, 1.5, 1.5, 2.0]), 2)
    >>> edges, density
    (array([0., 1., 2.]), array([0.25, 0.75]))
    """
    values = np.asarray(values, dtype=float).reshape(-1)
    if scale == "log":
        values = values[values > 0]
    elif scale != "linear":
        raise InputError("scale", scale, '"linear" or "log"')
    if edges is not None:
        return _fixed_bins_density(values, check_edges(edges, n_bins, scale), scale)
    if values.size == 0:
        empty = np.empty(0)
        return empty, empty.copy(), empty.copy()
    high = float(values.max())
    if scale == "linear":
        low = min(0.0, float(values.min()))
        if high <= low:
            low, high = low - 0.5, high + 0.5
        edges = np.linspace(low, high, n_bins + 1)
        centres = 0.5 * (edges[1:] + edges[:-1])
    else:
        low = float(values.min())
        if high <= low:
            low, high = low / 2.0, high * 2.0
        edges = np.geomspace(low, high, n_bins + 1)
        edges[0], edges[-1] = low, high  # exact ends: no sample lost to rounding
        centres = np.sqrt(edges[1:] * edges[:-1])
    counts, _ = np.histogram(values, bins=edges)
    density = counts / (values.size * np.diff(edges))
    return centres, density, edges


def check_edges(edges, n_bins: int, scale: str) -> np.ndarray:
    """``edges`` as a float array of n_bins + 1 strictly increasing values (positive for
    ``scale = "log"``), else an :class:`InputError`."""
    edges = np.asarray(edges, dtype=float).reshape(-1)
    if (edges.size != n_bins + 1 or not np.all(np.isfinite(edges))
            or not np.all(np.diff(edges) > 0) or (scale == "log" and edges[0] <= 0)):
        raise InputError(f"{scale} bin edges", edges.tolist(),
                         f"{n_bins + 1} increasing finite values"
                         + (", all positive" if scale == "log" else ""))
    return edges


def _fixed_bins_density(values: np.ndarray, edges: np.ndarray, scale: str
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if scale == "linear":
        centres = 0.5 * (edges[1:] + edges[:-1])
    else:
        centres = np.sqrt(edges[1:] * edges[:-1])
    counts, _ = np.histogram(values, bins=edges)
    if values.size == 0:
        return centres, np.full(centres.size, np.nan), edges.copy()
    return centres, counts / (values.size * np.diff(edges)), edges.copy()


def _pdf_frame(ratios: np.ndarray, n_bins: int, scale: str,
               edges: np.ndarray | None = None) -> pd.DataFrame:
    centres, density, edges = probability_density(ratios, n_bins, scale, edges)
    frame = pd.DataFrame({"force_ratio": centres, "density": density})
    frame.attrs["bin_edges"] = edges
    frame.attrs["scale"] = scale
    return frame


def pearson_correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Centred Pearson coefficient of two (m,) samples [-]; NaN when either is constant or
    there are fewer than two samples.

    >>> pearson_correlation(np.array([1.0, 2.0, 3.0]), np.array([2.0, 4.0, 6.0]))
    1.0
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.size < 2:
        return float("nan")
    da, db = a - a.mean(), b - b.mean()
    norm = float(np.sqrt(np.dot(da, da) * np.dot(db, db)))
    return float(np.clip(np.dot(da, db) / norm, -1.0, 1.0)) if norm > 0 else float("nan")


def radial_forces(network) -> np.ndarray:
    """(P,) radial force f_n' = F . l / |l| of every interaction [N], F the pair resultant
    (seed 003 §V.A; positive in compression)."""
    lengths = np.linalg.norm(network.pair_branches, axis=1)
    projected = np.einsum("pi,pi->p", network.pair_forces, network.pair_branches)
    return np.divide(projected, lengths, out=np.zeros_like(projected), where=lengths > 0)


class ForceStatistics(Compute):
    """Normal- and radial-force PDFs, fractions of forces above the mean and the
    branch-length / force correlation C_lf (seed 003 Figs. 14, 16; seed 002 eq. B2, centred;
    see the module docstring).

    Parameters
    ----------
    n_bins:
        Number of bins of every PDF (integer >= 1), default 40.
    linear_edges, log_edges:
        Fixed (n_bins + 1,) edges of the linear and logarithmic bins of f / <f> [-]
        (:func:`probability_density`); default None: bins over each snapshot's own range.
        Fixed edges make the PDFs of several snapshots comparable bin by bin; ratios outside
        them are left out of the counts, not of the normalisation.

    Properties after :meth:`compute`:

    * ``normal_pdf_linear``, ``normal_pdf_log``: P(f_n / <f_n>) over the active points;
    * ``radial_pdf_linear``, ``radial_pdf_log``: P(f_n' / <f_n'>) over the active pairs
      (log bins keep the positive ratios only);

      each a :class:`pandas.DataFrame` with columns ``force_ratio`` (bin centre) and
      ``density`` [-], and ``attrs["bin_edges"]``;
    * ``mean_normal_force`` <f_n>, ``mean_radial_force`` <f_n'> [N];
    * ``fraction_normal_above_mean``, ``fraction_radial_above_mean`` [-];
    * ``max_normal_ratio``, ``max_radial_ratio``: largest f / <f> [-];
    * ``pearson_length_force``: C_lf over the active pairs [-].

    Quantities over an empty set are NaN (and the PDFs empty, or NaN on fixed edges).

    >>> from grainlab.analysis.contact_network import ContactNetwork
    >>> net = ContactNetwork.from_arrays(
    ...     positions=[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], volumes=[3.0] * 3, volume=30.0,
    ...     pair_particles=[[0, 1], [0, 2]], pair_branches=[[2.0, 0.0], [0.0, 2.0]],
    ...     point_pairs=[0, 1], point_positions=[[1.0, 0.0], [0.0, 1.0]],
    ...     point_normals=[[1.0, 0.0], [0.0, 1.0]], point_forces=[[1.0, 0.0], [0.0, 3.0]])
    >>> stats = ForceStatistics(n_bins=4).compute(net)
    >>> stats.mean_normal_force, stats.fraction_normal_above_mean
    (2.0, 0.5)
    """

    def __init__(self, n_bins: int = 40, linear_edges: np.ndarray | None = None,
                 log_edges: np.ndarray | None = None) -> None:
        super().__init__()
        if isinstance(n_bins, bool) or not isinstance(n_bins, int | np.integer) or n_bins < 1:
            raise InputError("n_bins", n_bins, "an integer >= 1")
        self.n_bins = int(n_bins)
        self.edges = {
            scale: None if edges is None else check_edges(edges, self.n_bins, scale)
            for scale, edges in (("linear", linear_edges), ("log", log_edges))}

    def _compute(self, network) -> None:
        normal = network.point_normal_forces[network.active_points()]
        active_pairs = network.active_pairs()
        radial = radial_forces(network)[active_pairs]
        lengths = np.linalg.norm(network.pair_branches[active_pairs], axis=1)
        magnitudes = np.linalg.norm(network.pair_forces[active_pairs], axis=1)
        for name, forces in (("normal", normal), ("radial", radial)):
            mean = float(forces.mean()) if forces.size else float("nan")
            ratios = forces / mean if mean > 0 else np.empty(0)
            self._store(**{
                f"mean_{name}_force": mean,
                f"fraction_{name}_above_mean":
                    float(np.mean(forces > mean)) if forces.size else float("nan"),
                f"max_{name}_ratio": float(ratios.max()) if ratios.size else float("nan"),
                f"{name}_pdf_linear": _pdf_frame(ratios, self.n_bins, "linear",
                                                 self.edges["linear"]),
                f"{name}_pdf_log": _pdf_frame(ratios, self.n_bins, "log", self.edges["log"]),
            })
        self._store(pearson_length_force=pearson_correlation(lengths, magnitudes))

    @property
    def normal_pdf_linear(self) -> pd.DataFrame:
        """P(f_n/<f_n>) on linear bins: columns force_ratio, density."""
        return self._get("normal_pdf_linear")

    @property
    def normal_pdf_log(self) -> pd.DataFrame:
        """P(f_n/<f_n>) on logarithmic bins: columns force_ratio, density."""
        return self._get("normal_pdf_log")

    @property
    def radial_pdf_linear(self) -> pd.DataFrame:
        """P(f_n'/<f_n'>) on linear bins: columns force_ratio, density."""
        return self._get("radial_pdf_linear")

    @property
    def radial_pdf_log(self) -> pd.DataFrame:
        """P(f_n'/<f_n'>) on logarithmic bins (positive ratios): columns force_ratio, density."""
        return self._get("radial_pdf_log")

    @property
    def mean_normal_force(self) -> float:
        """<f_n> over active points [N]."""
        return self._get("mean_normal_force")

    @property
    def mean_radial_force(self) -> float:
        """<f_n'> over active pairs [N]."""
        return self._get("mean_radial_force")

    @property
    def fraction_normal_above_mean(self) -> float:
        """Fraction of active points with f_n > <f_n> [-]."""
        return self._get("fraction_normal_above_mean")

    @property
    def fraction_radial_above_mean(self) -> float:
        """Fraction of active pairs with f_n' > <f_n'> [-]."""
        return self._get("fraction_radial_above_mean")

    @property
    def max_normal_ratio(self) -> float:
        """max f_n / <f_n> [-]."""
        return self._get("max_normal_ratio")

    @property
    def max_radial_ratio(self) -> float:
        """max f_n' / <f_n'> [-]."""
        return self._get("max_radial_ratio")

    @property
    def pearson_length_force(self) -> float:
        """Centred Pearson coefficient C_lf of |l| and |F| over active pairs [-] (eq. B2)."""
        return self._get("pearson_length_force")

    def descriptors(self) -> dict[str, float]:
        """Flat dict: mean_normal_force, mean_radial_force, fraction_normal_above_mean,
        fraction_radial_above_mean, max_normal_ratio, max_radial_ratio,
        pearson_length_force."""
        return {name: self._get(name) for name in (
            "mean_normal_force", "mean_radial_force", "fraction_normal_above_mean",
            "fraction_radial_above_mean", "max_normal_ratio", "max_radial_ratio",
            "pearson_length_force")}
