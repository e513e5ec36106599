"""Per-contact implicit factor of the ``contact-implicit`` integrator (numba kernels).

The math is in :mod:`fcsweep.model.integrators`: every integral of a pair is scaled by
λ = 1 / (x + sqrt(1 + x²)), x = coef · (2 / R0) / (κ L), L the pair's chord and κ the
sum of the two contours' curvatures where the line through the contact direction
meets them (floored at ``kfloor`` / R0, :data:`fcsweep.model.integrators.KAPPA_FLOOR`).
``coef = 0`` (Euler) is never passed here: the Euler path does not call these
functions, so its arithmetic is unchanged to the bit.
"""

from __future__ import annotations

import math


from .options import NJIT, njit


@njit(inline="always", **NJIT)
def contact_factor(chord, coef):
    """λ = 1 / (x + sqrt(1 + x²)) with x = coef / chord; 1 for an empty contact."""
    if chord <= 0.0:
        return 1.0
    x = coef / chord
    return 1.0 / (x + math.sqrt(1.0 + x * x))


@njit(inline="always", **NJIT)
def body_angle(i, ux, uy, geo):
    """cos and sin of the body-frame angle of the lab direction (ux, uy) for cell i."""
    ct = geo[i, 2]
    st = geo[i, 3]
    return ux * ct + uy * st, uy * ct - ux * st


@njit(**NJIT)
def curvature(i, ux, uy, a, b, geo, R0):
    """Curvature of cell i's contour in the lab direction (ux, uy) (unit vector):
    (R² + 2R'² − R R'') / (R² + R'²)^(3/2), positive where convex."""
    c1, s1 = body_angle(i, ux, uy, geo)
    cn = c1
    sn = s1
    r = geo[i, 0]
    r1 = 0.0
    r2 = 0.0
    for m in range(a.shape[1]):
        cn, sn = cn * c1 - sn * s1, sn * c1 + cn * s1  # n = m + 2
        n = m + 2.0
        t = a[i, m] * cn + b[i, m] * sn
        r += t
        r1 += n * (b[i, m] * cn - a[i, m] * sn)
        r2 -= n * n * t
    r *= R0
    r1 *= R0
    r2 *= R0
    q = r * r + r1 * r1
    return (q + r1 * r1 - r * r2) / (q * math.sqrt(q))


@njit(inline="always", **NJIT)
def pair_coef(i, j, ux, uy, a, b, geo, R0, coef, kfloor):
    """``coef`` of the pair (i, j) whose contact lies in direction (ux, uy) from i:
    ``coef`` (written for κ = 2 / R0) times 2 / (R0 max(κ_i + κ_j, kfloor / R0))."""
    kap = curvature(i, ux, uy, a, b, geo, R0) + curvature(j, -ux, -uy, a, b, geo, R0)
    return coef * 2.0 / max(kap * R0, kfloor)


@njit(inline="always", **NJIT)
def scale_point_pair(i, j, W, saved, tid, R, px, py, a, b, geo, R0, coef, kfloor):
    """Scale the point weights that one pair added to ``W[i]`` (``saved[tid]`` holds the
    row before the pair) by the factor of the pair's inside contour length Σ ΔW R dφ;
    the contact direction is that of the weighted mean of the inside points."""
    K = R.shape[1]
    n = W.shape[1]
    dphi = 2.0 * math.pi / K
    length = 0.0
    ux = 0.0
    uy = 0.0
    for k in range(n):
        d = W[i, k] - saved[tid, k]
        if d != 0.0:
            length += d * R[i, k % K]
            ux += d * px[i, k]
            uy += d * py[i, k]
    if length <= 0.0:
        return
    norm = math.sqrt(ux * ux + uy * uy)
    if norm > 0.0:
        coef = pair_coef(i, j, ux / norm, uy / norm, a, b, geo, R0, coef, kfloor)
    lam = contact_factor(length * dphi, coef)
    for k in range(n):
        d = W[i, k] - saved[tid, k]
        if d != 0.0:
            W[i, k] = saved[tid, k] + lam * d


@njit(inline="always", **NJIT)
def add_scaled_arc_pair(i, j, tid, pair, dst, row, other, orow, a, b, geo, R0, coef, kfloor):
    """Add the integrals ``pair[tid]`` of the pair (i, j), resolved on i's contour,
    scaled by the pair's factor, to ``dst[row]``, and scale the other cell's share
    ``other[orow]`` (if ``orow >= 0``) by the same factor.  The chord is |force| (the
    arc integral of i's force is the chord turned by 90 degrees, pointing away from j)."""
    fx = pair[tid, 0]
    fy = pair[tid, 1]
    chord = math.sqrt(fx * fx + fy * fy)
    if chord > 0.0:
        coef = pair_coef(i, j, -fx / chord, -fy / chord, a, b, geo, R0, coef, kfloor)
    lam = contact_factor(chord, coef)
    for k in range(dst.shape[1]):
        dst[row, k] += lam * pair[tid, k]
    if orow >= 0:
        for k in range(dst.shape[1]):
            other[orow, k] *= lam


# ----------------------------------------------------------------------------- contact-jacobi
#: Columns of the per-pair record ``pinfo`` of the contact-jacobi integrator.
J_LAM, J_UX, J_UY, J_DEPTH, J_UOWN, J_DLAM = range(6)
J_COLS = 6


@njit(inline="always", **NJIT)
def radial_rate(i, ux, uy, w, X1, X2, row, oa, ob, usum, scale, a, b, geo, R0):
    """dR/dt of cell i's contour in the fixed lab direction (ux, uy) for the rotation
    rate ``w`` and the mode rates ``scale (X1[row, oa + m] - a_m usum / (2 a0))`` (and
    the same with ``X2``, ``ob``, ``b_m``): the shape modes, the area-keeping a0, and the
    turn of the body frame under the fixed direction (-w R')."""
    c1, s1 = body_angle(i, ux, uy, geo)
    cn = c1
    sn = s1
    a0 = geo[i, 0]
    r1 = 0.0
    rdot = 0.0
    a0dot = 0.0
    for m in range(a.shape[1]):
        cn, sn = cn * c1 - sn * s1, sn * c1 + cn * s1  # n = m + 2
        n = m + 2.0
        dam = scale * (X1[row, oa + m] - a[i, m] / (2.0 * a0) * usum)
        dbm = scale * (X2[row, ob + m] - b[i, m] / (2.0 * a0) * usum)
        r1 += n * (b[i, m] * cn - a[i, m] * sn)
        rdot += dam * cn + dbm * sn
        a0dot += a[i, m] * dam + b[i, m] * dbm
    return R0 * (rdot - a0dot / (2.0 * a0) - w * r1)


@njit(inline="always", **NJIT)
def share_depth_rate(i, j, ux, uy, si, ri, sj, rj, a, b, geo, R0, mu_theta, mu_shape):
    """Rate of change of the overlap depth of the pair (i, j) along (ux, uy) (from i
    towards j) caused by the pair's own integrals ``si[ri]`` on i and ``sj[rj]`` on j
    (layout of ``acc``: force, torque, R, R cos n phi, R sin n phi); negative."""
    M1 = a.shape[1]
    sc = -mu_shape * R0
    u = (si[ri, 0] - sj[rj, 0]) * ux + (si[ri, 1] - sj[rj, 1]) * uy
    u += radial_rate(i, ux, uy, mu_theta * si[ri, 2], si, si, ri, 4, 4 + M1, si[ri, 3], sc, a, b, geo, R0)
    u += radial_rate(j, -ux, -uy, mu_theta * sj[rj, 2], sj, sj, rj, 4, 4 + M1, sj[rj, 3], sc, a, b, geo, R0)
    return u


@njit(inline="always", **NJIT)
def rates_depth_rate(i, j, ux, uy, dpos, dth, da, db, a, b, geo, R0):
    """Rate of change of the overlap depth of the pair (i, j) along (ux, uy) under the
    cells' current rates."""
    u = (dpos[i, 0] - dpos[j, 0]) * ux + (dpos[i, 1] - dpos[j, 1]) * uy
    u += radial_rate(i, ux, uy, dth[i], da, db, i, 0, 0, 0.0, 1.0, a, b, geo, R0)
    u += radial_rate(j, -ux, -uy, dth[j], da, db, j, 0, 0, 0.0, 1.0, a, b, geo, R0)
    return u


@njit(inline="always", **NJIT)
def jacobi_factor(depth, u_own, u_other, dt, lam_max):
    """Factor λ of one contact's integrals in the implicit step of its depth,
    λ² δ = δ + dt u_other + dt u_own λ (the end-of-step force λ L = c sqrt(δ')), capped at
    ``lam_max``; 0 where the other forces open the contact within the step."""
    rhs = depth + dt * u_other
    if rhs <= 0.0:
        return 0.0
    A = -dt * u_own
    if A < 0.0:
        A = 0.0
    lam = 2.0 * rhs / (A + math.sqrt(A * A + 4.0 * depth * rhs))  # the positive root, no cancellation
    return min(lam, lam_max)


@njit(inline="always", **NJIT)
def record_arc_pair(i, j, e, tid, pbuf, pairbuf, ownbuf, pinfo, acc, a, b, geo, R0, mu_theta, mu_shape, kfloor):
    """Keep the unscaled integrals of list pair ``e`` (i's from ``pbuf[tid]``, j's in
    ``pairbuf[e]``), its contact direction, depth δ = L² κ / 8 and own depth rate in
    ``pinfo[e]``, and add i's share to ``acc[i]``: the sweeps start from the explicit
    forces (factor 1; 0 for a pair without contact)."""
    fx = pbuf[tid, 0]
    fy = pbuf[tid, 1]
    L = math.sqrt(fx * fx + fy * fy)
    pinfo[e, J_DEPTH] = 0.0
    pinfo[e, J_DLAM] = 0.0
    if L <= 0.0:
        pinfo[e, J_LAM] = 0.0
        return
    ux = -fx / L
    uy = -fy / L
    kap = max((curvature(i, ux, uy, a, b, geo, R0) + curvature(j, -ux, -uy, a, b, geo, R0)) * R0, kfloor) / R0
    u_own = share_depth_rate(i, j, ux, uy, pbuf, tid, pairbuf, e, a, b, geo, R0, mu_theta, mu_shape)
    pinfo[e, J_LAM] = 1.0
    pinfo[e, J_UX] = ux
    pinfo[e, J_UY] = uy
    pinfo[e, J_DEPTH] = L * L * kap / 8.0
    pinfo[e, J_UOWN] = u_own
    for k in range(acc.shape[1]):
        ownbuf[e, k] = pbuf[tid, k]
        acc[i, k] += pbuf[tid, k]


@njit(inline="always", **NJIT)
def add_share_rates(i, f, s, r, a, b, geo, R0, mu_theta, mu_shape, dpos, dth, da, db):
    """Add ``f`` times the rates of the integrals ``s[r]`` (layout of ``acc``) to cell i."""
    M1 = a.shape[1]
    a0 = geo[i, 0]
    dpos[i, 0] += f * s[r, 0]
    dpos[i, 1] += f * s[r, 1]
    dth[i] += f * mu_theta * s[r, 2]
    us = s[r, 3]
    for m in range(M1):
        da[i, m] -= f * mu_shape * R0 * (s[r, 4 + m] - a[i, m] / (2.0 * a0) * us)
        db[i, m] -= f * mu_shape * R0 * (s[r, 4 + M1 + m] - b[i, m] / (2.0 * a0) * us)
