"""Records of arrays that the numba kernels pass around (namedtuples, which numba
compiles to plain tuples), and the layout of the float parameter vector.

A record groups the arrays of one role so that a kernel takes a few records instead of
dozens of positional arrays; the arrays themselves are described in :mod:`.geometry`
(contour arrays), :mod:`.rates` (scratch), :mod:`.verlet` (neighbour list) and
:mod:`fcsweep.kernels.contacts` (contact-jacobi's pair records).

A parallel kernel unpacks its records into local arrays at its top, before any prange
loop, and the functions inlined into a loop body take plain arrays: numba loses the
writes to an array reached through a tuple inside a parallel loop (numba issue #5872,
open; reproduced with numba 0.68 for a tuple unpacked inside an inlined function).
"""

from __future__ import annotations

from collections import namedtuple

#: cos(n phi_k), sin(n phi_k) [M1, K]; cos(phi_k), sin(phi_k) [K].
Tables = namedtuple("Tables", "cosn sinn cphi sphi")
#: Per-step work arrays, rebuilt every step.
Scratch = namedtuple("Scratch", "R dR px py tx ty geo W tbuf acc pbuf")
#: The cell list: cell of each particle, start of each cell's members, members.
CellList = namedtuple("CellList", "cell_of cell_start cell_members")
#: The Verlet list and what lives per list pair: the arc rule's share of the other
#: cell (``pairbuf``) and the position of each pair in the other cell's row (``back``:
#: ``nbr[nbr[i, p], back[i, p]] == i``), contact-jacobi's own shares and records
#: (``ownbuf``, ``pinfo``).
NeighbourList = namedtuple("NeighbourList", "nbr count ref_pos ref_rb valid pairbuf ownbuf pinfo back")
#: The deterministic rates of every cell.
Rates = namedtuple("Rates", "dpos dth da db")

#: Indices into the float parameter vector (:func:`fcsweep.kernels.api.param_vector`).
#: ``P_ADH``: adhesion strength gamma (0: off); ``P_ADHR``: its range delta in length units
#: (0 when adhesion is off, so that the neighbour lists are today's).  ``P_WALL``: the wall code
#: (0: periodic box, no wall; :data:`fcsweep.model.confinement.WALL_CODES`) and its geometry
#: ``P_WALLA..C``: well (cx, cy, R_w), channel (y_lo, y_hi, 0).
(P_LX, P_LY, P_R0, P_ETA, P_V0, P_MUT, P_MUS, P_DT, P_NOISE, P_SMAX, P_DMAX, P_SKIN, P_CONTACT, P_KFLOOR, P_SWEEPS,
 P_LAMMAX, P_ADH, P_ADHR, P_CORE, P_WALL, P_WALLA, P_WALLB, P_WALLC) = range(23)
N_PARAMS = 23
