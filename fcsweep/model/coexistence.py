"""The crystal | fluid coexistence (``initial: coexistence``) start of docs/model.md, its
model-free part (pure numpy).

The box is the lattice's (``n x n`` hexagonal lattice at the run's area fraction,
:func:`fcsweep.model.lattice.hexagonal_lattice`).  Its rows ``n/4 <= j < n/4 + n/2``
(:func:`slab_rows`) are kept on the lattice: a crystal slab of ``N/2`` cells filling half
the box, bounded by two flat interfaces along x (a close-packed lattice direction).  The
other ``N/2`` cells are placed uniformly at random in the remaining band of the box (the
same area, so the same area fraction on both sides) and pushed apart as soft discs with
the slab's cells held fixed (:func:`held_soft_disc_relax`): the slab stays a perfect
crystal and the band becomes the disordered start's packing against it.  The model's own
relaxation at ``v0 = 0`` then follows (:meth:`fcsweep.simulation.Simulation.from_coexistence`).

Everything random here comes from :func:`coexistence_rng`, a stream of its own (neither
the dynamics' ``PCG64(seed)`` nor the disordered start's stream).

A slab needs room for a bulk on each side of its interfaces: ``n >= MIN_SIDE``
(:func:`coexistence_problem`); sizes and walls are refused by
:func:`fcsweep.model.sizes.size_problem` and :func:`fcsweep.model.confinement.boundary_problem`
(they need ``initial: disordered``: the slab is a lattice of equal cells in a periodic box).
"""

from __future__ import annotations

import math

import numpy as np

from .disordered import SOFT_DISC_DEPTH, SOFT_DISC_ITERATIONS, SOFT_DISC_STEP, soft_disc_pairs
from .lattice import hexagonal_lattice, lattice_box, lattice_side

__all__ = ["COEXISTENCE_STREAM", "MIN_SIDE", "coexistence_rng", "coexistence_problem", "slab_rows",
           "fluid_band", "held_soft_disc_relax", "coexistence_centres"]

#: Second word of the seed sequence of the start's own stream (ASCII "coex").
COEXISTENCE_STREAM = 0x636F6578
#: Smallest lattice side n (N = n^2): a slab of n/2 >= 4 rows and a band as high, so that
#: each side keeps a bulk beyond the interfaces' width (about two rows).
MIN_SIDE = 8


def coexistence_rng(seed: int) -> np.random.Generator:
    """The start's own random stream: ``PCG64(SeedSequence([seed, COEXISTENCE_STREAM]))``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), COEXISTENCE_STREAM])))


def coexistence_problem(N: int, initial: str) -> str:
    """Why ``initial`` cannot start ``N`` cells ("" if it can, or if it is not ``coexistence``).

    Parameters
    ----------
    N : int
        Number of cells (a valid lattice size: :func:`fcsweep.model.lattice.lattice_side`).
    initial : str
        The start.
    """
    if initial != "coexistence":
        return ""
    n = math.isqrt(int(N))
    if n < MIN_SIDE:
        return (f"initial: coexistence needs N >= {MIN_SIDE ** 2} (a lattice slab of n/2 >= {MIN_SIDE // 2} rows "
                f"and a disordered band as high); got N = {N}")
    return ""


def slab_rows(n: int) -> tuple[int, int]:
    """Lattice rows ``j0 <= j < j1`` of the crystal slab: ``n/2`` rows from ``n // 4``."""
    j0 = n // 4
    return j0, j0 + n // 2


def fluid_band(N: int, density: float = 0.95, R0: float = 1.0) -> tuple[float, float]:
    """The band of the box outside the slab: its lower edge ``y0`` and height ``H``
    (it covers ``[y0, y0 + H)`` modulo ``Ly``; ``H = Ly / 2``).

    The slab of rows ``j0 <= j < j1`` covers ``[j0 h, j1 h)``, ``h = a sqrt(3) / 2`` the
    row spacing (rows at ``y = (j + 1/2) h``), so the band starts at ``j1 h``.
    """
    n = lattice_side(N)
    a, _, Ly = lattice_box(N, density, R0)
    h = a * math.sqrt(3.0) / 2.0
    j0, j1 = slab_rows(n)
    return j1 * h, Ly - (j1 - j0) * h


def held_soft_disc_relax(pos, box, held, R0: float = 1.0, *, step: float = SOFT_DISC_STEP,
                         iterations: int = SOFT_DISC_ITERATIONS, depth: float = SOFT_DISC_DEPTH):
    """:func:`fcsweep.model.disordered.soft_disc_relax` (equal discs, periodic box) with
    the discs of ``held`` fixed: they push the others and are not pushed.

    Parameters
    ----------
    pos : array_like, shape (N, 2)
        Initial centres (not modified).
    box : array_like, shape (2,)
        Periodic box.
    held : array_like of bool, shape (N,)
        Discs that do not move.
    R0, step, iterations, depth : float, int
        As for :func:`fcsweep.model.disordered.soft_disc_relax`; the descent stops once no
        two discs overlap deeper than ``depth * R0`` (pairs of held discs included: they
        must already satisfy it).

    Returns
    -------
    pos : ndarray, shape (N, 2)
        Relaxed centres wrapped into the box (the held ones unchanged).
    iterations : int
        Iterations done.
    """
    box = np.asarray(box, float)
    pos = np.array(pos, float) % box
    free = ~np.asarray(held, bool)
    sigma = 2.0 * R0
    N = len(pos)
    done = 0
    while done < int(iterations):
        i, j, d = soft_disc_pairs(pos, box, sigma)
        r = np.sqrt(np.einsum("ij,ij->i", d, d))
        if r.size == 0 or r.min() >= sigma - depth * R0:
            break
        push = np.where(r > 0, (sigma - r) / np.where(r > 0, r, 1.0), 0.0)[:, None] * d
        force = np.stack([np.bincount(j, push[:, k], N) - np.bincount(i, push[:, k], N) for k in (0, 1)], axis=1)
        pos[free] = (pos[free] + step * R0 * force[free]) % box
        done += 1
    return pos, done


def coexistence_centres(N: int, density: float, R0: float, rng: np.random.Generator):
    """Centres of the coexistence start before the model's relaxation.

    Parameters
    ----------
    N : int
        Number of cells, ``n*n`` with ``n`` even and ``n >= MIN_SIDE``.
    density : float
        Area fraction (of the whole box and of each half).
    R0 : float
        Cell radius.
    rng : numpy.random.Generator
        The start's stream (:func:`coexistence_rng`).

    Returns
    -------
    pos : ndarray, shape (N, 2)
        The slab's lattice sites first (lattice order), then the band's relaxed centres.
    slab : ndarray of bool, shape (N,)
        True for the slab's cells.
    box : ndarray, shape (2,)
        ``(Lx, Ly)``, the lattice's box.
    """
    problem = coexistence_problem(N, "coexistence")
    if problem:
        raise ValueError(problem)
    n = lattice_side(N)
    lattice, box = hexagonal_lattice(N, density, R0)
    j0, j1 = slab_rows(n)
    crystal = lattice[j0 * n:j1 * n]  # rows j occupy indices j*n .. j*n + n - 1
    y0, H = fluid_band(N, density, R0)
    m = N - len(crystal)
    u = rng.uniform(0.0, 1.0, (m, 2))
    band = np.column_stack([u[:, 0] * box[0], (y0 + u[:, 1] * H) % box[1]])
    pos = np.concatenate([crystal, band])
    slab = np.arange(N) < len(crystal)
    pos, _ = held_soft_disc_relax(pos, box, slab, R0)
    return pos, slab, box
