"""Compare two mappings of one phase diagram: fixed length against until + refine.

Usage (after ``fcsweep simulate/analyze/aggregate`` of the first and ``fcsweep refine``
of the second, both from the same working directory)::

    python benchmarks/adaptive_compare.py configs/adaptive_fixed.yaml configs/adaptive_until.yaml \
        --figure docs/adaptive/labels.png > docs/adaptive/comparison.md

Prints, as Markdown: the point labels of both mappings at every point of the fixed grid
(with their confidences, and the steps each run did), how many agree, the label changes
along each swept axis (boundaries located between neighbours), and the cost of each
mapping from ``phase_diagram.nc`` (cell-steps, CPU seconds).  Costs are ratios within
one machine and one session.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import xarray as xr

from fcsweep.analysis.phase import PERCOLATION_FLAGS, PHASE_FLAGS
from fcsweep.config import load_config


def _labels(cfg):
    """point (swept values) -> dict of labels, confidences and steps done."""
    with xr.open_dataset(Path(cfg.output) / "phase_diagram.nc") as ds:
        ds = ds.load()
    out = {}
    for spec in cfg.runs():
        key = tuple(spec.params[a] for a in cfg.swept)
        sel = {d: spec.params[d] for d in ds["phase_point"].dims}
        st = json.loads((Path(cfg.output) / "runs" / spec.run_id / "status.json").read_text())
        out[key] = {"phase": int(ds["phase_point"].sel(sel)), "perc": int(ds["percolated_point"].sel(sel)),
                    "pc": float(ds["phase_point_confidence"].sel(sel)),
                    "cc": float(ds["percolated_point_confidence"].sel(sel)),
                    "steps": int(st.get("steps_done", 0)), "stop": st.get("stop_reason", ""),
                    "cell_steps": float(st.get("cell_steps_computed", 0)), "cpu": float(st.get("cpu_seconds", 0)),
                    "check_cpu": float(st.get("check_cpu_seconds", 0))}
    return out, ds.attrs


def _name(lab):
    return f"{PHASE_FLAGS[lab['phase']]}/{PERCOLATION_FLAGS[lab['perc']]}"


def _boundaries(labels, axes):
    """Label changes between neighbours along each axis: list of text lines."""
    lines = []
    for i, a in enumerate(axes):
        rows = {}
        for p in labels:
            rows.setdefault(p[:i] + p[i + 1:], []).append(p)
        for rest, pts in sorted(rows.items()):
            pts.sort(key=lambda p: p[i])
            for p, q in zip(pts, pts[1:]):
                if (labels[p]["phase"], labels[p]["perc"]) != (labels[q]["phase"], labels[q]["perc"]):
                    where = ", ".join(f"{axes[k]}={p[k]:.4g}" for k in range(len(axes)) if k != i)
                    lines.append(f"{a} in ({p[i]:.4g}, {q[i]:.4g}) at {where}: {_name(labels[p])} -> "
                                 f"{_name(labels[q])}")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("fixed")
    ap.add_argument("adaptive")
    ap.add_argument("--figure", default=None)
    args = ap.parse_args()
    cf, ca = load_config(args.fixed), load_config(args.adaptive)
    fixed, fa = _labels(cf)
    adaptive, aa = _labels(ca)
    axes = cf.swept
    print("| " + " | ".join(axes) + " | fixed length | conf | adaptive | conf | steps (adaptive) | agree |")
    print("|" + "---|" * (len(axes) + 6))
    agree = common = 0
    for p in sorted(fixed):
        f = fixed[p]
        a = adaptive.get(p)
        same = a is not None and (a["phase"], a["perc"]) == (f["phase"], f["perc"])
        common += a is not None
        agree += same
        cells = [f"{v:.4g}" for v in p] + [_name(f), f"{f['pc']:.2f}/{f['cc']:.2f}"]
        cells += [_name(a), f"{a['pc']:.2f}/{a['cc']:.2f}", f"{a['steps']} ({a['stop']})", "yes" if same else "NO"] \
            if a is not None else ["not run", "", "", ""]
        print("| " + " | ".join(cells) + " |")
    print(f"\n{agree} of {common} common points agree; the fixed grid has {len(fixed)} points, "
          f"the adaptive mapping ran {len(adaptive)}.\n")
    for title, lab in (("fixed length", fixed), ("adaptive", adaptive)):
        print(f"Label changes, {title}:\n")
        for line in _boundaries(lab, axes) or ["none"]:
            print(f"- {line}")
        print()
    print("| mapping | runs | cell-steps integrated | CPU seconds (of which checks) |")
    print("|---|---|---|---|")
    rows = [("fixed length, whole grid", list(fixed.values())),
            ("fixed length, only the points the adaptive mapping ran",
             [fixed[p] for p in adaptive if p in fixed]),
            ("coarse grid + until + refine", list(adaptive.values()))]
    cs_f = sum(r["cell_steps"] for r in rows[0][1])
    cpu_f = sum(r["cpu"] for r in rows[0][1])
    for title, runs in rows:
        cs, cpu, chk = (sum(r[k] for r in runs) for k in ("cell_steps", "cpu", "check_cpu"))
        print(f"| {title} | {len(runs)} | {cs:.3g} ({cs / cs_f:.2f}) | {cpu:.0f} ({chk:.0f}; {cpu / cpu_f:.2f}) |")
    print("\n(ratios to the whole fixed grid in parentheses; CPU is process CPU of the runs, "
          "one numba thread, this machine; the same sums as the `total_*` attributes of "
          f"phase_diagram.nc: {float(fa['total_cell_steps_computed']):.3g} and "
          f"{float(aa['total_cell_steps_computed']):.3g} cell-steps)")
    if args.figure:
        _figure(fixed, adaptive, axes, args.figure)


def _figure(fixed, adaptive, axes, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    markers = {0: "s", 1: "o", 2: "^", 3: "x", -1: "."}
    fig, axs = plt.subplots(1, 2, figsize=(9, 3.8), sharey=True)
    for ax, (title, lab) in zip(axs, (("fixed length", fixed), ("coarse grid + until + 2 refine rounds", adaptive))):
        for code, m in markers.items():
            pts = [p for p in lab if lab[p]["phase"] == code]
            if pts:
                x, y = np.array(pts, dtype=float).T
                perc = np.array([lab[p]["perc"] == 1 for p in pts])
                ax.scatter(x, y, marker=m, s=70, c=np.where(perc, "tab:red", "tab:blue"),
                           label=PHASE_FLAGS[code])
        ax.set_xscale("log")
        ax.set_xlabel(axes[0])
        ax.set_title(title, fontsize=10)
    axs[0].set_ylabel(axes[1])
    handles, names = axs[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", ncol=len(names), fontsize=8,
               title="phase (red: percolated, blue: not or undetermined)", title_fontsize=8)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
