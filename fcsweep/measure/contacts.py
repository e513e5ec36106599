"""The touching-neighbour graph of label masks: the alternative to the Voronoi rule.

Two cells are neighbours when their masks touch: pixels of the two labels within
``gap + 1`` pixels of each other along a row, a column or a diagonal (``gap`` pixels of
background allowed between them, as segmentations often leave a thin line between
cells).  Cells cut by the image edge are not classified (their neighbours outside are not
seen); every other cell is, with its number of touching neighbours as its ``n_sides``.
The result has the fields of :class:`fcsweep.analysis.voronoi_open.OpenVoronoi`, so the
per-frame statistics take either graph.
"""

from __future__ import annotations

import numpy as np

from fcsweep.analysis.voronoi_open import OpenVoronoi

__all__ = ["contact_graph", "CONTACT_GAP"]

#: Background pixels allowed between touching masks (0: masks that share a side or a corner).
CONTACT_GAP = 0


def _pairs(frame: np.ndarray, dy: int, dx: int) -> np.ndarray:
    ny, nx = frame.shape
    a = frame[max(0, -dy):ny - max(0, dy), max(0, -dx):nx - max(0, dx)]
    b = frame[max(0, dy):ny + min(0, dy) or None, max(0, dx):nx + min(0, dx) or None]
    keep = (a > 0) & (b > 0) & (a != b)
    return np.stack([a[keep], b[keep]], axis=1)


def contact_graph(frame: np.ndarray, labels: np.ndarray, gap: int = CONTACT_GAP) -> OpenVoronoi:
    """Touching-neighbour graph of the cells ``labels`` (in this order) of a label frame.

    Parameters
    ----------
    frame : ndarray of int, shape (Y, X)
    labels : ndarray of int, shape (N,)
        The labels present, in the order of the cells.
    gap : int
        Background pixels allowed between touching masks.

    Returns
    -------
    OpenVoronoi
        Bonds ``i, j`` (cell indices, both directions), ``n_sides`` (touching neighbours),
        ``interior`` (not cut by the image edge), ``reaches`` (the image edges a cut mask
        touches: left, right, bottom = row 0, top = last row).
    """
    frame = np.asarray(frame)
    shifts = [(dy, dx) for d in range(1, gap + 2) for dy, dx in ((0, d), (d, 0), (d, d), (d, -d))]
    pairs = np.concatenate([_pairs(frame, dy, dx) for dy, dx in shifts] + [np.zeros((0, 2), frame.dtype)])
    pairs = np.unique(np.sort(pairs, axis=1), axis=0)
    index = np.full(int(frame.max()) + 1, -1, dtype=np.int64)
    index[labels] = np.arange(len(labels))
    i = np.concatenate([index[pairs[:, 0]], index[pairs[:, 1]]])
    j = np.concatenate([index[pairs[:, 1]], index[pairs[:, 0]]])
    n = len(labels)
    reaches = np.zeros((n, 4), dtype=bool)
    for k, edge in enumerate((frame[:, 0], frame[:, -1], frame[0, :], frame[-1, :])):
        hit = np.unique(edge[edge > 0])
        reaches[index[hit], k] = True
    return OpenVoronoi(i, j, np.bincount(i, minlength=n).astype(np.int64), ~reaches.any(axis=1), reaches)
