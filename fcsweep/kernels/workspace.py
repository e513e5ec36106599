"""Preallocated scratch arrays and tables for the numba kernels (no per-step allocation)."""

from __future__ import annotations

import math

import numba
import numpy as np

from .contacts import J_COLS
from .geometry import LANES, mode_tables
from .pairs import QUADRATURE_CODES
from .records import CellList, NeighbourList, Rates, Scratch, Tables


class Workspace:
    """Tables and scratch for N cells, K contour points and M1 = M - 1 shape modes.

    Parameters
    ----------
    N, K, M1 : int
    box : (Lx, Ly) or None
        Sizes the cell-list arrays; ``None`` for open boundaries.
    R0 : float
        The mean radius.
    radii : ndarray, shape (N,), optional
        Per-cell radii R0,i (cell size differences), written once to column 5 of the
        geometry array that every kernel reads a cell's radius from; ``R0`` for all if
        omitted.
    pair_buffer : bool
        Allocate the per-pair buffer the arc rule needs (N x list capacity x (4 + 2 M1)
        doubles: 18 MB at N = 10^4); the other rules never read it.
    pair_records : bool
        Allocate the per-pair shares and records of the contact-jacobi integrator
        (N x list capacity x (4 + 2 M1 + 6) doubles); needs ``pair_buffer``.
    """

    def __init__(self, N, K, M1, box, R0=1.0, pair_buffer=True, pair_records=False, radii=None):
        self.N, self.K, self.M1 = int(N), int(K), int(M1)
        self.pair_buffer = bool(pair_buffer)
        self.pair_records = bool(pair_records) and self.pair_buffer
        self.tables = Tables(*mode_tables(self.K, self.M1))
        self.scratch = Scratch(
            np.zeros((N, K)),  # R
            np.zeros((N, K)),  # dR
            np.zeros((N, 2 * K + LANES)),  # px
            np.zeros((N, 2 * K + LANES)),  # py
            np.zeros((N, 2 * K + LANES)),  # tx
            np.zeros((N, 2 * K + LANES)),  # ty
            # geo: a0, bounding radius, cos, sin theta, largest sampled radius, own radius
            np.zeros((N, 6)),
            np.zeros((N, 2 * K + LANES)),  # W: point weights, periodic like px
            np.zeros((numba.config.NUMBA_NUM_THREADS, 8, 4 * K + 8)),  # tbuf: window scratch, Gauss nodes
            np.zeros((N, 4 + 2 * self.M1)),  # acc: arc integrals
            # pbuf: one pair's share (contact-implicit integrator), per thread
            np.zeros((numba.config.NUMBA_NUM_THREADS, max(2 * K + LANES, 4 + 2 * self.M1))),
        )
        self.scratch.geo[:, 5] = R0 if radii is None else np.asarray(radii, dtype=float).reshape(N)
        # cells of side >= 2 R0 (a0 + s) >= 2 R0 a0 >= 2 R0 / sqrt(3) ... bounded count (the
        # largest cell sets the side: with sizes it is >= the mean R0, so this bound holds)
        if box is None:
            ncell = 1
        else:
            side = 2.0 * R0 / math.sqrt(3.0) * 0.999
            ncell = min(int(box[0] // side + 1) * int(box[1] // side + 1), max(4 * N, 9))
        self.cl = CellList(np.zeros(N, np.int64), np.zeros(ncell + 1, np.int64), np.zeros(N, np.int64))
        self.nl = self.neighbour_list(16)
        self.out = Rates(np.zeros((N, 2)), np.zeros(N), np.zeros((N, M1)), np.zeros((N, M1)))
        self.flags = np.zeros(N, np.int64)

    def neighbour_list(self, capacity):
        """(nbr, count, reference positions, reference bounding radii, valid flag, pair
        buffer, own shares, pair records, back index) for up to ``capacity`` neighbours
        per cell.  The pair buffer holds, for the arc rule, the share of list pair (i, p)
        that cell nbr[i, p] collects, found through the back index; contact-jacobi keeps
        i's share and the pair's record (:mod:`fcsweep.kernels.contacts`)."""
        N = self.N
        rows = N * capacity if self.pair_buffer else 0
        records = rows if self.pair_records else 0
        return NeighbourList(np.zeros((N, capacity), np.int64), np.zeros(N, np.int64), np.zeros((N, 2)), np.zeros(N),
                             np.zeros(1, np.int64), np.zeros((rows, 4 + 2 * self.M1)),
                             np.zeros((records, 4 + 2 * self.M1)), np.zeros((records, J_COLS)),
                             np.zeros((N if self.pair_buffer else 0, capacity), np.int64))

    def grow_neighbour_list(self):
        """Double the neighbour-list capacity (after a LIST_FULL status); forces a rebuild."""
        self.nl = self.neighbour_list(2 * self.nl[0].shape[1])


#: Verlet skin in units of R0: lists are rebuilt after a cell moved ~skin/2.
SKIN = 0.3


def workspace_for(N, K, M1, box, R0, quadrature, integrator="euler", radii=None):
    """A :class:`Workspace` for one quadrature and integrator: the pair buffer only for the
    arc rule, the pair records only for contact-jacobi; ``radii`` the per-cell R0,i."""
    arc = quadrature_code(quadrature) == QUADRATURE_CODES["arc"]
    return Workspace(N, K, M1, box, R0, pair_buffer=arc, pair_records=integrator == "contact-jacobi", radii=radii)


def quadrature_code(name):
    """Integer code of a quadrature name; ValueError naming the allowed ones."""
    try:
        return QUADRATURE_CODES[name]
    except KeyError:
        raise ValueError(f"quadrature must be one of {sorted(QUADRATURE_CODES)}; got {name!r}") from None
