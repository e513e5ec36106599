"""The wall term of a confined run (numba): the rates of the area of each cell beyond the
wall, added to the cell-cell rates (reference: :func:`fcsweep.model.confinement.wall_rates`).

Only cells whose bounding circle reaches the wall do any work; the others are skipped
after one distance test, so the term costs O(cells at the wall).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .geometry import radius_at
from .options import NJIT, njit
from .pairs import QUAD_BINARY
from ..model.confinement import WALL_CODES
from .records import P_MUS, P_MUT, P_WALL, P_WALLA, P_WALLB, P_WALLC

#: The well's code (any other nonzero code is the channel).
WELL = WALL_CODES["well"]


@njit(inline="always", **NJIT)
def _gap(x, y, code, wa, wb, wc):
    """Signed distance of (x, y) beyond the wall (> 0 outside)."""
    if code == WELL:
        return math.sqrt((x - wa) * (x - wa) + (y - wb) * (y - wb)) - wc
    return max(wa - y, y - wb)


@njit(inline="always", **NJIT)
def _half(g, mid):
    """Fraction of a half arc beyond the wall, the gap linear from ``g`` to ``mid``."""
    if g > 0.0 and mid > 0.0:
        return 0.5
    if g <= 0.0 and mid <= 0.0:
        return 0.0
    return 0.5 * (g if g > 0.0 else mid) / (abs(g) + abs(mid))


@njit(inline="always", **NJIT)
def _disc_chord(x, y, R, code, wa, wb, wc):
    """Rigid disc: the chord vector of its part beyond the wall, pointing outward."""
    cx = 0.0
    cy = 0.0
    if code == WELL:
        dx = x - wa
        dy = y - wb
        D = math.sqrt(dx * dx + dy * dy)
        if D + R > wc and D > 0.0 and D < wc + R and D > abs(wc - R):
            s = (D * D + wc * wc - R * R) / (2.0 * D)
            h = math.sqrt(max(wc * wc - s * s, 0.0))
            cx = 2.0 * h * dx / D
            cy = 2.0 * h * dy / D
        return cx, cy
    for side in range(2):
        sign = -1.0 if side == 0 else 1.0
        depth = sign * (y - (wa if side == 0 else wb))
        if depth > -R and depth < R:
            cy += sign * 2.0 * math.sqrt(max(R * R - depth * depth, 0.0))
    return cx, cy


@njit(parallel=True, **NJIT)
def wall_rates(pos, a, b, prm, quad, tables, scratch, out):
    """Add the wall's rates of every cell to ``out`` (geometry in ``scratch.geo`` current;
    the rows of ``scratch.px`` and ``py`` are used as scratch).

    Point weights: ``binary`` 1 beyond the wall; otherwise the fraction of each point's arc
    beyond it, from the gap interpolated linearly between adjacent points.
    """
    cosn, sinn, cphi, sphi = tables
    px, py, geo = scratch.px, scratch.py, scratch.geo
    dpos, dth, da, db = out
    code = np.int64(prm[P_WALL])
    wa = prm[P_WALLA]
    wb = prm[P_WALLB]
    wc = prm[P_WALLC]
    mu_theta = prm[P_MUT]
    mu_shape = prm[P_MUS]
    N, M1 = a.shape
    K = cphi.shape[0]
    dphi = 2.0 * math.pi / K
    for ii in prange(N):
        i = np.int64(ii)
        x = pos[i, 0]
        y = pos[i, 1]
        rb = geo[i, 1]
        if _gap(x, y, code, wa, wb, wc) + rb <= 0.0:
            continue
        R0i = geo[i, 5]
        if M1 == 0:
            cx, cy = _disc_chord(x, y, R0i, code, wa, wb, wc)
            dpos[i, 0] -= cx
            dpos[i, 1] -= cy
            continue
        a0 = geo[i, 0]
        c = geo[i, 2]
        s = geo[i, 3]
        for k in range(K):
            r, d = radius_at(a, b, i, k, a0, cosn, sinn)
            ex = c * cphi[k] - s * sphi[k]
            ey = s * cphi[k] + c * sphi[k]
            px[i, k] = _gap(x + R0i * r * ex, y + R0i * r * ey, code, wa, wb, wc)
            px[i, K + k] = R0i * r
            py[i, K + k] = R0i * d
        for k in range(K):
            g = px[i, k]
            if quad == QUAD_BINARY:
                py[i, k] = 1.0 if g > 0.0 else 0.0
            else:
                gn = px[i, (k + 1) % K]
                gp = px[i, (k + K - 1) % K]
                py[i, k] = _half(g, 0.5 * (g + gn)) + _half(g, 0.5 * (g + gp))
        fx = 0.0
        fy = 0.0
        tq = 0.0
        usum = 0.0
        for k in range(K):
            w = py[i, k]
            if w == 0.0:
                continue
            r = px[i, K + k]
            d = py[i, K + k]
            ex = c * cphi[k] - s * sphi[k]
            ey = s * cphi[k] + c * sphi[k]
            fx += w * (-d * ey - r * ex)
            fy += w * (d * ex - r * ey)
            tq += w * r * d
            usum += w * r
        dpos[i, 0] += fx * dphi
        dpos[i, 1] += fy * dphi
        dth[i] += mu_theta * tq * dphi
        for m in range(M1):
            uc = 0.0
            us = 0.0
            for k in range(K):
                w = py[i, k]
                if w != 0.0:
                    uc += w * px[i, K + k] * cosn[m, k]
                    us += w * px[i, K + k] * sinn[m, k]
            da[i, m] -= mu_shape * R0i * (uc - a[i, m] / (2.0 * a0) * usum) * dphi
            db[i, m] -= mu_shape * R0i * (us - b[i, m] / (2.0 * a0) * usum) * dphi
