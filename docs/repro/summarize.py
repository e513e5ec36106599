"""Tables and fits for docs/reproduction.md from fcsweep phase_diagram.nc files.

Usage: python summarize.py PHASE_DIAGRAM.nc [...]
Prints, per state point: D_eff +- err, <q>, fraction q > 3.81, rho_d +- err, P_max,
|Psi6|, phase label; then power-law fits (cluster sizes, G6, G_r envelope) and the
number of peaks of the q histogram.
"""
import sys

import numpy as np
import xarray as xr


def slope(x, y):
    """Least-squares slope of log y against log x (positive finite points only)."""
    m = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if m.sum() < 3:
        return np.nan, 0
    p = np.polyfit(np.log(x[m]), np.log(y[m]), 1)
    return p[0], int(m.sum())


def peaks(qb, h):
    """Local maxima of a 3-bin smoothed histogram holding > 2 % of the peak height."""
    h = np.convolve(np.nan_to_num(h), np.ones(3) / 3, mode="same")
    i = [k for k in range(1, len(h) - 1) if h[k] > h[k - 1] and h[k] >= h[k + 1] and h[k] > 0.02 * h.max()]
    return [round(float(qb[k]), 3) for k in i]


for path in sys.argv[1:]:
    ds = xr.open_dataset(path)
    print("#", path, dict(ds.sizes))
    st = ds.stack(pt=[d for d in ds["D_eff"].dims])
    for k in range(st.sizes["pt"]):
        s = st.isel(pt=k)
        lab = {d: float(s[d]) for d in ds["D_eff"].dims if d != "replicate"}
        print(
            " ".join(f"{d}={v:g}" for d, v in lab.items()),
            f"| D_eff={float(s.D_eff):.3g}+-{float(s.D_eff_err):.2g}"
            f" q={float(s.q_mean):.4f} q>3.81={float(s.q_frac_above):.3f}"
            f" rho_d={float(s.rho_d):.3f}+-{float(s.rho_d_err):.3f}"
            f" Pmax={float(s.largest_cluster_fraction):.3f}+-{float(s.largest_cluster_fraction_err):.3f}"
            f" psi6={float(s.psi6):.3f} phase={int(s.phase)} perc={int(s.percolated)}",
            f"| q peaks {peaks(ds.q_bin.values, s.q_hist.values)}",
        )
        cs = s.cluster_size_distribution.values
        sz = ds.cluster_size.values
        n = len(cs[np.isfinite(cs) & (cs > 0)])
        tau, npt = slope(sz[(sz >= 2) & (sz <= 40)], cs[(sz >= 2) & (sz <= 40)])
        r = ds.r.values
        g6s, _ = slope(r[(r >= 2) & (r <= 6)], np.abs(s.G6.values[(r >= 2) & (r <= 6)]))
        dx = ds.dx.values
        gr = s.Gr.values - 1
        mk = (dx >= 1.5) & (dx <= 7.5)
        # G_r envelope: local maxima of G_r - 1 in the window
        xm, ym = [], []
        for j in np.where(mk)[0]:
            if 0 < j < len(gr) - 1 and gr[j] > gr[j - 1] and gr[j] >= gr[j + 1] and gr[j] > 0:
                xm.append(dx[j]); ym.append(gr[j])
        grs, ngr = slope(np.array(xm), np.array(ym))
        print(f"    cluster n(s) slope s=2..40: {tau:.2f} ({npt} sizes, {n} nonzero); "
              f"G6 slope r=2..6: {g6s:.3f}; G_r-1 envelope slope dx=1.5..7.5: {grs:.2f} ({ngr} peaks)")
