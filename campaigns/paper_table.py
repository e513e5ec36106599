"""Print the per-point table of docs/reproduction.md (paper's claims at the paper's N) from
aggregated datasets: python campaigns/paper_table.py DATASET.nc [...]."""

import sys

import numpy as np
import xarray as xr

WORDS = {-1: "unknown", 0: "solid", 1: "fluid", 2: "soft fluid", 3: "undetermined"}
KWORDS = {-1: "unknown", 0: "solid", 1: "hexatic", 2: "liquid", 3: "undetermined"}


def _pm(x, e, f="{:.3g}"):
    return f"{f.format(x)} ± {float(e):.2g}" if np.isfinite(x) else "–"


for path in sys.argv[1:]:
    ds = xr.open_dataset(path)
    print(f"\n{path}\n")
    print("| η | v0 | N | D_eff | D_eff_cr | CR-MSD / a² | ⟨q⟩ | ρ_d | P_max | phase | KTHNY |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for idx in np.ndindex(ds["phase"].shape):
        s = ds.isel({d: i for d, i in zip(ds["phase"].dims, idx)})
        ph = int(s.phase)
        lab = WORDS[ph] + (f" ({float(s.phase_confidence):.3f})" if ph in (0, 1, 2) else f": {str(s.phase_reason.values)[:60]}…")
        k = int(s.kthny) if "kthny" in s else -1
        klab = KWORDS[k] + (f" ({float(s.kthny_confidence):.2f})" if k in (0, 1, 2) else "")
        print(f"| {float(s.eta):g} | {float(s.v0):g} | {int(s.N)} | {_pm(float(s.D_eff), s.D_eff_err)} | "
              f"{_pm(float(s.D_eff_cr), s.D_eff_cr_err)} | {_pm(float(s.cage_msd_ratio), s.cage_msd_ratio_err)} | "
              f"{_pm(float(s.q_mean), s.q_mean_err, '{:.4f}')} | {_pm(float(s.rho_d), s.rho_d_err, '{:.3f}')} | "
              f"{_pm(float(s.largest_cluster_fraction), s.largest_cluster_fraction_err, '{:.3f}')} | {lab} | {klab} |")
