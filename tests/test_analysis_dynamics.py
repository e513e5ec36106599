"""Known answers for the MSD, D_eff, shape index and phase labels (fcsweep.analysis)."""

import numpy as np
import pytest
from scipy.integrate import quad

from fcsweep.analysis.diffusion import _slope_weights, effective_diffusion, estimate_diffusion, free_diffusion
from fcsweep.analysis.msd import drift_subtracted, log_lag_indices, msd_curve
from fcsweep.analysis.phase import (PHASE_FLUID, PHASE_SOFT_FLUID, PHASE_SOLID, PHASE_UNKNOWN,
                                    percolation_code, phase_code, phase_name)
from fcsweep.analysis.shapes import q_statistics, shape_indices
from fcsweep.model.lattice import hexagonal_lattice
from fcsweep.model.shape import Q_CIRCLE


def active_brownian(N, v0, Dr, dt, steps, every, seed):
    """Free active Brownian particles, Euler-Maruyama: dr = v0 e(theta) dt,
    dtheta = sqrt(2 Dr dt) xi.  Returns unwrapped positions every ``every`` steps."""
    rng = np.random.default_rng(seed)
    th = rng.uniform(0, 2 * np.pi, N)
    pos = rng.uniform(0, 50, (N, 2))
    out = [pos.copy()]
    for _ in range(steps // every):
        dth = np.sqrt(2 * Dr * dt) * rng.standard_normal((every, N))
        ths = th + np.cumsum(dth, axis=0) - dth  # angle at the start of each step
        pos = pos + v0 * dt * np.stack([np.cos(ths).sum(0), np.sin(ths).sum(0)], -1)
        th = th + dth.sum(0)
        out.append(pos.copy())
    return np.array(out)


def direct_msd(x):
    T = len(x)
    return np.array([0.0] + [np.mean(np.sum((x[k:] - x[:-k]) ** 2, -1)) for k in range(1, T)])


def test_msd_matches_direct_window_sum():
    # freud's FFT window MSD (single precision inside) against the O(T^2) float64 sum
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.normal(scale=0.3, size=(300, 50, 2)), axis=0) + 1e3
    m, blocks = msd_curve(x, subtract_drift=False, n_blocks=4)
    d = direct_msd(x - x[:1])
    mean_disp = np.array([0.0] + [np.sum(np.mean(x[k:] - x[:-k], axis=(0, 1)) ** 2)
                                  for k in range(1, 300)])
    assert np.allclose(m[1:], (d - mean_disp)[1:], rtol=2e-3)
    assert blocks.shape == (4, 300)
    # after drift subtraction the mean displacement of every frame pair vanishes
    ds = drift_subtracted(x)
    assert np.allclose(ds.mean(axis=1), 0.0, atol=1e-9)


def test_free_active_brownian_particles_have_unit_D_eff():
    # MSD -> 4 D0 t with D0 = v0^2 / (2 Dr) (docs/model.md property 6).  T = 200 / Dr:
    # 8 time blocks of 25 / Dr; 1000 particles.
    v0, Dr = 1.0, 1.0
    x = active_brownian(1000, v0, Dr, dt=0.02, steps=10000, every=10, seed=2)
    m, _ = msd_curve(x)
    lag = np.arange(len(m)) * 0.2
    fit = estimate_diffusion(lag, x, Dr=Dr)
    D_eff, err = effective_diffusion(fit.D, fit.D_err, v0, Dr)
    assert fit.n_time_blocks == 8 and fit.long_enough and fit.diffusive
    assert 0 < err < 0.05
    assert abs(D_eff - 1.0) < 3 * err
    # ballistic start: MSD(t) = v0^2 t^2 for t << 1/Dr
    assert m[1] == pytest.approx((v0 * 0.2) ** 2, rel=0.1)


def test_crystal_msd_saturates_and_is_solid():
    # lattice sites with independent Ornstein-Uhlenbeck vibrations (amplitude 0.02 R0,
    # relaxation time 2) -> MSD plateaus at 2 * 2 sigma^2 and D_eff << 1e-3
    pos, box = hexagonal_lattice(256)
    rng = np.random.default_rng(5)
    T, sig, tau, dt = 1000, 0.02, 2.0, 0.5
    f = np.exp(-dt / tau)
    u = np.zeros((T, 256, 2))
    u[0] = sig * rng.standard_normal((256, 2))
    for t in range(1, T):
        u[t] = f * u[t - 1] + sig * np.sqrt(1 - f * f) * rng.standard_normal((256, 2))
    m, _ = msd_curve(pos + u)
    lag = np.arange(T) * dt
    plateau = 4 * sig ** 2 * (1 - 1 / 256)
    assert m[200] == pytest.approx(plateau, rel=0.1)
    assert m[450] == pytest.approx(m[200], rel=0.1)
    fit = estimate_diffusion(lag, pos + u, Dr=0.01)  # 500 time units: one block of 4 / Dr
    D_eff, err = effective_diffusion(fit.D, fit.D_err, 0.03, 0.01)
    assert abs(D_eff) + 2 * err < 1e-3
    assert phase_code(D_eff, 3.6) == PHASE_SOLID


def test_msd_model_fit_recovers_exact_active_brownian_and_caged_curves():
    """The block fit is exact on the model's own form: the free-ABP MSD
    4 D0 [t - (1 - exp(-Dr t)) / Dr] gives D0, a caged one (saturating on 1/Dr) gives 0."""
    t = np.arange(400) * 0.5
    Dr, D0 = 0.05, 0.3
    free = 4 * D0 * (t - (1 - np.exp(-Dr * t)) / Dr)
    caged = 0.16 * (1 - np.exp(-Dr * t))
    lags = np.arange(40, 200)
    D = np.stack([free, caged])[:, lags] @ _slope_weights(lags, t, 1 / Dr)
    assert D[0] == pytest.approx(D0, rel=1e-9) and abs(D[1]) < 1e-12
    few = estimate_diffusion(t[:4], np.zeros((4, 3, 2)), Dr=Dr)
    assert np.isnan(few.D) and not few.long_enough
    assert free_diffusion(0.03, 0.01) == pytest.approx(0.045)


def test_log_lags():
    lags = log_lag_indices(1000, 50)
    assert lags[0] == 0 and lags[1] == 1 and lags[-1] == 999
    assert np.all(np.diff(lags) > 0)


def test_circle_shape_index_is_two_sqrt_pi():
    a = np.zeros((3, 5))
    assert np.allclose(shape_indices(a, a), Q_CIRCLE, rtol=1e-12)
    assert np.allclose(shape_indices(np.zeros((4, 0)), np.zeros((4, 0))), Q_CIRCLE)


@pytest.mark.parametrize("c", [0.2, 0.5, 0.8])
def test_mode2_perimeter_matches_adaptive_quadrature(c):
    # R = a0 + c cos 2 phi, a0 = sqrt(1 - c^2/2); c = 0.8 is 98% of the bound sqrt(2/3)
    a0 = np.sqrt(1 - c * c / 2)
    P, _ = quad(lambda p: np.hypot(a0 + c * np.cos(2 * p), -2 * c * np.sin(2 * p)),
                0, 2 * np.pi, epsabs=1e-13, epsrel=1e-13, limit=200)
    a = np.array([[c, 0, 0, 0, 0]])
    q = shape_indices(a, np.zeros_like(a))
    # 1024-point periodic trapezoid: spectral; at c = 0.8 (R_min = 0.025) still 1e-9
    assert q[0] * np.sqrt(np.pi) == pytest.approx(P, rel=1e-10 if c < 0.7 else 1e-8)


def test_q_statistics_histogram_is_a_density():
    rng = np.random.default_rng(1)
    q = rng.uniform(3.55, 4.2, size=(20, 100))
    s = q_statistics(q)
    assert np.sum(s["q_hist"] * np.diff(s["q_edges"])) == pytest.approx(1.0)
    assert s["q_mean"] == pytest.approx(q.mean())
    assert s["q_frac_above"] == pytest.approx(np.mean(q > 3.81))


def test_phase_labels():
    D = np.array([1e-4, 0.1, 0.1, np.nan, 0.1])
    q = np.array([3.9, 3.6, 3.9, 3.6, np.nan])
    codes = phase_code(D, q)
    assert list(codes) == [PHASE_SOLID, PHASE_FLUID, PHASE_SOFT_FLUID, PHASE_UNKNOWN,
                           PHASE_UNKNOWN]
    assert phase_name(PHASE_SOFT_FLUID) == "soft-fluid"
    assert list(percolation_code([0.4, 0.6, np.nan])) == [0, 1, -1]


def test_shape_indices_in_blocks_match_each_cell_alone():
    # 700 cells: blocks of 256 with a ragged last one; amplitudes up to the projection margin
    from fcsweep.model.shape import ADMISSIBLE_BOUND, amplitude_sum, shape_index

    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(2, 7, 100, 5))
    s = amplitude_sum(a, b)
    f = rng.uniform(0.0, 0.99, size=s.shape) * ADMISSIBLE_BOUND / s
    a, b = a * f[..., None], b * f[..., None]
    q = shape_indices(a, b)
    assert q.shape == (7, 100)
    one = np.array([shape_index(a[i, j], b[i, j], points=4096) for i, j in [(0, 0), (2, 55), (6, 99)]])
    assert q[[0, 2, 6], [0, 55, 99]] == pytest.approx(one, rel=1e-7)  # 1024 vs 4096 points at the bound
    assert np.array_equal(q.ravel(), shape_indices(a.reshape(-1, 5), b.reshape(-1, 5), chunk=10**6))


@pytest.mark.parametrize("s0", [0.05, 0.19, 0.2, 0.34, 0.35])
def test_fewer_points_for_small_shapes_stay_at_round_off(s0):
    # random and single-mode shapes at amplitude sum s0, up to each tier's edge
    from fcsweep.model.shape import amplitude_sum, shape_index

    rng = np.random.default_rng(11)
    a, b = rng.normal(size=(2, 500, 5))
    for k in range(5):
        a[k * 20:(k + 1) * 20] = np.eye(5)[k]
        b[k * 20:(k + 1) * 20] = 0.0
    f = s0 / amplitude_sum(a, b)
    a, b = a * f[:, None], b * f[:, None]
    assert np.abs(shape_indices(a, b) - shape_index(a, b, points=4096)).max() < 5e-14
