"""Overlap integrals of one pair of cells under each quadrature rule (numba kernels).

``pair_weights`` dispatches on the rule code: rigid discs (exact lens), ``binary``
(inside/outside weights of the contour points, the paper's rule), ``linear`` (fraction of
each point's arc inside, from the gaps at its ends) and ``arc`` (exact inside arcs,
:mod:`.arcs`).  Arrays as in :mod:`.geometry`.
"""

from __future__ import annotations

import math


from .arcs import arc_pair, may_touch
from .contacts import contact_factor
from .geometry import LANES, gap_at
from .options import NJIT, njit
from .windows import angular_window, binary_window, window_gaps6, window_gaps_generic

QUAD_BINARY = 0
QUAD_LINEAR = 1
QUAD_ARC = 2
QUADRATURE_CODES = {"binary": QUAD_BINARY, "linear": QUAD_LINEAR, "arc": QUAD_ARC}


@njit(inline="always", **NJIT)
def pair_disc(i, dx, dy, R0, acc, coef):
    """Rigid discs: the exact lens-overlap force, the chord 2 sqrt(R0^2 - D^2/4) along
    the line of centres, pushing i away from j (times the contact-implicit factor when
    ``coef > 0``).  (Equal radii and core exponent 1 only: :func:`pair_disc_ext` does
    the rest; this body is main's, so that its compiled arithmetic stays the same bit for
    bit under the ``contract`` fast-math flag.)"""
    D = math.sqrt(dx * dx + dy * dy)
    if D < 2.0 * R0 and D > 0.0:
        chord = 2.0 * math.sqrt(R0 * R0 - 0.25 * D * D)
        if coef > 0.0:
            chord *= contact_factor(chord, coef)
        acc[i, 0] -= chord * dx / D
        acc[i, 1] -= chord * dy / D


@njit(**NJIT)
def pair_disc_ext(i, dx, dy, Ri, Rj, acc, core):
    """Rigid discs of radii Ri, Rj (cell size differences) and/or a core exponent: the
    chord of their lens, 2 sqrt(Ri^2 - x^2) with x = (D^2 + Ri^2 - Rj^2) / (2 D) the
    distance from r_i to the chord, times core A^(core - 1) (A the lens area)."""
    D = math.sqrt(dx * dx + dy * dy)
    if D >= Ri + Rj or D <= abs(Ri - Rj):
        return
    x = (D * D + Ri * Ri - Rj * Rj) / (2.0 * D)
    hc = math.sqrt(max(Ri * Ri - x * x, 0.0))
    chord = 2.0 * hc
    if core != 1.0:
        area = Ri * Ri * math.acos(min(x / Ri, 1.0)) + Rj * Rj * math.acos(min((D - x) / Rj, 1.0)) - D * hc
        chord *= core * area ** (core - 1.0)
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
def pair_arc(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid, own, orow, other, xrow,
             core):
    """Contact-arc rule for the pair (i, j), resolved on i's contour: i's arc integrals
    into ``own[orow]`` and j's into ``other[xrow]`` (see :func:`.arcs.arc_pair`).
    Returns the overlap area when ``core != 1`` (else 0)."""
    k0, nseg = gap_window(i, j, dx, dy, True, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid)
    if may_touch(nseg, cphi.shape[0], R0, tb, tid):
        return arc_pair(i, j, dx, dy, k0, nseg, a, b, geo, R, px, py, R0, cphi, sphi, tb, tid, own, orow, other,
                        xrow, core)
    return 0.0


@njit(**NJIT)
def pair_arc_call(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid, own, orow, other, xrow,
                  core):
    """:func:`pair_arc` as a called function, for the all-image path (small or open
    boxes): each inlined copy of the rule costs about a minute of compilation."""
    return pair_arc(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, tb, tid, own, orow, other, xrow,
                    core)


@njit(inline="always", **NJIT)
def pair_weights(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, quad, W, tb, tid, acc, coef,
                 core):
    """Add the overlap of cell j onto cell i with a point-weight rule, or rigid discs.

    ``(dx, dy)`` is r_j - r_i for the image of j being considered.  Binary and linear
    rules add per-point weights to ``W[i]``; rigid discs add the lens force to
    ``acc[i]`` (with the contact-implicit factor when ``coef > 0``; the point rules
    are scaled by the caller).  ``tb[tid]`` is this thread's scratch.  One small function per rule,
    so that each compiles (and vectorises) on its own.  (The arc rule treats each pair
    once, for both cells: :func:`pair_arc`.)
    """
    if a.shape[1] == 0:
        if core == 1.0 and geo[i, 5] == R0 and geo[j, 5] == R0:
            pair_disc(i, dx, dy, R0, acc, coef)  # main's path, R0 from the parameter vector
        else:  # per-cell radii or a core exponent (never with a contact integrator)
            pair_disc_ext(i, dx, dy, geo[i, 5], geo[j, 5], acc, core)
    elif quad == QUAD_BINARY:
        pair_binary(i, j, dx, dy, a, b, geo, px, py, R0, W)
    else:
        pair_linear(i, j, dx, dy, a, b, geo, R, dR, px, py, tx, ty, cphi, sphi, R0, W, tb, tid)
