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

from numba import njit

from .options import NJIT


@njit(inline="always", **NJIT)
def contact_factor(chord, coef):
    """λ = 1 / (x + sqrt(1 + x²)) with x = coef / chord; 1 for an empty contact."""
    if chord <= 0.0:
        return 1.0
    x = coef / chord
    return 1.0 / (x + math.sqrt(1.0 + x * x))


@njit(**NJIT)
def curvature(i, ux, uy, a, b, geo, R0):
    """Curvature of cell i's contour in the lab direction (ux, uy) (unit vector):
    (R² + 2R'² − R R'') / (R² + R'²)^(3/2), positive where convex."""
    ct = geo[i, 2]
    st = geo[i, 3]
    c1 = ux * ct + uy * st  # cos and sin of the body-frame angle
    s1 = uy * ct - ux * st
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
