"""Initial hexagonal lattice and periodic box of docs/model.md (pure numpy)."""

from __future__ import annotations

import math

import numpy as np


def lattice_side(N: int) -> int:
    """Return n with N = n^2 and n even, or raise ValueError naming the nearest valid N.

    Parameters
    ----------
    N : int
        Number of cells.
    """
    if isinstance(N, bool) or int(N) != N or N < 4:
        raise ValueError(f"N must be an integer n*n with n even and n >= 2; got {N!r}")
    N = int(N)
    n = math.isqrt(N)
    if n * n == N and n % 2 == 0:
        return n
    lo = (n if n % 2 == 0 else n - 1)
    lo = max(lo, 2)
    hi = lo + 2
    if lo * lo == N:  # pragma: no cover - handled above
        return lo
    raise ValueError(
        f"N must be n*n with n even (hexagonal n x n lattice in a periodic box); got N={N}. "
        f"Nearest valid values: {lo * lo} (n={lo}) and {hi * hi} (n={hi})."
    )


def lattice_box(N: int, density: float = 0.95, R0: float = 1.0) -> tuple[float, float, float]:
    """Lattice constant and periodic box for N cells at area fraction ``density``.

    ``a = sqrt(2 pi R0^2 / (density sqrt 3))``, ``Lx = n a``, ``Ly = n a sqrt(3)/2``.

    Returns
    -------
    a, Lx, Ly : float
    """
    if not 0.0 < density < 1.0:
        raise ValueError(f"density must lie in (0, 1); got {density}")
    n = lattice_side(N)
    a = math.sqrt(2.0 * math.pi * R0 * R0 / (density * math.sqrt(3.0)))
    return a, n * a, n * a * math.sqrt(3.0) / 2.0


def hexagonal_lattice(N: int, density: float = 0.95, R0: float = 1.0):
    """Cell centres on an n x n triangular lattice filling a periodic box.

    Returns
    -------
    pos : ndarray, shape (N, 2)
        Centres inside ``[0, Lx) x [0, Ly)``.
    box : ndarray, shape (2,)
        ``(Lx, Ly)``; area fraction ``N pi R0^2 / (Lx Ly) == density``.
    """
    n = lattice_side(N)
    a, Lx, Ly = lattice_box(N, density, R0)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="xy")
    x = (i + 0.5 * (j % 2) + 0.25) * a
    y = (j + 0.5) * a * math.sqrt(3.0) / 2.0
    pos = np.stack([x.ravel(), y.ravel()], axis=1)
    return pos, np.array([Lx, Ly])
