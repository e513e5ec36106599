"""Adhesion rates (numba): the kernel of :mod:`fcsweep.model.adhesion`, which states the
energy and the rates and is the reference the tests compare this kernel with.

Called by :func:`fcsweep.kernels.step.compute_rates` only when ``prm[P_ADH] > 0``, after
:func:`fcsweep.kernels.rates.all_rates` has written the overlap and tension rates; it
adds the adhesion rates to them.  It uses, as scratch, rows that are free by then (all
are rebuilt at the next step): ``tx, ty[:, :K]`` for R_i(phi_k), R_i'(phi_k) of every
cell, ``px, py[i, :K]`` for cell i's per-point shape sums (part A of the model module)
and ``acc[i]`` for its sums at the other cells' points (part B).  Each cell writes only
its own rows, so the result does not depend on the number of threads.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .fourier import fourier_series
from .geometry import radius_at
from .options import NJIT, njit
from .records import P_ADH, P_ADHR, P_LX, P_LY, P_MUS, P_MUT, P_R0


@njit(**NJIT)  # not inlined: two call sites in a parallel loop would compile it twice
def _adhesion_pair(i, j, dx, dy, a, b, geo, tx, ty, cphi, sphi, U, V, acc, R0, delta):
    """Both parts of the ordered pair (i, j), ``(dx, dy) = r_j - r_i`` (image included):
    adds i's per-point sums to ``U[i], V[i]`` and its sums at j's points to ``acc[i]``;
    returns i's force (x, y) and torque sums, in units of gamma dphi."""
    M1 = a.shape[1]
    K = cphi.shape[0]
    ci = geo[i, 2]
    si = geo[i, 3]
    cj = geo[j, 2]
    sj = geo[j, 3]
    tiny = 1e-12 * R0
    fx = 0.0
    fy = 0.0
    tq = 0.0
    reach = geo[j, 1] + delta
    for k in range(K):  # A: i's points near j
        r = tx[i, k]
        d = ty[i, k]
        ex = ci * cphi[k] - si * sphi[k]
        ey = si * cphi[k] + ci * sphi[k]
        ox = r * ex - dx
        oy = r * ey - dy
        rho2 = ox * ox + oy * oy
        if rho2 >= reach * reach:
            continue
        sk = math.sqrt(r * r + d * d)
        rho = math.sqrt(rho2)
        if rho < tiny:  # at j's centre: deep inside
            U[i, k] += r / sk
            V[i, k] += d / sk
            continue
        inv = 1.0 / rho
        erx = ox * inv
        ery = oy * inv
        rr, dr = fourier_series(erx * cj + ery * sj, ery * cj - erx * sj, a, b, j)
        dRj = R0 * dr
        h = rho - R0 * (geo[j, 0] + rr)
        if h >= delta:
            continue
        w = 1.0
        if h > 0.0:
            u = h / delta
            w = (1.0 - u) * (1.0 - u) * (1.0 + 2.0 * u)
            ws = -6.0 * u * (1.0 - u) / delta * sk
            gx = erx + dRj * inv * ery
            gy = ery - dRj * inv * erx
            fx += ws * gx
            fy += ws * gy
            tq += ws * r * (ex * gy - ey * gx)
            U[i, k] += ws * (gx * ex + gy * ey)
        U[i, k] += w * r / sk
        V[i, k] += w * d / sk
    reach = geo[i, 1] + delta
    for k in range(K):  # B: j's points near i
        r = tx[j, k]
        d = ty[j, k]
        ox = dx + r * (cj * cphi[k] - sj * sphi[k])
        oy = dy + r * (sj * cphi[k] + cj * sphi[k])
        rho2 = ox * ox + oy * oy
        if rho2 >= reach * reach or rho2 < tiny * tiny:
            continue
        rho = math.sqrt(rho2)
        inv = 1.0 / rho
        erx = ox * inv
        ery = oy * inv
        c = erx * ci + ery * si
        s = ery * ci - erx * si
        rr, dr = fourier_series(c, s, a, b, i)
        dRi = R0 * dr
        h = rho - R0 * (geo[i, 0] + rr)
        if h <= 0.0 or h >= delta:
            continue
        u = h / delta
        ws = -6.0 * u * (1.0 - u) / delta * math.sqrt(r * r + d * d)
        fx -= ws * (erx + dRi * inv * ery)
        fy -= ws * (ery - dRi * inv * erx)
        tq += ws * dRi
        acc[i, 3] += ws
        cn = c
        sn = s
        for m in range(M1):
            t = cn * c - sn * s
            sn = sn * c + cn * s
            cn = t
            acc[i, 4 + m] += ws * cn
            acc[i, 4 + M1 + m] += ws * sn
    return fx, fy, tq


@njit(parallel=True, **NJIT)
def adhesion_rates(pos, a, b, prm, periodic, tables, scratch, nl, out, use_list):
    """Add the adhesion rates of every cell to ``out`` (records as in
    :func:`fcsweep.kernels.rates.all_rates`; the list must reach ``prm[P_ADHR]`` beyond
    the bounding radii, which :func:`fcsweep.kernels.step.compute_rates` builds it to).

    With ``use_list`` the pairs are the Verlet list's, at minimum image; otherwise every
    other cell at each of the 9 periodic images (or the direct pair for open boundaries).
    """
    cosn, sinn, cphi, sphi = tables
    px, py, tx, ty, geo, acc = scratch.px, scratch.py, scratch.tx, scratch.ty, scratch.geo, scratch.acc
    nbr = nl[0]
    count = nl[1]
    dpos, dth, da, db = out
    gamma = prm[P_ADH]
    delta = prm[P_ADHR]
    R0 = prm[P_R0]
    Lx = prm[P_LX]
    Ly = prm[P_LY]
    mu_theta = prm[P_MUT]
    mu_shape = prm[P_MUS]
    N, M1 = a.shape
    K = cphi.shape[0]
    c = gamma * 2.0 * math.pi / K
    for i in prange(N):
        a0 = geo[i, 0]
        for k in range(K):
            r, d = radius_at(a, b, i, k, a0, cosn, sinn)
            tx[i, k] = R0 * r
            ty[i, k] = R0 * d
    for ii in prange(N):
        i = np.int64(ii)
        for k in range(K):
            px[i, k] = 0.0
            py[i, k] = 0.0
        for k in range(acc.shape[1]):
            acc[i, k] = 0.0
        fx = 0.0
        fy = 0.0
        tq = 0.0
        xi = pos[i, 0]
        yi = pos[i, 1]
        if use_list:
            for p in range(count[i]):
                j = nbr[i, p]
                dx = pos[j, 0] - xi
                dy = pos[j, 1] - yi
                if dx > 0.5 * Lx:
                    dx -= Lx
                elif dx < -0.5 * Lx:
                    dx += Lx
                if dy > 0.5 * Ly:
                    dy -= Ly
                elif dy < -0.5 * Ly:
                    dy += Ly
                cut = geo[i, 1] + geo[j, 1] + delta
                if dx * dx + dy * dy >= cut * cut:
                    continue
                gx, gy, gt = _adhesion_pair(i, j, dx, dy, a, b, geo, tx, ty, cphi, sphi, px, py, acc, R0, delta)
                fx += gx
                fy += gy
                tq += gt
        else:
            nimg = 1 if periodic else 0
            for j in range(N):
                if j == i:
                    continue
                for sx in range(-nimg, nimg + 1):
                    for sy in range(-nimg, nimg + 1):
                        dx = pos[j, 0] + sx * Lx - xi
                        dy = pos[j, 1] + sy * Ly - yi
                        cut = geo[i, 1] + geo[j, 1] + delta
                        if dx * dx + dy * dy >= cut * cut:
                            continue
                        gx, gy, gt = _adhesion_pair(i, j, dx, dy, a, b, geo, tx, ty, cphi, sphi, px, py, acc, R0,
                                                    delta)
                        fx += gx
                        fy += gy
                        tq += gt
        dpos[i, 0] += c * fx
        dpos[i, 1] += c * fy
        if M1 == 0:  # rigid discs: no torque, no shape
            continue
        dth[i] += mu_theta * c * tq
        cs = mu_shape * c * R0
        a0 = geo[i, 0]
        usum = 0.0
        for k in range(K):
            usum += px[i, k]
        for m in range(M1):
            uc = 0.0
            us = 0.0
            vc = 0.0
            vs = 0.0
            for k in range(K):
                uc += px[i, k] * cosn[m, k]
                us += px[i, k] * sinn[m, k]
                vc += py[i, k] * cosn[m, k]
                vs += py[i, k] * sinn[m, k]
            n = m + 2.0
            da[i, m] += cs * ((uc - a[i, m] / (2.0 * a0) * usum - n * vs)
                              - (acc[i, 4 + m] - a[i, m] / (2.0 * a0) * acc[i, 3]))
            db[i, m] += cs * ((us - b[i, m] / (2.0 * a0) * usum + n * vc)
                              - (acc[i, 4 + M1 + m] - b[i, m] / (2.0 * a0) * acc[i, 3]))
