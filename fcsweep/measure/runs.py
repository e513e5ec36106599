"""Compiled helpers of the polygon estimator (:mod:`fcsweep.measure.perimeter`): the cut of a
cell's boundary pixels into maximal digital straight runs with their widest-margin lines, the
polygon those lines make, the sharpest bend of the outline (where the cut starts), and the
even-odd point-in-polygon count of mismatched pixels.  The per-cell pixel work before it is in
:mod:`fcsweep.measure.pixels`.

A run is digitally straight while some line separates its boundary pixel centres inside the
cell from those outside it; the test runs over :data:`ORIENTATIONS` directions (the extremes
of the projections are kept as the run grows, so a run costs its pixels times the
directions), and the chosen line is the one of widest margin, refined about the best
direction to a tenth of the grid's step.  Compiled with numba (cached next to this module,
or in numba's user-wide cache where that is not writable).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["digital_runs", "count_outside", "run_polygon", "sharpest_bend", "ORIENTATIONS"]

#: Directions (over 180 degrees) on which a run's boundary pixels are tested for a separating line.
ORIENTATIONS = 180
_BIG = 1e300


@numba.njit(cache=True, error_model="numpy")
def _gap_at(pts, side, at, k0, t, n, length, nx, ny, gap, sign, offset, a):
    """Margin, outward sign and offset of the separating line with normal (nx, ny) for the pixels
    from index k0 on whose relative sample is <= length from sample t, stored at index a."""
    N = pts.shape[0]
    hi_in = -_BIG
    lo_in = _BIG
    hi_out = -_BIG
    lo_out = _BIG
    for j in range(N):
        k = (k0 + j) % N
        if (at[k] - t) % n > length:
            break
        v = pts[k, 0] * nx + pts[k, 1] * ny
        if side[k]:
            hi_in = max(hi_in, v)
            lo_in = min(lo_in, v)
        else:
            hi_out = max(hi_out, v)
            lo_out = min(lo_out, v)
    g1 = lo_out - hi_in
    g2 = lo_in - hi_out
    if g1 >= g2:
        gap[a], sign[a], offset[a] = g1, 1.0, 0.5 * (lo_out + hi_in)
    else:
        gap[a], sign[a], offset[a] = g2, -1.0, -0.5 * (lo_in + hi_out)


@numba.njit(cache=True, error_model="numpy")
def _gaps(pts, side, at, k0, t, n, length, nx, ny, gap, sign, offset):
    """Margin, outward sign and offset of the separating line at each direction (nx, ny) for the
    pixels from index k0 on whose relative sample is <= length from sample t; gap <= 0 where none
    separates."""
    for a in range(nx.size):
        _gap_at(pts, side, at, k0, t, n, length, nx[a], ny[a], gap, sign, offset, a)


@numba.njit(cache=True, error_model="numpy")
def digital_runs(pts, side, at, n, start, first, orientations):
    """Maximal digitally straight runs of a closed outline of ``n`` samples.

    Parameters
    ----------
    pts : float64 (N, 2)
        Boundary pixel centres, sorted by ``at``.
    side : bool (N,)
        True for a centre inside the cell.
    at : int64 (N,)
        Index of the outline sample each centre is attached to (sorted).
    n, start, first : int
        Samples of the outline, the sample where the first run starts, the shortest run.
    orientations : int

    Returns
    -------
    t, length : int64 (R,)
        First sample and length (samples) of each run.
    ok : bool (R,)
        The run's pixels are separable (else the line is left to the caller).
    normal, offset : float64 (R, 2), (R,)
        The widest-margin line ``normal . x = offset``, normal pointing out of the cell.
    """
    N = pts.shape[0]
    nx = np.empty(orientations)
    ny = np.empty(orientations)
    for a in range(orientations):
        th = np.pi * a / orientations
        nx[a] = -np.sin(th)
        ny[a] = np.cos(th)
    hi_in = np.empty(orientations)
    lo_in = np.empty(orientations)
    hi_out = np.empty(orientations)
    lo_out = np.empty(orientations)
    gap = np.empty(orientations)
    sign = np.empty(orientations)
    offset = np.empty(orientations)
    fine = 21
    fx = np.empty(fine)
    fy = np.empty(fine)
    fgap = np.empty(fine)
    fsign = np.empty(fine)
    foff = np.empty(fine)
    out_t = np.empty(n, np.int64)
    out_len = np.empty(n, np.int64)
    out_ok = np.zeros(n, np.bool_)
    out_nrm = np.zeros((n, 2))
    out_off = np.zeros(n)
    r = 0
    t = start
    end = start + n
    live = np.empty(orientations, np.int64)
    kept = np.empty(orientations, np.int64)
    while t < end - 1:
        room = end - 1 - t
        k0 = np.searchsorted(at, t % n)
        for a in range(orientations):
            hi_in[a] = -_BIG
            lo_in[a] = _BIG
            hi_out[a] = -_BIG
            lo_out[a] = _BIG
            live[a] = a
            kept[a] = a
        nlive = orientations
        nkept = orientations
        fail = -1
        for j in range(N):
            k = (k0 + j) % N
            rel = (at[k] - t) % n
            if rel > room:
                break
            # a direction that no longer separates the run never will again: only the live ones are updated
            for q in range(nlive):
                kept[q] = live[q]
            nkept = nlive
            m = 0
            for q in range(nlive):
                a = live[q]
                v = pts[k, 0] * nx[a] + pts[k, 1] * ny[a]
                if side[k]:
                    hi_in[a] = max(hi_in[a], v)
                    lo_in[a] = min(lo_in[a], v)
                else:
                    hi_out[a] = max(hi_out[a], v)
                    lo_out[a] = min(lo_out[a], v)
                if lo_out[a] - hi_in[a] > 0 or lo_in[a] - hi_out[a] > 0:
                    live[m] = a
                    m += 1
            nlive = m
            if nlive == 0:
                fail = rel
                break
        length = room if fail < 0 else min(room, max(fail - 1, first))
        for a in range(orientations):
            gap[a] = -_BIG
        for q in range(nkept if fail >= 0 else nlive):
            a = kept[q] if fail >= 0 else live[q]
            _gap_at(pts, side, at, k0, t, n, length, nx[a], ny[a], gap, sign, offset, a)
        best = np.argmax(gap)
        ok = gap[best] > 0 and gap[best] < 1e200
        if ok:  # refine about the best direction
            th0 = np.pi * best / orientations
            for f in range(fine):
                th = th0 + (f - fine // 2) * (np.pi / orientations) / (fine // 2)
                fx[f] = -np.sin(th)
                fy[f] = np.cos(th)
            _gaps(pts, side, at, k0, t, n, length, fx, fy, fgap, fsign, foff)
            b = np.argmax(fgap)
            out_nrm[r, 0] = fsign[b] * fx[b]
            out_nrm[r, 1] = fsign[b] * fy[b]
            out_off[r] = foff[b]
        out_t[r] = t
        out_len[r] = length
        out_ok[r] = ok
        r += 1
        t += length + 1
    return out_t[:r], out_len[:r], out_ok[:r], out_nrm[:r], out_off[:r]


@numba.njit(cache=True, error_model="numpy")
def count_outside(px, py, inside, poly):
    """Pixels (px, py) whose side of the closed polygon ``poly`` (V, 2), by the even-odd rule,
    differs from ``inside``.  The crossings of a row are found once for a run of pixels on it
    (pixels given row by row cost the rows times the vertices plus the pixels times the
    crossings)."""
    count = 0
    V = poly.shape[0]
    xcs = np.empty(V)
    m = 0
    row = np.nan
    for k in range(px.size):
        x, y = px[k], py[k]
        if y != row:
            row = y
            m = 0
            j = V - 1
            for i in range(V):
                yi, yj = poly[i, 1], poly[j, 1]
                if (yi > y) != (yj > y):
                    xcs[m] = poly[i, 0] + (y - yi) * (poly[j, 0] - poly[i, 0]) / (yj - yi)
                    m += 1
                j = i
        c = False
        for i in range(m):
            if x < xcs[i]:
                c = not c
        if c != inside[k]:
            count += 1
    return count


@numba.njit(cache=True, error_model="numpy")
def _tls_line(p, t0, length):
    """Centre and unit direction of the total-least-squares line through p[t0 .. t0 + length] (cyclic)."""
    n = p.shape[0]
    cx = 0.0
    cy = 0.0
    for j in range(length + 1):
        k = (t0 + j) % n
        cx += p[k, 0]
        cy += p[k, 1]
    cx /= length + 1
    cy /= length + 1
    sxx = 0.0
    syy = 0.0
    sxy = 0.0
    for j in range(length + 1):
        k = (t0 + j) % n
        dx, dy = p[k, 0] - cx, p[k, 1] - cy
        sxx += dx * dx
        syy += dy * dy
        sxy += dx * dy
    th = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    return cx, cy, np.cos(th), np.sin(th)


@numba.njit(cache=True, error_model="numpy")
def _covers(ax, ay, bx, by, cx, cy, pts, side, tol):
    """Whether the triangle a, b, c holds a point of ``pts`` outside the cell (``side`` False)
    farther than ``tol`` inside its sides a-b and b-c (and inside c-a)."""
    reach = max(np.hypot(bx - ax, by - ay), np.hypot(bx - cx, by - cy)) + 1.0
    o = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    orient = -1.0 if o < 0 else 1.0
    l1 = max(np.hypot(bx - ax, by - ay), 1e-12)
    l2 = max(np.hypot(cx - bx, cy - by), 1e-12)
    l3 = max(np.hypot(ax - cx, ay - cy), 1e-12)
    for k in range(pts.shape[0]):
        if side[k]:
            continue
        x, y = pts[k, 0], pts[k, 1]
        if max(abs(x - bx), abs(y - by)) > reach:
            continue
        s1 = orient * ((bx - ax) * (y - ay) - (by - ay) * (x - ax)) / l1
        s2 = orient * ((cx - bx) * (y - by) - (cy - by) * (x - bx)) / l2
        s3 = orient * ((ax - cx) * (y - cy) - (ay - cy) * (x - cx)) / l3
        if s1 > tol and s2 > tol and s3 > 0:
            return True
    return False


@numba.njit(cache=True, error_model="numpy")
def run_polygon(p, pts, side, t0s, lengths, ok, normal, offset, min_sine, max_shift, tol):
    """Vertices (V, 2) of the polygon of the runs of :func:`digital_runs` on the outline ``p``:
    each run's line is its widest-margin line where ``ok`` (else the total-least-squares line
    of its outline points), consecutive lines meet at their intersection where they turn by a
    sine above ``min_sine``, the intersection lies within ``max_shift`` of the outline point
    between them and its corner takes in no pixel centre outside the cell (``pts`` with
    ``side`` False) farther than ``tol`` inside; else that outline point is the vertex."""
    n = p.shape[0]
    R = t0s.size
    lc = np.empty((R, 2))
    ld = np.empty((R, 2))
    for j in range(R):
        cx, cy, ux, uy = _tls_line(p, t0s[j], lengths[j])
        if ok[j]:
            nx, ny = normal[j, 0], normal[j, 1]
            sh = nx * cx + ny * cy - offset[j]
            cx, cy, ux, uy = cx - sh * nx, cy - sh * ny, ny, -nx
        lc[j, 0], lc[j, 1], ld[j, 0], ld[j, 1] = cx, cy, ux, uy
    verts = np.empty((R, 2))
    for j in range(R):
        i = j - 1 if j > 0 else R - 1
        c1x, c1y, d1x, d1y = lc[i, 0], lc[i, 1], ld[i, 0], ld[i, 1]
        c2x, c2y, d2x, d2y = lc[j, 0], lc[j, 1], ld[j, 0], ld[j, 1]
        x, y = p[t0s[j] % n, 0], p[t0s[j] % n, 1]
        det = d2x * d1y - d1x * d2y
        if abs(det) > min_sine:
            wx, wy = c2x - c1x, c2y - c1y
            f = (wy * d2x - wx * d2y) / det
            kx, ky = c1x + d1x * f, c1y + d1y * f
            f1 = (x - c1x) * d1x + (y - c1y) * d1y
            f2 = (x - c2x) * d2x + (y - c2y) * d2y
            if np.hypot(kx - x, ky - y) < max_shift and not _covers(
                    c1x + d1x * f1, c1y + d1y * f1, kx, ky, c2x + d2x * f2, c2y + d2y * f2, pts, side, tol):
                x, y = kx, ky
        verts[j, 0], verts[j, 1] = x, y
    return verts


@numba.njit(cache=True, error_model="numpy")
def sharpest_bend(p, weights):
    """Index of the sample of the closed outline ``p`` (K, 2) where its turn per sample, smoothed
    by the symmetric ``weights`` (2 r + 1, cyclic), is largest in magnitude (the first on a tie)."""
    n = p.shape[0]
    ang = np.empty(n)
    for i in range(n):
        j = (i + 1) % n
        ang[i] = np.arctan2(p[j, 1] - p[i, 1], p[j, 0] - p[i, 0])
    turn = np.empty(n)
    for i in range(n):
        d = ang[(i + 1) % n] - ang[i]
        turn[i] = np.arctan2(np.sin(d), np.cos(d))
    r = weights.size // 2
    best = -1.0
    at = 0
    for i in range(n):
        v = turn[i] * weights[r]
        for j in range(r, 0, -1):
            v += (turn[(i - j) % n] + turn[(i + j) % n]) * weights[r + j]
        if abs(v) > best:
            best = abs(v)
            at = i
    return at
