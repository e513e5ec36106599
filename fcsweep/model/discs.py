"""Rigid discs (``modes = 0``) and the core exponent: lens areas and forces (pure numpy).

The overlap of two discs of radii R_i, R_j at distance d is a lens; minus its gradient
with respect to r_i is its chord along (r_i - r_j)/d.  With a core exponent p (energy
sum_{i<j} A_ij^p) every pair's overlap terms are multiplied by p A_ij^(p-1)
(:func:`core_factor`), here and in the contour rules of :mod:`.rates`.
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["core_factor", "lens_area", "lens_chord", "disc_rates"]


def _images(box):
    """Periodic image shifts that can matter for a pair (all 3x3 shifts, or none)."""
    if box is None:
        return np.zeros((1, 2))
    Lx, Ly = float(box[0]), float(box[1])
    return np.array([(sx * Lx, sy * Ly) for sx, sy in itertools.product((-1, 0, 1), repeat=2)])


def per_cell_radii(N, R0, radii):
    """Per-cell radii (N,) from ``radii`` or the one ``R0``."""
    return np.full(N, float(R0)) if radii is None else np.asarray(radii, dtype=float).reshape(N)


def core_factor(area, core_exponent):
    """d(A^p)/dA = p A^(p-1) of a pair's overlap area A (0 without overlap for p > 1)."""
    if core_exponent == 1.0:
        return 1.0
    return core_exponent * area ** (core_exponent - 1.0) if area > 0.0 else 0.0


def lens_area(d, R0=1.0, R1=None):
    """Overlap area of two discs of radii R0 and R1 (default R0) at centre distance d
    (0 for d >= R0 + R1, the smaller disc for d <= |R0 - R1|)."""
    R1 = R0 if R1 is None else R1
    if d >= R0 + R1:
        return 0.0
    if d <= abs(R0 - R1):
        return np.pi * min(R0, R1) ** 2
    if R1 == R0:
        return 2 * R0 * R0 * np.arccos(d / (2 * R0)) - 0.5 * d * np.sqrt(4 * R0 * R0 - d * d)
    x = (d * d + R0 * R0 - R1 * R1) / (2 * d)  # from r_0 to the chord
    return R0 * R0 * np.arccos(x / R0) + R1 * R1 * np.arccos((d - x) / R1) - d * np.sqrt(R0 * R0 - x * x)


def lens_chord(d, R0=1.0, R1=None):
    """Chord of the lens of two discs of radii R0, R1 (default R0) at distance d: minus
    the derivative of :func:`lens_area` in d (0 without a crossing)."""
    R1 = R0 if R1 is None else R1
    if d >= R0 + R1 or d <= abs(R0 - R1):
        return 0.0
    if R1 == R0:
        return 2 * np.sqrt(R0 * R0 - d * d / 4)
    x = (d * d + R0 * R0 - R1 * R1) / (2 * d)
    return 2 * np.sqrt(R0 * R0 - x * x)


def disc_rates(pos, theta, *, v0, box=None, R0=1.0, core_exponent=1.0, radii=None):
    """Rigid discs (``modes = 0``, the high-tension limit): the exact overlap-area force.

    The overlap of two discs at distance d < 2 R0 is a lens; minus its gradient with
    respect to r_i is the chord 2 sqrt(R0^2 - d^2/4) along (r_i - r_j)/d, times
    p A^(p-1) (:func:`lens_area`) for a core exponent p; discs of radii ``radii`` (N,)
    push with the chord of their lens (:func:`lens_chord`).  No torque.
    """
    N = len(pos)
    Rc = per_cell_radii(N, R0, radii)
    dpos = v0 * np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    for i in range(N):
        for j in range(N):
            for shift in _images(box):
                if i == j and not shift.any():
                    continue
                d = pos[j] + shift - pos[i]
                dist = float(np.hypot(*d))
                if radii is None and 0.0 < dist < 2 * R0:
                    f = core_factor(lens_area(dist, R0), core_exponent)
                    dpos[i] -= f * 2 * np.sqrt(R0 * R0 - dist * dist / 4) * d / dist
                elif radii is not None and 0.0 < dist < Rc[i] + Rc[j]:
                    f = core_factor(lens_area(dist, Rc[i], Rc[j]), core_exponent)
                    dpos[i] -= f * lens_chord(dist, Rc[i], Rc[j]) * d / dist
    return {"dpos": dpos, "dtheta": np.zeros(N), "da": np.zeros((N, 0)), "db": np.zeros((N, 0))}
