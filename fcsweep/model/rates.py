"""Deterministic rates of the Fourier contour cell model: the readable numpy twin.

This module writes out docs/model.md's equations of motion directly, one pair of cells at a
time, with no cell list and no angular windows.  It is the reference the numba kernels
in :mod:`fcsweep.kernels` are tested against, and the function notebooks call.

Equations (docs/model.md), with ``o_ik`` the overlap weight of contour point k of cell i:

    dr_i/dt   = v0 e(theta_i) + sum_k o_ik [ R'_k e_perp(theta_i+phi_k) - R_k e(theta_i+phi_k) ] dphi
    dtheta_i  = mu_theta sum_k o_ik R_k R'_k dphi
    da_n/dt   = -mu_shape [ sum_k o_ik R_k dR/da_n(phi_k) dphi + eta dP/da_n ]
    db_n/dt   = -mu_shape [ sum_k o_ik R_k dR/db_n(phi_k) dphi + eta dP/db_n ]

With a core exponent p (energy sum_{i<j} A_ij^p + eta sum_i P_i) every pair's overlap
terms are multiplied by dA^p/dA = p A_ij^(p-1); the arc rule and rigid discs implement
it (the point rules have no pair area), the area from :mod:`.overlap_exact`.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from .discs import per_cell_radii, core_factor, disc_rates
from .integrators import core_exponent_problem
from .shape import a0_of, amplitude_sum, mode_numbers, radius

#: Quadrature rules for the overlap weights.
QUADRATURES = ("binary", "linear", "arc")
#: Above this many cells :func:`rates` warns that it is a slow reference.
SLOW_ABOVE_N = 256


def _images(box):
    """Periodic image shifts that can matter for a pair (all 3x3 shifts, or none)."""
    if box is None:
        return np.zeros((1, 2))
    Lx, Ly = float(box[0]), float(box[1])
    return np.array([(sx * Lx, sy * Ly) for sx, sy in itertools.product((-1, 0, 1), repeat=2)])


def radial_gap(points, pos_j, theta_j, a_j, b_j, R0=1.0):
    """Radial gap g = R_j(psi) - |x - r_j| of points x relative to cell j (> 0 inside).

    Parameters
    ----------
    points : ndarray, shape (..., 2)
        Points in the same frame as ``pos_j`` (no periodic wrapping is applied).
    pos_j : ndarray, shape (2,)
    theta_j : float
    a_j, b_j : ndarray, shape (M-1,)

    Returns
    -------
    ndarray, shape (...)
    """
    d = np.asarray(points, dtype=float) - np.asarray(pos_j, dtype=float)
    dist = np.hypot(d[..., 0], d[..., 1])
    psi = np.arctan2(d[..., 1], d[..., 0]) - theta_j
    n = mode_numbers(len(a_j))
    Rj = R0 * (a0_of(a_j, b_j) + np.cos(np.multiply.outer(psi, n)) @ a_j + np.sin(np.multiply.outer(psi, n)) @ b_j)
    return Rj - dist


def _segment_weights_linear(g):
    """Linear-gap weights: inside fraction of the half segments each point owns.

    ``g`` has shape (..., K) and is periodic along the last axis.  On each segment
    [k, k+1] g is interpolated linearly; point k owns the half next to it.
    """
    g0 = g
    g1 = np.roll(g, -1, axis=-1)
    in0 = g0 > 0
    in1 = g1 > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(in0 != in1, g0 / (g0 - g1), 0.0)  # root position in [0, 1]
    # inside length (in units of the segment) in the first half [0, 1/2] and second half
    out_in = ~in0 & in1
    in_out = in0 & ~in1
    first = np.select([in0 & in1, in_out, out_in], [0.5, np.minimum(t, 0.5), np.maximum(0.0, 0.5 - t)], 0.0)
    second = np.select([in0 & in1, in_out, out_in], [0.5, np.maximum(0.0, t - 0.5), np.minimum(0.5, 1.0 - t)], 0.0)
    return first + np.roll(second, 1, axis=-1)


def occupancy(pos, theta, a, b, *, box=None, R0=1.0, contour_points=40, quadrature="binary", radii=None):
    """Overlap weight o_ik of every contour point, summed over neighbours j != i.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    theta : ndarray, shape (N,)
    a, b : ndarray, shape (N, M-1)
    box : (Lx, Ly) or None
        Periodic box; ``None`` for open boundaries.
    quadrature : {"binary", "linear"}
        ``binary``: o_ik counts the neighbours whose interior holds the point (paper).
        (The arc rule has no point weights; see :func:`arc_integrals`.)
        ``linear``: each point is weighted by the inside fraction of the half segments
        on either side of it, from linear interpolation of the radial gap.
    radii : ndarray, shape (N,), optional
        Per-cell radii R0,i (cell size differences); ``R0`` for every cell if omitted.

    Returns
    -------
    ndarray, shape (N, K)
    """
    if quadrature not in ("binary", "linear"):
        raise ValueError(f"occupancy() supports 'binary' and 'linear'; got {quadrature!r}")
    pos = np.asarray(pos, dtype=float)
    theta = np.asarray(theta, dtype=float)
    a = np.asarray(a, dtype=float).reshape(len(pos), -1)
    b = np.asarray(b, dtype=float).reshape(len(pos), -1)
    N, K = len(pos), int(contour_points)
    phi = 2.0 * np.pi * np.arange(K) / K
    Rc = per_cell_radii(N, R0, radii)
    R, _ = radius(phi, a, b, R0 if radii is None else Rc[:, None])
    lab = theta[:, None] + phi[None, :]
    pts = np.stack([R * np.cos(lab), R * np.sin(lab)], axis=-1)  # (N, K, 2) relative to r_i
    Rb = Rc * (a0_of(a, b) + amplitude_sum(a, b))
    o = np.zeros((N, K))
    for i in range(N):
        for j in range(N):
            if i == j:
                continue
            for shift in _images(box):
                rij = pos[j] + shift - pos[i]
                if np.hypot(*rij) >= Rb[i] + Rb[j]:
                    continue
                g = radial_gap(pts[i], rij, theta[j], a[j], b[j], Rc[j])
                o[i] += (g > 0) if quadrature == "binary" else _segment_weights_linear(g)
    return o


def rates_from_occupancy(o, theta, a, b, *, eta, v0, R0=1.0, mu_theta=1.0, mu_shape=1.0, arcs=None, radii=None):
    """Deterministic rates from given contour weights ``o`` (N, K); see module docstring.

    The perimeter gradient is evaluated on the same K contour points.  ``arcs``
    (N, 4 + 2(M-1)), if given, adds overlap integrals computed on exact arcs (the arc
    rule): [force x, force y, torque, int R, int R cos n phi, int R sin n phi].
    ``radii`` (N,), if given, are the per-cell R0,i.
    """
    theta = np.asarray(theta, dtype=float)
    N, K = o.shape
    dphi = 2.0 * np.pi / K
    phi = dphi * np.arange(K)
    if radii is not None:
        R0 = np.asarray(radii, dtype=float).reshape(N, 1)
    R, dR = radius(phi, a, b, R0)
    lab = theta[:, None] + phi[None, :]
    e = np.stack([np.cos(lab), np.sin(lab)], axis=-1)
    e_perp = np.stack([-np.sin(lab), np.cos(lab)], axis=-1)
    f = (dR[..., None] * e_perp - R[..., None] * e) * o[..., None]
    dpos = v0 * np.stack([np.cos(theta), np.sin(theta)], axis=-1) + f.sum(axis=1) * dphi
    dtheta = mu_theta * (o * R * dR).sum(axis=1) * dphi

    n = mode_numbers(a.shape[1])
    cos_n = np.cos(np.multiply.outer(n, phi))  # (M-1, K)
    sin_n = np.sin(np.multiply.outer(n, phi))
    a0 = a0_of(a, b)[:, None]
    s = np.sqrt(R * R + dR * dR)
    # dR/da_n = R0 (cos n phi - a_n/(2 a0)),  dR'/da_n = -n R0 sin n phi
    u = o * R + eta * R / s
    v = eta * dR / s
    uc, us, usum = dphi * (u @ cos_n.T), dphi * (u @ sin_n.T), dphi * u.sum(axis=1)[:, None]
    if arcs is not None:
        M1 = a.shape[1]
        dpos = dpos + arcs[:, 0:2]
        dtheta = dtheta + mu_theta * arcs[:, 2]
        usum = usum + arcs[:, 3:4]
        uc = uc + arcs[:, 4:4 + M1]
        us = us + arcs[:, 4 + M1:4 + 2 * M1]
    da = -mu_shape * R0 * (uc - a / (2 * a0) * usum - n * dphi * (v @ sin_n.T))
    db = -mu_shape * R0 * (us - b / (2 * a0) * usum + n * dphi * (v @ cos_n.T))
    return {"dpos": dpos, "dtheta": dtheta, "da": da, "db": db}


#: Contact-arc rule: a Newton step on the true gap below this (in units of the segment)
#: ends the root iteration.
ROOT_STEP = 1e-4
#: Contact-arc rule: Hermite cubics farther than this from zero (R0 units at K = 40,
#: scaled by (40/K)^4 like the interpolation error) are trusted without evaluating the
#: true gap; nearer ones are confirmed on it.
DIP_MARGIN = 2e-3


def _hermite(t, g0, g1, m0, m1):
    """Cubic Hermite interpolant on [0, 1] (slopes scaled by the segment length)."""
    return ((2 * t**3 - 3 * t**2 + 1) * g0 + (t**3 - 2 * t**2 + t) * m0 + (-2 * t**3 + 3 * t**2) * g1
            + (t**3 - t**2) * m1)


def _cubic_roots(g0, g1, m0, m1, lo, hi):
    """Real roots of the Hermite cubic in (lo, hi), ascending."""
    c3 = 2 * g0 + m0 - 2 * g1 + m1
    c2 = -3 * g0 - 2 * m0 + 3 * g1 - m1
    roots = np.roots([c3, c2, m0, g0]) if abs(c3) + abs(c2) + abs(m0) > 0 else np.array([])
    return sorted(r.real for r in roots if abs(r.imag) < 1e-9 and lo < r.real < hi)


def _cubic_extremum(g0, g1, m0, m1, inside):
    """Stationary point of the Hermite cubic in (0, 1) nearest the other side of zero
    (its smallest value if ``inside`` else its largest), or None."""
    c3 = 2 * g0 + m0 - 2 * g1 + m1
    c2 = -3 * g0 - 2 * m0 + 3 * g1 - m1
    ts = [r.real for r in np.roots([3 * c3, 2 * c2, m0]) if abs(r.imag) < 1e-12 and 0.0 < r.real < 1.0] \
        if abs(c3) + abs(c2) > 0 else []
    if not ts:
        return None
    vals = [_hermite(t, g0, g1, m0, m1) for t in ts]
    k = int(np.argmin(vals) if inside else np.argmax(vals))
    return ts[k], vals[k]


class _Contour:
    """Cell i's contour and the gap to one neighbour j, evaluated anywhere on the contour."""

    def __init__(self, theta_i, a_i, b_i, rij, theta_j, a_j, b_j, R0, R0j=None):
        self.ti, self.ai, self.bi, self.rij = theta_i, a_i, b_i, rij
        self.tj, self.aj, self.bj, self.R0 = theta_j, a_j, b_j, R0
        self.R0j = R0 if R0j is None else R0j

    def point(self, phi):
        """Contour point x(phi) - r_i, its tangent dx/dphi, R and R'."""
        R, dR = radius(np.atleast_1d(phi), self.ai, self.bi, self.R0)
        lab = self.ti + np.atleast_1d(phi)
        e = np.stack([np.cos(lab), np.sin(lab)], axis=-1)
        ep = np.stack([-np.sin(lab), np.cos(lab)], axis=-1)
        return R[:, None] * e, dR[:, None] * e + R[:, None] * ep, R, dR

    def gap(self, phi):
        """Radial gap g = R_j(psi) - |d| and dg/dphi at contour angles ``phi``, with the
        contour point, tangent, R and R' there."""
        x, tan, R, dR = self.point(phi)
        d = x - self.rij
        dist = np.hypot(d[:, 0], d[:, 1])
        Rj, dRj = radius(np.arctan2(d[:, 1], d[:, 0]) - self.tj, self.aj, self.bj, self.R0j)
        dpsi = (d[:, 0] * tan[:, 1] - d[:, 1] * tan[:, 0]) / dist**2
        return Rj - dist, dRj * dpsi - (d * tan).sum(axis=1) / dist, x, tan, R, dR

    def root(self, phi_k, h, t, tl, tr, left_inside):
        """Crossing of the contour with j's in phi_k + h [tl, tr] (gap > 0 at tl iff
        ``left_inside``): bracketed Newton from t.  Returns (t, x, R) there."""
        for _ in range(60):
            g, dg, x, tan, R, dR = self.gap(phi_k + h * t)
            if (g[0] > 0) == left_inside:
                tl = t
            else:
                tr = t
            tn = t - g[0] / (h * dg[0]) if dg[0] != 0 else 0.5 * (tl + tr)
            if not tl <= tn <= tr:
                tn = 0.5 * (tl + tr)
            step = tn - t
            if abs(step) < ROOT_STEP or tr - tl < ROOT_STEP:
                return tn, x[0] + step * h * tan[0], R[0] + step * h * dR[0]
            t = tn
        return t, x[0], R[0]


def _arc_pieces(c, phi_k, h, g0, g1, m0, m1, end0, end1, eps):
    """Inside pieces [(t1, x1, R1, t2, x2, R2)] of the segment phi_k + h [0, 1] of the
    contour ``c`` relative to its neighbour, and the crossings [(x, kind)] among their
    ends (kind +1 where the contour enters the neighbour, -1 where it leaves); see
    :func:`arc_integrals`."""
    in0, in1 = g0 > 0, g1 > 0
    if in0 != in1:
        t0 = _cubic_roots(g0, g1, m0, m1, 0.0, 1.0)
        t, x, R = c.root(phi_k, h, t0[0] if t0 else 0.5, 0.0, 1.0, in0)
        if in0:
            return [(0.0, *end0, t, x, R)], [(x, -1)]
        return [(t, x, R, 1.0, *end1)], [(x, 1)]
    full = [(0.0, *end0, 1.0, *end1)] if in0 else []
    A, B = m0 - (g1 - g0), m1 - (g1 - g0)
    if in0 and min(g0, g1) - 0.25 * max(-A, B, 0.0) > eps:
        return full, []
    if not in0 and max(g0, g1) + 0.25 * max(A, -B, 0.0) <= -eps:
        return full, []
    ext = _cubic_extremum(g0, g1, m0, m1, in0)
    if ext is None or (ext[1] >= eps if in0 else ext[1] <= -eps):
        return full, []
    tc, pc = ext
    gc = c.gap(phi_k + h * tc)[0][0]
    if (gc > 0) == in0:
        return full, []
    if (pc > 0) != in0:
        sa = _cubic_roots(g0, g1, m0, m1, 0.0, tc)[-1]
        sb = _cubic_roots(g0, g1, m0, m1, tc, 1.0)[0]
    else:
        sa = tc * g0 / (g0 - gc)
        sb = tc + (1.0 - tc) * gc / (gc - g1)
    ta, xa, Ra = c.root(phi_k, h, sa, 0.0, tc, in0)
    tb, xb, Rb = c.root(phi_k, h, sb, tc, 1.0, not in0)
    if in0:
        return [(0.0, *end0, ta, xa, Ra), (tb, xb, Rb, 1.0, *end1)], [(xa, -1), (xb, 1)]
    return [(ta, xa, Ra, tb, xb, Rb)], [(xa, 1), (xb, -1)]


def _shape_sums(phi, w, a, b, R0):
    """Gauss sums [R, R cos n phi, R sin n phi] of one cell over nodes ``phi`` (weights ``w``)."""
    n = mode_numbers(a.shape[0])
    Rg, _ = radius(phi, a, b, R0)
    return np.concatenate([[np.sum(w * Rg)], np.cos(np.multiply.outer(n, phi)) @ (w * Rg),
                           np.sin(np.multiply.outer(n, phi)) @ (w * Rg)])


def _other_side(crossings, rij, theta_j, a_j, b_j, h, R0):
    """Cell j's arc integrals [torque, shape sums] over its arcs inside i, from the
    crossings found on i's contour (positions relative to r_i): each arc runs
    counter-clockwise from a crossing where i's contour leaves j to the next crossing
    along j's contour; panels no longer than h, two Gauss points each."""
    d = np.array([x - rij for x, _ in crossings])
    psi = np.arctan2(d[:, 1], d[:, 0]) - theta_j
    half_r2 = 0.5 * np.sum(d * d, axis=1)
    out = np.zeros(1 + 1 + 2 * a_j.shape[0])
    for c, (_, kind) in enumerate(crossings):
        if kind > 0 or len(crossings) < 2:
            continue
        gaps = np.mod(psi - psi[c], 2 * np.pi)
        gaps[c] = np.inf
        gaps[gaps <= 0] = 2 * np.pi
        e = int(np.argmin(gaps))
        span = gaps[e]
        out[0] += half_r2[e] - half_r2[c]
        n = max(1, int(np.ceil(span / h)))
        w = span / n
        mids = psi[c] + (np.arange(n) + 0.5) * w
        nodes = (mids[:, None] + np.array([-1.0, 1.0]) * w * 0.5 / np.sqrt(3.0)).ravel()
        out[1:] += _shape_sums(nodes, 0.5 * w, a_j, b_j, R0)
    return out


def _owner(i, j, shift):
    """True for one of the two instances (i, j, shift), (j, i, -shift) of a pair."""
    return i < j or (i == j and (shift[0] > 0 or (shift[0] == 0 and shift[1] > 0)))


def arc_integrals(pos, theta, a, b, *, box=None, R0=1.0, contour_points=40, core_exponent=1.0, radii=None):
    """Overlap integrals of the contact-arc rule, the numpy twin of :mod:`fcsweep.kernels.arcs`.

    Each pair is resolved once, on the contour of cell i (i < j).  For every contour
    segment of i the radial gap g to j and its derivative dg/dphi = R_j'(psi) dpsi/dphi
    - d.t/|d| (t = dx_i/dphi) at the two ends define a cubic Hermite interpolant.  It
    locates the crossings of the two contours (solved on the true gap by bracketed
    Newton) and shallow contacts between sample points (confirmed on the true gap at the
    cubic's extremum).  On each inside piece the force and torque integrals are exact
    end-point differences (the chord turned by 90 degrees; R^2/2), the shape integrals
    two-point Gauss-Legendre.  Cell j gets minus i's force, and its torque and shape
    integrals over its own arcs between the same crossings (:func:`_other_side`).
    With ``core_exponent`` p != 1 both cells' integrals of a pair are multiplied by
    p A^(p-1), A the pair's exact overlap area (:func:`.overlap_exact.overlap_areas`;
    one radius only).  ``radii`` (N,) are per-cell R0,i.
    Returns (N, 4 + 2(M-1)) as in :func:`rates_from_occupancy`.
    """
    from .overlap_exact import overlap_areas

    if core_exponent != 1.0 and radii is not None:
        raise NotImplementedError("the twin's exact overlap (overlap_exact) has one radius: core_exponent != 1 "
                                  "with per-cell radii is not referenced here")
    N, M1 = a.shape
    K = int(contour_points)
    h = 2.0 * np.pi / K
    eps = DIP_MARGIN * R0 * (40.0 / K) ** 4
    phi = h * np.arange(K + 1)
    Rc = per_cell_radii(N, R0, radii)
    Rb = Rc * (a0_of(a, b) + amplitude_sum(a, b))
    out = np.zeros((N, 4 + 2 * M1))
    nodes = 0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0)
    for i in range(N):
        for j in range(i, N):
            for shift in _images(box):
                if not _owner(i, j, shift):
                    continue
                rij = pos[j] + shift - pos[i]
                if np.hypot(*rij) >= Rb[i] + Rb[j]:
                    continue
                c = _Contour(theta[i], a[i], b[i], rij, theta[j], a[j], b[j], Rc[i], Rc[j])
                g, dg, x, _, R, _ = c.gap(phi)
                slope = h * dg
                own = np.zeros(4 + 2 * M1)
                crossings = []
                for k in range(K):
                    pieces, cross = _arc_pieces(c, phi[k], h, g[k], g[k + 1], slope[k], slope[k + 1],
                                                (x[k], R[k]), (x[k + 1], R[k + 1]), eps)
                    crossings += cross
                    for t1, x1, R1, t2, x2, R2 in pieces:
                        own[0] -= x2[1] - x1[1]
                        own[1] += x2[0] - x1[0]
                        own[2] += 0.5 * (R2 * R2 - R1 * R1)
                        ph = phi[k] + h * (t1 + (t2 - t1) * nodes)
                        own[3:] += _shape_sums(ph, 0.5 * (t2 - t1) * h, a[i], b[i], Rc[i])
                other = np.zeros(4 + 2 * M1)
                other[0:2] = -own[0:2]
                if crossings:
                    other[2:] = _other_side(crossings, rij, theta[j], a[j], b[j], h, Rc[j])
                f = 1.0
                if core_exponent != 1.0 and (own.any() or other.any()):
                    area = overlap_areas(rij[None, :], theta[i], a[i], b[i], theta[j], a[j], b[j], R0=R0)[0]
                    f = core_factor(area, core_exponent)
                out[i] += f * own if f != 1.0 else own
                out[j] += f * other if f != 1.0 else other
    return out


def rates(pos, theta, a, b, *, eta, v0, box=None, R0=1.0, contour_points=40, quadrature="arc",
          mu_theta=1.0, mu_shape=1.0, core_exponent=1.0, radii=None):
    """Deterministic time derivatives of docs/model.md (no noise).

    Parameters
    ----------
    pos : array_like, shape (N, 2)
        Cell centres (polar origins r_i).
    theta : array_like, shape (N,)
        Polarity angles.
    a, b : array_like, shape (N, M-1)
        Shape modes; column k holds mode n = k + 2.  M is inferred from the width.
    eta, v0 : float
        Membrane tension and self-propulsion speed.
    box : (Lx, Ly) or None
        Periodic box (minimum image and, for tiny boxes, every image in range), or
        ``None`` for open boundaries.
    R0 : float
        Radius of the circle of equal area.
    contour_points : int
        K, contour quadrature points.
    quadrature : {"binary", "linear", "arc"}
        Overlap rule; ``"binary"`` is the paper's.
    mu_theta, mu_shape : float
        Mobilities of theta and of the shape modes.
    core_exponent : float
        p of the overlap energy sum A_ij^p (1: the paper's); p != 1 needs the arc rule
        or rigid discs (ValueError otherwise).
    radii : array_like, shape (N,), optional
        Per-cell radii R0,i (cell size differences: each cell's shape and area pi R0,i^2
        are those of its own radius); ``R0`` for every cell if omitted.

    Returns
    -------
    dict
        ``"dpos"`` (N, 2) including ``v0 e(theta)``, ``"dtheta"`` (N,),
        ``"da"`` and ``"db"`` (N, M-1).  With zero-width mode arrays (``modes = 0``)
        the cells are rigid discs with the exact lens force (:func:`disc_rates`).

    Warns
    -----
    UserWarning
        For more than :data:`SLOW_ABOVE_N` cells: this reference loops over all pairs in
        Python (tens of seconds at N = 1024); ``fcsweep.kernels.api.kernel_rates`` is the
        fast equivalent.
    """
    pos = np.asarray(pos, dtype=float).reshape(-1, 2)
    N = len(pos)
    if N > SLOW_ABOVE_N:
        warnings.warn(f"fcsweep.model.rates is the slow numpy reference (all pairs in Python); N = {N} takes "
                      "seconds to minutes: use fcsweep.kernels.api.kernel_rates for large N",
                      UserWarning, stacklevel=2)
    theta = np.asarray(theta, dtype=float).reshape(N)
    a = np.asarray(a, dtype=float).reshape(N, -1)
    b = np.asarray(b, dtype=float).reshape(N, -1)
    if quadrature not in QUADRATURES:
        raise ValueError(f"quadrature must be one of {QUADRATURES}; got {quadrature!r}")
    if a.shape[1] == 0:
        return disc_rates(pos, theta, v0=v0, box=box, R0=R0, core_exponent=core_exponent, radii=radii)
    problem = core_exponent_problem(core_exponent, quadrature, a.shape[1] + 1, "euler")
    if problem:
        raise ValueError(problem)
    if quadrature == "arc":
        arcs = arc_integrals(pos, theta, a, b, box=box, R0=R0, contour_points=contour_points,
                             core_exponent=core_exponent, radii=radii)
        return rates_from_occupancy(np.zeros((N, int(contour_points))), theta, a, b, eta=eta, v0=v0, R0=R0,
                                    mu_theta=mu_theta, mu_shape=mu_shape, arcs=arcs, radii=radii)
    o = occupancy(pos, theta, a, b, box=box, R0=R0, contour_points=contour_points, quadrature=quadrature,
                  radii=radii)
    return rates_from_occupancy(o, theta, a, b, eta=eta, v0=v0, R0=R0, mu_theta=mu_theta, mu_shape=mu_shape,
                                radii=radii)
