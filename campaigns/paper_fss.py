"""Percolation at v0 = 0.06 over every N the campaign ran (Fig. 3a-c): joins the datasets of
configs/paper_percolation_cut.yaml (N = 256, 1024, 4900) and configs/paper_percolation_10k.yaml
(N = 10^4), prints P_max per eta and N, the Fisher exponents and the finite-size collapse over
all sizes and over N >= 1024, and draws the collapse and the unscaled data:

    python campaigns/paper_fss.py CUT.nc TENK.nc [FIGURE_DIR]

The collapse is the one `fcsweep aggregate` stores per v0 (fcsweep.analysis.fss.fss_collapse
on the replicate means of P_max against rho_d, bootstrap errors); here it just sees the four
sizes of two sweeps at once."""

import sys
from pathlib import Path

import numpy as np
import xarray as xr

from fcsweep.results.figures import fss_collapse_figure, largest_cluster_unscaled
from fcsweep.analysis.fss import BETA_2D, NU_2D, fss_collapse

KEEP = ("rho_d_rmean", "largest_cluster_fraction_rmean", "largest_cluster_fraction_rmean_err",
        "tau_fisher", "tau_fisher_err")
FIT = ("rho_c", "rho_c_err", "nu", "nu_err", "beta", "beta_err", "quality")


def joined(paths):
    """One dataset of the variables the collapse needs, N from every file (outer join in eta)."""
    parts = [xr.open_dataset(p)[list(KEEP)] for p in paths]
    return xr.concat(parts, dim="N", join="outer").sortby("N")


def collapse(ds, n_min=0):
    """fss_collapse over the points with N >= n_min (the largest v0)."""
    s = ds.isel(v0=-1).sel(N=ds.N[ds.N >= n_min])
    rho, p, e = (s[v].transpose("N", "eta").values.ravel() for v in KEEP[:3])
    n = np.broadcast_to(s.N.values[:, None].astype(float), s.rho_d_rmean.transpose("N", "eta").shape).ravel()
    ok = np.isfinite(rho) & np.isfinite(p)
    e = np.where(np.isfinite(e[ok]), e[ok], 0.0)
    return fss_collapse(rho[ok], p[ok], n[ok], e), int(ok.sum())


def main(cut, tenk, figdir=None):
    ds = joined([cut, tenk])
    v0 = float(ds.v0.values[-1])
    print(f"\nv0 = {v0:g}: P_max (replicate mean ± 1σ) per η and N\n")
    print("| η | " + " | ".join(f"N = {int(n)}" for n in ds.N.values) + " |")
    print("|---|" + "---|" * ds.sizes["N"])
    for eta in ds.eta.values:
        row = ds.sel(eta=eta).isel(v0=-1)
        cells = [f"{float(p):.3f} ± {float(e):.3f}" if np.isfinite(p) else "–"
                 for p, e in zip(row.largest_cluster_fraction_rmean.values, row.largest_cluster_fraction_rmean_err.values)]
        print(f"| {eta:g} | " + " | ".join(cells) + " |")
    print("\nFisher exponent τ (pooled cluster sizes; 187/91 = 2.055)\n")
    for eta in ds.eta.values:
        t = ds.tau_fisher.sel(eta=eta).isel(v0=-1)
        te = ds.tau_fisher_err.sel(eta=eta).isel(v0=-1)
        vals = ", ".join(f"{float(a):.2f} ± {float(b):.2f} (N = {int(n)})" for a, b, n in zip(t.values, te.values, ds.N.values)
                         if np.isfinite(a))
        print(f"- η = {eta:g}: {vals or '–'}")
    print("\nFinite-size collapse (2-D percolation: ρ_c = 1/2, ν = 4/3, β = 5/36 = 0.139)\n")
    print("| sizes | points | ρ_c | ν | β | quality S | pulls from 1/2, 4/3, 5/36 | reason |")
    print("|---|---|---|---|---|---|---|---|")
    fits = {}
    for n_min in (0, 1024):
        fit, npts = collapse(ds, n_min)
        fits[n_min] = fit
        sizes = ", ".join(str(int(n)) for n in ds.N.values if n >= n_min)
        pulls = ", ".join(f"{(fit[k] - ref) / fit[f'{k}_err']:+.1f}" for k, ref in
                          (("rho_c", 0.5), ("nu", NU_2D), ("beta", BETA_2D)))
        print(f"| {sizes} | {npts} | {fit.rho_c:.3f} ± {fit.rho_c_err:.3f} | {fit.nu:.2f} ± {fit.nu_err:.2f} | "
              f"{fit.beta:.3f} ± {fit.beta_err:.3f} | {fit.quality:.2f} | {pulls} | {fit.reason or '–'} |")
    if figdir:
        out = Path(figdir)
        out.mkdir(parents=True, exist_ok=True)
        for k in FIT:  # the four-size fit, where the figure looks for a stored one
            ds[f"fss_{k}"] = ("v0", [fits[0][k]])
        ds["fss_reason"] = ("v0", [fits[0].reason])
        fss_collapse_figure(ds).savefig(out / "fss_collapse.png", dpi=150, bbox_inches="tight")
        fss_collapse_figure(ds, exponents="paper").savefig(out / "fss_collapse_paper.png", dpi=150,
                                                             bbox_inches="tight")
        largest_cluster_unscaled(ds).savefig(out / "largest_cluster_unscaled.png", dpi=150, bbox_inches="tight")
        print(f"\nfigures in {out}")


if __name__ == "__main__":
    main(*sys.argv[1:4])
