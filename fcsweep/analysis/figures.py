"""``plot_sweep``: figure files of a sweep (from phase_diagram.nc) or a run snapshot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from fcsweep import plots
from fcsweep.analysis import shapes, voronoi
from fcsweep.analysis.pipeline import DATASET_FILE, TRAJECTORY_FILE
from fcsweep.analysis.trajectory import open_trajectory


def _find_run(config, run):
    runs = config.runs()
    for spec in runs:
        if spec.run_id == str(run):
            return spec
    try:
        k = int(run)
    except (TypeError, ValueError):
        k = None
    if k is not None and -len(runs) <= k < len(runs):
        return runs[k]
    raise ValueError(f"no run {run!r} in this sweep: give a run id or an index 0..{len(runs) - 1}")


def snapshot_run(traj_path, frame=-1, stem=None) -> list[Path]:
    """Draw one frame of a trajectory (cells coloured by q, defects marked)."""
    traj = open_trajectory(traj_path)
    k = int(frame) % traj.n_frames
    R0 = float(traj.params.get("R0", 1.0))
    pos = traj.read("position", [k])[0] / R0
    box = traj.box / R0
    theta = traj.read("theta", [k])[0] if "theta" in traj.fields else np.zeros(len(pos))
    if "shape_a" in traj.fields and "shape_b" in traj.fields:
        a, b = traj.read("shape_a", [k])[0], traj.read("shape_b", [k])[0]
    else:
        a = b = np.zeros((len(pos), 0))
    q = shapes.shape_indices(a, b)
    vn = voronoi.voronoi_neighbors(pos, box)
    defect = voronoi.defect_mask(vn.n_sides)
    p = traj.params
    title = (f"run {p.get('run_id', '')}  eta={p.get('eta', '?')} v0={p.get('v0', '?')}  "
             f"t={traj.time[k]:g}  rho_d={defect.mean():.2f}")
    fig = plots.snapshot(pos, theta, a, b, box, q, defect, title=title)
    stem = stem or Path(traj_path).with_name(f"snapshot_frame{k}")
    return plots.save_figure(fig, stem)


def plot_dataset(ds: xr.Dataset, outdir) -> list[Path]:
    """All sweep figures of a phase-diagram dataset into ``outdir``."""
    outdir = Path(outdir)
    out = []
    for name, fn in (("phase_diagram", plots.phase_diagram), ("q_distributions", plots.q_distributions),
                     ("largest_cluster", plots.largest_cluster), ("cluster_sizes", plots.cluster_sizes),
                     ("correlations", plots.correlations),
                     ("correlations_across_v0", lambda d: plots.correlations(d, across="v0")),
                     ("msd", plots.msd_curves)):
        out += plots.save_figure(fn(ds), outdir / name)
    return out


def plot_sweep(config, *, run=None, frame=-1, outdir=None) -> list[Path]:
    """Sweep figures (aggregating first if needed), or the snapshot of run ``run``."""
    outdir = Path(outdir) if outdir is not None else Path(config.output) / "figures"
    if run is not None:
        spec = _find_run(config, run)
        traj = Path(config.output) / "runs" / spec.run_id / TRAJECTORY_FILE
        return snapshot_run(traj, frame, outdir / f"snapshot_{spec.run_id}_frame{frame}")
    nc = Path(config.output) / DATASET_FILE
    if not nc.exists():
        from fcsweep.analysis.aggregate import aggregate_sweep

        aggregate_sweep(config)
    with xr.open_dataset(nc) as ds:
        ds = ds.load()
    return plot_dataset(ds, outdir)
