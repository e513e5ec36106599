"""Fisher exponent tau of a pooled cluster-size distribution, with corrections to scaling,
(the finite-size-scaling collapse is :mod:`fcsweep.analysis.fss`).

At a 2-D percolation point the number of clusters of size ``s`` per site is

    n_s = A s^-tau (1 + a s^-Omega + ...) F(s / s_xi),    tau = 187/91,

with a non-universal correction amplitude ``a``, a correction exponent ``Omega`` and a
cutoff function ``F`` that is 1 for ``s << s_xi``.  In a finite periodic system at the
critical point ``s_xi ~ N^(D/2)`` (fractal dimension D = 91/48), and ``F`` is not a plain
cutoff: the spanning cluster makes a bump that starts near ``0.2 N^(91/96)`` (measured on
site percolation on the triangular lattice, N = 1024 ... 65536).  Small clusters are far
from the asymptote: on the triangular lattice ``n_s s^tau`` grows by a factor 3.6 from
``s = 1`` to ``s = 100``, so a pure power law fitted over sizes 2 ... 128 reads tau = 1.7-1.95
instead of 2.055.

:func:`fit_fisher_exponent` therefore fits, by maximum likelihood, the truncated discrete
distribution ``p(s) ∝ s^-tau (1 + a s^-Omega)`` to the counts in a window
``[s_min, s_max]`` with ``s_max = CUTOFF_FRACTION * N^(91/96)`` below the finite-size bump,
``s_min = 6`` and an effective ``Omega = 0.65``.  These three choices are the calibration:
on exact critical site percolation (triangular lattice, N = 1024 ... 65536, 7 x 10^5
clusters each, 1.4 x 10^5 in the window) the fit returns tau within 0.009 of 187/91 (at
most 1.0 of its own error there), while the asymptotic ``Omega = 72/91`` (Ziff, Phys.
Rev. E 83, 020107 (2011)) with a single correction term reads 0.015-0.025 low at
N = 1024 and 4096, because at these sizes further
corrections (``s^-1``, ``s^-2 Omega``) still matter and an effective exponent absorbs them.

The correction amplitude is bounded by ``|a| s_min^-Omega <= 1``: the correction must stay
smaller than the leading term across the window, otherwise the expansion is meaningless
and the fit degenerates (``a -> infinity`` turns ``s^-tau`` into ``s^-(tau + Omega)``).
A fit that ends on that bound is flagged.

Errors (1 sigma): statistical from the profile likelihood (the interval where the
likelihood, maximised over ``a``, has dropped by ``g/2`` for statistical inefficiency
``g``; the error is its wider side, because at ~10^3 clusters the interval is
asymmetric and its half-width covers 187/91 in only 62 % of exact samples), combined in
quadrature with a systematic one, half the shift of tau when the fit is repeated with
``Omega = 72/91``.  The counts are treated as independent
(Poisson) draws; clusters of successive frames of a trajectory are not, so pass the
statistical inefficiency ``g = 1 + 2 tau_int`` of the frames (e.g. of the number of
clusters per frame) as ``inefficiency`` when it is known; with ``g = 1`` the error is a
lower bound for correlated frames.

The finite-size-scaling collapse of the largest cluster is :mod:`fcsweep.analysis.fss`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, minimize_scalar
from scipy.stats import chi2

#: Fisher exponent of 2-D percolation.
TAU_2D = 187.0 / 91.0
#: Fractal dimension of 2-D percolation clusters.
D_F_2D = 91.0 / 48.0
#: Effective correction-to-scaling exponent used by default (calibrated; see module doc).
OMEGA_EFFECTIVE = 0.65
#: Asymptotic correction exponent (Ziff 2011), used for the systematic error.
OMEGA_ASYMPTOTIC = 72.0 / 91.0
#: Default smallest cluster size fitted.
S_MIN = 6
#: Default largest size fitted, as a fraction of the critical cluster size N^(D/2).
CUTOFF_FRACTION = 0.1
#: Range of tau searched by the fit.
TAU_RANGE = (0.5, 8.0)
#: Goodness-of-fit p-value below which a fit is flagged.
P_VALUE_MIN = 1e-3


@dataclass(frozen=True)
class FisherFit:
    """Result of :func:`fit_fisher_exponent`.

    Attributes
    ----------
    tau, tau_err : float
        Fisher exponent and its total 1-sigma error (statistical and Omega-systematic in
        quadrature); NaN when the data cannot determine tau (see ``reason``).
    tau_err_stat, tau_err_sys : float
        The two parts of ``tau_err``.
    tau_lo, tau_hi : float
        Profile-likelihood 1-sigma interval (statistical only; may be asymmetric).
    amplitude : float
        Fitted correction amplitude ``a``.
    s_min, s_max : int
        Fit window (cluster sizes, inclusive).
    n_clusters : int
        Clusters inside the window.
    p_value : float
        Chi-square goodness of fit of the model to the counts (sizes merged so that each
        group expects >= 5 clusters), with ``inefficiency`` taken into account.
    reason : str
        Empty when the fit is usable, otherwise why it is not (or not trusted).
    """

    tau: float
    tau_err: float
    tau_err_stat: float
    tau_err_sys: float
    tau_lo: float
    tau_hi: float
    amplitude: float
    s_min: int
    s_max: int
    n_clusters: int
    p_value: float
    reason: str


def fisher_window(n_sites: int, s_min: int = S_MIN, cutoff_fraction: float = CUTOFF_FRACTION) -> tuple[int, int]:
    """Default fit window ``(s_min, s_max)`` for a system of ``n_sites`` sites.

    ``s_max = floor(cutoff_fraction * n_sites^(D/2))`` with D = 91/48, i.e. a fixed fraction
    of the size of the largest critical cluster, below the finite-size bump.
    """
    if n_sites < 1:
        raise ValueError(f"n_sites must be >= 1, got {n_sites}")
    return int(s_min), int(np.floor(cutoff_fraction * float(n_sites) ** (D_F_2D / 2.0)))


class _WindowModel:
    """Negative log-likelihood of ``p(s) ∝ s^-tau (1 + a s^-omega)`` on the window counts."""

    def __init__(self, s: np.ndarray, c: np.ndarray, omega: float):
        self.c = c
        self.n = c.sum()
        self.log_s = np.log(s)
        self.x = s ** -omega
        # |a| s_min^-omega <= 1, slightly inside on the negative side so 1 + a x > 0.
        self.a_bounds = (-(1.0 - 1e-9) / self.x[0], 1.0 / self.x[0])

    def nll(self, tau: float, a: float) -> float:
        lw = -tau * self.log_s + np.log1p(a * self.x)
        m = lw.max()
        return float(-(self.c * lw).sum() + self.n * (m + np.log(np.exp(lw - m).sum())))

    def profile(self, tau: float) -> tuple[float, float]:
        """``(min_a nll(tau, a), argmin a)`` over the bounded amplitude."""
        r = minimize_scalar(lambda a: self.nll(tau, a), bounds=self.a_bounds, method="bounded",
                            options={"xatol": 1e-7 * (self.a_bounds[1] - self.a_bounds[0])})
        return float(r.fun), float(r.x)

    def probabilities(self, tau: float, a: float) -> np.ndarray:
        lw = -tau * self.log_s + np.log1p(a * self.x)
        w = np.exp(lw - lw.max())
        return w / w.sum()


def _profile_fit(model: _WindowModel, threshold: float):
    """Maximum-likelihood tau, amplitude and the profile interval where nll rises by ``threshold``."""
    grid = np.linspace(TAU_RANGE[0], TAU_RANGE[1], 151)
    prof = np.array([model.profile(t)[0] for t in grid])
    k = int(np.argmin(prof))
    lo_b, hi_b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    r = minimize_scalar(lambda t: model.profile(t)[0], bounds=(lo_b, hi_b), method="bounded",
                        options={"xatol": 1e-7})
    tau, best = float(r.x), float(r.fun)
    a = model.profile(tau)[1]

    def excess(t):
        return model.profile(t)[0] - best - threshold

    out = prof - best > threshold
    below, above = grid[out & (grid < tau)], grid[out & (grid > tau)]
    lo = brentq(excess, below[-1], tau, xtol=1e-6) if below.size else np.nan
    hi = brentq(excess, tau, above[0], xtol=1e-6) if above.size else np.nan
    return tau, a, lo, hi


def _p_value(c: np.ndarray, expected: np.ndarray, n_params: int, inefficiency: float) -> float:
    """Pearson chi-square p-value, consecutive sizes merged until each group expects >= 5."""
    groups_c, groups_e, acc_c, acc_e = [], [], 0.0, 0.0
    for ci, ei in zip(c, expected):
        acc_c += ci
        acc_e += ei
        if acc_e >= 5.0:
            groups_c.append(acc_c)
            groups_e.append(acc_e)
            acc_c = acc_e = 0.0
    if groups_e and acc_e > 0:
        groups_c[-1] += acc_c
        groups_e[-1] += acc_e
    dof = len(groups_e) - 1 - n_params
    if dof < 1:
        return np.nan
    gc, ge = np.array(groups_c), np.array(groups_e)
    return float(chi2.sf(((gc - ge) ** 2 / ge).sum() / inefficiency, dof))


def _check_counts(counts, n_sites: int) -> np.ndarray:
    c = np.asarray(counts, dtype=float)
    if c.ndim != 1:
        raise ValueError(f"counts must be 1-D (counts[s-1] = clusters of size s), got shape {c.shape}")
    if n_sites < 1:
        raise ValueError(f"n_sites must be >= 1, got {n_sites}")
    if not np.all(np.isfinite(c)) or np.any(c < 0):
        raise ValueError("counts must be finite and >= 0")
    if np.any(c[n_sites:] != 0):
        raise ValueError(f"counts has clusters larger than n_sites = {n_sites}: a cluster cannot exceed n_sites")
    return c[:n_sites]  # trailing zeros (a size axis shared with larger systems) are dropped


def fit_fisher_exponent(counts, n_sites: int, *, s_min: int = S_MIN, s_max: int | None = None,
                        omega: float = OMEGA_EFFECTIVE, omega_alt: float | None = OMEGA_ASYMPTOTIC,
                        inefficiency: float = 1.0) -> FisherFit:
    """Fisher exponent of a pooled cluster-size distribution, with its error and diagnostics.

    Maximum-likelihood fit of ``p(s) ∝ s^-tau (1 + a s^-omega)`` to the clusters with sizes in
    ``[s_min, s_max]`` (see the module docstring for the model, the calibration on exact
    critical percolation and the error).

    Parameters
    ----------
    counts : array_like, shape (S,)
        ``counts[s-1]`` = number of clusters of size ``s`` pooled over frames; entries beyond
        ``n_sites`` must be zero (NaN is not allowed; missing sizes are zeros).
    n_sites : int
        Number of sites (cells) of one frame; sets the finite-size window.
    s_min : int, optional
        Smallest size fitted (default 6; below it one correction term is not enough).
    s_max : int, optional
        Largest size fitted; default ``fisher_window(n_sites)[1] = 0.1 n_sites^(91/96)``.
    omega : float, optional
        Correction-to-scaling exponent (default 0.65, effective, calibrated).
    omega_alt : float or None, optional
        Exponent of the refit that gives the systematic error (default 72/91); None skips it.
    inefficiency : float, optional
        Statistical inefficiency ``g >= 1`` of the pooled frames; statistical errors scale
        as ``sqrt(g)`` (default 1: independent frames).

    Returns
    -------
    FisherFit
        tau, its errors, the amplitude, window, goodness of fit and a ``reason`` that is
        empty for a usable fit.  tau and its errors are NaN when the window holds too
        few sizes or clusters, or the likelihood does not bound tau inside (0.5, 8).

    Raises
    ------
    ValueError
        For counts that are not 1-D, negative or non-finite, non-zero beyond ``n_sites``, or a
        window or inefficiency out of range.
    """
    c_all = _check_counts(counts, n_sites)
    if s_max is None:
        s_max = fisher_window(n_sites, s_min)[1]
    s_min, s_max = int(s_min), int(s_max)
    if s_min < 1 or s_max > n_sites:
        raise ValueError(f"window [s_min, s_max] = [{s_min}, {s_max}] must lie in [1, n_sites = {n_sites}]")
    if not (inefficiency >= 1.0 and np.isfinite(inefficiency)):
        raise ValueError(f"inefficiency must be a finite number >= 1, got {inefficiency}")
    nan = float("nan")
    c = np.zeros(max(s_max - s_min + 1, 0))
    top = min(s_max, c_all.size)
    if top >= s_min:
        c[:top - s_min + 1] = c_all[s_min - 1:top]
    n_in = int(round(c.sum()))

    def empty(reason, tau=nan, a=nan, lo=nan, hi=nan, p=nan):
        return FisherFit(tau, nan, nan, nan, lo, hi, a, s_min, s_max, n_in, p, reason)

    if s_max < 3 * s_min:
        return empty(f"window [{s_min}, {s_max}] narrower than a factor 3 (n_sites = {n_sites} too small)")
    if np.count_nonzero(c) < 4:
        return empty(f"fewer than 4 distinct cluster sizes in [{s_min}, {s_max}]")
    s = np.arange(s_min, s_max + 1, dtype=float)
    model = _WindowModel(s, c, omega)
    tau, a, lo, hi = _profile_fit(model, 0.5 * inefficiency)
    p = _p_value(c, n_in * model.probabilities(tau, a), 2, inefficiency)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return empty(f"likelihood does not bound tau inside {TAU_RANGE} ({n_in} clusters in window)",
                     tau, a, lo, hi, p)
    err_stat = max(hi - tau, tau - lo)  # the wider side: half the width under-covers (measured)
    err_sys = 0.0
    if omega_alt is not None:
        tau_alt, _, _, _ = _profile_fit(_WindowModel(s, c, omega_alt), 0.5 * inefficiency)
        err_sys = 0.5 * abs(tau_alt - tau)
    reasons = []
    if abs(a) * model.x[0] > 1.0 - 1e-3:
        reasons.append(f"correction amplitude at its bound |a| s_min^-omega = 1 (a = {a:.3g}): "
                       "window not in the scaling regime")
    if np.isfinite(p) and p < P_VALUE_MIN:
        reasons.append(f"poor fit, p = {p:.2g}")
    return FisherFit(tau, float(np.hypot(err_stat, err_sys)), err_stat, err_sys, lo, hi, a,
                     s_min, s_max, n_in, p, "; ".join(reasons))


def fisher_exponent(counts, n_sites: int, **kwargs) -> tuple[float, float]:
    """Fisher exponent ``tau`` of ``n_s ~ s^-tau`` and its 1-sigma error from pooled cluster counts.

    Calibrated estimator: a maximum-likelihood fit of ``s^-tau (1 + a s^-0.65)`` over
    ``6 <= s <= 0.1 n_sites^(91/96)``, which returns 187/91 within its error on exact
    critical site percolation of the same size (method, calibration and error in
    :mod:`fcsweep.analysis.percolation`; all diagnostics from :func:`fit_fisher_exponent`).

    Parameters
    ----------
    counts : array_like, shape (S,)
        ``counts[s-1]`` = number of clusters of size ``s`` pooled over frames (zero beyond ``n_sites``).
    n_sites : int
        Number of sites of one frame.
    **kwargs
        ``s_min``, ``s_max``, ``omega``, ``omega_alt``, ``inefficiency``: see
        :func:`fit_fisher_exponent`.

    Returns
    -------
    tau, tau_err : float
        NaN, NaN when the counts cannot determine tau (too small a system or too few clusters).
    """
    obs = fisher_observables(counts, n_sites, **kwargs)
    return obs["tau_fisher"], obs["tau_fisher_err"]


def fisher_observables(counts, n_sites: int, **kwargs) -> dict:
    """``tau_fisher``, ``tau_fisher_err`` and ``tau_fisher_reason`` of one state point, for datasets.

    Call it per (eta, v0, N) point on the ``cluster_size_distribution`` pooled over frames
    (and summed over replicates, which are independent); ``kwargs`` go to
    :func:`fit_fisher_exponent`.  The values are NaN and the reason says why when the
    counts cannot determine tau; a non-empty reason with finite values flags a fit that
    is not in the scaling regime or fits poorly.
    """
    fit = fit_fisher_exponent(counts, n_sites, **kwargs)
    ok = np.isfinite(fit.tau_err)
    return {"tau_fisher": fit.tau if ok else float("nan"), "tau_fisher_err": fit.tau_err,
            "tau_fisher_reason": fit.reason}
