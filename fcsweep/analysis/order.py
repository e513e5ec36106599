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
- ``C_G1(r) = Re < psi_G,i psi_G,j^* >`` with ``psi_G,i = exp(i G . r_i)``, i.e. the mean of
  ``cos(G . (r_j - r_i))`` over pairs at minimum-image distance in ``[r, r + dr)``, averaged
  over the first-shell reciprocal vectors ``G`` of the crystal (:func:`first_shell_vectors`,
  :func:`shell_correlation`).  For a crystal ``C_G1 ~ r^(-eta_G1)``: the translational
  exponent that KTHNY's 1/3 bounds.

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
           r_max: float | None = None, vectors: np.ndarray | None = None):
    """Translational correlation along the hexatic axis, ``G_r(dx, 0)``.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    box : (Lx, Ly)
    orientation : float
        Mean hexatic orientation ``arg(Psi6)/6`` (radians).
    dx : float
        Bin width in both directions (the strip is ``|dy'| < dx/2``).
    vectors : ndarray, optional
        The pair vectors of :func:`pair_vectors` out to at least ``r_max`` (computed if
        not given; pass them to share one pair query with :func:`shell_correlation`).

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
    v = pair_vectors(pos, box, r_max) if vectors is None else vectors
    c, s = np.cos(orientation), np.sin(orientation)
    xr = c * v[:, 0] + s * v[:, 1]
    yr = -s * v[:, 0] + c * v[:, 1]
    sel = np.abs(yr) < dx / 2
    counts, _ = np.histogram(np.abs(xr[sel]), bins=np.arange(x.size + 1) * dx)
    area = float(box[0]) * float(box[1])
    ideal = N * (N - 1) / area * 2.0 * dx * dx
    return x, counts / ideal


#: ``|G1| a`` of a triangular lattice of spacing ``a``: the first Bragg shell.
G1_SPACING = 4.0 * np.pi / np.sqrt(3.0)


def _structure_factor(pos: np.ndarray, G: np.ndarray) -> np.ndarray:
    """``|sum_i exp(i G . r_i)|^2 / N`` for each row of ``G`` (M, 2)."""
    ph = pos @ G.T
    return (np.cos(ph).sum(axis=0) ** 2 + np.sin(ph).sum(axis=0) ** 2) / pos.shape[0]


def first_shell_vectors(pos: np.ndarray, box, orientation: float, spacing: float, *,
                        search: int = 4) -> np.ndarray:
    """The first-shell reciprocal vectors of a crystal, from its structure factor's peaks.

    The first guesses are ``|G| = 4 pi / (sqrt(3) a)`` at ``orientation + 30 + k 60`` degrees
    (``k = 0, 1, 2``; the other three are their negatives and give the same correlation).
    Each is moved to the largest ``S(G) = |sum_i exp(i G . r_i)|^2 / N`` on the box's
    reciprocal lattice ``2 pi (m / Lx, n / Ly)`` within ``search`` modes of the guess: a
    crystal grown from disorder need be neither at the density's spacing nor aligned with
    the box, but a crystal that wraps around a periodic box has its Bragg peaks on box
    modes.  (A search between the box modes picks maxima shifted by noise: on a
    commensurate harmonic crystal, 1/8 of a mode off in one of two frames, which turns
    ``cos(G . r)`` by 0.5 rad at ``r = L/2``.)  At ``r ~ L/2`` an error of one mode turns
    it half a period, hence the search rather than the guess.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    box : (Lx, Ly)
    orientation : float
        Mean hexatic orientation ``arg(Psi6) / 6`` (radians).
    spacing : float
        Neighbour spacing ``a``.
    search : int
        Search half-width in box modes (4 modes: 3 degrees of orientation at L = 64 a).

    Returns
    -------
    ndarray, shape (3, 2)
    """
    pos = np.asarray(pos, dtype=float)
    dk = 2.0 * np.pi / np.array([float(box[0]), float(box[1])])
    m = np.arange(-search, search + 1)
    grid = np.stack(np.meshgrid(m, m), -1).reshape(-1, 2)
    out = np.empty((3, 2))
    for k in range(3):
        th = orientation + np.pi / 6.0 + k * np.pi / 3.0
        g0 = G1_SPACING / float(spacing) * np.array([np.cos(th), np.sin(th)])
        trial = (np.round(g0 / dk) + grid) * dk
        out[k] = trial[int(np.argmax(_structure_factor(pos, trial)))]
    return out


def shell_correlation(vectors: np.ndarray, G: np.ndarray, *, dr: float = 0.1, r_max: float,
                      chunk: int = 1 << 21):
    """First-shell translational correlation ``C_G1(r)`` from pair vectors.

    ``C_G1(r)`` is the mean of ``cos(G . d_ij)`` over the pair vectors ``d_ij`` with
    ``|d_ij|`` in ``[r, r + dr)`` and over the rows of ``G`` (the same bins as :func:`g6`).
    Since ``cos(G . (r_j - r_i)) = Re[psi_G,j psi_G,i^*]`` this is the correlation of
    ``psi_G,i = exp(i G . r_i)``.  One pass over the pairs of the query shared with
    :func:`gr_cut`, in single precision (freud's own; ``G . d`` stays within 1e-4 rad):
    about the cost of :func:`g6`.

    Parameters
    ----------
    vectors : ndarray, shape (P, 2)
        Pair vectors (:func:`pair_vectors`), out to at least ``r_max``.
    G : ndarray, shape (M, 2)
        Reciprocal vectors (:func:`first_shell_vectors`).
    dr, r_max : float
        Bin width and range (whole bins, as :func:`bin_centres`).

    Returns
    -------
    r : ndarray, shape (B,)
        Bin centres.
    C : ndarray, shape (B,)
        NaN where a bin holds no pair.
    """
    r = bin_centres(r_max, dr)
    sums = np.zeros(r.size)
    counts = np.zeros(r.size)
    G = np.asarray(G, dtype=np.float32).reshape(-1, 2)
    for lo in range(0, vectors.shape[0], chunk):
        x = np.asarray(vectors[lo:lo + chunk, 0], dtype=np.float32)
        y = np.asarray(vectors[lo:lo + chunk, 1], dtype=np.float32)
        idx = (np.sqrt(x * x + y * y) * np.float32(1.0 / dr)).astype(np.int64)
        keep = idx < r.size
        x, y, idx = x[keep], y[keep], idx[keep]
        c = np.zeros(x.size, dtype=np.float32)
        for g in G:
            c += np.cos(x * g[0] + y * g[1])
        sums += np.bincount(idx, weights=c, minlength=r.size) / G.shape[0]
        counts += np.bincount(idx, minlength=r.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        return r, np.where(counts > 0, sums / counts, np.nan)
