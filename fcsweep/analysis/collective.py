"""How many independent cells a displacement average really holds.

Cells that move together (swirls, box-scale modes of a dense active layer) are not
independent samples: the error of a mean over ``N`` cells is ``sqrt(g var / N)`` with a
*spatial statistical inefficiency* ``g``, the spatial twin of ``1 + 2 tau_int`` of a time
series (``g = 1`` for independent cells, ``g = N`` when all move as one).

:func:`spatial_inefficiency` measures it on the squared displacements ``s_i = |u_i|^2``
over a short lag ``m``, from consecutive, non-overlapping windows (origins ``0, m, 2m,
...``): the cell average ``S = mean_i s_i`` fluctuates from window to window by
``var(S) = g var_i(s) / N``. Independent cells give ``var(S) = var_i(s) / N``; a few
collective modes that carry the motion make every cell's ``s_i`` rise and fall together
and ``var(S)`` is of the order of ``var_i(s)``. Pair correlations of the displacement
vectors ``u_i . u_j`` would miss them: over a periodic box the correlation of a box
mode sums to zero, while the squared displacements of all cells still share its random
amplitude, which is what the error of a mean squared displacement sees.
"""

from __future__ import annotations

import numpy as np

#: Fewest windows from which the window-to-window variance is used.
MIN_WINDOWS = 8


def spatial_inefficiency(displacements, *, windows: int = 16) -> float:
    """Spatial statistical inefficiency of squared displacements (see module doc).

    Parameters
    ----------
    displacements : ndarray, shape (T, N, 2)
        Drift-subtracted displacements of ``N`` cells from the first frame, at ``T``
        equally spaced frames (unwrapped positions minus the first frame work too).
    windows : int
        Number of consecutive windows the frames are cut into (their length is the lag).

    Returns
    -------
    float
        ``g`` in ``[1, N]``; 1 when there are too few frames or cells to measure it.
    """
    d = np.asarray(displacements, dtype=float)
    T, N = d.shape[:2]
    m, k = inefficiency_windows(T, windows)
    if N < 2 or k < MIN_WINDOWS:
        return 1.0
    return inefficiency_of_squares(window_squares(d, m, k))


def inefficiency_windows(T: int, windows: int = 16) -> tuple[int, int]:
    """Lag ``m`` (frames) and number ``k`` of the windows :func:`spatial_inefficiency` uses
    on ``T`` frames (it returns 1 where ``k < MIN_WINDOWS``)."""
    m = max(1, (T - 1) // max(int(windows), 1))
    return m, (T - 1) // m


def window_squares(d: np.ndarray, m: int, k: int) -> np.ndarray:
    """Squared increments ``|d(j m + m) - d(j m)|^2``, shape ``(k, N)``, of displacements
    ``d`` (T, N, 2): cell by cell, so blocks of cells can be done apart."""
    u = d[m:(k + 1) * m:m] - d[0:k * m:m]  # (k, N, 2) consecutive increments over lag m
    return np.sum(u * u, axis=-1)


def inefficiency_of_squares(s: np.ndarray) -> float:
    """``g`` of :func:`spatial_inefficiency` from the squared window increments ``s`` (k, N)."""
    N = s.shape[1]
    within = float(np.mean(s.var(axis=1, ddof=1)))
    if within <= 0:
        return 1.0
    g = N * float(s.mean(axis=1).var(ddof=1)) / within
    return float(min(max(g, 1.0), N))
