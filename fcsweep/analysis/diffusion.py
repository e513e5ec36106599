"""Long-time self-diffusion from the MSD: D_s, D0 and D_eff (docs/model.md, Observables).

:func:`estimate_diffusion` cuts the analysed span into time blocks at least a few
persistence times long, fits the active-Brownian MSD form
``4 D t + A (1 - exp(-Dr t)) + c`` in each, and takes the mean over blocks with the
larger of the time-block and cell-block errors (see its docstring for why each part
is there). D_eff = D_s / D0 with D0 = v0^2 / (2 Dr); a run is solid below
:data:`D_EFF_SOLID`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fcsweep.analysis.collective import (MIN_WINDOWS, inefficiency_of_squares, inefficiency_windows,
                                         spatial_inefficiency, window_squares)
from fcsweep.analysis.frames import FrameSource, work_blocks
from fcsweep.analysis.msd import (block_displacements, drift_subtracted, frame_drift, mean_displacement,
                                  particle_msd, window_mean)

#: D_eff below which a run is labelled solid.
D_EFF_SOLID = 1e-3
#: Time blocks from which their scatter is a second error estimate (fewer: too noisy).
TIME_ERROR_MIN_BLOCKS = 4


def free_diffusion(v0: float, Dr: float) -> float:
    """D0 = v0^2 / (2 Dr), the long-time diffusion of a free active Brownian particle."""
    if Dr <= 0:
        return float("inf") if v0 != 0 else float("nan")
    return float(v0) ** 2 / (2.0 * float(Dr))


@dataclass(frozen=True)
class DiffusionEstimate:
    """Result of :func:`estimate_diffusion` (D in length^2 / time).

    Attributes
    ----------
    D, D_err : float
        Long-time self-diffusion coefficient and its 1-sigma error: the cell error
        ``D_err_cells``, or the larger of it and the time-block error ``D_err_time``
        when there are at least ``TIME_ERROR_MIN_BLOCKS`` blocks.
    D_err_time, D_err_cells : float
        Error from the scatter of the ``n_time_blocks`` time blocks (slow relaxation;
        NaN with one block) and from the scatter of the cells' own slopes within each
        block, counted with the spatial inefficiency ``g_cells`` (collective motion).
    g_cells : float
        Spatial statistical inefficiency of the displacements (mean over blocks):
        ``N / g_cells`` cells move independently (:mod:`fcsweep.analysis.collective`).
    D_late, D_late_err : float
        The same estimate from the upper half of the fit window only.
    D_long, D_long_err : float
        The same estimate at another block length: with ``B >= 2`` blocks, one block
        spanning the whole run (lags up to half the run; its cell error); with one block,
        two blocks of half its length. NaN when the run is too short for either. The
        whole-run block sees a slow cage plateau that short blocks miss: the phase rule
        tests "solid" on it.
    t_min, t_max : float
        Fit window (lags) within each block.
    block_span : float
        Length of one time block.
    n_time_blocks : int
    persistence : bool
        Whether the persistent start ``A (1 - exp(-t Dr))`` was fitted.
    diffusive : bool
        True when the slope has settled: ``D_late`` agrees with ``D`` within
        ``3 D_late_err``, and ``D_long`` within 3 sigma of their difference (or both
        within an absolute ``settle_tol``).
    long_enough : bool
        True when every block spans at least ``min_block_persistence / Dr``.
    """

    D: float
    D_err: float
    D_err_time: float
    D_err_cells: float
    D_late: float
    D_late_err: float
    D_long: float
    D_long_err: float
    t_min: float
    t_max: float
    block_span: float
    n_time_blocks: int
    persistence: bool
    diffusive: bool
    long_enough: bool
    g_cells: float = float("nan")


def _design(t: np.ndarray, tau_r: float) -> tuple[np.ndarray, bool]:
    """Columns of the linear MSD model over lags ``t``: ``4t``, ``1 - exp(-t/tau_r)``, ``1``."""
    cols = [4.0 * t]
    persist = bool(tau_r > 0 and np.exp(-t[0] / tau_r) > 1e-3)
    if persist:
        cols.append(-np.expm1(-t / tau_r))
    cols.append(np.ones_like(t))
    return np.stack(cols, axis=1), persist


def _slope_weights(lags: np.ndarray, t: np.ndarray, tau_r: float) -> np.ndarray:
    """Weights ``w`` with ``D = w . msd[lags]`` for the MSD model fitted over ``lags``."""
    X, _ = _design(t[lags], tau_r)
    return np.linalg.pinv(X)[0]


def estimate_diffusion(time, unwrapped, *, Dr: float, max_time_blocks: int = 8,
                       min_block_persistence: float = 8.0, min_block_frames: int = 16,
                       fit_start: float = 0.2, settle_tol: float = 0.0) -> DiffusionEstimate:
    """Long-time self-diffusion from time blocks of a trajectory, with an honest error.

    The analysed span is cut into ``B`` equal time blocks, each at least
    ``min_block_persistence / Dr`` long (and ``min_block_frames`` frames), ``B <=
    max_time_blocks``. In every block the drift-subtracted window MSD (variance form,
    :func:`fcsweep.analysis.msd.msd_curve`) is fitted over lags ``[fit_start, 1] x t_hi``,
    ``t_hi`` = half the block, to the active-Brownian form

        MSD(t) = 4 D t + A (1 - exp(-Dr t)) + c,

    whose second term is the persistent start of a free ABP (``A = -4 D0 / Dr``) and the
    saturation of an ABP in a harmonic cage (``D = 0``); a linear fit would read the
    still-rising MSD of a caged crystal as diffusion and underestimate a free ABP unless
    the window lay far beyond ``1/Dr``. The fit is linear in the MSD, so ``D`` is the
    mean of the block estimates, and the mean over cells of each cell's own slope.
    Its error comes from the scatter of those cell slopes, with the spatial statistical
    inefficiency of the displacements (:mod:`fcsweep.analysis.collective`): cells that
    move together are one sample, not many, at any number of time blocks, one included.
    With ``TIME_ERROR_MIN_BLOCKS`` blocks or more, the scatter over time blocks (slow
    relaxation, drifts) is a second estimate and the larger of the two is quoted.
    Measured on synthetic data with known spread (tests/test_honest_diffusion.py): free
    and caged active Brownian particles and box-scale collective modes, one to eight
    blocks, quoted error / spread over realisations 0.8-1.5.

    Settling: the same estimate from the upper half of the fit window must agree with
    ``D``, and the estimate over the longer of two block lengths (the whole run against
    its blocks; one block against its halves) must not read higher than the shorter one
    (lower is a cage still being explored: less diffusion over longer windows). A crystal whose cage relaxes more
    slowly than ``1/Dr`` still has a rising MSD within short blocks; the whole run sees
    the plateau, the two disagree, and the estimate is flagged not ``diffusive``. A cage
    slower than half the run cannot be told from diffusion by any window.

    Parameters
    ----------
    time : ndarray, shape (T,)
        Equally spaced frame times.
    unwrapped : ndarray, shape (T, N, 2), or fcsweep.analysis.frames.FrameSource
        Unwrapped centroids; a frame source is read a block of cells at a time (the same
        estimate within rounding, without holding the whole series).
    Dr : float
        Rotational diffusion (sets the persistence time ``1/Dr``; 0 or non-finite: a
        linear fit ``4 D t + c``).
    max_time_blocks, min_block_persistence, min_block_frames, fit_start
        See above.
    settle_tol : float
        Absolute difference of ``D_late`` or ``D_long`` and ``D`` always accepted as
        settled.

    Returns
    -------
    DiffusionEstimate
    """
    time = np.asarray(time, dtype=float)
    x = unwrapped if isinstance(unwrapped, FrameSource) else np.asarray(unwrapped, dtype=float)
    _blocks = _blocks_streamed if isinstance(x, FrameSource) else _blocks_held
    h = float(time[1] - time[0])
    span = float(time[-1] - time[0])
    tau_r = 1.0 / float(Dr) if np.isfinite(Dr) and Dr > 0 else 0.0
    L_min = max(min_block_persistence * tau_r, (min_block_frames - 1) * h)
    B = int(min(max_time_blocks, span // L_min)) if L_min > 0 else 1
    long_enough = B >= 1
    B = max(B, 1)
    main = _blocks(x, h, B, tau_r, fit_start)
    nan = float("nan")
    if main is None:
        Lf = x.shape[0] // B
        return DiffusionEstimate(nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, (Lf - 1) * h, B,
                                 False, False, False)
    D, err_t, err_c, Dl, err_late, lo, hi, Lf, g = main
    err = float(np.nanmax([err_t, err_c])) if B >= TIME_ERROR_MIN_BLOCKS else err_c
    settled = abs(Dl - D) <= max(3.0 * err_late, settle_tol)
    D2, err2 = nan, nan
    if B >= 2:  # one block over the whole run, with its cell error (collective motion included)
        other = _blocks(x, h, 1, tau_r, fit_start)
        if other is not None:
            D2, err2 = other[0], float(other[2])
    else:  # one block: compare with two blocks of half the length (their scatter is measurable)
        other = _blocks(x, h, 2, tau_r, fit_start)
        if other is not None:
            D2, err2 = other[0], float(other[2])
    if np.isfinite(D2):
        tol = max(3.0 * np.hypot(err, err2), settle_tol)
        # The longer window reading lower is the approach to a cage plateau (the phase
        # rule tests "solid" on the longest window); only the longer window reading
        # higher, diffusion still speeding up, is unsettled.
        settled = settled and (D2 - D <= tol if B >= 2 else D - D2 <= tol)
    _, persist = _design(np.arange(lo, hi + 1) * h, tau_r)
    return DiffusionEstimate(D, err, err_t, err_c, Dl, err_late, D2, err2, lo * h, hi * h,
                             (Lf - 1) * h, B, persist, bool(settled), long_enough, g)


def _cell_msd(xb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Drift-subtracted displacements, per-cell window MSDs ``(Lf, N)`` and the squared
    mean displacement per lag (the variance form's correction) of one time block."""
    disp = drift_subtracted(xb)
    return disp, particle_msd(disp), np.sum(mean_displacement(disp) ** 2, axis=-1)


def _blocks_held(x: np.ndarray, h: float, B: int, tau_r: float, fit_start: float):
    """Block estimate over ``B`` time blocks (None if too short):
    ``(D, err_time, err_cells, D_late, err_late, lo, hi, frames_per_block, g)``.

    In each block every cell's slope ``D_i`` is the same linear functional of its own
    window MSD, so the block estimate is their mean; its error is ``sqrt(g var_i(D_i) / N)``
    with the spatial inefficiency ``g`` of the displacements over the top fit lag
    (:mod:`fcsweep.analysis.collective`): cells that move together count once."""
    plan = _block_plan(x.shape[0], h, B, tau_r, fit_start)
    if plan is None:
        return None
    Lf, lo, hi, lags, late, w_all, w_late = plan
    N = x.shape[1]
    Db, Dl, var_b, var_l, gs = (np.empty(B) for _ in range(5))
    for b in range(B):
        xb = x[b * Lf:(b + 1) * Lf]
        disp, per, mean_sq = _cell_msd(xb)
        for w, ls, D_out, v_out in ((w_all, lags, Db, var_b), (w_late, late, Dl, var_l)):
            Di = w @ per[ls]
            D_out[b] = Di.mean() - w @ mean_sq[ls]
            v_out[b] = Di.var(ddof=1) / N if N > 1 else np.nan
        gs[b] = spatial_inefficiency(disp)
    return _block_result(Db, Dl, var_b, var_l, gs, lo, hi, Lf)


def _block_plan(T: int, h: float, B: int, tau_r: float, fit_start: float):
    """Frames per block, fitted lags (all and late) and their slope weights of ``B`` time
    blocks of ``T`` frames (None when a block is too short for 3 lags)."""
    Lf = T // B
    hi = Lf // 2
    lo = max(1, int(np.ceil(fit_start * hi)))
    lags, late = np.arange(lo, hi + 1), np.arange(max(lo, hi // 2), hi + 1)
    if lags.size < 3 or late.size < 3:
        return None
    t = np.arange(Lf) * h
    return Lf, lo, hi, lags, late, _slope_weights(lags, t, tau_r), _slope_weights(late, t, tau_r)


def _block_result(Db, Dl, var_b, var_l, gs, lo: int, hi: int, Lf: int):
    """The block estimate's tuple (see :func:`_blocks_held`) from the per-block slopes,
    their variances over cells and the spatial inefficiencies."""
    B = len(Db)
    err_t = float(Db.std(ddof=1) / np.sqrt(B)) if B > 1 else float("nan")
    err_c = float(np.sqrt(np.sum(gs * var_b)) / B)
    errl_t = float(Dl.std(ddof=1) / np.sqrt(B)) if B > 1 else float("nan")
    errl_c = float(np.sqrt(np.sum(gs * var_l)) / B)
    return (float(Db.mean()), err_t, err_c, float(Dl.mean()), float(np.nanmax([errl_t, errl_c])),
            lo, hi, Lf, float(gs.mean()))


def _blocks_streamed(x: FrameSource, h: float, B: int, tau_r: float, fit_start: float):
    """:func:`_blocks_held` of a frame source: per time block, the drift of all cells from one
    pass over its frames, then the cells' slopes a block of cells at a time (each cell's
    window MSD is the one :func:`_blocks_held` computes; the window increments of
    the spatial inefficiency are ``(k <= 16, N)``)."""
    plan = _block_plan(x.shape[0], h, B, tau_r, fit_start)
    if plan is None:
        return None
    Lf, lo, hi, lags, late, w_all, w_late = plan
    N = x.shape[1]
    m, k = inefficiency_windows(Lf)
    Db, Dl, var_b, var_l, gs = (np.empty(B) for _ in range(5))
    for b in range(B):
        xb = x.window(b * Lf, (b + 1) * Lf)
        drift = frame_drift(xb)
        Di = {"all": np.empty(N), "late": np.empty(N)}
        csum = np.zeros((Lf, 2))
        squares = np.empty((k, N)) if N >= 2 and k >= MIN_WINDOWS else None
        for lo_, hi_ in xb.cell_blocks():
            for a, xc in work_blocks(xb.cells(lo_, hi_)):
                c0, c1 = lo_ + a, lo_ + a + xc.shape[1]
                disp = block_displacements(xc, drift)
                per = particle_msd(disp)
                Di["all"][c0:c1] = w_all @ per[lags]
                Di["late"][c0:c1] = w_late @ per[late]
                csum += disp.sum(axis=1)
                if squares is not None:
                    squares[:, c0:c1] = window_squares(disp, m, k)
        mean_sq = np.sum(window_mean(csum / N) ** 2, axis=-1)
        for w, ls, key, D_out, v_out in ((w_all, lags, "all", Db, var_b), (w_late, late, "late", Dl, var_l)):
            D_out[b] = Di[key].mean() - w @ mean_sq[ls]
            v_out[b] = Di[key].var(ddof=1) / N if N > 1 else np.nan
        gs[b] = 1.0 if squares is None else inefficiency_of_squares(squares)
    return _block_result(Db, Dl, var_b, var_l, gs, lo, hi, Lf)


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
