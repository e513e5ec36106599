"""Time-series statistics against series with known answers (AR(1), replicates)."""

import numpy as np
import pytest
from synthetic import ar1

from fcsweep.analysis.stats import combine, detect_equilibration, integrated_time, time_average

PHI = 0.9
TAU = (1 + PHI) / (1 - PHI)  # 19 samples


def test_ar1_tau_and_error_are_honest():
    """300 AR(1) series of 2000 samples (n / tau = 105): the quoted error of the mean
    matches the scatter of the means to 20 % (the scatter itself is known to 4 %, the mean
    quoted error to ~1 %; measured 0.99), and the median tau is within 20 % of 19."""
    rng = np.random.default_rng(11)
    res = [time_average(ar1(PHI, 2000, rng)) for _ in range(300)]
    means = np.array([r.mean for r in res])
    errs = np.array([r.err for r in res])
    assert np.mean(errs) / np.std(means, ddof=1) == pytest.approx(1.0, abs=0.2)
    assert np.median([r.tau for r in res]) == pytest.approx(TAU, rel=0.2)
    assert np.median([r.n_eff for r in res]) == pytest.approx(2000 / TAU, rel=0.25)


def test_ar1_short_series_error_is_not_too_small():
    """n / tau = 16: the mean-subtraction bias of the autocorrelation is corrected
    (without it the errors are ~30 % small); honest to 25 %."""
    rng = np.random.default_rng(12)
    res = [time_average(ar1(PHI, 300, rng)) for _ in range(300)]
    ratio = np.mean([r.err for r in res]) / np.std([r.mean for r in res], ddof=1)
    assert 0.75 < ratio < 1.25


def test_transient_is_detected_and_cut():
    """A series starting 60 sigma_eps away (14 stationary sds) relaxes in ~60 samples:
    equilibration detection cuts it, so the mean is unbiased within its error,
    while keeping everything biases it by several errors."""
    rng = np.random.default_rng(13)
    cut, kept = [], []
    for _ in range(100):
        x = ar1(PHI, 1000, rng, x0=60.0)
        r = time_average(x)
        assert r.start > 0
        cut.append(r.mean / r.err)
        k = time_average(x, equilibrate=False)
        kept.append(k.mean / k.err)
    assert abs(np.mean(cut)) < 0.4
    assert np.mean(kept) > 0.6  # measured 0.80: the transient also inflates the error it biases


def test_stationary_series_keeps_almost_everything():
    rng = np.random.default_rng(14)
    starts = [detect_equilibration(ar1(0.5, 1000, rng)) for _ in range(50)]
    assert np.median(starts) == 0


def test_independent_samples_and_degenerate_input():
    rng = np.random.default_rng(15)
    assert integrated_time(rng.normal(size=5000)) == pytest.approx(1.0, abs=0.15)
    c = time_average(np.full(50, 3.5))
    assert c.mean == 3.5 and c.err == 0.0 and c.tau == 1.0
    assert np.isnan(time_average([1.0, 2.0]).err)
    with pytest.raises(ValueError, match="non-finite"):
        time_average([1.0, np.nan, 2.0])


def test_combine_replicates_checks_errors_against_scatter():
    rng = np.random.default_rng(16)
    truth, sigma = 2.0, 0.1
    honest = [combine(truth + sigma * rng.normal(size=8), np.full(8, sigma)) for _ in range(400)]
    # chi2/dof of honest errors averages 1; the combined error is sigma / sqrt(8) or more
    assert np.mean([c.chi2_dof for c in honest]) == pytest.approx(1.0, abs=0.1)
    assert all(c.err >= sigma / np.sqrt(8) - 1e-12 for c in honest)
    # errors quoted 3x too small: chi2/dof ~ 9 and the scale factor restores the error
    small = [combine(truth + sigma * rng.normal(size=8), np.full(8, sigma / 3)) for _ in range(400)]
    assert np.mean([c.chi2_dof for c in small]) > 5
    pulls = np.array([(c.mean - truth) / c.err for c in small])
    assert np.std(pulls) == pytest.approx(1.0, abs=0.2)


def test_equilibration_cut_of_d_eff_keeps_half_the_frames():
    """The D_eff window starts at the latest series' equilibration start, but never past the
    middle of the frames after the transient: a run of 2 x 8/Dr after the transient keeps a
    window of 8/Dr even when a coarse series' start lands a few frames beyond its half
    (the N = 1024 crystal at eta = 0.01, v0 = 0.01 read 792 of the 800 time units it needs)."""
    from fcsweep.analysis.run_observables import equilibrated_frames

    frames = np.arange(200, 1001)  # 801 frames after the transient, 2 time units apart
    assert equilibrated_frames(frames, [620, 300]).tolist() == list(range(600, 1001))
    assert (equilibrated_frames(frames, [620])[-1] - equilibrated_frames(frames, [620])[0]) * 2 == 800
    assert equilibrated_frames(frames, [350, 420]).tolist() == list(range(420, 1001))
    assert equilibrated_frames(frames, []).tolist() == frames.tolist()
    assert equilibrated_frames(frames, [0]).tolist() == frames.tolist()
