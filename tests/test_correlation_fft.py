"""The FFT correlation functions against the pair-count ones of the same estimators.

- Machinery, exact: with nearest-grid-point deposit the FFT sums are the pair sums of the
  cells' separations; checked pair by pair (brute force over the cell indices) for the
  counts, ``G6`` and ``C_G1`` sums, and the sum rule: the count autocorrelation holds
  every ordered pair ``i != j`` once, ``N (N - 1)`` in all, in integers.
- Against today's pair-count functions (order.g6, order.shell_correlation, order.gr_cut)
  on the true positions: a pair's cells' separation differs from its own by at most
  ``sqrt(2) h`` (``h`` the cell side), so over the windows of half a spacing the C_G1 fit
  uses, at most a fraction ``2 sqrt(2) h / w`` of a window's pairs (those that close to
  its two edges) can be exchanged with the neighbouring windows: a window mean moves by
  at most that fraction of the range of the curve over it and its neighbours.  G_r is a
  histogram in a strip one or two cells wide: the FFT strip and the exact one hold
  different pairs near their edges, so its windows agree within that bound plus the
  counting noise of the strip.
- The exponents kthny fits to the FFT curves (harmonic crystals, exact eta_G1 known) agree
  with those it fits to the pair-count curves within their errors, and the labels agree.
"""

import functools
import warnings

import numpy as np
import pytest
from synthetic import harmonic_crystal, triangular_crystal

from fcsweep.analysis import correlation_fft as cf
from fcsweep.analysis import kthny, order
from fcsweep.analysis.cage import neighbour_spacing


def _brute(pos, grid, w, dr, n_bins):
    """Per radial bin: ordered pairs i != j and the sum of Re[w_j w_i^*], binned by the
    minimum-image separation of their cells (the arithmetic of correlation_fft)."""
    nx, ny = grid.shape
    hx, hy = grid.spacing
    idx = cf.cell_index(pos, grid)
    ix, iy = idx // ny, idx % ny
    p = np.mod(ix[None, :] - ix[:, None], nx)
    q = np.mod(iy[None, :] - iy[:, None], ny)
    dx = np.where(p < (nx + 1) // 2, p, p - nx) * hx
    dy = np.where(q < (ny + 1) // 2, q, q - ny) * hy
    k = (np.sqrt(dx * dx + dy * dy) / dr).astype(np.int64)
    off = ~np.eye(len(pos), dtype=bool)
    keep = off & (k < n_bins)
    prod = np.real(w[None, :] * np.conj(w[:, None]))
    return (np.bincount(k[keep], minlength=n_bins).astype(float),
            np.bincount(k[keep], weights=prod[keep], minlength=n_bins))


def test_sum_rule_every_ordered_pair_once():
    """Random centres in an odd box: the count autocorrelation sums to N (N - 1) exactly."""
    rng = np.random.default_rng(0)
    box = (17.3, 11.9)
    pos = rng.uniform(0, 1, (700, 2)) * box
    for h in (0.05, 0.31, 1.7):  # cells much smaller than, about, and larger than the spacing
        C = cf.autocorrelation(pos, cf.make_grid(box, h))
        assert C.sum() == 700 * 699 and C.min() >= 0


@pytest.mark.parametrize("box", [(14.1, 12.2), (13.0, 13.0)])
def test_fft_sums_are_the_pair_sums_of_the_cells(box):
    """Counts exactly, G6 and C_G1 sums to rounding, pair by pair (odd and even grids)."""
    rng = np.random.default_rng(1)
    pos = rng.uniform(0, 1, (400, 2)) * box
    psi = rng.normal(size=400) + 1j * rng.normal(size=400)
    G = np.array([[3.1, 1.2], [-0.4, 2.9], [1.7, -2.2]])
    dr = 0.1
    c = cf.correlations(pos, box, psi=psi, G=G, dr=dr, h=0.07)
    n = c.r.size
    cnt, s6 = _brute(pos, c.grid, psi, dr, n)
    assert np.array_equal(c.counts, cnt)
    ok = cnt > 0
    assert np.allclose(c.G6[ok], s6[ok] / cnt[ok], rtol=0, atol=1e-9)
    sg = sum(_brute(pos, c.grid, np.exp(1j * pos @ g), dr, n)[1] for g in G) / 3
    assert np.allclose(c.C_G1[ok], sg[ok] / cnt[ok], rtol=0, atol=1e-9)
    assert np.all(np.isnan(c.G6[~ok]))


def _pair_and_fft(pos, box, dr=0.1, dx=0.1):
    ps = order.psi6(pos, box)
    _, ang = order.global_psi6(ps)
    G1 = order.first_shell_vectors(pos, box, ang, neighbour_spacing(len(pos), box))
    r, g = order.g6(pos, box, ps, dr=dr)
    v = order.pair_vectors(pos, box, order.max_range(box))
    x, gr = order.gr_cut(pos, box, ang, dx=dx, vectors=v)
    _, cg = order.shell_correlation(v, G1, dr=dr, r_max=order.max_range(box))
    c = cf.correlations(pos, box, psi=ps, G=G1, orientation=ang, dr=dr, dx=dx)
    assert np.allclose(c.r, r) and np.allclose(c.x, x)
    return r, x, (g, cg, gr), (c.G6, c.C_G1, c.Gr), c.grid


def _windows(r, y, w, lo):
    s = (r >= lo) & np.isfinite(y)
    k = np.floor(r[s] / w).astype(int)
    n = np.bincount(k)
    has = n > 0
    mean = np.bincount(k, weights=y[s])[has] / n[has]
    # range of the curve's bins over each window and its two neighbours
    ks = np.flatnonzero(has)
    rng = np.array([np.ptp(y[s][(k >= j - 1) & (k <= j + 1)]) for j in ks])
    return mean, rng, n[has]


@pytest.mark.parametrize("make", [lambda g: triangular_crystal(32, 0.1, g),
                                  lambda g: harmonic_crystal(32, 0.5, g)[0]], ids=["jittered", "harmonic"])
def test_curves_agree_with_the_pair_counts_window_by_window(make):
    """N = 1024 crystals, one frame, windows of half a spacing from 0.8 a on: G6 and C_G1
    within the exchange bound 2 sqrt(2) h / w of the local range (measured: deviations up to
    0.16 of it); G_r within that plus 4 sigma of the two strips' counting noise (up to 0.25)."""
    pos, box = make(np.random.default_rng(3))
    r, x, pair, fft, grid = _pair_and_fft(pos, box)
    w = 0.5
    frac = 2 * np.sqrt(2) * max(grid.spacing) / w
    for p, f in zip(pair[:2], fft[:2]):
        pm, rg, _ = _windows(r, p, w, 0.8)
        fm, _, _ = _windows(r, f, w, 0.8)
        assert np.all(np.abs(fm - pm) <= frac * rg + 1e-12), np.max(np.abs(fm - pm) / (frac * rg))
    pm, rg, nb = _windows(x, pair[2], w, 0.8)
    fm, _, _ = _windows(x, fft[2], w, 0.8)
    N = len(pos)
    ideal = N * (N - 1) / (box[0] * box[1]) * 2 * 0.1 * 0.1  # pairs per bin of G_r = 1
    sigma = np.sqrt(2 * np.maximum(pm, 1.0 / ideal) / (ideal * nb))  # difference of two strips' Poisson means
    assert np.all(np.abs(fm - pm) <= frac * rg + 4 * sigma), np.max(np.abs(fm - pm) / (frac * rg + 4 * sigma))


@functools.cache
def _harmonic_curves(n, eta, frames, seed):
    out = [_pair_and_fft(pos, box) for pos, box in harmonic_crystal(n, eta, np.random.default_rng(seed), frames=frames)]
    r, x = out[0][0], out[0][1]
    pair = [np.array([o[2][k] for o in out]) for k in range(3)]
    fft = [np.array([o[3][k] for o in out]) for k in range(3)]
    return r, x, pair, fft, out[0][4], harmonic_crystal(n, eta, np.random.default_rng(seed))[0][1]


def _fits(r, x, curves, box):
    def mean(c):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # bins without pairs in every frame
            return np.nanmean(c, axis=0), np.nanstd(c, axis=0, ddof=1) / np.sqrt(c.shape[0])

    (G6, G6e), (CG, CGe), (Gr, Gre) = (mean(c) for c in curves)
    return kthny.kthny_fits(r, G6, x, Gr, G6_err=G6e, Gr_err=Gre, C_G1=CG, C_G1_err=CGe, box=box)


def _check_exponents(n, eta, frames, seed, label=None):
    r, x, pair, fft, _, box = _harmonic_curves(n, eta, frames, seed)
    fp, ff = _fits(r, x, pair, box), _fits(r, x, fft, box)
    for k in ("eta_G1", "eta_6", "eta_T"):
        e_p, e_f = fp[f"{k}_err"], ff[f"{k}_err"]
        # C_G1 and G6 average the same pairs' weights: their fits differ by less than either's
        # error; the G_r strips (a cell or two wide) hold partly different pairs, so their
        # envelopes' exponents differ within the errors added in quadrature
        tol = np.hypot(e_p, e_f) if k == "eta_T" else max(e_p, e_f)
        assert abs(ff[k] - fp[k]) < tol, (k, fp[k], e_p, ff[k], e_f)
    lp = kthny.classify_kthny(fp, min_confidence=0.9)
    lf = kthny.classify_kthny(ff, min_confidence=0.9)
    assert lp.code == lf.code, (lp.reason, lf.reason)
    if label is not None:
        assert lf.code == label, lf.reason


def test_harmonic_crystal_exponents_agree_small():
    """32 x 32 harmonic crystal of eta_G1 = 0.5, 10 frames (measured: eta_G1 0.504 +- 0.125
    pair, 0.503 +- 0.126 FFT; eta_T 0.22 against 0.26, +- 0.10)."""
    _check_exponents(32, 0.5, 10, 7)


@pytest.mark.slow
@pytest.mark.parametrize("eta, label", [(0.15, kthny.KTHNY_SOLID), (0.5, kthny.KTHNY_HEXATIC)])
def test_harmonic_crystal_exponents_and_label_agree(eta, label):
    """64 x 64 (N = 4096), 10 frames, as tests/test_kthny.py: same exponents within errors
    and the same label as the pair-count curves (measured at eta_G1 = 0.5: eta_T 0.43 +- 0.10
    pair against 0.32 +- 0.05 FFT)."""
    _check_exponents(64, eta, 10, 7, label)


def test_grid_is_fft_friendly_and_no_coarser_than_asked():
    g = cf.make_grid((100.3, 50.1), 0.07)
    assert max(g.spacing) <= 0.07 and g.size == g.shape[0] * g.shape[1]
    # shapes chosen by scipy.fft.next_fast_len
    import scipy.fft
    assert all(scipy.fft.next_fast_len(n, real=True) == n for n in g.shape)
