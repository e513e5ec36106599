"""Shape index q = P / sqrt(pi R0^2) per cell and frame, and its statistics."""

from __future__ import annotations

import numpy as np

from fcsweep.model.settings import Q_BINS, Q_RANGE, SETTINGS
from fcsweep.model.shape import Q_CIRCLE, Q_STAR, amplitude_sum, shape_index

#: Default histogram edges of q: width 0.01 from 3.54 (just below 2 sqrt(pi)) to 5.04 (the
#: analysis setting ``q_edges``).
Q_EDGES = np.round(np.linspace(*Q_RANGE, Q_BINS + 1), 10)
#: Quadrature points for the perimeter; spectral convergence makes 1024 exact to
#: ~1e-9 for admissible shapes up to M = 6 even at 98% of the admissibility
#: bound (256 points: 1e-5 there; checked in tests against scipy.integrate.quad).
Q_POINTS = SETTINGS["q_points"].default


#: Fewer quadrature points suffice for smaller shapes: (largest amplitude sum s, points),
#: each with a worst-case error below 3e-14 in q over random and single-mode shapes of
#: M = 6 (the trapezoidal rule converges geometrically, slower as s nears the bound,
#: where the full ``points`` are used: 5e-8 at 0.999 of it with 1024).
Q_TIERS = ((0.2, 256), (0.35, 512))


def shape_indices(a: np.ndarray, b: np.ndarray, R0: float = 1.0, points: int = Q_POINTS,
                  chunk: int = 256) -> np.ndarray:
    """Shape index of every cell.

    Parameters
    ----------
    a, b : ndarray, shape (..., M-1)
        Mode amplitudes (mode ``n = k + 2`` in column ``k``); width 0 means rigid discs.
    R0 : float
    points : int
        Perimeter quadrature points for shapes near the admissibility bound; cells with
        smaller amplitude sums use the fewer points of ``Q_TIERS`` (when M <= 6).
    chunk : int
        Cells per vectorised block: 256 cells x 1024 points keep the work arrays in
        cache (7x faster than blocks of 20000 cells).

    Returns
    -------
    ndarray, shape (...)
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    lead = a.shape[:-1]
    if a.shape[-1] == 0:
        return np.full(lead, Q_CIRCLE)
    fa = a.reshape(-1, a.shape[-1])
    fb = b.reshape(-1, b.shape[-1])
    out = np.empty(fa.shape[0])
    tier = np.full(fa.shape[0], int(points))
    if fa.shape[-1] <= 5:
        s = amplitude_sum(fa, fb)
        for s_max, k in reversed(Q_TIERS):
            tier[s <= s_max] = min(k, int(points))
    for k in np.unique(tier):
        idx = np.flatnonzero(tier == k)
        for lo in range(0, idx.size, chunk):
            sel = idx[lo:lo + chunk]
            out[sel] = shape_index(fa[sel], fb[sel], R0, int(k))
    return out.reshape(lead)


def q_statistics(q: np.ndarray, edges: np.ndarray = Q_EDGES, q_star: float = Q_STAR) -> dict:
    """Mean, spread, histogram and fraction above q* of shape indices pooled over cells and frames.

    Values outside ``edges`` are counted in the first or last bin.

    Returns
    -------
    dict
        ``q_mean``, ``q_std``, ``q_frac_above`` (fraction with q > q_star), ``q_hist``
        (probability density over the bins, integrating to 1) and ``q_edges``.
    """
    q = np.asarray(q, dtype=float).ravel()
    q = q[np.isfinite(q)]
    edges = np.asarray(edges, dtype=float)
    nb = len(edges) - 1
    if q.size == 0:
        return {"q_mean": np.nan, "q_std": np.nan, "q_frac_above": np.nan,
                "q_hist": np.full(nb, np.nan), "q_edges": edges}
    counts, _ = np.histogram(np.clip(q, edges[0], np.nextafter(edges[-1], -np.inf)), bins=edges)
    dens = counts / (q.size * np.diff(edges))
    return {"q_mean": float(q.mean()), "q_std": float(q.std()),
            "q_frac_above": float(np.mean(q > q_star)), "q_hist": dens, "q_edges": edges}


class QStatistics:
    """:func:`q_statistics` accumulated over blocks of frames (:meth:`add` each block of
    ``q``, shape (F, N)), and the per-frame ``<q>`` and fraction above q*.

    The pooled mean and spread combine the blocks' own (Chan et al.), the histogram and
    the count above q* add up; with one block every number is :func:`q_statistics`'s.
    """

    def __init__(self, edges: np.ndarray = Q_EDGES, q_star: float = Q_STAR):
        self.edges = np.asarray(edges, dtype=float)
        self.q_star = q_star
        self.n, self.mean, self.m2, self.above = 0, 0.0, 0.0, 0
        self.counts = np.zeros(len(self.edges) - 1, dtype=np.int64)
        self.frame_mean, self.frame_above, self.finite = [], [], True

    def add(self, q: np.ndarray) -> None:
        """Add the shape indices of a block of frames, shape (F, N)."""
        q = np.asarray(q, dtype=float)
        self.finite = self.finite and bool(np.all(np.isfinite(q)))
        self.frame_mean.append(q.mean(axis=1))
        self.frame_above.append((q > self.q_star).mean(axis=1))
        v = q.ravel()
        v = v[np.isfinite(v)]
        if v.size == 0:
            return
        e = self.edges
        self.counts += np.histogram(np.clip(v, e[0], np.nextafter(e[-1], -np.inf)), bins=e)[0]
        self.above += int(np.count_nonzero(v > self.q_star))
        mean = v.sum() / v.size
        dev = v - mean
        m2 = float(np.sum(dev * dev))
        n = self.n + v.size
        delta = mean - self.mean
        self.mean = mean if self.n == 0 else self.mean + delta * v.size / n
        self.m2 = m2 if self.n == 0 else self.m2 + m2 + delta * delta * self.n * v.size / n
        self.n = n

    def result(self) -> dict:
        """The dict of :func:`q_statistics`, plus ``q_mean_frames`` and ``q_frac_above_frames``."""
        nb = len(self.edges) - 1
        series = {"q_mean_frames": np.concatenate(self.frame_mean) if self.frame_mean else np.zeros(0),
                  "q_frac_above_frames": np.concatenate(self.frame_above) if self.frame_above else np.zeros(0)}
        if self.n == 0:
            return {"q_mean": np.nan, "q_std": np.nan, "q_frac_above": np.nan,
                    "q_hist": np.full(nb, np.nan), "q_edges": self.edges, **series}
        return {"q_mean": float(self.mean), "q_std": float(np.sqrt(self.m2 / self.n)),
                "q_frac_above": float(self.above / self.n), "q_hist": self.counts / (self.n * np.diff(self.edges)),
                "q_edges": self.edges, **series}
