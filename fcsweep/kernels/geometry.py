"""Contour geometry of every cell (numba kernels): sampled radii, contour points and
tangents in the lab frame, bounding radii, and the radial gap of a point to a contour.

Array conventions (N cells, K contour points, M1 = M - 1 shape modes):

- ``cosn, sinn``  float64[M1, K]  cos(n phi_k), sin(n phi_k), n = 2..M
- ``cphi, sphi``  float64[K]      cos(phi_k), sin(phi_k)
- ``R, dR``       float64[N, K]   R_i(phi_k), R'_i(phi_k)
- ``px, py``      float64[N, 2K+LANES]  contour point offsets x_ik - r_i in the lab
  frame, repeated periodically along the row so that an angular window never wraps
- ``tx, ty``      like px, py: contour tangents dx/dphi (arc rule only)
- ``geo``         float64[N, 6]   a0, bounding radius (rigorous), cos(theta),
  sin(theta), largest sampled radius, and the cell's own radius R0,i (column 5: set
  once by the :class:`.workspace.Workspace`, the mean R0 unless sizes differ; every
  kernel reads a cell's radius there)
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .fourier import fourier6, fourier_series, modes6
from .options import NJIT, njit

#: Points per vector block of the binary rule (a multiple of the SIMD width).
LANES = 4



def mode_tables(K, M1):
    """cos/sin tables of the contour angles: (cosn, sinn, cphi, sphi)."""
    phi = 2.0 * np.pi * np.arange(K) / K
    n = np.arange(2, M1 + 2)
    cosn = np.ascontiguousarray(np.cos(np.multiply.outer(n, phi)))
    sinn = np.ascontiguousarray(np.sin(np.multiply.outer(n, phi)))
    return cosn.reshape(M1, K), sinn.reshape(M1, K), np.cos(phi), np.sin(phi)


@njit(parallel=True, **NJIT)
def geometry(theta, a, b, R0, tables, scratch, tangents):
    """Contour radius, its derivative and lab-frame contour points of every cell
    (and, if ``tangents``, the contour tangents dx/dphi = R' e + R e_perp) into
    ``scratch`` (a :class:`.records.Scratch`: R, dR, px, py, tx, ty, geo).

    Loops use unsigned indices so that numba emits no wraparound checks and LLVM
    vectorises them across contour points.  Each cell's radius is its own, ``geo[i, 5]``
    (``R0``, the mean, is not read: it stays in the signature for the callers).
    """
    cosn, sinn, cphi, sphi = tables
    R, dR, px, py, tx, ty, geo = scratch.R, scratch.dR, scratch.px, scratch.py, scratch.tx, scratch.ty, scratch.geo
    N, M1 = a.shape
    K = np.uint64(cphi.shape[0])
    L = np.uint64(px.shape[1])
    for i in prange(N):
        ui = np.uint64(i)
        R0i = geo[i, 5]
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
            geo[i, 1] = R0i
            geo[i, 4] = R0i
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
            r = R0i * R[ui, k]
            d = R0i * dR[ui, k]
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
        geo[i, 1] = min(R0i * (a0 + s1), rho + math.pi / cphi.shape[0] * R0i * sn1)


@njit(inline="always", **NJIT)
def radius_at(a, b, i, k, a0, cosn, sinn):
    """R_i(phi_k) / R0,i and R_i'(phi_k) / R0,i of cell i at contour point k (the mode sums;
    ``a0`` is ``geo[i, 0]``)."""
    r = a0
    d = 0.0
    for m in range(a.shape[1]):
        r += a[i, m] * cosn[m, k] + b[i, m] * sinn[m, k]
        d += (m + 2.0) * (b[i, m] * cosn[m, k] - a[i, m] * sinn[m, k])
    return r, d


@njit(**NJIT)
def gap_at(ox, oy, j, a, b, geo, R0):
    """Radial gap R_j(psi) - |d| of the offset d = (ox, oy) from the centre of cell j
    (``R0`` unused: j's radius is ``geo[j, 5]``)."""
    R0 = geo[j, 5]
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
