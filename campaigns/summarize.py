"""Tables and fits for docs/reproduction.md from fcsweep phase_diagram.nc files.

Usage: python summarize.py PHASE_DIAGRAM.nc [...]
Prints, per state point: D_eff +- err (with the time- and cell-block parts and the
settling check), <q> +- err, fraction q > 3.81, rho_d +- err, P_max +- err, |Psi6| +- err,
phase and percolation labels with their confidence and reason, tau_fisher; then
power-law fits (G6, G_r envelope) and the peaks of the q histogram.
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


def shell_slope(dx, gr, a=(2 * np.pi / (0.95 * np.sqrt(3))) ** 0.5):
    """Slope of log(peak of G_r - 1) against log dx over lattice shells dx = n*a.

    The peak of shell n is the largest sum of two adjacent bins within 0.4 of n*a.
    """
    x, y = [], []
    for n in range(1, 20):
        m = np.where(np.abs(dx - n * a) < 0.4)[0]
        if len(m) < 2 or dx.max() < n * a:
            break
        g = np.nan_to_num(gr[m])
        pk = max(g[k] + g[k + 1] for k in range(len(g) - 1)) - 2
        x.append(n * a)
        y.append(pk)
    return slope(np.array(x), np.array(y))


def peaks(qb, h):
    """Local maxima of a 3-bin smoothed histogram holding > 2 % of the peak height."""
    h = np.convolve(np.nan_to_num(h), np.ones(3) / 3, mode="same")
    i = [k for k in range(1, len(h) - 1) if h[k] > h[k - 1] and h[k] >= h[k + 1] and h[k] > 0.02 * h.max()]
    return [round(float(qb[k]), 3) for k in i]


def main(paths):
    """Print the tables and fits for each dataset path."""
    for path in paths:
        ds = xr.open_dataset(path)
        print("#", path, dict(ds.sizes))
        st = ds.stack(pt=[d for d in ds["D_eff"].dims])
        for k in range(st.sizes["pt"]):
            s = st.isel(pt=k)
            lab = {d: float(s[d]) for d in ds["D_eff"].dims if d != "replicate"}
            f = (lambda v: float(s[v]))
            print(
                " ".join(f"{d}={v:g}" for d, v in lab.items()),
                f"| D_eff={f('D_eff'):.3g}+-{f('D_eff_err'):.2g} (time {f('D_eff_err_time'):.2g},"
                f" cells {f('D_eff_err_cells'):.2g}, late {f('D_eff_late'):.3g}, B={f('n_time_blocks'):.0f})"
                f" q={f('q_mean'):.4f}+-{f('q_mean_err'):.4f} q>3.81={f('q_frac_above'):.3f}"
                f" rho_d={f('rho_d'):.3f}+-{f('rho_d_err'):.3f}"
                f" Pmax={f('largest_cluster_fraction'):.3f}+-{f('largest_cluster_fraction_err'):.3f}"
                f" psi6={f('psi6'):.3f}+-{f('psi6_err'):.3f}",
                f"| phase={int(s.phase)} P={f('phase_confidence'):.3f} ({s.phase_reason.item()})"
                f" perc={int(s.percolated)} P={f('percolated_confidence'):.3f}"
                f" tau={f('tau_fisher'):.2f}+-{f('tau_fisher_err'):.2f}",
                f"| q peaks {peaks(ds.q_bin.values, s.q_hist.values)}",
            )
            r = ds.r.values
            g6s, _ = slope(r[(r >= 2) & (r <= 6)], np.abs(s.G6.values[(r >= 2) & (r <= 6)]))
            grs, ngr = shell_slope(ds.dx.values, s.Gr.values)
            print(f"    G6 slope r=2..6: {g6s:.3f}; G_r shell-peak slope: {grs:.2f} ({ngr} shells)")


if __name__ == "__main__":
    main(sys.argv[1:])
