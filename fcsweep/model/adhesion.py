"""Adhesion between cell contours: the energy and its rates, the readable numpy twin.

Each contour point of cell i that lies inside cell j, or outside it within the range
delta, adheres to j (docs/model.md, "Adhesion").  With the radial gap of a point x to
cell j, h = |x - r_j| - R_j(psi) (psi the body angle of x seen from r_j; h < 0 inside),
and a smooth step w(h) that is 1 for h <= 0, 0 for h >= delta and
w = (1 - u)^2 (1 + 2u), u = h/delta, in between (w and w' continuous), the energy is::

    E_adh = -gamma sum_i sum_{j != i} sum_k w(h_ij(phi_k)) s_i(phi_k) dphi,
    s_i(phi) = sqrt(R_i^2 + R_i'^2)      (the arc length element of contour i)

gamma (``adhesion``) is an energy per contour length, in the units of the tension eta;
delta = ``adhesion_range`` R0.  A flat adhered contact of length l between two cells
lowers the energy by 2 gamma l (each contour counts it), against a tension cost
2 eta l for the same stretch of both perimeters.

The rates are minus the gradient of E_adh (mobility 1 for the centres, mu_theta and
mu_shape for theta and the modes), in two parts for every ordered neighbour pair:

A. cell i's contour near j, through the points x_ik (r_i, theta_i, a_i) and their
   arc length elements (a_i);
B. cell j's contour near i, through the gap h_ji = |y - r_i| - R_i(psi) of j's points
   y (r_i, theta_i and a_i enter R_i(psi)).

With g = e_rho - (R'(psi) / rho) e_psi the gradient of h in the point (e_rho, e_psi
the polar unit vectors of the point seen from the other centre)::

    dr_i/dt     += gamma dphi [ sum_A w' s g            - sum_B w' s g ]
    dtheta_i/dt += mu_theta gamma dphi [ sum_A w' s g . R_i e_perp + sum_B w' s R_i'(psi) ]
    da_n/dt     += mu_shape gamma dphi [ sum_A ( (w' s g . e + w R/s) dR/da_n + (w R'/s) dR'/da_n )
                                        - sum_B w' s dR/da_n(psi) ]

with dR/da_n = R0 (cos n phi - a_n / (2 a0)), dR'/da_n = -n R0 sin n phi (b_n likewise).
Rigid discs (no modes) get the centre rates only.  A cell does not adhere to its own
periodic image.  The numba kernel is :mod:`fcsweep.kernels.adhesion`.
"""

from __future__ import annotations

import numpy as np

from .shape import a0_of, amplitude_sum, mode_numbers, radius

__all__ = ["smooth_step", "adhesion_energy", "adhesion_rates"]


def smooth_step(h, delta):
    """Adhesion weight w(h) and its derivative dw/dh.

    Parameters
    ----------
    h : ndarray
        Radial gaps (< 0 inside the other cell).
    delta : float
        Range (> 0).

    Returns
    -------
    w, dw : ndarray
        1 for h <= 0, 0 for h >= delta, (1 - u)^2 (1 + 2u) with u = h/delta between;
        dw = -6 u (1 - u) / delta there, 0 elsewhere.
    """
    u = np.clip(np.asarray(h, dtype=float) / delta, 0.0, 1.0)
    return (1.0 - u) ** 2 * (1.0 + 2.0 * u), -6.0 * u * (1.0 - u) / delta


def _series(psi, a, b, R0):
    """R(psi), R'(psi), cos n psi, sin n psi of one cell at arbitrary body angles."""
    n = mode_numbers(len(a))
    cn = np.cos(np.multiply.outer(psi, n))
    sn = np.sin(np.multiply.outer(psi, n))
    R = R0 * (a0_of(a, b) + cn @ a + sn @ b)
    dR = R0 * (cn @ (n * b) - sn @ (n * a))
    return R, dR, cn, sn


def _gap(points, centre, theta, a, b, R0):
    """Gap h = |x - r| - R(psi) of points to a cell, with its gradient in x, and what the
    cell's own derivatives need."""
    d = points - centre
    rho = np.hypot(d[:, 0], d[:, 1])
    alpha = np.arctan2(d[:, 1], d[:, 0])
    R, dR, cn, sn = _series(alpha - theta, a, b, R0)
    safe = np.where(rho > 0.0, rho, 1.0)
    er = np.stack([np.cos(alpha), np.sin(alpha)], axis=1)
    ep = np.stack([-np.sin(alpha), np.cos(alpha)], axis=1)
    g = er - (dR / safe)[:, None] * ep
    return rho - R, g, dR, cn, sn


def _contours(theta, a, b, R0, K):
    phi = 2.0 * np.pi * np.arange(K) / K
    if a.shape[1] == 0:
        R = np.full((len(theta), K), R0)
        dR = np.zeros((len(theta), K))
    else:
        R, dR = radius(phi, a, b, R0)
    lab = theta[:, None] + phi[None, :]
    e = np.stack([np.cos(lab), np.sin(lab)], axis=-1)
    eperp = np.stack([-np.sin(lab), np.cos(lab)], axis=-1)
    return phi, R, dR, e, eperp


def _pairs(pos, Rb, box, delta):
    """Ordered pairs (i, j, offset r_j + shift - r_i) within adhesion reach."""
    shifts = [np.zeros(2)] if box is None else [np.array([sx * box[0], sy * box[1]], float)
                                                for sx in (-1, 0, 1) for sy in (-1, 0, 1)]
    for i in range(len(pos)):
        for j in range(len(pos)):
            if i == j:
                continue
            for sh in shifts:
                rij = pos[j] + sh - pos[i]
                if np.hypot(*rij) < Rb[i] + Rb[j] + delta:
                    yield i, j, rij


def _prepare(pos, theta, a, b, R0, K):
    pos = np.asarray(pos, dtype=float).reshape(-1, 2)
    N = len(pos)
    theta = np.asarray(theta, dtype=float).reshape(N)
    a = np.asarray(a, dtype=float).reshape(N, -1)
    b = np.asarray(b, dtype=float).reshape(N, -1)
    Rb = R0 * (a0_of(a, b) + amplitude_sum(a, b))
    return pos, theta, a, b, Rb, _contours(theta, a, b, R0, int(K))


def adhesion_energy(pos, theta, a, b, *, adhesion, adhesion_range, box=None, R0=1.0, contour_points=40):
    """The adhesion energy E_adh on the K contour points (module docstring).

    Parameters
    ----------
    pos, theta, a, b, box, R0, contour_points
        As for :func:`fcsweep.model.rates.rates`.
    adhesion : float
        gamma, energy per adhered contour length (units of eta).
    adhesion_range : float
        delta / R0.

    Returns
    -------
    float
        E_adh (<= 0).
    """
    pos, theta, a, b, Rb, (phi, R, dR, e, _) = _prepare(pos, theta, a, b, R0, contour_points)
    delta = adhesion_range * R0
    dphi = 2.0 * np.pi / len(phi)
    s = np.sqrt(R * R + dR * dR)
    E = 0.0
    for i, j, rij in _pairs(pos, Rb, box, delta):
        h, *_ = _gap(R[i][:, None] * e[i], rij, theta[j], a[j], b[j], R0)
        w, _ = smooth_step(h, delta)
        E -= adhesion * dphi * np.sum(w * s[i])
    return E


def adhesion_rates(pos, theta, a, b, *, adhesion, adhesion_range, box=None, R0=1.0, contour_points=40,
                   mu_theta=1.0, mu_shape=1.0):
    """The rates of the adhesion energy, minus its gradient times the mobilities.

    Parameters
    ----------
    pos, theta, a, b, box, R0, contour_points, mu_theta, mu_shape
        As for :func:`fcsweep.model.rates.rates`.
    adhesion, adhesion_range : float
        As for :func:`adhesion_energy`.

    Returns
    -------
    dict
        ``"dpos"`` (N, 2), ``"dtheta"`` (N,), ``"da"``, ``"db"`` (N, M-1): the adhesion
        terms alone, to be added to the rates of :func:`fcsweep.model.rates.rates`.
    """
    pos, theta, a, b, Rb, (phi, R, dR, e, ep) = _prepare(pos, theta, a, b, R0, contour_points)
    N, M1 = a.shape
    K = len(phi)
    delta = adhesion_range * R0
    dphi = 2.0 * np.pi / K
    s = np.sqrt(R * R + dR * dR)
    n = mode_numbers(M1)
    a0 = a0_of(a, b)
    cphi = np.cos(np.multiply.outer(n, phi))
    sphi = np.sin(np.multiply.outer(n, phi))
    dpos = np.zeros((N, 2))
    dth = np.zeros(N)
    da = np.zeros((N, M1))
    db = np.zeros((N, M1))
    for i, j, rij in _pairs(pos, Rb, box, delta):
        # A: i's points near j
        h, g, _, _, _ = _gap(R[i][:, None] * e[i], rij, theta[j], a[j], b[j], R0)
        w, dw = smooth_step(h, delta)
        ws = dw * s[i]
        dpos[i] += adhesion * dphi * (ws[:, None] * g).sum(axis=0)
        # B: j's points near i
        hb, gb, dRb, cn, sn = _gap(rij + R[j][:, None] * e[j], np.zeros(2), theta[i], a[i], b[i], R0)
        _, dwb = smooth_step(hb, delta)
        wsb = dwb * s[j]
        dpos[i] -= adhesion * dphi * (wsb[:, None] * gb).sum(axis=0)
        if M1 == 0:  # rigid discs: no torque, no shape
            continue
        c = mu_shape * adhesion * dphi * R0
        dth[i] += mu_theta * adhesion * dphi * (np.sum(ws * R[i] * (g * ep[i]).sum(axis=1)) + np.sum(wsb * dRb))
        U = ws * (g * e[i]).sum(axis=1) + w * R[i] / s[i]
        V = w * dR[i] / s[i]
        da[i] += c * (cphi @ U - a[i] / (2 * a0[i]) * U.sum() - n * (sphi @ V))
        db[i] += c * (sphi @ U - b[i] / (2 * a0[i]) * U.sum() + n * (cphi @ V))
        da[i] -= c * (wsb @ cn - a[i] / (2 * a0[i]) * wsb.sum())
        db[i] -= c * (wsb @ sn - b[i] / (2 * a0[i]) * wsb.sum())
    return {"dpos": dpos, "dtheta": dth, "da": da, "db": db}
