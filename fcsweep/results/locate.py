"""Where a sweep's results lie: a run's directory and trajectory, the phase-diagram dataset.

File finding for the commands that read results (``plot``, ``movie``) and for
:mod:`fcsweep.results.figures`, which draws and writes figures only.
"""

from __future__ import annotations

from pathlib import Path

from fcsweep.io.failures import WriteFailure
from fcsweep.io.schema import DATASET, TRAJECTORY
from fcsweep.io.sweepdir import run_path
from fcsweep.results.aggregate import build_dataset, write_dataset
from fcsweep.results.reduce import ANALYSED


def find_run(config, run):
    """The run spec of run ``run`` of a sweep.

    Parameters
    ----------
    config : fcsweep.config.SweepConfig
        The sweep.
    run : str or int
        A run id, or an index into the sweep's runs (negative counts from the end).

    Returns
    -------
    RunSpec

    Raises
    ------
    ValueError
        If no run has that id or index.
    """
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


def run_trajectory(config, run) -> Path:
    """Trajectory file of run ``run`` (id or index) of a sweep (it may not exist yet)."""
    return run_path(config.output, find_run(config, run).run_id) / TRAJECTORY


def sweep_dataset(config):
    """The phase-diagram dataset of a sweep, loaded into memory.

    Reads ``<output>/phase_diagram.nc``; where it does not exist, aggregates the
    analysed runs (and writes the file when at least one run is analysed).

    Returns
    -------
    xarray.Dataset
    """
    import xarray as xr

    nc = Path(config.output) / DATASET
    if nc.exists():
        with xr.open_dataset(nc) as ds:
            return ds.load()
    ds = build_dataset(config)
    if int(ds.attrs.get("n_analysed", 0)):
        try:
            write_dataset(ds, nc)
        except WriteFailure:  # kept in memory: the figures do not need the file
            pass
    return ds


def has_analysed_run(ds) -> bool:
    """False when the dataset records a status and no run has an analysis (status ``analysed``)."""
    return "status" not in ds or bool((ds["status"] == ANALYSED).any())
