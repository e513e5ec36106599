"""Percolation of random labels on Voronoi graphs: the known answers of the shuffled control.

Site percolation on any planar triangulation (the Voronoi graph of points in general
position is one: its dual is the Delaunay triangulation) has threshold 1/2 for
independent labels.  Labels that are correlated, and not symmetric under exchanging
labelled and unlabelled cells, move it.  Here: the "Swiss cheese" labels, a cell labelled
when no centre of a Poisson set of discs of radius ``r`` covers it (positively correlated
labels; in the continuum the uncovered phase percolates at area fraction 0.32), percolate
below 1/2, while the symmetric labels of a thresholded Gaussian field (correlated, but
labelled and unlabelled cells exchangeable) stay at 1/2.  Permuting the labels over the cells
(:func:`fcsweep.analysis.voronoi.shuffled_defects`)
restores 1/2.  Test helper (also used by the slow known-answer tests), not part of the package.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from fcsweep.analysis.voronoi import defect_clusters, shuffled_defects, voronoi_neighbors


def random_points(N: int, rng) -> tuple[np.ndarray, tuple]:
    """``N`` uniform points at unit density in a square periodic box."""
    L = np.sqrt(N)
    return rng.uniform(0.0, L, (N, 2)), (L, L)


def jittered_triangular(N: int, rng, jitter: float = 0.2) -> tuple[np.ndarray, tuple]:
    """A triangular lattice of ``n x n`` sites (``N = n^2``, n even), unit density, with
    independent Gaussian displacements of ``jitter`` lattice spacings per component."""
    n = int(round(np.sqrt(N)))
    a = np.sqrt(2.0 / np.sqrt(3.0))  # unit density
    x, y = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    pos = np.stack([(x + 0.5 * (y % 2)) * a, y * a * np.sqrt(3.0) / 2.0], axis=-1).reshape(-1, 2)
    box = (n * a, n * a * np.sqrt(3.0) / 2.0)
    pos = pos + jitter * a * rng.standard_normal(pos.shape)
    return np.mod(pos, box), box


def independent_labels(pos, box, p: float, rng) -> np.ndarray:
    """Each cell labelled with probability ``p``."""
    return rng.random(len(pos)) < p


def swiss_cheese_labels(pos, box, p: float, rng, radius: float = 1.5) -> np.ndarray:
    """Cells not covered by discs of ``radius`` around Poisson centres, the density of the
    centres chosen so that a cell is labelled with probability ``p``."""
    area = box[0] * box[1]
    n_centres = rng.poisson(-np.log(p) / (np.pi * radius ** 2) * area)
    if n_centres == 0:
        return np.ones(len(pos), dtype=bool)
    centres = rng.uniform(0.0, 1.0, (n_centres, 2)) * np.asarray(box)
    d, _ = cKDTree(centres, boxsize=box).query(pos, distance_upper_bound=radius)
    return ~np.isfinite(d)


def largest_cluster_data(points, labels, sizes: dict, p_grid, seed=0, n_graphs: int = 8):
    """``(rho, P_max, its error, P_max shuffled, its error, N)`` per (N, p), averaged over
    ``sizes[N]`` realisations of the labels ``labels(pos, box, p, rng)``, spread over
    ``n_graphs`` graphs per N from ``points(N, rng)`` (the tessellation is the costly part);
    the shuffled statistic permutes each realisation's labels over the same graph."""
    rng = np.random.default_rng(seed)
    rows = []
    k = 0
    for N, n_real in sizes.items():
        graphs = []
        for _ in range(n_graphs):
            pos, box = points(N, rng)
            vn = voronoi_neighbors(pos, box)
            graphs.append((pos, box, vn.i, vn.j))
        for p in p_grid:
            rho, big, shuf = (np.empty(n_real) for _ in range(3))
            for r in range(n_real):
                pos, box, i, j = graphs[r % n_graphs]
                d = labels(pos, box, p, rng)
                rho[r] = d.mean()
                s = defect_clusters(d, i, j)
                big[r] = s[0] / N if s.size else 0.0
                s = defect_clusters(shuffled_defects(d, k), i, j)
                shuf[r] = s[0] / N if s.size else 0.0
                k += 1
            err = np.sqrt(n_real)
            rows.append((rho.mean(), big.mean(), big.std(ddof=1) / err, shuf.mean(), shuf.std(ddof=1) / err, N))
    return tuple(np.array(c) for c in zip(*rows))


def gaussian_field_labels(pos, box, p: float, rng, xi: float = 2.0) -> np.ndarray:
    """The fraction ``p`` of cells where a smooth Gaussian random field is highest.

    The field is a sum of the box's Fourier modes with random phases and Gaussian
    amplitudes, spectrum ``exp(-k^2 xi^2 / 4)`` (correlation ``exp(-r^2 / xi^2)``).  Its law is
    symmetric under ``f -> -f``, so labelled and unlabelled cells are exchangeable at p = 1/2."""
    Lx, Ly = box
    kmax = 3.0 / xi
    nx, ny = int(kmax * Lx / (2 * np.pi)), int(kmax * Ly / (2 * np.pi))
    m, n = np.arange(0, nx + 1), np.arange(-ny, ny + 1)
    k2 = (2 * np.pi * m[:, None] / Lx) ** 2 + (2 * np.pi * n[None, :] / Ly) ** 2
    coef = np.exp(-k2 * xi ** 2 / 8.0) * (rng.standard_normal(k2.shape) + 1j * rng.standard_normal(k2.shape))
    coef[0, :ny + 1] = 0.0  # m = 0: keep n > 0 only, one of each pair +-k
    ex = np.exp(2j * np.pi * pos[:, :1] * m[None, :] / Lx)
    ey = np.exp(2j * np.pi * pos[:, 1:] * n[None, :] / Ly)
    field = ((ex @ coef) * ey).sum(axis=1).real
    n_label = int(round(p * len(pos)))
    d = np.zeros(len(pos), dtype=bool)
    d[np.argsort(field)[len(pos) - n_label:]] = True
    return d
