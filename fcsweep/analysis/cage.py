"""Structural relaxation: have the cells left their cages within the window?

Fluidity can be shown in a finite window, solidity only bounded. :func:`cage_breaking`
measures the *cage-relative* displacement of every cell (its displacement minus the mean
displacement of its Voronoi neighbours at the time origin; Vivek et al., PNAS 114, 1850
(2017); Illing et al., PNAS 114, 1856 (2017)), which removes the long-wavelength
collective motion that moves a 2-D crystal without breaking it, and compares its mean
square at a lag ``t*`` (the first lag at which it exceeds ``a^2`` by three errors, else
the whole analysed window: the earliest clear crossing gives the strongest bound below)
with the squared neighbour spacing ``a^2``, ``a = (2 A / (sqrt(3) N))^(1/2)`` (the
spacing of a triangular lattice of that density; 1.95 R0 at area fraction 0.95). The
cage is broken when cells have, on average, moved farther than a neighbour spacing
relative to their first shell, with probability
``P(CR-MSD(t*) > a^2)`` from the scatter over spatially contiguous blocks of cells.

After the cages broke the cage-relative MSD keeps growing diffusively: its slope over
the lags past ``t*`` gives the self-diffusion coefficient directly (``D_late``, corrected
for the neighbours it is measured against), and the phase rule reads "solid" or "not
solid" from it with its error (:mod:`fcsweep.analysis.phase`). The earlier rule took a
broken cage as "not solid" only where ``a^2 / (4 t* D0)`` exceeded 5e-3; since for steady
creep ``t* ~ a^2 / (4 D_cr)`` that bound is about D_eff itself, so every state with
``1e-3 < D_eff < 5e-3`` stayed undetermined at any run length. The bound is still
stored (``cage_d_eff_bound``), as information only.
A caged solid never reaches ``a^2``: a harmonic cage holds the MSD at ``2 v0^2 / (k (k + Dr))``
(0.16 R0^2 at k = 0.1, v0 = 0.03, Dr = 0.01, against ``a^2 = 3.8 R0^2``).

Also reported: the self-intermediate scattering function of the cage-relative
displacements, ``F_s(k, t) = < J0(k |dr_i(t)|) >`` (the isotropic 2-D average of
``cos k . dr``) at ``k = 2 pi / a``, and the structural relaxation time ``tau_alpha`` where
it first falls below ``1/e`` (NaN when it does not within the window).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.special import j0, ndtr

from fcsweep.analysis.diffusion import D_EFF_SOLID, free_diffusion
from fcsweep.analysis.frames import FrameSource
from fcsweep.analysis.voronoi import voronoi_neighbors

#: Lags added between ``t*`` and the window's end for the slope past ``t*``.
LATE_LAGS = 12
#: Lags added between the grid lags around the first clear crossing, to place ``t*``.
CROSSING_LAGS = 6
#: Fewest lags at or past ``t*`` for a slope there (``D_late``).
MIN_LATE_LAGS = 4
#: Time origins averaged per lag (evenly spaced over the window; one at the whole window).
N_ORIGINS = 12
#: Spatially contiguous blocks per side for the error (``BLOCKS_PER_SIDE ** 2`` blocks).
BLOCKS_PER_SIDE = 4
#: Bytes of time origins' Voronoi shells kept for the lags added after the first pass
#: (about 57 B per cell and origin: all origins at N = 10^4, the first ~45 at 10^5).
SHELL_CACHE_BYTES = 256 << 20


def neighbour_spacing(n_cells: int, box) -> float:
    """Spacing ``a`` of a triangular lattice of ``n_cells`` points in ``box`` (Lx, Ly)."""
    area = float(box[0]) * float(box[1])
    return float(np.sqrt(2.0 * area / (np.sqrt(3.0) * n_cells)))


@dataclass(frozen=True)
class CageBreaking:
    """Result of :func:`cage_breaking` (lengths in the positions' unit).

    Attributes
    ----------
    spacing : float
        Neighbour spacing ``a``.
    lag : float
        Lag ``t*`` of the test: the first at which the cage-relative MSD exceeds ``a^2``
        by three errors, else the whole window (one time origin).
    ratio, ratio_err : float
        Cage-relative MSD at ``t*`` over ``a^2``, and its 1-sigma error.
    p_broken : float
        ``P(ratio > 1)`` (Gaussian).
    fs, tau_alpha : float
        ``F_s(2 pi / a, t*)`` and the lag where ``F_s`` first falls below ``1/e``.
    lags, cr_msd, F_s : ndarray
        The curves over lags (time units).
    D_cr, D_cr_err : float
        Cage-relative diffusion coefficient: a quarter of the slope of the cage-relative
        MSD over the last three quarters of the window, and its error over the spatial
        blocks. In a fluid it tends to ``D_s (1 + 1/n)`` (n ~ 6 neighbours); in a solid to 0
        without the slow long-wavelength growth that keeps a 2-D crystal's plain MSD rising
        (Mermin-Wagner), which is why the solid test uses it.
    D_late, D_late_err : float
        Self-diffusion coefficient from the cage-relative MSD past ``t*`` (its diffusive
        regime, measured only where the cages broke clearly): a quarter of its slope over
        the lags ``>= t*`` (``LATE_LAGS`` added there), divided by ``1 + <1/n_i>`` because
        ``n_i`` independent neighbours add ``D / n_i`` to a cage-relative D; error over the
        spatial blocks. NaN where the cages did not break or fewer than ``MIN_LATE_LAGS``
        lags lie past ``t*``. The fluid rule reads this one.
    inv_neighbours : float
        ``<1/n_i>``: Voronoi neighbour counts at the time origins.
    fs_lags, fs_blocks : ndarray
        The first pass's lags (time units) and ``F_s`` of each spatial block there, for
        :meth:`fs_at`.
    """

    spacing: float
    lag: float
    ratio: float
    ratio_err: float
    p_broken: float
    fs: float
    tau_alpha: float
    lags: np.ndarray
    cr_msd: np.ndarray
    F_s: np.ndarray
    D_cr: float = float("nan")
    D_cr_err: float = float("nan")
    D_late: float = float("nan")
    D_late_err: float = float("nan")
    inv_neighbours: float = float("nan")
    fs_lags: np.ndarray = None
    fs_blocks: np.ndarray = None

    def d_eff_bound(self, v0: float, Dr: float) -> float:
        """``a^2 / (4 t* D0)``: the D_eff a broken cage at ``t*`` stands for (NaN if D0 is 0).
        Stored for information; no label depends on it."""
        D0 = free_diffusion(v0, Dr)
        if not (np.isfinite(D0) and D0 > 0 and self.lag > 0):
            return float("nan")
        return float(self.spacing ** 2 / (4.0 * self.lag * D0))


    def fs_at(self, lag: float) -> tuple[float, float]:
        """``F_s(2 pi / a)`` at the largest measured lag not above ``lag`` and its error over
        the spatial blocks; NaN where ``lag`` is before the first lag or beyond the window."""
        if self.fs_lags is None or not np.isfinite(lag) or lag > self.fs_lags[-1] or lag < self.fs_lags[0]:
            return float("nan"), float("nan")
        i = int(np.searchsorted(self.fs_lags, lag, side="right")) - 1
        b = self.fs_blocks[i]
        b = b[np.isfinite(b)]
        if b.size < 2:
            return float("nan"), float("nan")
        return float(b.mean()), float(b.std(ddof=1) / np.sqrt(b.size))

    def relaxation_lag(self, v0: float, Dr: float, d_solid: float) -> float:
        """The lag by which a state with ``D_eff`` at ``d_solid`` would at the earliest have
        relaxed: ``F_s(2 pi / a)`` of Gaussian cage-relative displacements is
        ``exp(-pi^2 MSD / a^2)``, ``1/e`` at ``MSD = a^2 / pi^2``, reached at
        ``a^2 / (4 pi^2 D_cr)`` with ``D_cr = d_solid D0 (1 + <1/n>)``.  Any other shape of the
        displacements (hops, a plateau) relaxes later at the same D: so ``F_s`` below ``1/e``
        at this lag means ``D_eff > d_solid``."""
        D0 = free_diffusion(v0, Dr)
        inv_n = self.inv_neighbours if np.isfinite(self.inv_neighbours) else 1.0 / 6.0
        if not (np.isfinite(D0) and D0 > 0):
            return float("nan")
        return float(self.spacing ** 2 / (4.0 * np.pi ** 2 * d_solid * D0 * (1.0 + inv_n)))

    def scalars(self, v0: float, Dr: float) -> dict:
        """The cage observables as stored in ``analysis.h5`` (names of the pipeline; the
        diffusion coefficients past ``t*`` in units of D0)."""
        D0 = free_diffusion(v0, Dr)
        D0 = D0 if np.isfinite(D0) else 0.0
        return {"neighbour_spacing": self.spacing, "cage_lag": self.lag, "cage_msd_ratio": self.ratio,
                "cage_msd_ratio_err": self.ratio_err, "cage_broken_probability": self.p_broken,
                "cage_d_eff_bound": self.d_eff_bound(v0, Dr), "F_s_window": self.fs, "tau_alpha": self.tau_alpha,
                "D_eff_cr_late": self.D_late / D0 if D0 > 0 else float("nan"),
                "D_eff_cr_late_err": self.D_late_err / D0 if D0 > 0 else float("nan"),
                **dict(zip(("F_s_bound", "F_s_bound_err"), self.fs_at(self.relaxation_lag(v0, Dr, D_EFF_SOLID)))),
                "relaxation_lag": self.relaxation_lag(v0, Dr, D_EFF_SOLID)}


def broken_probability(ratio: float, err: float) -> float:
    """``P(ratio > 1)`` for a Gaussian estimate of the cage-relative MSD over ``a^2``."""
    return float(ndtr((ratio - 1.0) / err)) if err > 0 else float(ratio > 1.0)


def _lag_frames(T: int, n: int = 16) -> np.ndarray:
    top = max(1, T - 1)
    return np.unique(np.round(np.geomspace(1, top, n)).astype(int))


def cage_breaking(time, unwrapped, box, *, spacing: float | None = None,
                  n_origins: int = N_ORIGINS, neighbours=None, cells=None) -> CageBreaking:
    """Cage-relative MSD against the neighbour spacing, and ``F_s`` (see module doc).

    Parameters
    ----------
    time : ndarray, shape (T,)
        Equally spaced frame times of the analysed window.
    unwrapped : ndarray, shape (T, N, 2), or fcsweep.analysis.frames.FrameSource
        Unwrapped centroids (a frame source is read a frame at a time: the time origins
        and their lags).
    box : (Lx, Ly)
        Periodic box (for the Voronoi neighbours and the spacing).
    spacing : float, optional
        Neighbour spacing (default :func:`neighbour_spacing`).
    n_origins : int
        Time origins averaged.
    neighbours : callable, optional
        ``neighbours(pos) -> (i, j)``, the bonds of the cells at a time origin; default
        the periodic Voronoi of ``box`` (an image passes its open-boundary graph).
    cells : callable, optional
        ``cells(pos) -> bool (N,)``: the cells a time origin counts (a confined run: those
        at least 2a from the walls, :mod:`fcsweep.analysis.confined`); the mean squares,
        ``F_s``, the block errors and ``<1/n>`` are over them (all cells by default).
        Their neighbours' displacements still enter every counted cell's cage.

    Returns
    -------
    CageBreaking
    """
    t = np.asarray(time, dtype=float)
    x = unwrapped if isinstance(unwrapped, FrameSource) else np.asarray(unwrapped, dtype=float)
    T, N = x.shape[:2]
    a = float(spacing) if spacing is not None else neighbour_spacing(N, box)
    nan = float("nan")
    if T < 3 or N < 4:
        e = np.zeros(0)
        return CageBreaking(a, nan, nan, nan, nan, nan, nan, e, e, e)
    h = float(t[1] - t[0])
    lags = _lag_frames(T)
    k = 2.0 * np.pi / a
    L = np.asarray(box, dtype=float)[:2]
    side = np.floor(np.mod(x[0], L) / L * BLOCKS_PER_SIDE).astype(int) % BLOCKS_PER_SIDE
    block = side[:, 0] * BLOCKS_PER_SIDE + side[:, 1]
    shells = {}
    msd, fs, per_cell, inv_n, per_fs = _cage_curves(x, lags, L, k, n_origins, shells, neighbours, cells)
    if not np.isfinite(msd).all():  # no cell counted at some origin
        e = np.zeros(0)
        return CageBreaking(a, nan, nan, nan, nan, nan, nan, e, e, e)
    labels = np.unique(block if cells is None else block[np.asarray(cells(x[0]), bool)])

    def by_block(pc):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a block without counted cells at some lag
            return np.stack([np.nanmean(pc[:, block == b], axis=1) for b in labels], axis=1) / a ** 2

    blocks = by_block(per_cell)
    fs_blocks = by_block(per_fs) * a ** 2  # (lags, blocks): F_s of each spatial block, for fs_at
    fs_lags = lags * h
    ratios = msd / a ** 2
    errs = blocks.std(axis=1, ddof=1) / np.sqrt(labels.size) if labels.size > 1 else np.full(lags.size, nan)
    # the test lag: the first at which the cages are broken by 3 errors, else the whole window
    clear = np.flatnonzero(ratios - 3.0 * errs > 1.0)
    at = int(clear[0]) if clear.size else lags.size - 1
    ratio, err = float(ratios[at]), float(errs[at])
    p = broken_probability(ratio, err)
    D, D_err = _late_slope(lags * h, blocks * a ** 2)
    D_late = D_late_err = nan
    if clear.size:
        curves = [lags, msd, fs, blocks]

        def add(more):  # the curves at more lags (frames), merged in lag order
            more = np.setdiff1d(np.unique(np.round(more).astype(int)), curves[0])
            if more.size:
                m2, f2, p2, _, _ = _cage_curves(x, more, L, k, n_origins, shells, neighbours, cells)
                order = np.argsort(np.concatenate([curves[0], more]))
                for q, new in enumerate((more, m2, f2, by_block(p2))):
                    curves[q] = np.concatenate([curves[q], new])[order]
            return more

        t_lag = lags[at]
        if at > 0:  # the crossing between two grid lags: the first clear one among lags between
            more = add(np.linspace(lags[at - 1], lags[at], CROSSING_LAGS + 2)[1:-1])
            if more.size:
                i = np.searchsorted(curves[0], more)
                b = curves[3][i]
                hit = np.flatnonzero(curves[1][i] / a ** 2 - 3.0 * b.std(axis=1, ddof=1) / np.sqrt(labels.size) > 1.0)
                t_lag = more[hit[0]] if hit.size else t_lag
        # past t* the cage-relative MSD is diffusive: more lags there give its slope
        add(np.linspace(t_lag, T - 1, LATE_LAGS))
        lags, msd, fs, blocks = curves
        at = int(np.searchsorted(lags, t_lag))
        ratio = float(msd[at] / a ** 2)
        err = float(blocks[at].std(ddof=1) / np.sqrt(labels.size))
        p = broken_probability(ratio, err)
        D_late, D_late_err = _slope_past(lags[at:] * h, blocks[at:] * a ** 2)
        D_late, D_late_err = D_late / (1.0 + inv_n), D_late_err / (1.0 + inv_n)
    below = np.flatnonzero(fs < np.exp(-1.0))
    if below.size == 0:
        tau = nan
    elif below[0] == 0:
        tau = float(lags[0] * h)
    else:
        i = below[0]  # log-linear interpolation between the bracketing lags
        f0, f1 = fs[i - 1], fs[i]
        w = (f0 - np.exp(-1.0)) / (f0 - f1)
        tau = float(np.exp(np.log(lags[i - 1] * h) + w * (np.log(lags[i] * h) - np.log(lags[i - 1] * h))))
    return CageBreaking(a, float(lags[at] * h), ratio, err, p, float(fs[at]), tau, lags * h, msd, fs, D, D_err,
                        float(D_late), float(D_late_err), float(inv_n), fs_lags, fs_blocks)


def _cage_curves(x, lags, L, k, n_origins, shells, neighbours=None, cells=None):
    """Cage-relative MSD, ``F_s`` and per-cell mean squares at ``lags`` (frames),
    ``<1/n_i>`` over the cells and origins, and per-cell means of ``F_s``.  A cell never
    counted at a lag's origins has a NaN mean square there.

    Each time origin is tessellated once per call and measured at every lag that uses it;
    ``shells`` keeps origins' shells for later calls up to :data:`SHELL_CACHE_BYTES` (all
    of them took 1.3 GB at N = 10^5). Every lag still sums its origins in increasing order,
    so the curves are those of a lag-by-lag loop, bit for bit."""
    T, N = x.shape[:2]
    msd = np.zeros(lags.size)
    fs = np.zeros(lags.size)
    per_cell = np.zeros((lags.size, N))
    per_fs = np.zeros((lags.size, N))
    per_count = np.zeros((lags.size, N))
    of_lag = [np.unique(np.linspace(0, T - 1 - m, min(n_origins, T - m)).astype(int)) for m in lags]
    users: dict[int, list[int]] = {}  # origin -> its lags, in the order first met (lag by lag)
    for q, origins in enumerate(of_lag):
        for o in origins:
            users.setdefault(int(o), []).append(q)
    inv = {}
    for o in sorted(users):
        if o in shells:
            i, j, deg, use = shells[o]
        else:
            if neighbours is None:
                vn = voronoi_neighbors(np.mod(x[o], L), L)
                i, j = vn.i, vn.j
            else:
                i, j = neighbours(x[o])
            i, j = np.asarray(i, dtype=np.int32), np.asarray(j, dtype=np.int32)
            use = np.ones(N, bool) if cells is None else np.asarray(cells(x[o]), bool)
            deg = np.maximum(np.bincount(i, minlength=N), 1).astype(np.int32)
            held = sum(sum(a.nbytes for a in sh) for sh in shells.values())
            if held + i.nbytes + j.nbytes + deg.nbytes + use.nbytes <= SHELL_CACHE_BYTES:
                shells[o] = (i, j, deg, use)
        if use.any():
            inv[o] = np.mean(1.0 / deg[use])
        x0 = np.array(x[o])
        for q in users[o]:
            d = x[o + lags[q]] - x0
            # bincount adds in index order, as np.add.at does: the same sums, 4x faster
            nb = np.stack([np.bincount(i, weights=d[j, c], minlength=N) for c in range(2)], axis=1)
            rel = d - nb / deg[:, None]
            s = np.sum(rel * rel, axis=1)
            su = s[use]
            msd[q] += (su.mean() if su.size else np.nan) / of_lag[q].size
            fs[q] += (j0(k * np.sqrt(su)).mean() if su.size else np.nan) / of_lag[q].size
            per_cell[q] += np.where(use, s, 0.0)
            per_fs[q] += np.where(use, j0(k * np.sqrt(s)), 0.0)
            per_count[q] += use
    with np.errstate(invalid="ignore", divide="ignore"):
        per_cell = np.where(per_count > 0, per_cell / np.maximum(per_count, 1), np.nan)
        per_fs = np.where(per_count > 0, per_fs / np.maximum(per_count, 1), np.nan)
    means = [inv[o] for o in users if o in inv]  # first-met order, as the mean always took them
    inv_n = float(np.mean(means)) if means else float("nan")
    return msd, fs, per_cell, inv_n, per_fs


def _slope_past(t: np.ndarray, curves: np.ndarray) -> tuple[float, float]:
    """``slope / 4`` of curves ``(lags, blocks)`` over all the given lags (straight line
    per block), mean over blocks and its error; NaN with fewer than ``MIN_LATE_LAGS``."""
    if t.size < MIN_LATE_LAGS or curves.shape[1] < 2:
        return float("nan"), float("nan")
    X = np.stack([t, np.ones(t.size)], axis=1)
    slopes = np.linalg.lstsq(X, curves, rcond=None)[0][0] / 4.0
    return float(slopes.mean()), float(slopes.std(ddof=1) / np.sqrt(slopes.size))


def _late_slope(t: np.ndarray, curves: np.ndarray) -> tuple[float, float]:
    """``slope / 4`` of curves ``(lags, blocks)`` over the last three quarters of the lag
    range (straight-line fit per block), mean over blocks and its error."""
    late = t >= 0.25 * t[-1]
    if late.sum() < 3 or curves.shape[1] < 2:
        return float("nan"), float("nan")
    X = np.stack([t[late], np.ones(late.sum())], axis=1)
    slopes = np.linalg.lstsq(X, curves[late], rcond=None)[0][0] / 4.0
    return float(slopes.mean()), float(slopes.std(ddof=1) / np.sqrt(slopes.size))
