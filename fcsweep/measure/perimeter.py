"""Perimeter estimators of one cell's binary mask for the shape index ``q = P / sqrt(A)``.

A label mask is the Gauss digitisation of the cell: a pixel belongs to the cell when its
centre does.  Three estimators read the cell's perimeter from it (validated on shapes with
exact answers in docs/measure.md, "How q is measured"):

``fit``
    The perimeter of the least-squares fit of ``R(phi)`` with M Fourier modes about the
    centroid (:func:`fcsweep.measure.cells.fit_radius`).  Exact for smooth star-shaped cells
    whose outline has no structure above mode M (the model's cells); it rounds the corners
    of polygons (-2 % on hexagons, -5 % on squares) and cannot follow elongated cells
    (+17 % at aspect 7).
``polygon``
    The polygon of the cell's maximal digital straight runs (:func:`polygon_perimeter`): each
    line is the widest-margin line between the boundary pixel centres inside and outside the
    cell, corners are where consecutive lines meet.  Exact to the pixel staircase for polygons
    whose sides are a few pixels long or more; on a smooth curve its lines are chords of
    digital arcs and it reads high (+2.4 % on discs of radius 10 px, +1 % at 20 px).
``blurred``
    The length of the 1/2 line of the mask blurred with a Gaussian of :data:`BLUR` px plus the
    first-order correction of the blur, ``(s^2 / 2) * integral kappa^2 dl``
    (:func:`blurred_perimeter`).  A fallback for cells neither of the others takes.

:func:`fcsweep.measure.cells.measure_cells` chooses per cell (docs/measure.md).
"""

from __future__ import annotations

import contourpy
import numpy as np
from scipy import ndimage

__all__ = ["blurred_line", "polygon_perimeter", "blurred_perimeter", "closed_length", "mismatch", "BLUR", "STEP",
           "MIN_RUN", "SEARCH_SPAN", "MIN_CORNER_SINE", "MAX_CORNER_SHIFT",
           "CORNER_TOLERANCE"]

#: Standard deviation (pixels) of the Gaussian blur of the mask before its sub-pixel outline is traced.
BLUR = 1.0
#: Arc-length step (pixels) of the resampled blurred outline.
STEP = 0.25
#: Shortest run (pixels of outline) tried for a straight line.
MIN_RUN = 1.0
#: Half-width (radians) of the search for the widest-margin line about the run's least-squares direction.
SEARCH_SPAN = 0.35
#: Two consecutive lines meet at a corner only if their directions differ by more than this sine (30
#: degrees: a smaller turn is a bend of a smooth outline, whose vertex stays on the blurred outline) ...
MIN_CORNER_SINE = 0.5
#: ... and the corner lies within this many pixels of the outline; else the outline's point is the vertex.
MAX_CORNER_SHIFT = 3.0
#: Pixel centres outside the cell closer than this (pixels) to a line do not stop its corner.
CORNER_TOLERANCE = 0.15


def _covers(a, b, c, pts) -> bool:
    """Whether the triangle a, b, c (a -> b and b -> c along the two lines, a, c on the outline)
    holds any of the points ``pts`` farther than :data:`CORNER_TOLERANCE` px inside its sides a-b
    and b-c: a sharpened corner that takes in pixel centres outside the cell is a rounded one."""
    def side(p0, p1):
        e = p1 - p0
        return (e[0] * (pts[:, 1] - p0[1]) - e[1] * (pts[:, 0] - p0[0])) / max(np.hypot(e[0], e[1]), 1e-12)

    s1, s2, s3 = side(a, b), side(b, c), side(c, a)
    orient = np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) or 1.0
    s1, s2, s3 = orient * s1, orient * s2, orient * s3
    return bool(np.any((s1 > CORNER_TOLERANCE) & (s2 > CORNER_TOLERANCE) & (s3 > 0)))


def closed_length(pts: np.ndarray) -> float:
    """Length of the closed polygon ``pts`` (K, 2), not repeated at the end."""
    d = np.diff(pts, axis=0, append=pts[:1])
    return float(np.hypot(d[:, 0], d[:, 1]).sum())


def blurred_line(mask: np.ndarray, blur: float = BLUR):
    """The outer 1/2 line of the blurred mask, in the mask's pixel coordinates (pixel ``(r, c)``
    at ``(c, r)``), open (end != start); None if the blurred mask never reaches 1/2."""
    pad = int(np.ceil(4 * blur)) + 1
    z = ndimage.gaussian_filter(np.pad(mask, pad).astype(np.float64), blur, mode="constant", truncate=4.0)
    lines = contourpy.contour_generator(z=z, line_type="Separate").lines(0.5)
    if not lines:
        return None
    line = max(lines, key=len)
    if line.shape[0] > 1 and np.allclose(line[0], line[-1]):
        line = line[:-1]
    return line - pad if line.shape[0] >= 3 else None


def _resample(line: np.ndarray, step: float):
    closed = np.vstack([line, line[:1]])
    seg = np.hypot(*np.diff(closed, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(int(np.ceil(s[-1] / step)), 8)
    t = np.arange(n) * (s[-1] / n)
    return np.stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])], 1), s[-1] / n


def blurred_perimeter(line: np.ndarray, blur: float = BLUR, scale=(1.0, 1.0)) -> float:
    """Length of the blurred line plus ``(blur^2 / 2) * integral kappa^2 dl``, the curvature
    taken from the tangent angle smoothed over half a blur width; ``scale`` = (px, py), the
    pixel size (the correction is scaled by ``sqrt(px py)``)."""
    p, h = _resample(line, STEP)
    e = np.roll(p, -1, 0) - p
    ang = np.arctan2(e[:, 1], e[:, 0])
    turn = np.angle(np.exp(1j * (np.roll(ang, -1) - ang)))
    k = ndimage.gaussian_filter1d(turn / h, 0.5 * blur / h, mode="wrap")
    corr = 0.5 * blur * blur * float(np.sum(k * k)) * h
    return closed_length(line * np.asarray(scale, dtype=float)) + corr * float(np.sqrt(scale[0] * scale[1]))


def _widest_margin(inner: np.ndarray, outer: np.ndarray, th0: float):
    """(gap, normal, offset) of the widest-margin line between the point sets near direction
    ``th0``: the normal points out of the cell; gap <= 0 when no line near th0 separates them."""
    best = None
    for span, num in ((SEARCH_SPAN, 41), (SEARCH_SPAN / 20, 21)):
        ths = (th0 if best is None else best[3]) + np.linspace(-span, span, num)
        nrm = np.stack([-np.sin(ths), np.cos(ths)], 1)
        pi, po = inner @ nrm.T, outer @ nrm.T
        if po.mean() < pi.mean():
            nrm, pi, po = -nrm, -pi, -po
        lo, hi = po.min(0), pi.max(0)
        j = int(np.argmax(lo - hi))
        best = (lo[j] - hi[j], nrm[j], 0.5 * (lo[j] + hi[j]), ths[j])
    return best[:3]


def _edge_pixels(mask: np.ndarray, p: np.ndarray):
    """The pixel centres of the mask with a 4-neighbour outside it and those outside with a
    4-neighbour in it, each with the index of its nearest point of ``p``."""
    from scipy.spatial import cKDTree

    padded = np.pad(mask, 1)
    tree = cKDTree(p)
    out = []
    for sel in (padded & ~ndimage.binary_erosion(padded), ndimage.binary_dilation(padded) & ~padded):
        pts = np.argwhere(sel)[:, ::-1].astype(float) - 1.0
        out.append((pts, tree.query(pts)[1]))
    return out


def _line(q: np.ndarray):
    """Centre and unit direction of the total-least-squares line through the points ``q``."""
    c = q.mean(0)
    d = q - c
    sxx, syy, sxy = (d[:, 0] ** 2).sum(), (d[:, 1] ** 2).sum(), (d[:, 0] * d[:, 1]).sum()
    th = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    return c, np.array([np.cos(th), np.sin(th)])


def polygon_perimeter(line: np.ndarray, mask: np.ndarray, scale=(1.0, 1.0)):
    """Corner-preserving polygon of a cell: its maximal digital straight runs.

    Starting at the sharpest bend of the blurred outline, the outline is cut greedily into runs,
    each as long as a straight line still separates the run's boundary pixel centres inside the
    cell from those outside it (the boundary pixels are attached to the nearest point of the
    blurred outline).  Each run's line is the widest-margin separating line (the middle of the
    lines that digitise to the mask there); the polygon's corners are the intersections of
    consecutive lines, or the blurred outline's point between them where the lines turn by
    less than 30 degrees (:data:`MIN_CORNER_SINE`: a bend of a smooth outline), meet more than
    :data:`MAX_CORNER_SHIFT` px away, or would take in a boundary pixel centre outside the cell
    (a rounded corner).

    Parameters
    ----------
    line : ndarray, shape (K, 2)
        :func:`blurred_line` of the mask.
    mask : ndarray of bool
        The cell's mask (pixel ``(r, c)`` at ``(c, r)``).
    scale : (px, py)
        Pixel size: the polygon's length is in these units.

    Returns
    -------
    perimeter : float
    vertices : ndarray, shape (V, 2)
        The polygon, in pixel coordinates.
    """
    p, h = _resample(line, STEP)
    n = len(p)
    (inner, at_in), (outer, at_out) = _edge_pixels(mask, p)
    e = np.roll(p, -1, 0) - p
    ang = np.arctan2(e[:, 1], e[:, 0])
    turn = np.abs(ndimage.gaussian_filter1d(np.angle(np.exp(1j * (np.roll(ang, -1) - ang))), 0.5 / h, mode="wrap"))
    start = int(np.argmax(turn))

    def run_line(t0: int, length: int):
        """(separable, centre, direction) of the run of ``length`` steps from ``t0``."""
        c, u = _line(p[np.arange(t0, t0 + length + 1) % n])
        i = inner[(at_in - t0) % n <= length]
        o = outer[(at_out - t0) % n <= length]
        if len(i) == 0 or len(o) == 0:
            return True, c, u
        gap, nrm, off = _widest_margin(i, o, np.arctan2(u[1], u[0]))
        if gap <= 0:
            return False, c, u
        return True, c - (nrm @ c - off) * nrm, np.array([nrm[1], -nrm[0]])

    runs, t, end = [], start, start + n
    first = max(int(MIN_RUN / h), 2)
    while t < end - 1:
        room = end - 1 - t
        good_len = min(first, room)
        good = run_line(t % n, good_len)
        bad_len = None
        while good_len < room:  # doubling, then bisection, for the longest separable run
            trial = min(2 * good_len, room)
            r = run_line(t % n, trial)
            if not r[0]:
                bad_len = trial
                break
            good_len, good = trial, r
        while bad_len is not None and bad_len - good_len > 1:
            mid = (good_len + bad_len) // 2
            r = run_line(t % n, mid)
            if r[0]:
                good_len, good = mid, r
            else:
                bad_len = mid
        runs.append((t, good[1], good[2]))
        t += good_len + 1
    verts = []
    for j in range(len(runs)):
        _, c1, d1 = runs[j - 1]
        t2, c2, d2 = runs[j]
        x = p[t2 % n]
        det = d2[0] * d1[1] - d1[0] * d2[1]
        if abs(det) > MIN_CORNER_SINE:
            w = c2 - c1
            corner = c1 + d1 * ((w[1] * d2[0] - w[0] * d2[1]) / det)
            a, b = c1 + d1 * ((x - c1) @ d1), c2 + d2 * ((x - c2) @ d2)
            if np.hypot(*(corner - x)) < MAX_CORNER_SHIFT and not _covers(a, corner, b, outer):
                x = corner
        verts.append(x)
    verts = np.asarray(verts)
    return closed_length(verts * np.asarray(scale, dtype=float)), verts


def mismatch(mask: np.ndarray, outline: np.ndarray) -> int:
    """Pixels of ``mask`` whose centre the closed ``outline`` (pixel coordinates: pixel ``(r, c)``
    at ``(c, r)``) puts on the wrong side: how well the outline, digitised as the image was,
    reproduces the mask (0 for the outline that made it)."""
    from matplotlib.path import Path

    ny, nx = mask.shape
    gx, gy = np.meshgrid(np.arange(nx, dtype=float), np.arange(ny, dtype=float))
    inside = Path(outline).contains_points(np.stack([gx.ravel(), gy.ravel()], 1)).reshape(mask.shape)
    return int(np.count_nonzero(inside != mask))
