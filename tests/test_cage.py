"""Fluidity shown in a finite window: cage breaking, and the asymmetric phase rule.

Known answers (synthetic active Brownian particles, v0 = 0.03, Dr = 0.01, 256 particles in
a 50 x 50 periodic box, neighbour spacing a = 3.36):
- free ABPs move sqrt(MSD) = 4.5 in 2/Dr and 9.5 in 8/Dr: cages (neighbour shells) are
  left within every window from 2/Dr on (cage-relative MSD 2.1 a^2 over 2/Dr, measured);
- ABPs in harmonic cages (k = 0.1) hold their MSD at 0.16 = 0.014 a^2: never broken.
"""

import numpy as np
import pytest
from synthetic import abp_positions, ar1

from fcsweep.analysis.cage import cage_breaking, neighbour_spacing
from fcsweep.analysis.diffusion import estimate_diffusion, free_diffusion
from fcsweep.analysis.phase import (PHASE_FLUID, PHASE_SOFT_FLUID, PHASE_SOLID, PHASE_UNDETERMINED,
                                    classify_phase)
from fcsweep.analysis.phase import cage_evidence
from fcsweep.analysis.stats import detect_equilibration

V0, DR, BOX = 0.03, 0.01, (50.0, 50.0)
D0 = free_diffusion(V0, DR)


def _label(k, span, seed, q=(3.6, 0.002)):
    """The pipeline's phase rule on a synthetic ABP trajectory of ``span`` time units."""
    frames = int(span / 2) + 1
    t = np.arange(frames) * 2.0
    x = abp_positions(256, frames, 2.0, v0=V0, Dr=DR, k=k, substeps=4, rng=np.random.default_rng(seed))
    est = estimate_diffusion(t, x, Dr=DR)
    cb = cage_breaking(t, x, BOX)
    sc = cb.scalars(V0, DR)
    p, note = cage_evidence(sc)
    ok = est.long_enough and est.diffusive
    return classify_phase(est.D / D0, est.D_err / D0, *q, diffusion_ok=ok, diffusion_note="D_eff not trusted",
                          cage_broken=p, cage_note=note, D_late=sc["D_eff_cr_late"],
                          D_late_err=sc["D_eff_cr_late_err"]), cb


def test_neighbour_spacing_of_the_model_box():
    """a = (2 pi / (sqrt(3) rho))^(1/2) R0 = 1.95 R0 at rho = 0.95 (triangular lattice)."""
    n = 16
    a = np.sqrt(2 * np.pi / (0.95 * np.sqrt(3)))
    assert neighbour_spacing(n * n, (n * a, n * a * np.sqrt(3) / 2)) == pytest.approx(a, rel=1e-12)
    assert a == pytest.approx(1.954, abs=1e-3)


@pytest.mark.parametrize("span", [200, 400, 800])
@pytest.mark.parametrize("seed", [1, 2])
def test_free_abps_read_fluid_over_2_4_and_8_persistence_times(span, seed):
    """Free ABPs leave their neighbour shells within 2/Dr already, and the cage-relative
    MSD past that lag gives D_eff_cr_late far above 1e-3: fluid, decided (the old rule
    said "run too short" for 2/Dr and 4/Dr), whatever D_eff's own trust."""
    lab, cb = _label(0.0, span, seed)
    assert cb.ratio > 1.0 and cb.p_broken > 0.99 and cb.lag <= span
    assert cb.D_late / D0 > 0.1
    assert lab.code == PHASE_FLUID and lab.confidence > 0.95, lab.reason


@pytest.mark.parametrize("span", [200, 400, 800])
def test_caged_abps_never_read_fluid(span):
    """Harmonic cages: cage-relative MSD stays at ~0.01 a^2 and F_s near 0.85; never
    fluid (solid where D_eff is trustworthy over 8/Dr, else undetermined)."""
    lab, cb = _label(0.1, span, 3)
    assert cb.ratio < 0.05 and cb.p_broken < 1e-6
    assert cb.fs > 0.7 and not np.isfinite(cb.tau_alpha)
    assert lab.code in (PHASE_SOLID, PHASE_UNDETERMINED)
    if span < 800:
        assert lab.code == PHASE_UNDETERMINED and "no cage broken" in lab.reason


def test_f_s_of_free_abps_relaxes_and_tau_alpha_is_where_it_crosses_one_over_e():
    lab, cb = _label(0.0, 400, 4)
    assert cb.F_s[0] > 0.9 and cb.fs < 0.1
    i = np.searchsorted(cb.lags, cb.tau_alpha)
    assert cb.F_s[i - 1] >= np.exp(-1) >= cb.F_s[i]


def test_asymmetric_rule():
    """With broken cages D_eff_cr_late decides (both sides); without them D_eff can
    decide only "solid"; a broken cage without a slope past it, or no evidence, is
    undetermined."""
    late = {"D_late": 5e-3, "D_late_err": 1e-3}
    fluid = classify_phase(5e-3, 1e-3, 3.6, 0.01, cage_broken=0.999, **late)
    assert fluid.code == PHASE_FLUID and fluid.confidence > 0.99
    soft = classify_phase(5e-3, 1e-3, 3.9, 0.01, cage_broken=0.999, **late)
    assert soft.code == PHASE_SOFT_FLUID
    no_slope = classify_phase(5e-3, 1e-3, 3.6, 0.01, cage_broken=0.999)
    assert no_slope.code == PHASE_UNDETERMINED and "too few lags" in no_slope.reason
    near = classify_phase(5e-3, 1e-3, 3.6, 0.01, cage_broken=0.999, D_late=1.5e-3, D_late_err=1e-3)
    assert near.code == PHASE_UNDETERMINED and "solid threshold" in near.reason
    near_q = classify_phase(5e-3, 1e-3, 3.812, 0.01, cage_broken=0.999, **late)
    assert near_q.code == PHASE_UNDETERMINED and "3.81" in near_q.reason
    no_cage = classify_phase(5e-2, 1e-3, 3.6, 0.01, cage_broken=0.0, cage_note="no cage broken within the window")
    assert no_cage.code == PHASE_UNDETERMINED and "reads fluid" in no_cage.reason
    solid = classify_phase(1e-4, 2e-4, 3.6, 0.01, cage_broken=0.0)
    assert solid.code == PHASE_SOLID and solid.confidence > 0.99
    untrusted = classify_phase(1e-4, 2e-4, 3.6, 0.01, diffusion_ok=False, diffusion_note="too short",
                               cage_broken=0.0)
    assert untrusted.code == PHASE_UNDETERMINED and "too short" in untrusted.reason
    slow = classify_phase(5e-3, 1e-3, 3.6, 0.01, cage_broken=0.999, D_late=2e-4, D_late_err=2e-4)
    assert slow.code == PHASE_SOLID and "D_eff_cr_late" in slow.reason
    no_evidence = classify_phase(1e-4, 2e-4, 3.6, 0.01, cage_broken=float("nan"))
    assert no_evidence.code == PHASE_SOLID


def test_the_d_eff_bound_of_a_broken_cage_gates_nothing():
    """Broken cages whose a^2 / (4 t* D0) is only 4e-3 (the old rule's blind band) are
    decided by D_eff_cr_late: 2e-3 +- 2e-4 is fluid."""
    from fcsweep.analysis.phase import phase_evidence, phase_label

    sc = {"cage_msd_ratio": 3.0, "cage_msd_ratio_err": 0.1, "cage_broken_probability": 1.0, "cage_lag": 200.0,
          "cage_d_eff_bound": 0.004, "D_eff_cr_late": 2e-3, "D_eff_cr_late_err": 2e-4, "q_mean": 3.6,
          "q_mean_err": 0.01}
    p, note = cage_evidence(sc)
    assert p > 0.999
    lab = phase_label(phase_evidence(sc))
    assert lab.code == PHASE_FLUID and lab.confidence > 0.95, lab.reason


def test_stationary_series_is_not_cut_by_equilibration_detection():
    """A stationary AR(1) (phi = 0.9) keeps all its samples in >= 90 of 100 cases (the old
    marginal-standard-error rule alone cut up to half of them, measured 10 % of the D_eff
    window of free ABPs); a series with a transient is still cut (test_stats)."""
    rng = np.random.default_rng(5)
    kept = sum(detect_equilibration(ar1(0.9, 1000, rng)) == 0 for _ in range(100))
    assert kept >= 90


def _model_label(eta, v0, time_units=500.0, every=400, N=256):
    """The phase rule on a real run of the model (Dr = 0.01, binary rule, frames every
    2 time units, the first 20 % dropped as the pipeline's transient)."""
    from fcsweep.analysis.stats import time_average
    from fcsweep.model.shape import shape_index
    from fcsweep.simulation import Simulation

    s = Simulation.from_lattice(N, eta=eta, v0=v0, Dr=DR, seed=3)
    frames = int(time_units / (every * s.params.dt))
    x, q = [], []
    for _ in range(frames):
        s.advance(every)
        x.append(s.state.unwrapped().copy())
        q.append(shape_index(s.state.a, s.state.b, points=128).mean())
    keep = slice(frames // 5, None)
    x = np.array(x)[keep]
    t = np.arange(len(x)) * every * s.params.dt
    box = s.params.box
    est = estimate_diffusion(t, x, Dr=DR)
    cb = cage_breaking(t, x, box)
    D0m = free_diffusion(v0, DR)
    sc = cb.scalars(v0, DR)
    p, note = cage_evidence(sc)
    qa = time_average(np.array(q)[keep])
    return classify_phase(est.D / D0m, est.D_err / D0m, qa.mean, qa.err,
                          diffusion_ok=est.long_enough and est.diffusive, diffusion_note="D_eff not trusted",
                          cage_broken=p, cage_note=note, D_late=sc["D_eff_cr_late"],
                          D_late_err=sc["D_eff_cr_late_err"]), cb


@pytest.mark.slow
def test_model_fluid_is_decided_after_500_time_units_and_the_crystal_is_not_called_fluid():
    """N = 256, Dr = 0.01, 500 time units (400 analysed, half the 8/Dr a D_eff label
    needs): eta = 0.03, v0 = 0.06 leaves its cages and reads a fluid phase; the crystal at
    eta = 0.1, v0 = 0.01 keeps them and is not called fluid."""
    fluid, cb = _model_label(0.03, 0.06)
    assert cb.p_broken > 0.99 and fluid.code in (PHASE_FLUID, PHASE_SOFT_FLUID), fluid.reason
    crystal, cb = _model_label(0.1, 0.01)
    assert cb.ratio < 0.1
    assert crystal.code not in (PHASE_FLUID, PHASE_SOFT_FLUID), crystal.reason


def _reference_curves(x, lags, L, k, n_origins, cells=None):
    """The cage-relative curves the plain way: lag by lag, each origin tessellated where met."""
    from scipy.special import j0

    from fcsweep.analysis.voronoi import voronoi_neighbors
    T, N = x.shape[:2]
    msd, fs = np.zeros(lags.size), np.zeros(lags.size)
    for q, m in enumerate(lags):
        origins = np.unique(np.linspace(0, T - 1 - m, min(n_origins, T - m)).astype(int))
        for o in origins:
            vn = voronoi_neighbors(np.mod(x[o], L), L)
            deg = np.maximum(np.bincount(vn.i, minlength=N), 1)[:, None]
            use = np.ones(N, bool) if cells is None else cells(x[o])
            d = x[o + m] - x[o]
            nb = np.zeros((N, 2))
            np.add.at(nb, vn.i, d[vn.j])
            s = np.sum((d - nb / deg) ** 2, axis=1)[use]
            msd[q] += s.mean() / origins.size
            fs[q] += j0(k * np.sqrt(s)).mean() / origins.size
    return msd, fs


@pytest.mark.parametrize("cache_bytes", [256 << 20, 0])
def test_origin_by_origin_curves_equal_the_lag_by_lag_loop_bit_for_bit(monkeypatch, cache_bytes):
    """cage_breaking tessellates each origin once and keeps shells up to a byte budget
    (memory at N = 10^5); the curves must be those of the plain loop, whatever the budget,
    on a window where the cages break (so lags are added past t*) and with counted cells."""
    from fcsweep.analysis import cage
    monkeypatch.setattr(cage, "SHELL_CACHE_BYTES", cache_bytes)
    frames = 101
    t = np.arange(frames) * 2.0
    x = abp_positions(256, frames, 2.0, v0=V0, Dr=DR, substeps=4, rng=np.random.default_rng(11))
    cells = (lambda p: np.mod(p[:, 0], BOX[0]) < 30.0)
    for counted in (None, cells):
        cb = cage_breaking(t, x, BOX, cells=counted)
        assert cb.lags.size > 16  # lags were added past t*: the origins' shells were reused
        lags = np.rint(cb.lags / 2.0).astype(int)
        msd, fs = _reference_curves(x, lags, np.asarray(BOX), 2 * np.pi / cb.spacing, cage.N_ORIGINS, counted)
        np.testing.assert_array_equal(cb.cr_msd, msd)
        np.testing.assert_array_equal(cb.F_s, fs)
