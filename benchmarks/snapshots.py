"""Dense, deformed test configurations made without the simulation engine.

``dense_snapshot`` puts cells on the hexagonal lattice of docs/model.md, jitters them, gives
them random polarities and random admissible shapes; ``snapshot_from_arrays`` wraps
arrays taken from a real run (e.g. ``sim.state``) into the same dict.
"""

from __future__ import annotations

import numpy as np

from fcsweep.model.lattice import hexagonal_lattice
from fcsweep.model.shape import ADMISSIBLE_BOUND


def dense_snapshot(N=64, density=0.95, seed=0, deform=0.15, *, jitter=0.1, modes=6, R0=1.0):
    """Hexagonal lattice with position jitter, random θ and random admissible modes.

    Parameters
    ----------
    N : int
        Cells, n*n with n even.
    density : float
        Area fraction N π R0² / (Lx Ly).
    seed : int
    deform : float
        Target amplitude sum Σ_n |c_n| per cell (each cell gets deform × U(0.8, 1.2),
        capped at 0.95 of the admissibility bound sqrt(2/3)).
    jitter : float
        Standard deviation of the position jitter, in units of R0.
    modes : int
        Highest Fourier mode M (mode arrays have width M - 1).

    Returns
    -------
    dict
        ``pos`` (N, 2) wrapped into the box, ``theta`` (N,), ``a``, ``b`` (N, M-1),
        ``box`` (2,).
    """
    rng = np.random.default_rng(seed)
    pos, box = hexagonal_lattice(N, density, R0)
    pos = np.mod(pos + jitter * R0 * rng.normal(size=pos.shape), box)
    theta = rng.uniform(0.0, 2.0 * np.pi, N)
    m = modes - 1
    amp = rng.exponential(size=(N, m))
    phase = rng.uniform(0.0, 2.0 * np.pi, (N, m))
    target = np.minimum(deform * rng.uniform(0.8, 1.2, N), 0.95 * ADMISSIBLE_BOUND)
    amp *= (target / np.maximum(amp.sum(axis=1), 1e-300))[:, None]
    return {"pos": pos, "theta": theta, "a": amp * np.cos(phase), "b": amp * np.sin(phase),
            "box": np.asarray(box, dtype=float)}


def snapshot_from_arrays(pos, theta, a, b, box):
    """Validate and package arrays from a real simulation as a snapshot dict.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    theta : ndarray, shape (N,)
    a, b : ndarray, shape (N, M-1)
    box : array_like, shape (2,)
    """
    box = np.asarray(box, dtype=float).reshape(2)
    pos = np.mod(np.asarray(pos, dtype=float), box)
    theta = np.asarray(theta, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    N = pos.shape[0]
    if pos.shape != (N, 2) or theta.shape != (N,) or a.shape != b.shape or a.shape[0] != N:
        raise ValueError(f"inconsistent shapes: pos {pos.shape}, theta {theta.shape}, "
                         f"a {a.shape}, b {b.shape}")
    return {"pos": pos.copy(), "theta": theta.copy(), "a": a.copy(), "b": b.copy(), "box": box}
