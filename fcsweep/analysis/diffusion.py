"""Long-time self-diffusion from the MSD: D_s, D0 and D_eff (MODEL.md, Observables).

Fit window (documented choice): all lags ``t`` with
``window[0] * t_span <= t <= window[1] * t_span``, default ``window = (0.1, 0.5)``, where
``t_span`` is the time between the first and last analysed frame.  The MSD is fitted
by least squares to ``4 D_s t + c``; the intercept ``c`` absorbs the persistent
(ballistic) start ``-4 D0 / Dr`` of active Brownian motion, so the window must lie
well beyond the persistence time ``1/Dr`` for ``D_s`` to be the long-time value.
Lags beyond half the span are averaged over few time origins and are excluded.

Error: the same fit on B disjoint subsets of the cells gives slopes ``D_b``; the error
is ``std(D_b, ddof=1) / sqrt(B)``.  For independent cells this is the statistical
error of the estimate; for a correlated fluid it is a lower bound.  Without blocks
the standard error of the least-squares slope is returned (it ignores the strong
correlation between MSD values at neighbouring lags and so underestimates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Default fit window, as fractions of the analysed time span.
FIT_WINDOW = (0.1, 0.5)
#: D_eff below which a run is labelled solid.
D_EFF_SOLID = 1e-3


@dataclass(frozen=True)
class DiffusionFit:
    """Result of :func:`fit_diffusion` (D in simulation units, length^2 / time)."""

    D: float
    D_err: float
    intercept: float
    t_min: float
    t_max: float
    n_points: int


def free_diffusion(v0: float, Dr: float) -> float:
    """D0 = v0^2 / (2 Dr), the long-time diffusion of a free active Brownian particle."""
    if Dr <= 0:
        return float("inf") if v0 != 0 else float("nan")
    return float(v0) ** 2 / (2.0 * float(Dr))


def _slope(t: np.ndarray, y: np.ndarray):
    A = np.stack([t, np.ones_like(t)], axis=1)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return coef


def fit_diffusion(lag_time, msd, *, window=FIT_WINDOW, msd_blocks=None) -> DiffusionFit:
    """Fit ``msd = 4 D t + c`` over a window of long lags.

    Parameters
    ----------
    lag_time : ndarray, shape (T,)
        Lag times, increasing, ``lag_time[0] = 0``.
    msd : ndarray, shape (T,)
    window : (float, float)
        Fit window as fractions of ``lag_time[-1]``.
    msd_blocks : ndarray, shape (B, T), optional
        MSDs of disjoint cell subsets; their slopes give the error.

    Returns
    -------
    DiffusionFit
        NaN fields if fewer than 3 lags fall in the window.
    """
    t = np.asarray(lag_time, dtype=float)
    y = np.asarray(msd, dtype=float)
    span = t[-1] if t.size else 0.0
    lo, hi = float(window[0]) * span, float(window[1]) * span
    sel = (t >= lo) & (t <= hi) & np.isfinite(y)
    n = int(sel.sum())
    nan = float("nan")
    if n < 3:
        return DiffusionFit(nan, nan, nan, lo, hi, n)
    slope, icpt = _slope(t[sel], y[sel])
    D = slope / 4.0
    if msd_blocks is not None and np.shape(msd_blocks)[0] >= 2:
        Db = np.array([_slope(t[sel], yb[sel])[0] / 4.0 for yb in np.asarray(msd_blocks)])
        err = float(np.std(Db, ddof=1) / np.sqrt(len(Db)))
    else:
        res = y[sel] - (slope * t[sel] + icpt)
        s2 = res @ res / max(n - 2, 1)
        tc = t[sel] - t[sel].mean()
        err = float(np.sqrt(s2 / (tc @ tc)) / 4.0)
    return DiffusionFit(float(D), err, float(icpt), lo, hi, n)


def effective_diffusion(D_s: float, D_s_err: float, v0: float, Dr: float):
    """D_eff = D_s / D0 and its error; NaN when D0 is zero or undefined.

    Returns
    -------
    D_eff, D_eff_err : float
    """
    D0 = free_diffusion(v0, Dr)
    if not np.isfinite(D0) or D0 <= 0:
        return float("nan"), float("nan")
    return float(D_s / D0), float(D_s_err / D0)
