"""The isotropic (``initial: disordered``) start of docs/model.md, its model-free part (pure numpy).

Uniformly random centres in the lattice's periodic box would overlap arbitrarily deeply
(pairs at distance ~0 are common at area fraction 0.95); a soft-disc pre-relaxation
(harmonic repulsion of discs of radius R0, gradient descent with minimum image) removes
those deep overlaps, and only those, before the model's own dynamics relaxes positions and shapes
(:meth:`fcsweep.simulation.Simulation.from_disordered`).  Everything random here comes
from :func:`start_rng`, a stream of its own, so the dynamics' noise stream is untouched.
"""

from __future__ import annotations

import numpy as np

from .confinement import wall_gap

__all__ = ["DISORDERED_STREAM", "SOFT_DISC_STEP", "SOFT_DISC_ITERATIONS", "SOFT_DISC_DEPTH",
           "start_rng", "random_centres", "soft_disc_pairs", "soft_disc_relax"]

#: Second word of the seed sequence of the start's own stream (ASCII "disr"); any
#: constant other than the dynamics' plain ``PCG64(seed)`` keeps the two streams apart.
DISORDERED_STREAM = 0x64697372
#: Gradient-descent step of the soft-disc pre-relaxation, in R0 per unit force (stable
#: below 2 / (2 x 6 neighbours) ~ 0.17 for unit springs).
SOFT_DISC_STEP = 0.1
#: Iterations at most of the pre-relaxation.
SOFT_DISC_ITERATIONS = 1000
#: The pre-relaxation stops once no two discs overlap deeper than this (R0): the depth the
#: model's own dynamics resolves (tests/test_simulation.py).  Relaxing monodisperse discs
#: further at area fraction 0.95 crystallises them (|Psi6| 0.65-1 at N = 144 after 1000
#: iterations, 0.06-0.22 when stopped here).
SOFT_DISC_DEPTH = 0.5


def start_rng(seed: int) -> np.random.Generator:
    """The start's own random stream: ``PCG64(SeedSequence([seed, DISORDERED_STREAM]))``.

    Parameters
    ----------
    seed : int
        The run's seed (the dynamics draw from ``PCG64(seed)``).
    """
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), DISORDERED_STREAM])))


def random_centres(N: int, box, rng: np.random.Generator) -> np.ndarray:
    """``N`` centres uniformly distributed in ``[0, Lx) x [0, Ly)``.

    Returns
    -------
    ndarray, shape (N, 2)
    """
    box = np.asarray(box, float)
    return rng.uniform(0.0, 1.0, (int(N), 2)) * box


def _min_image(d: np.ndarray, box: np.ndarray) -> np.ndarray:
    return d - box * np.rint(d / box)


def soft_disc_pairs(pos: np.ndarray, box, cutoff: float):
    """Pairs of centres closer than ``cutoff`` in the periodic box (cell list, numpy).

    Returns
    -------
    i, j : ndarray of int
        Pair indices, ``i < j``, each pair once.
    d : ndarray, shape (P, 2)
        Minimum-image separations ``pos[j] - pos[i]``.
    """
    box = np.asarray(box, float)
    N = len(pos)
    nc = np.maximum((box // cutoff).astype(np.int64), 1)
    if (nc < 3).any():  # too small a box for distinct neighbour cells: all pairs
        i, j = np.triu_indices(N, 1)
    else:
        c = np.floor(pos / box * nc).astype(np.int64) % nc
        cid = c[:, 0] * nc[1] + c[:, 1]
        order = np.argsort(cid, kind="stable")
        counts = np.bincount(cid, minlength=int(nc.prod()))
        starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
        m = int(counts.max())
        slot = np.arange(N) - starts[cid[order]]
        members = np.full((int(nc.prod()), m), -1, np.int64)
        members[cid[order], slot] = order
        cx, cy = np.divmod(np.arange(int(nc.prod())), nc[1])
        ii, jj = [], []
        for ox in (-1, 0, 1):
            for oy in (-1, 0, 1):
                nb = ((cx + ox) % nc[0]) * nc[1] + (cy + oy) % nc[1]
                a = np.broadcast_to(members[:, :, None], (len(nb), m, m))
                b = np.broadcast_to(members[nb][:, None, :], (len(nb), m, m))
                keep = (a >= 0) & (b >= 0) & (a < b)
                ii.append(a[keep])
                jj.append(b[keep])
        i, j = np.concatenate(ii), np.concatenate(jj)
    d = _min_image(pos[j] - pos[i], box)
    close = np.einsum("ij,ij->i", d, d) < cutoff * cutoff
    return i[close], j[close], d[close]


def soft_disc_relax(pos, box, R0: float = 1.0, *, step: float = SOFT_DISC_STEP,
                    iterations: int = SOFT_DISC_ITERATIONS, depth: float = SOFT_DISC_DEPTH, radii=None,
                    confinement=None):
    """Push discs of radius ``R0`` apart (harmonic repulsion ``(2 R0 - r)^2 / 2``, gradient
    descent) until no two overlap deeper than ``depth * R0``.

    Parameters
    ----------
    pos : array_like, shape (N, 2)
        Initial centres (not modified).
    box : array_like, shape (2,)
        Periodic box ``(Lx, Ly)``.
    R0 : float
        Disc radius (with ``radii``: the mean radius, the unit of ``step`` and ``depth``).
    step : float
        Descent step (R0 per unit force).
    iterations : int
        Iterations at most.
    depth : float
        Deepest overlap (R0) at which the descent stops.
    radii : array_like, shape (N,), optional
        Per-disc radii (cell size differences): the repulsion is (R_i + R_j - r)^2 / 2.
    confinement : fcsweep.model.confinement.Confinement, optional
        Walls (``box`` is then its host box): a disc beyond a wall by h is pushed back with
        the repulsion h^2 / 2, and the descent also stops only once no disc is beyond a
        wall by more than ``depth * R0``.

    Returns
    -------
    pos : ndarray, shape (N, 2)
        Relaxed centres wrapped into the box.
    iterations : int
        Iterations done.
    """
    box = np.asarray(box, float)
    pos = np.array(pos, float) % box
    sigma = 2.0 * R0
    N = len(pos)
    rad = None if radii is None else np.asarray(radii, float).reshape(N)
    cutoff = sigma if rad is None else 2.0 * float(rad.max())
    done = 0
    while done < int(iterations):
        i, j, d = soft_disc_pairs(pos, box, cutoff)
        r = np.sqrt(np.einsum("ij,ij->i", d, d))
        if rad is not None:  # pairs in the cutoff that do not touch push with zero
            sigma = rad[i] + rad[j]
            touch = r < sigma
            i, j, d, r, sigma = i[touch], j[touch], d[touch], r[touch], sigma[touch]
        wall_h = None
        if confinement is not None:
            wall_h = np.maximum(wall_gap(pos, confinement) + (R0 if rad is None else rad), 0.0)
        pairs_done = r.size == 0 or (r.min() >= sigma - depth * R0 if rad is None
                                     else (r - (sigma - depth * R0)).min() >= 0.0)
        if pairs_done and (wall_h is None or wall_h.max() <= depth * R0):
            break
        # coincident centres (probability zero) get no force this iteration
        push = np.where(r > 0, (sigma - r) / np.where(r > 0, r, 1.0), 0.0)[:, None] * d
        force = np.stack([np.bincount(j, push[:, k], N) - np.bincount(i, push[:, k], N) for k in (0, 1)], axis=1)
        if wall_h is not None:
            force -= wall_h[:, None] * confinement.outward_normal(pos)
        pos = (pos + step * R0 * force) % box
        done += 1
    return pos, done
