"""``measure(labels, ...)``: a segmented movie in, an xarray.Dataset of the simulation's
observables out; ``write_measure`` stores it as ``OUT/measure.nc``.

Dimensions ``time`` (frames, in the user's time unit), ``cell`` (a track: a cell linked
across frames by the overlap of its masks keeps its index, NaN / fill where it is absent;
:mod:`fcsweep.measure.tracking`; with ``track=False`` the cells of each frame in the order of
their labels), ``mode`` (n = 2..M) and ``lag`` (of the MSD).  Every variable carries its
CF ``units`` and ``long_name`` (:data:`VARIABLES`).

The frames are measured one at a time and their per-cell results spooled to disk
(:mod:`fcsweep.measure.store`): ``measure_to_file`` (the command) writes the same dataset as
``write_measure(measure(...))`` without holding its ``time`` x ``cell`` variables in memory.
"""

from __future__ import annotations

import datetime as _dt
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from fcsweep import __version__
from fcsweep.analysis.stats import time_average
from fcsweep.io.sweepdir import atomic_write
from fcsweep.measure.calibration import resolve
from fcsweep.measure.cells import measure_cells
from fcsweep.measure.frames import PERCOLATION_THRESHOLD, frame_statistics
from fcsweep.measure.readers import MeasureInputError, iter_frames, relabel
from fcsweep.measure.store import CellSpool, append_cell_variables
from fcsweep.measure.contacts import contact_graph
from fcsweep.measure.labels import movie_labels
from fcsweep.measure.tracking import bond_changes, link_frames, tracked_cages, tracked_diffusion, tracked_msd
from fcsweep.model.shape import Q_STAR

__all__ = ["measure", "measure_to_file", "write_measure", "VARIABLES", "OUTPUT_NAME"]

#: File written by ``fcsweep measure`` in its output directory.
OUTPUT_NAME = "measure.nc"

# name -> (dims, units, long_name); units "L", "L2", "T" stand for the user's units.
_C, _T, _M = ("time", "cell"), ("time",), ("time", "cell", "mode")
#: The variables of the measured dataset: dims, CF units ("L" / "L2" the length unit and its
#: square, "T" the time unit) and long name.
VARIABLES = {
    "label": (_C, "1", "mask label of the cell in its frame (0: no cell)"),
    "x": (_C, "L", "centroid x (column direction) of the cell's mask"),
    "y": (_C, "L", "centroid y (row direction) of the cell's mask"),
    "area": (_C, "L2", "area of the cell's mask"),
    "perimeter_contour": (_C, "L", "length of the marching-squares contour of the mask (biased high)"),
    "perimeter_fit": (_C, "L", "perimeter of the least-squares fit of R(phi) with M modes to the contour"),
    "q_fit": (_C, "1", "shape index P / sqrt(A) of the fitted R(phi) (rounds corners, fails on elongated cells)"),
    "perimeter": (_C, "L", "perimeter: the fit's for smooth cells, the corner-preserving polygon's for cells with "
                           "corners or not star-shaped (q_estimator)"),
    "q": (_C, "1", "shape index P / sqrt(A) with A the mask area (docs/measure.md: How q is measured)"),
    "q_err": (_C, "1", "resolution error of q: the estimator's per-cell rms error on the validation shapes at the "
                       "cell's size"),
    "q_estimator": (_C, "1", "perimeter estimator of q: 1 fit, 2 polygon, 3 blurred outline, 0 none"),
    "shape_flag": (_C, "1", "0 measured; why the cell has no shape: 1 cut by the image edge, 2 split label, "
                            "3 sliver, 4 unresolved"),
    "a": (_M, "1", "Fourier coefficient a_n of R(phi) about the centroid, lab frame, in units of sqrt(A / pi)"),
    "b": (_M, "1", "Fourier coefficient b_n of R(phi) about the centroid, lab frame, in units of sqrt(A / pi)"),
    "c_abs": (_M, "1", "rotation-invariant mode amplitude sqrt(a_n^2 + b_n^2)"),
    "star_shaped": (_C, "1", "1 if the contour is star-shaped about the centroid (the fit is meaningful)"),
    "edge_cut": (_C, "1", "1 if the mask touches the image edge (left out of the shape statistics)"),
    "n_sides": (_C, "1", "Voronoi neighbours of the centroid (-1: Voronoi cell reaches the field-of-view edge)"),
    "defect": (_C, "1", "1 defect (n_sides != 6), 0 not, -1 not classified (Voronoi cell reaches the edge)"),
    "n_cells": (_T, "1", "cells in the frame"),
    "n_edge_cut": (_T, "1", "cells cut by the image edge, left out of the shape statistics"),
    "n_split": (_T, "1", "cells whose label is split into separate pieces, left out of the shape statistics"),
    "n_sliver": (_T, "1", "slivers (too small or too thin to measure), left out of the shape statistics"),
    "n_unresolved": (_T, "1", "cells without a resolved outline, left out of the shape statistics"),
    "n_boundary": (_T, "1", "cells whose Voronoi cell reaches the field-of-view edge, neither defect nor not"),
    "n_classified": (_T, "1", "cells classified as defect or not"),
    "q_mean": (_T, "1", "mean shape index over the measured cells (shape_flag 0)"),
    "q_mean_err": (_T, "1", "standard error of q_mean over the cells of the frame"),
    "q_frac_above": (_T, "1", f"fraction of cells with q > q* = {Q_STAR}"),
    "rho_d": (_T, "1", "defect fraction among the classified cells (Voronoi of the centroids, open boundaries)"),
    "n_defects": (_T, "1", "defect cells"),
    "n_clusters": (_T, "1", "defect clusters (connected over Voronoi adjacency)"),
    "largest_cluster_fraction": (_T, "1", "largest defect cluster / classified cells"),
    "percolated": (_T, "1", "1 if rho_d > percolation_threshold"),
    "spanning": (_T, "1", "1 if a defect cluster touches two opposite edges of the field of view"),
    "psi6": (_T, "1", "global hexatic order |mean psi6_i| over the classified cells"),
    "bond_change_fraction": (_T, "1", "fraction of the neighbour bonds between cells classified in this and the "
                                      "previous frame that changed (NaN in the first frame)"),
    "msd": (("lag",), "L2", "drift-subtracted mean squared displacement of the cells tracked, uncut, through "
                            "every frame "
                            "(NaN for unequally spaced frames)"),
    "n_tracked": ((), "1", "cells tracked, not cut by the image edge, through every frame (those of the msd)"),
    "D_s": ((), "L2/T", "long-time self-diffusion coefficient of the tracked cells (the simulations' estimator; "
                        "active-Brownian fit with Dr, else linear)"),
    "D_s_err": ((), "L2/T", "1-sigma error of D_s"),
    "D_s_diffusive": ((), "1", "1 if the MSD slope has settled (and, with Dr, the movie spans 8 / Dr): D_s is a "
                               "long-time value; 0 if not"),
    "D_eff": ((), "1", "D_s / D0 with D0 = v0^2 / (2 Dr) from the given v0 and Dr (NaN without them)"),
    "D_eff_err": ((), "1", "1-sigma error of D_eff"),
    "neighbour_spacing": ((), "L", "neighbour spacing a of a triangular lattice at the cells' density"),
    "cage_msd_ratio": ((), "1", "cage-relative MSD over a^2 at the cage test's lag (> 1: cages broken)"),
    "cage_msd_ratio_err": ((), "1", "1-sigma error of cage_msd_ratio"),
    "cage_broken_probability": ((), "1", "P(cage_msd_ratio > 1)"),
    "tau_alpha": ((), "T", "lag where F_s(2 pi / a, t) of the cage-relative displacements falls below 1/e"),
    "D_s_cr_late": ((), "L2/T", "self-diffusion from the cage-relative MSD past the cage breaking"),
    "D_s_cr_late_err": ((), "L2/T", "1-sigma error of D_s_cr_late"),
    "D_eff_cr_late": ((), "1", "D_s_cr_late / D0 (with v0 and Dr)"),
    "D_eff_cr_late_err": ((), "1", "1-sigma error of D_eff_cr_late"),
    "cage_msd": (("cage_lag",), "L2", "cage-relative mean squared displacement of the tracked cells"),
    "F_s": (("cage_lag",), "1", "self-intermediate scattering function F_s(2 pi / a, t) of the cage-relative "
                                "displacements"),
}
#: Per-frame series averaged over the movie (``<name>_movie`` and ``<name>_movie_err``).
AVERAGED = ("q_mean", "q_frac_above", "rho_d", "largest_cluster_fraction", "psi6")
for _name in AVERAGED:
    VARIABLES[f"{_name}_movie"] = ((), "1", f"{_name} averaged over the frames (all kept: a movie has no "
                                            "equilibration to cut)")
    VARIABLES[f"{_name}_movie_err"] = ((), "1", f"1-sigma error of {_name}_movie from the frames' autocorrelation "
                                                "(NaN with fewer than 4 frames)")
#: Movie labels (``<name>_movie`` int8 flags with ``_confidence`` and ``_reason``; :mod:`fcsweep.measure.labels`).
LABELS = {"percolated": "percolation label of the movie: rho_d_movie > percolation_threshold with its error",
          "phase": "phase label of the movie: the simulations' rule with v0 and Dr; without them broken cages "
                   "alone (fluid or soft fluid from q_mean_movie > 3.81), intact cages undetermined"}
_CAGE = ("neighbour_spacing", "cage_msd_ratio", "cage_msd_ratio_err", "cage_broken_probability", "tau_alpha",
         "D_s_cr_late", "D_s_cr_late_err", "D_eff_cr_late", "D_eff_cr_late_err", "cage_msd", "F_s")
_MOVIE = ("msd", "n_tracked", "D_s", "D_s_err", "D_s_diffusive", "D_eff", "D_eff_err", *_CAGE,
          *(f"{n}_movie{e}" for n in AVERAGED for e in ("", "_err")))

_CELL_INT = {"label": 0, "n_sides": -1, "defect": -1, "q_estimator": -1, "shape_flag": -1}


def _check_times(times) -> None:
    """Time stamps must be finite and increase from frame to frame (their count is checked after the frames)."""
    if times is None:
        return
    t = np.asarray(times, dtype=float).ravel()
    if not np.all(np.isfinite(t)):
        raise MeasureInputError(f"--times must be finite numbers, got {','.join(f'{v:g}' for v in t)}")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise MeasureInputError(f"--times must increase from frame to frame, got {','.join(f'{v:g}' for v in t)}: "
                                f"frame {k} is at {t[k]:g}, not after frame {k - 1} at {t[k - 1]:g}")


def _pixel_pair(pixel_size) -> tuple[float, float]:
    px, py = (pixel_size, pixel_size) if np.ndim(pixel_size) == 0 else tuple(pixel_size)
    px, py = float(px), float(py)
    if not (np.isfinite(px) and np.isfinite(py) and px > 0 and py > 0):
        raise MeasureInputError(f"pixel size must be positive, got {pixel_size!r}")
    return px, py


def measure(labels, pixel_size=None, frame_interval=None, *, modes: int = 6, length_unit: str | None = None,
            time_unit: str | None = None, times=None, percolation_threshold: float = PERCOLATION_THRESHOLD,
            track: bool = True, v0: float | None = None, Dr: float | None = None,
            neighbours: str = "voronoi", scratch=None, label_binary: bool = False) -> xr.Dataset:
    """Measure a segmented image or movie of a cell monolayer.

    Parameters
    ----------
    labels : ndarray, path, list of paths, or iterable of 2-D arrays
        Integer label frames, 0 = background, 1..n = cells (:func:`fcsweep.measure.readers.iter_frames`):
        a 2-D or T x Y x X array, a TIFF, PNG or Cellpose ``_seg.npy`` file or a directory of
        them, or an iterator of frames (read one at a time).
    pixel_size : float or (float, float), optional
        Pixel width (and height) in ``length_unit``.  Default: from the OME / ImageJ
        metadata of a TIFF, else 1.  Each of these four must agree with the metadata
        where both exist (:mod:`fcsweep.measure.calibration`).
    frame_interval : float, optional
        Time between frames in ``time_unit`` (unused when ``times`` is given); default
        from the metadata, else 1.
    modes : int
        Highest Fourier mode M of the contour fit (>= 2).
    length_unit, time_unit : str, optional
        CF / UDUNITS unit strings written into the dataset (e.g. ``"um"``, ``"min"``);
        default from the metadata, else ``"1"``.
    times : array_like, optional
        Time stamp of each frame.
    percolation_threshold : float
        rho_d above which a frame is percolated.
    track : bool
        Link cells across frames by mask overlap (:mod:`fcsweep.measure.tracking`): the
        ``cell`` index is then a track.  The MSD and D_s need it.
    neighbours : {"voronoi", "contact"}
        The neighbour graph of the defects: the Voronoi of the centroids with open
        boundaries (the paper's rule, default) or the touching masks
        (:mod:`fcsweep.measure.contacts`).
    v0, Dr : float, optional
        Self-propulsion speed (length / time) and rotational diffusion (1 / time) of the
        cells, if known: ``Dr`` selects the active-Brownian fit of D_s, both give ``D_eff``.
    label_binary : bool
        Label a binary mask (one value in separate pieces) by its 8-connected pieces; by default
        it is refused (:class:`MeasureInputError`).
    scratch : path-like, optional
        Directory for the temporary spool of the per-cell results (default: the system's
        temporary directory); about 0.2 kB per cell and frame, removed on return.

    Returns
    -------
    xarray.Dataset
        The variables of :data:`VARIABLES` on dimensions ``time``, ``cell``, ``mode``.

    Raises
    ------
    MeasureInputError
        Input that is not a usable label image (the message says which frame and why).
    """
    with _Run(labels, pixel_size, frame_interval, modes=modes, length_unit=length_unit, time_unit=time_unit,
              times=times, percolation_threshold=percolation_threshold, track=track, v0=v0, Dr=Dr,
              neighbours=neighbours, scratch=scratch, label_binary=label_binary) as run:
        ds = run.small.assign({name: run.cell_variable(name) for name in run.cell_names})
    return ds[[n for n in VARIABLES if n in ds] + [n for n in ds.data_vars if n not in VARIABLES]]


class _Run:
    """One pass over the frames: the per-cell results go to a :class:`CellSpool` on disk, the
    per-frame ones stay in memory.  ``small`` is the dataset without the ``time`` x ``cell``
    variables (:attr:`cell_names`), which :meth:`cell_variable` assembles."""

    def __init__(self, labels, pixel_size, frame_interval, *, modes, length_unit, time_unit, times,
                 percolation_threshold, track, v0, Dr, neighbours, scratch, label_binary=False):
        if int(modes) < 2:
            raise MeasureInputError(f"modes must be >= 2, got {modes}")
        if neighbours not in ("voronoi", "contact"):
            raise MeasureInputError(f"neighbours must be 'voronoi' or 'contact', got {neighbours!r}")
        if frame_interval is not None and not (np.isfinite(frame_interval) and frame_interval > 0):
            raise MeasureInputError(f"frame interval must be positive, got {frame_interval!r}")
        _check_times(times)
        cal = resolve(labels, None if pixel_size is None else _pixel_pair(pixel_size), frame_interval, length_unit,
                      time_unit)
        self.modes = int(modes)
        self.label_binary = bool(label_binary)
        self.cell_names = [n for n, (dims, _, _) in VARIABLES.items() if dims in (_C, _M)]
        self.spool = CellSpool({n: (self._dtype(n), self._tail(n)) for n in self.cell_names}, scratch)
        try:
            self.small = self._measure(labels, cal, times, percolation_threshold, track, v0, Dr, neighbours)
        except BaseException:
            self.spool.close()
            raise

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.spool.close()

    @staticmethod
    def _dtype(name):
        if name == "label":
            return np.int64
        return np.int32 if name in _CELL_INT else np.float64

    def _tail(self, name):
        return (self.modes - 1,) if VARIABLES[name][0] == _M else ()

    def cell_variable(self, name: str, frames: slice = slice(None)) -> xr.Variable:
        """The ``time`` x ``cell`` (x ``mode``) variable ``name``, of ``frames``."""
        dims, unit, long_name = VARIABLES[name]
        arr = self.spool.dense(name, self.ncell, _CELL_INT.get(name, np.nan), self._dtype(name), frames)
        return xr.Variable(dims, arr, {"units": self.units[unit], "long_name": long_name})

    def _measure(self, labels, cal, times, percolation_threshold, track, v0, Dr, neighbours) -> xr.Dataset:
        px, py = cal.pixel_size
        frame_interval, length_unit, time_unit = cal.frame_interval, cal.length_unit, cal.time_unit
        modes = self.modes
        per_frame, shape = [], None
        prev, prev_tracks, next_id = None, {}, 0
        prev_bonds = prev_index = None
        warned = False
        for where, frame in iter_frames(labels, label_binary=self.label_binary):
            shape = frame.shape
            frame, originals = relabel(frame)
            try:
                cells = measure_cells(frame, (px, py), modes)
            except MemoryError:
                raise MeasureInputError(f"{where}: out of memory measuring a frame of {shape[0]} x {shape[1]} "
                                        "pixels") from None
            if track:
                cells["index"], next_id = link_frames(prev, prev_tracks, frame, cells["label"], next_id)
                prev, prev_tracks = frame, dict(zip(cells["label"].tolist(), cells["index"].tolist()))
            else:
                cells["index"] = np.arange(len(cells["label"]))
                next_id = max(next_id, len(cells["label"]))
            graph = contact_graph(frame, cells["label"]) if neighbours == "contact" else None
            if graph is not None and not warned:
                alone = int(np.sum(graph.interior & (graph.n_sides == 0)))
                if alone > 0.5 * max(int(graph.interior.sum()), 1):
                    warned = True
                    warnings.warn(f"{where}: --neighbours contact leaves {alone} of {int(graph.interior.sum())} "
                                  "classified cells without a touching neighbour (gaps between the masks?): they "
                                  "count as defects; the Voronoi rule (the default) does not need touching masks",
                                  UserWarning, stacklevel=2)
            stats = frame_statistics(cells, (0.0, shape[1] * px, 0.0, shape[0] * py), percolation_threshold, graph)
            cells.update(n_sides=stats.pop("n_sides"), defect=stats.pop("defect"))
            bonds = stats.pop("bonds")
            stats["bond_change_fraction"] = bond_changes(prev_bonds, prev_index, bonds, cells["index"]) \
                if (track and prev_bonds is not None) else np.nan
            prev_bonds, prev_index = bonds, cells["index"]
            if originals is not None:
                cells["label"] = originals[cells["label"] - 1]
            self.spool.append(cells, cells["index"])
            per_frame.append(stats)
        del prev, frame
        T = len(per_frame)
        if times is None:
            t = np.arange(T) * float(frame_interval)
        else:
            t = np.asarray(times, dtype=float)
            if t.shape != (T,):
                raise MeasureInputError(f"--times: {t.size} time stamps given for {T} frames; give one per frame")
        self.ncell = ncell = next_id
        units = {"L": length_unit, "L2": f"{length_unit}2" if length_unit != "1" else "1", "T": time_unit, "1": "1"}
        units["L2/T"] = " ".join([u for u in (units["L2"], f"{time_unit}-1") if u not in ("1", "1-1")]) or "1"
        self.units = units
        data = {}
        for name, (dims, unit, long_name) in VARIABLES.items():
            if dims == _T:
                data[name] = xr.Variable(dims, np.array([f[name] for f in per_frame], dtype=float),
                                         {"units": units[unit], "long_name": long_name})
        dt = np.diff(t)
        even = T < 2 or np.allclose(dt, dt[0], rtol=1e-6)
        # the MSD's window average needs equally spaced frames; a cut cell's centroid moves with the cut
        cut = self.spool.dense("edge_cut", ncell, np.nan, np.float64) == 1
        xs, ys = (self.spool.dense(v, ncell, np.nan, np.float64) for v in ("x", "y"))
        xs[cut], ys[cut] = np.nan, np.nan
        del cut
        msd, n_tracked = tracked_msd(xs, ys) if track else (np.full(T, np.nan), 0)
        if not even:
            msd = np.full(T, np.nan)
        diff = tracked_diffusion(t, xs, ys, v0=v0, Dr=Dr) if (track and even) \
            else tracked_diffusion(t[:1], xs[:1], ys[:1])
        bounds = (0.0, shape[1] * px, 0.0, shape[0] * py)
        n_eff = float(np.mean(data["n_cells"].values - data["n_edge_cut"].values / 2))  # a cut cell counts half
        cb, cage = tracked_cages(t, xs, ys, bounds, n_eff, v0=v0, Dr=Dr) \
            if (track and even) else (None, tracked_cages(t[:1], xs[:1], ys[:1], bounds, 1.0)[1])
        del xs, ys
        diff.update(cage)
        lags_cr = cb.lags if cb is not None else np.zeros(0)
        diff.update(cage_msd=cb.cr_msd if cb is not None else np.zeros(0),
                    F_s=cb.F_s if cb is not None else np.zeros(0))
        for name in AVERAGED:
            series = data[name].values
            avg = time_average(series, equilibrate=False) if np.all(np.isfinite(series)) else None
            diff[f"{name}_movie"] = avg.mean if avg else np.nan
            diff[f"{name}_movie_err"] = avg.err if avg else np.nan
        for name, value in (("msd", msd), ("n_tracked", np.int32(n_tracked)), *diff.items()):
            dims, unit, long_name = VARIABLES[name]
            data[name] = xr.Variable(dims, value, {"units": units[unit], "long_name": long_name})
        for name, (code, conf, reason, flags) in movie_labels(diff, threshold=percolation_threshold).items():
            data[f"{name}_movie"] = xr.Variable((), np.int8(code), {"long_name": LABELS[name], **flags})
            data[f"{name}_movie_confidence"] = xr.Variable((), float(conf), {
                "units": "1", "long_name": f"probability of the most probable {name} label"})
            data[f"{name}_movie_reason"] = xr.Variable((), str(reason),
                                                       {"long_name": f"why {name}_movie is what it is"})
        ds = xr.Dataset(data, coords={
            "time": ("time", t, {"units": time_unit, "long_name": "time of the frame"}),
            "mode": ("mode", np.arange(2, modes + 1, dtype=np.int32),
                     {"units": "1", "long_name": "Fourier mode number n"}),
            "lag_time": ("lag", np.arange(T) * (dt[0] if T > 1 else 0.0),
                         {"units": time_unit, "long_name": "lag time of the msd"}),
            "cage_lag_time": ("cage_lag", np.asarray(lags_cr, dtype=float),
                              {"units": time_unit, "long_name": "lag time of cage_msd and F_s"})})
        ds.attrs.update(Conventions="CF-1.8", title="fcsweep measure: shape and defect observables of a segmented "
                        "cell monolayer", pixel_size_x=px, pixel_size_y=py, length_unit=length_unit,
                        time_unit=time_unit, modes=modes, neighbours=neighbours,
                        v0=np.nan if v0 is None else float(v0),
                        Dr=np.nan if Dr is None else float(Dr), percolation_threshold=float(percolation_threshold),
                        image_shape=np.asarray(shape, dtype=np.int32), q_star=Q_STAR,
                        history=f"{_dt.datetime.now(_dt.timezone.utc).isoformat(timespec='seconds')} fcsweep measure",
                        fcsweep_version=__version__)
        return ds


def _encoding(ds: xr.Dataset) -> dict:
    return {v: {"_FillValue": None if v in ds.coords else np.nan} for v in ds.variables if ds[v].dtype.kind == "f"}


def measure_to_file(labels, out_dir, pixel_size=None, frame_interval=None, *, attrs: dict | None = None,
                    **options) -> Path:
    """Measure ``labels`` and write ``out_dir/measure.nc`` without holding the ``time`` x
    ``cell`` variables in memory: the file that ``write_measure(measure(labels, ...))``
    writes, with the same variables, values and attributes.

    Parameters
    ----------
    labels, pixel_size, frame_interval
        As :func:`measure`.
    out_dir : path-like
        Output directory (made if missing); the per-cell results are spooled to a
        temporary directory in it while the frames are measured.
    attrs : dict, optional
        Global attributes to add (e.g. ``source``).
    **options
        The keyword options of :func:`measure`.

    Returns
    -------
    Path
        ``out_dir/measure.nc``.
    """
    out_dir = Path(out_dir)
    made = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    options.setdefault("scratch", out_dir)  # not the system's /tmp, often a RAM disk
    try:
        return _stream(labels, out_dir, pixel_size, frame_interval, attrs, options)
    except BaseException:
        if made and not any(out_dir.iterdir()):
            out_dir.rmdir()
        raise


def _stream(labels, out_dir, pixel_size, frame_interval, attrs, options) -> Path:
    with _Run(labels, pixel_size, frame_interval, **_run_options(options)) as run:
        small = run.small
        small.attrs.update(attrs or {})
        cells = {}
        for name in run.cell_names:
            dims, unit, long_name = VARIABLES[name]
            cells[name] = (dims, run._dtype(name), _CELL_INT.get(name, np.nan),
                           {"units": run.units[unit], "long_name": long_name})

        def write(tmp):
            small.to_netcdf(tmp, format="NETCDF4", encoding=_encoding(small))
            append_cell_variables(tmp, run.spool, run.ncell, cells)

        return atomic_write(out_dir / OUTPUT_NAME, write, suffix=".nc")


def _run_options(options: dict) -> dict:
    defaults = dict(modes=6, length_unit=None, time_unit=None, times=None, percolation_threshold=PERCOLATION_THRESHOLD,
                    track=True, v0=None, Dr=None, neighbours="voronoi", scratch=None, label_binary=False)
    unknown = set(options) - set(defaults)
    if unknown:
        raise TypeError(f"unknown options {sorted(unknown)}")
    return {**defaults, **options}


def write_measure(ds: xr.Dataset, out_dir) -> Path:
    """Write ``ds`` to ``out_dir/measure.nc`` through :func:`fcsweep.io.sweepdir.atomic_write`."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return atomic_write(out_dir / OUTPUT_NAME, lambda tmp: ds.to_netcdf(tmp, format="NETCDF4", encoding=_encoding(ds)),
                        suffix=".nc")
