"""KTHNY classification on configurations with known answers.

- A triangular lattice with independent Gaussian jitter: constant G_r peak heights
  (eta_T = 0) and constant G6 -> solid.
- Random sequential addition of discs at area fraction 0.45: both correlations die within
  two diameters -> liquid.
- N below MIN_CELLS (4096): undetermined, with the reason naming N.
"""

import numpy as np
import pytest
from synthetic import random_sequential_discs, triangular_crystal

from fcsweep.analysis import kthny, order
from fcsweep.analysis.phase import KTHNY_FLAGS, KTHNY_LIQUID, KTHNY_SOLID, KTHNY_UNDETERMINED, kthny_name
from fcsweep.analysis.pipeline import _frame_mean


def _curves(make, frames, seed):
    rng = np.random.default_rng(seed)
    g6s, grs = [], []
    for _ in range(frames):
        pos, box = make(rng)
        ps = order.psi6(pos, box)
        _, ang = order.global_psi6(ps)
        r, g = order.g6(pos, box, ps, dr=0.1)
        dx, gr = order.gr_cut(pos, box, ang, dx=0.1)
        g6s.append(g)
        grs.append(gr)
    G6, G6e = _frame_mean(np.array(g6s))
    Gr, Gre = _frame_mean(np.array(grs))
    return kthny.kthny_fits(r, G6, dx, Gr, G6_err=G6e, Gr_err=Gre), len(pos)


def test_names_and_flags():
    assert [kthny_name(c) for c in sorted(KTHNY_FLAGS)] == ["unknown", "solid", "hexatic", "liquid", "undetermined"]
    assert kthny_name(7) == "unknown"


@pytest.mark.parametrize("jitter", [0.05, 0.1])
def test_jittered_crystal_is_kthny_solid(jitter):
    """N = 4096, 2 frames: eta_T and eta_6 consistent with 0 (measured |eta| < 0.02 +- 0.02),
    far below 1/3 and 1/4."""
    fits, N = _curves(lambda g: triangular_crystal(64, jitter, g), 2, 1)
    assert abs(fits["eta_T"]) < 3 * fits["eta_T_err"] + 0.02 and abs(fits["eta_6"]) < 3 * fits["eta_6_err"] + 0.02
    assert fits["T_points"] >= 20  # one peak per lattice spacing over the last 3/4 of half the box
    lab = kthny.classify_kthny(fits, n_cells=N)
    assert lab.code == KTHNY_SOLID and lab.confidence > 0.99, lab.reason


def test_random_disc_fluid_is_kthny_liquid():
    fits, N = _curves(lambda g: random_sequential_discs(4096, 0.45, g), 1, 2)
    assert fits["six_sunk"] and fits["six_r_end"] < 4.0  # G6 gone within ~2 diameters
    lab = kthny.classify_kthny(fits, n_cells=N)
    assert lab.code == KTHNY_LIQUID and lab.confidence > 0.99, lab.reason


def test_small_system_is_undetermined_with_the_reason():
    fits, N = _curves(lambda g: triangular_crystal(16, 0.08, g), 2, 3)
    lab = kthny.classify_kthny(fits, n_cells=N)
    assert lab.code == KTHNY_UNDETERMINED and f"N = {N}" in lab.reason


def test_fit_decays_recovers_known_exponent_and_length():
    """Exact curves with 1 % noise: eta within 2 errors and within 0.02, xi within 5 %."""
    rng = np.random.default_rng(4)
    r = np.linspace(1, 15, 60)
    y = 0.8 * r ** -0.3 * (1 + 0.01 * rng.normal(size=r.size))
    f = kthny.fit_decays(r, y, 0.01 * y)
    assert abs(f["eta"] - 0.3) < max(2 * f["eta_err"], 0.02) and f["chi2_power"] < f["chi2_exp"]
    y = 0.8 * np.exp(-r / 4.0) * (1 + 0.01 * rng.normal(size=r.size))
    f = kthny.fit_decays(r, y, 0.01 * y)
    assert f["xi"] == pytest.approx(4.0, rel=0.05) and f["chi2_exp"] < f["chi2_power"]


def test_hexatic_from_exponents():
    """Short-ranged translational order with quasi-long-ranged bond order is hexatic; an
    exponent straddling its bound is undetermined."""
    fits = {"eta_T": 1.5, "eta_T_err": 0.1, "eta_6": 0.1, "eta_6_err": 0.03, "T_sunk": False, "six_sunk": False}
    assert kthny.classify_kthny(fits, n_cells=4900).code == 1
    near = dict(fits, eta_6=0.25, eta_6_err=0.05)
    assert kthny.classify_kthny(near, n_cells=4900).code == KTHNY_UNDETERMINED
