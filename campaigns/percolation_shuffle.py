"""Real and shuffled-label finite-size collapses of defect percolation, side by side.

    python campaigns/percolation_shuffle.py SWEEP.yaml|DATASET.nc [...]

Each argument is a sweep config (its ``<output>/phase_diagram.nc`` is read, so run
``fcsweep analyze`` and ``fcsweep aggregate`` first) or a dataset.  The datasets are joined
over N (outer join in eta, like paper_fss.py), so sweeps of different sizes make one
collapse.  For every v0 (and any other swept parameter) it fits
:func:`fcsweep.analysis.fss.fss_collapse` to the replicate means of
``largest_cluster_fraction`` and of ``largest_cluster_fraction_shuffled`` (defect labels
permuted over each frame's Voronoi graph: same rho_d, correlations destroyed) against
``rho_d`` and prints rho_c, nu, beta and the quality S of both, and the shift
rho_c - rho_c(shuffled) that the defect correlations cause (docs/statistics.md).
Analyses made before the shuffled statistic existed have it NaN: re-run
``fcsweep analyze --force``.
"""

import sys
from pathlib import Path

import numpy as np
import xarray as xr

from fcsweep.analysis.fss import fss_collapse
from fcsweep.results.analyze import DATASET_FILE

STATS = ("largest_cluster_fraction", "largest_cluster_fraction_shuffled")
KEEP = ("rho_d_rmean",) + tuple(f"{s}_rmean{e}" for s in STATS for e in ("", "_err"))


def dataset_path(arg: str) -> Path:
    """The dataset of a config (``<output>/phase_diagram.nc``) or the dataset given."""
    if arg.endswith((".yaml", ".yml")):
        from fcsweep.config import load_config

        return Path(load_config(arg).output) / DATASET_FILE
    return Path(arg)


def joined(paths):
    """One dataset of the variables the collapses need, N from every file."""
    parts = []
    for p in paths:
        ds = xr.open_dataset(p)
        for v in KEEP:
            if v not in ds:  # an aggregate older than the statistic
                ds[v] = xr.full_like(ds["rho_d_rmean"], np.nan)
        parts.append(ds[list(KEEP)])
    return xr.concat(parts, dim="N", join="outer").sortby("N") if len(parts) > 1 else parts[0]


def collapse(s, stat: str):
    """fss_collapse of one slice (dims eta, N) for the statistic ``stat``; None without two N."""
    rho = s["rho_d_rmean"].transpose("N", "eta").values
    p = s[f"{stat}_rmean"].transpose("N", "eta").values
    e = s[f"{stat}_rmean_err"].transpose("N", "eta").values
    n = np.broadcast_to(s["N"].values[:, None].astype(float), rho.shape)
    ok = np.isfinite(rho) & np.isfinite(p)
    if np.unique(n[ok]).size < 2:
        return None
    return fss_collapse(rho[ok], p[ok], n[ok], np.where(np.isfinite(e[ok]), e[ok], 0.0))


def row(name: str, fit) -> str:
    if fit is None:
        return f"| {name} | – | – | – | – | fewer than two N with data |"
    return (f"| {name} | {fit.rho_c:.4f} ± {fit.rho_c_err:.4f} | {fit.nu:.2f} ± {fit.nu_err:.2f} | "
            f"{fit.beta:.3f} ± {fit.beta_err:.3f} | {fit.quality:.2f} | {fit.reason or 'ok'} |")


def main(args):
    ds = joined([dataset_path(a) for a in args])
    print(f"N = {', '.join(str(int(n)) for n in ds.N.values)}; random site percolation on a triangulation: "
          "rho_c = 1/2, nu = 4/3, beta = 5/36 = 0.139")
    others = [d for d in ds["rho_d_rmean"].dims if d not in ("eta", "N")]
    for idx in np.ndindex(*(ds.sizes[d] for d in others)):
        s = ds.isel(dict(zip(others, idx)))
        where = ", ".join(f"{d} = {float(s[d]):g}" if np.issubdtype(s[d].dtype, np.number) else f"{d} = {s[d].item()}"
                          for d in others)
        fits = [collapse(s, stat) for stat in STATS]
        print(f"\n{where or 'all points'}\n")
        print("| statistic | rho_c | nu | beta | S | reason |")
        print("|---|---|---|---|---|---|")
        print(row("real defects", fits[0]))
        print(row("labels shuffled", fits[1]))
        if all(f is not None and np.isfinite(f.rho_c) for f in fits):
            d = fits[0].rho_c - fits[1].rho_c
            de = np.hypot(fits[0].rho_c_err, fits[1].rho_c_err)
            print(f"\nshift by defect correlations: rho_c - rho_c(shuffled) = {d:+.4f} ± {de:.4f} "
                  f"({d / de:+.1f} sigma)" if de > 0 else f"\nshift: {d:+.4f}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
