"""Perimeter estimators of one cell's binary mask for the shape index ``q = P / sqrt(A)``.

A label mask is the Gauss digitisation of the cell: a pixel belongs to the cell when its
centre does.  Three estimators read the cell's perimeter from it (validated on shapes with
exact answers in docs/measure.md, "How q is measured"):

``fit``
    The perimeter of the least-squares fit of ``R(phi)`` with M Fourier modes about the
    centroid (:func:`fcsweep.measure.cells.fit_radius`).  Exact for smooth star-shaped cells
    whose outline has no structure above mode M (the model's cells); it rounds the corners
    of polygons and cannot follow elongated cells.
``polygon``
    Corner-preserving polygon: the marching-squares line at 1/2 of the mask blurred with a
    Gaussian of :data:`BLUR` px (sub-pixel, free of the pixel staircase), split into straight
    runs by Douglas-Peucker at :data:`SPLIT_TOLERANCE` px; a line is fitted (total least
    squares) to each run that is longer than twice :data:`CORNER_ZONE` blur widths, away
    from its ends (where the blur rounds the corners), and the corners are the
    intersections of consecutive lines.  Exact for polygons whose edges are longer than
    a few pixels; on a smooth curve its chords lie up to the tolerance off the curve.
``blurred``
    The length of the blurred line itself plus the first-order correction of the blur,
    ``(s^2 / 2) * integral kappa^2 dl`` (the 1/2 line of a blurred smooth outline lies
    ``s^2 kappa / 2`` inside it).  A fallback: +0.8 % on discs, corners cut.

:func:`polygon_perimeter` and :func:`blurred_line` are used by
:func:`fcsweep.measure.cells.measure_cells`, which chooses per cell (docs/measure.md).
"""

from __future__ import annotations

import contourpy
import numpy as np
from scipy import ndimage

__all__ = ["blurred_line", "polygon_perimeter", "blurred_perimeter", "closed_length", "peak_curvature", "BLUR",
           "SPLIT_TOLERANCE", "CORNER_ZONE", "STEP"]

#: Standard deviation (pixels) of the Gaussian blur of the mask before its sub-pixel outline is traced.
BLUR = 1.0
#: Douglas-Peucker tolerance (pixels) that splits the blurred outline into straight runs.
SPLIT_TOLERANCE = 0.4
#: Blur widths at each end of a run left out of its line fit (the blur rounds corners over ~2 widths).
CORNER_ZONE = 1.5
#: Arc-length step (pixels) of the resampled blurred outline.
STEP = 0.25
#: Two consecutive lines meet at a corner only if their directions differ by more than this sine and the
#: corner lies within MAX_CORNER_SHIFT blur widths of the outline; else the run's own points are kept.
MIN_CORNER_SINE = 0.1
MAX_CORNER_SHIFT = 3.0


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


def peak_curvature(line: np.ndarray, blur: float = BLUR) -> float:
    """Largest |curvature| (1 / px) of the blurred line, the tangent angle smoothed over half a blur
    width: a corner of the mask shows as a peak near ``1 / (2 blur)`` or above."""
    p, h = _resample(line, STEP)
    e = np.roll(p, -1, 0) - p
    ang = np.arctan2(e[:, 1], e[:, 0])
    turn = np.angle(np.exp(1j * (np.roll(ang, -1) - ang)))
    return float(np.abs(ndimage.gaussian_filter1d(turn / h, 0.5 * blur / h, mode="wrap")).max())


def _split(p: np.ndarray, eps: float) -> np.ndarray:
    """Douglas-Peucker vertices (sorted indices) of the closed outline ``p``."""
    n = len(p)
    j = int(np.argmax(np.hypot(*(p - p[0]).T)))
    keep = [0, j]
    stack = [(0, j), (j, n)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        pa, d = p[a], p[b % n] - p[a]
        q = p[a + 1:b] - pa
        L = np.hypot(d[0], d[1])
        dist = np.abs(q[:, 0] * d[1] - q[:, 1] * d[0]) / L if L > 0 else np.hypot(q[:, 0], q[:, 1])
        k = int(np.argmax(dist))
        if dist[k] > eps:
            m = a + 1 + k
            keep.append(m)
            stack += [(a, m), (m, b)]
    return np.array(sorted(keep))


def polygon_perimeter(line: np.ndarray, blur: float = BLUR, scale=(1.0, 1.0)):
    """Corner-preserving polygon of a blurred outline.

    Parameters
    ----------
    line : ndarray, shape (K, 2)
        :func:`blurred_line`.
    blur : float
    scale : (px, py)
        Pixel size: the polygon's length is in these units.

    Returns
    -------
    perimeter : float
        NaN when fewer than three runs are long enough for a line.
    residual : float
        Rms distance (px) of the fitted runs' points from their lines (inf without lines).
    """
    p, h = _resample(line, STEP)
    n = len(p)
    v = _split(p, SPLIT_TOLERANCE)
    k = len(v)
    m = int(round(CORNER_ZONE * blur / h))
    runs, sq, count = [], 0.0, 0
    for i in range(k):
        a, b = v[i], (v[i + 1] if i + 1 < k else v[0] + n)
        if b - a > 2 * m + 4:
            q = p[np.arange(a + m, b - m + 1) % n]
            c = q.mean(0)
            d = q - c
            sxx, syy, sxy = (d[:, 0] ** 2).sum(), (d[:, 1] ** 2).sum(), (d[:, 0] * d[:, 1]).sum()
            th = 0.5 * np.arctan2(2 * sxy, sxx - syy)
            u = np.array([np.cos(th), np.sin(th)])
            r = d[:, 0] * -u[1] + d[:, 1] * u[0]
            sq += float(r @ r)
            count += r.size
            runs.append((i, c, u))
    if len(runs) < 3:
        return float("nan"), float("inf")
    verts = []
    for j in range(len(runs)):
        i1, c1, d1 = runs[j - 1]
        i2, c2, d2 = runs[j]
        bend = v[np.arange(i1 + 1, i2 + 1 + (k if i2 <= i1 else 0)) % k]
        det = d2[0] * d1[1] - d1[0] * d2[1]
        if abs(det) > MIN_CORNER_SINE:
            w = c2 - c1
            corner = c1 + d1 * ((w[1] * d2[0] - w[0] * d2[1]) / det)
            if np.min(np.hypot(*(p[bend] - corner).T)) < MAX_CORNER_SHIFT * blur:
                verts.append(corner)
                continue
        verts.extend(p[bend])
    return closed_length(np.asarray(verts) * np.asarray(scale, dtype=float)), float(np.sqrt(sq / count))
