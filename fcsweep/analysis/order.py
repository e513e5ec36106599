"""Hexatic order and correlation functions (freud), positions in a periodic 2-D box.

- ``psi6_i = (1/n_i) sum_j exp(6 i theta_ij)`` over the Voronoi neighbours (unweighted,
  docs/model.md), via ``freud.order.Hexatic(k=6)`` on the Voronoi neighbour list.
- ``|Psi6| = |mean_i psi6_i|``; the mean hexatic orientation is ``arg(Psi6) / 6``.
- ``G6(r) = Re < psi6_i psi6_j^* >`` over pairs at distance in ``[r, r + dr)``
  (``freud.density.CorrelationFunction``); bins without pairs are NaN.
- ``G_r(dx, 0)``: ordered pairs ``i != j`` with minimum-image separation rotated by
  ``-arg(Psi6)/6`` (so a lattice direction lies along x), kept if ``|dy'| < h/2``,
  histogrammed in ``|dx'|`` with bin width ``h``, divided by the ideal-gas expectation
  ``N (N - 1) / A * 2 h^2``.  It tends to 1 for an uncorrelated fluid.

Lengths are in the units of the positions passed in (the pipeline passes units of R0).
"""

from __future__ import annotations

import freud
import numpy as np

from fcsweep.analysis.voronoi import freud_system, voronoi_neighbors


def psi6(pos: np.ndarray, box, nlist=None) -> np.ndarray:
    """Local hexatic order of each cell over its Voronoi neighbours, complex (N,)."""
    system = freud_system(pos, box)
    if nlist is None:
        nlist = voronoi_neighbors(pos, box).nlist
    hx = freud.order.Hexatic(k=6, weighted=False)
    hx.compute(system, neighbors=nlist)
    return np.asarray(hx.particle_order, dtype=complex)


def global_psi6(psi: np.ndarray) -> tuple[float, float]:
    """``|Psi6|`` and the mean hexatic orientation ``arg(Psi6) / 6`` (radians)."""
    m = np.mean(np.asarray(psi))
    return float(np.abs(m)), float(np.angle(m) / 6.0)


def max_range(box) -> float:
    """Largest usable pair distance, just below half the smaller box side."""
    return 0.499 * float(min(box[0], box[1]))


def bin_centres(r_max: float, width: float) -> np.ndarray:
    """Centres ``(k + 1/2) width`` of the bins covering ``[0, r_max)`` (whole bins only)."""
    n = int(np.floor(r_max / width + 1e-9))
    return (np.arange(n) + 0.5) * width


def g6(pos: np.ndarray, box, psi: np.ndarray, *, dr: float = 0.1, r_max: float | None = None):
    """Bond-orientational correlation ``G6(r)``.

    Returns
    -------
    r : ndarray, shape (B,)
        Bin centres.
    G6 : ndarray, shape (B,)
        NaN where a bin holds no pair.
    """
    r_max = max_range(box) if r_max is None else min(r_max, max_range(box))
    r = bin_centres(r_max, dr)
    if r.size == 0:
        return r, r.copy()
    cf = freud.density.CorrelationFunction(bins=r.size, r_max=r.size * dr)
    cf.compute(freud_system(pos, box), values=np.asarray(psi, dtype=complex))
    val = np.real(np.asarray(cf.correlation, dtype=complex))
    cnt = np.asarray(cf.bin_counts)
    return r, np.where(cnt > 0, val, np.nan)


def pair_vectors(pos: np.ndarray, box, r_max: float) -> np.ndarray:
    """Minimum-image vectors ``r_j - r_i`` of all ordered pairs ``i != j`` closer than ``r_max``."""
    fbox, p3 = freud_system(pos, box)
    q = freud.locality.AABBQuery(fbox, p3)
    nl = q.query(p3, {"r_max": r_max, "exclude_ii": True}).toNeighborList()
    return np.asarray(nl.vectors, dtype=float)[:, :2]


def gr_cut(pos: np.ndarray, box, orientation: float, *, dx: float = 0.2,
           r_max: float | None = None):
    """Translational correlation along the hexatic axis, ``G_r(dx, 0)``.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    box : (Lx, Ly)
    orientation : float
        Mean hexatic orientation ``arg(Psi6)/6`` (radians).
    dx : float
        Bin width in both directions (the strip is ``|dy'| < dx/2``).

    Returns
    -------
    x : ndarray
        Bin centres of ``|dx'|``.
    Gr : ndarray
    """
    pos = np.asarray(pos, dtype=float)
    N = pos.shape[0]
    r_max = max_range(box) if r_max is None else min(r_max, max_range(box))
    x_max = np.sqrt(max(r_max ** 2 - (dx / 2) ** 2, 0.0))
    x = bin_centres(x_max, dx)
    if x.size == 0 or N < 2:
        return x, np.full(x.shape, np.nan)
    v = pair_vectors(pos, box, r_max)
    c, s = np.cos(orientation), np.sin(orientation)
    xr = c * v[:, 0] + s * v[:, 1]
    yr = -s * v[:, 0] + c * v[:, 1]
    sel = np.abs(yr) < dx / 2
    counts, _ = np.histogram(np.abs(xr[sel]), bins=np.arange(x.size + 1) * dx)
    area = float(box[0]) * float(box[1])
    ideal = N * (N - 1) / area * 2.0 * dx * dx
    return x, counts / ideal
