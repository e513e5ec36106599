"""Periodic Voronoi neighbours of cell centroids, defect cells and defect clusters.

The tessellation is freud's (voro++) in a 2-D periodic box.  freud boxes are centred at
the origin; positions given in ``[0, Lx) x [0, Ly)`` are shifted by half the box.
A cell's neighbour count is its number of Voronoi edges (sides).  A defect is a cell
with a count different from 6 (docs/model.md); ``rho_d`` = defects / N.  Defect clusters are
connected components of defect cells over Voronoi adjacency
(``scipy.sparse.csgraph.connected_components``).

Shuffled control: the same largest-cluster statistic with the defect labels permuted at
random over the cells of each frame's own Voronoi graph (:func:`shuffled_defects`).  The
permutation keeps the graph and the number of defects (so rho_d) and destroys every
correlation of the labels with each other and with the graph: on a planar triangulation
that is random site percolation, whose threshold is 1/2.  The permutation of the frame
with trajectory index ``k`` is drawn from ``numpy.random.default_rng((SHUFFLE_SEED, k))``,
so a re-analysis of the same frames gives the same numbers.

Cells of different sizes (``particles/cells/R0`` in the trajectory) are tessellated by
the radical (Laguerre, power) tessellation instead, whose edges lie where the tangent
lengths to the two cells' circles of radius R0,i are equal, so that a large cell is not
cut by the bisector of its small neighbour (:func:`laguerre_bonds`).  freud's Voronoi
(voro++ ``container``) takes no radii (freud 3: ``Voronoi.compute(system)`` only), so
the bonds come from the lower convex hull of the lifted points (x, y, x^2 + y^2 - R0,i^2)
(scipy's qhull) over the periodic 3 x 3 images; with equal radii this is the Delaunay
triangulation, the dual of freud's tessellation.
"""

from __future__ import annotations

from dataclasses import dataclass

import freud
import numpy as np
from scipy.spatial import ConvexHull, Delaunay
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from fcsweep.analysis.frames import FrameSource
from fcsweep.analysis.stats import time_average

#: Above this many cells the Voronoi bonds come from scipy's Delaunay triangulation
#: (:func:`delaunay_bonds`). freud 3.4's Voronoi takes ~24 kB per cell while it runs
#: (2.4 GB at N = 99 856, against 0.1 GB for the Delaunay bonds, which are 2.7x faster
#: there), and it failed at 7·10^5 random points and on a 10^6-cell near-lattice. Up to
#: 2^16 cells freud's tessellation is kept, so analyses there are unchanged bit for bit.
FREUD_VORONOI_MAX = 65_536

#: First entry of the seed of the label permutation of each frame (the second is the frame index).
SHUFFLE_SEED = 3206


def freud_system(pos: np.ndarray, box) -> tuple:
    """A freud ``(Box, points)`` system for 2-D positions in ``[0, Lx) x [0, Ly)``."""
    pos = np.asarray(pos, dtype=float)
    Lx, Ly = float(box[0]), float(box[1])
    fbox = freud.box.Box(Lx, Ly, is2D=True)
    p3 = np.zeros((pos.shape[0], 3), dtype=float)
    p3[:, :2] = pos - np.array([Lx, Ly]) / 2.0
    p3[:, :2] = p3[:, :2] - np.array([Lx, Ly]) * np.round(p3[:, :2] / np.array([Lx, Ly]))
    return fbox, p3


@dataclass
class VoronoiNeighbors:
    """Voronoi bonds of one frame.

    Attributes
    ----------
    i, j : ndarray of int, shape (B,)
        Directed bonds ``i -> j``, one per Voronoi edge of cell ``i``.
    vectors : ndarray, shape (B, 2)
        Minimum-image bond vectors ``r_j - r_i``.
    n_sides : ndarray of int, shape (N,)
        Voronoi edges per cell.
    nlist : freud.locality.NeighborList
        The same bonds, for reuse in freud computations.
    """

    i: np.ndarray
    j: np.ndarray
    vectors: np.ndarray
    n_sides: np.ndarray
    nlist: object


def laguerre_bonds(pos: np.ndarray, box, radii) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directed bonds of the periodic radical (Laguerre) tessellation of discs of radii
    ``radii`` at ``pos`` in ``box``: (i, j, r_j - r_i minimum image), one per edge of i.

    The regular triangulation (dual of the power diagram) is the lower convex hull of
    the points lifted to x^2 + y^2 - R_i^2; the central copy's bonds to any of the 3 x 3
    images are kept.  A cell whose lifted point lies above the hull (a tiny cell hidden
    among large ones) has no bonds.
    """
    pos = np.mod(np.asarray(pos, dtype=float), np.asarray(box, dtype=float))
    N = len(pos)
    L = np.asarray(box, dtype=float)
    shifts = np.array([(sx, sy) for sx in (-1, 0, 1) for sy in (-1, 0, 1)], dtype=float)
    pts = (pos[None, :, :] + shifts[:, None, :] * L).reshape(-1, 2)
    w = np.tile(np.asarray(radii, dtype=float) ** 2, len(shifts))
    hull = ConvexHull(np.column_stack([pts, (pts ** 2).sum(axis=1) - w]))
    faces = hull.simplices[hull.equations[:, 2] < 0]  # the lower hull
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    centre = 4 * N  # shift (0, 0) is the fifth of the nine copies
    e = e[(e[:, 0] >= centre) & (e[:, 0] < centre + N)]
    e = np.unique(e, axis=0)
    i, jimg = e[:, 0] - centre, e[:, 1]
    vec = pts[jimg] - pts[e[:, 0]]
    j = jimg % N
    order = np.lexsort((j, i))
    return i[order].astype(np.int64), j[order].astype(np.int64), vec[order]


def delaunay_bonds(pos: np.ndarray, box, margin: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directed bonds of the periodic Voronoi tessellation from scipy's 2-D Delaunay
    triangulation (its dual): (i, j, r_j - r_i minimum image), one per edge of i.

    The box is padded with the periodic images of the points within ``margin`` of its
    edges (default: 6 mean spacings, far beyond a Voronoi neighbour of a dense packing);
    the bonds of the central copy are kept.  Used above ``FREUD_VORONOI_MAX`` cells; the
    same bonds as freud's on dense packings (tests/test_voronoi_large.py) except where four
    centres are cocircular to rounding, whose vanishing edge one of them may keep (one
    edge of 3·10^5 in a frame of the N = 99 856 run).
    """
    L = np.asarray(box, dtype=float)
    pos = np.mod(np.asarray(pos, dtype=float), L)
    N = len(pos)
    m = 6.0 * np.sqrt(L.prod() / N) if margin is None else float(margin)
    pts, idx = [pos], [np.arange(N)]
    for sx in (-1, 0, 1):
        for sy in (-1, 0, 1):
            if sx == 0 and sy == 0:
                continue
            q = pos + np.array([sx, sy]) * L
            near = np.all((q > -m) & (q < L + m), axis=1)
            pts.append(q[near])
            idx.append(np.flatnonzero(near))
    pts, idx = np.concatenate(pts), np.concatenate(idx)
    tri = Delaunay(pts)
    t = tri.simplices
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    e = np.unique(e[e[:, 0] < N], axis=0)
    i, j = e[:, 0], idx[e[:, 1]]
    vec = pts[e[:, 1]] - pts[e[:, 0]]
    order = np.lexsort((j, i))
    return i[order].astype(np.int64), j[order].astype(np.int64), vec[order]


def _from_bonds(i, j, vec, N: int) -> VoronoiNeighbors:
    v3 = np.zeros((len(i), 3))
    v3[:, :2] = vec
    nl = freud.locality.NeighborList.from_arrays(N, N, i, j, v3)
    return VoronoiNeighbors(i, j, vec, np.bincount(i, minlength=N).astype(np.int64), nl)


def voronoi_neighbors(pos: np.ndarray, box, radii=None) -> VoronoiNeighbors:
    """Periodic Voronoi tessellation of the centroids ``pos`` (N, 2) in ``box`` (Lx, Ly);
    with per-cell ``radii`` (N,) the radical (Laguerre) one (:func:`laguerre_bonds`).
    Beyond ``FREUD_VORONOI_MAX`` cells from scipy's Delaunay triangulation
    (:func:`delaunay_bonds`): freud 3.4's Voronoi takes 24 kB per cell there and fails
    further up (a segmentation fault on a near-lattice of 10^6 cells,
    ``bad_array_new_length`` on 7·10^5 random points)."""
    if radii is None and len(pos) > FREUD_VORONOI_MAX:
        return _from_bonds(*delaunay_bonds(pos, box), len(pos))
    if radii is not None:
        return _from_bonds(*laguerre_bonds(pos, box, radii), len(pos))
    system = freud_system(pos, box)
    vor = freud.locality.Voronoi()
    vor.compute(system)
    nl = vor.nlist
    i = np.asarray(nl.query_point_indices, dtype=np.int64)
    j = np.asarray(nl.point_indices, dtype=np.int64)
    n_sides = np.bincount(i, minlength=len(pos)).astype(np.int64)
    vec = np.asarray(nl.vectors, dtype=float)[:, :2]
    return VoronoiNeighbors(i, j, vec, n_sides, nl)


def defect_mask(n_sides: np.ndarray) -> np.ndarray:
    """True for cells whose number of Voronoi neighbours differs from 6."""
    return np.asarray(n_sides) != 6


def defect_clusters(defect: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Sizes of the connected clusters of defect cells over the bonds ``(i, j)``.

    Parameters
    ----------
    defect : ndarray of bool, shape (N,)
    i, j : ndarray of int
        Neighbour bonds (either direction, duplicates allowed).

    Returns
    -------
    ndarray of int
        Cluster sizes, largest first; empty if there is no defect.
    """
    defect = np.asarray(defect, dtype=bool)
    N = defect.size
    idx = np.flatnonzero(defect)
    if idx.size == 0:
        return np.zeros(0, dtype=np.int64)
    keep = defect[i] & defect[j]
    g = coo_matrix((np.ones(int(keep.sum())), (i[keep], j[keep])), shape=(N, N)).tocsr()
    _, labels = connected_components(g, directed=False)
    sizes = np.bincount(labels[idx])
    sizes = sizes[sizes > 0]
    return np.sort(sizes)[::-1].astype(np.int64)


def cluster_size_counts(sizes: np.ndarray, N: int) -> np.ndarray:
    """Number of clusters of each size ``s = 1 .. N`` (index ``s - 1``)."""
    sizes = np.asarray(sizes, dtype=np.int64)
    return np.bincount(sizes, minlength=N + 1)[1:N + 1].astype(np.int64)


def shuffled_defects(defect: np.ndarray, frame_index: int) -> np.ndarray:
    """The defect labels permuted over the cells, reproducibly for one frame.

    Parameters
    ----------
    defect : ndarray of bool, shape (N,)
    frame_index : int
        Index of the frame in its trajectory; the permutation is drawn from
        ``numpy.random.default_rng((SHUFFLE_SEED, frame_index))``.

    Returns
    -------
    ndarray of bool, shape (N,)
        The same number of True entries at uniformly random cells.
    """
    rng = np.random.default_rng((SHUFFLE_SEED, int(frame_index)))
    return rng.permutation(np.asarray(defect, dtype=bool))


def defect_statistics(frames_pos, box, frame_indices=None, each=None, radii=None) -> dict:
    """Defect fraction and clusters averaged over frames.

    Parameters
    ----------
    frames_pos : ndarray, shape (F, N, 2), or fcsweep.analysis.frames.FrameSource
    box : (Lx, Ly)
    frame_indices : array_like of int, shape (F,), optional
        Trajectory index of each frame, the seed of its label permutation
        (:func:`shuffled_defects`); default ``0 .. F-1``.
    each : callable, optional
        Called as ``each(f, vn)`` with every frame's :class:`VoronoiNeighbors` (``f`` in
        ``0 .. F-1``), so that another per-frame step reuses the tessellation.
    radii : ndarray, shape (N,), optional
        Per-cell radii (cell size differences): the radical tessellation.

    Returns
    -------
    dict
        ``rho_d`` (defect fraction), ``largest_cluster_fraction`` (s_max / N): time
        averages (:func:`fcsweep.analysis.stats.time_average`, after equilibration
        detection) with ``_err`` (1-sigma, autocorrelation of the frame series) and
        ``_start`` (first frame kept); ``largest_cluster_fraction_shuffled``, the same
        for the defect labels permuted over the cells of each frame's graph (same
        rho_d, correlations destroyed; :func:`shuffled_defects`), with ``_err`` and
        ``_start``; ``rho_d_frames``, ``largest_cluster_fraction_frames`` and
        ``largest_cluster_fraction_shuffled_frames`` (the per-frame series),
        ``cluster_size_counts`` (int, shape (N,), pooled over frames),
        ``n_sides_counts`` (int, shape (13,), cells with 0..12 sides pooled), ``n_frames``.
    """
    if not isinstance(frames_pos, FrameSource):  # a frame source is read a frame at a time
        frames_pos = np.asarray(frames_pos, dtype=float)
    F, N, _ = frames_pos.shape
    frame_indices = np.arange(F) if frame_indices is None else np.asarray(frame_indices, dtype=np.int64)
    if frame_indices.shape != (F,):
        raise ValueError(f"frame_indices must have one entry per frame ({F}), got shape {frame_indices.shape}")
    rho, pmax, pshuf = np.empty(F), np.empty(F), np.empty(F)
    counts = np.zeros(N, dtype=np.int64)
    sides = np.zeros(13, dtype=np.int64)
    for f in range(F):
        vn = voronoi_neighbors(frames_pos[f], box, radii)
        if each is not None:
            each(f, vn)
        d = defect_mask(vn.n_sides)
        rho[f] = d.mean()
        sizes = defect_clusters(d, vn.i, vn.j)
        pmax[f] = sizes[0] / N if sizes.size else 0.0
        counts += cluster_size_counts(sizes, N)
        shuf = defect_clusters(shuffled_defects(d, frame_indices[f]), vn.i, vn.j)
        pshuf[f] = shuf[0] / N if shuf.size else 0.0
        sides += np.bincount(np.minimum(vn.n_sides, 12), minlength=13)
    out = {"cluster_size_counts": counts, "n_sides_counts": sides, "n_frames": F,
           "rho_d_frames": rho, "largest_cluster_fraction_frames": pmax,
           "largest_cluster_fraction_shuffled_frames": pshuf}
    for name, series in (("rho_d", rho), ("largest_cluster_fraction", pmax),
                         ("largest_cluster_fraction_shuffled", pshuf)):
        ta = time_average(series)
        out.update({name: ta.mean, f"{name}_err": ta.err, f"{name}_start": ta.start})
    return out
