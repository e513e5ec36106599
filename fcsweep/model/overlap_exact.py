"""Converged reference for overlap areas, energy and deterministic rates (pure numpy).

This module is an *independent* reference for the fast kernels: it shares nothing with
them but :mod:`fcsweep.model.shape` (``a0_of``, ``perimeter``, ``bounding_radius``).

Overlap area of two cells (Green's theorem, exact integrals)
------------------------------------------------------------
Cells are star-shaped about their polar origins r_i.  The boundary of i ∩ j is the part
of contour i inside j plus the part of contour j inside i, both run counter-clockwise, so
with the origin at r_i

    A = 1/2 [ ∫_{i in j} R_i(φ)^2 dφ  +  ∫_{j in i} R_j(ψ)^2 dψ  +  Σ_arcs d × (x_j(end) − x_j(start)) ]

with d = r_j − r_i (minimum image) and x_j(ψ) = R_j(ψ) e(θ_j + ψ) (because
∫ d × dx = d × Δx along any arc).  R^2 is a trigonometric polynomial of degree 2M, so
its antiderivative is evaluated in closed form: no quadrature error at all.  The only
numerical step is locating where a contour enters and leaves the other cell: the radial
gap g(φ) = R_j(ψ(φ)) − |x_i(φ) − r_j| (> 0 inside) is sampled at ``resolution``
points, sign changes are bisected to ~1e-15 in φ, and near-zero local extrema of the
sampled gap are refined (golden section) so that shallow contacts whose chord is shorter
than the sample spacing are not missed.  An error δφ in a crossing changes A only at
second order (the two contours meet there), so areas are exact to round-off.

Energy and rates
----------------
``exact_energy`` = Σ_{i<j} A(i∩j) + η Σ_i P_i.  ``reference_rates`` differentiates it by
a 4-point central stencil (error O(h^4)) per cell variable, holding the area fixed
(a0 re-derived from the modes), and returns the deterministic rates of docs/model.md:
dr_i/dt = v0 e(θ_i) − ∂H/∂r_i, dθ_i/dt = −μθ ∂H/∂θ_i, da_n/dt = −μs ∂H/∂a_n, likewise b_n.
"""

from __future__ import annotations

import math

import numpy as np

from fcsweep.model.shape import a0_of, bounding_radius, perimeter

__all__ = [
    "overlap_area",
    "overlap_areas",
    "inside_arcs",
    "exact_energy",
    "reference_rates",
    "minimum_image",
    "candidate_pairs",
    "continuum_rates",
]

_CHUNK_POINTS = 1 << 21  # grid points per vectorised chunk (memory ~ 100 MB peak)


# ----------------------------------------------------------------------------- helpers
def minimum_image(d: np.ndarray, box) -> np.ndarray:
    """Minimum-image displacement(s) ``d`` (shape (..., 2)) in a periodic box or None."""
    d = np.asarray(d, dtype=float)
    if box is None:
        return d
    L = np.asarray(box, dtype=float)
    return d - L * np.round(d / L)


def _radius_u(u: np.ndarray, a0: np.ndarray, C: np.ndarray) -> np.ndarray:
    """R/R0 at unit complex numbers u = e^{iφ}; C[..., k] = a_n − i b_n, n = k + 2.

    u has shape (B, P) (or (P,) with B-free parameters); a0 (B,), C (B, M-1).
    Horner: Σ_n C_n u^n = u^2 (C_2 + u (C_3 + ...)).
    """
    m = C.shape[-1]
    shape = np.broadcast_shapes(u.shape, a0[..., None].shape)
    if m == 0:
        return np.broadcast_to(a0[..., None], shape).astype(float)
    p = np.broadcast_to(C[..., m - 1, None], shape).astype(complex)
    for k in range(m - 2, -1, -1):
        p = p * u + C[..., k, None]
    p = p * (u * u)
    return a0[..., None] + p.real


def _square_coeffs(a0: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Fourier coefficients s_k, k = 0..2M, of (R/R0)^2 = Σ_{k=-2M}^{2M} s_k e^{ikφ}."""
    B, m = C.shape
    M = m + 1
    c = np.zeros((B, 2 * M + 1), dtype=complex)  # index k + M, k = -M..M
    c[:, M] = a0
    c[:, M + 2:] = 0.5 * C
    c[:, :M - 1] = np.conj(0.5 * C[:, ::-1])
    s = np.zeros((B, 4 * M + 1), dtype=complex)  # index k + 2M
    for p in range(2 * M + 1):
        s[:, p:p + 2 * M + 1] += c[:, p, None] * c
    return s[:, 2 * M:]


def _antiderivative(phi: np.ndarray, s: np.ndarray) -> np.ndarray:
    """F(φ) = ∫_0^φ (R/R0)^2 with coefficients ``s`` (rows already gathered per φ)."""
    K2 = s.shape[-1] - 1
    u = np.exp(1j * phi)
    powers = np.cumprod(np.broadcast_to(u[:, None], (u.size, K2)), axis=1)
    k = np.arange(1, K2 + 1)
    osc = 2.0 * np.real(np.sum(s[:, 1:] * (powers - 1.0) / (1j * k), axis=1))
    return s[:, 0].real * phi + osc


class _Side:
    """Parameters of the 'self' contour and the 'other' cell for one direction, per pair."""

    def __init__(self, D, th_s, a_s, b_s, th_o, a_o, b_o):
        self.Dc = D[:, 0] + 1j * D[:, 1]  # other centre − self centre
        self.eth_s = np.exp(1j * th_s)
        self.eth_o_conj = np.exp(-1j * th_o)
        self.a0_s = a0_of(a_s, b_s)
        self.a0_o = a0_of(a_o, b_o)
        self.C_s = a_s - 1j * b_s
        self.C_o = a_o - 1j * b_o

    def take(self, idx):
        new = object.__new__(_Side)
        for name, val in self.__dict__.items():
            setattr(new, name, val[idx])
        return new

    def gap_grid(self, u_grid, R0, sl):
        """g on the common grid for pairs ``sl`` (B, K)."""
        Rs = R0 * _radius_u(u_grid[None, :], self.a0_s[sl], self.C_s[sl])
        z = Rs * (self.eth_s[sl, None] * u_grid[None, :])
        return self._gap_from_z(z, R0, sl)

    def _gap_from_z(self, z, R0, sl):
        w = z - self.Dc[sl, None]
        r = np.abs(w)
        with np.errstate(invalid="ignore", divide="ignore"):
            uo = (w / r) * self.eth_o_conj[sl, None]
        uo = np.where(r > 0, uo, 1.0)
        return R0 * _radius_u(uo, self.a0_o[sl], self.C_o[sl]) - r

    def gap_at(self, phi, R0, idx):
        """g at one angle per entry, for pairs ``idx`` (flat)."""
        u = np.exp(1j * phi)[:, None]
        Rs = R0 * _radius_u(u, self.a0_s[idx], self.C_s[idx])
        z = Rs * (self.eth_s[idx, None] * u)
        return self._gap_from_z(z, R0, idx)[:, 0]

    def z_at(self, phi, R0, idx):
        u = np.exp(1j * phi)[:, None]
        Rs = R0 * _radius_u(u, self.a0_s[idx], self.C_s[idx])[:, 0]
        return Rs * self.eth_s[idx] * u[:, 0]


def _bisect(side, R0, idx, lo, hi, inside_lo, tol=1e-15):
    """Vectorised bisection of the inside/outside switch in [lo, hi]."""
    lo = lo.copy()
    hi = hi.copy()
    width = float(np.max(hi - lo)) if lo.size else 0.0
    n_iter = max(1, int(math.ceil(math.log2(max(width, tol) / tol))))
    for _ in range(n_iter):
        mid = 0.5 * (lo + hi)
        same = (side.gap_at(mid, R0, idx) > 0.0) == inside_lo
        lo = np.where(same, mid, lo)
        hi = np.where(same, hi, mid)
    return 0.5 * (lo + hi)


def _golden(side, R0, idx, lo, hi, sign, n_iter=48):
    """Vectorised golden-section search for the max of sign*g on [lo, hi]."""
    gr = (math.sqrt(5.0) - 1.0) / 2.0
    c = hi - gr * (hi - lo)
    d = lo + gr * (hi - lo)
    fc = sign * side.gap_at(c, R0, idx)
    fd = sign * side.gap_at(d, R0, idx)
    for _ in range(n_iter):
        left = fc > fd  # the max lies in [lo, d]
        hi = np.where(left, d, hi)
        lo = np.where(left, lo, c)
        x = np.where(left, hi - gr * (hi - lo), lo + gr * (hi - lo))
        fx = sign * side.gap_at(x, R0, idx)
        c, d = np.where(left, x, d), np.where(left, c, x)
        fc, fd = np.where(left, fx, fd), np.where(left, fc, fx)
    x = 0.5 * (lo + hi)
    return x, side.gap_at(x, R0, idx)


def _inside_integral(side: _Side, O: np.ndarray, R0: float, K: int, *, return_crossings=False,
                     return_coincident=False):
    """I = ∫_{self inside other} (x × dx) with origin offset O (self centre − origin).

    Returns I (B,) and, optionally, crossings (pair index, φ, is_entry) sorted per pair.
    """
    B = side.Dc.size
    if B == 0:
        empty = (np.zeros(0, np.intp), np.zeros(0), np.zeros(0, bool))
        return (np.zeros(0), empty) if return_crossings else (
            (np.zeros(0), np.zeros(0, bool)) if return_coincident else np.zeros(0))
    dphi = 2.0 * np.pi / K
    phi_grid = dphi * np.arange(K)
    u_grid = np.exp(1j * phi_grid)
    tol_ext = 1.0e3 * dphi * dphi * R0
    pair_l, lo_l, hi_l, in_l = [], [], [], []
    inside0 = np.zeros(B, dtype=bool)
    coincident = np.zeros(B, dtype=bool)
    ext_p, ext_k, ext_sign = [], [], []
    step = max(1, _CHUNK_POINTS // K)
    for start in range(0, B, step):
        sl = slice(start, min(B, start + step))
        g = side.gap_grid(u_grid, R0, sl)
        coincident[sl] = np.max(np.abs(g), axis=1) <= 1e-13 * R0
        g[coincident[sl]] = -1.0  # handled by the caller
        ins = g > 0.0
        inside0[sl] = ins[:, 0]
        nxt = np.roll(ins, -1, axis=1)
        p, k = np.nonzero(ins != nxt)
        pair_l.append(p + start)
        lo_l.append(phi_grid[k])
        hi_l.append(phi_grid[k] + dphi)
        in_l.append(ins[p, k])
        # near-zero local extrema of the sampled gap (hidden double crossings)
        gm = np.roll(g, 1, axis=1)
        gp = np.roll(g, -1, axis=1)
        cmax = (g >= gm) & (g > gp) & (g <= 0.0) & (g > -tol_ext)
        cmin = (g <= gm) & (g < gp) & (g > 0.0) & (g < tol_ext)
        for cand, sgn in ((cmax, 1.0), (cmin, -1.0)):
            p, k = np.nonzero(cand)
            ext_p.append(p + start)
            ext_k.append(k)
            ext_sign.append(np.full(p.size, sgn))
    if ext_p:
        ep = np.concatenate(ext_p)
        ek = np.concatenate(ext_k)
        es = np.concatenate(ext_sign)
        if ep.size:
            x, gx = _golden(side, R0, ep, phi_grid[ek] - dphi, phi_grid[ek] + dphi, es)
            hit = (es * gx) > 0.0  # the extremum crosses zero: two hidden crossings
            ep, ek, es, x = ep[hit], ek[hit], es[hit], x[hit]
            out_state = es < 0  # state at the bracket ends: outside for a max, inside for a min
            pair_l += [ep, ep]
            lo_l += [phi_grid[ek] - dphi, x]
            hi_l += [x, phi_grid[ek] + dphi]
            in_l += [out_state, ~out_state]
    pidx = np.concatenate(pair_l).astype(np.intp)
    lo = np.concatenate(lo_l)
    hi = np.concatenate(hi_l)
    in_lo = np.concatenate(in_l).astype(bool)
    root = np.mod(_bisect(side, R0, pidx, lo, hi, in_lo), 2.0 * np.pi)
    is_entry = ~in_lo
    order = np.lexsort((root, pidx))
    pidx, root, is_entry = pidx[order], root[order], is_entry[order]

    # inside at φ = 0: from the first crossing of each pair, else from the sample at 0
    wrap = inside0.copy()
    if pidx.size:
        first = np.ones(pidx.size, dtype=bool)
        first[1:] = pidx[1:] != pidx[:-1]
        wrap[pidx[first]] = ~is_entry[first]
        counts = np.bincount(pidx, minlength=B)
        if np.any(counts % 2):
            bad = np.flatnonzero(counts % 2)
            raise RuntimeError(f"odd number of contour crossings for pairs {bad[:5]} (tangent contact?)")
    s = _square_coeffs(side.a0_s, side.C_s)  # (B, 2M+1)
    I = wrap * (2.0 * np.pi) * s[:, 0].real * R0 * R0
    if pidx.size:
        F = R0 * R0 * _antiderivative(root, s[pidx])
        zc = side.z_at(root, R0, pidx)
        Oc = O[pidx, 0] + 1j * O[pidx, 1]
        F = F + np.imag(np.conj(Oc) * zc)  # O × z
        sign = np.where(is_entry, -1.0, 1.0)
        I = I + np.bincount(pidx, weights=sign * F, minlength=B)
    if return_crossings:
        return I, (pidx, root, is_entry)
    if return_coincident:
        return I, coincident
    return I


def _as_modes(a, B):
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        a = np.broadcast_to(a, (B, a.size))
    return a


def overlap_areas(d, theta_i, a_i, b_i, theta_j, a_j, b_j, *, R0=1.0, resolution=4096):
    """Exact overlap areas of many pairs of cells (vectorised).

    Parameters
    ----------
    d : ndarray, shape (B, 2)
        Centre displacements ``r_j − r_i`` (already minimum-imaged).
    theta_i, theta_j : ndarray, shape (B,)
    a_i, b_i, a_j, b_j : ndarray, shape (B, M-1)
    R0 : float
    resolution : int
        Sample points per contour used to locate crossings (the integrals are exact).

    Returns
    -------
    ndarray, shape (B,)
        Areas A(i ∩ j).
    """
    d = np.atleast_2d(np.asarray(d, dtype=float))
    B = d.shape[0]
    th_i = np.broadcast_to(np.asarray(theta_i, dtype=float), (B,))
    th_j = np.broadcast_to(np.asarray(theta_j, dtype=float), (B,))
    a_i, b_i, a_j, b_j = (_as_modes(x, B) for x in (a_i, b_i, a_j, b_j))
    # pairs that cannot touch: skip
    dist = np.hypot(d[:, 0], d[:, 1])
    near = dist < (bounding_radius(a_i, b_i, R0) + bounding_radius(a_j, b_j, R0)) * (1 + 1e-12)
    out = np.zeros(B)
    if not np.any(near):
        return out
    idx = np.flatnonzero(near)
    D = d[idx]
    side_i = _Side(D, th_i[idx], a_i[idx], b_i[idx], th_j[idx], a_j[idx], b_j[idx])
    side_j = _Side(-D, th_j[idx], a_j[idx], b_j[idx], th_i[idx], a_i[idx], b_i[idx])
    I_i, same = _inside_integral(side_i, np.zeros_like(D), R0, int(resolution),
                                 return_coincident=True)
    I_j = _inside_integral(side_j, D, R0, int(resolution))
    # coincident contours (gap zero to round-off everywhere): A = π R0²
    out[idx] = np.where(same, np.pi * R0 * R0, 0.5 * (I_i + I_j))
    return out


def overlap_area(pos_i, theta_i, a_i, b_i, pos_j, theta_j, a_j, b_j, *, R0=1.0, box=None,
                 resolution=4096) -> float:
    """Exact (converged) area of the intersection of two Fourier cells.

    Parameters
    ----------
    pos_i, pos_j : array_like, shape (2,)
        Polar origins r_i, r_j.
    theta_i, theta_j : float
        Polarity angles.
    a_i, b_i, a_j, b_j : array_like, shape (M-1,)
        Shape modes n = 2..M (a0 follows from the fixed area π R0²).
    R0 : float
    box : (Lx, Ly) or None
        Periodic box; the minimum image of ``r_j − r_i`` is used.
    resolution : int
        Samples per contour used to locate the crossings; the arc integrals are exact
        (closed-form antiderivative of R²), crossings are bisected to ~1e-15.

    Returns
    -------
    float
        A(i ∩ j), exact to round-off for transversal crossings; 0 without contact.
    """
    d = minimum_image(np.asarray(pos_j, float) - np.asarray(pos_i, float), box)
    return float(overlap_areas(d[None, :], [theta_i], np.atleast_2d(a_i), np.atleast_2d(b_i),
                               [theta_j], np.atleast_2d(a_j), np.atleast_2d(b_j), R0=R0,
                               resolution=resolution)[0])


def inside_arcs(pos_i, theta_i, a_i, b_i, pos_j, theta_j, a_j, b_j, *, R0=1.0, box=None,
                resolution=4096):
    """Body-angle arcs of contour i that lie inside cell j.

    Returns
    -------
    list of (start, end)
        Arcs in body angle φ of cell i, counter-clockwise, ``end > start`` (an arc that
        wraps through φ = 0 ends beyond 2π); ``[(0, 2π)]`` when i lies inside j.
    """
    d = minimum_image(np.asarray(pos_j, float) - np.asarray(pos_i, float), box)[None, :]
    one = lambda x: np.atleast_2d(np.asarray(x, float))  # noqa: E731
    side = _Side(d, np.array([theta_i], float), one(a_i), one(b_i), np.array([theta_j], float),
                 one(a_j), one(b_j))
    _, (p, root, is_entry) = _inside_integral(side, np.zeros_like(d), R0, int(resolution),
                                              return_crossings=True)
    if root.size == 0:
        g0 = side.gap_at(np.array([0.0]), R0, np.array([0]))[0]
        return [(0.0, 2 * np.pi)] if g0 > 0 else []
    if not is_entry[0]:  # starts inside: rotate so the list begins with an entry
        root = np.concatenate([root[1:], root[:1] + 2 * np.pi])
    return [(float(root[k]), float(root[k + 1])) for k in range(0, root.size, 2)]


def _contact_depths(D, th_i, a_i, b_i, th_j, a_j, b_j, R0, K, samples=33):
    """Shallowest contact depth per pair: min over inside arcs of the max radial gap.

    The derivatives of A vary on the scale of this depth (a contact of depth δ has
    A ~ δ^{3/2}), so it caps the finite-difference step.  inf where there is no arc.
    """
    B = D.shape[0]
    depth = np.full(B, np.inf)
    for side in (_Side(D, th_i, a_i, b_i, th_j, a_j, b_j), _Side(-D, th_j, a_j, b_j, th_i, a_i, b_i)):
        _, (p, root, is_entry) = _inside_integral(side, np.zeros_like(D), R0, K,
                                                  return_crossings=True)
        if p.size == 0:
            continue
        first = np.ones(p.size, dtype=bool)
        first[1:] = p[1:] != p[:-1]
        first_idx = np.maximum.accumulate(np.where(first, np.arange(p.size), 0))
        nxt = np.arange(p.size) + 1
        last = np.ones(p.size, dtype=bool)
        last[:-1] = p[1:] != p[:-1]
        nxt[last] = first_idx[last]
        start = root[is_entry]
        end = root[nxt[is_entry]]
        end = np.where(end <= start, end + 2 * np.pi, end)
        pp = p[is_entry]
        t = (np.arange(samples) + 0.5) / samples
        phi = start[:, None] + (end - start)[:, None] * t[None, :]
        g = side.gap_at(phi.ravel(), R0, np.repeat(pp, samples)).reshape(-1, samples)
        np.minimum.at(depth, pp, g.max(axis=1))
    return depth


# ----------------------------------------------------------------------------- energy
def candidate_pairs(pos, a, b, *, R0=1.0, box=None, margin=0.0):
    """Pairs i < j whose bounding circles overlap (brute force, O(N²)).

    Returns
    -------
    i, j : ndarray of int
    d : ndarray, shape (P, 2)
        Minimum-image ``r_j − r_i``.
    """
    pos = np.asarray(pos, dtype=float)
    N = pos.shape[0]
    rb = bounding_radius(a, b, R0)
    i, j = np.triu_indices(N, k=1)
    d = minimum_image(pos[j] - pos[i], box)
    dist = np.hypot(d[:, 0], d[:, 1])
    keep = dist < rb[i] + rb[j] + margin
    return i[keep], j[keep], d[keep]


def exact_energy(pos, theta, a, b, *, eta, R0=1.0, box=None, resolution=2048) -> float:
    """H = Σ_{i<j} A(i∩j) + η Σ_i P_i with exact overlap areas.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    theta : ndarray, shape (N,)
    a, b : ndarray, shape (N, M-1)
    eta : float
        Membrane tension.
    box : (Lx, Ly) or None
    resolution : int
        Crossing-search samples per contour.
    """
    theta = np.asarray(theta, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    i, j, d = candidate_pairs(pos, a, b, R0=R0, box=box)
    A = overlap_areas(d, theta[i], a[i], b[i], theta[j], a[j], b[j], R0=R0,
                      resolution=resolution).sum() if i.size else 0.0
    return float(A + eta * np.sum(perimeter(a, b, R0)))


_STENCIL = ((-2.0, 1.0 / 12.0), (-1.0, -8.0 / 12.0), (1.0, 8.0 / 12.0), (2.0, -1.0 / 12.0))


def reference_rates(pos, theta, a, b, *, eta, v0, box=None, R0=1.0, mu_theta=1.0,
                    mu_shape=1.0, h=1e-4, resolution=1024, shallow_fraction=0.01) -> dict:
    """Deterministic rates of docs/model.md from finite differences of the exact energy.

    Every cell variable v (x, y, θ, a_n, b_n) is perturbed with the 4-point central
    stencil ``[f(−2h) − 8f(−h) + 8f(h) − f(2h)] / 12h`` (truncation O(h⁴)); a0 is
    re-derived from the perturbed modes, so the area stays π R0².  Only the pairs that
    contain the perturbed cell and overlap now are recomputed (A = 0 means A vanishes
    in a neighbourhood, so its gradient is exactly 0); all perturbed pairs are evaluated
    in one vectorised batch.  Shallow contacts: a contact of depth δ (the largest radial
    gap inside its shallowest arc) has A ~ δ^{3/2} and derivatives that vary on the scale
    δ, so each pair uses the step ``min(h, shallow_fraction * δ / R0)``; the absolute
    round-off of such a pair is ~1e-15/step (1e-7 for a contact 1e-6 deep).

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    theta : ndarray, shape (N,)
    a, b : ndarray, shape (N, M-1)
    eta, v0 : float
    box : (Lx, Ly) or None
    R0, mu_theta, mu_shape : float
    h : float
        Finite-difference step (default 1e-4: round-off ~1e-12/h, truncation ~h⁴).
    resolution : int
        Crossing-search samples per contour.
    shallow_fraction : float
        Per-pair step cap relative to the contact depth estimate (see above).

    Returns
    -------
    dict
        ``dpos`` (N, 2), ``dtheta`` (N,), ``da``, ``db`` (N, M-1), and the energy
        gradient pieces ``grad_pos``, ``grad_theta``, ``grad_a``, ``grad_b`` (∂H/∂v).
    """
    pos = np.asarray(pos, dtype=float)
    theta = np.asarray(theta, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    N, m = a.shape
    nvar = 3 + 2 * m
    # pairs in contact now; a pair with A = 0 has zero gradient (A vanishes nearby)
    pi, pj, pd = candidate_pairs(pos, a, b, R0=R0, box=box)
    A0 = overlap_areas(pd, theta[pi], a[pi], b[pi], theta[pj], a[pj], b[pj], R0=R0,
                       resolution=resolution)
    touch = A0 > 0.0
    pi, pj, pd, A0 = pi[touch], pj[touch], pd[touch], A0[touch]
    # ordered pairs (I perturbed, J fixed)
    I = np.concatenate([pi, pj])
    J = np.concatenate([pj, pi])
    Dm = np.concatenate([pd, -pd])  # r_J − r_I
    # the stencil must stay well inside the shallowest contact of each pair
    depth = _contact_depths(pd, theta[pi], a[pi], b[pi], theta[pj], a[pj], b[pj], R0, resolution)
    depth = np.concatenate([depth, depth])
    hp = np.minimum(h, shallow_fraction * depth / R0)
    P = I.size
    grad = np.zeros((N, nvar))
    ns = len(_STENCIL)
    if P:
        # batch layout: (pair, variable, stencil)
        shape = (P, nvar, ns)
        D = np.broadcast_to(Dm[:, None, None, :], shape + (2,)).copy()
        th_i = np.broadcast_to(theta[I][:, None, None], shape).copy()
        a_i = np.broadcast_to(a[I][:, None, None, :], shape + (m,)).copy()
        b_i = np.broadcast_to(b[I][:, None, None, :], shape + (m,)).copy()
        off = np.array([s for s, _ in _STENCIL])[None, :] * hp[:, None]  # (P, ns)
        D[:, 0, :, 0] -= off  # moving r_i by +δ moves r_j − r_i by −δ
        D[:, 1, :, 1] -= off
        th_i[:, 2, :] += off
        for k in range(m):
            a_i[:, 3 + k, :, k] += off
            b_i[:, 3 + m + k, :, k] += off
        A = overlap_areas(D.reshape(-1, 2), th_i.ravel(), a_i.reshape(-1, m), b_i.reshape(-1, m),
                          np.repeat(theta[J], nvar * ns), np.repeat(a[J], nvar * ns, axis=0),
                          np.repeat(b[J], nvar * ns, axis=0), R0=R0,
                          resolution=resolution).reshape(shape)
        w = np.array([c for _, c in _STENCIL])
        dA = (A @ w) / hp[:, None]  # (P, nvar)
        np.add.at(grad, I, dA)
    # perimeter part (only modes)
    if eta != 0.0 and m:
        for k in range(m):
            for which, col in ((0, 3 + k), (1, 3 + m + k)):
                acc = np.zeros(N)
                for s, c in _STENCIL:
                    ap, bp = a.copy(), b.copy()
                    (ap if which == 0 else bp)[:, k] += s * h
                    acc += c * perimeter(ap, bp, R0)
                grad[:, col] += eta * acc / h
    e = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    g_pos = grad[:, 0:2]
    g_th = grad[:, 2]
    g_a = grad[:, 3:3 + m]
    g_b = grad[:, 3 + m:]
    return {
        "dpos": v0 * e - g_pos,
        "dtheta": -mu_theta * g_th,
        "da": -mu_shape * g_a,
        "db": -mu_shape * g_b,
        "grad_pos": g_pos,
        "grad_theta": g_th,
        "grad_a": g_a,
        "grad_b": g_b,
    }


def continuum_rates(pos, theta, a, b, *, eta, v0, box=None, R0=1.0, mu_theta=1.0,
                    mu_shape=1.0, resolution=2048, gauss_points=64) -> dict:
    """docs/model.md's rate integrals evaluated on the exact inside arcs (K → ∞ limit).

    The sums Σ_k o_ik f(φ_k) Δφ of docs/model.md become Σ_j ∫_{arcs of i inside j} f(φ) dφ,
    integrated with Gauss–Legendre (``gauss_points`` per arc, exact for these smooth
    trigonometric integrands of degree ≤ 2M + 1).  ∂P/∂a_n uses
    :func:`fcsweep.model.shape.perimeter_gradient`.  A loop over pairs: for tests and
    small N.  Comparing it with :func:`reference_rates` checks docs/model.md's formulas.

    Returns
    -------
    dict
        ``dpos`` (N, 2), ``dtheta`` (N,), ``da``, ``db`` (N, M-1).
    """
    from fcsweep.model.shape import mode_numbers, perimeter_gradient, radius

    pos = np.asarray(pos, dtype=float)
    theta = np.asarray(theta, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    N, m = a.shape
    n = mode_numbers(m)
    x_gl, w_gl = np.polynomial.legendre.leggauss(gauss_points)
    F = np.zeros((N, 2))
    T = np.zeros(N)
    GA = np.zeros((N, m))
    GB = np.zeros((N, m))
    pi, pj, _ = candidate_pairs(pos, a, b, R0=R0, box=box)
    a0 = a0_of(a, b)
    for i, j in zip(np.concatenate([pi, pj]), np.concatenate([pj, pi])):
        arcs = inside_arcs(pos[i], theta[i], a[i], b[i], pos[j], theta[j], a[j], b[j], R0=R0,
                           box=box, resolution=resolution)
        for s, t in arcs:
            phi = 0.5 * (s + t) + 0.5 * (t - s) * x_gl
            w = 0.5 * (t - s) * w_gl
            R, dR = radius(phi, a[i], b[i], R0)
            lab = theta[i] + phi
            e = np.stack([np.cos(lab), np.sin(lab)], axis=1)
            ep = np.stack([-np.sin(lab), np.cos(lab)], axis=1)
            F[i] += ((dR[:, None] * ep - R[:, None] * e) * w[:, None]).sum(0)
            T[i] += np.sum(R * dR * w)
            cos_n = np.cos(np.multiply.outer(phi, n))
            sin_n = np.sin(np.multiply.outer(phi, n))
            GA[i] += R0 * ((R * w) @ (cos_n - a[i] / (2 * a0[i])))
            GB[i] += R0 * ((R * w) @ (sin_n - b[i] / (2 * a0[i])))
    # 4096 points: the default 256 is off by up to ~1e-2 near the admissibility bound
    dPa, dPb = perimeter_gradient(a, b, R0, points=4096) if m else (GA * 0, GB * 0)
    e = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    return {"dpos": v0 * e + F, "dtheta": mu_theta * T,
            "da": -mu_shape * (GA + eta * dPa), "db": -mu_shape * (GB + eta * dPb)}
