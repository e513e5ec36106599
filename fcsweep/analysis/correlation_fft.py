"""Pair correlation functions of one frame by FFT on a grid, in O(M log M) with M ~ N.

The pair-count estimators of :mod:`fcsweep.analysis.order` sum a weight product over all
ordered pairs ``i != j`` out to half the box, O(N^2) per frame.  Here the same estimators
are computed from fields on a periodic grid:

1. **Deposit** (nearest grid point): the box ``Lx x Ly`` is cut into ``nx x ny`` cells of
   side ``hx = Lx / nx``, ``hy = Ly / ny`` (``nx = next_fast_len(ceil(Lx / h))``), and
   each cell's field is the sum of the per-particle weights ``w_i`` of the centres in it:
   ``1`` (density), ``psi6_i`` (bond order) or ``exp(i G . r_i)`` (first Bragg shell).
2. **Autocorrelate**: ``C(d) = sum_c Re[W(c + d) W(c)^*]`` for every grid displacement
   ``d`` by ``irfft2(|rfft2 Re W|^2 + |rfft2 Im W|^2)``; ``C(d)`` is the sum of
   ``Re[w_j w_i^*]`` over the ordered pairs whose *cells* are ``d`` apart (minimum image).
   The self-pairs, ``sum_i |w_i|^2``, are taken out of ``d = 0``.
3. **Bin** the grid displacements as the pair version bins the pair vectors (``|d|`` into
   ``[k dr, (k + 1) dr)``; for ``G_r(dx, 0)`` the strip ``|d_y'| < dx/2`` of ``d`` rotated by
   ``-orientation``, binned in ``|d_x'|``) and divide by the density autocorrelation
   binned alike: the pair count of the bin.

With nearest-grid-point deposit this is *exactly* the pair-count estimator applied to the
centres moved to their cell centres: every pair is counted once (the sum rule
``sum_bins counts = pairs in range`` holds in integers), with its exact weight product
``Re[w_j w_i^*]`` (the phases ``psi6_i`` and ``G . r_i`` are taken at the true positions),
only binned by its cells' separation instead of its own.  That separation differs from
the true one by the difference of two rounding errors, at most ``hx`` and ``hy`` per
component (``|delta| <= sqrt(2) h``; standard deviation ``h / sqrt(6)`` per component):
a pair moves at most one bin when ``h <= dr / sqrt(2)``, the default
(``GRID_PER_BIN``).  The curves are then the pair curves smoothed over about
``0.4 h`` in ``r``; ``G_r`` peaks, a histogram of the separations themselves, are
broadened by that much (a relative height loss ``~ (0.4 h / width)^2 / 2``).

Cost: ``M = (Lx / h)(Ly / h) = N (sqrt(3) / 2) (a / h)^2`` cells (``a`` the mean
spacing).  At the pipeline's bins (``dr = 0.1 R0``, about ``a / 20``) and the default
``h = dr / sqrt(2)``, ``M ~ 700 N`` (measured 730-750).  The grid work is one real FFT
per real weight and two per complex one (its real and imaginary parts): 1 + 2 + 3 x 2
for the counts, psi6 and three G vectors, one inverse per estimator, and O(M) binning.
Each weighted autocorrelation is binned and dropped before the next, so the float64
working memory is about ``5 x 8 M`` bytes (the count grid, one field, its half spectrum
and their sum).

A coarser grid (``h`` given) keeps the fits but not the bin-by-bin bound: on 64 x 64
harmonic crystals (10 frames, ``dr = dx = 0.1 a``) the exponents and labels of
:mod:`fcsweep.analysis.kthny` read from grids of ``h = a / 14`` (the default), ``a / 8``
and ``a / 4`` were eta_G1 = 0.133, 0.133, 0.141 (pair count 0.148 +- 0.019, solid) and
0.546, 0.539, 0.526 (pair count 0.572 +- 0.096, hexatic), every label the pair count's.
At ``h = a / 4`` (``M ~ 14 N``) the grid is 50x smaller than the default at the
pipeline's bins (``M ~ 700 N``).

Lengths are in the units of the positions passed in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft

from fcsweep.analysis.order import bin_centres, max_range

#: Default grid spacing ``h = dr / GRID_PER_BIN``: a pair's cells' separation then lies
#: in the pair's own radial bin or a neighbour (``|delta| <= sqrt(2) h = dr``).
GRID_PER_BIN = np.sqrt(2.0)

#: Most grid cells :func:`pipeline_spacing` allows (2^25: about 1.3 GB of float64 working
#: memory, ``5 x 8 M`` bytes); reached at N ~ 48 000 at the pipeline's bins and density 0.95.
MAX_GRID_CELLS = 2 ** 25

#: Rows of displacement grid binned per block (bounds the temporaries to ~ ROWS x ny).
_ROWS = 256


@dataclass(frozen=True)
class Grid:
    """A periodic ``nx x ny`` grid over the box ``(Lx, Ly)``.

    Attributes
    ----------
    box : tuple of float
    shape : tuple of int
        ``(nx, ny)``.
    """

    box: tuple
    shape: tuple

    @property
    def spacing(self) -> tuple:
        """Cell sides ``(hx, hy)``."""
        return self.box[0] / self.shape[0], self.box[1] / self.shape[1]

    @property
    def size(self) -> int:
        """Number of cells ``M``."""
        return self.shape[0] * self.shape[1]


def make_grid(box, h: float) -> Grid:
    """The grid of cells no wider than ``h`` (FFT-friendly sizes, ``scipy.fft.next_fast_len``)."""
    Lx, Ly = float(box[0]), float(box[1])
    n = [scipy.fft.next_fast_len(max(int(np.ceil(L / float(h) - 1e-9)), 1), real=True) for L in (Lx, Ly)]
    return Grid((Lx, Ly), (int(n[0]), int(n[1])))


def pipeline_spacing(box, dr: float, dx: float, max_cells: int = MAX_GRID_CELLS) -> float:
    """Grid spacing of the analysis pipeline: the default ``min(dr, dx) / GRID_PER_BIN``
    (every pair within a bin of its own) while the grid has at most ``max_cells`` cells,
    else the spacing of ``max_cells`` cells over the box, so that the memory stays bounded
    at any N.

    With ``N`` centres at mean spacing ``a`` the coarse spacing is
    ``h = a sqrt((sqrt(3) / 2) N / max_cells)``: ``a / 6.2`` at N = 10^6 (validated range
    of the module doc: ``a / 14`` to ``a / 4``).  The curves are then the pair curves
    smoothed over about ``0.4 h``; once ``h`` exceeds ``dx`` (N of a few 10^5) the strip of
    ``G_r`` holds no grid displacement in some of its bins (NaN there).
    """
    h = min(float(dr), float(dx)) / GRID_PER_BIN
    return max(h, float(np.sqrt(float(box[0]) * float(box[1]) / float(max_cells))))


def cell_index(pos: np.ndarray, grid: Grid) -> np.ndarray:
    """Flat index (row-major ``(nx, ny)``) of the cell of each centre (nearest grid point)."""
    pos = np.asarray(pos, dtype=float)
    nx, ny = grid.shape
    hx, hy = grid.spacing
    ix = np.floor(np.mod(pos[:, 0], grid.box[0]) / hx).astype(np.int64) % nx
    iy = np.floor(np.mod(pos[:, 1], grid.box[1]) / hy).astype(np.int64) % ny
    return ix * ny + iy


def _power(idx: np.ndarray, grid: Grid, weights, workers: int) -> np.ndarray:
    """``|FFT W|^2`` summed over the real and imaginary part of the deposited weights."""
    out = None
    w = np.ones(idx.size) if weights is None else np.asarray(weights)
    parts = (w.real, w.imag) if np.iscomplexobj(w) else (w,)
    for part in parts:
        field = np.bincount(idx, weights=part, minlength=grid.size).reshape(grid.shape)
        F = scipy.fft.rfft2(field, workers=workers)
        del field
        p = F.real ** 2 + F.imag ** 2
        del F
        if out is None:
            out = p
        else:
            out += p
    return out


def autocorrelation(pos: np.ndarray, grid: Grid, weights=None, *, workers: int = 1) -> np.ndarray:
    """``C(d) = sum_{i != j, cell_j - cell_i = d} Re[w_j w_i^*]`` on the grid's displacements.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    grid : Grid
    weights : ndarray, shape (N,), optional
        Real or complex per-centre weights (default 1: pair counts).
    workers : int
        Threads of ``scipy.fft``.

    Returns
    -------
    ndarray, shape (nx, ny)
        Indexed by ``d = (p hx, q hy)`` at ``[p mod nx, q mod ny]``; self-pairs removed.
        Pair counts (``weights`` None) are rounded to integers.
    """
    idx = cell_index(pos, grid)
    C = scipy.fft.irfft2(_power(idx, grid, weights, workers), s=grid.shape, workers=workers)
    if weights is None:
        C = np.rint(C)
        C[0, 0] -= idx.size
    else:
        C[0, 0] -= float(np.sum(np.abs(np.asarray(weights)) ** 2))
    return C


def _row_blocks(grid: Grid):
    """Blocks of rows of minimum-image displacements ``(rows, dx (R, 1), dy (1, ny))``."""
    nx, ny = grid.shape
    hx, hy = grid.spacing
    q = np.arange(ny)
    dy = (np.where(q < (ny + 1) // 2, q, q - ny) * hy)[None, :]
    for lo in range(0, nx, _ROWS):
        p = np.arange(lo, min(lo + _ROWS, nx))
        yield slice(lo, p[-1] + 1), (np.where(p < (nx + 1) // 2, p, p - nx) * hx)[:, None], dy


def radial_sums(grid: Grid, fields, dr: float, n_bins: int) -> list:
    """Sums of grid fields over the displacements with ``|d|`` in ``[k dr, (k + 1) dr)``, ``k < n_bins``."""
    out = [np.zeros(n_bins) for _ in fields]
    for rows, dx, dy in _row_blocks(grid):
        k = (np.sqrt(dx * dx + dy * dy) / dr).astype(np.int64).ravel()
        keep = k < n_bins
        for s, f in zip(out, fields):
            s += np.bincount(k[keep], weights=f[rows].ravel()[keep], minlength=n_bins)
    return out


def strip_sums(grid: Grid, field: np.ndarray, orientation: float, dx: float, n_bins: int):
    """Sum of a grid field over the displacements in the strip of :func:`order.gr_cut`.

    The displacement rotated by ``-orientation`` is kept if ``|d_y'| < dx / 2`` and binned
    in ``|d_x'|`` into ``[k dx, (k + 1) dx)``, ``k < n_bins`` (the last bin closed, as
    ``numpy.histogram``'s).

    Returns
    -------
    sums, cells : ndarray, shape (n_bins,)
        The field summed per bin, and the number of grid displacements in each bin.
    """
    c, s = np.cos(orientation), np.sin(orientation)
    out = np.zeros(n_bins)
    cells = np.zeros(n_bins)
    top = n_bins * dx
    for rows, ddx, ddy in _row_blocks(grid):
        xr = np.abs(c * ddx + s * ddy).ravel()
        yr = (-s * ddx + c * ddy).ravel()
        keep = (np.abs(yr) < dx / 2) & (xr <= top)
        k = np.minimum((xr[keep] / dx).astype(np.int64), n_bins - 1)
        out += np.bincount(k, weights=field[rows].ravel()[keep], minlength=n_bins)
        cells += np.bincount(k, minlength=n_bins)
    return out, cells


def _ratio(sums: np.ndarray, counts: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(counts > 0, sums / counts, np.nan)


@dataclass
class Correlations:
    """Result of :func:`correlations` (NaN where a bin holds no pair).

    Attributes
    ----------
    r : ndarray, shape (B,)
        Radial bin centres (as :func:`order.bin_centres`).
    counts : ndarray, shape (B,)
        Ordered pairs per radial bin (by their cells' separation).
    G6, C_G1 : ndarray, shape (B,) or None
        As :func:`order.g6` and :func:`order.shell_correlation` (None if not asked for).
    x, Gr : ndarray or None
        As :func:`order.gr_cut` (``Gr`` NaN where no grid displacement lies in a strip
        bin, which only a grid coarser than ``dx`` leaves).
    grid : Grid
    """

    r: np.ndarray
    counts: np.ndarray
    G6: np.ndarray | None
    C_G1: np.ndarray | None
    x: np.ndarray | None
    Gr: np.ndarray | None
    grid: Grid


def correlations(pos: np.ndarray, box, *, psi=None, G=None, orientation: float | None = None,
                 dr: float = 0.1, dx: float = 0.2, r_max: float | None = None, h: float | None = None,
                 workers: int = 1) -> Correlations:
    """``G6(r)``, ``C_G1(r)`` and ``G_r(dx, 0)`` of one frame from one grid (module doc).

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
        Centres in the periodic box.
    box : (Lx, Ly)
    psi : ndarray, shape (N,), optional
        ``psi6`` of each centre (:func:`order.psi6`): gives ``G6``.
    G : ndarray, shape (K, 2), optional
        Reciprocal vectors (:func:`order.first_shell_vectors`): gives ``C_G1``.
    orientation : float, optional
        ``arg(Psi6) / 6`` (:func:`order.global_psi6`): gives ``G_r(dx, 0)``.
    dr, dx : float
        Radial bin width (G6, C_G1) and strip bin width (G_r), as the pair versions.
    r_max : float, optional
        Range (default and cap :func:`order.max_range`).
    h : float, optional
        Grid spacing (default ``min(dr, dx) / GRID_PER_BIN``).
    workers : int
        Threads of ``scipy.fft``.

    Returns
    -------
    Correlations
    """
    pos = np.asarray(pos, dtype=float)
    N = pos.shape[0]
    r_max = max_range(box) if r_max is None else min(r_max, max_range(box))
    want_gr = orientation is not None
    h = (min(dr, dx) if want_gr else dr) / GRID_PER_BIN if h is None else float(h)
    grid = make_grid(box, h)
    r = bin_centres(r_max, dr)
    P = autocorrelation(pos, grid, workers=workers)
    counts = radial_sums(grid, [P], dr, r.size)[0]
    G6 = C_G1 = None
    # each weighted autocorrelation is binned and dropped before the next (memory ~ 3 grids)
    if psi is not None:
        s6 = radial_sums(grid, [autocorrelation(pos, grid, np.asarray(psi, dtype=complex), workers=workers)],
                         dr, r.size)[0]
        G6 = _ratio(s6, counts)
    if G is not None:
        G = np.asarray(G, dtype=float).reshape(-1, 2)
        idx = cell_index(pos, grid)
        spec = None
        for g in G:
            p = _power(idx, grid, np.exp(1j * (pos @ g)), workers)
            if spec is None:
                spec = p
            else:
                spec += p
            del p
        CG = scipy.fft.irfft2(spec, s=grid.shape, workers=workers) / G.shape[0]
        del spec
        CG[0, 0] -= N
        C_G1 = _ratio(radial_sums(grid, [CG], dr, r.size)[0], counts)
        del CG
    x = Gr = None
    if want_gr:
        x_max = np.sqrt(max(r_max ** 2 - (dx / 2) ** 2, 0.0))
        x = bin_centres(x_max, dx)
        if x.size and N >= 2:
            pairs, cells = strip_sums(grid, P, float(orientation), dx, x.size)
            # the strip is a few cells wide: the grid displacements in a bin cover an area
            # that beats with the grid (1 to 2 cells per bin at dx = 1.5 h), so the ideal
            # count is per cell, N (N - 1) / M, not per area 2 dx^2
            with np.errstate(invalid="ignore", divide="ignore"):
                Gr = np.where(cells > 0, pairs / (N * (N - 1) / grid.size * cells), np.nan)
        else:
            Gr = np.full(x.shape, np.nan)
    return Correlations(r, counts, G6, C_G1, x, Gr, grid)


def g6(pos: np.ndarray, box, psi: np.ndarray, *, dr: float = 0.1, r_max: float | None = None,
       h: float | None = None):
    """:func:`order.g6` by FFT: bin centres and ``G6`` (NaN where a bin holds no pair)."""
    c = correlations(pos, box, psi=psi, dr=dr, r_max=r_max, h=h)
    return c.r, c.G6


def gr_cut(pos: np.ndarray, box, orientation: float, *, dx: float = 0.2, r_max: float | None = None,
           h: float | None = None):
    """:func:`order.gr_cut` by FFT: bin centres of ``|dx'|`` and ``G_r(dx, 0)``."""
    c = correlations(pos, box, orientation=orientation, dx=dx, dr=dx, r_max=r_max, h=h)
    return c.x, c.Gr


def shell_correlation(pos: np.ndarray, box, G: np.ndarray, *, dr: float = 0.1, r_max: float | None = None,
                      h: float | None = None):
    """:func:`order.shell_correlation` by FFT (from positions, not pair vectors): ``r``, ``C_G1``."""
    c = correlations(pos, box, G=G, dr=dr, r_max=r_max, h=h)
    return c.r, c.C_G1
