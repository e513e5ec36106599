"""Finite-size scaling of defect percolation.

:func:`fss_collapse` fits the threshold and exponents of defect percolation to the
largest-cluster fraction of two or more system sizes (``L = sqrt(N)``),

    P_max L^(beta/nu) = f((rho_d - rho_c) L^(1/nu)),

by minimising the Houdayer--Hartmann collapse quality (Phys. Rev. B 70, 014418 (2004)):
each point is compared with the weighted straight line through the points of every
other size that bracket its scaled x, and S is the mean of ``(y - Y)^2 / (dy^2 + dY^2)``
over the points that have such neighbours (S ~ 1 when the sizes collapse within their
errors).  The fit searches ``(rho_c, 1/nu, beta/nu)``: a coarse grid, then Nelder--Mead
from its four best points.  Two choices make it work on exact percolation:

* a scaling window ``|x| <= x_max = 1``, chosen self-consistently (refit on the points
  inside the window of the previous fit until the set is stable, the set fixed within
  each minimisation, because with a moving window S improves by dropping points), and
  at least half of the points must overlap another size;
* a relative tolerance of 2 % of P_max for corrections to scaling, added in
  quadrature to the errors of P_max.  Without it the precise points below the threshold,
  where the small sizes still deviate from the scaling form, dominate the fit, and on
  exact site percolation of the triangular lattice (L = 24, 48, 96; p = 0.40-0.60 in steps
  of 0.005; 300/150/60 realisations) rho_c read 0.493-0.499 against 1/2, 0.6-3.1 of its
  statistical error low (mean -2.2).  With it the same 10 data sets give rho_c =
  0.495-0.500, all within 1.5 errors (mean pull -0.8), nu = 1.24-1.36 (4/3) and
  beta = 0.150-0.184 (5/36 = 0.139): the corrections at these sizes still push beta/nu
  up by ~0.03, so quote the exponents with their L range.

Errors (1 sigma) are the standard deviation of bootstrap refits (100 by default; each
repeats the window iteration from the fit): parametric, Gaussian noise of the errors of
P_max (tolerance included) added to P_max, when ``pmax_err`` is given; otherwise the
points are resampled with replacement and weigh the same.  The errors of rho_d are not
used.  ``fixed`` holds any of rho_c, nu, beta at a given value (e.g. the percolation
exponents nu = 4/3 and beta = 5/36 to draw the paper's collapse); with them fixed the
same exact data give rho_c = 0.4999 +- 0.0009.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Exponents of 2-D percolation: correlation length nu and order parameter beta.
NU_2D = 4.0 / 3.0
BETA_2D = 5.0 / 36.0
#: Fit parameters of :func:`fss_collapse`, in order.
FSS_PARAMETERS = ("rho_c", "nu", "beta")
#: Range of 1/nu and beta/nu searched by the collapse fit.
INV_NU_RANGE = (0.05, 5.0)
BETA_NU_RANGE = (-2.0, 2.0)
#: Default half width of the scaling window of :func:`fss_collapse`, in |x| = |rho - rho_c| L^(1/nu).
FSS_X_MAX = 1.0
#: Default relative tolerance for corrections to scaling, added in quadrature to the errors of P_max.
FSS_TOLERANCE = 0.02
#: Refits at most while the window of :func:`fss_collapse` settles.
MAX_WINDOW_ITERATIONS = 10
#: Default number of bootstrap refits behind the errors of :func:`fss_collapse`.
FSS_BOOTSTRAP = 100
#: The reason code (:mod:`fcsweep.analysis.reasons`) that marks a collapse not applicable
#: to confined runs; the collapse's reason text starts with it (:func:`not_periodic_reason`).
NOT_PERIODIC = "not_periodic"


def not_periodic_reason() -> str:
    """Why no collapse is fitted to confined runs (a well or a channel), starting with
    the reason code :data:`NOT_PERIODIC`.

    The collapse scales with L = sqrt(N), the linear size of a periodic box of N cells
    with no boundary; in a well or channel the counted cells lie away from the walls, a
    boundary layer whose width does not scale with L cuts them off, and a channel's
    largest cluster is bounded by its width, not by L."""
    return (f"{NOT_PERIODIC}: finite-size scaling with L = sqrt(N) does not apply to confined runs (a well or "
            "channel: walls, not periodic images, bound the clusters)")


@dataclass(frozen=True)
class CollapseFit:
    """Result of :func:`fss_collapse`; its fields are also keys (``fit["rho_c"]``).

    Attributes
    ----------
    rho_c, rho_c_err, nu, nu_err, beta, beta_err : float
        Threshold and exponents with their 1-sigma bootstrap errors (error 0 for a
        parameter held fixed; all NaN when no collapse could be fitted, see ``reason``).
    quality : float
        Collapse quality S at the minimum: the mean squared scatter of the points about
        the local master curve in units of its error, ~1 for a collapse within the
        errors when ``pmax_err`` is given (with unit errors otherwise).
    n_points : int
        Points that overlap another size at the minimum (the terms of S).
    n_sizes : int
        Distinct system sizes.
    L_min, L_max : float
        Smallest and largest L = sqrt(N).
    fixed : tuple of str
        Parameters held fixed.
    n_bootstrap : int
        Bootstrap refits that converged (the errors are their standard deviation).
    reason : str
        Empty when the fit is usable, otherwise why it is not (or not trusted).
    """

    rho_c: float
    rho_c_err: float
    nu: float
    nu_err: float
    beta: float
    beta_err: float
    quality: float
    n_points: int
    n_sizes: int
    L_min: float
    L_max: float
    fixed: tuple = ()
    n_bootstrap: int = 0
    reason: str = ""

    def __getitem__(self, key: str):
        if key not in self.__dataclass_fields__:
            raise KeyError(key)
        return getattr(self, key)

    def keys(self):
        """Field names, so that ``dict(fit)`` works."""
        return self.__dataclass_fields__.keys()


def fss_scaled(rho_d, pmax, n_cells, rho_c: float, nu: float, beta: float):
    """Scaling variables of the largest-cluster fraction, for a collapse plot.

    ``x = (rho_d - rho_c) L^(1/nu)`` and ``y = pmax L^(beta/nu)`` with ``L = sqrt(n_cells)``;
    an error of ``pmax`` scales like ``pmax`` (multiply it by ``L^(beta/nu)``).

    Parameters
    ----------
    rho_d, pmax, n_cells : array_like
        Defect fraction, largest-cluster fraction and number of cells of each point
        (broadcast together).
    rho_c, nu, beta : float
        Threshold and exponents of the collapse.

    Returns
    -------
    x, y : ndarray
    """
    rho_d, pmax, n_cells = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (rho_d, pmax, n_cells)))
    L = np.sqrt(n_cells)
    return (rho_d - rho_c) * L ** (1.0 / nu), pmax * L ** (beta / nu)


class _Collapse:
    """Houdayer--Hartmann quality of the collapse of points of several sizes.

    Parametrised by ``(rho_c, a = 1/nu, b = beta/nu)``: each point is compared with the
    weighted straight line through the points of every other size that bracket its
    scaled x (a local master curve), and S is the mean of
    ``(y - Y)^2 / (dy^2 + dY^2)`` over the points that have such neighbours.
    """

    def __init__(self, rho, y, dy, L):
        self.rho, self.y, self.dy, self.L = rho, y, dy, L
        self.logL = np.log(L)
        self.sizes = np.unique(L)
        self.groups = [np.flatnonzero(L == s) for s in self.sizes]
        # half the points must overlap another size: the mean over a handful of
        # overlapping points rewards parameters that pull the sizes apart
        self.min_terms = max(4, 2 * len(self.sizes), int(np.ceil(0.5 * len(rho))))

    def terms(self, rho_c, a, b):
        """``(S, number of terms)``; S is inf when too few points overlap."""
        x = (self.rho - rho_c) * np.exp(a * self.logL)
        sc = np.exp(b * self.logL)
        y, dy = self.y * sc, self.dy * sc
        n = len(x)
        S0 = np.zeros(n)
        Sx, Sy, Sxx, Sxy = (np.zeros(n) for _ in range(4))
        used = np.zeros(n, dtype=bool)
        order = [g[np.argsort(x[g])] for g in self.groups]
        for k, gk in enumerate(order):
            xk = x[gk]
            for j, gj in enumerate(order):
                if j == k:
                    continue
                xj = x[gj]
                pos = np.searchsorted(xj, xk, side="right")
                inside = (pos > 0) & (pos < len(xj))
                if not inside.any():
                    continue
                pts = gk[inside]
                used[pts] = True
                for nb in (gj[pos[inside] - 1], gj[pos[inside]]):
                    w = 1.0 / dy[nb] ** 2
                    S0[pts] += w
                    Sx[pts] += w * x[nb]
                    Sy[pts] += w * y[nb]
                    Sxx[pts] += w * x[nb] ** 2
                    Sxy[pts] += w * x[nb] * y[nb]
        det = S0 * Sxx - Sx ** 2
        ok = used & (det > 1e-12 * np.maximum(S0 * Sxx, 1e-300))
        m = int(ok.sum())
        if m < self.min_terms:
            return np.inf, m
        xi = x[ok]
        Y = (Sxx[ok] * Sy[ok] - Sx[ok] * Sxy[ok] + xi * (S0[ok] * Sxy[ok] - Sx[ok] * Sy[ok])) / det[ok]
        dY2 = (Sxx[ok] - 2 * xi * Sx[ok] + xi ** 2 * S0[ok]) / det[ok]
        return float(np.mean((y[ok] - Y) ** 2 / (dy[ok] ** 2 + dY2))), m

    def __call__(self, rho_c, a, b):
        return self.terms(rho_c, a, b)[0]


def _params(fixed):
    """Map the free parameter vector (``rho_c``, ``a``, ``b`` in that order, fixed ones left
    out) to ``(rho_c, a = 1/nu, b = beta/nu)``; a fixed beta with a free nu is ``b = beta a``."""
    def full(v):
        it = iter(v)
        rho_c = fixed["rho_c"] if "rho_c" in fixed else next(it)
        a = 1.0 / fixed["nu"] if "nu" in fixed else next(it)
        if "beta" in fixed:
            b = fixed["beta"] * a
        else:
            b = next(it)
        return rho_c, a, b
    return full


_BAD = 1e30  # objective value of parameters out of range or without overlap


def _minimise(collapse, full, starts, rho_range, steps):
    """Nelder--Mead from each start (initial simplex ``steps`` wide); the best ``(value, free vector)``."""
    from scipy.optimize import minimize

    def objective(v):
        rho_c, a, b = full(v)
        if not (rho_range[0] <= rho_c <= rho_range[1] and INV_NU_RANGE[0] <= a <= INV_NU_RANGE[1]
                and BETA_NU_RANGE[0] <= b <= BETA_NU_RANGE[1]):
            return _BAD
        return min(collapse(rho_c, a, b), _BAD)  # finite: inf - inf in the simplex warns

    best = (np.inf, None)
    for s in starts:
        s = np.asarray(s, dtype=float)
        if s.size == 0:  # everything fixed
            val = objective(s)
            return (val if val < _BAD else np.inf), s
        simplex = np.vstack([s] + [s + np.eye(s.size)[i] * steps[i] for i in range(s.size)])
        r = minimize(objective, s, method="Nelder-Mead",
                     options={"xatol": 1e-6, "fatol": 1e-9, "maxiter": 4000, "initial_simplex": simplex})
        if r.fun < min(best[0], _BAD):
            best = (float(r.fun), np.asarray(r.x))
    return best


def _grid_starts(collapse, full, fixed, rho_range, n_best=4):
    """Coarse grid over the free parameters (rho_c, 1/nu, beta/nu); its ``n_best`` lowest
    points as starts."""
    axes = []
    if "rho_c" not in fixed:
        lo, hi = rho_range
        axes.append(np.linspace(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), 13))
    if "nu" not in fixed:
        axes.append(np.array([0.3, 0.5, 0.75, 1.0, 1.5, 2.2]))  # 1/nu
    if "beta" not in fixed:  # beta/nu
        axes.append(np.array([-0.3, 0.0, 0.1, 0.25, 0.5, 1.0]))
    if not axes:
        return [np.zeros(0)]
    grid = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    vals = np.array([collapse(*full(v)) for v in grid])
    keep = np.argsort(vals)[:n_best]
    return [grid[k] for k in keep if np.isfinite(vals[k])] or [grid[len(grid) // 2]]


def fss_collapse(rho_d, pmax, n_cells, pmax_err=None, *, fixed: dict | None = None,
                 x_max: float = FSS_X_MAX, tolerance: float = FSS_TOLERANCE, n_bootstrap: int = FSS_BOOTSTRAP,
                 seed=0) -> CollapseFit:
    """Threshold and exponents of defect percolation from a finite-size-scaling collapse.

    Fits ``P_max L^(beta/nu) = f((rho_d - rho_c) L^(1/nu))``, ``L = sqrt(N)``, to the
    largest-cluster fraction of two or more system sizes by minimising the
    Houdayer--Hartmann collapse quality (method, errors and their calibration on exact
    percolation in the module docstring, section "Finite-size scaling").

    Parameters
    ----------
    rho_d, pmax, n_cells : array_like, shape (n,)
        Defect fraction, largest-cluster fraction and number of cells of each point (one
        entry per run or state point; points with a non-finite entry are dropped).
    pmax_err : array_like, shape (n,), optional
        1-sigma errors of ``pmax``: the weights of the quality and the noise of the
        parametric bootstrap.  Without them every point weighs the same and the bootstrap
        resamples the points.  Non-positive errors are raised to the smallest positive one.
    fixed : dict, optional
        Parameters held fixed, from ``rho_c``, ``nu``, ``beta``, e.g. the exponents of 2-D
        percolation ``{"nu": NU_2D, "beta": BETA_2D}``; the others are fitted.
    x_max : float, optional
        Half width of the scaling window: only points with ``|rho_d - rho_c| L^(1/nu) <= x_max``
        at the fitted parameters count (chosen self-consistently; default 1; ``np.inf``:
        all points).
    tolerance : float, optional
        Relative allowance for corrections to scaling, ``tolerance * pmax`` added in
        quadrature to ``pmax_err`` in the weights and the bootstrap noise (default 0.02,
        calibrated on exact percolation; 0: statistical errors only).  Unused without
        ``pmax_err``.
    n_bootstrap : int, optional
        Bootstrap refits behind the errors (default 100; 0: errors NaN).
    seed : int or numpy.random.Generator, optional
        Seed of the bootstrap.

    Returns
    -------
    CollapseFit
        The fitted parameters (attributes or keys), their errors and diagnostics; a
        non-empty ``reason`` flags a fit that is unusable (NaN values) or not trusted.

    Raises
    ------
    ValueError
        For inputs of different lengths or not 1-D, unknown ``fixed`` names, or fewer than
        two distinct sizes with finite data.
    """
    arrays = [np.asarray(v, dtype=float) for v in (rho_d, pmax, n_cells)]
    if pmax_err is not None:
        arrays.append(np.asarray(pmax_err, dtype=float))
    if any(a.ndim != 1 for a in arrays) or len({a.size for a in arrays}) != 1:
        raise ValueError("rho_d, pmax, n_cells (and pmax_err) must be 1-D arrays of equal length, got shapes "
                         + ", ".join(str(a.shape) for a in arrays))
    fixed = dict(fixed or {})
    unknown = set(fixed) - set(FSS_PARAMETERS)
    if unknown:
        raise ValueError(f"fixed may only name {FSS_PARAMETERS}, got {sorted(unknown)}")
    fixed = {k: float(v) for k, v in fixed.items()}
    ok = np.all([np.isfinite(a) for a in arrays], axis=0) & (arrays[2] > 0)
    rho, p, N = (a[ok] for a in arrays[:3])
    L = np.sqrt(N)
    n_sizes = int(np.unique(N).size)
    if n_sizes < 2:
        raise ValueError(f"a finite-size collapse needs points at two or more distinct N, got {n_sizes} "
                         f"(N = {np.unique(N).tolist()}) with finite rho_d and pmax")
    if pmax_err is not None:
        err = arrays[3][ok]
        pos = err[err > 0]
        err = np.where(err > 0, err, pos.min() if pos.size else 1.0)
        err = np.hypot(err, tolerance * np.abs(p))
    else:
        err = np.ones_like(p)
    names = tuple(k for k in FSS_PARAMETERS if k in fixed)
    nan = float("nan")

    def result(vals, errs, quality, m, n_boot, reason):
        return CollapseFit(*(float(x) for pair in zip(vals, errs) for x in pair), float(quality), int(m),
                           n_sizes, float(L.min()), float(L.max()), names, int(n_boot), reason)

    if rho.size < 6:
        return result((nan,) * 3, (nan,) * 3, nan, 0, 0, f"only {rho.size} points: too few for a collapse")
    rho_range = (float(rho.min()), float(rho.max()))
    full = _params(fixed)
    steps = [s for k, s in zip(FSS_PARAMETERS, (0.02 * (rho_range[1] - rho_range[0]), 0.1, 0.05))
             if k not in fixed]

    def fit(r, y, e, l_, starts):
        """Collapse fit of the points inside the window |x| <= x_max, which is chosen
        self-consistently: refit on the points inside the window of the last fit until the
        set stops changing (a set fixed within each minimisation, so that the quality
        cannot improve by dropping points)."""
        c = _Collapse(r, y, e, l_)
        val, v = _minimise(c, full, starts, rho_range, steps)
        inside = np.ones(r.size, dtype=bool)
        for _ in range(MAX_WINDOW_ITERATIONS if np.isfinite(x_max) else 0):
            if not np.isfinite(val):
                break
            rc, a_, _b = full(v)
            new = np.abs((r - rc) * l_ ** a_) <= x_max
            if np.array_equal(new, inside):
                break
            inside = new
            if np.unique(l_[inside]).size < 2 or inside.sum() < 6:
                return np.inf, v, inside, 0
            c = _Collapse(r[inside], y[inside], e[inside], l_[inside])
            val, v = _minimise(c, full, [v], rho_range, steps)
        m = c.terms(*full(v))[1] if np.isfinite(val) else 0
        return val, v, inside, m

    starts = _grid_starts(_Collapse(rho, p, err, L), full, fixed, rho_range)
    val, v, inside, m = fit(rho, p, err, L, starts)
    if not np.isfinite(val):
        return result((nan,) * 3, (nan,) * 3, nan, m, 0,
                      f"no collapse: fewer than half the points{' in the window' if np.isfinite(x_max) else ''} "
                      "overlap another size in the scaled variable")
    rho_c, a, b = full(v)
    best = np.array([rho_c, 1.0 / a, b / a])

    rng = np.random.default_rng(seed)
    boots = []
    for _ in range(int(n_bootstrap)):
        if pmax_err is not None:
            bval, bv, _, _ = fit(rho, p + err * rng.standard_normal(p.size), err, L, [v])
        else:
            k = rng.integers(0, p.size, p.size)
            if np.unique(N[k]).size < 2:
                continue
            bval, bv, _, _ = fit(rho[k], p[k], err[k], L[k], [v])
        if np.isfinite(bval):
            r_, a_, b_ = full(bv)
            boots.append((r_, 1.0 / a_, b_ / a_))
    boots = np.asarray(boots).reshape(-1, 3)
    errs = boots.std(axis=0, ddof=1) if len(boots) >= 2 else np.full(3, nan)
    for i, name in enumerate(FSS_PARAMETERS):
        if name in fixed:
            errs[i] = 0.0
    reasons = []
    eps = 1e-3
    if "rho_c" not in fixed and min(rho_c - rho_range[0], rho_range[1] - rho_c) < eps * (rho_range[1] - rho_range[0]):
        reasons.append(f"rho_c = {rho_c:.4g} at the edge of the data")
    if "nu" not in fixed and not (INV_NU_RANGE[0] * (1 + eps) < a < INV_NU_RANGE[1] * (1 - eps)):
        reasons.append(f"nu = {1 / a:.3g} at the edge of its search range")
    if "beta" not in fixed and not (BETA_NU_RANGE[0] + eps < b < BETA_NU_RANGE[1] - eps):
        reasons.append(f"beta/nu = {b:.3g} at the edge of its search range")
    if n_bootstrap and len(boots) < max(2, n_bootstrap // 2):
        reasons.append(f"only {len(boots)} of {n_bootstrap} bootstrap refits converged")
    return result(best, errs, val, m, len(boots), "; ".join(reasons))
