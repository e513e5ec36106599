"""The paper's Fig. 4e at N = 4900: the KTHNY summary of the two N = 4900 scans, eta = 0.1
(configs/paper_correlations_4900.yaml, v0 = 0.01-0.05) and v0 = 0.06
(configs/paper_percolation_cut.yaml, eta = 0.01-0.1), drawn on one (eta, v0) plane:

    python campaigns/paper_fig4e.py CORRELATIONS.nc PERCOLATION.nc FIGURE.png

Labels are the datasets' own (fcsweep.results.figures.summary_labels: KTHNY where decided,
else the phase label); grid points neither scan visited are left empty."""

import sys

import numpy as np
import xarray as xr

from fcsweep.results.figures import summary_diagram, summary_labels

LABELS = ("kthny", "phase")
KEEP = LABELS + ("run_id", "t_end")


def joined(paths, N=4900):
    """kthny and phase labels of the N = 4900 runs of every file on one (eta, v0) plane."""
    parts = [xr.open_dataset(p)[list(KEEP)].sel(N=[N]) for p in paths]
    ds = xr.merge(parts, join="outer", compat="no_conflicts")
    for name in LABELS:  # the outer join turns the int8 flags into floats with NaN holes
        attrs = parts[0][name].attrs
        ds[name] = ds[name].fillna(-1).astype(np.int8)
        ds[name].attrs = attrs
    ds["run_id"] = ds["run_id"].fillna("")  # no run at the points only the other scan has
    ds.attrs = dict(parts[0].attrs)
    return ds


def main(corr, perc, out):
    ds = joined([corr, perc])
    words = summary_labels(ds, {"N": 4900})
    print("| v0 \\ η | " + " | ".join(f"{e:g}" for e in ds.eta.values) + " |")
    print("|---|" + "---|" * ds.sizes["eta"])
    for i, v0 in enumerate(ds.v0.values):
        print(f"| {v0:g} | " + " | ".join("" if w == "none" else w.replace("_", " ") for w in words[i]) + " |")
    summary_diagram(ds, select={"N": 4900}).savefig(out, dpi=150, bbox_inches="tight")
    print(f"\nfigure {out}")


if __name__ == "__main__":
    main(*sys.argv[1:4])
