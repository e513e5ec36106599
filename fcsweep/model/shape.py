"""Cell shape of the Fourier contour model (pure numpy, readable).

A cell is the polar curve, measured from its polarity angle theta_i,

    R(phi)  = R0 [ a0 + sum_{n=2..M} ( a_n cos n phi + b_n sin n phi ) ]
    a0      = sqrt( 1 - 1/2 sum_n (a_n^2 + b_n^2) )

so that its area is exactly pi R0^2.  Mode arrays follow one convention throughout the
package: ``a[..., k]`` and ``b[..., k]`` hold mode ``n = k + 2``; M = width + 1.

Admissibility (no self-crossing, R > 0):  s = sum_n sqrt(a_n^2 + b_n^2) < sqrt(2/3).
"""

from __future__ import annotations

import math

import numpy as np

#: Upper bound of the admissible sum of mode amplitudes, sqrt(2/3).
ADMISSIBLE_BOUND = float(np.sqrt(2.0 / 3.0))
#: Shapes whose amplitude sum exceeds this fraction of the bound are scaled back to it.
PROJECTION_MARGIN = 0.99
#: Vertex-model shape-index threshold q* separating round from elongated cells.
Q_STAR = 3.81
#: Shape index of a circle, 2 sqrt(pi).
Q_CIRCLE = float(2.0 * np.sqrt(np.pi))


def mode_numbers(n_modes_width: int) -> np.ndarray:
    """Mode numbers n = 2..M for mode arrays of width ``M - 1``."""
    return np.arange(2, n_modes_width + 2)


def a0_of(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Zeroth mode that keeps the cell area at pi R0^2.

    Parameters
    ----------
    a, b : ndarray, shape (..., M-1)

    Returns
    -------
    ndarray, shape (...)
        ``sqrt(1 - 0.5 * sum(a^2 + b^2))``.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.sqrt(1.0 - 0.5 * np.sum(a * a + b * b, axis=-1))


def radius(phi: np.ndarray, a: np.ndarray, b: np.ndarray, R0: float = 1.0) -> np.ndarray:
    """Contour radius R(phi) and its derivative R'(phi).

    Parameters
    ----------
    phi : ndarray, shape (K,)
        Body angles.
    a, b : ndarray, shape (N, M-1) or (M-1,)

    Returns
    -------
    R, dR : ndarray, shape (N, K) (or (K,) for a single cell)
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    phi = np.asarray(phi, dtype=float)
    n = mode_numbers(a.shape[-1])
    cos_n = np.cos(np.multiply.outer(n, phi))  # (M-1, K)
    sin_n = np.sin(np.multiply.outer(n, phi))
    a0 = a0_of(a, b)
    R = R0 * (np.asarray(a0)[..., None] + _mode_sum(a, cos_n) + _mode_sum(b, sin_n))
    dR = R0 * (_mode_sum(b * n, cos_n) - _mode_sum(a * n, sin_n))
    return R, dR


def _mode_sum(c: np.ndarray, table: np.ndarray) -> np.ndarray:
    """``c @ table`` over the few modes, without BLAS: for these thin products a BLAS call
    starts its thread pool, which costs far more than the sums (2-10x under load)."""
    return np.einsum("...k,kp->...p", c, table)


def perimeter(a: np.ndarray, b: np.ndarray, R0: float = 1.0, points: int = 2048) -> np.ndarray:
    """Perimeter P = int_0^{2pi} sqrt(R^2 + R'^2) dphi.

    The trapezoidal rule on a periodic smooth integrand converges spectrally, so the
    default 2048 points are exact to round-off for admissible shapes with M <= 16.

    Parameters
    ----------
    a, b : ndarray, shape (N, M-1) or (M-1,)
    points : int
        Quadrature points.
    """
    phi = 2.0 * np.pi * np.arange(points) / points
    R, dR = radius(phi, a, b, R0)
    return np.sqrt(R * R + dR * dR).sum(axis=-1) * (2.0 * np.pi / points)


def shape_index(a: np.ndarray, b: np.ndarray, R0: float = 1.0, points: int = 2048) -> np.ndarray:
    """Shape index q = P / sqrt(pi R0^2); a circle has q = 2 sqrt(pi) ~ 3.545."""
    return perimeter(a, b, R0, points) / (np.sqrt(np.pi) * R0)


def perimeter_gradient(a: np.ndarray, b: np.ndarray, R0: float = 1.0, points: int = 256):
    """Gradient of the perimeter with respect to the modes, dP/da_n and dP/db_n.

    ``dP/da_n = int (R dR/da_n + R' dR'/da_n) / sqrt(R^2 + R'^2) dphi`` with
    ``dR/da_n = R0 (cos n phi - a_n/(2 a0))`` and ``dR'/da_n = -n R0 sin n phi``
    (and likewise for b_n), evaluated with the periodic trapezoidal rule.

    Returns
    -------
    dPda, dPdb : ndarray, shape like ``a``
    """
    a = np.atleast_2d(np.asarray(a, dtype=float))
    b = np.atleast_2d(np.asarray(b, dtype=float))
    phi = 2.0 * np.pi * np.arange(points) / points
    n = mode_numbers(a.shape[-1])
    cos_n = np.cos(np.multiply.outer(n, phi))
    sin_n = np.sin(np.multiply.outer(n, phi))
    R, dR = radius(phi, a, b, R0)
    inv_s = 1.0 / np.sqrt(R * R + dR * dR)  # (N, K)
    a0 = a0_of(a, b)[:, None]
    w = 2.0 * np.pi / points
    # int R * R0 cos(n phi) / s  and the a-dependent constant part
    Rs = R * inv_s
    dRs = dR * inv_s
    dPda = R0 * w * (Rs @ cos_n.T - (a / (2 * a0)) * Rs.sum(-1)[:, None] - n * (dRs @ sin_n.T))
    dPdb = R0 * w * (Rs @ sin_n.T - (b / (2 * a0)) * Rs.sum(-1)[:, None] + n * (dRs @ cos_n.T))
    return dPda, dPdb


def amplitude_sum(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """s = sum_n sqrt(a_n^2 + b_n^2), the quantity bounded by admissibility."""
    return np.sqrt(np.asarray(a) ** 2 + np.asarray(b) ** 2).sum(axis=-1)


def is_admissible(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """True where ``sum_n sqrt(a_n^2 + b_n^2) < sqrt(2/3)``."""
    return amplitude_sum(a, b) < ADMISSIBLE_BOUND


def project_admissible(a: np.ndarray, b: np.ndarray, margin: float = PROJECTION_MARGIN):
    """Scale the modes of cells beyond ``margin * sqrt(2/3)`` back onto it.

    Parameters
    ----------
    a, b : ndarray, shape (N, M-1)
    margin : float
        Target fraction of the admissibility bound, in (0, 1).

    Returns
    -------
    a, b : ndarray
        Projected copies.
    projected : ndarray of bool, shape (N,)
        Which cells were scaled.
    """
    a = np.array(a, dtype=float, copy=True)
    b = np.array(b, dtype=float, copy=True)
    s = amplitude_sum(a, b)
    bad = s > margin * ADMISSIBLE_BOUND
    if np.any(bad):
        f = (margin * ADMISSIBLE_BOUND) / s[bad]
        a[bad] *= f[:, None]
        b[bad] *= f[:, None]
    return a, b, bad


def bounding_radius(a: np.ndarray, b: np.ndarray, R0: float = 1.0) -> np.ndarray:
    """Rigorous upper bound of R(phi): R0 (a0 + sum_n |c_n|)."""
    return R0 * (a0_of(a, b) + amplitude_sum(a, b))


def inner_radius(a: np.ndarray, b: np.ndarray, R0: float = 1.0) -> np.ndarray:
    """Rigorous lower bound of R(phi): R0 (a0 - sum_n |c_n|), positive when admissible."""
    return R0 * (a0_of(a, b) - amplitude_sum(a, b))


def tension_rate(n: int, eta: float, mu_shape: float = 1.0, R0: float = 1.0) -> float:
    """Relaxation rate of shape mode n of a round cell under membrane tension alone.

    Near the circle the perimeter is P = 2 pi R0 [1 + sum_n (n^2 - 1)(a_n^2 + b_n^2) / 4]
    to second order, so da_n/dt = -mu_shape eta dP/da_n = -lambda_n a_n with
    lambda_n = pi mu_shape eta R0 (n^2 - 1).
    """
    return float(np.pi * mu_shape * eta * R0 * (n * n - 1))


def max_stable_dt(eta: float, modes: int, mu_shape: float = 1.0, R0: float = 1.0) -> float:
    """Largest time step allowed by the tension relaxation of the stiffest shape mode M:
    dt <= 1.5 / lambda_M (:func:`tension_rate`).

    The explicit (Euler) step multiplies that mode by 1 - dt lambda_M: beyond
    dt = 2 / lambda_M it grows every step and, kept finite only by the admissibility
    projection, gives wrong shapes without any non-finite value.  At 1.5 / lambda_M it
    still halves every step (with a sign flip), which leaves a margin for the extra
    stiffness of overlaps; away from the circle the tension stiffness only decreases, and
    the response to slowly varying forces (the fixed point of the step) does not depend
    on dt.  Valid for K > 2M contour points (:func:`contour_points_problem`): fewer alias
    mode M and make the sampled tension stiffer.  ``inf`` for rigid discs (modes = 0) or
    no tension.
    """
    rate = _stiffest_rate(eta, modes, mu_shape, R0)
    return float("inf") if rate <= 0.0 else 1.5 / rate


def _stiffest_rate(eta, modes, mu_shape, R0) -> float:
    """lambda_M of the highest mode, 0 for rigid discs (no shape modes)."""
    return tension_rate(modes, eta, mu_shape, R0) if modes >= 2 else 0.0


def _round_down(x: float, digits: int = 3) -> str:
    """``x`` to ``digits`` significant digits, rounded towards zero (a bound to quote)."""
    if not 0.0 < x < float("inf"):
        return f"{x:g}"
    q = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return f"{math.floor(x / q * (1 + 1e-12)) * q:.{digits}g}"


def dt_problem(dt, eta, modes, mu_shape=1.0, R0=1.0) -> str:
    """Why ``dt`` is too large for the membrane tension (:func:`max_stable_dt`), or ""
    if it is not."""
    rate = _stiffest_rate(eta, modes, mu_shape, R0)
    if dt * rate <= 1.5:
        return ""
    if not math.isfinite(rate):
        return f"eta = {eta:g}, mu_shape = {mu_shape:g}, R0 = {R0:g} make the tension rate overflow; no dt is stable"
    return (f"dt = {dt:g} is too large for eta = {eta:g} (modes = {modes}, mu_shape = {mu_shape:g}, R0 = {R0:g}): "
            f"the explicit step multiplies shape mode {modes} by 1 - dt lambda with lambda = "
            f"pi mu_shape eta R0 (M^2 - 1) = {rate:.4g} per unit time, which amplifies it above dt = "
            f"{2.0 / rate:.3g}; allowed: 0 < dt <= {_round_down(1.5 / rate)} (1.5 / lambda)")


def contour_points_problem(contour_points: int, modes: int) -> str:
    """Why K contour points cannot carry M modes (K <= 2M aliases mode M), or ""."""
    if modes < 2 or contour_points > 2 * modes:
        return ""
    return (f"contour_points = {contour_points} cannot resolve modes = {modes}: K <= 2M aliases the highest "
            f"mode (its sampled tension is stiffer and dt limits no longer hold); allowed: contour_points >= "
            f"{2 * modes + 1}")


#: Largest step length v0 dt as a fraction of the contour spacing 2 pi R0 / K ...
MAX_STEP_PER_SPACING = 0.5
#: ... and in units of R0 whatever K (rigid discs have no contour).
MAX_STEP_PER_R0 = 0.1
#: Largest D_r dt: the discrete walk has D = D0 (D_r dt / 2) coth(D_r dt / 2) = D0 (1 + (D_r dt)^2/12 + ...).
MAX_DR_DT = 0.1


def step_problem(v0, dt, R0, contour_points, modes, key: str = "v0") -> str:
    """Why a step moves a cell too far ("" if it does not): ``v0 dt`` must stay within
    ``min(MAX_STEP_PER_SPACING * 2 pi R0 / K, MAX_STEP_PER_R0 * R0)`` (the contour term only
    for ``modes >= 2``; ``R0`` the smallest cell's radius): contacts are sampled on the
    contour points, and a cell that jumps a large part of their spacing per step overshoots
    its neighbours' contours.  ``key`` names v0 in the message (``grid.v0`` in a config)."""
    limit, what = MAX_STEP_PER_R0 * R0, f"{MAX_STEP_PER_R0:g} R0"
    if modes >= 2 and MAX_STEP_PER_SPACING * 2 * math.pi * R0 / contour_points < limit:
        limit = MAX_STEP_PER_SPACING * 2 * math.pi * R0 / contour_points
        what = f"half the contour spacing 2 pi R0/K with contour_points = {contour_points}"
    if v0 * dt <= limit:
        return ""
    return (f"{key} = {v0:g} with dt = {dt:g} (R0 = {R0:g}) moves a cell v0*dt = {v0 * dt:.3g} per step; "
            f"allowed v0*dt <= {limit:.4g} ({what}): lower dt or v0")


def turn_problem(Dr, dt, key: str = "Dr") -> str:
    """Why a step turns the polarity too far ("" if it does not): ``D_r dt <= MAX_DR_DT``;
    beyond it the polarity decorrelates within a few steps and the discrete walk's D0
    deviates by (D_r dt)^2 / 12 from v0^2 / (2 D_r)."""
    if Dr * dt <= MAX_DR_DT:
        return ""
    return (f"{key} = {Dr:g} with dt = {dt:g} gives Dr*dt = {Dr * dt:.3g}; allowed Dr*dt <= {MAX_DR_DT:g} "
            "(beyond it the discrete walk no longer has D0 = v0^2/(2 Dr)): lower dt or Dr")
