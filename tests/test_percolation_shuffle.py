"""The shuffled-label control of defect percolation against known answers.

Site percolation with independent labels on a planar triangulation (the Voronoi graph of
points in general position) has threshold 1/2; positively correlated labels that are not
symmetric under exchanging labelled and unlabelled cells move it ("Swiss cheese" labels:
cells not covered by Poisson discs of radius 2.5 spacings percolate near 0.41 at
N = 256-4096); correlated labels that are symmetric (a thresholded Gaussian field) do
not.  Permuting the labels over the cells of the same graph
(:func:`fcsweep.analysis.voronoi.shuffled_defects`) keeps rho and the graph and must give
1/2 back.  Default tests hold the exponents at the 2-D values (finite-range correlations
do not change the universality class) and use two small sizes; the slow ones fit all three
parameters over N = 256, 1024, 4096.
"""

import numpy as np
import pytest
from voronoi_percolation import (gaussian_field_labels, independent_labels, jittered_triangular,
                                 largest_cluster_data, random_points, swiss_cheese_labels)

from fcsweep.analysis.fss import BETA_2D, NU_2D, fss_collapse
from fcsweep.analysis.voronoi import defect_statistics, shuffled_defects

PAPER = {"nu": NU_2D, "beta": BETA_2D}
SMALL = {256: 80, 1024: 40}
LARGE = {256: 100, 1024: 50, 4096: 20}


def cheese(pos, box, p, rng):
    return swiss_cheese_labels(pos, box, p, rng, radius=2.5)


def collapses(data, **kwargs):
    """The collapse of the real and of the shuffled statistic of ``largest_cluster_data``."""
    rho, pm, pe, ps, pse, N = data
    return (fss_collapse(rho, pm, N, pe, seed=1, **kwargs), fss_collapse(rho, ps, N, pse, seed=1, **kwargs))


def test_shuffle_keeps_the_count_and_is_reproducible_per_frame():
    d = np.random.default_rng(3).random(500) < 0.3
    a, b, c = shuffled_defects(d, 7), shuffled_defects(d, 7), shuffled_defects(d, 8)
    assert a.sum() == d.sum() == c.sum()
    assert np.array_equal(a, b) and not np.array_equal(a, c) and not np.array_equal(a, d)


def test_defect_statistics_carry_the_shuffled_series():
    rng = np.random.default_rng(0)
    frames = np.stack([random_points(400, rng)[0] for _ in range(6)])
    box = (20.0, 20.0)
    st = defect_statistics(frames, box, frame_indices=np.arange(10, 16))
    shuf = st["largest_cluster_fraction_shuffled_frames"]
    assert shuf.shape == (6,) and np.all((shuf > 0) & (shuf <= st["rho_d_frames"] + 1e-12))
    assert np.isfinite(st["largest_cluster_fraction_shuffled"]) and st["largest_cluster_fraction_shuffled_err"] >= 0
    again = defect_statistics(frames, box, frame_indices=np.arange(10, 16))
    assert np.array_equal(again["largest_cluster_fraction_shuffled_frames"], shuf)
    # the real statistic does not depend on the seeds
    other = defect_statistics(frames, box)
    assert np.array_equal(other["largest_cluster_fraction_frames"], st["largest_cluster_fraction_frames"])
    with pytest.raises(ValueError, match="one entry per frame"):
        defect_statistics(frames, box, frame_indices=[1, 2])


@pytest.mark.parametrize("points", [random_points, jittered_triangular])
def test_independent_labels_percolate_at_one_half_real_and_shuffled(points):
    """Measured pulls (rho_c - 1/2) / err over 5 seeds, both graphs, real and shuffled
    (20 fits): rms 1.0, extremes -1.9 and 2.2; hence 3 errors."""
    real, shuf = collapses(largest_cluster_data(points, independent_labels, SMALL, np.arange(0.40, 0.601, 0.02)),
                           fixed=PAPER, n_bootstrap=30)
    for fit in (real, shuf):
        assert fit.reason == "" and 0 < fit.rho_c_err < 0.02, fit
        assert abs(fit.rho_c - 0.5) <= 3 * fit.rho_c_err, fit


def test_correlated_labels_percolate_below_one_half_and_the_shuffle_restores_it():
    """Swiss-cheese labels: over 4 seeds the real threshold read 0.416-0.425, 3.8-8.5 errors
    below 1/2, the shuffled one 0.488-0.505 (pulls -1.8 ... 0.5)."""
    real, shuf = collapses(largest_cluster_data(random_points, cheese, SMALL, np.arange(0.26, 0.601, 0.02)),
                           fixed=PAPER, n_bootstrap=30)
    assert real.reason == "" and shuf.reason == ""
    assert real.rho_c + 3 * real.rho_c_err < 0.5, real
    assert abs(shuf.rho_c - 0.5) <= 3 * shuf.rho_c_err, shuf
    assert shuf.rho_c - real.rho_c > 3 * np.hypot(real.rho_c_err, shuf.rho_c_err)


@pytest.mark.slow
@pytest.mark.parametrize("points", [random_points, jittered_triangular])
def test_free_collapse_of_independent_labels_gives_one_half(points):
    """All three parameters free, N = 256-4096: measured rho_c 0.493-0.505 (pulls -1.6 ... 0.9)."""
    real, shuf = collapses(largest_cluster_data(points, independent_labels, LARGE, np.arange(0.40, 0.601, 0.01)),
                           n_bootstrap=20)
    for fit in (real, shuf):
        assert fit.reason == "", fit
        assert abs(fit.rho_c - 0.5) <= 3 * fit.rho_c_err, fit
        assert abs(fit.nu - NU_2D) < 0.4, fit


@pytest.mark.slow
def test_symmetric_correlated_labels_still_percolate_at_one_half():
    """A thresholded Gaussian field (correlation length 2 spacings; neighbours agree in 78 %
    of bonds against 50 % for independent labels) is symmetric under exchanging labelled and
    unlabelled cells: measured 0.5018 +- 0.0064 (real), 0.5002 +- 0.0042 (shuffled).  With
    the exponents fixed and N = 256, 1024 over 5 seeds: pulls -1.3 ... 2.0."""
    real, shuf = collapses(largest_cluster_data(random_points, gaussian_field_labels, LARGE,
                                                np.arange(0.40, 0.601, 0.01)), n_bootstrap=20)
    for fit in (real, shuf):
        assert fit.reason == "", fit
        assert abs(fit.rho_c - 0.5) <= 3 * fit.rho_c_err, fit


@pytest.mark.slow
def test_free_collapse_of_correlated_labels_is_shifted_and_the_shuffle_is_not():
    """Measured: real 0.407 +- 0.013, shuffled 0.497 +- 0.014 (N = 256-4096, free exponents)."""
    real, shuf = collapses(largest_cluster_data(random_points, cheese, LARGE, np.arange(0.20, 0.601, 0.01)),
                           n_bootstrap=20)
    assert real.rho_c + 3 * real.rho_c_err < 0.5, real
    assert abs(shuf.rho_c - 0.5) <= 3 * shuf.rho_c_err, shuf


def _scaling(rho, N, rho_c, nu, beta):
    """P_max of exact finite-size scaling, P_max L^(beta/nu) = f((rho - rho_c) L^(1/nu))."""
    L = np.sqrt(N)
    x = (rho - rho_c) * L ** (1 / nu)
    return (0.3 + 0.5 * np.tanh(0.8 * x) + 0.05 * x ** 2) * L ** (-beta / nu)


def test_aggregate_stores_the_shuffled_collapse_beside_the_real_one():
    """Exactly scaling data, real threshold 0.42 and shuffled 1/2: each collapse returns its
    own within 3e-3 (the error of noiseless data, test_fss)."""
    import xarray as xr

    from fcsweep.results.reduce import FSS_SHUFFLED_VARS, FSS_VARS, fss_collapses

    sizes = np.array([256, 1024, 4096])
    rho = np.broadcast_to(np.linspace(0.30, 0.60, 31)[:, None, None], (31, 1, 3))
    N = np.broadcast_to(sizes[None, None, :].astype(float), rho.shape)
    dims = ("eta", "v0", "N")
    err = (dims, np.full(rho.shape, 1e-3))
    ds = xr.Dataset({"rho_d_rmean": (dims, rho.copy()),
                     "largest_cluster_fraction_rmean": (dims, _scaling(rho, N, 0.42, 1.1, 0.2)),
                     "largest_cluster_fraction_rmean_err": err,
                     "largest_cluster_fraction_shuffled_rmean": (dims, _scaling(rho, N, 0.5, NU_2D, BETA_2D)),
                     "largest_cluster_fraction_shuffled_rmean_err": err},
                    coords={"eta": np.arange(31.0), "v0": [0.06], "N": sizes.astype(np.int32)})
    old = ds.drop_vars(["largest_cluster_fraction_shuffled_rmean", "largest_cluster_fraction_shuffled_rmean_err"])
    fss_collapses(ds, n_bootstrap=0)
    for name in FSS_VARS + FSS_SHUFFLED_VARS + ("fss_reason", "fss_shuffled_reason"):
        assert ds[name].dims == ("v0",) and ds[name].attrs["long_name"], name
    assert ds["fss_rho_c"].item() == pytest.approx(0.42, abs=3e-3)
    assert ds["fss_shuffled_rho_c"].item() == pytest.approx(0.5, abs=3e-3)
    assert ds["fss_shuffled_nu"].item() == pytest.approx(NU_2D, rel=0.05)
    assert "defect correlations" in ds["fss_shuffled_rho_c"].attrs["long_name"]
    fss_collapses(old, n_bootstrap=0)  # a dataset without the shuffled statistic: only the real collapse
    assert "fss_rho_c" in old and "fss_shuffled_rho_c" not in old
