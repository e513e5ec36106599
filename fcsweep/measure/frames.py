"""Per frame: shape statistics, Voronoi defects and their clusters, hexatic order.

The names are those of the simulated datasets where they exist (docs/measure.md):

- ``q_mean``, ``q_mean_err`` (standard error over the cells of the frame),
  ``q_frac_above`` (fraction with q > 3.81) over the measured cells (``shape_flag`` 0: not
  cut by the image edge, not split, not a sliver); ``n_split``, ``n_sliver``,
  ``n_unresolved`` count the others;
- ``rho_d``: defects / classified cells, on the Voronoi of the centroids with open
  boundaries (:func:`fcsweep.analysis.voronoi_open.open_voronoi`): a cell whose Voronoi
  region reaches the edge of the field of view is neither defect nor non-defect;
- ``n_clusters`` and ``largest_cluster_fraction`` (largest cluster / classified cells) of the
  defect clusters over Voronoi adjacency (:func:`fcsweep.analysis.voronoi.defect_clusters`);
- ``percolated``: ``rho_d > percolation_threshold`` (the simulation's rule, default 1/2);
- ``spanning``: a defect cluster touches two opposite edges (one of its cells is a Voronoi
  neighbour of a boundary cell on the left and on the right, or at the bottom and top);
- ``psi6``: ``|mean psi6_i|`` over the classified cells, ``psi6_i`` over all Voronoi
  neighbours.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from fcsweep.analysis.voronoi import defect_mask
from fcsweep.analysis.voronoi_open import open_voronoi
from fcsweep.model.settings import PERCOLATION_THRESHOLD
from fcsweep.model.shape import Q_STAR

__all__ = ["frame_statistics", "FRAME_FIELDS", "PERCOLATION_THRESHOLD"]

#: Per-frame outputs of :func:`frame_statistics`.
FRAME_FIELDS = ("n_cells", "n_edge_cut", "n_split", "n_sliver", "n_unresolved",
                "n_boundary", "n_classified", "q_mean", "q_mean_err", "q_frac_above",
                "rho_d", "n_defects", "n_clusters", "largest_cluster_fraction", "percolated", "spanning", "psi6")


def _clusters(defect: np.ndarray, i: np.ndarray, j: np.ndarray):
    """Component label of every defect cell over defect-defect bonds (-1 elsewhere)."""
    n = defect.size
    keep = defect[i] & defect[j]
    g = coo_matrix((np.ones(int(keep.sum())), (i[keep], j[keep])), shape=(n, n)).tocsr()
    _, comp = connected_components(g, directed=False)
    return np.where(defect, comp, -1)


def frame_statistics(cells: dict, bounds, threshold: float = PERCOLATION_THRESHOLD, graph=None) -> dict:
    """The per-frame numbers of one measured frame.

    Parameters
    ----------
    cells : dict
        Output of :func:`fcsweep.measure.cells.measure_cells`.
    bounds : (x0, x1, y0, y1)
        Field of view in length units.
    threshold : float
        rho_d above which the frame is percolated.
    graph : OpenVoronoi, optional
        The neighbour graph; default the Voronoi of the centroids with open boundaries
        (the touching-neighbour graph: :func:`fcsweep.measure.contacts.contact_graph`).

    Returns
    -------
    dict
        The :data:`FRAME_FIELDS` (floats; NaN where undefined, e.g. no classified cell),
        plus per-cell ``n_sides`` (int, -1 for boundary cells) and ``defect`` (int8: 1
        defect, 0 not, -1 boundary), and ``bonds`` (int, (B, 2)): the neighbour pairs
        ``i < j`` of classified cells.
    """
    pos = np.stack([cells["x"], cells["y"]], axis=1)
    n = pos.shape[0]
    flag = cells["shape_flag"]
    q = cells["q"][flag == 0]
    q = q[np.isfinite(q)]
    out = dict.fromkeys(FRAME_FIELDS, np.nan)
    out.update(n_cells=n, n_edge_cut=int(cells["edge_cut"].sum()), n_split=int(np.sum(flag == 2)),
               n_sliver=int(np.sum(flag == 3)), n_unresolved=int(np.sum(flag == 4)))
    if q.size:
        out.update(q_mean=float(q.mean()), q_frac_above=float(np.mean(q > Q_STAR)),
                   q_mean_err=float(q.std(ddof=1) / np.sqrt(q.size)) if q.size > 1 else np.nan)
    vor = open_voronoi(pos, bounds) if graph is None else graph
    inner = vor.interior
    n_in = int(inner.sum())
    defect = defect_mask(vor.n_sides) & inner
    out.update(n_boundary=n - n_in, n_classified=n_in)
    out["n_sides"] = np.where(inner, vor.n_sides, -1)
    out["defect"] = np.where(inner, defect.astype(np.int8), np.int8(-1)).astype(np.int8)
    both = inner[vor.i] & inner[vor.j] & (vor.i < vor.j)
    out["bonds"] = np.stack([vor.i[both], vor.j[both]], axis=1)
    if n_in == 0:
        return out
    comp = _clusters(defect, vor.i, vor.j)
    sizes = np.bincount(comp[comp >= 0]) if defect.any() else np.zeros(0, dtype=np.int64)
    sizes = sizes[sizes > 0]
    rho = float(defect.sum() / n_in)
    out.update(rho_d=rho, n_defects=int(defect.sum()), n_clusters=int(sizes.size),
               largest_cluster_fraction=float(sizes.max() / n_in) if sizes.size else 0.0,
               percolated=float(rho > threshold))
    # which edges each cluster touches, through its bonds to boundary cells
    touch = {}
    bond = (comp[vor.i] >= 0) & ~inner[vor.j]
    for c, k in zip(comp[vor.i[bond]], vor.j[bond]):
        touch[c] = touch.get(c, np.zeros(4, dtype=bool)) | vor.reaches[k]
    out["spanning"] = float(any((t[0] and t[1]) or (t[2] and t[3]) for t in touch.values()))
    d = pos[vor.j] - pos[vor.i]
    z = np.exp(6j * np.arctan2(d[:, 1], d[:, 0]))
    psi = np.bincount(vor.i, weights=z.real, minlength=n) + 1j * np.bincount(vor.i, weights=z.imag, minlength=n)
    psi = psi / np.maximum(np.bincount(vor.i, minlength=n), 1)
    out["psi6"] = float(np.abs(psi[inner].mean()))
    return out
