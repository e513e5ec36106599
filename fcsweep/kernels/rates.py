"""Deterministic rates of every cell (numba kernels): the per-cell mode sums of the
overlap and tension terms, and the parallel loop over cells and their neighbours.

The readable numpy twin of the whole computation is :func:`fcsweep.model.rates.rates`;
tests compare the two.  Arrays as in :mod:`.geometry`, and

- ``tbuf``        float64[threads, 8, 4K + 8]  per-thread window scratch (arc rule: Gauss nodes)
- ``pbuf``        float64[threads, >= max(2K+LANES, 4+2M1)]  one pair's share (contact-implicit)
"""

from __future__ import annotations

import math

import numpy as np
from numba import get_thread_id, prange

from .contacts import (J_DEPTH, J_DLAM, J_LAM, J_UOWN, J_UX, J_UY, add_scaled_arc_pair, add_share_rates,
                       jacobi_factor, rates_depth_rate, record_arc_pair, scale_point_pair)
from .options import NJIT, njit
from .pairs import QUAD_ARC, pair_arc, pair_arc_call, pair_weights
from .records import P_CONTACT, P_CORE, P_DT, P_ETA, P_KFLOOR, P_LAMMAX, P_LX, P_LY, P_MUS, P_MUT, P_R0, P_V0


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

    (Plain arrays, not records: it is inlined into a prange loop, and numba loses the
    writes to arrays taken out of a tuple inside an inlined function there.)

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
    R0i = geo[i, 5]  # the cell's own radius (``R0``, the mean, is not read)
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
        da[i, m] = -mu_shape * R0i * (uc - a[i, m] / (2.0 * a0) * usum - n * vs)
        db[i, m] = -mu_shape * R0i * (us - b[i, m] / (2.0 * a0) * usum + n * vc)


@njit(inline="always", **NJIT)
def add_core_pair(tid, pair, dst, row, other, orow, core, area):
    """Add one pair's integrals ``pair[tid]`` times p A^(p - 1) (p = ``core``, A the
    pair's overlap area: the gradient of A^p) to ``dst[row]``, and scale the other
    cell's share ``other[orow]`` (if ``orow >= 0``) by the same factor."""
    f = core * area ** (core - 1.0) if area > 0.0 else 0.0
    for k in range(dst.shape[1]):
        dst[row, k] += f * pair[tid, k]
    if orow >= 0:
        for k in range(dst.shape[1]):
            other[orow, k] *= f


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
def all_rates(pos, a, b, prm, periodic, quad, tables, scratch, nl, out, use_list, jacobi):
    """Deterministic rates of every cell into ``out`` (geometry in ``scratch`` must be
    current; the records are those of :mod:`.records`, unpacked here, outside the
    parallel loops: the functions inlined into them take plain arrays).

    With ``use_list`` the Verlet list ``nbr[i, :count[i]]`` (see :mod:`.verlet`) gives
    the candidates in ascending j; otherwise (boxes too small for a cell list) every
    cell and every one of the 9 periodic images (or, for open boundaries, the direct
    pair only) is visited.  Each iteration writes only to row i, so the result does not
    depend on the number of threads.

    The arc rule resolves each pair once, on the contour of its lower-index cell, and
    derives the other cell's integrals from the same crossings (exact action-reaction).
    With the list, cell i keeps j's share in ``pairbuf[i * cap + p]`` (``nbr[i, p] = j``)
    and j collects it in a second pass (at ``back[j, p']``, built with the list); without
    it, the higher-index cell recomputes
    the pair (small boxes only).

    With ``coef > 0`` (the ``contact-implicit`` integrator, :mod:`fcsweep.kernels.contacts`) every
    pair's integrals are scaled by the pair's implicit factor before they are added: a
    point rule's weights via a copy of ``W[i]`` in ``pbuf[tid]``, the arc rule's by
    resolving the pair into ``pbuf[tid]``.  (A cell overlapping its own periodic image,
    in boxes of a few cells, is left explicit.)  The rates are then the effective rates
    of one step of length dt, not the physical ones.

    With ``core != 1`` (the core exponent p, energy sum A_ij^p) the arc rule resolves
    each pair into ``pbuf[tid]`` as well, with its overlap area A, and adds it times
    p A^(p - 1) (:func:`add_core_pair`); rigid discs scale the chord (:func:`.pairs.pair_disc`).
    At p = 1 none of this runs.
    """
    cosn, sinn, cphi, sphi = tables
    R, dR, px, py, tx, ty, geo, W, tbuf, acc, pbuf = scratch
    nbr, count, _, _, _, pairbuf, ownbuf, pinfo, back = nl
    dpos, dth, da, db = out
    Lx = prm[P_LX]
    Ly = prm[P_LY]
    R0 = prm[P_R0]
    eta = prm[P_ETA]
    v0 = prm[P_V0]
    mu_theta = prm[P_MUT]
    mu_shape = prm[P_MUS]
    coef = prm[P_CONTACT]
    kfloor = prm[P_KFLOOR]
    core = prm[P_CORE]
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
                    if jacobi:
                        pinfo[i * cap + p, J_DEPTH] = 0.0
                    continue
                if arc:
                    # i's share to acc[i], or first to pbuf[tid] to be scaled (one inlined
                    # copy of the rule: each costs about a minute of compilation)
                    scaled = coef > 0.0 or core != 1.0
                    dst = pbuf if scaled else acc
                    row = tid if scaled else i
                    if scaled:
                        for k in range(acc.shape[1]):
                            pbuf[tid, k] = 0.0
                    area = pair_arc(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tbuf, tid,
                                    dst, row, pairbuf, i * cap + p, core)
                    if jacobi:
                        record_arc_pair(i, j, i * cap + p, tid, pbuf, pairbuf, ownbuf, pinfo, acc, a, b, geo, R0,
                                        mu_theta, mu_shape, kfloor)
                    elif coef > 0.0:
                        add_scaled_arc_pair(i, j, tid, pbuf, acc, i, pairbuf, i * cap + p, a, b, geo, R0, coef,
                                            kfloor)
                    elif scaled:
                        add_core_pair(tid, pbuf, acc, i, pairbuf, i * cap + p, core, area)
                else:
                    if points:
                        for k in range(W.shape[1]):
                            pbuf[tid, k] = W[i, k]
                    pair_weights(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, quad,
                                 W, tbuf, tid, acc, coef, core)
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
                                         W, tbuf, tid, acc, coef, core)
                            if points:
                                scale_point_pair(i, j, W, pbuf, tid, R, px, py, a, b, geo, R0, coef, kfloor)
                        elif j != i:
                            # the lower index resolves the pair; the other recomputes it
                            # (pairbuf row i takes the share that is not i's).  i's share goes
                            # to acc[i], or first to pbuf[tid] to be scaled (contact-implicit:
                            # i's force points away from j from either side, so the factor
                            # is the same for both cells)
                            scaled = coef > 0.0 or core != 1.0
                            dst = pbuf if scaled else acc
                            row = tid if scaled else i
                            if scaled:
                                for k in range(acc.shape[1]):
                                    pbuf[tid, k] = 0.0
                            if i < j:
                                area = pair_arc_call(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi,
                                                     R0, tbuf, tid, dst, row, pairbuf, i, core)
                            else:
                                area = pair_arc_call(j, i, -dx, -dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi,
                                                     R0, tbuf, tid, pairbuf, i, dst, row, core)
                            if coef > 0.0:
                                add_scaled_arc_pair(i, j, tid, pbuf, acc, i, pairbuf, -1, a, b, geo, R0, coef,
                                                    kfloor)
                            elif scaled:
                                add_core_pair(tid, pbuf, acc, i, pairbuf, -1, core, area)
                        elif sx > 0 or (sx == 0 and sy > 0):
                            # one of the two instances of a pair with its own image: both shares
                            # (left at p = 1 under a core exponent: boxes of a few cells only)
                            pair_arc_call(i, i, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tbuf,
                                          tid, acc, i, acc, i, 1.0)
    # a second pass: cell_rates overwrites rows that pairs of other cells read above
    for jj in prange(N):
        j = np.int64(jj)
        if arc and use_list:
            for p in range(count[j]):
                i = nbr[j, p]
                if i > j:
                    break
                if back[j, p] >= 0:
                    e = i * cap + back[j, p]
                    f = pinfo[e, J_LAM] if jacobi else 1.0
                    for k in range(acc.shape[1]):
                        acc[j, k] += f * pairbuf[e, k]
        cell_rates(j, a, b, geo, R, dR, px, py, cosn, sinn, cphi, sphi, W, acc, R0, eta, v0, mu_theta,
                   mu_shape, dpos, dth, da, db)


@njit(parallel=True, **NJIT)
def contact_sweeps(a, b, prm, scratch, nl, out, sweeps):
    """Jacobi sweeps of the contact-jacobi integrator over the list pairs recorded by
    :func:`all_rates` (see :mod:`fcsweep.model.integrators`).

    Each sweep takes every contact's approach rate from the other forces out of the
    current rates (all rates minus the contact's own scaled share), solves the
    contact's implicit depth step for its factor, and then adds each cell's change of
    factors times its unscaled shares to its rates.  Pairs are read in the list order of
    their lower-index cell, so the result does not depend on the number of threads.
    """
    geo = scratch.geo
    nbr, count, _, _, _, pairbuf, ownbuf, pinfo, back = nl
    dpos, dth, da, db = out
    R0 = prm[P_R0]
    mu_theta = prm[P_MUT]
    mu_shape = prm[P_MUS]
    dt = prm[P_DT]
    lam_max = prm[P_LAMMAX]
    N = nbr.shape[0]
    cap = nbr.shape[1]
    for _ in range(sweeps):
        for ii in prange(N):
            i = np.int64(ii)
            for p in range(count[i]):
                j = nbr[i, p]
                e = i * cap + p
                if j < i or pinfo[e, J_DEPTH] <= 0.0:
                    continue
                ux = pinfo[e, J_UX]
                uy = pinfo[e, J_UY]
                lam = pinfo[e, J_LAM]
                u_own = pinfo[e, J_UOWN]
                u_other = rates_depth_rate(i, j, ux, uy, dpos, dth, da, db, a, b, geo, R0) - lam * u_own
                new = jacobi_factor(pinfo[e, J_DEPTH], u_own, u_other, dt, lam_max)
                pinfo[e, J_DLAM] = new - lam
                pinfo[e, J_LAM] = new
        for jj in prange(N):
            j = np.int64(jj)
            for p in range(count[j]):
                i = nbr[j, p]
                # j's own share of its pairs with higher cells, else the share i keeps for j
                own = i > j
                if not own and back[j, p] < 0:
                    continue
                e = j * cap + p if own else i * cap + back[j, p]
                if pinfo[e, J_DEPTH] > 0.0 and pinfo[e, J_DLAM] != 0.0:
                    add_share_rates(j, pinfo[e, J_DLAM], ownbuf if own else pairbuf, e, a, b, geo, R0, mu_theta,
                                    mu_shape, dpos, dth, da, db)
