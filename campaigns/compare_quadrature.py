"""Binary vs arc at matched run length: paired table of D_eff, <q>, <q> difference with its
error, rho_d, |Psi6|, and the phase and percolation labels (undetermined: "?").

Usage: python compare_quadrature.py BINARY.nc ARC.nc
"""
import sys

import numpy as np
import xarray as xr

from fcsweep.analysis.phase import PERCOLATION_UNDETERMINED, PHASE_UNDETERMINED

b, a = (xr.open_dataset(p) for p in sys.argv[1:3])
print("| η | v0 | D_eff binary | D_eff arc | ⟨q⟩ binary | ⟨q⟩ arc | Δ⟨q⟩ | ρ_d binary | ρ_d arc | \\|Ψ6\\| b / a | "
      "label b / a (phase, percolation) |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
names = {0: "solid", 1: "fluid", 2: "soft", -1: "unknown", PHASE_UNDETERMINED: "?"}


def label(s):
    perc = int(s.percolated)
    return f"{names[int(s.phase)]}, {'?' if perc == PERCOLATION_UNDETERMINED else 'perc' if perc == 1 else 'no'}"


for eta in b.eta.values:
    for v0 in b.v0.values:
        sb = b.sel(eta=eta, v0=v0).squeeze()
        sa = a.sel(eta=eta, v0=v0).squeeze()
        print(
            f"| {eta:g} | {v0:g} | {float(sb.D_eff):.2e} ± {float(sb.D_eff_err):.1e} | "
            f"{float(sa.D_eff):.2e} ± {float(sa.D_eff_err):.1e} | {float(sb.q_mean):.3f} | "
            f"{float(sa.q_mean):.3f} | {float(sb.q_mean - sa.q_mean):+.3f} ± "
            f"{float(np.hypot(sb.q_mean_err, sa.q_mean_err)):.3f} | "
            f"{float(sb.rho_d):.3f} ± {float(sb.rho_d_err):.3f} | {float(sa.rho_d):.3f} ± {float(sa.rho_d_err):.3f} | "
            f"{float(sb.psi6):.2f} / {float(sa.psi6):.2f} | "
            f"{label(sb)} / {label(sa)} |"
        )
