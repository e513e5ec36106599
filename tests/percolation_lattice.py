"""Exact site percolation on periodic triangular lattices: the known answer for tau.

A square L x L grid with the bonds (1, 0), (0, 1) and (1, -1) (periodic) is the
triangular lattice (coordination 6), whose site-percolation threshold is exactly 1/2;
at p = 1/2 cluster sizes follow n_s ~ s^-187/91.  Clusters are the connected components
of occupied sites (scipy.sparse.csgraph), many realisations labelled at once as one
block-diagonal graph.  Test helper (also used by campaigns/percolation_tau.py), not
part of the package.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


def triangular_bonds(L: int) -> np.ndarray:
    """Bonds ``(2, 3 L^2)`` of the periodic L x L triangular lattice, site index ``x + L y``."""
    x, y = np.meshgrid(np.arange(L), np.arange(L), indexing="ij")
    i = (x + L * y).ravel()
    js = [(((x + dx) % L) + L * ((y + dy) % L)).ravel() for dx, dy in ((1, 0), (0, 1), (1, -1))]
    return np.concatenate([np.stack([i, j]) for j in js], axis=1)


def cluster_counts(L: int, n_realisations: int, p: float = 0.5, seed=None, batch_sites: int = 400_000,
                   largest: list | None = None) -> np.ndarray:
    """Cluster-size counts pooled over independent realisations of site percolation.

    Returns ``counts`` of length ``L^2`` with ``counts[s-1]`` = number of clusters of size s;
    the largest cluster size of each realisation is appended to ``largest`` when given.
    """
    rng = np.random.default_rng(seed)
    n = L * L
    b = triangular_bonds(L)
    counts = np.zeros(n, dtype=np.int64)
    per_batch = max(1, batch_sites // n)
    done = 0
    while done < n_realisations:
        m = min(per_batch, n_realisations - done)
        occ = rng.random((m, n)) < p
        offset = (np.arange(m) * n)[:, None]
        keep = occ[:, b[0]] & occ[:, b[1]]
        i, j = (b[0] + offset)[keep], (b[1] + offset)[keep]
        graph = coo_matrix((np.ones(i.size, dtype=np.int8), (i, j)), shape=(m * n, m * n))
        _, labels = connected_components(graph, directed=False)
        occupied = np.flatnonzero(occ)
        sizes = np.bincount(labels[occupied])
        if largest is not None:
            realisation = np.zeros(sizes.size, dtype=np.int64)
            realisation[labels[occupied]] = occupied // n
            per_real = np.zeros(m, dtype=np.int64)
            np.maximum.at(per_real, realisation, sizes)
            largest.extend(per_real.tolist())
        counts += np.bincount(sizes[sizes > 0], minlength=n + 1)[1:]
        done += m
    return counts
