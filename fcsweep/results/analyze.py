"""File-level analysis pipeline: one run -> analysis.h5, and every finished run of a sweep.

Entry points called by the CLI (``fcsweep analyze | aggregate | plot``):

- :func:`analyze_run` reads one trajectory, computes every observable of docs/model.md over the
  frames after the transient and writes ``analysis.h5`` beside it (atomically);
- :func:`analyze_sweep` does that for every finished run of a sweep, in parallel,
  skipping runs analysed with the same settings unless ``force``;
- :func:`fcsweep.results.aggregate.aggregate_sweep` (a separate module, which imports this
  one and never the other way round) collects the per-run files into one NetCDF dataset;
  figures are drawn by :mod:`fcsweep.results.figures`.

Analysis settings (``DEFAULT_SETTINGS``; stored with every result):

- ``transient``: fraction of the recorded frames discarded at the start; after it,
  automatic equilibration detection (:mod:`fcsweep.analysis.stats`) on the frame series
  of ``<q>`` and ``rho_d`` may cut more: the MSD uses the frames from the later of the
  two starts (``t_equilibrated``), at most half of them cut
  (:func:`fcsweep.analysis.run_observables.equilibrated_frames`);
- D_s from ``max_time_blocks`` time blocks of at least ``min_block_persistence / Dr``,
  fitted to the active-Brownian MSD form from ``fit_start`` x half a block on, error
  from time blocks and the scatter of the cells' own slopes with their spatial inefficiency
  (see :func:`fcsweep.analysis.diffusion.estimate_diffusion`);
- cage breaking over the same frames: cage-relative MSD against the squared neighbour
  spacing, F_s and tau_alpha, and past the breaking the cage-relative D_eff_cr_late
  (:mod:`fcsweep.analysis.cage`); the phase rule (:func:`fcsweep.analysis.phase.phase_label`)
  reads D_eff_cr_late where the cages broke, else a trustworthy D_eff_cr for "solid";
- q on up to ``shape_frames`` evenly spaced frames; Voronoi defects and clusters and
  |Psi6| on up to ``structure_frames`` frames; G6 and Gr on up to
  ``correlation_frames`` frames (they cost O(N * pairs within L/2)); every frame
  average carries the error of a correlated time series;
- labels need the probability ``label_confidence`` (default 0.95; :mod:`fcsweep.analysis.phase`),
  and a run is percolated where rho_d exceeds ``percolation_threshold`` (default 1/2); the
  config's ``analysis`` section sets both (:func:`config_settings`);
- lengths of G6(r) and Gr(dx, 0) in units of R0, bin widths ``g6_dr`` and ``gr_dx``;
- ``correlations`` (:data:`OPTIONAL_SETTINGS`, the config's ``analysis.correlations``):
  G6, C_G1 and G_r from the pair counts (``pairs``) or by FFT on a grid (``fft``,
  :mod:`fcsweep.analysis.correlation_fft`); the default ``auto`` is ``pairs`` up to
  ``PAIRS_MAX_N`` = 10^4 cells and ``fft`` above (:func:`fcsweep.config.settings.settings_for_run`).
  It is stored only where it is not ``pairs`` at N <= 10^4, so analysis.h5 files written
  before it existed stay current.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import multiprocessing
import os
import signal
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import h5py
import numpy as np

from fcsweep import __version__
from fcsweep.analysis.phase import phase_name
from fcsweep.analysis.reasons import reason_flags
from fcsweep.analysis import run_observables
from fcsweep.analysis.frames import FrameSource
from fcsweep.analysis.run_observables import AnalysisError, RunFrames, frame_plan
from fcsweep.config.settings import DEFAULT_CORRELATIONS, RunSettings, settings_for_run
from fcsweep.io import schema
from fcsweep.io.failures import Terminated, WriteFailure, advice, remove_stale
from fcsweep.io.machine import worker_layout
from fcsweep.io.rundir import analysis_is_current
from fcsweep.io.sweepdir import atomic_write, run_path, run_state
from fcsweep.io.trajectory import TrajectoryError, open_trajectory
from fcsweep.model.settings import AnalysisSettings
from fcsweep.model.observables import CURVES, LABELS, REASON_CODES, REASONS, RUN_SCALARS

__all__ = ["ANALYSIS_FILE", "ANALYSIS_ERROR_FILE", "DATASET_FILE", "DEFAULT_SETTINGS", "DEFAULT_TRANSIENT",
           "OPTIONAL_SETTINGS",
           "SCALARS", "STATUS_FILE", "TRAJECTORY_FILE", "TrajectoryFrames", "UNWRITTEN", "AnalysisError",
           "analyze_run", "analyze_sweep",
           "config_settings", "label_summary", "read_analysis", "read_run_frames", "settings_with",
           "trajectory_observables"]

#: File names of a sweep directory (declared once, in :mod:`fcsweep.io.schema`).
ANALYSIS_FILE = schema.ANALYSIS
TRAJECTORY_FILE = schema.TRAJECTORY
STATUS_FILE = schema.STATUS
DATASET_FILE = schema.DATASET
#: Written beside the trajectory when its analysis fails (the reason), removed on success.
ANALYSIS_ERROR_FILE = schema.ANALYSIS_ERROR
#: Status of a run whose analysis.h5 could not be written (full disk, quota, read-only).
UNWRITTEN = "not written"

#: The transient of a run without ``run.transient``: the config's own default.
DEFAULT_TRANSIENT = {f.name: f.default for f in dataclasses.fields(RunSettings)}["transient"]

#: The analysis settings at their defaults, as the analysis reads and stores them
#: (:class:`fcsweep.model.settings.AnalysisSettings`, the one table of them).
DEFAULT_SETTINGS = AnalysisSettings().as_dict()

#: Settings that may be absent, with the meaning of their absence: ``correlations`` is
#: ``auto`` until :func:`fcsweep.config.settings.settings_for_run` resolves it for a run
#: (stored only as ``"fft"``; absent in a stored file: the pair counts).
OPTIONAL_SETTINGS = {"correlations": DEFAULT_CORRELATIONS}

#: Scalar observables stored as attributes of ``/observables`` in analysis.h5: the per-run
#: numbers and label codes of the observable table (:mod:`fcsweep.model.observables`);
#: beside them the label explanations ``REASONS`` as strings.
SCALARS = RUN_SCALARS + LABELS


def settings_with(overrides=None, *, transient=None) -> dict:
    """Analysis settings: the defaults updated by ``overrides`` and ``transient``, each value
    checked against the table (:class:`fcsweep.model.settings.AnalysisSettings`; unknown
    keys and values out of range raise ``ValueError``).

    A key of :data:`OPTIONAL_SETTINGS` is present only where it differs from its default
    (``correlations``: ``pairs`` or ``fft`` where asked for, absent for ``auto``); a run's
    analysis resolves it with :func:`fcsweep.config.settings.settings_for_run`.
    """
    values = dict(overrides or {})
    if transient is not None:
        values["transient"] = float(transient)
    return AnalysisSettings.from_dict(values).as_dict()


def config_settings(config) -> dict:
    """The analysis settings a sweep's config sets: its ``analysis`` section
    (``label_confidence``, ``percolation_threshold``, ``correlations`` where not the
    default); {} for a config without one."""
    analysis = getattr(config, "analysis", None)
    return dict(analysis.config_dict()) if analysis is not None else {}


# ------------------------------------------------------------------ one run: read (the computation is
# fcsweep.analysis.run_observables, arrays in, dict out)

def read_run_frames(traj, settings: dict) -> RunFrames:
    """The arrays of an opened trajectory that :func:`fcsweep.analysis.run_observables.compute_observables`
    reads: frame times, box, parameters, and the per-cell fields on the frames of its
    :func:`fcsweep.analysis.run_observables.frame_plan`.

    Parameters
    ----------
    traj : fcsweep.io.trajectory.Trajectory
    settings : dict
        Analysis settings (:func:`settings_with`).

    Returns
    -------
    RunFrames
    """
    plan = frame_plan(traj.n_frames, settings, source=str(traj.path))
    p = traj.params
    rigid = traj.modes_width == 0 and int(p.get("modes", 1) or 0) == 0
    a = b = None
    if not rigid and "shape_a" in traj.fields and "shape_b" in traj.fields:
        a, b = (TrajectoryFrames(traj, name, plan.shape_frames) for name in ("shape_a", "shape_b"))
    wall_pos = wall_theta = None
    if str(p.get("boundary", "periodic")) != "periodic" and "theta" in traj.fields:  # the pressure on the wall
        wall_pos = TrajectoryFrames(traj, "position", plan.shape_frames)
        wall_theta = TrajectoryFrames(traj, "theta", plan.shape_frames)
    return RunFrames(source=str(traj.path), params=p, box=traj.box, time=traj.time, plan=plan, shape_a=a,
                     shape_b=b, rigid=rigid, positions=TrajectoryFrames(traj, "position", plan.structure_frames),
                     unwrapped=TrajectoryFrames(traj, "position", plan.frames, unwrap=True), radii=traj.radii,
                     wall_positions=wall_pos, wall_theta=wall_theta)


class TrajectoryFrames(FrameSource):
    """One field of a trajectory on some of its frames, read from the file in pieces
    (:class:`fcsweep.analysis.frames.FrameSource`): nothing is held but the piece asked for.

    Parameters
    ----------
    traj : fcsweep.io.trajectory.Trajectory
    name : str
        ``position``, ``theta`` (shape (T, N)), ``shape_a`` or ``shape_b``.
    frames : array_like of int
        Trajectory frame indices, increasing.
    unwrap : bool
        With ``name = "position"``: unwrapped centroids ``position + image * edges``, the
        values of :meth:`fcsweep.io.trajectory.Trajectory.unwrapped`.
    """

    def __init__(self, traj, name: str, frames, *, unwrap: bool = False):
        self._traj, self._name, self._unwrap = traj, name, unwrap
        width = traj.modes_width if name.startswith("shape") else 2
        shape = (traj.n_frames, traj.n_cells) if name == "theta" else (traj.n_frames, traj.n_cells, width)
        super().__init__(shape, rows=frames)

    def _read(self, rows, lo, hi):
        cells = slice(lo, hi)
        out = np.asarray(self._traj.read(self._name, rows, cells=cells), dtype=float)
        if self._unwrap and "image" in self._traj.fields:
            out = out + self._traj.read("image", rows, cells=cells) * self._traj.box
        return out


def trajectory_observables(traj, settings: dict, *, curves: bool = True,
                           psi6: bool = True) -> tuple[dict, dict, dict]:
    """:func:`fcsweep.analysis.run_observables.compute_observables` of an opened trajectory
    (:func:`fcsweep.io.trajectory.open_trajectory`); see there for ``curves``, ``psi6`` and
    what it returns."""
    return run_observables.compute_observables(read_run_frames(traj, settings), settings, curves=curves, psi6=psi6)




# ------------------------------------------------------------------ one run: files

def read_analysis(path) -> dict:
    """Read an ``analysis.h5``: ``{"scalars", "curves", "settings", "attrs"}``."""
    with h5py.File(path, "r", locking=False) as f:
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
        sc = {k: (v.decode() if isinstance(v, bytes) else str(v)) if k in REASONS else float(v)
              for k, v in f["observables"].attrs.items()}
        cv = {name: (f["curves"][coord][()], f["curves"][name][()])
              for name, coord in CURVES.items() if name in f["curves"]}
    return {"scalars": sc, "curves": cv, "settings": json.loads(attrs.get("settings_json", "{}")),
            "attrs": attrs}


def _write_analysis(out_path: Path, traj, settings, sc, cv, extra) -> None:
    """Write ``analysis.h5`` through :func:`fcsweep.io.sweepdir.atomic_write` (the old file
    stays until the new one is complete; a full disk raises ``WriteFailure``)."""
    atomic_write(out_path, lambda tmp: _write_h5(tmp, traj, settings, sc, cv, extra), fsync=True)


def _write_h5(tmp: Path, traj, settings, sc, cv, extra) -> None:
    with h5py.File(tmp, "w", locking=False) as f:
        f.attrs["fcsweep_version"] = __version__
        f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        f.attrs["source"] = str(traj.path)
        f.attrs["settings_json"] = json.dumps(settings, sort_keys=True)
        f.attrs[schema.LABEL_RULES_ATTR] = schema.LABEL_RULES
        f.attrs["parameters_json"] = json.dumps(traj.params, sort_keys=True, default=str)
        f.attrs["run_id"] = str(traj.params.get("run_id", ""))
        g = f.create_group("observables")
        for k in SCALARS:
            g.attrs[k] = np.float64(sc[k])
        for k in REASONS:
            g.attrs[k] = str(sc[k])
        for k in REASON_CODES:  # int8 HDF5 enums: the file names its codes
            flags = reason_flags(k.removesuffix("_reason_code"))
            g.attrs.create(k, np.int8(sc[k]), dtype=h5py.enum_dtype({n: c for c, n in flags.items()}, basetype="i1"))
        c = f.create_group("curves")
        for name, coord in CURVES.items():
            x, y = cv[name]
            if coord not in c:
                c.create_dataset(coord, data=np.asarray(x))
            c.create_dataset(name, data=np.asarray(y, dtype=float))
        f.create_dataset("n_sides_counts", data=extra["n_sides_counts"])
        f.create_dataset("frames", data=extra["frames"])


def analyze_run(traj_path, out_path=None, *, transient=DEFAULT_TRANSIENT, force=False, settings=None) -> dict:
    """Analyse one trajectory and write ``analysis.h5``.

    Parameters
    ----------
    traj_path : path-like
        ``trajectory.h5`` of a finished run.
    out_path : path-like, optional
        Output file (default: ``analysis.h5`` beside the trajectory).
    transient : float
        Fraction of recorded frames discarded at the start (overrides ``settings``).
    force : bool
        Recompute even if an analysis with the same settings exists.
    settings : dict, optional
        Overrides of :data:`DEFAULT_SETTINGS`.

    Returns
    -------
    dict
        ``status`` ("done" or "skipped"), ``message``, ``path`` and the scalar observables.

    Raises
    ------
    TrajectoryError, AnalysisError
        With a message naming the file and the problem.
    """
    traj_path = Path(traj_path)
    out_path = Path(out_path) if out_path is not None else traj_path.with_name(ANALYSIS_FILE)
    traj = open_trajectory(traj_path)
    s = settings_for_run(settings_with(settings, transient=transient), traj.n_cells)
    if not force and analysis_is_current(out_path, settings=s):  # the one rule `fcsweep status` uses too
        try:
            old = read_analysis(out_path)
            return {"status": "skipped", "message": "up to date", "path": str(out_path), **old["scalars"]}
        except (OSError, KeyError, ValueError):
            pass  # unreadable: recompute
    sc, cv, extra = trajectory_observables(traj, s)
    _write_analysis(out_path, traj, s, sc, cv, extra)
    return {"status": "done", "message": f"{int(sc['n_frames'])} frames; {label_summary(sc)}",
            "path": str(out_path), **sc}


def label_summary(sc: dict) -> str:
    """One line for a terminal: the phase label with its confidence, or why undetermined."""
    name = phase_name(int(sc["phase"])) if np.isfinite(sc.get("phase", np.nan)) else "unknown"
    if name in ("undetermined", "unknown"):
        return f"{name}: {sc.get('phase_reason', '')}"
    return f"{name} (P = {float(sc['phase_confidence']):.3f})"


def _record_failure(traj_path: Path, reason: str) -> None:
    """A failed analysis (an error of the analysis, not of the disk) leaves no stale
    analysis.h5 behind, and says why."""
    rd = Path(traj_path).parent
    (rd / ANALYSIS_FILE).unlink(missing_ok=True)
    try:
        atomic_write(rd / ANALYSIS_ERROR_FILE, lambda tmp: tmp.write_text(reason + "\n"))
    except OSError:
        pass  # the run stays "not analysed", which aggregate reports too


def _analyze_task(traj_path, transient, force, settings):
    try:
        res = analyze_run(traj_path, transient=transient, force=force, settings=settings)
    except WriteFailure as exc:  # the environment: the previous analysis.h5 stays
        return UNWRITTEN, advice(exc)
    except (KeyboardInterrupt, Terminated, SystemExit) as exc:
        if multiprocessing.parent_process() is not None:  # a -j worker: its files are clean, stop now
            os._exit(130 if isinstance(exc, KeyboardInterrupt) else 143)
        raise
    except (TrajectoryError, AnalysisError) as exc:
        _record_failure(traj_path, str(exc))
        return "failed", str(exc)
    except Exception as exc:  # noqa: BLE001 - report, never crash the sweep
        _record_failure(traj_path, f"{type(exc).__name__}: {exc}")
        return "failed", f"{type(exc).__name__}: {exc}"
    (Path(traj_path).parent / ANALYSIS_ERROR_FILE).unlink(missing_ok=True)
    return res["status"], res["message"]


def _init_worker(threads: int) -> None:
    """Pool processes: freud uses ``threads`` threads, so processes x threads <= cores.
    Ctrl-C reaches the parent, which stops the workers with SIGTERM: a worker exits
    quietly (after the rename of a write under way, see ``atomic_write``)."""
    import freud

    freud.parallel.set_num_threads(threads)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _worker_exit)


def _worker_exit(signum, frame):
    raise SystemExit(143)


def analyze_sweep(config, *, workers=1, force=False, settings=None, say=None) -> list:
    """Analyse every finished run of a sweep.

    Runs that are not done (the state of :func:`fcsweep.io.sweepdir.run_state`, which
    ``fcsweep status`` shows) are reported as "skipped" with their state; analysis errors
    are reported as "failed" (the sweep goes on).  The runs are read once, so points that
    ``fcsweep refine`` adds meanwhile are left for the next call.  The labels use the
    config's ``analysis`` section (:func:`config_settings`), overridden by ``settings``.

    A results file that cannot be written (full disk, quota, read-only run directory:
    :class:`fcsweep.io.failures.WriteFailure`) leaves the previous ``analysis.h5`` as it
    was and is reported as :data:`UNWRITTEN`; the other runs go on.  Temporary files that
    killed analyses left in the run directories are removed first, each told to ``say``.

    Returns
    -------
    list of (run_id, status, message)
        status is "done", "skipped", "failed" or "not written", in run order.
    """
    transient = float(getattr(getattr(config, "run", None), "transient", DEFAULT_SETTINGS["transient"]))
    settings = {**config_settings(config), **dict(settings or {})}
    specs = list(config.runs())
    out = {}
    todo = []
    for spec in specs:
        rd = run_path(config.output, spec.run_id)
        rs = run_state(rd)
        if rs.status is None and rs.state == schema.PENDING:
            out[spec.run_id] = ("skipped", "not run (no status.json)")
        elif rs.state != schema.DONE:
            out[spec.run_id] = ("skipped", f"run {rs.state}" + (f": {rs.reason}" if rs.reason else ""))
        else:
            todo.append((spec.run_id, rd / TRAJECTORY_FILE))
            for tmp in remove_stale(rd, (ANALYSIS_FILE, ANALYSIS_ERROR_FILE)):
                (say or (lambda m: None))(f"removed {tmp}, left by a killed analysis")
    if workers <= 1 or len(todo) <= 1:
        for rid, tp in todo:
            out[rid] = _analyze_task(tp, transient, force, settings)
    else:
        processes, threads = worker_layout(workers)
        pool = ProcessPoolExecutor(max_workers=processes, initializer=_init_worker, initargs=(threads,))
        try:
            futs = {pool.submit(_analyze_task, tp, transient, force, settings): rid for rid, tp in todo}
            for fut in as_completed(futs):
                try:
                    out[futs[fut]] = fut.result()
                except Exception as exc:  # noqa: BLE001 - e.g. a worker killed for memory
                    out[futs[fut]] = ("failed", f"{type(exc).__name__}: {exc}")
        except BaseException:  # a signal: workers stop now, removing their temporary files
            for proc in list(getattr(pool, "_processes", {}).values()):
                proc.terminate()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    return [(spec.run_id, *out[spec.run_id]) for spec in specs]
