"""Per-contact implicit factor of the ``contact-implicit`` integrator (numba kernels).

The math is in :mod:`fcsweep.model.integrators`: every integral of a pair is scaled by
λ = 1 / (x + sqrt(1 + x²)), x = coef / L, L the pair's chord.  ``coef = 0`` (Euler)
is never passed here: the Euler path does not call these functions, so its arithmetic
is unchanged to the bit.
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


@njit(inline="always", **NJIT)
def scale_point_pair(i, W, saved, tid, R, coef):
    """Scale the point weights that one pair added to ``W[i]`` (``saved[tid]`` holds the
    row before the pair) by the factor of the pair's inside contour length Σ ΔW R dφ."""
    K = R.shape[1]
    n = W.shape[1]
    dphi = 2.0 * math.pi / K
    length = 0.0
    for k in range(n):
        d = W[i, k] - saved[tid, k]
        if d != 0.0:
            length += d * R[i, k % K]
    lam = contact_factor(length * dphi, coef)
    for k in range(n):
        d = W[i, k] - saved[tid, k]
        if d != 0.0:
            W[i, k] = saved[tid, k] + lam * d


@njit(inline="always", **NJIT)
def add_scaled_arc_pair(tid, pair, dst, row, other, orow, coef):
    """Add the resolving cell's integrals ``pair[tid]`` scaled by the pair's factor to
    ``dst[row]``, and scale the other cell's share ``other[orow]`` (if ``orow >= 0``) by
    the same factor.  The chord is |force| (the arc integral of the force is the chord
    turned by 90 degrees)."""
    chord = math.sqrt(pair[tid, 0] * pair[tid, 0] + pair[tid, 1] * pair[tid, 1])
    lam = contact_factor(chord, coef)
    for k in range(dst.shape[1]):
        dst[row, k] += lam * pair[tid, k]
    if orow >= 0:
        for k in range(dst.shape[1]):
            other[orow, k] *= lam
