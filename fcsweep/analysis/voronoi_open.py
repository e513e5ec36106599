"""Voronoi neighbours of points in a non-periodic field of view (open boundaries).

An image, or a confined simulation, is not periodic: the Voronoi cell of a point near the
edge of the field of view can be changed by cells outside it, which are not seen.  A
Voronoi vertex ``v`` of cell ``i`` is the centre of a circle through ``i`` and two
neighbours with no point inside; a point outside the field of view changes the vertex only
if it falls inside that circle.  So the rule (docs/measure.md): a cell is *interior*, its
number of sides certain whatever lies outside, when its region is bounded and the circle of
every one of its vertices lies inside the field of view; otherwise it *reaches the edge*
and is a boundary cell, neither defect nor non-defect.  Boundary cells stay in the
neighbour graph: they are the neighbours of interior cells.

The tessellation is ``scipy.spatial.Voronoi`` (Qhull).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import Voronoi

__all__ = ["OpenVoronoi", "open_voronoi", "EDGES"]

#: The four edges of the field of view, in the order of :attr:`OpenVoronoi.reaches`.
EDGES = ("left", "right", "bottom", "top")


@dataclass
class OpenVoronoi:
    """Voronoi bonds of points in a rectangle.

    Attributes
    ----------
    i, j : ndarray of int, shape (B,)
        Directed bonds ``i -> j`` (both directions present), one per shared Voronoi edge.
    n_sides : ndarray of int, shape (N,)
        Voronoi neighbours of each point (meaningful for interior points only).
    interior : ndarray of bool, shape (N,)
        Region bounded and the empty circle of each of its vertices inside the field of view.
    reaches : ndarray of bool, shape (N, 4)
        Region reaches the left, right, bottom, top edge (:data:`EDGES`): the circle of one
        of its vertices crosses it, or the region is unbounded towards it.
    """

    i: np.ndarray
    j: np.ndarray
    n_sides: np.ndarray
    interior: np.ndarray
    reaches: np.ndarray


def _empty(n: int) -> OpenVoronoi:
    z = np.zeros(0, dtype=np.int64)
    return OpenVoronoi(z, z.copy(), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=bool),
                       np.ones((n, 4), dtype=bool))


def open_voronoi(points: np.ndarray, bounds) -> OpenVoronoi:
    """Voronoi tessellation of ``points`` (N, 2) in the field of view ``bounds``.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Positions, finite and distinct.
    bounds : (x0, x1, y0, y1)
        The field of view.

    Returns
    -------
    OpenVoronoi
        With fewer than 4 points every point is a boundary point and there is no bond.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    n = pts.shape[0]
    if n < 4:
        return _empty(n)
    x0, x1, y0, y1 = (float(v) for v in bounds)
    vor = Voronoi(pts)
    ridges = np.asarray(vor.ridge_points, dtype=np.int64)
    i = np.concatenate([ridges[:, 0], ridges[:, 1]])
    j = np.concatenate([ridges[:, 1], ridges[:, 0]])
    n_sides = np.bincount(i, minlength=n).astype(np.int64)
    verts = np.asarray(vor.vertices, dtype=float)
    reaches = np.zeros((n, 4), dtype=bool)
    centre = pts.mean(axis=0)
    for k in range(n):
        region = vor.regions[vor.point_region[k]]
        idx = np.asarray([v for v in region if v >= 0], dtype=np.int64)
        if idx.size:
            v = verts[idx]
            r = np.hypot(v[:, 0] - pts[k, 0], v[:, 1] - pts[k, 1])
            reaches[k] |= np.array([(v[:, 0] - r < x0).any(), (v[:, 0] + r > x1).any(),
                                    (v[:, 1] - r < y0).any(), (v[:, 1] + r > y1).any()])
        if -1 in region or not region:
            # unbounded: it opens away from the cloud of points, towards the nearest edges
            d = pts[k] - centre
            dist = np.array([pts[k, 0] - x0, x1 - pts[k, 0], pts[k, 1] - y0, y1 - pts[k, 1]])
            reaches[k, int(np.argmin(dist))] = True
            reaches[k] |= np.array([d[0] < 0, d[0] > 0, d[1] < 0, d[1] > 0]) & (dist <= np.sort(dist)[1])
    interior = ~reaches.any(axis=1)
    return OpenVoronoi(i, j, n_sides, interior, reaches)
