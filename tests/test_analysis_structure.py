"""Known answers for Voronoi defects, clusters and hexatic order (fcsweep.analysis)."""

import numpy as np
import pytest

from fcsweep.analysis.order import g6, global_psi6, gr_cut, psi6
from fcsweep.analysis.voronoi import (cluster_size_counts, defect_clusters, defect_mask,
                                      defect_statistics, voronoi_neighbors)
from fcsweep.model.lattice import hexagonal_lattice


def test_perfect_lattice_has_no_defects_and_full_hexatic_order():
    pos, box = hexagonal_lattice(256)
    vn = voronoi_neighbors(pos, box)
    assert np.all(vn.n_sides == 6)
    stats = defect_statistics(pos[None], box)
    assert stats["rho_d"] == 0.0
    assert stats["largest_cluster_fraction"] == 0.0
    mod, _ = global_psi6(psi6(pos, box, vn.nlist))
    assert mod == pytest.approx(1.0, abs=1e-6)  # freud works in float32


def test_rotated_shifted_lattice_keeps_order_and_orientation():
    # |Psi6| is invariant under a rigid translation; the orientation follows a rotation
    pos, box = hexagonal_lattice(64)
    shifted = (pos + np.array([0.37, 1.21])) % box
    p = psi6(shifted, box)
    mod, ang = global_psi6(p)
    assert mod == pytest.approx(1.0, abs=1e-6)
    assert np.cos(6 * ang) == pytest.approx(1.0, abs=1e-6)  # bonds along x


def test_poisson_points_defect_fraction():
    # Poisson-Voronoi: P(6 sides) = 0.294667 (Hayen & Quine 2000), so rho_d = 0.7053.
    # 5 frames x 4000 points; the binomial standard error is sqrt(p(1-p)/20000) = 0.0032
    # (the sum rule <n> = 6 makes the true error smaller); tolerance 0.012 ~ 4 sigma.
    rng = np.random.default_rng(7)
    box = np.array([100.0, 80.0])
    frames = rng.uniform(0, 1, (5, 4000, 2)) * box
    stats = defect_statistics(frames, box)
    assert stats["rho_d"] == pytest.approx(0.7053, abs=0.012)
    # Euler: the mean number of sides is 6 in a periodic tessellation (voro++ drops the
    # odd near-degenerate edge shorter than its tolerance: ~1 in 10^4 here)
    sides = stats["n_sides_counts"]
    assert (np.arange(13) * sides).sum() / sides.sum() == pytest.approx(6.0, abs=1e-3)
    # defect clusters percolate above rho_d = 1/2 on the Voronoi graph
    assert stats["largest_cluster_fraction"] > 0.3
    assert stats["cluster_size_counts"].sum() > 0


def _edge_displacement(x, y, b, nu=0.3):
    """Isotropic-elastic displacement of an edge dislocation with Burgers vector (b, 0)."""
    r2 = x * x + y * y
    ux = b / (2 * np.pi) * (np.arctan2(y, x) + x * y / (2 * (1 - nu) * r2))
    uy = -b / (2 * np.pi) * ((1 - 2 * nu) / (4 * (1 - nu)) * np.log(r2)
                             + (x * x - y * y) / (4 * (1 - nu) * r2))
    return np.stack([ux, uy], axis=-1)


def test_dislocation_dipole_gives_two_five_seven_pairs():
    # A periodic box holds dislocations only in pairs of opposite Burgers vector.  Two
    # edge dislocations (b = +-a along x) 12 lattice constants apart, cores placed
    # between lattice rows; the known answer is two 5-7 pairs, every other cell 6-fold.
    n = 40
    pos, box = hexagonal_lattice(n * n)
    a = box[0] / n
    y0 = box[1] / 2 + a * np.sqrt(3) / 4
    c1 = np.array([box[0] / 2 - 6 * a, y0])
    c2 = np.array([box[0] / 2 + 6 * a, y0])
    u = _edge_displacement(*(pos - c1).T, a) - _edge_displacement(*(pos - c2).T, a)
    P = (pos + u) % box
    vn = voronoi_neighbors(P, box)
    counts = np.bincount(vn.n_sides, minlength=9)
    assert counts[5] == 2 and counts[7] == 2 and counts[6] == n * n - 4
    five = np.flatnonzero(vn.n_sides == 5)
    seven = set(np.flatnonzero(vn.n_sides == 7))
    for f in five:  # each 5-fold cell touches a 7-fold cell near one core
        nb = set(vn.j[vn.i == f])
        assert nb & seven
    sizes = defect_clusters(defect_mask(vn.n_sides), vn.i, vn.j)
    assert list(sizes) == [2, 2]
    assert list(cluster_size_counts(sizes, 5)) == [0, 2, 0, 0, 0]


def test_clusters_on_a_chain_graph():
    # 0-1-2-3-4-5 chain: defects {0,1,3,4,5} form clusters of sizes 3 and 2
    i = np.array([0, 1, 2, 3, 4])
    j = i + 1
    defect = np.array([1, 1, 0, 1, 1, 1], bool)
    assert list(defect_clusters(defect, i, j)) == [3, 2]
    assert defect_clusters(np.zeros(6, bool), i, j).size == 0


def test_g6_and_gr_on_lattice():
    pos, box = hexagonal_lattice(256)
    a = box[0] / 16
    p = psi6(pos, box)
    r, G = g6(pos, box, p, dr=0.1)
    ok = np.isfinite(G)
    assert ok.sum() > 5
    assert np.allclose(G[ok], 1.0, atol=1e-5)  # perfect orientational order at all r
    assert np.all(~ok[r < a - 0.1])  # no pair closer than the lattice constant
    _, ang = global_psi6(p)
    x, Gr = gr_cut(pos, box, ang, dx=0.2)
    # peaks exactly at multiples of the lattice constant along the row
    peaks = x[Gr > 0]
    assert np.allclose(peaks / a, np.round(peaks / a), atol=0.2 / a)
    # the strip |dy| < h/2 holds one row point at each k a on either side, so each peak
    # is (2 N) / (N (N - 1) / A * 2 h^2) = A / ((N - 1) h^2)
    assert np.allclose(Gr[Gr > 0], box[0] * box[1] / (255 * 0.2**2), rtol=1e-9)


def test_gr_of_ideal_gas_is_one():
    # one frame of 1000 points in a 40 x 40 box has ~1250 ordered pairs per (1 x 1) bin
    # pair region, a per-bin scatter of 0.04 (measured over 40 frames, no bias); over 10
    # frames 0.013, so a 5-sigma tolerance of 0.065 per bin and 0.02 on the mean
    rng = np.random.default_rng(3)
    box = np.array([40.0, 40.0])
    vals = []
    for _ in range(10):
        P = rng.uniform(0, 40, (1000, 2))
        x, Gr = gr_cut(P, box, 0.3, dx=1.0, r_max=10.0)
        vals.append(Gr)
    assert len(x) == 9
    mean = np.mean(vals, axis=0)
    assert mean == pytest.approx(np.ones_like(x), abs=0.065)
    assert mean.mean() == pytest.approx(1.0, abs=0.02)
