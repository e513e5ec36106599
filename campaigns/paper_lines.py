"""Where the soft-fluid line <q> = 3.81 and the percolation line rho_d = 1/2 cross eta at each
v0 (Fig. 3d), from an aggregated phase-diagram dataset: python campaigns/paper_lines.py DATASET.nc

Linear interpolation between the two grid points that bracket the level; the 1-sigma error
propagates the errors of both points (correlation in time included in them)."""

import sys

import numpy as np
import xarray as xr

Q_STAR, RHO_C = 3.81, 0.5


def crossing(eta, y, err, level):
    """eta where y crosses level (first bracket in eta order) and its error, or None."""
    f = y - level
    for i in range(len(eta) - 1):
        f1, f2 = f[i], f[i + 1]
        if np.isfinite(f1) and np.isfinite(f2) and f1 * f2 <= 0 and f1 != f2:
            d = eta[i + 1] - eta[i]
            x = eta[i] + d * f1 / (f1 - f2)
            s = np.hypot(d * f2 / (f1 - f2) ** 2 * err[i], d * f1 / (f1 - f2) ** 2 * err[i + 1])
            return x, s
    return None


def _fmt(c, y, level, name):
    if c is not None:
        return f"{c[0]:.4f} ± {c[1]:.4f}"
    side = "above" if np.nanmin(y) > level else "below" if np.nanmax(y) < level else "mixed"
    return f"none in the grid ({name} {side} {level:g} at every η)"


for path in sys.argv[1:]:
    ds = xr.open_dataset(path).isel(replicate=0)
    print(f"\n{path}\n")
    print("| v0 | N | η at ⟨q⟩ = 3.81 | η at ρ_d = 1/2 | difference / σ |")
    print("|---|---|---|---|---|")
    eta = ds.eta.values
    for N in ds.N.values:
        for v0 in ds.v0.values:
            s = ds.sel(v0=v0, N=N)
            q, qe = s.q_mean.values, s.q_mean_err.values
            r, re = s.rho_d.values, s.rho_d_err.values
            cq, cr = crossing(eta, q, qe, Q_STAR), crossing(eta, r, re, RHO_C)
            diff = f"{(cq[0] - cr[0]) / np.hypot(cq[1], cr[1]):+.1f}" if cq and cr else "–"
            print(f"| {v0:g} | {int(N)} | {_fmt(cq, q, Q_STAR, '⟨q⟩')} | {_fmt(cr, r, RHO_C, 'ρ_d')} | {diff} |")
