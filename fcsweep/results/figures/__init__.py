"""Figures of a sweep and of one run, fit for a paper or a talk (matplotlib).

* drawing -- functions that take arrays or the phase-diagram :class:`xarray.Dataset`
  and return a :class:`matplotlib.figure.Figure` (:func:`phase_diagram`,
  :func:`d_eff_curves`, :func:`q_distributions`, :func:`largest_cluster`,
  :func:`cluster_sizes`, :func:`correlations`, :func:`msd_curves`,
  :func:`summary_diagram`, :func:`snapshot`).  Each takes ``ax=None`` (or ``axes=None``
  for the figures of several panels): given, it draws into those axes, else it makes a
  figure;
* files -- :func:`plot_sweep`, :func:`plot_dataset`, :func:`snapshot_run` and
  :func:`movie_run` write figure files; finding them is :mod:`fcsweep.results.locate`.

Importing the module leaves matplotlib's backend alone (a notebook keeps its own); the
command line selects Agg.  Conventions: colour-blind-safe palettes (viridis for ordered
values, truncated before its pale yellow end; Okabe--Ito for categories); single-panel
figures one paper column wide (:data:`COLUMN` = 3.4 in), figures of several panels two
columns (:data:`DOUBLE_COLUMN` = 7.0 in), fonts legible at that size and on a slide; a
caption line with N, run length and quadrature; eta, v0 and t in model units
(:data:`ETA_LABEL`, :data:`V0_LABEL`, :data:`TIME_UNIT`); log axes where a swept grid is
logarithmic, symlog where a quantity changes sign.  Every drawing function accepts 1-D
grids and single points; threshold contours run on the edges between grid cells whose
values lie on either side of the level (none where no two neighbours do).  Datasets with
the ``<name>_err`` variables and the ``undetermined`` phase code get error bars, hollow
markers and hatched cells; older ones draw without.
"""

from __future__ import annotations

from pathlib import Path

from fcsweep.results.locate import find_run, has_analysed_run, run_trajectory, sweep_dataset
from fcsweep.results.figures.common import (COLUMN, DOUBLE_COLUMN, ETA_LABEL, OKABE_ITO, PHASE_COLORS, STYLE,
                                             TIME_UNIT, V0_LABEL, caption, save_figure)
from fcsweep.results.figures.diagrams import (SHORT_REASONS, d_eff_curves, phase_diagram, short_reason,
                                               summary_diagram, summary_labels)
from fcsweep.results.figures.curves import (cluster_sizes, correlations, largest_cluster, log_binned, msd_curves,
                                             q_distributions)
from fcsweep.results.figures.frames import (FrameArtist, SLIDE, SLIDE_STYLE, cell_polygons, movie_run, snapshot,
                                             snapshot_run)
from fcsweep.results.figures.fss import FSS_FIGURES, fss_collapse_figure, largest_cluster_unscaled

__all__ = [
    "COLUMN", "DOUBLE_COLUMN", "ETA_LABEL", "FSS_FIGURES", "FrameArtist", "NothingToPlot", "OKABE_ITO",
    "OPTIONAL_FIGURES", "PHASE_COLORS", "SHORT_REASONS", "SLIDE", "SLIDE_STYLE", "STYLE", "SWEEP_FIGURES",
    "TIME_UNIT", "V0_LABEL", "caption", "cell_polygons", "cluster_sizes", "correlations", "d_eff_curves",
    "fss_collapse_figure", "largest_cluster", "largest_cluster_unscaled", "log_binned", "movie_run", "msd_curves",
    "phase_diagram", "plot_dataset", "plot_sweep", "q_distributions", "save_figure", "short_reason", "snapshot",
    "snapshot_run", "summary_diagram", "summary_labels",
]


#: Figure files of a sweep: name -> drawing function of the phase-diagram dataset.
SWEEP_FIGURES = {
    "phase_diagram": phase_diagram,
    "d_eff": d_eff_curves,
    "q_distributions": q_distributions,
    "largest_cluster": largest_cluster,
    "cluster_sizes": cluster_sizes,
    "correlations": correlations,
    "correlations_across_v0": lambda d: correlations(d, across="v0"),
    "msd": msd_curves,
}


#: Figures drawn only when the dataset has a variable: name -> (variable, drawing function).
OPTIONAL_FIGURES = {"summary": ("kthny", summary_diagram)}


def plot_dataset(ds, outdir) -> list[Path]:
    """All sweep figures of a phase-diagram dataset into ``outdir`` (those of
    :data:`OPTIONAL_FIGURES` where the dataset has their variable, those of
    :data:`FSS_FIGURES` where it has two or more N)."""
    outdir = Path(outdir)
    out = []
    for name, fn in SWEEP_FIGURES.items():
        out += save_figure(fn(ds), outdir / name)
    for name, (var, fn) in OPTIONAL_FIGURES.items():
        if var in ds:
            out += save_figure(fn(ds), outdir / name)
    if ds.sizes.get("N", 1) >= 2:
        for name, fn in FSS_FIGURES.items():
            out += save_figure(fn(ds), outdir / name)
    return out


class NothingToPlot(RuntimeError):
    """The sweep has no analysed run, so every figure would be blank."""


def plot_sweep(config, *, run=None, frame=-1, outdir=None, measured=()) -> list[Path]:
    """Sweep figures (aggregating first if needed, :func:`fcsweep.results.locate.sweep_dataset`),
    or the snapshot of run ``run``.  With ``measured`` (paths of ``measure.nc`` files or of
    directories holding one), also ``measured_q_rho``: the movies beside the simulated
    points on the <q> - rho_d plane (:func:`fcsweep.results.figures.measured.measured_plane`).

    Raises
    ------
    NothingToPlot
        When no run of the sweep is analysed (nothing is written).
    """
    outdir = Path(outdir) if outdir is not None else Path(config.output) / "figures"
    if run is not None:
        spec = find_run(config, run)
        return snapshot_run(run_trajectory(config, run), frame, outdir / f"snapshot_{spec.run_id}_frame{frame}")
    ds = sweep_dataset(config)
    if not has_analysed_run(ds):
        raise NothingToPlot(f"no analysed run in {config.output}: run `fcsweep analyze` first")
    out = plot_dataset(ds, outdir)
    if measured:
        import xarray as xr

        from fcsweep.results.figures.measured import measured_plane

        files = [Path(p) / "measure.nc" if Path(p).is_dir() else Path(p) for p in measured]
        sets = []
        for f in files:
            with xr.open_dataset(f) as m:
                sets.append(m.load())
        out += save_figure(measured_plane(ds, sets, names=[f.parent.name if f.name == "measure.nc" else f.stem
                                                           for f in files]), outdir / "measured_q_rho")
    return out
