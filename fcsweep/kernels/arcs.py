"""Contact-arc quadrature (numba): resolve overlap arcs between contour points.

Each pair of cells is resolved once, on the contour of one of them (i).  On each
contour segment [phi_k, phi_k + h] of cell i the radial gap g(phi) of the contour
relative to cell j (positive inside j) is interpolated by the cubic Hermite polynomial
through g and dg/dphi at both ends.  The cubic only *locates* crossings and shallow
contacts (a dip of the gap above zero between two outside points, which no sample point
sees); every crossing is then solved on the true gap by a bracketed Newton iteration
started from the cubic's root (the iteration ends when the Newton step is below
``ROOT_STEP`` of the segment; the step is still applied), and every candidate dip is
confirmed or rejected by the true gap at the cubic's extremum.  Segments whose cubic
stays more than ``DIP_MARGIN`` (scaled like the interpolation error, K^-4) away from
zero are settled without any evaluation.

On each inside piece the force and torque integrands are exact derivatives (of the
contour point and of R^2/2), so their integrals are closed-form differences of the end
points; the shape integrals (R, R cos n phi, R sin n phi) use two-point Gauss-Legendre,
with the nodes of all pieces of a pair summed in one pass.

The overlap region is bounded by i's arcs inside j and j's arcs inside i, which meet at
the same crossings.  So j's integrals follow from i's crossings: its force is minus
i's (action and reaction hold exactly), its torque is a difference of |P - r_j|^2 / 2
at the crossings, and only its shape integrals need Gauss nodes on its own arcs.

Every helper is inlined into :func:`arc_pair` (numba IR inlining) except the two
Gauss sums and j's side.  :func:`arc_pair` itself is called, not inlined, and only for
pairs whose cubics come near zero (:func:`may_touch`): inlining it saved 7.5 % of the
arc step but tripled the first-run compile time (about 75 s now).
"""

from __future__ import annotations

import math


from ..model.rates import DIP_MARGIN, ROOT_STEP
from .fourier import fourier_series, modes6, multiples6, series6
from .options import NJIT, njit

_G = 0.5 / math.sqrt(3.0)  # Gauss-Legendre nodes at 1/2 -+ _G on [0, 1]


@njit(inline="always", **NJIT)
def _hermite(t, g0, g1, m0, m1):
    """Cubic Hermite value and derivative on [0, 1] (slopes already scaled by h)."""
    t2 = t * t
    t3 = t2 * t
    p = (2 * t3 - 3 * t2 + 1) * g0 + (t3 - 2 * t2 + t) * m0 + (-2 * t3 + 3 * t2) * g1 + (t3 - t2) * m1
    dp = (6 * t2 - 6 * t) * g0 + (3 * t2 - 4 * t + 1) * m0 + (-6 * t2 + 6 * t) * g1 + (3 * t2 - 2 * t) * m1
    return p, dp


@njit(inline="always", **NJIT)
def _root(tl, tr, pl, g0, g1, m0, m1):
    """Root of the Hermite cubic in [tl, tr] where it changes sign; safeguarded Newton
    from the secant (only a starting point for :func:`polish`)."""
    pr, _ = _hermite(tr, g0, g1, m0, m1)
    t = tl + (tr - tl) * pl / (pl - pr) if pl != pr else 0.5 * (tl + tr)
    if not (tl < t < tr):
        t = 0.5 * (tl + tr)
    for _ in range(60):
        p, dp = _hermite(t, g0, g1, m0, m1)
        if (p > 0.0) == (pl > 0.0):
            tl = t
        else:
            tr = t
        step_ok = dp != 0.0
        tn = t - p / dp if step_ok else 0.5 * (tl + tr)
        if not (tl < tn < tr):
            tn = 0.5 * (tl + tr)
        if abs(tn - t) < 1e-10 or tr - tl < 1e-10:  # a start for polish()
            return tn
        t = tn
    return t


@njit(inline="always", **NJIT)
def _critical_points(g0, g1, m0, m1):
    """Stationary points of the Hermite cubic in (0, 1): returns (count, t1, t2)."""
    # p'(t) = A t^2 + B t + C
    A = 6 * g0 + 3 * m0 - 6 * g1 + 3 * m1
    B = -6 * g0 - 4 * m0 + 6 * g1 - 2 * m1
    C = m0
    n = 0
    r1 = 0.0
    r2 = 0.0
    if abs(A) < 1e-300:
        if B != 0.0:
            r = -C / B
            if 0.0 < r < 1.0:
                return 1, r, 0.0
        return 0, 0.0, 0.0
    disc = B * B - 4 * A * C
    if disc < 0.0:
        return 0, 0.0, 0.0
    sq = math.sqrt(disc)
    q = -0.5 * (B + math.copysign(sq, B))
    cands0 = q / A
    cands1 = C / q if q != 0.0 else cands0
    lo = min(cands0, cands1)
    hi = max(cands0, cands1)
    if 0.0 < lo < 1.0:
        r1 = lo
        n = 1
    if 0.0 < hi < 1.0 and hi != lo:
        if n == 0:
            r1 = hi
        else:
            r2 = hi
        n += 1
    return n, r1, r2


@njit(inline="always", **NJIT)
def _cos_sin_small(d):
    """cos d and sin d by Taylor series, for |d| <= pi/4 (error < 2e-10 there and
    < 1e-18 for the K = 40 spacing); avoids libm calls per Gauss point."""
    d2 = d * d
    c = 1.0 - d2 / 2 * (1.0 - d2 / 12 * (1.0 - d2 / 30 * (1.0 - d2 / 56 * (1.0 - d2 / 90))))
    s = d * (1.0 - d2 / 6 * (1.0 - d2 / 20 * (1.0 - d2 / 42 * (1.0 - d2 / 72 * (1.0 - d2 / 110)))))
    return c, s


@njit(inline="always", **NJIT)
def _angle(k, t, h, cphi, sphi):
    """cos and sin of phi_k + t h."""
    d = t * h
    if h <= 0.25 * math.pi:
        cd, sd = _cos_sin_small(d)
    else:
        cd = math.cos(d)
        sd = math.sin(d)
    return cphi[k] * cd - sphi[k] * sd, sphi[k] * cd + cphi[k] * sd


@njit(inline="always", **NJIT)
def true_gap(i, j, k, t, h, dx, dy, a, b, geo, R0, cphi, sphi):
    """The gap of cell i's contour relative to cell j at phi = phi_k + t h.

    Returns (g, h dg/dphi, x, y, R, h dx/dphi, h dy/dphi, h dR/dphi): the gap and its
    scaled slope, the contour point relative to r_i, its radius, and their scaled
    derivatives (used to move the point to a Newton-corrected root).
    """
    cp, sp = _angle(k, t, h, cphi, sphi)
    ri, dri = fourier_series(cp, sp, a, b, i)
    R0i = geo[i, 5]
    r = R0i * (geo[i, 0] + ri)
    dr = R0i * dri
    ex = geo[i, 2] * cp - geo[i, 3] * sp
    ey = geo[i, 3] * cp + geo[i, 2] * sp
    x = r * ex
    y = r * ey
    tx = dr * ex - r * ey
    ty = dr * ey + r * ex
    ox = x - dx
    oy = y - dy
    dist = math.sqrt(ox * ox + oy * oy)
    inv = 1.0 / max(dist, 1e-300)
    cj = (ox * geo[j, 2] + oy * geo[j, 3]) * inv
    sj = (oy * geo[j, 2] - ox * geo[j, 3]) * inv
    rj, drj = fourier_series(cj, sj, a, b, j)
    R0j = geo[j, 5]
    g = R0j * (geo[j, 0] + rj) - dist
    dpsi = (ox * ty - oy * tx) * inv * inv
    dg = (R0j * drj * dpsi - (ox * tx + oy * ty) * inv) * h
    return g, dg, x, y, r, tx * h, ty * h, dr * h


@njit(inline="always", **NJIT)
def polish(t, tl, tr, left_inside, i, j, k, h, dx, dy, a, b, geo, R0, cphi, sphi):
    """Root of the true gap in [tl, tr] (positive at tl iff ``left_inside``) by a
    bracketed Newton iteration from t.

    Stops when the Newton step is below ``ROOT_STEP`` (the root is then accurate to about
    the step squared) and returns the root with the contour point and radius there,
    moved from the last evaluation by the step (first order): (t, x, y, R).
    """
    x = 0.0
    y = 0.0
    r = 0.0
    for _ in range(60):
        g, dg, x, y, r, dx_, dy_, dr_ = true_gap(i, j, k, t, h, dx, dy, a, b, geo, R0, cphi, sphi)
        if (g > 0.0) == left_inside:
            tl = t
        else:
            tr = t
        tn = t - g / dg if dg != 0.0 else 0.5 * (tl + tr)
        if not (tl <= tn <= tr):
            tn = 0.5 * (tl + tr)
        step = tn - t
        if abs(step) < ROOT_STEP or tr - tl < ROOT_STEP:
            return tn, x + step * dx_, y + step * dy_, r + step * dr_
        t = tn
    return t, x, y, r


@njit(inline="always", **NJIT)
def _piece(k, t1, t2, x1, y1, r1, x2, y2, r2, h, cphi, sphi, tb, tid, nq):
    """One inside piece phi in [phi_k + t1 h, phi_k + t2 h] with end points (x1, y1),
    (x2, y2) and radii r1, r2.

    Returns its force and torque integrals — the force integrand is dx/dphi turned by
    +90 degrees, so its integral is the chord (x2 - x1) turned; the torque integrand
    R R' is d(R^2/2)/dphi — and stores its two Gauss-Legendre nodes (cos, sin, weight)
    in rows 0-2 of ``tb[tid]`` from column ``nq``: returns (fx, fy, torque, nq + 2).
    """
    w = 0.5 * (t2 - t1) * h
    mid = 0.5 * (t1 + t2)
    half = 0.5 * (t2 - t1)
    for q in range(2):
        cp, sp = _angle(k, mid + (2 * q - 1) * 2.0 * _G * half, h, cphi, sphi)
        tb[tid, 0, nq + q] = cp
        tb[tid, 1, nq + q] = sp
        tb[tid, 2, nq + q] = w
    return y1 - y2, x2 - x1, 0.5 * (r2 * r2 - r1 * r1), nq + 2


@njit(**NJIT)
def _shape_integrals(i, nq, a, b, geo, R0, tb, tid, acc, row):
    """Add the Gauss sums of cell i's R, R cos n phi and R sin n phi over the ``nq``
    nodes (cos, sin, weight) stored in rows 0-2 of ``tb[tid]`` to ``acc[row, 3:]``
    (i's own radius ``geo[i, 5]``, not ``R0``)."""
    R0 = geo[i, 5]
    M1 = a.shape[1]
    if M1 <= 5:
        a2, a3, a4, a5, a6, b2, b3, b4, b5, b6 = modes6(a, b, i)
        a0 = geo[i, 0]
        u = 0.0
        uc2 = uc3 = uc4 = uc5 = uc6 = 0.0
        us2 = us3 = us4 = us5 = us6 = 0.0
        for q in range(nq):
            c2, c3, c4, c5, c6, s2, s3, s4, s5, s6 = multiples6(tb[tid, 0, q], tb[tid, 1, q])
            rr, _ = series6(c2, c3, c4, c5, c6, s2, s3, s4, s5, s6, a2, a3, a4, a5, a6, b2, b3, b4, b5, b6)
            wr = tb[tid, 2, q] * R0 * (a0 + rr)
            u += wr
            uc2 += wr * c2
            uc3 += wr * c3
            uc4 += wr * c4
            uc5 += wr * c5
            uc6 += wr * c6
            us2 += wr * s2
            us3 += wr * s3
            us4 += wr * s4
            us5 += wr * s5
            us6 += wr * s6
        acc[row, 3] += u
        uc = (uc2, uc3, uc4, uc5, uc6)
        us = (us2, us3, us4, us5, us6)
        for m in range(M1):
            acc[row, 4 + m] += uc[m]
            acc[row, 4 + M1 + m] += us[m]
        return
    for q in range(nq):
        cp = tb[tid, 0, q]
        sp = tb[tid, 1, q]
        rr, _ = fourier_series(cp, sp, a, b, i)
        wr = tb[tid, 2, q] * R0 * (geo[i, 0] + rr)
        acc[row, 3] += wr
        cn = cp
        sn = sp
        for m in range(M1):
            tt = cn * cp - sn * sp
            sn = sn * cp + cn * sp
            cn = tt
            acc[row, 4 + m] += wr * cn
            acc[row, 4 + M1 + m] += wr * sn


@njit(**NJIT)
def _half_r2(i, nq, a, b, geo, R0, tb, tid):
    """Half the Gauss sum of cell i's R^2 over the ``nq`` nodes in rows 0-2 of
    ``tb[tid]``: the area its arcs sweep about r_i (only for ``core_exponent != 1``)."""
    s = 0.0
    for q in range(nq):
        rr, _ = fourier_series(tb[tid, 0, q], tb[tid, 1, q], a, b, i)
        r = geo[i, 5] * (geo[i, 0] + rr)
        s += tb[tid, 2, q] * r * r
    return 0.5 * s


@njit(inline="always", **NJIT)
def may_touch(nseg, K, R0, tb, tid):
    """False if the Hermite cubics of all window segments stay below -eps: the pair does
    not touch and :func:`arc_pair` would add nothing.

    On segment m write the cubic as p(t) = (1-t) g0 + t g1 + t(1-t) [(1-t) A - t B] with
    A = m0 - (g1-g0), B = m1 - (g1-g0); the bracket lies between A and -B and
    t(1-t) <= 1/4, so p <= max(g0, g1) + max(A, -B, 0)/4.  Most pairs in a dense packing
    come close without touching: this one branch-free pass settles them.
    """
    eps = DIP_MARGIN * R0 * (40.0 / K) ** 4
    top = -1e300
    for m in range(nseg):
        g0 = tb[tid, 6, m]
        g1 = tb[tid, 6, m + 1]
        dg = g1 - g0
        top = max(top, max(g0, g1) + 0.25 * max(tb[tid, 7, m] - dg, dg - tb[tid, 7, m + 1], 0.0))
    return top > -eps


@njit(inline="always", **NJIT)
def _crossing(x, y, kind, nc, tb, tid):
    """Record a crossing of the two contours at (x, y) (relative to r_i) in rows 3-5 of
    ``tb[tid]``: ``kind`` +1 where i's contour enters j, -1 where it leaves."""
    tb[tid, 3, nc] = x
    tb[tid, 4, nc] = y
    tb[tid, 5, nc] = kind
    return nc + 1


@njit(**NJIT)
def _other_side(j, dx, dy, nc, fx, fy, a, b, geo, R0, h, tb, tid, dst, row, core):
    """Add cell j's integrals over its arcs inside cell i, from the ``nc`` crossings that
    :func:`arc_pair` found on i's contour, to ``dst[row]``.  Returns j's part of the
    overlap area (Green's theorem about r_i: half the Gauss sum of R_j^2 over its arcs plus
    half of d x (end - start) of each arc) when ``core != 1``, else 0.

    The overlap region is bounded by i's arcs inside j and j's arcs inside i, so j's
    force is minus i's, exactly.  Each of j's arcs runs counter-clockwise from a crossing
    where i's contour leaves j to the next crossing along j's contour; its torque integral
    is the difference of |P - r_j|^2 / 2 at the ends, its shape integrals use two-point
    Gauss-Legendre on panels no longer than the contour spacing h.
    """
    dst[row, 0] -= fx
    dst[row, 1] -= fy
    ct = geo[j, 2]
    st = geo[j, 3]
    for c in range(nc):
        ox = tb[tid, 3, c] - dx
        oy = tb[tid, 4, c] - dy
        r2 = ox * ox + oy * oy
        inv = 1.0 / math.sqrt(max(r2, 1e-300))
        tb[tid, 6, c] = math.atan2((oy * ct - ox * st) * inv, (ox * ct + oy * st) * inv)
        tb[tid, 7, c] = 0.5 * r2
    two_pi = 2.0 * math.pi
    tq = 0.0
    nq = 0
    cross = 0.0
    for c in range(nc):
        if tb[tid, 5, c] > 0.0:
            continue
        psi = tb[tid, 6, c]
        span = 4.0 * math.pi
        nxt = c
        for e in range(nc):
            if e != c:
                d = tb[tid, 6, e] - psi
                if d <= 0.0:
                    d += two_pi
                if d < span:
                    span = d
                    nxt = e
        if nxt == c:
            continue
        tq += tb[tid, 7, nxt] - tb[tid, 7, c]
        if core != 1.0:
            cross += dx * (tb[tid, 4, nxt] - tb[tid, 4, c]) - dy * (tb[tid, 3, nxt] - tb[tid, 3, c])
        n = max(1, int(math.ceil(span / h)))
        if nq + 2 * n > tb.shape[2]:
            # only if the crossings do not alternate (arcs then overlap): keep in bounds
            break
        w = span / n
        for p in range(n):
            mid = psi + (p + 0.5) * w
            for q in range(2):
                ang = mid + (2 * q - 1) * _G * w
                tb[tid, 0, nq] = math.cos(ang)
                tb[tid, 1, nq] = math.sin(ang)
                tb[tid, 2, nq] = 0.5 * w
                nq += 1
    dst[row, 2] += tq
    if nq > 0:
        _shape_integrals(j, nq, a, b, geo, R0, tb, tid, dst, row)
    if core != 1.0:
        return 0.5 * cross + (_half_r2(j, nq, a, b, geo, R0, tb, tid) if nq > 0 else 0.0)
    return 0.0


@njit(**NJIT)
def arc_pair(i, j, dx, dy, k0, nseg, a, b, geo, R, px, py, R0, cphi, sphi, tb, tid, own, orow, other, xrow, core):
    """Integrate the overlap of cells i and j (j at offset (dx, dy)) over the contour of
    cell i, and, from the same crossings, over the contour of j.

    Returns the overlap area A(i ∩ j) when ``core`` (the core exponent) is not 1, from
    the same arcs (Green's theorem about r_i, as in :mod:`fcsweep.model.overlap_exact`),
    else 0 without computing it: the caller scales the pair's integrals by
    core A^(core - 1).

    ``tb[tid, 6, m]`` and ``tb[tid, 7, m]`` hold the gap and h * dg/dphi at window point m
    (contour index k0 + m, modulo K); segments m = 0 .. nseg - 1 join points m, m + 1.
    ``R``, ``px``, ``py`` are the sampled radii and contour points of
    :func:`fcsweep.kernels.geometry.geometry`.  Adds i's arc integrals to ``own[orow]``
    and j's to ``other[xrow]``.  (No boolean switches: numba compiles a function once
    per combination of literal arguments, and this one takes a minute.)
    """
    K = cphi.shape[0]
    h = 2.0 * math.pi / K
    eps = DIP_MARGIN * R0 * (40.0 / K) ** 4
    fx = 0.0
    fy = 0.0
    tq = 0.0
    nq = 0
    nc = 0
    for m in range(nseg):
        g0 = tb[tid, 6, m]
        g1 = tb[tid, 6, m + 1]
        m0 = tb[tid, 7, m]
        m1 = tb[tid, 7, m + 1]
        A = m0 - (g1 - g0)
        B = m1 - (g1 - g0)
        if max(g0, g1) + 0.25 * max(A, -B, 0.0) <= -eps:
            continue  # the cubic stays well outside
        in0 = g0 > 0.0
        in1 = g1 > 0.0
        k = (k0 + m) % K
        k1 = k + 1 if k + 1 < K else 0
        # the inside piece(s) [ta, tb] (up to two) of the segment, with end points
        ta = 0.0
        xa = px[i, k]
        ya = py[i, k]
        ra = R[i, k]
        tb_ = 1.0
        xb = px[i, k1]
        yb = py[i, k1]
        rb = R[i, k1]
        if in0 != in1:
            t = _root(0.0, 1.0, g0, g0, g1, m0, m1)
            t, x, y, r = polish(t, 0.0, 1.0, in0, i, j, k, h, dx, dy, a, b, geo, R0, cphi, sphi)
            nc = _crossing(x, y, -1.0 if in0 else 1.0, nc, tb, tid)
            if in0:
                tb_, xb, yb, rb = t, x, y, r
            else:
                ta, xa, ya, ra = t, x, y, r
        elif not (in0 and min(g0, g1) - 0.25 * max(-A, B, 0.0) > eps):
            # same sign at both ends and the cubic comes near zero: check the true gap at
            # the cubic's extremum towards the other side
            n, t1, t2 = _critical_points(g0, g1, m0, m1)
            tc = -1.0
            pc = 0.0
            for q in range(n):
                tq_ = t1 if q == 0 else t2
                p, _ = _hermite(tq_, g0, g1, m0, m1)
                if tc < 0.0 or (p < pc if in0 else p > pc):
                    tc = tq_
                    pc = p
            crossed = False
            gc = 0.0
            if tc >= 0.0 and (pc < eps if in0 else pc > -eps):
                gc = true_gap(i, j, k, tc, h, dx, dy, a, b, geo, R0, cphi, sphi)[0]
                crossed = (gc > 0.0) != in0
            if not crossed and not in0:
                continue
            if crossed:
                # two crossings, in [0, tc] and [tc, 1]: start from the cubic's roots
                # where the cubic crosses too, else from the secant
                if (pc > 0.0) != in0:
                    sa = _root(0.0, tc, g0, g0, g1, m0, m1)
                    sb = _root(tc, 1.0, pc, g0, g1, m0, m1)
                else:
                    sa = tc * g0 / (g0 - gc)
                    sb = tc + (1.0 - tc) * gc / (gc - g1)
                t, x, y, r = polish(sa, 0.0, tc, in0, i, j, k, h, dx, dy, a, b, geo, R0, cphi, sphi)
                u, xu, yu, ru = polish(sb, tc, 1.0, not in0, i, j, k, h, dx, dy, a, b, geo, R0, cphi, sphi)
                nc = _crossing(x, y, -1.0 if in0 else 1.0, nc, tb, tid)
                nc = _crossing(xu, yu, 1.0 if in0 else -1.0, nc, tb, tid)
                if in0:
                    f1, f2, f3, nq = _piece(k, 0.0, t, xa, ya, ra, x, y, r, h, cphi, sphi, tb, tid, nq)
                    fx += f1
                    fy += f2
                    tq += f3
                    ta, xa, ya, ra = u, xu, yu, ru
                else:
                    ta, xa, ya, ra = t, x, y, r
                    tb_, xb, yb, rb = u, xu, yu, ru
        f1, f2, f3, nq = _piece(k, ta, tb_, xa, ya, ra, xb, yb, rb, h, cphi, sphi, tb, tid, nq)
        fx += f1
        fy += f2
        tq += f3
    own[orow, 0] += fx
    own[orow, 1] += fy
    own[orow, 2] += tq
    area = 0.0
    if nq > 0:
        _shape_integrals(i, nq, a, b, geo, R0, tb, tid, own, orow)
        if core != 1.0:
            area = _half_r2(i, nq, a, b, geo, R0, tb, tid)
    if nc > 0:
        area += _other_side(j, dx, dy, nc, fx, fy, a, b, geo, R0, h, tb, tid, other, xrow, core)
    return area
