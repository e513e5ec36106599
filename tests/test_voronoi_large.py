"""The Delaunay path of the Voronoi bonds (used beyond freud's reach) against freud's.

freud 3.4's Voronoi fails in 2-D boxes beyond a few 10^5 points, so
``voronoi.voronoi_neighbors`` takes the bonds from scipy's Delaunay triangulation there
(``delaunay_bonds``). On a jittered lattice and on a random set (no degenerate
quadrilaterals) the two tessellations have the same bonds, sides and minimum-image vectors
(to freud's float32).
"""

import numpy as np
import pytest
from synthetic import triangular_crystal

from fcsweep.analysis import voronoi


@pytest.mark.parametrize("kind", ["lattice", "random"])
def test_delaunay_bonds_are_freuds(kind):
    rng = np.random.default_rng(5)
    if kind == "lattice":
        pos, box = triangular_crystal(40, 0.1, rng)
    else:
        box = (31.0, 27.0)
        pos = rng.uniform(0, 1, (1500, 2)) * box
    ref = voronoi.voronoi_neighbors(pos, box)
    i, j, vec = voronoi.delaunay_bonds(pos, box)
    assert np.array_equal(i, ref.i) and np.array_equal(j, ref.j)  # both sorted by (i, j)
    assert np.allclose(vec, ref.vectors, atol=1e-5)  # freud's vectors are float32
    assert np.array_equal(np.bincount(i, minlength=len(pos)), ref.n_sides)


def test_large_n_takes_the_delaunay_path(monkeypatch):
    """Above FREUD_VORONOI_MAX the neighbours (and their freud list, for psi6) come from
    the Delaunay bonds: same sides as freud's on the same cells."""
    pos, box = triangular_crystal(20, 0.1, np.random.default_rng(2))
    ref = voronoi.voronoi_neighbors(pos, box)
    monkeypatch.setattr(voronoi, "FREUD_VORONOI_MAX", 100)
    big = voronoi.voronoi_neighbors(pos, box)
    assert np.array_equal(big.n_sides, ref.n_sides)
    assert len(big.nlist.point_indices) == len(ref.i)
