"""Fourier sums of the cell contour for M <= 6, as straight-line code (numba).

The paper's M = 6 needs only modes 2..6; writing them out lets LLVM keep everything in
registers and vectorise loops across contour points.  Kernels fall back to generic
loops for M > 6.
"""

from __future__ import annotations


from .options import NJIT, njit


@njit(inline="always", **NJIT)
def multiples6(c, s):
    """cos n psi and sin n psi for n = 2..6 from c = cos psi, s = sin psi, by exact
    multiple-angle products: returns (c2, c3, c4, c5, c6, s2, s3, s4, s5, s6)."""
    c2 = c * c - s * s
    s2 = 2.0 * c * s
    c3 = c2 * c - s2 * s
    s3 = s2 * c + c2 * s
    c4 = c2 * c2 - s2 * s2
    s4 = 2.0 * c2 * s2
    c5 = c4 * c - s4 * s
    s5 = s4 * c + c4 * s
    c6 = c3 * c3 - s3 * s3
    s6 = 2.0 * c3 * s3
    return c2, c3, c4, c5, c6, s2, s3, s4, s5, s6


@njit(inline="always", **NJIT)
def modes6(a, b, j):
    """The modes n = 2..6 of cell j as ten scalars, zero beyond the array width."""
    M1 = a.shape[1]
    a2 = a[j, 0] if M1 > 0 else 0.0
    a3 = a[j, 1] if M1 > 1 else 0.0
    a4 = a[j, 2] if M1 > 2 else 0.0
    a5 = a[j, 3] if M1 > 3 else 0.0
    a6 = a[j, 4] if M1 > 4 else 0.0
    b2 = b[j, 0] if M1 > 0 else 0.0
    b3 = b[j, 1] if M1 > 1 else 0.0
    b4 = b[j, 2] if M1 > 2 else 0.0
    b5 = b[j, 3] if M1 > 3 else 0.0
    b6 = b[j, 4] if M1 > 4 else 0.0
    return a2, a3, a4, a5, a6, b2, b3, b4, b5, b6


@njit(inline="always", **NJIT)
def series6(c2, c3, c4, c5, c6, s2, s3, s4, s5, s6, a2, a3, a4, a5, a6, b2, b3, b4, b5, b6):
    """sum_n (a_n cos n psi + b_n sin n psi) and its psi-derivative for n = 2..6 from the
    multiple-angle values of :func:`multiples6`."""
    # summed as a tree, not left to right: a short dependency chain without letting the
    # compiler reassociate (see fcsweep.kernels.options)
    r = ((a2 * c2 + b2 * s2) + (a3 * c3 + b3 * s3)) + ((a4 * c4 + b4 * s4) + (a5 * c5 + b5 * s5)) \
        + (a6 * c6 + b6 * s6)
    dr = ((2.0 * (b2 * c2 - a2 * s2) + 3.0 * (b3 * c3 - a3 * s3)) + (4.0 * (b4 * c4 - a4 * s4)
                                                                      + 5.0 * (b5 * c5 - a5 * s5))) \
        + 6.0 * (b6 * c6 - a6 * s6)
    return r, dr


@njit(inline="always", **NJIT)
def fourier6(c, s, a2, a3, a4, a5, a6, b2, b3, b4, b5, b6):
    """sum_n (a_n cos n psi + b_n sin n psi) and its psi-derivative for n = 2..6,
    from c = cos psi and s = sin psi (no trig calls).  Straight-line code, so that loops
    calling it vectorise across points."""
    c2, c3, c4, c5, c6, s2, s3, s4, s5, s6 = multiples6(c, s)
    return series6(c2, c3, c4, c5, c6, s2, s3, s4, s5, s6, a2, a3, a4, a5, a6, b2, b3, b4, b5, b6)


@njit(inline="always", **NJIT)
def fourier_series(c, s, a, b, j):
    """sum_n (a_n cos n psi + b_n sin n psi) of cell j and its psi-derivative, for any
    number of modes (:func:`fourier6` for M <= 6, else the multiple-angle recurrence)."""
    M1 = a.shape[1]
    if M1 <= 5:
        a2, a3, a4, a5, a6, b2, b3, b4, b5, b6 = modes6(a, b, j)
        return fourier6(c, s, a2, a3, a4, a5, a6, b2, b3, b4, b5, b6)
    cn = c
    sn = s
    r = 0.0
    dr = 0.0
    for m in range(M1):
        t = cn * c - sn * s
        sn = sn * c + cn * s
        cn = t
        r += a[j, m] * cn + b[j, m] * sn
        dr += (m + 2.0) * (b[j, m] * cn - a[j, m] * sn)
    return r, dr
