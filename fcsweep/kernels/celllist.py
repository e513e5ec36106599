"""Cell list on the periodic box (numba).

The cell size is at least the largest possible interaction range, twice the largest
bounding radius, so every pair that can touch lies in the same or an adjacent cell.
With fewer than three cells along an axis the list is not used and the pair loop
visits every cell and every periodic image (tiny boxes only).
"""

from __future__ import annotations

import math


from .options import NJIT, njit


@njit(**NJIT)
def grid_shape(Lx, Ly, cutoff, N):
    """Number of grid cells along x and y for a side of at least ``cutoff``.

    In dilute systems the grid is coarsened to at most ``max(4 N, 9)`` cells (sides
    stay >= cutoff), so that building the list costs O(N), not O(box area).
    """
    nx = max(int(Lx // cutoff), 1)
    ny = max(int(Ly // cutoff), 1)
    cap = max(4 * N, 9)
    if nx * ny > cap:
        f = math.sqrt(nx * ny / cap)
        nx = max(3, int(nx / f))
        ny = max(3, int(ny / f))
    return nx, ny


@njit(**NJIT)
def build_cell_list(pos, Lx, Ly, nx, ny, cell_of, cell_start, cell_members):
    """Counting sort of the cells into an ``nx`` x ``ny`` grid.

    Parameters
    ----------
    pos : float64[N, 2]
        Wrapped positions in [0, Lx) x [0, Ly).
    cell_of : int64[N]
        Output: grid cell of each biological cell.
    cell_start : int64[nx*ny + 1]
        Output: members of grid cell c are ``cell_members[cell_start[c]:cell_start[c+1]]``.
    cell_members : int64[N]
        Output.
    """
    N = pos.shape[0]
    ncell = nx * ny
    for c in range(ncell + 1):
        cell_start[c] = 0
    for i in range(N):
        cx = int(pos[i, 0] / Lx * nx)
        cy = int(pos[i, 1] / Ly * ny)
        if cx >= nx:
            cx = nx - 1
        if cy >= ny:
            cy = ny - 1
        if cx < 0:
            cx = 0
        if cy < 0:
            cy = 0
        c = cy * nx + cx
        cell_of[i] = c
        cell_start[c + 1] += 1
    for c in range(ncell):
        cell_start[c + 1] += cell_start[c]
    # fill, stable in i so that the order is deterministic
    fill = cell_start[:ncell].copy()
    for i in range(N):
        c = cell_of[i]
        cell_members[fill[c]] = i
        fill[c] += 1
