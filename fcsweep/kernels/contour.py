"""Contour geometry, overlap weights and deterministic rates (numba kernels).

Every function here takes ndarrays and scalars only.  The readable numpy twin of the
whole computation is :func:`fcsweep.model.rates.rates`; tests compare the two.

Array conventions (N cells, K contour points, M1 = M - 1 shape modes):

- ``cosn, sinn``  float64[M1, K]  cos(n phi_k), sin(n phi_k), n = 2..M
- ``cphi, sphi``  float64[K]      cos(phi_k), sin(phi_k)
- ``R, dR``       float64[N, K]   R_i(phi_k), R'_i(phi_k)
- ``px, py``      float64[N, 2K+LANES]  contour point offsets x_ik - r_i in the lab
  frame, repeated periodically along the row so that an angular window never wraps
- ``tx, ty``      like px, py: contour tangents dx/dphi (arc rule only)
- ``geo``         float64[N, 5]   a0, bounding radius (rigorous), cos(theta),
  sin(theta), largest sampled radius
- ``tbuf``        float64[threads, 8, 4K + 8]  per-thread window scratch (arc rule: Gauss nodes)
- ``pbuf``        float64[threads, >= max(2K+LANES, 4+2M1)]  one pair's share (contact-implicit)
"""

from __future__ import annotations

import math

import numpy as np
from numba import get_thread_id, njit, prange

from .arcs import arc_pair, may_touch
from .contacts import add_scaled_arc_pair, contact_factor, scale_point_pair
from .fourier import fourier6, fourier_series, modes6
from .options import NJIT


#: Points per vector block of the binary rule (a multiple of the SIMD width).
LANES = 4

QUAD_BINARY = 0
QUAD_LINEAR = 1
QUAD_ARC = 2
QUADRATURE_CODES = {"binary": QUAD_BINARY, "linear": QUAD_LINEAR, "arc": QUAD_ARC}


def mode_tables(K, M1):
    """cos/sin tables of the contour angles: (cosn, sinn, cphi, sphi)."""
    phi = 2.0 * np.pi * np.arange(K) / K
    n = np.arange(2, M1 + 2)
    cosn = np.ascontiguousarray(np.cos(np.multiply.outer(n, phi)))
    sinn = np.ascontiguousarray(np.sin(np.multiply.outer(n, phi)))
    return cosn.reshape(M1, K), sinn.reshape(M1, K), np.cos(phi), np.sin(phi)


@njit(parallel=True, **NJIT)
def geometry(theta, a, b, R0, cosn, sinn, cphi, sphi, R, dR, px, py, tx, ty, tangents, geo):
    """Contour radius, its derivative and lab-frame contour points of every cell
    (and, if ``tangents``, the contour tangents dx/dphi = R' e + R e_perp).

    Loops use unsigned indices so that numba emits no wraparound checks and LLVM
    vectorises them across contour points.
    """
    N, M1 = a.shape
    K = np.uint64(cphi.shape[0])
    L = np.uint64(px.shape[1])
    for i in prange(N):
        ui = np.uint64(i)
        s2 = 0.0
        s1 = 0.0
        sn1 = 0.0
        for m in range(M1):
            q = a[i, m] * a[i, m] + b[i, m] * b[i, m]
            s2 += q
            s1 += math.sqrt(q)
            sn1 += (m + 2.0) * math.sqrt(q)
        a0 = math.sqrt(1.0 - 0.5 * s2)
        c = math.cos(theta[i])
        s = math.sin(theta[i])
        geo[i, 0] = a0
        geo[i, 2] = c
        geo[i, 3] = s
        if M1 == 0:  # rigid discs: no contour is needed
            geo[i, 1] = R0
            geo[i, 4] = R0
            continue
        if M1 <= 5:
            a2, a3, a4, a5, a6, b2, b3, b4, b5, b6 = modes6(a, b, i)
            for k in range(K):
                r, d = fourier6(cphi[k], sphi[k], a2, a3, a4, a5, a6, b2, b3, b4, b5, b6)
                R[ui, k] = a0 + r
                dR[ui, k] = d
        else:
            for k in range(K):
                R[ui, k] = a0
                dR[ui, k] = 0.0
            for m in range(M1):
                am = a[i, m]
                bm = b[i, m]
                n = m + 2.0
                for k in range(K):
                    R[ui, k] += am * cosn[m, k] + bm * sinn[m, k]
                    dR[ui, k] += n * (bm * cosn[m, k] - am * sinn[m, k])
        for k in range(K):
            r = R0 * R[ui, k]
            d = R0 * dR[ui, k]
            R[ui, k] = r
            dR[ui, k] = d
            ex = c * cphi[k] - s * sphi[k]
            ey = s * cphi[k] + c * sphi[k]
            px[ui, k] = r * ex
            py[ui, k] = r * ey
        if tangents:
            for k in range(K):
                r = R[ui, k]
                d = dR[ui, k]
                ex = c * cphi[k] - s * sphi[k]
                ey = s * cphi[k] + c * sphi[k]
                tx[ui, k] = d * ex - r * ey
                ty[ui, k] = d * ey + r * ex
        rho = 0.0  # a separate loop: max-reductions do not vectorise without nnan
        for k in range(K):
            if R[ui, k] > rho:
                rho = R[ui, k]
        for k in range(K, L):
            px[ui, k] = px[ui, k - K]
            py[ui, k] = py[ui, k - K]
        if tangents:
            for k in range(K, L):
                tx[ui, k] = tx[ui, k - K]
                ty[ui, k] = ty[ui, k - K]
        geo[i, 4] = rho
        # rigorous bounding radius: R0 (a0 + sum |c_n|), or the largest sample plus the
        # most R can rise within half a point spacing, (pi/K) max|R'| <= (pi/K) R0 sum n|c_n|
        geo[i, 1] = min(R0 * (a0 + s1), rho + math.pi / cphi.shape[0] * R0 * sn1)


@njit(**NJIT)
def gap_at(ox, oy, j, a, b, geo, R0):
    """Radial gap R_j(psi) - |d| of the offset d = (ox, oy) from the centre of cell j."""
    d2 = ox * ox + oy * oy
    r = math.sqrt(d2)
    if r < 1e-300:
        return R0 * geo[j, 0]
    inv = 1.0 / r
    ct = geo[j, 2]
    st = geo[j, 3]
    c = (ox * ct + oy * st) * inv
    s = (oy * ct - ox * st) * inv
    rr, _ = fourier_series(c, s, a, b, j)
    return R0 * (geo[j, 0] + rr) - r


@njit(inline="always", **NJIT)
def atan2_fast(y, x):
    """atan2 by octant reduction and an odd minimax polynomial; |error| < 1e-5 rad.

    Used only to place angular windows, which carry a larger safety margin.
    """
    ax = abs(x)
    ay = abs(y)
    mx = max(ax, ay)
    if mx == 0.0:
        return 0.0
    z = min(ax, ay) / mx
    z2 = z * z
    r = z * (0.9998660 + z2 * (-0.3302995 + z2 * (0.1801410 + z2 * (-0.0851330 + z2 * 0.0208351))))
    if ay > ax:
        r = 0.5 * math.pi - r
    if x < 0.0:
        r = math.pi - r
    if y < 0.0:
        r = -r
    return r


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
    window never wraps.  Points beyond j's bounding circle are masked out.
    """
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


@njit(inline="always", **NJIT)
def pair_disc(i, dx, dy, R0, acc, coef):
    """Rigid discs: the exact lens-overlap force, the chord 2 sqrt(R0^2 - D^2/4) along
    the line of centres, pushing i away from j (times the contact-implicit factor when
    ``coef > 0``)."""
    D = math.sqrt(dx * dx + dy * dy)
    if D < 2.0 * R0 and D > 0.0:
        chord = 2.0 * math.sqrt(R0 * R0 - 0.25 * D * D)
        if coef > 0.0:
            chord *= contact_factor(chord, coef)
        acc[i, 0] -= chord * dx / D
        acc[i, 1] -= chord * dy / D


@njit(inline="always", **NJIT)
def pair_binary(i, j, dx, dy, a, b, geo, px, py, R0, W):
    """Binary rule (paper): W[i, k] += 1 for every contour point of i inside j."""
    K = (px.shape[1] - LANES) // 2
    rbj = geo[j, 1]
    D = math.sqrt(dx * dx + dy * dy)
    k0, cnt = angular_window(dx, dy, D, geo[i, 2], geo[i, 3], geo[i, 4], rbj, K)
    if a.shape[1] <= 5:
        binary_window(i, j, dx, dy, k0, cnt, a, b, geo, px, py, R0, W)
        return
    # generic M: per-point bounding-circle rejection, then the Fourier test
    rb2 = rbj * rbj
    for kk in range(k0, k0 + cnt):
        ox = px[i, kk] - dx
        oy = py[i, kk] - dy
        if ox * ox + oy * oy < rb2:
            if gap_at(ox, oy, j, a, b, geo, R0) > 0.0:
                W[i, kk] += 1.0


@njit(inline="always", **NJIT)
def gap_window(i, j, dx, dy, slopes, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid):
    """Gaps (and slopes) of cell i's contour relative to j on the rigorous window (the
    contour between samples may bulge beyond the sampled radii), extended by one point
    on either side.  Returns (k0, nseg): segments m = 0..nseg-1 join window points m, m+1.
    """
    K = cphi.shape[0]
    D = math.sqrt(dx * dx + dy * dy)
    k0, cnt = angular_window(dx, dy, D, geo[i, 2], geo[i, 3], geo[i, 1], geo[j, 1], K)
    if cnt + 2 >= K:
        k0 = 0
        nseg = K
    else:
        k0 = k0 - 1
        if k0 < 0:
            k0 += K
        nseg = cnt + 1
    if a.shape[1] <= 5:
        # padded to whole vector blocks (the extra points are never read): no scalar tail
        window_gaps6(i, j, dx, dy, k0, (nseg + LANES) // LANES * LANES, slopes, a, b, geo, px, py, tx, ty, R0,
                     2.0 * math.pi / K, tb, tid)
    else:
        window_gaps_generic(i, j, dx, dy, k0, nseg + 1, slopes, a, b, geo, R, dR, px, py, cphi, sphi,
                            R0, tb, tid)
    return k0, nseg


@njit(**NJIT)
def pair_linear(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, W, tb, tid):
    """Linear-gap rule: each point gets the inside fraction of its half segments."""
    K = cphi.shape[0]
    k0, nseg = gap_window(i, j, dx, dy, False, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid)
    for m in range(nseg):
        g0 = tb[tid, 6, m]
        g1 = tb[tid, 6, m + 1]
        in0 = g0 > 0.0
        in1 = g1 > 0.0
        if not in0 and not in1:
            continue
        first = 0.5
        second = 0.5
        if in0 and not in1:
            t = g0 / (g0 - g1)
            first = min(t, 0.5)
            second = max(0.0, t - 0.5)
        elif in1 and not in0:
            t = g0 / (g0 - g1)
            first = max(0.0, 0.5 - t)
            second = min(0.5, 1.0 - t)
        kk = (k0 + m) % K
        W[i, kk] += first
        kk1 = kk + 1 if kk + 1 < K else 0
        W[i, kk1] += second


@njit(inline="always", **NJIT)
def pair_arc(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid, own, orow, other, xrow):
    """Contact-arc rule for the pair (i, j), resolved on i's contour: i's arc integrals
    into ``own[orow]`` and j's into ``other[xrow]`` (see :func:`.arcs.arc_pair`)."""
    k0, nseg = gap_window(i, j, dx, dy, True, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid)
    if may_touch(nseg, cphi.shape[0], R0, tb, tid):
        arc_pair(i, j, dx, dy, k0, nseg, a, b, geo, R, px, py, R0, cphi, sphi, tb, tid, own, orow, other, xrow)


@njit(**NJIT)
def pair_arc_call(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid, own, orow, other, xrow):
    """:func:`pair_arc` as a called function, for the all-image path (small or open
    boxes): each inlined copy of the rule costs about a minute of compilation."""
    pair_arc(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid, own, orow, other, xrow)


@njit(inline="always", **NJIT)
def pair_weights(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, quad, W, tb, tid, acc, coef):
    """Add the overlap of cell j onto cell i with a point-weight rule, or rigid discs.

    ``(dx, dy)`` is r_j - r_i for the image of j being considered.  Binary and linear
    rules add per-point weights to ``W[i]``; rigid discs add the lens force to
    ``acc[i]`` (with the contact-implicit factor when ``coef > 0``; the point rules
    are scaled by the caller).  ``tb[tid]`` is this thread's scratch.  One small function per rule,
    so that each compiles (and vectorises) on its own.  (The arc rule treats each pair
    once, for both cells: :func:`pair_arc`.)
    """
    if a.shape[1] == 0:
        pair_disc(i, dx, dy, R0, acc, coef)
    elif quad == QUAD_BINARY:
        pair_binary(i, j, dx, dy, a, b, geo, px, py, R0, W)
    else:
        pair_linear(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, W, tb, tid)


@njit(inline="always", **NJIT)
def _sums4(x0, x1, x2, x3, ui, K):
    """Sums over k < K of the rows ``x0[ui]`` .. ``x3[ui]`` in a fixed order: four
    interleaved partial sums (k mod 4), added pairwise at the end.

    The four independent chains keep the adder busy although the compiler may not
    reassociate (see :mod:`fcsweep.kernels.options`): the order of the additions is the
    source order, wherever and however the code is compiled.
    """
    p0 = p1 = p2 = p3 = 0.0
    q0 = q1 = q2 = q3 = 0.0
    r0 = r1 = r2 = r3 = 0.0
    t0 = t1 = t2 = t3 = 0.0
    K4 = K - K % np.uint64(4)
    for k in range(np.uint64(0), K4, np.uint64(4)):
        p0 += x0[ui, k]
        p1 += x0[ui, k + 1]
        p2 += x0[ui, k + 2]
        p3 += x0[ui, k + 3]
        q0 += x1[ui, k]
        q1 += x1[ui, k + 1]
        q2 += x1[ui, k + 2]
        q3 += x1[ui, k + 3]
        r0 += x2[ui, k]
        r1 += x2[ui, k + 1]
        r2 += x2[ui, k + 2]
        r3 += x2[ui, k + 3]
        t0 += x3[ui, k]
        t1 += x3[ui, k + 1]
        t2 += x3[ui, k + 2]
        t3 += x3[ui, k + 3]
    for k in range(K4, K):
        p0 += x0[ui, k]
        q0 += x1[ui, k]
        r0 += x2[ui, k]
        t0 += x3[ui, k]
    return (p0 + p1) + (p2 + p3), (q0 + q1) + (q2 + q3), (r0 + r1) + (r2 + r3), (t0 + t1) + (t2 + t3)


@njit(inline="always", **NJIT)
def _mode_sums(u, v, ui, cosn, sinn, m, K):
    """(sum u_k cos n phi_k, sum u_k sin, sum v_k cos, sum v_k sin) over k < K for the
    mode row m of the tables, in order of k: the fallback of :func:`_folded_mode_sums`
    when K is not divisible by 4."""
    uc = us = vc = vs = 0.0
    for k in range(K):
        c = cosn[m, k]
        s = sinn[m, k]
        uc += u[ui, k] * c
        us += u[ui, k] * s
        vc += v[ui, k] * c
        vs += v[ui, k] * s
    return uc, us, vc, vs


@njit(inline="always", **NJIT)
def _fold_quarters(x, ui, K, out, off):
    """Fold the row ``x[ui, :K]`` onto the first quarter of the contour for the mode sums
    (K divisible by 4, H = K/4): for k = 1 .. H-1, with e = x_k + x_{K-k},
    d = x_k - x_{K-k} and e', d' the same for the points K/2 - k and K/2 + k, write
    e + e', e - e', d + d', d - d' to ``out[ui, off + q (H-1) + k - 1]``, q = 0..3.

    Because cos n phi and sin n phi are even / odd under phi -> -phi and pick up (-1)^n
    under phi -> pi - phi, a mode sum over the K points is a sum over these H - 1 folded
    values plus the four points on the axes (:func:`_folded_mode_sums`): a quarter of
    the multiply-adds, which do not vectorise (the sums keep a fixed order).
    """
    H = K // np.uint64(4)
    K2 = K // np.uint64(2)
    n = H - np.uint64(1)
    for q in range(n):
        k = q + np.uint64(1)
        e = x[ui, k] + x[ui, K - k]
        d = x[ui, k] - x[ui, K - k]
        e2 = x[ui, K2 - k] + x[ui, K2 + k]
        d2 = x[ui, K2 - k] - x[ui, K2 + k]
        out[ui, off + q] = e + e2
        out[ui, off + n + q] = e - e2
        out[ui, off + np.uint64(2) * n + q] = d + d2
        out[ui, off + np.uint64(3) * n + q] = d - d2


@njit(inline="always", **NJIT)
def _folded_mode_sums(u, v, f, ui, cosn, sinn, m, K):
    """:func:`_mode_sums` from the rows folded by :func:`_fold_quarters` (u's folds in
    ``u[ui, K:]``, v's in ``f[ui, :]``) and the four points on the axes."""
    H = K // np.uint64(4)
    K2 = K // np.uint64(2)
    H3 = np.uint64(3) * H
    n = H - np.uint64(1)
    even = m % 2 == 0  # mode number m + 2
    cu = K if even else K + n  # e + e' for even modes, e - e' for odd
    su = K + np.uint64(3) * n if even else K + np.uint64(2) * n  # d - d' for even, d + d' for odd
    cv = np.uint64(0) if even else n
    sv = np.uint64(3) * n if even else np.uint64(2) * n
    z = np.uint64(0)
    uc = (u[ui, z] * cosn[m, z] + u[ui, K2] * cosn[m, K2]) + (u[ui, H] * cosn[m, H] + u[ui, H3] * cosn[m, H3])
    us = (u[ui, z] * sinn[m, z] + u[ui, K2] * sinn[m, K2]) + (u[ui, H] * sinn[m, H] + u[ui, H3] * sinn[m, H3])
    vc = (v[ui, z] * cosn[m, z] + v[ui, K2] * cosn[m, K2]) + (v[ui, H] * cosn[m, H] + v[ui, H3] * cosn[m, H3])
    vs = (v[ui, z] * sinn[m, z] + v[ui, K2] * sinn[m, K2]) + (v[ui, H] * sinn[m, H] + v[ui, H3] * sinn[m, H3])
    for q in range(n):
        k = q + np.uint64(1)
        c = cosn[m, k]
        s = sinn[m, k]
        uc += u[ui, cu + q] * c
        us += u[ui, su + q] * s
        vc += f[ui, cv + q] * c
        vs += f[ui, sv + q] * s
    return uc, us, vc, vs


@njit(inline="always", **NJIT)
def cell_rates(i, a, b, geo, R, dR, px, py, cosn, sinn, cphi, sphi, W, acc, R0, eta, v0, mu_theta, mu_shape,
               dpos, dth, da, db):
    """Rates of cell i from its point weights ``W[i]`` and arc integrals ``acc[i]``.

    ``W[i]`` is periodic with period K (windows never wrap); it is folded first.
    ``acc[i]`` holds, for the arc rule, the integrals over overlap arcs of
    [force x, force y, torque, R, R cos n phi (M1), R sin n phi (M1)].
    The rows ``W[i]``, ``R[i]``, ``dR[i]``, ``px[i]`` and ``py[i]`` are used as scratch
    afterwards (all are rebuilt every step).  Every sum has a fixed order, so the rates
    are the same to the last bit whether the kernel was just compiled or loaded from
    numba's cache.
    """
    K = np.uint64(cphi.shape[0])
    L = np.uint64(W.shape[1])
    M1 = a.shape[1]
    ui = np.uint64(i)
    dphi = 2.0 * math.pi / cphi.shape[0]
    c = geo[i, 2]
    s = geo[i, 3]
    a0 = geo[i, 0]
    if M1 == 0:  # rigid discs: no torque, no shape
        dpos[i, 0] = v0 * c + acc[i, 0]
        dpos[i, 1] = v0 * s + acc[i, 1]
        dth[i] = 0.0
        return
    for k in range(K, L - K):
        W[ui, k] += W[ui, k + K]
    for k in range(K, L):
        W[ui, k - K] += W[ui, k]
    for k in range(K):
        w = W[ui, k]
        r = R[ui, k]
        d = dR[ui, k]
        ex = c * cphi[k] - s * sphi[k]
        ey = s * cphi[k] + c * sphi[k]
        px[ui, k] = w * (-d * ey - r * ex)
        py[ui, k] = w * (d * ex - r * ey)
        dR[ui, k] = w * r * d
        # u_k = w R + eta R/s and v_k = eta R'/s (perimeter gradient on the same points)
        inv_s = 1.0 / math.sqrt(r * r + d * d)
        W[ui, k] = (w * r + eta * r * inv_s) * dphi
        R[ui, k] = eta * d * inv_s * dphi
    fx, fy, tq, usum = _sums4(px, py, dR, W, ui, K)
    dpos[i, 0] = v0 * c + fx * dphi + acc[i, 0]
    dpos[i, 1] = v0 * s + fy * dphi + acc[i, 1]
    dth[i] = mu_theta * (tq * dphi + acc[i, 2])
    usum += acc[i, 3]
    folded = K % np.uint64(4) == 0 and K >= np.uint64(8)
    if folded:  # px[i] is free now that its sum is taken
        _fold_quarters(W, ui, K, W, K)
        _fold_quarters(R, ui, K, px, np.uint64(0))
    for m in range(M1):
        n = m + 2.0
        if folded:
            uc, us, vc, vs = _folded_mode_sums(W, R, px, ui, cosn, sinn, m, K)
        else:
            uc, us, vc, vs = _mode_sums(W, R, ui, cosn, sinn, m, K)
        uc += acc[i, 4 + m]
        us += acc[i, 4 + M1 + m]
        da[i, m] = -mu_shape * R0 * (uc - a[i, m] / (2.0 * a0) * usum - n * vs)
        db[i, m] = -mu_shape * R0 * (us - b[i, m] / (2.0 * a0) * usum + n * vc)


@njit(inline="always", **NJIT)
def _min_image(dx, dy, Lx, Ly):
    """Nearest image of an offset known to be shorter than a third of the box."""
    if dx > 0.5 * Lx:
        dx -= Lx
    elif dx < -0.5 * Lx:
        dx += Lx
    if dy > 0.5 * Ly:
        dy -= Ly
    elif dy < -0.5 * Ly:
        dy += Ly
    return dx, dy


@njit(parallel=True, **NJIT)
def all_rates(pos, a, b, Lx, Ly, periodic, R0, eta, v0, mu_theta, mu_shape, quad,
              cosn, sinn, cphi, sphi, R, dR, px, py, tx, ty, geo, W, tbuf, acc,
              use_list, nbr, count, pairbuf, dpos, dth, da, db, coef, kfloor, pbuf):
    """Deterministic rates of every cell (geometry must be current).

    With ``use_list`` the Verlet list ``nbr[i, :count[i]]`` (see :mod:`.verlet`) gives
    the candidates in ascending j; otherwise (boxes too small for a cell list) every
    cell and every one of the 9 periodic images (or, for open boundaries, the direct
    pair only) is visited.  Each iteration writes only to row i, so the result does not
    depend on the number of threads.

    The arc rule resolves each pair once, on the contour of its lower-index cell, and
    derives the other cell's integrals from the same crossings (exact action-reaction).
    With the list, cell i keeps j's share in ``pairbuf[i * cap + p]`` (``nbr[i, p] = j``)
    and j collects it in a second pass; without it, the higher-index cell recomputes
    the pair (small boxes only).

    With ``coef > 0`` (the ``contact-implicit`` integrator, :mod:`.contacts`) every
    pair's integrals are scaled by the pair's implicit factor before they are added: a
    point rule's weights via a copy of ``W[i]`` in ``pbuf[tid]``, the arc rule's by
    resolving the pair into ``pbuf[tid]``.  (A cell overlapping its own periodic image,
    in boxes of a few cells, is left explicit.)  The rates are then the effective rates
    of one step of length dt, not the physical ones.
    """
    N = pos.shape[0]
    arc = quad == QUAD_ARC and a.shape[1] > 0
    points = coef > 0.0 and a.shape[1] > 0 and not arc
    cap = nbr.shape[1]
    for ii in prange(N):
        i = np.int64(ii)  # prange indices are unsigned: one type for i and j, one compilation
        tid = get_thread_id()
        for k in range(W.shape[1]):
            W[i, k] = 0.0
        for k in range(acc.shape[1]):
            acc[i, k] = 0.0
        rbi = geo[i, 1]
        xi = pos[i, 0]
        yi = pos[i, 1]
        if use_list:
            for p in range(count[i]):
                j = nbr[i, p]
                if arc:
                    if j < i:
                        continue  # resolved by j; collected below
                    for k in range(acc.shape[1]):
                        pairbuf[i * cap + p, k] = 0.0
                # list pairs are closer than a third of the box: one shift at most
                dx, dy = _min_image(pos[j, 0] - xi, pos[j, 1] - yi, Lx, Ly)
                cut = rbi + geo[j, 1]
                if dx * dx + dy * dy >= cut * cut:
                    continue
                if arc:
                    # i's share to acc[i], or first to pbuf[tid] to be scaled (one inlined
                    # copy of the rule: each costs about a minute of compilation)
                    dst = pbuf if coef > 0.0 else acc
                    row = tid if coef > 0.0 else i
                    if coef > 0.0:
                        for k in range(acc.shape[1]):
                            pbuf[tid, k] = 0.0
                    pair_arc(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tbuf, tid,
                             dst, row, pairbuf, i * cap + p)
                    if coef > 0.0:
                        add_scaled_arc_pair(i, j, tid, pbuf, acc, i, pairbuf, i * cap + p, a, b, geo, R0, coef,
                                            kfloor)
                else:
                    if points:
                        for k in range(W.shape[1]):
                            pbuf[tid, k] = W[i, k]
                    pair_weights(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, quad,
                                 W, tbuf, tid, acc, coef)
                    if points:
                        scale_point_pair(i, j, W, pbuf, tid, R, px, py, a, b, geo, R0, coef, kfloor)
        else:
            nimg = 1 if periodic else 0
            for j in range(N):
                for sx in range(-nimg, nimg + 1):
                    for sy in range(-nimg, nimg + 1):
                        if j == i and sx == 0 and sy == 0:
                            continue
                        dx = pos[j, 0] + sx * Lx - xi
                        dy = pos[j, 1] + sy * Ly - yi
                        cut = rbi + geo[j, 1]
                        if dx * dx + dy * dy >= cut * cut:
                            continue
                        if not arc:
                            if points:
                                for k in range(W.shape[1]):
                                    pbuf[tid, k] = W[i, k]
                            pair_weights(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, quad,
                                         W, tbuf, tid, acc, coef)
                            if points:
                                scale_point_pair(i, j, W, pbuf, tid, R, px, py, a, b, geo, R0, coef, kfloor)
                        elif j != i:
                            # the lower index resolves the pair; the other recomputes it
                            # (pairbuf row i takes the share that is not i's).  i's share goes
                            # to acc[i], or first to pbuf[tid] to be scaled (contact-implicit:
                            # i's force points away from j from either side, so the factor
                            # is the same for both cells)
                            dst = pbuf if coef > 0.0 else acc
                            row = tid if coef > 0.0 else i
                            if coef > 0.0:
                                for k in range(acc.shape[1]):
                                    pbuf[tid, k] = 0.0
                            if i < j:
                                pair_arc_call(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0,
                                              tbuf, tid, dst, row, pairbuf, i)
                            else:
                                pair_arc_call(j, i, -dx, -dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0,
                                              tbuf, tid, pairbuf, i, dst, row)
                            if coef > 0.0:
                                add_scaled_arc_pair(i, j, tid, pbuf, acc, i, pairbuf, -1, a, b, geo, R0, coef,
                                                    kfloor)
                        elif sx > 0 or (sx == 0 and sy > 0):
                            # one of the two instances of a pair with its own image: both shares
                            pair_arc_call(i, i, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tbuf,
                                          tid, acc, i, acc, i)
    # a second pass: cell_rates overwrites rows that pairs of other cells read above
    for jj in prange(N):
        j = np.int64(jj)
        if arc and use_list:
            for p in range(count[j]):
                i = nbr[j, p]
                if i > j:
                    break
                for q in range(count[i]):
                    if nbr[i, q] == j:
                        for k in range(acc.shape[1]):
                            acc[j, k] += pairbuf[i * cap + q, k]
                        break
        cell_rates(j, a, b, geo, R, dR, px, py, cosn, sinn, cphi, sphi, W, acc, R0, eta, v0, mu_theta,
                   mu_shape, dpos, dth, da, db)
