"""Percolation-cut tables and cluster-size exponent fits for docs/reproduction.md.

Usage: python percolation_long.py PHASE_DIAGRAM.nc [RUNS_DIR] [OUT.png]

Prints, per (eta, N): P_max, rho_d, <q>, fraction q > 3.81, and whether
rho_d > 1/2 and <q> > 3.81 give the same label. Then the cluster-size exponent tau of
n(s) ~ s^-tau from the pooled cluster counts (all analysed frames) by two methods over
the same documented size windows [s_min, s_max]:

- "LSQ": least-squares slope of log n(s) on log s, n(s) log-binned in bins
  [2^k, 2^(k+1)) (clusters per unit size, bin centre the geometric mean), bins fully
  inside the window and holding >= 3 clusters;
- "MLE": maximum likelihood for a discrete power law truncated to [s_min, s_max]
  (p(s) = s^-tau / sum_{s'=s_min}^{s_max} s'^-tau), error from the Fisher information
  (1 / sqrt(n Var_tau[log s])); clusters from different frames of one run are
  correlated, so this error is a lower bound.

With RUNS_DIR (<output>/runs), also recomputes rho_d and P_max per frame from the
trajectories (fcsweep.analysis.voronoi) and prints their means over successive quarters
of the run, to judge equilibration; with OUT.png, plots rho_d(t) and n(s).
"""
import sys

import numpy as np
import xarray as xr
from scipy.optimize import minimize_scalar

from summarize import slope

WINDOWS = [(2, 32), (2, 64), (4, 128), (2, 128)]


def lsq_tau(sz, cs, smin, smax):
    """Log-binned least-squares tau over bins [2^k, 2^(k+1)) inside [smin, smax]."""
    x, y = [], []
    for k in range(0, 20):
        lo, hi = 2 ** k, 2 ** (k + 1)
        if lo < smin or hi - 1 > smax:
            continue
        m = (sz >= lo) & (sz < hi)
        c = cs[m].sum()
        if c >= 3:
            x.append(np.sqrt(lo * (hi - 1)))
            y.append(c / (hi - lo))
    k, n = slope(np.array(x), np.array(y))
    return -k, n


def mle_tau(sz, cs, smin, smax):
    """Discrete truncated power-law MLE of tau on [smin, smax]; returns (tau, err, n)."""
    m = (sz >= smin) & (sz <= smax)
    s, c = sz[m].astype(float), cs[m]
    n = c.sum()
    if n < 10:
        return np.nan, np.nan, int(n)
    grid = np.arange(smin, smax + 1, dtype=float)
    sumlog = (c * np.log(s)).sum()

    def nll(t):
        return t * sumlog + n * np.log((grid ** -t).sum())

    t = minimize_scalar(nll, bounds=(0.0, 5.0), method="bounded").x
    w = grid ** -t
    w /= w.sum()
    var = (w * np.log(grid) ** 2).sum() - (w * np.log(grid)).sum() ** 2
    return t, 1 / np.sqrt(n * var), int(n)


def window_fits(sz, cs):
    """'[s_min,s_max] LSQ(bins) / MLE+-err(n)' for each of WINDOWS."""
    out = []
    for lo, hi in WINDOWS:
        tl, nb = lsq_tau(sz, cs, lo, hi)
        tm, em, n = mle_tau(sz, cs, lo, hi)
        out.append(f"[{lo},{hi}] {tl:.2f}({nb}b) / {tm:.2f}+-{em:.2f}(n={n})")
    return out


def per_frame(traj):
    """rho_d, P_max per frame and times from one trajectory.h5."""
    import h5py

    from fcsweep.analysis.voronoi import defect_clusters, defect_mask, voronoi_neighbors

    with h5py.File(traj, "r") as f:
        pos = f["particles/cells/position/value"][()]
        t = f["particles/cells/position/time"][()]
        box = f["particles/cells/box/edges"][()]
    rho, pm = [], []
    for p in pos:
        vn = voronoi_neighbors(p, box)
        d = defect_mask(vn.n_sides)
        sizes = defect_clusters(d, vn.i, vn.j)
        rho.append(d.mean())
        pm.append(sizes[0] / len(d) if sizes.size else 0.0)
    return t, np.array(rho), np.array(pm)


def main(path, runs=None, out=None):
    """Print the tables (and optionally the time series and figure)."""
    ds = xr.open_dataset(path).squeeze("replicate", drop=True).squeeze("v0", drop=True)
    sz = ds.cluster_size.values
    print("# ", path)
    print("eta N | P_max +- err | rho_d +- err | <q> | q>3.81 | rho_d>1/2 <q>>3.81 same?")
    agree = 0
    for eta in ds.eta.values:
        for N in ds.N.values:
            s = ds.sel(eta=eta, N=N)
            a, b = float(s.rho_d) > 0.5, float(s.q_mean) > 3.81
            agree += a == b
            print(f"{eta:g} {N} | {float(s.largest_cluster_fraction):.3f} +- {float(s.largest_cluster_fraction_err):.3f}"
                  f" | {float(s.rho_d):.3f} +- {float(s.rho_d_err):.3f} | {float(s.q_mean):.4f}"
                  f" | {float(s.q_frac_above):.3f} | {a} {b} {'yes' if a == b else 'NO'}")
    print(f"rho_d > 1/2 <=> <q> > 3.81 at {agree} / {ds.sizes['eta'] * ds.sizes['N']} points")
    print("\ntau fits (LSQ log-binned / MLE truncated discrete), window [s_min, s_max]:")
    for N in ds.N.values:
        for eta in ds.eta.values:
            cs = np.nan_to_num(ds.sel(eta=eta, N=N).cluster_size_distribution.values)
            line = [f"N={N} eta={eta:g} clusters={int(cs.sum())} s_max_seen={int(sz[cs > 0].max()) if cs.any() else 0}:"]
            print("  ".join(line + window_fits(sz, cs)))
    series = {}
    if runs:
        import pathlib
        print("\nper-frame rho_d / P_max, means over quarters of the run (time ranges):")
        for eta in ds.eta.values:
            for N in ds.N.values:
                rid = str(ds.sel(eta=eta, N=N).run_id.values)
                t, rho, pm = per_frame(pathlib.Path(runs) / rid / "trajectory.h5")
                series[(eta, N)] = (t, rho, pm)
                q = np.array_split(np.arange(len(t)), 4)
                print(f"eta={eta:g} N={N}: rho_d " + " ".join(f"{rho[i].mean():.3f}" for i in q)
                      + " | P_max " + " ".join(f"{pm[i].mean():.3f}" for i in q)
                      + " | quarters end at t = " + ", ".join(f"{t[i[-1]]:.0f}" for i in q))
    if out:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        for (eta, N), (t, rho, pm) in series.items():
            ax[0].plot(t, rho, "-" if N == ds.N.values.max() else ":", lw=1, label=f"eta={eta:g} N={N}")
        ax[0].axhline(0.5, color="k", lw=0.5)
        ax[0].set_xlabel("time"); ax[0].set_ylabel(r"$\rho_d$"); ax[0].legend(fontsize=6, ncol=2)
        N = ds.N.values.max()
        for eta in ds.eta.values:
            cs = np.nan_to_num(ds.sel(eta=eta, N=N).cluster_size_distribution.values)
            x, y = [], []
            for k in range(0, 12):
                lo, hi = 2 ** k, 2 ** (k + 1)
                c = cs[(sz >= lo) & (sz < hi)].sum()
                if c > 0:
                    x.append(np.sqrt(lo * (hi - 1))); y.append(c / (hi - lo) / cs.sum())
            ax[1].loglog(x, y, "o-", ms=3, label=f"eta={eta:g}")
        xs = np.array([2, 128])
        ax[1].loglog(xs, 0.5 * xs ** (-187 / 91), "k--", label=r"$s^{-187/91}$")
        ax[1].set_xlabel("cluster size s"); ax[1].set_ylabel(f"n(s) (log-binned, N={N})"); ax[1].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], *(sys.argv[2:4]))
