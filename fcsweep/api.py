"""The observables of one run, and the phase diagram of a sweep, as ``xarray`` datasets, from
a notebook.

>>> import fcsweep
>>> sim = fcsweep.Simulation.create(64, eta=0.3, v0=0.2, Dr=0.1, seed=1)   # doctest: +SKIP
>>> frames = sim.run(200, every=2)                                          # doctest: +SKIP
>>> ds = fcsweep.observables(frames)                                        # doctest: +SKIP
>>> ds["phase"].item(), float(ds["D_eff"]), float(ds["D_eff_err"])         # doctest: +SKIP

:func:`observables` runs the analysis ``fcsweep analyze`` runs
(:func:`fcsweep.analysis.run_observables.compute_observables`, with the settings of
:class:`fcsweep.model.settings.AnalysisSettings` resolved for the run's N as the results
layer resolves them) on frames held in memory (:class:`fcsweep.frames.Frames`) or on a
``trajectory.h5``, and returns the numbers ``analysis.h5`` stores: every per-run scalar
with its 1-sigma error, the curves on their own coordinates, and the labels.  A label is a
word (``phase``: ``solid``, ``fluid``, ``soft_fluid``, ``undetermined``, ``unknown``;
``percolated``; ``kthny``) beside its stored code (``phase_code``), the reason in words
(``phase_reason``) and its reason code; ``<label>_confidence`` is the probability of the
label given, NaN where the label is undetermined (the reason then says what was missing).

:func:`phase_diagram` does for a sweep config what ``fcsweep simulate``, ``analyze`` and
``aggregate`` do (resuming what is already done) and returns ``phase_diagram.nc``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from fcsweep import __version__
from fcsweep.analysis.phase import KTHNY_FLAGS, PERCOLATION_FLAGS, PHASE_FLAGS
from fcsweep.analysis.run_observables import RunFrames, compute_observables, frame_plan
from fcsweep.config.settings import settings_for_run
from fcsweep.frames import Frames
from fcsweep.model.observables import CURVES, LABELS, OBSERVABLES, REASON_CODES, REASONS, RUN_SCALARS
from fcsweep.model.settings import AnalysisSettings

__all__ = ["observables", "phase_diagram", "LABEL_WORDS"]

#: The words of each label's codes.
LABEL_WORDS = {"phase": PHASE_FLAGS, "percolated": PERCOLATION_FLAGS, "kthny": KTHNY_FLAGS}
#: Words of a label that decides nothing: its confidence is NaN beside it.
UNDECIDED = ("undetermined", "unknown")


def _run_frames(frames: Frames, settings: dict) -> RunFrames:
    """The arrays :func:`compute_observables` reads, on the frames of the analysis's plan
    (as :func:`fcsweep.results.analyze.read_run_frames` reads them from a file)."""
    plan = frame_plan(len(frames), settings, source="frames in memory")
    p = frames.params
    rigid = int(p.get("modes", 1) or 0) == 0 or frames.shape_a.shape[-1] == 0
    a = b = wall_pos = wall_theta = None
    if not rigid:
        a, b = frames.shape_a[plan.shape_frames], frames.shape_b[plan.shape_frames]
    if str(p.get("boundary", "periodic")) != "periodic":  # the pressure on the wall
        wall_pos, wall_theta = frames.position[plan.shape_frames], frames.theta[plan.shape_frames]
    unwrapped = frames.position[plan.frames] + frames.image[plan.frames] * frames.box
    return RunFrames(source="frames in memory", params=p, box=frames.box, time=frames.time, plan=plan,
                     shape_a=a, shape_b=b, rigid=rigid, positions=frames.position[plan.structure_frames],
                     unwrapped=unwrapped, radii=frames.radii, wall_positions=wall_pos, wall_theta=wall_theta)


def observables(frames, **settings) -> xr.Dataset:
    """Every observable of one run, with errors and labels.

    Parameters
    ----------
    frames : fcsweep.frames.Frames or path-like
        Frames recorded by :meth:`fcsweep.simulation.Simulation.run`, or a run's
        ``trajectory.h5``.
    **settings
        Analysis settings (:class:`fcsweep.model.settings.AnalysisSettings`: ``transient``,
        ``label_confidence``, ``percolation_threshold``, ``correlations``, ...); the rest
        at their defaults.

    Returns
    -------
    xarray.Dataset
        The scalars of the observable table (``D_eff``, ``D_eff_err``, ``q_mean``, ``rho_d``,
        ``largest_cluster_fraction``, ...), the labels as words with their codes, reasons and
        confidences, the curves (``msd`` on ``lag_time``, ``G6`` on ``r``, ...), and in
        ``attrs`` the parameters, the settings used and the fcsweep version.

    Raises
    ------
    ValueError
        An unknown setting or a value out of its range.
    fcsweep.analysis.run_observables.AnalysisError
        Frames that cannot be analysed (fewer than 3 after the transient, unequal spacing).
    """
    chosen = AnalysisSettings.from_dict(settings).as_dict()
    if isinstance(frames, Frames):
        s = settings_for_run(chosen, frames.n_cells)
        sc, cv, extra = compute_observables(_run_frames(frames, s), s)
        params, source = dict(frames.params), "frames in memory"
    else:
        from fcsweep.io.trajectory import open_trajectory
        from fcsweep.results.analyze import trajectory_observables

        traj = open_trajectory(Path(frames))
        s = settings_for_run(chosen, traj.n_cells)
        sc, cv, extra = trajectory_observables(traj, s)
        params, source = dict(traj.params), str(traj.path)
    return _dataset(sc, cv, extra, params, s, source)


def _dataset(sc: dict, cv: dict, extra: dict, params: dict, settings: dict, source: str) -> xr.Dataset:
    ds = xr.Dataset()
    for name in RUN_SCALARS:
        ds[name] = xr.DataArray(float(sc[name]), attrs={"long_name": OBSERVABLES[name].long_name,
                                                        "units": OBSERVABLES[name].units})
    for label in LABELS:
        code = sc[label]
        word = LABEL_WORDS[label].get(int(code), "unknown") if np.isfinite(code) else "unknown"
        ds[label] = xr.DataArray(word, attrs={"long_name": OBSERVABLES[label].long_name})
        flags = LABEL_WORDS[label]
        ds[f"{label}_code"] = xr.DataArray(np.int8(code if np.isfinite(code) else -1), attrs={
            "long_name": f"code of {label}", "flag_values": np.array(sorted(flags), dtype=np.int8),
            "flag_meanings": " ".join(flags[k] for k in sorted(flags))})
        conf = f"{label}_confidence"
        if conf in ds and word in UNDECIDED:
            ds[conf] = xr.DataArray(np.nan, attrs={**ds[conf].attrs, "comment": f"{label} is {word}: "
                                                   f"no label is decided (see {label}_reason)"})
    for name in REASONS:
        ds[name] = xr.DataArray(str(sc[name]))
    for name in REASON_CODES:
        ds[name] = xr.DataArray(np.int8(sc[name]))
    for name, coord in CURVES.items():
        x, y = cv[name]
        x, y = np.asarray(x), np.asarray(y, dtype=float)
        if coord in ds.coords and (ds.sizes[coord] != x.size or not np.array_equal(ds[coord].values, x)):
            dim = f"{coord}_{name}"  # a curve on other points than its neighbour on the same axis
        else:
            dim = coord
        ds[name] = xr.DataArray(y, dims=(dim,), coords={dim: x},
                                attrs={"long_name": OBSERVABLES[name].long_name})
    ds["n_sides_counts"] = xr.DataArray(np.asarray(extra["n_sides_counts"]), dims=("n_sides",))
    ds["frames"] = xr.DataArray(np.asarray(extra["frames"]), dims=("frame",),
                                attrs={"long_name": "indices of the analysed frames (after the transient)"})
    ds.attrs.update(source=source, fcsweep_version=__version__,
                    parameters_json=json.dumps(params, sort_keys=True, default=str),
                    settings_json=json.dumps(settings, sort_keys=True))
    return ds


def phase_diagram(config, *, workers: int = 1) -> xr.Dataset:
    """Simulate the runs of a sweep that are not done yet, analyse them and aggregate the
    phase diagram, as ``fcsweep simulate``, ``analyze`` and ``aggregate`` do.

    Parameters
    ----------
    config : path-like or fcsweep.config.SweepConfig
        A sweep YAML file (checked before anything runs) or a loaded config.
    workers : int
        Processes for the runs and their analysis.

    Returns
    -------
    xarray.Dataset
        ``<output>/phase_diagram.nc``, loaded into memory.

    Raises
    ------
    fcsweep.config.ConfigError
        A config that cannot run (the message names the key and what is allowed).
    RuntimeError
        Runs that failed (each run's reason is in its ``status.json``; the others are kept).
    """
    from fcsweep.config import SweepConfig, check_runnable, load_config
    from fcsweep.results.aggregate import aggregate_sweep
    from fcsweep.results.analyze import analyze_sweep
    from fcsweep.sweep.executors import run_sweep, select_runs
    from fcsweep.sweep.options import SweepOptions
    from fcsweep.sweep.warmup import compile_kernels

    cfg = config if isinstance(config, SweepConfig) else load_config(config)
    check_runnable(cfg)
    specs = select_runs(cfg)
    compile_kernels(None)
    outcomes = run_sweep(cfg, specs, SweepOptions(executor="process" if workers > 1 else "serial", workers=workers))
    failed = [o for o in outcomes if o.outcome == "failed"]
    if failed:
        raise RuntimeError(f"{len(failed)} of {len(specs)} run(s) failed; their reasons are in "
                           f"{Path(cfg.output) / 'runs'}/*/status.json")
    analyze_sweep(cfg, workers=workers)
    return xr.load_dataset(aggregate_sweep(cfg))
