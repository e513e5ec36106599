"""Per cell of one label frame: centroid, area, perimeter, shape index and Fourier modes.

Coordinates: the pixel in row ``r``, column ``c`` has its centre at
``x = (c + 1/2) px``, ``y = (r + 1/2) py``; the field of view is ``[0, X px] x [0, Y py]``.

The sub-pixel contour of a cell is the marching-squares line of its binary mask at level
1/2 (``contourpy``).  Its length (``perimeter_contour``) overestimates the perimeter by a
few per cent at any resolution: the line runs through the midpoints of pixel edges and
follows the staircase of the mask at the scale of one pixel, so the error does not vanish
as the cell gets larger.  The reported perimeter is that of a least-squares fit of
``R(phi) = c_0 + sum_{n=1..M} (A_n cos n phi + B_n sin n phi)`` about the centroid to the
contour's vertices, weighted by the contour length each vertex stands for (the vertex
density of a pixel contour depends on the direction of the boundary).  The fit's length
and area give ``q = P / sqrt(A)``, which is independent of the units.  Bias of both
perimeters on cells rendered from the model: docs/measure.md.

The mode amplitudes ``a_n = A_n / R0_i``, ``b_n = B_n / R0_i`` (``n = 2..M``,
``R0_i = sqrt(A_i / pi)`` with ``A_i`` the mask area) are in the lab frame (``phi``
measured from the x axis); ``|c_n| = sqrt(a_n^2 + b_n^2)`` is independent of the cell's
orientation and compares with the simulation's body-frame modes.  The ``n = 1`` term only
absorbs the offset of the centroid from the centre of the polar curve.
"""

from __future__ import annotations

import contourpy
import numpy as np
from scipy import ndimage

__all__ = ["measure_cells", "CELL_FIELDS", "fit_radius", "STAR_TOLERANCE", "FIT_POINTS"]

#: Per-cell outputs of :func:`measure_cells` (besides the mode arrays ``a``, ``b``, ``c_abs``).
CELL_FIELDS = ("label", "x", "y", "area", "perimeter_contour", "perimeter", "q", "star_shaped", "edge_cut")
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
    phi = np.arctan2(y, x)
    r = np.hypot(x, y)
    dphi = np.angle(np.exp(1j * np.diff(np.append(phi, phi[0]))))
    turn = dphi.sum()
    back = -np.minimum(np.sign(turn) * dphi, 0.0).sum()
    star = bool(abs(abs(turn) - 2 * np.pi) < 1e-6 and back < STAR_TOLERANCE)
    n_par = 2 * modes + 1
    if x.size < n_par + 2:
        return np.full(n_par, np.nan), np.nan, np.nan, star
    seg = np.hypot(np.diff(np.append(x, x[0])), np.diff(np.append(y, y[0])))
    w = np.sqrt(0.5 * (seg + np.roll(seg, 1)))
    n = np.arange(1, modes + 1)
    cols = [np.ones_like(phi)]
    for k in n:
        cols += [np.cos(k * phi), np.sin(k * phi)]
    design = np.stack(cols, axis=1)
    coef = np.linalg.lstsq(design * w[:, None], r * w, rcond=None)[0]
    t = 2 * np.pi * np.arange(FIT_POINTS) / FIT_POINTS
    A, B = coef[1::2], coef[2::2]
    ct, st = np.cos(np.outer(n, t)), np.sin(np.outer(n, t))
    R = coef[0] + A @ ct + B @ st
    dR = (B * n) @ ct - (A * n) @ st
    h = 2 * np.pi / FIT_POINTS
    return coef, float(np.sqrt(R * R + dR * dR).sum() * h), float(0.5 * (R * R).sum() * h), star


def _outline(mask: np.ndarray):
    """Marching-squares lines of a padded binary mask at 1/2, longest first, open (end != start)."""
    gen = contourpy.contour_generator(z=mask.astype(np.float64), line_type="Separate")
    lines = []
    for ln in gen.lines(0.5):
        ln = np.asarray(ln, dtype=float)
        if ln.shape[0] > 1 and np.allclose(ln[0], ln[-1]):
            ln = ln[:-1]
        lines.append(ln)
    lines.sort(key=lambda ln: -ln.shape[0])
    return lines


def measure_cells(frame: np.ndarray, pixel_size=(1.0, 1.0), modes: int = 6) -> dict:
    """Measure every cell of one label frame.

    Parameters
    ----------
    frame : ndarray of int, shape (Y, X)
        0 = background, 1..n = cells.
    pixel_size : (px, py)
        Pixel width and height in length units.
    modes : int
        Highest Fourier mode M of the fit (>= 2).

    Returns
    -------
    dict
        Arrays over the cells present, ordered by label: ``label``, ``x``, ``y`` (centroid),
        ``area``, ``perimeter_contour`` (marching squares), ``perimeter`` (fit), ``q``
        (fit), ``star_shaped``, ``edge_cut`` (the mask touches the image edge: its shape
        is cut, so its shape fields are NaN), and ``a``, ``b``, ``c_abs`` of shape
        (cells, M - 1) for modes 2..M.
    """
    px, py = float(pixel_size[0]), float(pixel_size[1])
    ny, nx = frame.shape
    slices = ndimage.find_objects(frame)
    labels = [k + 1 for k, s in enumerate(slices) if s is not None]
    n = len(labels)
    out = {f: np.full(n, np.nan) for f in CELL_FIELDS}
    out["label"] = np.asarray(labels, dtype=np.int64)
    out["star_shaped"] = np.zeros(n, dtype=bool)
    out["edge_cut"] = np.zeros(n, dtype=bool)
    for f in ("a", "b", "c_abs"):
        out[f] = np.full((n, modes - 1), np.nan)
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
        if cut:
            continue
        lines = _outline(np.pad(mask, 1))
        if not lines:
            continue
        # padded index (k) -> pixel k - 1 of the crop, centre at + 1/2
        line = lines[0]
        xs = (line[:, 0] + sc.start - 0.5) * px
        ys = (line[:, 1] + sr.start - 0.5) * py
        closing = np.hypot(*(np.array([xs[0] - xs[-1], ys[0] - ys[-1]])))
        out["perimeter_contour"][c] = np.hypot(np.diff(xs), np.diff(ys)).sum() + closing
        coef, perim, area_fit, star = fit_radius(xs - out["x"][c], ys - out["y"][c], modes)
        out["star_shaped"][c] = star and len(lines) == 1
        out["perimeter"][c] = perim
        out["q"][c] = perim / np.sqrt(area_fit) if area_fit > 0 else np.nan
        R0 = np.sqrt(out["area"][c] / np.pi)
        out["a"][c] = coef[3::2] / R0
        out["b"][c] = coef[4::2] / R0
    out["c_abs"] = np.hypot(out["a"], out["b"])
    return out
