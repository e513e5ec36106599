"""Mean squared displacement of unwrapped centroids (window average, freud).

The estimator is

    MSD(m) = < |r_i(k+m) - r_i(k)|^2 >_{i,k}  -  | < r_i(k+m) - r_i(k) >_{i,k} |^2

(the variance form of docs/model.md), computed on drift-subtracted trajectories
``r_i(t) - r_i(0) - [C(t) - C(0)]`` with ``C(t)`` the centre of mass of all cells at
frame t.  After drift subtraction the mean displacement vanishes identically, so the
second term only matters when ``subtract_drift=False``.  For N independent particles
the drift subtraction lowers the MSD by the factor ``1 - 1/N``.

freud's windowed MSD (FFT algorithm) works internally in single precision; on absolute
positions of size L its cancellation error is ~1e-7 L^2, which would swamp the
displacements of a solid.  We therefore pass displacements from the first frame
(relative error ~1e-5 of the MSD itself, checked in the tests against a direct sum).
"""

from __future__ import annotations

import freud
import numpy as np

from fcsweep.analysis.frames import work_blocks


def drift_subtracted(unwrapped: np.ndarray) -> np.ndarray:
    """Displacements from frame 0 with the centre-of-mass displacement removed.

    Parameters
    ----------
    unwrapped : ndarray, shape (T, N, 2)
        Unwrapped centroids.

    Returns
    -------
    ndarray, shape (T, N, 2)
        ``r_i(t) - r_i(0) - (C(t) - C(0))``.
    """
    x = np.asarray(unwrapped, dtype=float)
    d = x - x[:1]
    return d - d.mean(axis=1, keepdims=True)


def _freud_window(disp: np.ndarray):
    T, n, _ = disp.shape
    p3 = np.zeros((T, n, 3), dtype=float)
    p3[..., :2] = disp
    m = freud.msd.MSD(mode="window")
    m.compute(p3)
    return m


def _freud_msd(disp: np.ndarray) -> np.ndarray:
    """Window MSD of displacements ``disp`` (T, n, 2) with freud, shape (T,)."""
    out = np.array(_freud_window(disp).msd, dtype=float)
    out[0] = 0.0
    return out


def particle_msd(disp: np.ndarray) -> np.ndarray:
    """Window MSD of every particle of ``disp`` (T, n, 2) with freud, shape (T, n)."""
    out = np.array(_freud_window(disp).particle_msd, dtype=float)
    out[0] = 0.0
    return out


def mean_displacement(disp: np.ndarray) -> np.ndarray:
    """Window- and particle-averaged displacement vector per lag, shape (T, 2)."""
    return window_mean(disp.mean(axis=1))  # (T, 2) mean over particles


def window_mean(c: np.ndarray) -> np.ndarray:
    """Window average ``mean_k (c[k + m] - c[k])`` per lag ``m`` of a series ``c`` (T, 2)."""
    T = c.shape[0]
    cs = np.concatenate([np.zeros((1, 2)), np.cumsum(c, axis=0)])  # cs[k] = sum_{<k}
    m = np.arange(T)
    # mean_k (c[k+m] - c[k]) over k = 0..T-1-m, via prefix sums
    tail = cs[T] - cs[m]  # sum_{k=m}^{T-1} c[k]
    head = cs[T - m]  # sum_{k=0}^{T-1-m} c[k]
    return (tail - head) / (T - m)[:, None]


def msd_curve(unwrapped: np.ndarray, *, subtract_drift: bool = True, n_blocks: int = 16):
    """Window-averaged MSD (variance form) for all lags, with per-block curves.

    Parameters
    ----------
    unwrapped : ndarray, shape (T, N, 2)
        Unwrapped centroids at equally spaced frames.
    subtract_drift : bool
        Remove the centre-of-mass displacement of every frame first (default).
    n_blocks : int
        Number of disjoint cell subsets (cells ``i`` with ``i % n_blocks == b``) whose
        MSDs are returned as well, for the error of the diffusion fit.

    Returns
    -------
    msd : ndarray, shape (T,)
        MSD at lag ``m`` frames, ``msd[0] = 0``.
    msd_blocks : ndarray, shape (B, T)
        The same estimator restricted to each block, ``B = min(n_blocks, N)``.
    """
    x = np.asarray(unwrapped, dtype=float)
    if x.ndim != 3 or x.shape[-1] != 2:
        raise ValueError(f"unwrapped must have shape (T, N, 2); got {x.shape}")
    T, N, _ = x.shape
    if T < 2:
        raise ValueError("need at least two frames for an MSD")
    disp = drift_subtracted(x) if subtract_drift else x - x[:1]
    mean_sq = np.sum(mean_displacement(disp) ** 2, axis=-1)
    B = max(1, min(int(n_blocks), N))
    blocks = np.empty((B, T))
    weights = np.empty(B)
    for b in range(B):
        sub = disp[:, b::B]
        blocks[b] = _freud_msd(sub) - mean_sq
        weights[b] = sub.shape[1]
    msd = (weights[:, None] * blocks).sum(axis=0) / weights.sum()
    return msd, blocks


def log_lag_indices(T: int, n: int = 120) -> np.ndarray:
    """About ``n`` integer lags ``0 .. T-1``, logarithmically spaced (always incl. 0, 1, T-1)."""
    if T < 2:
        return np.zeros(1, dtype=np.int64)
    lags = np.unique(np.round(np.geomspace(1, T - 1, max(int(n), 2))).astype(np.int64))
    return np.concatenate([[0], lags])


def frame_drift(src) -> np.ndarray:
    """Mean over cells of ``x(t) - x(0)`` of a :class:`fcsweep.analysis.frames.FrameSource`,
    shape (T, 2), read a block of frames at a time (:func:`drift_subtracted` removes it).

    Raises
    ------
    ValueError
        Where a position is not finite.
    """
    x0 = src[0]
    out = np.empty((src.shape[0], 2))
    for s, e in src.frame_blocks():
        d = src.frames(s, e) - x0
        if not np.all(np.isfinite(d)):
            raise ValueError("non-finite positions")
        out[s:e] = d.mean(axis=1)
    return out


def block_displacements(xc: np.ndarray, drift: np.ndarray | None) -> np.ndarray:
    """Displacements from frame 0 of a block of cells ``xc`` (T, n, 2), less the drift of
    all cells (:func:`frame_drift`; None: none removed): :func:`drift_subtracted` cell by cell."""
    d = xc - xc[:1]
    return d if drift is None else d - drift[:, None, :]


def msd_curve_streamed(src, *, subtract_drift: bool = True, block_bytes: int | None = None,
                       drift: np.ndarray | None = None) -> np.ndarray:
    """:func:`msd_curve` (its ``msd``, one block) of a frame source, a block of cells at a time.

    Parameters
    ----------
    src : fcsweep.analysis.frames.FrameSource
        Unwrapped centroids, shape (T, N, 2).
    subtract_drift : bool
    block_bytes : int, optional
        Bytes of one block of cells over all frames
        (default :data:`fcsweep.analysis.frames.BLOCK_BYTES`).
    drift : ndarray, shape (T, 2), optional
        :func:`frame_drift` of ``src`` where already known.

    Returns
    -------
    ndarray, shape (T,)
        The same curve as ``msd_curve(x, n_blocks=1)[0]`` within rounding (each cell's
        window MSD is freud's on the same displacements; only the sums over cells are
        split), with a peak memory of a few blocks instead of several ``(T, N, 2)`` arrays.
    """
    T, N = src.shape[:2]
    if T < 2:
        raise ValueError("need at least two frames for an MSD")
    if not subtract_drift:
        drift = None
    elif drift is None:
        drift = frame_drift(src)
    total = np.zeros(T)
    csum = np.zeros((T, 2))
    for lo, hi in src.cell_blocks(block_bytes):
        for _, xc in work_blocks(src.cells(lo, hi)):
            disp = block_displacements(xc, drift)
            total += particle_msd(disp).sum(axis=1)
            csum += disp.sum(axis=1)
    return total / N - np.sum(window_mean(csum / N) ** 2, axis=-1)
