"""Calibrated Fisher exponent of the percolation cuts, against exact site percolation.

Usage (from campaigns): python percolation_tau.py percolation_long/phase_diagram.nc [more.nc ...]

For every (eta, N) of each dataset: tau from fcsweep.analysis.percolation.fit_fisher_exponent
on the pooled cluster_size_distribution (window, error, amplitude a, goodness of fit, flag),
and the same estimator on exact site percolation of the triangular lattice with the same N
(L = sqrt(N), periodic) at p = 1/2 (critical) and at p = rho_d of that point (the null
model "defects = independent sites at density rho_d"), with the mean largest-cluster
fraction P_max of those samples beside the dataset's.  Then the first estimators of
percolation_long.py (truncated pure power-law MLE and log-binned LSQ) on exact critical
samples, to show their finite-size bias.  Exact samples come from tests/percolation_lattice.py
(seeded; 2000 realisations at N = 1024, 8000 at N = 256, 500 at N = 4096).
"""
import pathlib
import sys

import numpy as np
import xarray as xr

from percolation_long import window_fits

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "tests"))
from percolation_lattice import cluster_counts  # noqa: E402

from fcsweep.analysis.percolation import TAU_2D, fit_fisher_exponent  # noqa: E402

REALISATIONS = {256: 8000, 1024: 2000, 4096: 500}


def describe(fit):
    """One-line summary of a FisherFit."""
    if not np.isfinite(fit.tau_err):
        return f"tau undetermined ({fit.reason})"
    pull = (fit.tau - TAU_2D) / fit.tau_err
    flag = f" FLAG: {fit.reason}" if fit.reason else ""
    return (f"tau = {fit.tau:.3f} +- {fit.tau_err:.3f} (profile [{fit.tau_lo:.3f}, {fit.tau_hi:.3f}], "
            f"sys {fit.tau_err_sys:.3f}) a = {fit.amplitude:.2f} window [{fit.s_min}, {fit.s_max}] "
            f"n = {fit.n_clusters} p = {fit.p_value:.2g} (tau - 187/91)/err = {pull:+.1f}{flag}")


def exact(N, p, seed):
    """FisherFit, counts and 'P_max = mean +- err' of exact triangular-lattice site percolation (N sites, p)."""
    L = int(round(np.sqrt(N)))
    big = []
    counts = cluster_counts(L, REALISATIONS[N], p=p, seed=seed, largest=big)
    big = np.array(big) / (L * L)
    pmax = f"P_max = {big.mean():.3f} +- {big.std(ddof=1) / np.sqrt(big.size):.3f}"
    return fit_fisher_exponent(counts, L * L), counts, pmax


def main(paths):
    """Print the tables."""
    print(f"# 187/91 = {TAU_2D:.4f}; errors assume independent frames (inefficiency g = 1)")
    for path in paths:
        ds = xr.open_dataset(path).squeeze("replicate", drop=True).squeeze("v0", drop=True)
        print(f"\n## {path}")
        for N in ds.N.values:
            crit, _, pmax = exact(int(N), 0.5, seed=int(N))
            print(f"exact critical, N = {N}: {pmax}; {describe(crit)}")
            for eta in ds.eta.values:
                s = ds.sel(eta=eta, N=N)
                c = np.nan_to_num(s.cluster_size_distribution.values)[:int(N)]
                rho = float(s.rho_d)
                ref, _, pmax = exact(int(N), rho, seed=int(N) + int(round(1e4 * rho)))
                print(f"N = {N} eta = {eta:g} rho_d = {rho:.3f} clusters = {int(c.sum())}:\n"
                      f"    data:                      P_max = {float(s.largest_cluster_fraction):.3f}; "
                      f"{describe(fit_fisher_exponent(c, int(N)))}\n"
                      f"    exact at p = rho_d:        {pmax}; {describe(ref)}")
    print("\n## first estimators (percolation_long.py) on exact critical samples")
    for N in (1024, 4096):
        _, counts, _ = exact(N, 0.5, seed=N)
        print("  ".join([f"N = {N}, {int(counts.sum())} clusters, LSQ(bins) / MLE:"]
                        + window_fits(np.arange(1, N + 1), counts)))


if __name__ == "__main__":
    main(sys.argv[1:])
