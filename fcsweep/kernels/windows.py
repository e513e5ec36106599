"""Angular windows of a pair (numba kernels): which of cell i's contour points can lie
inside cell j, and the radial gaps of those points to j's contour.

Arrays as in :mod:`.geometry`; ``tb`` is the calling thread's scratch block of
``tbuf`` (float64[threads, 8, 4K + 8]).
"""

from __future__ import annotations

import math

import numpy as np

from .fourier import fourier6, modes6
from .geometry import LANES, atan2_fast
from .options import NJIT, njit

#: Safety margin of the angular windows, in radians (>> the atan2_fast error).
WINDOW_MARGIN = 1e-3


@njit(inline="always", **NJIT)
def angular_window(dx, dy, D, c_i, s_i, rho_max, rbj, K):
    """Contour points of cell i that can lie in the bounding circle of j.

    A point at distance rho <= rho_max from r_i in direction beta is within ``rbj`` of
    r_j (distance D, direction alpha) only if cos(beta - alpha) > (rho^2 + D^2 - rbj^2)
    / (2 rho D); the loosest such bound over rho gives the half-width of the window.
    Returns the first index (0 <= k0 < K) and the count (K for the whole contour).
    """
    if D <= rbj * (1.0 + 1e-12):
        return 0, K
    tangent2 = D * D - rbj * rbj
    if rho_max * rho_max >= tangent2:
        sin_half = rbj / D  # the window reaches the tangent lines of j's circle
        half = atan2_fast(sin_half, math.sqrt(tangent2) / D)
    else:
        cos_half = (rho_max * rho_max + tangent2) / (2.0 * rho_max * D)
        if cos_half >= 1.0:
            return 0, 0
        half = atan2_fast(math.sqrt(1.0 - cos_half * cos_half), cos_half)
    # direction of r_j - r_i in the body frame of i
    bx = dx * c_i + dy * s_i
    by = dy * c_i - dx * s_i
    dphi = 2.0 * math.pi / K
    centre = atan2_fast(by, bx) / dphi
    half = (half + WINDOW_MARGIN) / dphi
    lo = int(math.floor(centre - half))
    hi = int(math.ceil(centre + half))
    cnt = hi - lo + 1
    if cnt >= K:
        return 0, K
    k0 = lo % K
    if k0 < 0:
        k0 += K
    return k0, cnt


@njit(inline="always", **NJIT)
def binary_window(i, j, dx, dy, k0, cnt, a, b, geo, px, py, R0, W):
    """Binary rule: add 1 to ``W[i, kk]`` for each window point kk inside cell j.

    One branch-free loop that the compiler vectorises; the window is padded up to a
    multiple of LANES points (the extra points lie outside the window's cone, so they
    test outside).  ``px``, ``py`` and ``W`` have 2K + LANES periodic columns so that a
    window never wraps.  Points beyond j's bounding circle are masked out.  (In this
    module ``R0`` is replaced by cell j's own radius ``geo[j, 5]``.)
    """
    R0 = geo[j, 5]
    a2, a3, a4, a5, a6, b2, b3, b4, b5, b6 = modes6(a, b, j)
    a0 = geo[j, 0]
    ct = geo[j, 2]
    st = geo[j, 3]
    rb2 = geo[j, 1] * geo[j, 1]
    # unsigned indices: numba then emits no negative-index wraparound, and LLVM
    # vectorises the loop across points
    ui = np.uint64(i)
    start = np.uint64(k0)
    stop = start + np.uint64((cnt + LANES - 1) // LANES * LANES)
    for kk in range(start, stop):
        ox = px[ui, kk] - dx
        oy = py[ui, kk] - dy
        d2 = ox * ox + oy * oy
        r = math.sqrt(d2)
        inv = 1.0 / max(r, 1e-300)
        c = (ox * ct + oy * st) * inv
        s = (oy * ct - ox * st) * inv
        rr, _ = fourier6(c, s, a2, a3, a4, a5, a6, b2, b3, b4, b5, b6)
        inside = (R0 * (a0 + rr) > r) & (d2 < rb2)
        W[ui, kk] += 1.0 if inside else 0.0


@njit(inline="always", **NJIT)
def window_gaps6(i, j, dx, dy, k0, n, slopes, a, b, geo, px, py, tx, ty, R0, h, tb, tid):
    """Gap g (row 6 of ``tb``) and, if ``slopes``, h dg/dphi (row 7) at the window
    points k0 .. k0+n-1 of cell i relative to cell j, for M <= 6 (vectorised loop).

    dg/dphi = R_j'(psi) dpsi/dphi - d.t/|d| with t = dx_i/dphi the contour tangent and
    dpsi/dphi = (d x t)/|d|^2.
    """
    R0 = geo[j, 5]
    a2, a3, a4, a5, a6, b2, b3, b4, b5, b6 = modes6(a, b, j)
    a0 = geo[j, 0]
    ct = geo[j, 2]
    st = geo[j, 3]
    ui = np.uint64(i)
    ut = np.uint64(tid)
    start = np.uint64(k0)
    for m in range(np.uint64(0), np.uint64(n)):
        kk = start + m
        ox = px[ui, kk] - dx
        oy = py[ui, kk] - dy
        r = math.sqrt(ox * ox + oy * oy)
        inv = 1.0 / max(r, 1e-300)
        c = (ox * ct + oy * st) * inv
        s = (oy * ct - ox * st) * inv
        rr, drr = fourier6(c, s, a2, a3, a4, a5, a6, b2, b3, b4, b5, b6)
        tb[ut, 6, m] = R0 * (a0 + rr) - r
        if slopes:
            txk = tx[ui, kk]
            tyk = ty[ui, kk]
            dpsi = (ox * tyk - oy * txk) * inv * inv
            tb[ut, 7, m] = (R0 * drr * dpsi - (ox * txk + oy * tyk) * inv) * h


@njit(inline="always", **NJIT)
def window_gaps_generic(i, j, dx, dy, k0, cnt, slopes, a, b, geo, R, dR, px, py, cphi, sphi, R0, tb, tid):
    """Radial gaps of the contour points k0 .. k0+cnt-1 of cell i relative to cell j.

    Written as three short loops over the window (direction cosines; the mode
    recurrence; the gap) so that the compiler vectorises them across points.  Row 6 of
    ``tb`` receives g, row 7 dg/dphi when ``slopes`` is set (arc rule).
    """
    R0 = geo[j, 5]
    K = cphi.shape[0]
    M1 = a.shape[1]
    ct = geo[j, 2]
    st = geo[j, 3]
    for m in range(cnt):
        ox = px[i, k0 + m] - dx
        oy = py[i, k0 + m] - dy
        r = math.sqrt(ox * ox + oy * oy)
        inv = 1.0 / max(r, 1e-300)
        c = (ox * ct + oy * st) * inv
        s = (oy * ct - ox * st) * inv
        tb[tid, 0, m] = c
        tb[tid, 1, m] = s
        tb[tid, 2, m] = c
        tb[tid, 3, m] = s
        tb[tid, 4, m] = geo[j, 0]
        tb[tid, 5, m] = r
        tb[tid, 7, m] = 0.0
    for mm in range(M1):
        am = a[j, mm]
        bm = b[j, mm]
        nn = mm + 2.0
        for m in range(cnt):
            c = tb[tid, 0, m]
            s = tb[tid, 1, m]
            cn = tb[tid, 2, m] * c - tb[tid, 3, m] * s
            sn = tb[tid, 3, m] * c + tb[tid, 2, m] * s
            tb[tid, 2, m] = cn
            tb[tid, 3, m] = sn
            tb[tid, 4, m] += am * cn + bm * sn
            tb[tid, 7, m] += nn * (bm * cn - am * sn)
    for m in range(cnt):
        tb[tid, 6, m] = R0 * tb[tid, 4, m] - tb[tid, 5, m]
    if slopes:
        h = 2.0 * math.pi / K
        ci = geo[i, 2]
        si = geo[i, 3]
        for m in range(cnt):
            k = (k0 + m) % K
            ox = px[i, k] - dx
            oy = py[i, k] - dy
            ex = ci * cphi[k] - si * sphi[k]
            ey = si * cphi[k] + ci * sphi[k]
            tx = dR[i, k] * ex - R[i, k] * ey
            ty = dR[i, k] * ey + R[i, k] * ex
            inv = 1.0 / max(tb[tid, 5, m], 1e-300)
            dpsi = (ox * ty - oy * tx) * inv * inv
            tb[tid, 7, m] = (R0 * tb[tid, 7, m] * dpsi - (ox * tx + oy * ty) * inv) * h
