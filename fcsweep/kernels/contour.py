"""Contour geometry, overlap weights and deterministic rates (numba kernels).

Every function here takes ndarrays and scalars only.  The readable numpy twin of the
whole computation is :func:`fcsweep.model.rates.rates`; tests compare the two.

Array conventions (N cells, K contour points, M1 = M - 1 shape modes):

- ``cosn, sinn``  float64[M1, K]  cos(n phi_k), sin(n phi_k), n = 2..M
- ``cphi, sphi``  float64[K]      cos(phi_k), sin(phi_k)
- ``R, dR``       float64[N, K]   R_i(phi_k), R'_i(phi_k)
- ``px, py``      float64[N, 2K]  contour point offsets x_ik - r_i in the lab frame,
  stored twice in a row so that an angular window never wraps
- ``geo``         float64[N, 4]   a0, bounding radius, cos(theta), sin(theta)
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .arcs import arc_pair

NJIT = dict(cache=True, error_model="numpy")

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
def geometry(theta, a, b, R0, cosn, sinn, cphi, sphi, R, dR, px, py, geo):
    """Contour radius, its derivative and lab-frame contour points of every cell."""
    N, M1 = a.shape
    K = cphi.shape[0]
    for i in prange(N):
        s2 = 0.0
        s1 = 0.0
        for m in range(M1):
            q = a[i, m] * a[i, m] + b[i, m] * b[i, m]
            s2 += q
            s1 += math.sqrt(q)
        a0 = math.sqrt(1.0 - 0.5 * s2)
        c = math.cos(theta[i])
        s = math.sin(theta[i])
        geo[i, 0] = a0
        geo[i, 1] = R0 * (a0 + s1)
        geo[i, 2] = c
        geo[i, 3] = s
        for k in range(K):
            R[i, k] = a0
            dR[i, k] = 0.0
        for m in range(M1):
            am = a[i, m]
            bm = b[i, m]
            n = m + 2.0
            for k in range(K):
                R[i, k] += am * cosn[m, k] + bm * sinn[m, k]
                dR[i, k] += n * (bm * cosn[m, k] - am * sinn[m, k])
        for k in range(K):
            r = R0 * R[i, k]
            R[i, k] = r
            dR[i, k] *= R0
            x = r * (c * cphi[k] - s * sphi[k])
            y = r * (s * cphi[k] + c * sphi[k])
            px[i, k] = x
            py[i, k] = y
            px[i, k + K] = x
            py[i, k + K] = y


@njit(**NJIT)
def gap_at(ox, oy, j, a, b, geo, R0):
    """Radial gap R_j(psi) - |d| of the offset d = (ox, oy) from the centre of cell j."""
    M1 = a.shape[1]
    d2 = ox * ox + oy * oy
    r = math.sqrt(d2)
    if r < 1e-300:
        return R0 * geo[j, 0]
    inv = 1.0 / r
    ct = geo[j, 2]
    st = geo[j, 3]
    c = (ox * ct + oy * st) * inv
    s = (oy * ct - ox * st) * inv
    cn = c
    sn = s
    Rj = geo[j, 0]
    for m in range(M1):
        t = cn * c - sn * s
        sn = sn * c + cn * s
        cn = t
        Rj += a[j, m] * cn + b[j, m] * sn
    return R0 * Rj - r


@njit(**NJIT)
def angular_window(dx, dy, D, theta_i, rbj, K):
    """Contour points of cell i that can lie in the bounding circle of j.

    A point at any radius in direction beta from r_i is within ``rbj`` of r_j (at
    distance D in direction alpha) only if |beta - alpha| <= asin(rbj / D).  Returns
    the first index (0 <= k0 < K) and the count (K for the whole contour).
    """
    if D <= rbj * (1.0 + 1e-12):
        return 0, K
    dphi = 2.0 * math.pi / K
    half = math.asin(rbj / D) / dphi
    centre = (math.atan2(dy, dx) - theta_i) / dphi
    lo = int(math.floor(centre - half))
    hi = int(math.ceil(centre + half))
    cnt = hi - lo + 1
    if cnt >= K:
        return 0, K
    k0 = lo % K
    if k0 < 0:
        k0 += K
    return k0, cnt


@njit(**NJIT)
def pair_weights(i, j, dx, dy, theta, a, b, geo, R, dR, px, py, cphi, sphi, R0, quad, W, gbuf, acc):
    """Add the overlap weights of cell j onto the contour points of cell i.

    ``(dx, dy)`` is r_j - r_i for the image of j being considered.  Binary and linear
    rules add per-point weights to ``W[i]``; the arc rule adds exact arc integrals to
    ``acc[i]`` directly.
    """
    K = cphi.shape[0]
    rbj = geo[j, 1]
    D = math.sqrt(dx * dx + dy * dy)
    if quad == QUAD_BINARY:
        k0, cnt = angular_window(dx, dy, D, theta[i], rbj, K)
        rb2 = rbj * rbj
        for kk in range(k0, k0 + cnt):
            ox = px[i, kk] - dx
            oy = py[i, kk] - dy
            if ox * ox + oy * oy < rb2:
                if gap_at(ox, oy, j, a, b, geo, R0) > 0.0:
                    W[i, kk if kk < K else kk - K] += 1.0
        return
    # linear and arc rules need the gap one point beyond each end of the window
    k0, cnt = angular_window(dx, dy, D, theta[i], rbj, K)
    full = cnt + 2 >= K
    if full:
        k0 = 0
        cnt = K
    else:
        k0 = k0 - 1
        if k0 < 0:
            k0 += K
        cnt += 2
    nseg = K if full else cnt - 1
    if quad == QUAD_ARC:
        arc_pair(i, j, dx, dy, k0, nseg, theta, a, b, geo, R, dR, px, py, cphi, sphi, R0, gbuf, acc)
        return
    for m in range(nseg + 1):
        kk = (k0 + m) % K
        gbuf[i, 0, m] = gap_at(px[i, kk] - dx, py[i, kk] - dy, j, a, b, geo, R0)
    for m in range(nseg):
        g0 = gbuf[i, 0, m]
        g1 = gbuf[i, 0, m + 1]
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


@njit(**NJIT)
def cell_rates(i, theta, a, b, geo, R, dR, cosn, sinn, cphi, sphi, W, acc, R0, eta, v0, mu_theta, mu_shape,
               dpos, dth, da, db):
    """Rates of cell i from its point weights ``W[i]`` and arc integrals ``acc[i]``.

    ``acc[i]`` holds, for the arc rule, the integrals over overlap arcs of
    [force x, force y, torque, R, R cos n phi (M1), R sin n phi (M1)].
    """
    K = cphi.shape[0]
    M1 = a.shape[1]
    dphi = 2.0 * math.pi / K
    c = geo[i, 2]
    s = geo[i, 3]
    a0 = geo[i, 0]
    fx = 0.0
    fy = 0.0
    tq = 0.0
    usum = 0.0
    for k in range(K):
        w = W[i, k]
        r = R[i, k]
        d = dR[i, k]
        ex = c * cphi[k] - s * sphi[k]
        ey = s * cphi[k] + c * sphi[k]
        fx += w * (-d * ey - r * ex)
        fy += w * (d * ex - r * ey)
        tq += w * r * d
    fx = fx * dphi + acc[i, 0]
    fy = fy * dphi + acc[i, 1]
    tq = tq * dphi + acc[i, 2]
    dpos[i, 0] = v0 * c + fx
    dpos[i, 1] = v0 * s + fy
    dth[i] = mu_theta * tq
    # u_k = w R + eta R/s and v_k = eta R'/s (perimeter gradient on the same points)
    for k in range(K):
        r = R[i, k]
        d = dR[i, k]
        inv_s = 1.0 / math.sqrt(r * r + d * d)
        W[i, k] = (W[i, k] * r + eta * r * inv_s) * dphi  # reuse W as u_k dphi
        usum += W[i, k]
        dR_over_s = eta * d * inv_s * dphi
        R[i, k] = dR_over_s  # reuse R as v_k dphi (R is recomputed next step)
    usum += acc[i, 3]
    for m in range(M1):
        n = m + 2.0
        uc = 0.0
        us = 0.0
        vc = 0.0
        vs = 0.0
        for k in range(K):
            u = W[i, k]
            v = R[i, k]
            uc += u * cosn[m, k]
            us += u * sinn[m, k]
            vc += v * cosn[m, k]
            vs += v * sinn[m, k]
        uc += acc[i, 4 + m]
        us += acc[i, 4 + M1 + m]
        da[i, m] = -mu_shape * R0 * (uc - a[i, m] / (2.0 * a0) * usum - n * vs)
        db[i, m] = -mu_shape * R0 * (us - b[i, m] / (2.0 * a0) * usum + n * vc)


@njit(parallel=True, **NJIT)
def all_rates(pos, theta, a, b, Lx, Ly, periodic, R0, eta, v0, mu_theta, mu_shape, quad,
              cosn, sinn, cphi, sphi, R, dR, px, py, geo, W, gbuf, acc,
              nx, ny, cell_of, cell_start, cell_members, dpos, dth, da, db):
    """Deterministic rates of every cell (geometry must be current).

    With ``nx, ny >= 3`` the cell list is used with minimum-image pairs; otherwise every
    cell and every one of the 9 periodic images (or, for open boundaries, the direct
    pair only) is visited.  Each iteration writes only to row i, so the result does not
    depend on the number of threads.
    """
    N = pos.shape[0]
    for i in prange(N):
        for k in range(W.shape[1]):
            W[i, k] = 0.0
        for k in range(acc.shape[1]):
            acc[i, k] = 0.0
        rbi = geo[i, 1]
        xi = pos[i, 0]
        yi = pos[i, 1]
        if nx >= 3 and ny >= 3:
            c = cell_of[i]
            cx = c % nx
            cy = c // nx
            for ox in range(-1, 2):
                ccx = cx + ox
                if ccx < 0:
                    ccx += nx
                elif ccx >= nx:
                    ccx -= nx
                for oy in range(-1, 2):
                    ccy = cy + oy
                    if ccy < 0:
                        ccy += ny
                    elif ccy >= ny:
                        ccy -= ny
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
                        if dx * dx + dy * dy >= cut * cut:
                            continue
                        pair_weights(i, j, dx, dy, theta, a, b, geo, R, dR, px, py, cphi, sphi, R0, quad, W, gbuf, acc)
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
                        pair_weights(i, j, dx, dy, theta, a, b, geo, R, dR, px, py, cphi, sphi, R0, quad, W, gbuf, acc)
        cell_rates(i, theta, a, b, geo, R, dR, cosn, sinn, cphi, sphi, W, acc, R0, eta, v0, mu_theta, mu_shape,
                   dpos, dth, da, db)
