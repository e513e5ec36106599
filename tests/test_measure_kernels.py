"""The compiled helpers of the shape estimators (fcsweep/measure/runs.py) against the library
operations they replace: each must give the same answer (bit for bit where it replicates the
operation order, to rounding where it solves the same problem another way), on random masks
and outlines, so that the per-cell cost can fall without moving any q (docs/measure.md,
"Cost and memory")."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial import cKDTree

from fcsweep.measure.cells import FIT_POINTS, MIN_INSCRIBED_RADIUS_PX, fit_radius
from fcsweep.measure.perimeter import gaussian_weights, padded
from fcsweep.measure.pixels import blurred_mask, edge_pixels, mixed_pixels, pieces_and_fit, resample
from fcsweep.measure.runs import count_outside, sharpest_bend


def _masks(seed, n=12):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        h, w = rng.integers(6, 40, size=2)
        yield ndimage.binary_opening(rng.random((h, w)) < 0.7) if rng.random() < 0.5 else rng.random((h, w)) < 0.6


def _blob(rng, r=12.0):
    """A star-shaped random mask (r px, a few modes), as bool."""
    yy, xx = np.mgrid[:40, :40] - 19.5 - rng.random(2)[:, None, None]
    phi = np.arctan2(yy, xx)
    R = r * (1 + sum(0.06 * rng.normal() * np.cos(k * phi + rng.uniform(0, 6)) for k in range(2, 6)))
    return np.hypot(xx, yy) < R


def test_blur_is_scipy_gaussian_filter_bit_for_bit():
    for mask in _masks(1):
        ref = ndimage.gaussian_filter(padded(mask, 5, np.float64), 1.0, mode="constant", truncate=4.0)
        assert np.array_equal(blurred_mask(mask, 5, gaussian_weights(1.0)), ref)


def test_resample_is_np_interp_bit_for_bit():
    rng = np.random.default_rng(2)
    for _ in range(30):
        k = int(rng.integers(3, 200))
        th = np.sort(rng.uniform(0, 2 * np.pi, k))
        line = np.stack([np.cos(th), np.sin(th)], 1) * (10 + rng.random((k, 1)))
        closed = np.vstack([line, line[:1]])
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(closed, axis=0).T))])
        n = max(int(np.ceil(s[-1] / 0.25)), 8)
        t = np.arange(n) * (s[-1] / n)
        p, h = resample(line, 0.25)
        assert h == s[-1] / n
        assert np.array_equal(p, np.stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])], 1))


def test_edge_pixels_are_the_boundary_attached_to_a_nearest_sample():
    rng = np.random.default_rng(3)
    for _ in range(8):
        mask = _blob(rng)
        th = np.linspace(0, 2 * np.pi, 400, endpoint=False)
        p = np.stack([19.5 + 11 * np.cos(th), 19.5 + 11 * np.sin(th)], 1)
        pts, side, at = edge_pixels(mask, p)
        m = np.pad(mask, 2)
        core = m[1:-1, 1:-1]
        nb = [m[:-2, 1:-1], m[2:, 1:-1], m[1:-1, :-2], m[1:-1, 2:]]
        inner = np.argwhere(core & ~(nb[0] & nb[1] & nb[2] & nb[3]))[:, ::-1] - 1.0
        outer = np.argwhere(~core & (nb[0] | nb[1] | nb[2] | nb[3]))[:, ::-1] - 1.0
        assert sorted(map(tuple, pts[side])) == sorted(map(tuple, inner))
        assert sorted(map(tuple, pts[~side])) == sorted(map(tuple, outer))
        assert np.all(np.diff(at) >= 0)
        dist = cKDTree(p).query(pts)[0]
        assert np.allclose(np.hypot(*(pts - p[at]).T), dist, rtol=0, atol=1e-12)


def test_mismatch_count_is_the_even_odd_rule_in_any_pixel_order():
    from matplotlib.path import Path

    rng = np.random.default_rng(4)
    th = np.sort(rng.uniform(0, 2 * np.pi, 9))
    poly = np.stack([20 + 12 * np.cos(th), 20 + 12 * np.sin(th)], 1)
    pix = np.argwhere(np.ones((41, 41), bool))[:, ::-1].astype(float) + 0.01
    pix = pix[rng.permutation(len(pix))]
    inside = rng.random(len(pix)) < 0.5
    ref = int(np.sum(Path(poly).contains_points(pix) != inside))
    assert count_outside(pix[:, 0].copy(), pix[:, 1].copy(), inside, poly) == ref


def test_split_sliver_test_and_edge_band_are_the_morphology_they_replace():
    disc = np.hypot(*np.mgrid[-2:3, -2:3]) <= MIN_INSCRIBED_RADIUS_PX
    for mask in _masks(5, 20):
        split, fits = pieces_and_fit(mask, disc)
        assert split == (ndimage.label(mask, structure=np.ones((3, 3), bool))[1] > 1)
        assert fits == bool(ndimage.binary_erosion(np.pad(mask, 3), disc).any())
        share = ndimage.uniform_filter(mask.astype(np.float32), 5, mode="constant")
        ref = np.nonzero((share > 0.01) & (share < 0.99))
        rows, cols = mixed_pixels(mask, 2)
        assert np.array_equal(rows, ref[0]) and np.array_equal(cols, ref[1])


def test_fit_is_the_weighted_least_squares_solution():
    rng = np.random.default_rng(6)
    th = np.sort(rng.uniform(0, 2 * np.pi, 150))
    r = 10 * (1 + 0.1 * np.cos(2 * th) + 0.05 * np.sin(5 * th)) + 0.05 * rng.normal(size=th.size)
    x, y = r * np.cos(th), r * np.sin(th)
    coef, perim, area, star = fit_radius(x, y, 6)
    seg = np.hypot(np.diff(np.append(x, x[0])), np.diff(np.append(y, y[0])))
    w = np.sqrt(0.5 * (seg + np.roll(seg, 1)))
    phi = np.arctan2(y, x)
    design = np.stack([np.ones_like(phi)] + [f(k * phi) for k in range(1, 7) for f in (np.cos, np.sin)], 1)
    ref = np.linalg.lstsq(design * w[:, None], np.hypot(x, y) * w, rcond=None)[0]
    assert star and np.allclose(coef, ref, rtol=0, atol=1e-10)
    t = 2 * np.pi * np.arange(FIT_POINTS) / FIT_POINTS
    R = ref[0] + sum(ref[2 * k - 1] * np.cos(k * t) + ref[2 * k] * np.sin(k * t) for k in range(1, 7))
    assert area == pytest.approx(0.5 * np.sum(R * R) * 2 * np.pi / FIT_POINTS, rel=1e-12)
    assert perim > 2 * np.sqrt(np.pi * area)  # isoperimetric: a non-circular outline


def test_sharpest_bend_finds_the_one_sharp_corner():
    """A 20 px square with three corners rounded (radius 3 px) and one sharp, resampled every
    0.25 px: the smoothed turn peaks at the sharp corner."""
    pts = []
    for k, (cx, cy) in enumerate([(20, 0), (20, 20), (0, 20), (0, 0)]):
        r = 0.0 if k == 0 else 3.0
        # corner k, entered along side k, arc centred inside the square
        ox, oy = cx - np.sign(cx - 10) * r, cy - np.sign(cy - 10) * r
        a0 = np.pi * (k - 1) / 2
        for t in np.linspace(a0, a0 + np.pi / 2, 13):
            pts.append((ox + r * np.cos(t), oy + r * np.sin(t)))
    line = np.unique(np.round(np.array(pts), 12), axis=0, return_index=True)[1]
    line = np.array(pts)[np.sort(line)]
    p, h = resample(line, 0.25)
    k = sharpest_bend(p, gaussian_weights(0.5 / h))
    assert np.hypot(*(p[k] - (20, 0))) < 0.5
