"""G_r(dx, 0) - 1 and G_6(r) at eta = 0.1 for each v0 of a phase_diagram.nc (the paper's Fig. 4 cut).

Usage: python eta01_correlations.py PHASE_DIAGRAM.nc [PHASE_DIAGRAM.nc ...] OUT.png
(several datasets, e.g. repro_phase.yaml's and repro_hexatic.yaml's, are combined into
one cut, sorted by v0). Prints the log-log slope of |G_6| over r in [2, 13] and in [4, 13] (all bins; the
[4, 13] fit leaves out the dip between the first two neighbour shells, r ~ 2.5-3.4, which
biases the [2, 13] slope when the shell structure is sharp) and of the lattice-shell
peaks of G_r - 1 (see summarize.shell_slope); KTHNY references -1/4 and -1/3.
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from summarize import shell_slope, slope

args = sys.argv[1:]
out = [a for a in args if a.endswith(".png")][-1]
dss = [xr.open_dataset(a) for a in args if not a.endswith(".png")]
cut = sorted((float(v0), ds) for ds in dss for v0 in ds.v0.values)
fig, ax = plt.subplots(1, 2, figsize=(9, 3.8))
for v0, ds in cut:
    s = ds.sel(eta=0.1, v0=v0).squeeze()
    r, g6 = ds.r.values, s.G6.values
    m = (r >= 2) & (r <= 13)
    k6, _ = slope(r[m], np.abs(g6[m]))
    m4 = (r >= 4) & (r <= 13)
    k64, _ = slope(r[m4], np.abs(g6[m4]))
    kr, nr = shell_slope(ds.dx.values, s.Gr.values)
    print(f"eta=0.1 v0={v0:g}: G6 slope r=2..13 {k6:.3f}, r=4..13 {k64:.3f}; G_r shell-peak slope {kr:.2f} ({nr} shells); psi6 {float(s.psi6):.3f};"
          f" rho_d {float(s.rho_d):.3f}+-{float(s.rho_d_err):.3f}; D_eff {float(s.D_eff):.3g}+-{float(s.D_eff_err):.2g};"
          f" <q> {float(s.q_mean):.4f}; P_max {float(s.largest_cluster_fraction):.3f}")
    ax[0].plot(ds.dx.values, s.Gr.values - 1, ".", ms=3, label=f"v0={v0:g}")
    ax[1].plot(r, np.abs(g6), label=f"v0={v0:g} (slope r>=4: {k64:.2f})")
x = np.linspace(1, 13, 20)
ax[0].plot(x, x ** (-1 / 3), "k--", label=r"$\Delta x^{-1/3}$")
ax[1].plot(x, 0.5 * x ** (-1 / 4), "k--", label=r"$r^{-1/4}$")
for a, xl, yl in ((ax[0], r"$\Delta x/R_0$", r"$G_r(\Delta x,0)-1$"), (ax[1], r"$r/R_0$", r"$|G_6(r)|$")):
    a.set_xscale("log"); a.set_yscale("log"); a.set_xlabel(xl); a.set_ylabel(yl); a.legend(fontsize=7)
ax[0].set_ylim(1e-2, 2e2)
fig.suptitle(r"$\eta = 0.1$, N = 256, 1000 time units")
fig.tight_layout()
fig.savefig(out, dpi=110)
