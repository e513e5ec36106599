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

import functools

import contourpy
import numpy as np
from scipy import ndimage

from fcsweep.measure.pixels import blurred_mask, edge_pixels, mixed_pixels, resample
from fcsweep.measure.runs import ORIENTATIONS, count_outside, digital_runs, run_polygon, sharpest_bend

__all__ = ["blurred_line", "contour_lines", "polygon_perimeter", "blurred_perimeter", "closed_length", "closes",
           "padded", "gaussian_weights", "mismatch", "edge_band", "BLUR", "STEP",
           "MIN_RUN", "MIN_CORNER_SINE", "MAX_CORNER_SHIFT", "CORNER_TOLERANCE"]

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


@functools.lru_cache(maxsize=256)
def _grid(ny: int, nx: int):
    x, y = np.meshgrid(np.arange(nx, dtype=np.float64), np.arange(ny, dtype=np.float64))
    x.flags.writeable = y.flags.writeable = False
    return x, y


def contour_lines(z: np.ndarray, level: float) -> list:
    """The lines of ``z`` (2-D float64, no NaN) at ``level``, pixel ``(r, c)`` at ``(c, r)``: what
    ``contourpy.contour_generator(z=z, line_type="Separate").lines(level)`` returns, without its
    masked-array checks and grid set-up (the per-call cost of small cells)."""
    x, y = _grid(*z.shape)
    gen = contourpy.SerialContourGenerator(
        x, y, z, None, corner_mask=True, line_type=contourpy.LineType.Separate,
        fill_type=contourpy.SerialContourGenerator.default_fill_type, quad_as_tri=False,
        z_interp=contourpy.ZInterp.Linear, x_chunk_size=0, y_chunk_size=0)
    return gen.lines(level)


def padded(mask: np.ndarray, width: int, dtype=bool) -> np.ndarray:
    """``np.pad(mask, width).astype(dtype)``, made in one step."""
    out = np.zeros((mask.shape[0] + 2 * width, mask.shape[1] + 2 * width), dtype=dtype)
    out[width:-width, width:-width] = mask
    return out


def closes(line: np.ndarray) -> bool:
    """Whether the line's last point repeats its first (``np.allclose`` of the two)."""
    (x0, y0), (x1, y1) = line[0], line[-1]
    return abs(x0 - x1) <= 1e-8 + 1e-5 * abs(x1) and abs(y0 - y1) <= 1e-8 + 1e-5 * abs(y1)


@functools.lru_cache(maxsize=64)
def gaussian_weights(sigma: float, truncate: float = 4.0) -> np.ndarray:
    """The normalised Gaussian kernel of ``scipy.ndimage.gaussian_filter1d`` (radius ``truncate``
    sigma, computed as it does), read-only."""
    radius = int(truncate * sigma + 0.5)
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / (sigma * sigma) * x ** 2)
    phi = phi / phi.sum()
    phi.flags.writeable = False
    return phi


def closed_length(pts: np.ndarray) -> float:
    """Length of the closed polygon ``pts`` (K, 2), not repeated at the end."""
    d = np.diff(pts, axis=0, append=pts[:1])
    return float(np.hypot(d[:, 0], d[:, 1]).sum())


def blurred_line(mask: np.ndarray, blur: float = BLUR):
    """The outer 1/2 line of the blurred mask, in the mask's pixel coordinates (pixel ``(r, c)``
    at ``(c, r)``), open (end != start); None if the blurred mask never reaches 1/2."""
    pad = int(np.ceil(4 * blur)) + 1
    z = blurred_mask(np.ascontiguousarray(mask, dtype=bool), pad, gaussian_weights(blur))
    lines = contour_lines(z, 0.5)
    if not lines:
        return None
    line = max(lines, key=len)
    if line.shape[0] > 1 and closes(line):
        line = line[:-1]
    return line - pad if line.shape[0] >= 3 else None


def _resample(line: np.ndarray, step: float):
    return resample(np.ascontiguousarray(line, dtype=np.float64), float(step))


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
    pts, side, at = edge_pixels(np.ascontiguousarray(mask, dtype=bool), p)
    start = sharpest_bend(p, gaussian_weights(0.5 / h))
    t0s, lengths, ok, normal, offset = digital_runs(pts, side, at, n, start, max(int(MIN_RUN / h), 2), ORIENTATIONS)
    verts = run_polygon(p, pts, side, t0s, lengths, ok, normal, offset, MIN_CORNER_SINE, MAX_CORNER_SHIFT,
                        CORNER_TOLERANCE)
    return closed_length(verts * np.asarray(scale, dtype=float)), verts


def edge_band(mask: np.ndarray):
    """(rows, cols) of the pixels within 2 px (a 5 x 5 square) of the mask's edge."""
    return mixed_pixels(np.ascontiguousarray(mask, dtype=bool), 2)


def mismatch(mask: np.ndarray, outline: np.ndarray, band=None) -> int:
    """Pixels of ``mask`` whose centre the closed ``outline`` (pixel coordinates: pixel ``(r, c)``
    at ``(c, r)``) puts on the wrong side: how well the outline, digitised as the image was,
    reproduces the mask (0 for the outline that made it).  Only the pixels of ``band``
    (default :func:`edge_band`) are tested: the outlines compared stay within a pixel of the edge."""
    rows, cols = edge_band(mask) if band is None else band
    return int(count_outside(cols.astype(np.float64), rows.astype(np.float64), mask[rows, cols],
                             np.ascontiguousarray(outline, dtype=np.float64)))
