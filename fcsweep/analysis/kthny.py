"""KTHNY (2-D melting) classification from C_G1(r) and G6(r); the G_r(dx, 0) envelope for figures.

KTHNY theory tells the three phases of a 2-D system by how its correlations decay:

- **solid**: translational order quasi-long-ranged, the first-shell correlation
  ``C_G1(r) = Re <psi_G,i psi_G,j*>`` (``psi_G,i = exp(i G1 . r_i)``) decaying as
  ``r^(-eta_G1)`` with ``eta_G1 <= 1/3`` (1/3 at melting); bond order long-ranged;
- **hexatic**: translational order decaying faster, bond order quasi-long-ranged,
  ``G6 ~ r^(-eta_6)`` with ``eta_6 <= 1/4``;
- **liquid**: both short-ranged.

The bound 1/3 is on the first Bragg shell's exponent.  The peak envelope of
``G_r(dx, 0) - 1`` sums all shells (``eta_G = eta_G1 G^2 / G1^2``: the second shell 3x,
the third 4x), so its log-slope over a box overstates ``eta_G1``; ``eta_T`` is still fitted
(the paper's figure) but decides nothing.

:func:`kthny_fits` fits ``C_G1`` (on windows of half a spacing, :func:`rebin`; given the
box, ``r^(-eta)`` in its periodic form ``exp(-eta f(r))``, :func:`periodic_log`) and the
``G_r`` envelope from a quarter of half the box on, ``G6`` from the shell beyond its first
inter-shell minimum (:func:`g6_fit_start`), to ``A r^(-eta)`` and ``A exp(-r / xi)``
(weighted least squares of the logarithm over the distances where the curve stands clear
of its noise, up to half the box), with 1-sigma errors from the fit (scaled up by
``sqrt(chi2 / dof)`` when the points scatter more than their errors) and the spread over
the fit ranges ``RANGES`` x L/2 added in quadrature (:func:`ranged_fit`).
:func:`classify_kthny` decides with the algebraic exponents against the KTHNY bounds: an
exponential decay over the fitted range reads as a large effective exponent, so

    P(solid)   = P(eta_G1 < 1/3) P(eta_6 < 1/4),
    P(hexatic) = P(eta_G1 > 1/3) P(eta_6 < 1/4),
    P(liquid)  = P(eta_6 > 1/4),

each Gaussian in the fitted exponent with its total error. A curve that falls into its
noise (a point less than 2 errors above zero) within half the fitted range is not fitted;
it is tested against the slowest decay its bound allows, ``y_ref (r / r_ref)^(-1/3)``
(``-1/4`` for G6) drawn from its point 5 pooled errors above zero that puts it highest, and
P(eta <= bound) = Phi(d / s) with ``d`` the mean excess of the points after the fall over
that curve and ``s`` its error (:func:`_p_above_bound`). Without frame errors on C_G1 (one
frame) or without C_G1 the translational order is not decided, so such a curve can only
say liquid (from G6). The label is the most probable one when it reaches the confidence,
else undetermined.

**What N a decision needs.** The decays are fitted from a quarter of the range on (their
asymptotic part), so a decision needs at least ``MIN_CELLS`` = 4096 cells (half the box
then spans 32 neighbour spacings). Measured on N = 1024 crystals of the model (eta = 0.1,
v0 = 0.01-0.03, 1000 time units): the effective exponent of the envelope still falls with
the start of the fit (1.03, 0.90, 0.65 from 1, 3 and 5 spacings at v0 = 0.03), so at 16
spacings the asymptotic exponent is not reached; a 32 x 32 harmonic crystal of
``eta_G1 = 0.5`` reads 0.50 +- 0.13: undecided (P(hexatic) = 0.91).  The synthetic
cases of tests/test_kthny.py (jittered crystal, random discs, aligned mosaic, harmonic
crystals) are decided right at N ~ 4096 from 2-10 frames.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks
from scipy.special import j0, ndtr

from fcsweep.analysis.phase import (KTHNY_HEXATIC, KTHNY_LIQUID, KTHNY_SOLID, KTHNY_UNDETERMINED, KTHNY_UNKNOWN,
                                    MIN_CONFIDENCE, Label, kthny_name)

#: KTHNY bound on the translational exponent (at melting).
ETA_T_MAX = 1.0 / 3.0
#: KTHNY bound on the bond-orientational exponent (at the hexatic-liquid transition).
ETA_6_MAX = 0.25
#: Fewest cells for a decision (see the module doc).
MIN_CELLS = 4096
#: The G_r peak envelope is fitted from this fraction of the range on (its asymptotic part).
ASYMPTOTIC = 0.25
#: Fit ranges, as fractions of half the box: the spread of the exponents over them is
#: part of their error (:func:`ranged_fit`).
RANGES = (0.6, 0.75, 1.0)
#: Fewest points a decay fit needs.
MIN_POINTS = 3
#: A curve that fell into its noise is tested against its bound drawn from a point
#: this many errors above zero.
REF_SIGMAS = 5.0


def peak_envelope(dx, Gr, *, spacing: float | None = None):
    """Local maxima of ``G_r(dx, 0)`` beyond the core, one per lattice period.

    Parameters
    ----------
    dx, Gr : ndarray
        Bin centres and the cut ``G_r(dx, 0)`` (NaN bins are ignored).
    spacing : float, optional
        Neighbour spacing; default: the first maximum that reaches half the largest
        excess ``max(G_r) - 1``.

    Returns
    -------
    positions, heights : ndarray
        Peak positions and ``G_r - 1`` there, from the first neighbour shell on.
    """
    x = np.asarray(dx, dtype=float)
    y = np.nan_to_num(np.asarray(Gr, dtype=float), nan=0.0)
    if x.size < 3:
        return np.zeros(0), np.zeros(0)
    h = float(x[1] - x[0])
    if spacing:
        a = float(spacing)
    else:  # the first maximum that reaches half the largest excess
        top, _ = find_peaks(y, height=1.0 + 0.5 * (np.max(y) - 1.0))
        a = float(x[top[0]]) if top.size else float(x[int(np.argmax(y))])
    idx, _ = find_peaks(y, distance=max(1, int(0.7 * a / h)))
    idx = idx[x[idx] >= 0.8 * a]
    return x[idx], y[idx] - 1.0


def _log_fit(X, y, e):
    """Weighted least squares of ``log y = c0 + c1 X``: coefficients, their errors, chi2/dof."""
    w = 1.0 / np.maximum(e / y, 1e-6)
    A = np.stack([np.ones_like(X), X], axis=1) * w[:, None]
    b = np.log(y) * w
    coef, *_ = np.linalg.lstsq(A, b, rcond=None)
    dof = max(X.size - 2, 1)
    chi2 = float(np.sum((A @ coef - b) ** 2)) / dof
    cov = np.linalg.inv(A.T @ A) * max(chi2, 1.0)
    return coef, np.sqrt(np.diag(cov)), chi2


def fit_decays(r, y, y_err=None, *, r_min: float = 0.0, r_max: float | None = None, log_r=None) -> dict:
    """Fit ``y = A r^(-eta)`` and ``y = A exp(-r / xi)`` over the points clear of the noise.

    Points with ``r_min <= r <= r_max`` are used from the first on, up to the first that is
    not positive or not 2 errors above zero (the curve has sunk into its noise).  Without
    ``y_err`` the errors are taken from the scatter about each fit (equal weights).
    ``log_r`` (same shape as ``r``) replaces ``ln r`` in the algebraic fit, e.g. by its
    periodic-box form :func:`periodic_log`.

    Returns
    -------
    dict
        ``eta``, ``eta_err``, ``xi``, ``xi_err``, ``chi2_power``, ``chi2_exp`` (per degree of
        freedom, weighted), ``n`` (points used), ``r_end`` (last distance used) and
        ``sunk`` (True when the curve fell into its noise before ``r_max / 2``).
    """
    r = np.asarray(r, dtype=float)
    y = np.asarray(y, dtype=float)
    e = np.full(y.shape, np.nan) if y_err is None else np.asarray(y_err, dtype=float)
    r_max = float(np.nanmax(r)) if r_max is None else float(r_max)
    lr = np.log(np.where(r > 0, r, np.nan)) if log_r is None else np.asarray(log_r, dtype=float)
    keep = (r >= r_min) & (r <= r_max) & np.isfinite(y)
    r, y, e, lr = r[keep], y[keep], e[keep], lr[keep]
    clear = _clear(y, e)
    stop = int(np.argmin(clear)) if not clear.all() else y.size
    r, y, e, lr = r[:stop], y[:stop], e[:stop], lr[:stop]
    nan = float("nan")
    out = {"eta": nan, "eta_err": nan, "xi": nan, "xi_err": nan, "chi2_power": nan, "chi2_exp": nan,
           "n": int(r.size), "r_end": float(r[-1]) if r.size else nan,
           "sunk": bool(stop < keep.sum() and (r[-1] if r.size else 0.0) < 0.5 * r_max)}
    if r.size < MIN_POINTS or np.any(r <= 0):
        return out
    if not np.all(np.isfinite(e) & (e > 0)):
        e = np.full(y.shape, 1.0) * y  # equal weights in log space; errors from the residuals
        e_from_fit = True
    else:
        e_from_fit = False
    (c, ce, chi_p) = _log_fit(lr, y, e)
    (d, de, chi_e) = _log_fit(r, y, e)
    if e_from_fit:  # unit weights: the scale is the residual scatter itself
        ce = ce / np.sqrt(max(chi_p, 1.0)) * np.sqrt(chi_p)
        de = de / np.sqrt(max(chi_e, 1.0)) * np.sqrt(chi_e)
    out.update(eta=float(-c[1]), eta_err=float(ce[1]), chi2_power=chi_p, chi2_exp=chi_e)
    if d[1] < 0:
        xi = -1.0 / d[1]
        out.update(xi=float(xi), xi_err=float(de[1] * xi * xi))
    else:
        out.update(xi=float("inf"), xi_err=float("nan"))
    return out


def g6_fit_start(r, G6, spacing: float) -> float:
    """Where the G6 fit starts: the next shell beyond the first inter-shell minimum.

    The minimum is the lowest finite ``G6`` within ``[a, 2a]`` (between the first and the
    second or third neighbour shell), the start the highest point within ``0.75 a`` beyond
    it.  A fit from the first shell on would run into that dip, which in a soft crystal
    falls within 2 errors of zero and reads as a curve sunk into its noise.
    """
    r = np.asarray(r, dtype=float)
    y = np.asarray(G6, dtype=float)
    a = float(spacing)
    ok = np.isfinite(y)
    win = np.flatnonzero(ok & (r >= a) & (r <= 2.0 * a))
    if win.size == 0:
        return 0.8 * a
    r_dip = r[win[int(np.argmin(y[win]))]]
    after = np.flatnonzero(ok & (r > r_dip) & (r <= r_dip + 0.75 * a))
    return float(r[after[int(np.argmax(y[after]))]]) if after.size else float(r_dip)


def periodic_log(r, box, spacing: float) -> np.ndarray:
    """The periodic box's form of ``ln r`` for an elastic (harmonic) crystal.

    ``f(r) = (2 pi / A) sum_k (1 - J0(k r)) / k^2`` over the box's modes
    ``k = 2 pi (m / Lx, n / Ly)``, ``0 < |k| <= k_D`` (``k_D^2 = 8 pi / (sqrt(3) a^2)``:
    one mode per cell, the Debye disc), ``A`` the box area.  For a harmonic crystal with a
    ``c / k^2`` displacement spectrum ``-ln C_G1(r) = eta_G1 f(r) + const`` with the exact
    ``eta_G1 = G1^2 c A / (4 pi)`` (tests/synthetic.py ``harmonic_crystal``; ``J0`` is
    the mean of ``cos k.r`` over the pair directions).  In an infinite box ``f`` tends to
    ``ln(k_D r) - 0.116``, so ``C_G1 ~ r^(-eta_G1)``; in a periodic box it flattens
    towards ``L/2`` and a fit against ``ln r`` reads the exponent low (exact curve of a
    64 x 64 crystal of ``eta_G1 = 0.5``: 0.38 to L/2).
    """
    Lx, Ly = float(box[0]), float(box[1])
    kd = np.sqrt(8.0 * np.pi / np.sqrt(3.0)) / float(spacing)
    mx, my = int(np.ceil(kd * Lx / (2 * np.pi))), int(np.ceil(kd * Ly / (2 * np.pi)))
    kx, ky = np.meshgrid(2 * np.pi / Lx * np.arange(-mx, mx + 1), 2 * np.pi / Ly * np.arange(-my, my + 1))
    k = np.hypot(kx, ky).ravel()
    k = k[(k > 0) & (k <= kd)]
    r = np.asarray(r, dtype=float)
    out = np.empty(r.shape)
    for i, x in enumerate(r.ravel()):
        out.flat[i] = np.sum((1.0 - j0(k * x)) / (k * k))
    return out * 2.0 * np.pi / (Lx * Ly)


def ranged_fit(x, y, e, *, r_min: float, r_max: float, log_r=None) -> dict:
    """:func:`fit_decays` to ``r_max``, with the spread over the fit ranges in its error.

    The exponent is fitted up to each of ``RANGES`` x ``r_max``; the quoted one is the
    fit to ``r_max``, ``eta_spread`` the largest shift of the others from it beyond what
    their noise explains, and ``eta_err`` the statistical error and that spread added in
    quadrature (``eta_stat`` keeps the statistical one, ``eta_shift`` the largest shift).
    The effective exponent of a curve not yet in its asymptotic regime depends on the
    range (measured: eta_T = 0.08, 0.45 and 0.58 to 1, 0.75 and 0.6 of L/2 at N = 4900,
    v0 = 0.03), which the statistical error omits.  A fit to a sub-range shares its points
    with the full fit, so their difference has the variance ``err_sub^2 - err_full^2``
    from noise alone; that much of the shift is taken out in quadrature (else the noise
    counts twice: a 64 x 64 harmonic crystal of eta_G1 = 0.5, 10 frames, read
    0.57 +- 0.16 with the raw shift of 0.13 and 0.57 +- 0.10 without it).
    """
    fits = [fit_decays(x, y, e, r_min=r_min, r_max=f * r_max, log_r=log_r) for f in RANGES]
    out = dict(fits[-1])
    shift = spread = 0.0
    if np.isfinite(out["eta"]):
        for f in fits[:-1]:
            if np.isfinite(f["eta"]):
                d2 = (f["eta"] - out["eta"]) ** 2
                noise2 = max(f["eta_err"] ** 2 - out["eta_err"] ** 2, 0.0) if np.isfinite(f["eta_err"]) else 0.0
                shift = max(shift, float(np.sqrt(d2)))
                spread = max(spread, float(np.sqrt(max(d2 - noise2, 0.0))))
    out.update(eta_stat=out["eta_err"], eta_shift=shift, eta_spread=spread,
               eta_err=float(np.hypot(out["eta_err"], spread)))
    return out


def kthny_fits(r, G6, dx, Gr, *, G6_err=None, Gr_err=None, spacing: float | None = None,
               C_G1=None, C_G1_err=None, box=None) -> dict:
    """Decay fits of the first-shell correlation, the ``G_r(dx, 0) - 1`` envelope and ``G6(r)``.

    Parameters
    ----------
    r, G6 : ndarray
        ``G6`` binned by pair distance (:func:`fcsweep.analysis.order.g6`), frame mean.
    dx, Gr : ndarray
        ``G_r(dx, 0)`` (:func:`fcsweep.analysis.order.gr_cut`), frame mean.
    G6_err, Gr_err, C_G1_err : ndarray, optional
        Standard errors of the frame means (NaN or None: from the fit residuals).
    spacing : float, optional
        Neighbour spacing (default: see :func:`peak_envelope`).
    C_G1 : ndarray, optional
        First-shell correlation on the bins ``r`` of G6
        (:func:`fcsweep.analysis.order.shell_correlation`), frame mean; without it the
        translational order cannot be decided.
    box : (Lx, Ly), optional
        The periodic box: ``C_G1`` is then fitted to ``A exp(-eta_G1 f(r))`` with ``f`` the
        box's form of ``ln r`` (:func:`periodic_log`), else to ``A r^(-eta_G1)``.

    Returns
    -------
    dict
        ``eta_G1``, ``eta_G1_err`` (the decision), ``eta_T``, ``eta_T_err``, ``xi_T``,
        ``xi_T_err`` (the envelope, for the figure), ``eta_6``, ``eta_6_err``, ``xi_6``,
        ``xi_6_err``; every ``eta_*_err`` includes the fit-range spread
        (:func:`ranged_fit`; ``*_spread`` alone).  Per curve ``G1``, ``T``, ``six``:
        ``*_points``, ``*_sunk``, ``*_r_end`` (points fitted, fell into the noise within
        half the range, last distance fitted) and ``*_p_bound`` (for a curve that fell
        into its noise, the probability that it still decays no faster than its KTHNY
        bound; NaN otherwise); ``T_errors``, ``G1_errors`` (errors known over the fitted
        range), ``six_r_min`` (start of the G6 fit) and ``r_max`` (the fitted range).
    """
    dx = np.asarray(dx, dtype=float)
    Gr = np.asarray(Gr, dtype=float)
    r = np.asarray(r, dtype=float)
    pos, hgt = peak_envelope(dx, Gr, spacing=spacing)
    if Gr_err is not None and pos.size:
        he = np.interp(pos, dx, np.nan_to_num(np.asarray(Gr_err, dtype=float), nan=np.nan))
    else:
        he = None
    nan = float("nan")
    r_max = float(np.nanmax(dx)) if dx.size else nan
    a = float(spacing) if spacing else (pos[0] if pos.size else 1.0)
    r_T = ASYMPTOTIC * r_max
    T = ranged_fit(pos, hgt, he, r_min=r_T, r_max=r_max)
    r6 = g6_fit_start(r, G6, a)
    six = ranged_fit(r, G6, G6_err, r_min=r6, r_max=r_max)
    in_range = pos >= r_T
    out = {"eta_T": T["eta"], "eta_T_err": T["eta_err"], "eta_T_spread": T["eta_spread"],
           "xi_T": T["xi"], "xi_T_err": T["xi_err"],
           "eta_6": six["eta"], "eta_6_err": six["eta_err"], "eta_6_spread": six["eta_spread"],
           "xi_6": six["xi"], "xi_6_err": six["xi_err"],
           "T_points": T["n"], "T_sunk": T["sunk"], "T_r_end": T["r_end"],
           "T_p_bound": _p_above_bound(pos, hgt, he, ETA_T_MAX, r_T, r_max) if T["sunk"] else nan,
           "T_errors": bool(he is not None and in_range.any() and np.all(np.isfinite(he[in_range]))),
           "six_points": six["n"], "six_sunk": six["sunk"], "six_r_end": six["r_end"], "six_r_min": r6,
           "six_p_bound": _p_above_bound(r, np.asarray(G6, dtype=float),
                                         None if G6_err is None else np.asarray(G6_err, dtype=float),
                                         ETA_6_MAX, r6, r_max) if six["sunk"] else nan,
           "r_max": r_max}
    out.update(_g1_fits(r, C_G1, C_G1_err, r_T, r_max, a, box))
    return out


def rebin(r, y, e, width: float):
    """Means of a binned curve over windows ``[k width, (k + 1) width)`` (NaN bins left out).

    The error of a window is the RMS of its bins' errors: the bins of one frame are
    correlated, so the window's error is not taken smaller than its bins'.

    Returns
    -------
    r, y, e : ndarray
        Mean distance, mean value and error of the windows that hold a finite bin
        (``e`` NaN where ``e`` is None).
    """
    r = np.asarray(r, dtype=float)
    y = np.asarray(y, dtype=float)
    e = np.full(y.shape, np.nan) if e is None else np.asarray(e, dtype=float)
    ok = np.isfinite(y) & np.isfinite(r)
    k = np.floor(r[ok] / width).astype(int)
    n = np.bincount(k)
    has = n > 0
    mean = lambda v: np.bincount(k, weights=v)[has] / n[has]  # noqa: E731
    return mean(r[ok]), mean(y[ok]), np.sqrt(mean(e[ok] ** 2))


def _g1_fits(r, C, C_err, r_min: float, r_max: float, spacing: float, box=None) -> dict:
    """The ``G1`` part of :func:`kthny_fits` (all NaN without ``C``).

    ``C_G1`` is fitted on windows of half a spacing (:func:`rebin`): binned by ``|r_ij|``,
    it varies from bin to bin by which lattice vectors the displacements carry into a
    bin, the same in every frame (measured on a jittered crystal: a scatter of 0.05 about
    0.59 against frame errors of 1e-3, chi2/dof ~ 1e5), so weighted by the frame errors
    the fit follows a few bins (eta_G1 0.05-0.17 for a flat curve).  With ``box`` the
    algebraic decay is fitted in its periodic-box form (:func:`periodic_log`).
    """
    nan = float("nan")
    if C is None:
        return {"eta_G1": nan, "eta_G1_err": nan, "eta_G1_spread": nan, "G1_points": 0, "G1_sunk": False,
                "G1_r_end": nan, "G1_p_bound": nan, "G1_errors": False, "G1_computed": False}
    r, C, e = rebin(r, C, C_err, 0.5 * spacing)
    e = None if C_err is None else e
    lr = None if box is None else periodic_log(r, box, spacing)
    f = ranged_fit(r, C, e, r_min=r_min, r_max=r_max, log_r=lr)
    sel = (r >= r_min) & (r <= r_max) & np.isfinite(C)
    return {"eta_G1": f["eta"], "eta_G1_err": f["eta_err"], "eta_G1_spread": f["eta_spread"],
            "G1_points": f["n"], "G1_sunk": f["sunk"], "G1_r_end": f["r_end"],
            "G1_p_bound": _p_above_bound(r, C, e, ETA_T_MAX, r_min, r_max) if f["sunk"] else nan,
            "G1_errors": bool(e is not None and sel.any() and np.all(np.isfinite(e[sel]))),
            "G1_computed": True}


def _clear(y, e):
    """Points standing clear of their noise: positive and, where an error is known, 2 errors above 0."""
    return (y > 0) & ~(np.isfinite(e) & (y < 2.0 * e))


def _p_above_bound(x, y, e, bound: float, r_min: float, r_max: float) -> float:
    """Probability that a curve which fell into its noise still decays no faster than ``r^(-bound)``.

    The slowest decay the bound allows is drawn from a point ``REF_SIGMAS`` errors above
    zero before the curve fell into its noise within ``[r_min, r_max]`` (``x_ref``,
    ``y_ref``): ``b(r) = y_ref (r / x_ref)^(-bound)``, from the point of the fitted range
    whose ``b`` lies highest (a shell peak, not an inter-shell dip), or without one there
    from the last such point before ``r_min``.  A bound drawn from a dip lies below the
    next shells: the G6 of a polycrystal (bond order lost over ~10 spacings, 0.7 to 0.02
    over the box) then read as decaying no faster than ``r^(-1/4)``.  Over
    the points from the fall to ``r_max`` the weighted mean excess ``d`` of the data over
    ``b`` has the error ``s`` (the points' errors pooled, or without them the scatter of
    those points, and the error of ``y_ref`` carried along ``b``); the probability is
    ``Phi(d / s)``. NaN when there is no such reference point or fewer than 2 points after
    the fall.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    e = np.full(y.shape, np.nan) if e is None else np.asarray(e, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y) & (x <= r_max) & (x > 0)
    x, y, e = x[ok], y[ok], e[ok]
    clear = _clear(y, e)
    fit = x >= r_min
    if not fit.any():
        return float("nan")
    first = int(np.argmax(fit))
    stop = first + (int(np.argmin(clear[first:])) if not clear[first:].all() else int(fit.sum()))
    tail = slice(stop, x.size)
    if x.size - stop < 2:
        return float("nan")
    et = e[tail]
    # the noise pooled over the tail: per-point errors from a few frames scatter widely
    if np.all(np.isfinite(et) & (et > 0)):
        noise = float(np.sqrt(np.mean(et ** 2)))
    else:  # no errors: the scatter of the noise itself
        noise = float(np.std(y[tail], ddof=1))
    # the reference must stand well clear: the tail's local maxima of noise sit about one
    # error above zero, and a bound drawn from a marginal point would lie below them
    sig = np.maximum(np.where(np.isfinite(e[:stop]), e[:stop], 0.0), noise)
    ref = np.flatnonzero(y[:stop] > REF_SIGMAS * sig)
    if ref.size == 0 or not noise > 0:
        return float("nan")
    in_fit = ref[ref >= first]
    k = int(in_fit[np.argmax(y[in_fit] * x[in_fit] ** bound)]) if in_fit.size else int(ref[-1])
    shape = (x[tail] / x[k]) ** (-bound)
    mean = float(np.mean(y[tail] - y[k] * shape))
    s = float(np.sqrt(noise ** 2 / shape.size + (sig[k] * np.mean(shape)) ** 2))
    return float(ndtr(mean / s)) if s > 0 else float(mean >= 0)


def _p_below(x: float, err: float, bound: float) -> float:
    if not np.isfinite(x):
        return float("nan")
    if not (np.isfinite(err) and err > 0):
        return 1.0 if x < bound else 0.0
    return float(ndtr((bound - x) / err))


def _describe(fits: dict, which: str, bound: str) -> str:
    curve, key = {"G1": ("C_G1", "G1"), "6": ("G6", "six")}[which]
    if which == "G1" and not fits.get("G1_errors", False):
        return "C_G1 without errors"
    if fits.get(f"{key}_sunk"):
        p, r_end = fits.get(f"{key}_p_bound", 0.0), fits.get(f"{key}_r_end", float("nan"))
        where = f"from r = {r_end:.3g}" if np.isfinite(r_end) else "over the whole fitted range"
        test = f"; P(eta_{which} <= {bound}) = {p:.2g}" if np.isfinite(p) else ""
        return f"{curve} short-ranged (in its noise {where}{test})"
    spread = fits.get(f"eta_{which}_spread", float("nan"))
    of = f" (fit ranges {spread:.2g})" if np.isfinite(spread) else ""
    return f"eta_{which} = {fits[f'eta_{which}']:.3g} +- {fits[f'eta_{which}_err']:.2g}{of} (bound {bound})"


def classify_kthny(fits: dict, *, min_confidence: float = MIN_CONFIDENCE, n_cells: int | None = None) -> Label:
    """KTHNY label from :func:`kthny_fits` (see module doc).

    Returns
    -------
    Label
        ``code`` one of ``phase.KTHNY_FLAGS``, ``confidence`` the probability of the most
        probable label, ``reason`` the exponents that decided or why none did.
    """
    if n_cells is not None and n_cells < MIN_CELLS:
        return Label(KTHNY_UNDETERMINED, float("nan"),
                     f"N = {n_cells} < {MIN_CELLS}: C_G1 and G6 need distances up to half a box of at least "
                     f"{MIN_CELLS} cells", "too_few_cells")
    # a curve sunk into its noise is tested against the slowest decay its bound allows
    # (r^(-1/4) or r^(-1/3) drawn from a point 5 errors above zero), not taken as short-ranged outright
    if fits.get("six_sunk"):
        p6 = fits.get("six_p_bound", 0.0)
        if not np.isfinite(p6):
            return Label(KTHNY_UNDETERMINED, float("nan"), "G6 fell into its noise with too few points to test",
                         "g6_noise_untestable")
    else:
        p6 = _p_below(fits["eta_6"], fits["eta_6_err"], ETA_6_MAX)
        if not np.isfinite(p6):
            return Label(KTHNY_UNKNOWN, float("nan"), "G6 could not be fitted", "g6_not_fitted")
    if not fits.get("G1_computed", False):
        pT, why_T = float("nan"), ("C_G1 not computed: the translational order cannot be decided", "cg1_not_computed")
    elif not fits.get("G1_errors", False):
        # one frame: the fit's errors come from its residuals alone and a curve in its noise
        # cannot be told from a slow decay
        pT, why_T = float("nan"), ("C_G1 has no error estimate (one frame): its decay cannot be told from noise",
                                   "no_error")
    elif fits.get("G1_sunk"):
        pT, why_T = fits.get("G1_p_bound", 0.0), ("C_G1 fell into its noise with too few points to test",
                                                  "cg1_noise_untestable")
    else:
        pT, why_T = _p_below(fits["eta_G1"], fits["eta_G1_err"], ETA_T_MAX), ("C_G1 could not be fitted",
                                                                              "cg1_not_fitted")
    if not np.isfinite(pT):
        if p6 > 1 - min_confidence:  # not liquid by G6 alone: the translational order must decide
            return Label(KTHNY_UNDETERMINED, float("nan"), *why_T)
        pT = 0.0
    p = {KTHNY_SOLID: pT * p6, KTHNY_HEXATIC: (1.0 - pT) * p6, KTHNY_LIQUID: 1.0 - p6}
    best = max(p, key=lambda k: p[k])
    conf = float(p[best])
    what = ", ".join(_describe(fits, k, b) for k, b in (("G1", "1/3"), ("6", "1/4")))
    if conf < min_confidence:
        return Label(KTHNY_UNDETERMINED, conf, f"{what}: P({kthny_name(best)}) = {conf:.2f} < {min_confidence:.2f}",
                     "near_kthny_bounds")
    return Label(int(best), conf, f"P({kthny_name(best)}) = {conf:.3f}: {what}", "decided_exponents")
