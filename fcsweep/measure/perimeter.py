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

from fcsweep.measure.runs import ORIENTATIONS, count_outside, digital_runs

__all__ = ["blurred_line", "polygon_perimeter", "blurred_perimeter", "closed_length", "mismatch", "edge_band", "BLUR",
           "STEP", "MIN_RUN", "MIN_CORNER_SINE", "MAX_CORNER_SHIFT", "CORNER_TOLERANCE"]

#: Standard deviation (pixels) of the Gaussian blur of the mask before its sub-pixel outline is traced.
BLUR = 1.0
#: Arc-length step (pixels) of the resampled blurred outline.
STEP = 0.25
#: Shortest run (pixels of outline) tried for a straight line.
MIN_RUN = 1.0
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
    reach = max(np.hypot(*(b - a)), np.hypot(*(b - c))) + 1.0
    pts = pts[np.abs(pts - b).max(axis=1) <= reach]
    if not len(pts):
        return False
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


def _edge_pixels(mask: np.ndarray, p: np.ndarray):
    """The pixel centres of the mask with a 4-neighbour outside it and those outside with a
    4-neighbour in it, each with the index of its nearest point of ``p``."""
    from scipy.spatial import cKDTree

    m = np.pad(mask, 2)
    core = m[1:-1, 1:-1]
    up, down, left, right = m[:-2, 1:-1], m[2:, 1:-1], m[1:-1, :-2], m[1:-1, 2:]
    tree = cKDTree(p)
    out = []
    for sel in (core & ~(up & down & left & right), ~core & (up | down | left | right)):
        pts = np.argwhere(sel)[:, ::-1].astype(float) - 1.0
        out.append((pts, tree.query(pts)[1]))
    return out


def _line(q: np.ndarray):
    """Centre and unit direction of the total-least-squares line through the points ``q``."""
    c = q.sum(0) / len(q)
    d = q - c
    sxx, syy, sxy = d[:, 0] @ d[:, 0], d[:, 1] @ d[:, 1], d[:, 0] @ d[:, 1]
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

    pts = np.concatenate([inner, outer])
    at = np.concatenate([at_in, at_out]).astype(np.int64)
    side = np.concatenate([np.ones(len(inner), bool), np.zeros(len(outer), bool)])
    order = np.argsort(at, kind="stable")
    t0s, lengths, ok, normal, offset = digital_runs(np.ascontiguousarray(pts[order]), side[order], at[order], n,
                                                    start, max(int(MIN_RUN / h), 2), ORIENTATIONS)
    runs = []
    for t0, length, good, nrm, off in zip(t0s, lengths, ok, normal, offset):
        c, u = _line(p[np.arange(t0, t0 + length + 1) % n])
        if good:
            c, u = c - (nrm @ c - off) * nrm, np.array([nrm[1], -nrm[0]])
        runs.append((int(t0), c, u))
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


def edge_band(mask: np.ndarray):
    """(rows, cols) of the pixels within 2 px (a 5 x 5 square) of the mask's edge."""
    share = ndimage.uniform_filter(mask.astype(np.float32), 5, mode="constant")
    return np.nonzero((share > 0.01) & (share < 0.99))


def mismatch(mask: np.ndarray, outline: np.ndarray, band=None) -> int:
    """Pixels of ``mask`` whose centre the closed ``outline`` (pixel coordinates: pixel ``(r, c)``
    at ``(c, r)``) puts on the wrong side: how well the outline, digitised as the image was,
    reproduces the mask (0 for the outline that made it).  Only the pixels of ``band``
    (default :func:`edge_band`) are tested: the outlines compared stay within a pixel of the edge."""
    rows, cols = edge_band(mask) if band is None else band
    return int(count_outside(cols.astype(np.float64), rows.astype(np.float64), mask[rows, cols],
                             np.ascontiguousarray(outline, dtype=np.float64)))
