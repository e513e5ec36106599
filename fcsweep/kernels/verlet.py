"""Verlet neighbour lists with a skin (numba).

Each cell keeps the cells j within ``Rb_i + Rb_j + skin`` (bounding radii at build time),
sorted by j so that pairs are always visited in the same order — the rates, and hence
trajectories, do not depend on when a list was rebuilt.  The list stays valid while
``2 max|r_i - r_i^0| + 2 max(Rb_i - Rb_i^0, 0) < skin`` (a pair that can touch now was
within the build cutoff then); it is rebuilt from the cell list otherwise.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .options import NJIT, njit


@njit(**NJIT)
def needs_rebuild(pos, geo, ref_pos, ref_rb, Lx, Ly, skin):
    """True if some cell moved or grew so much that the list may miss a pair."""
    dmax = 0.0
    gmax = 0.0
    for i in range(pos.shape[0]):
        dx = pos[i, 0] - ref_pos[i, 0]
        dy = pos[i, 1] - ref_pos[i, 1]
        dx -= Lx * np.rint(dx / Lx)
        dy -= Ly * np.rint(dy / Ly)
        dmax = max(dmax, dx * dx + dy * dy)
        gmax = max(gmax, geo[i, 1] - ref_rb[i])
    return 2.0 * math.sqrt(dmax) + 2.0 * gmax >= skin


@njit(parallel=True, **NJIT)
def build_verlet(pos, geo, Lx, Ly, skin, nx, ny, cell_of, cell_start, cell_members, nbr, count, ref_pos, ref_rb):
    """Fill ``nbr[i, :count[i]]`` (ascending j) from a cell list whose cells are at least
    ``2 max Rb + skin`` wide.  Returns False if a row overflowed ``nbr.shape[1]``."""
    N = pos.shape[0]
    cap = nbr.shape[1]
    ok = True
    for i in prange(N):
        n = 0
        xi = pos[i, 0]
        yi = pos[i, 1]
        rbi = geo[i, 1] + skin
        c = cell_of[i]
        cx = c % nx
        cy = c // nx
        for ox in range(-1, 2):
            ccx = (cx + ox + nx) % nx
            for oy in range(-1, 2):
                ccy = (cy + oy + ny) % ny
                cc = ccy * nx + ccx
                for p in range(cell_start[cc], cell_start[cc + 1]):
                    j = cell_members[p]
                    if j == i:
                        continue
                    dx = pos[j, 0] - xi
                    dy = pos[j, 1] - yi
                    dx -= Lx * np.rint(dx / Lx)
                    dy -= Ly * np.rint(dy / Ly)
                    cut = rbi + geo[j, 1]
                    if dx * dx + dy * dy < cut * cut:
                        if n < cap:
                            # insertion keeps the row sorted by j
                            q = n
                            while q > 0 and nbr[i, q - 1] > j:
                                nbr[i, q] = nbr[i, q - 1]
                                q -= 1
                            nbr[i, q] = j
                        n += 1
        count[i] = n
        ref_pos[i, 0] = xi
        ref_pos[i, 1] = yi
        ref_rb[i] = geo[i, 1]
    for i in range(N):
        if count[i] > cap:
            ok = False
    return ok


@njit(parallel=True, **NJIT)
def build_back(nbr, count, back):
    """``back[i, p] = q`` with ``nbr[j, q] == i`` for ``j = nbr[i, p]`` (-1 if j does not
    list i), once per list build: the per-step passes that collect a pair's share from
    the other cell's row look it up instead of searching the row."""
    for i in prange(nbr.shape[0]):
        for p in range(count[i]):
            j = nbr[i, p]
            back[i, p] = -1
            for q in range(count[j]):
                if nbr[j, q] == i:
                    back[i, p] = q
                    break
