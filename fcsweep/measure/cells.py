"""Per cell of one label frame: centroid, area, perimeter, shape index and Fourier modes.

Coordinates: the pixel in row ``r``, column ``c`` has its centre at
``x = (c + 1/2) px``, ``y = (r + 1/2) py``; the field of view is ``[0, X px] x [0, Y py]``.

The sub-pixel contour of a cell is the marching-squares line of its binary mask at level
1/2 (``contourpy``).  Its length (``perimeter_contour``) overestimates the perimeter by a
few per cent at any resolution: the line runs through the midpoints of pixel edges and
follows the staircase of the mask at the scale of one pixel.  Two estimators remove that
bias (:mod:`fcsweep.measure.perimeter`): the least-squares fit of
``R(phi) = c_0 + sum_{n=1..M} (A_n cos n phi + B_n sin n phi)`` about the centroid to the
contour's vertices, weighted by the contour length each vertex stands for
(``perimeter_fit``, ``q_fit = P_fit / sqrt(A_fit)``), exact for smooth star-shaped cells;
and the polygon of the cell's maximal digital straight runs, exact for polygons and close
for elongated cells.  ``perimeter`` and ``q = P / sqrt(A)`` (``A`` the mask area) are those
of the one whose outline reproduces the mask better: mismatched pixel centres plus
:data:`PARAMETER_COST` per parameter (2 M + 1 for the fit, 2 per polygon vertex), ties to the
fit; the fit for star-shaped cells of equivalent radius below :data:`POLYGON_MIN_RADIUS_PX`
pixels, the polygon for cells that are not star-shaped, the blurred outline's length with
its curvature correction when neither exists (``q_estimator`` 1 fit, 2 polygon, 3
blurred).  ``q_err`` is the resolution error of ``q``: the per-cell rms error of its
estimator on the validation shapes at the cell's size (``q`` times :data:`Q_ERR_COEF`
divided by the equivalent radius in pixels).  Bias and errors: docs/measure.md.

Cells that cannot be measured keep their centroid and area but no shape (NaN) and a
reason in ``shape_flag`` (:data:`SHAPE_FLAGS`): cut by the image edge, split (the label's
pixels form several 8-connected pieces), a sliver (fewer than :data:`MIN_AREA_PX` pixels or
no inscribed disc of radius :data:`MIN_INSCRIBED_RADIUS_PX` pixels), or unresolved (no
outline).  The frame statistics leave them out of the means.

The mode amplitudes ``a_n = A_n / R0_i``, ``b_n = B_n / R0_i`` (``n = 2..M``,
``R0_i = sqrt(A_i / pi)`` with ``A_i`` the mask area) are in the lab frame (``phi``
measured from the x axis); ``|c_n| = sqrt(a_n^2 + b_n^2)`` is independent of the cell's
orientation and compares with the simulation's body-frame modes.  The ``n = 1`` term only
absorbs the offset of the centroid from the centre of the polar curve.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import ndimage

from fcsweep.measure.perimeter import (blurred_line, blurred_perimeter, closes, contour_lines, edge_band, mismatch,
                                      padded, polygon_perimeter)
from fcsweep.measure.pixels import pieces_and_fit, radius_fit

__all__ = ["measure_cells", "CELL_FIELDS", "fit_radius", "STAR_TOLERANCE", "FIT_POINTS", "SHAPE_FLAGS",
           "ESTIMATORS", "MIN_AREA_PX", "MIN_INSCRIBED_RADIUS_PX", "Q_ERR_COEF", "PARAMETER_COST",
           "POLYGON_MIN_RADIUS_PX"]

#: Per-cell outputs of :func:`measure_cells` (besides the mode arrays ``a``, ``b``, ``c_abs``).
CELL_FIELDS = ("label", "x", "y", "area", "perimeter_contour", "perimeter_fit", "q_fit", "perimeter", "q", "q_err",
               "q_estimator", "shape_flag", "star_shaped", "edge_cut")
#: ``shape_flag`` codes: why a cell has no shape (0: it has one).
SHAPE_FLAGS = {0: "measured", 1: "edge_cut", 2: "split", 3: "sliver", 4: "unresolved"}
#: ``q_estimator`` codes (0: none).
ESTIMATORS = {0: "none", 1: "fit", 2: "polygon", 3: "blurred"}
#: Cells of fewer pixels are slivers.
MIN_AREA_PX = 20
#: Cells without an inscribed disc of this radius (pixels, from the distance transform) are slivers.
MIN_INSCRIBED_RADIUS_PX = 2.5
#: Cells of smaller equivalent radius (pixels) take the fit when they are star-shaped (their polygon
#: has too few pixels per side to beat it).
POLYGON_MIN_RADIUS_PX = 8.0
#: Cost of one parameter of an outline, in mismatched pixels, when the fit and the polygon are compared.
PARAMETER_COST = 0.5
#: Per-cell rms relative error of q times the equivalent radius sqrt(A / pi) in pixels, per estimator
#: (measured on the validation shapes, docs/measure.md): ``q_err = q * Q_ERR_COEF[k] / R_px``.
Q_ERR_COEF = {1: 0.06, 2: 0.10, 3: 0.10}
#: Total backward turn (radians) of the contour's polar angle about the centroid above which a
#: cell is not star-shaped (a pixel contour of a star-shaped cell turns back by far less).
STAR_TOLERANCE = 0.05
#: Points of the fitted curve used for its length and area (spectral accuracy for M <= 8).
FIT_POINTS = 512


def fit_radius(x: np.ndarray, y: np.ndarray, modes: int):
    """Weighted least-squares fit of ``R(phi)`` to a closed contour about the origin.

    Parameters
    ----------
    x, y : ndarray, shape (K,)
        Contour vertices relative to the centroid, in order, not repeated at the end.
    modes : int
        Highest mode M.

    Returns
    -------
    coef : ndarray, shape (2 M + 1,)
        ``c_0, A_1, B_1, ..., A_M, B_M``; NaN when there are too few vertices.
    perimeter, area : float
        Of the fitted curve.
    star_shaped : bool
        The contour's polar angle turns back by less than :data:`STAR_TOLERANCE`.
    """
    ct, st = _fit_tables(modes)
    coef, perim, area, star = radius_fit(np.ascontiguousarray(x, dtype=np.float64),
                                         np.ascontiguousarray(y, dtype=np.float64), int(modes), STAR_TOLERANCE, ct, st)
    return coef, float(perim), float(area), bool(star)


@functools.lru_cache(maxsize=8)
def _fit_tables(modes: int):
    """cos(n t), sin(n t) for n = 1..M at the :data:`FIT_POINTS` points t of one turn."""
    t = 2 * np.pi * np.arange(FIT_POINTS) / FIT_POINTS
    n = np.arange(1, modes + 1)
    return np.cos(np.outer(n, t)), np.sin(np.outer(n, t))


@functools.lru_cache(maxsize=8)
def _curve_tables(modes: int, points: int):
    """cos(n t), sin(n t) for n = 0..M (row 0: cos t, sin t) at ``points`` points t of one turn."""
    t = np.linspace(0, 2 * np.pi, points, endpoint=False)
    n = np.arange(1, modes + 1)
    ct, st = np.cos(np.outer(n, t)), np.sin(np.outer(n, t))
    return np.vstack([np.cos(t), ct]), np.vstack([np.sin(t), st])


def _outline(mask: np.ndarray):
    """Marching-squares lines of a padded binary mask at 1/2, longest first, open (end != start)."""
    lines = []
    for ln in contour_lines(np.asarray(mask, dtype=np.float64), 0.5):
        ln = np.asarray(ln, dtype=float)
        if ln.shape[0] > 1 and closes(ln):
            ln = ln[:-1]
        lines.append(ln)
    lines.sort(key=lambda ln: -ln.shape[0])
    return lines


def _empty(n: int, modes: int) -> dict:
    out = {f: np.full(n, np.nan) for f in CELL_FIELDS}
    out["star_shaped"] = np.zeros(n, dtype=bool)
    out["edge_cut"] = np.zeros(n, dtype=bool)
    out["q_estimator"] = np.zeros(n, dtype=np.int8)
    out["shape_flag"] = np.zeros(n, dtype=np.int8)
    for f in ("a", "b", "c_abs"):
        out[f] = np.full((n, modes - 1), np.nan)
    return out


_DISC = np.hypot(*np.mgrid[-2:3, -2:3]) <= MIN_INSCRIBED_RADIUS_PX


def _unmeasurable(mask: np.ndarray) -> int:
    """0, or the :data:`SHAPE_FLAGS` code of a split label or a sliver (no disc of radius
    :data:`MIN_INSCRIBED_RADIUS_PX` fits: the mask's erosion by it is empty)."""
    split, fits = pieces_and_fit(mask, _DISC)
    if split:
        return 2
    if mask.sum() < MIN_AREA_PX or not fits:
        return 3
    return 0


def measure_cells(frame: np.ndarray, pixel_size=(1.0, 1.0), modes: int = 6, slices=None) -> dict:
    """Measure every cell of one label frame.

    Parameters
    ----------
    frame : ndarray of int, shape (Y, X)
        0 = background, 1..n = cells (consecutive labels: :func:`fcsweep.measure.readers.relabel`).
    pixel_size : (px, py)
        Pixel width and height in length units.
    modes : int
        Highest Fourier mode M of the fit (>= 2).
    slices : list, optional
        ``scipy.ndimage.find_objects(frame)``, if already computed.

    Returns
    -------
    dict
        Arrays over the cells present, ordered by label: ``label``, ``x``, ``y`` (centroid),
        ``area``, ``perimeter_contour`` (marching squares), ``perimeter_fit`` and ``q_fit``
        (the M-mode fit), ``perimeter``, ``q``, ``q_err`` and ``q_estimator`` (the chosen
        estimator, module docstring), ``shape_flag`` (:data:`SHAPE_FLAGS`),
        ``star_shaped``, ``edge_cut`` (the mask touches the image edge: its shape is cut),
        and ``a``, ``b``, ``c_abs`` of shape (cells, M - 1) for modes 2..M.  Shape fields
        are NaN where ``shape_flag`` != 0.
    """
    px, py = float(pixel_size[0]), float(pixel_size[1])
    scale = (px, py)
    ny, nx = frame.shape
    if slices is None:
        slices = ndimage.find_objects(frame)
    labels = [k + 1 for k, s in enumerate(slices) if s is not None]
    n = len(labels)
    out = _empty(n, modes)
    out["label"] = np.asarray(labels, dtype=np.int64)
    for c, lab in enumerate(labels):
        sr, sc = slices[lab - 1]
        mask = frame[sr, sc] == lab
        rows, cols = np.nonzero(mask)
        area_px = rows.size
        out["area"][c] = area_px * px * py
        out["x"][c] = (cols.mean() + sc.start + 0.5) * px
        out["y"][c] = (rows.mean() + sr.start + 0.5) * py
        cut = sr.start == 0 or sc.start == 0 or sr.stop == ny or sc.stop == nx
        out["edge_cut"][c] = cut
        flag = 1 if cut else _unmeasurable(mask)
        lines = _outline(padded(mask, 1, np.float64)) if not flag else []
        blurred = blurred_line(mask) if lines else None
        if not flag and (not lines or blurred is None):
            flag = 4
        out["shape_flag"][c] = flag
        if flag:
            continue
        # padded index (k) -> pixel k - 1 of the crop, centre at + 1/2
        line = lines[0]
        xs = (line[:, 0] + sc.start - 0.5) * px
        ys = (line[:, 1] + sr.start - 0.5) * py
        closing = np.hypot(*(np.array([xs[0] - xs[-1], ys[0] - ys[-1]])))
        out["perimeter_contour"][c] = np.hypot(np.diff(xs), np.diff(ys)).sum() + closing
        coef, perim, area_fit, star = fit_radius(xs - out["x"][c], ys - out["y"][c], modes)
        star = star and len(lines) == 1
        out["star_shaped"][c] = star
        out["perimeter_fit"][c] = perim
        out["q_fit"][c] = perim / np.sqrt(area_fit) if area_fit > 0 else np.nan
        R0 = np.sqrt(out["area"][c] / np.pi)
        out["a"][c] = coef[3::2] / R0
        out["b"][c] = coef[4::2] / R0
        est, p = _choose(mask, blurred, coef, perim, star,
                         (out["x"][c] / px - sc.start - 0.5, out["y"][c] / py - sr.start - 0.5), scale)
        out["q_estimator"][c] = est
        out["perimeter"][c] = p
        out["q"][c] = p / np.sqrt(out["area"][c])
        out["q_err"][c] = out["q"][c] * Q_ERR_COEF[est] / np.sqrt(area_px / np.pi)
    out["c_abs"] = np.hypot(out["a"], out["b"])
    return out





def _choose(mask, blurred, coef, perim, star, centre, scale):
    """(estimator code, perimeter): of the fit and the polygon, the outline that reproduces the
    mask better, counting each pixel centre it puts on the wrong side as 1 and each parameter of
    the outline as :data:`PARAMETER_COST` (the fit has 2 M + 1, the polygon 2 per vertex); the
    fit only for star-shaped cells; the blurred outline when neither exists."""
    fit_ok = star and np.isfinite(perim)
    if fit_ok and mask.sum() < np.pi * POLYGON_MIN_RADIUS_PX ** 2:
        return 1, perim
    p_poly, verts = polygon_perimeter(blurred, mask, scale)
    if fit_ok and len(verts) >= 3:
        pad = padded(mask, 1)
        ct, st = _curve_tables((coef.size - 1) // 2, 128)
        R = coef[0] + coef[1::2] @ ct[1:] + coef[2::2] @ st[1:]
        curve = np.stack([centre[0] + R * ct[0] / scale[0], centre[1] + R * st[0] / scale[1]], 1)
        band = edge_band(pad)
        fit_ok = (mismatch(pad, curve + 1, band) + PARAMETER_COST * coef.size
                  <= mismatch(pad, verts + 1, band) + PARAMETER_COST * 2 * len(verts))
    if fit_ok:
        return 1, perim
    if len(verts) >= 3:
        return 2, p_poly
    return 3, blurred_perimeter(blurred, scale=scale)
