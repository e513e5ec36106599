"""Markdown table of a phase-diagram dataset swept over ``initial`` (lattice and disordered
starts): per grid point the label of each start with its confidence, the point's label,
whether the starts agree, the deciding numbers and the CPU of each start's run.

    python campaigns/both_starts_table.py DATASET.nc [RUNS_DIR]

RUNS_DIR (the sweep's ``runs/`` folder) adds the CPU seconds and run lengths from each
run's ``status.json``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import xarray as xr

WORDS = {-1: "unknown", 0: "solid", 1: "fluid", 2: "soft fluid", 3: "undetermined"}
KTHNY = {-1: "unknown", 0: "solid", 1: "hexatic", 2: "liquid", 3: "undetermined"}
HYST = {-1: "unknown", 0: "agree", 1: "disagree", 2: "one-sided"}


def _label(code, conf, words=WORDS) -> str:
    w = words.get(int(code), "unknown")
    return f"{w} ({float(conf):.3f})" if int(code) in (0, 1, 2) and np.isfinite(conf) else w


def _num(ds, name, sel) -> str:
    if name not in ds:
        return "–"
    x = float(ds[name].sel(sel).values.squeeze())
    e = float(ds[f"{name}_err"].sel(sel).values.squeeze()) if f"{name}_err" in ds else np.nan
    if not np.isfinite(x):
        return "–"
    return f"{x:.2g} ± {e:.1g}" if np.isfinite(e) else f"{x:.2g}"


def _run_cost(runs: Path | None, run_id: str) -> str:
    if runs is None:
        return "–"
    f = runs / run_id / "status.json"
    if not f.exists():
        return "–"
    st = json.loads(f.read_text())
    return f"{(float(st.get('cpu_seconds') or 0) + float(st.get('check_cpu_seconds') or 0)) / 60:.1f} min"


def table(path, runs=None) -> str:
    ds = xr.open_dataset(path)
    rows = ["| η | v0 | N | start | label (P) | D_eff_cr | D_eff_cr_late | CR-MSD / a² | KTHNY | run length | CPU | point | starts |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for eta in ds["eta"].values:
        for v0 in ds["v0"].values:
            for N in ds["N"].values:
                base = {"eta": eta, "v0": v0, "N": N, "replicate": 0}
                for k, start in enumerate(ds["initial"].values):
                    sel = {**base, "initial": start}
                    rid = str(ds["run_id"].sel(sel).values.squeeze())
                    lab = _label(ds["phase"].sel(sel).values, ds["phase_confidence"].sel(sel).values)
                    kth = _label(ds["kthny"].sel(sel).values, ds["kthny_confidence"].sel(sel).values, KTHNY)
                    point = hyst = ""
                    if k == 0:
                        psel = {"eta": eta, "v0": v0, "N": N}
                        point = _label(ds["phase_point"].sel(psel).values, ds["phase_point_confidence"].sel(psel).values)
                        hyst = HYST.get(int(ds["phase_hysteresis"].sel(psel).values), "unknown")
                    rows.append(f"| {eta:g} | {v0:g} | {N} | {start} | {lab} | {_num(ds, 'D_eff_cr', sel)} | "
                                f"{_num(ds, 'D_eff_cr_late', sel)} | {_num(ds, 'cage_msd_ratio', sel)} | {kth} | "
                                f"{float(ds['t_end'].sel(sel).values.squeeze()):.0f} | {_run_cost(runs, rid)} | {point} | {hyst} |")
    return "\n".join(rows)


if __name__ == "__main__":
    print(table(sys.argv[1], Path(sys.argv[2]) if len(sys.argv) > 2 else None))
