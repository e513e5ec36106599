"""File-level analysis pipeline: one run -> analysis.h5, and every finished run of a sweep.

Entry points called by the CLI (``fcsweep analyze | aggregate | plot``):

- :func:`analyze_run` reads one trajectory, computes every observable of docs/model.md over the
  frames after the transient and writes ``analysis.h5`` beside it (atomically);
- :func:`analyze_sweep` does that for every finished run of a sweep, in parallel,
  skipping runs analysed with the same settings unless ``force``;
- :func:`fcsweep.analysis.aggregate.aggregate_sweep` (a separate module, which imports this
  one and never the other way round) collects the per-run files into one NetCDF dataset;
  figures are drawn by :mod:`fcsweep.analysis.figures`.

Analysis settings (``DEFAULT_SETTINGS``; stored with every result):

- ``transient``: fraction of the recorded frames discarded at the start; after it,
  automatic equilibration detection (:mod:`fcsweep.analysis.stats`) on the frame series
  of ``<q>`` and ``rho_d`` may cut more: the MSD uses the frames from the later of the
  two starts (``t_equilibrated``), at most half of them cut (:func:`equilibrated_frames`);
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
- lengths of G6(r) and Gr(dx, 0) in units of R0, bin widths ``g6_dr`` and ``gr_dx``.
"""

from __future__ import annotations

import datetime as _dt
import json
import multiprocessing
import os
import signal
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import h5py
import numpy as np

from fcsweep import __version__
from fcsweep.analysis import cage, diffusion, kthny, order, shapes, voronoi
from fcsweep.analysis.msd import log_lag_indices, msd_curve
from fcsweep.analysis.phase import (MIN_CONFIDENCE, RHO_D_PERCOLATION, cage_evidence, classify_percolation,  # noqa: F401
                                    phase_evidence, phase_label, phase_name, solid_test_estimate)
from fcsweep.analysis.stats import time_average
from fcsweep.analysis.trajectory import TrajectoryError, open_trajectory
from fcsweep.io import schema
from fcsweep.io.machine import worker_layout
from fcsweep.io.observables import CURVES, LABELS, RUN_SCALARS
from fcsweep.io.failures import Terminated, WriteFailure, advice, remove_stale
from fcsweep.io.sweepdir import atomic_write, run_path, run_state

#: File names of a sweep directory (declared once, in :mod:`fcsweep.io.schema`).
ANALYSIS_FILE = schema.ANALYSIS
TRAJECTORY_FILE = schema.TRAJECTORY
STATUS_FILE = schema.STATUS
DATASET_FILE = schema.DATASET
#: Written beside the trajectory when its analysis fails (the reason), removed on success.
ANALYSIS_ERROR_FILE = schema.ANALYSIS_ERROR
#: Status of a run whose analysis.h5 could not be written (full disk, quota, read-only).
UNWRITTEN = "not written"

DEFAULT_SETTINGS = {
    "transient": 0.2,
    "fit_start": 0.2,
    "max_time_blocks": 8,
    "min_block_persistence": 8.0,
    "label_confidence": MIN_CONFIDENCE,
    "percolation_threshold": RHO_D_PERCOLATION,
    "subtract_drift": True,
    "msd_lags": 120,
    "shape_frames": 200,
    "structure_frames": 100,
    "correlation_frames": 10,
    "q_edges": [3.54, 5.04, 150],
    "q_points": shapes.Q_POINTS,
    "g6_dr": 0.1,
    "gr_dx": 0.2,
}

#: Scalar observables stored as attributes of ``/observables`` in analysis.h5: the per-run
#: numbers and label codes of the observable table (:mod:`fcsweep.io.observables`).
SCALARS = RUN_SCALARS + LABELS
#: KTHNY fit results (:func:`fcsweep.analysis.kthny.kthny_fits`) stored per run.
KTHNY_FIT_KEYS = ("eta_G1", "eta_G1_err", "eta_T", "eta_T_err", "xi_T", "xi_T_err", "eta_6", "eta_6_err",
                  "xi_6", "xi_6_err")
KTHNY_SCALARS = KTHNY_FIT_KEYS + ("kthny", "kthny_confidence")
#: Label explanations stored as string attributes of ``/observables``.
REASONS = ("phase_reason", "percolated_reason", "kthny_reason")


class AnalysisError(RuntimeError):
    """A run that cannot be analysed (too few frames, missing fields, ...)."""


def _evenly(indices: np.ndarray, k: int) -> np.ndarray:
    """At most ``k`` evenly spaced entries of ``indices`` (always including the last)."""
    if k <= 0 or len(indices) <= k:
        return np.asarray(indices)
    pick = np.unique(np.round(np.linspace(0, len(indices) - 1, k)).astype(int))
    return np.asarray(indices)[pick]


def settings_with(overrides=None, *, transient=None) -> dict:
    """Analysis settings: the defaults updated by ``overrides`` (unknown keys rejected)."""
    s = json.loads(json.dumps(DEFAULT_SETTINGS))
    for k, v in dict(overrides or {}).items():
        if k not in s:
            raise ValueError(f"unknown analysis setting {k!r}; allowed: {sorted(s)}")
        s[k] = v
    if transient is not None:
        s["transient"] = float(transient)
    if not 0.0 <= float(s["transient"]) < 1.0:
        raise ValueError(f"transient = {s['transient']} must lie in [0, 1)")
    return s


def config_settings(config) -> dict:
    """The analysis settings a sweep's config sets: its ``analysis`` section
    (``label_confidence``, ``percolation_threshold``); {} for a config without one."""
    analysis = getattr(config, "analysis", None)
    return dict(analysis.as_dict()) if analysis is not None else {}


# ------------------------------------------------------------------ one run: compute

def compute_observables(traj, settings: dict, *, curves: bool = True,
                        psi6: bool = True) -> tuple[dict, dict, dict]:
    """All observables of one opened trajectory.

    Parameters
    ----------
    traj : Trajectory
        An opened trajectory (:func:`fcsweep.analysis.trajectory.open_trajectory`).
    settings : dict
        Analysis settings (:func:`settings_with`).
    curves : bool
        Compute the curves (MSD, G6, G_r).  The in-run check of ``run.until`` leaves them
        out: no label depends on them.
    psi6 : bool
        Compute |Psi6| (a second Voronoi pass over the structure frames); NaN otherwise.

    Returns
    -------
    scalars : dict
        name -> float (see ``SCALARS``).
    curves : dict
        name -> (coordinate values, values).
    extra : dict
        ``n_sides_counts`` and the analysed frame indices.
    """
    T = traj.n_frames
    first = int(np.ceil(float(settings["transient"]) * (T - 1) - 1e-9))
    frames = np.arange(first, T)
    if frames.size < 3:
        raise AnalysisError(f"{traj.path}: only {frames.size} frames after the transient "
                            f"({T} recorded, transient {settings['transient']}); need >= 3")
    p = traj.params
    R0 = float(p.get("R0", 1.0))
    v0, Dr = float(p.get("v0", np.nan)), float(p.get("Dr", np.nan))
    box = traj.box
    N = traj.n_cells
    time = traj.time[frames] - traj.time[frames[0]]
    if np.any(np.diff(time) <= 0):
        raise AnalysisError(f"{traj.path}: frame times are not increasing")
    if not np.allclose(np.diff(time), time[1] - time[0], rtol=1e-6, atol=1e-12):
        raise AnalysisError(f"{traj.path}: frames are not equally spaced in time")
    sc, cv = {}, {}

    # --- shape index: per-frame <q> and fraction above q*, time averages with errors
    lo, hi, nb = settings["q_edges"]
    edges = np.linspace(float(lo), float(hi), int(nb) + 1)
    centres = 0.5 * (edges[1:] + edges[:-1])
    sf = _evenly(frames, int(settings["shape_frames"]))
    if traj.modes_width == 0 and int(p.get("modes", 1) or 0) == 0:
        q = np.full((sf.size, N), shapes.Q_CIRCLE)  # rigid discs
    elif "shape_a" in traj.fields and "shape_b" in traj.fields:
        q = shapes.shape_indices(traj.read("shape_a", sf), traj.read("shape_b", sf), 1.0,
                                 int(settings["q_points"]))
    else:
        q = np.full((1, N), np.nan)  # shapes not stored
    qs = shapes.q_statistics(q, edges)
    sc["q_std"] = qs["q_std"]
    cv["q_hist"] = (centres, qs["q_hist"])
    starts = []
    if np.all(np.isfinite(q)):
        for name, series in (("q_mean", q.mean(axis=1)), ("q_frac_above", (q > shapes.Q_STAR).mean(axis=1))):
            ta = time_average(series)
            sc[name], sc[f"{name}_err"] = ta.mean, ta.err
            if name == "q_mean":
                starts.append(sf[ta.start])
    else:
        sc.update(q_mean=np.nan, q_mean_err=np.nan, q_frac_above=np.nan, q_frac_above_err=np.nan)

    # --- Voronoi defects, clusters, |Psi6| (lengths in units of R0 from here on)
    vf = _evenly(frames, int(settings["structure_frames"]))
    pos = traj.read("position", vf) / R0
    boxr = box / R0
    ds = voronoi.defect_statistics(pos, boxr, frame_indices=vf)
    for name in ("rho_d", "largest_cluster_fraction", "largest_cluster_fraction_shuffled"):
        sc[name], sc[f"{name}_err"] = ds[name], ds[f"{name}_err"]
    starts.append(vf[ds["rho_d_start"]])
    counts = ds["cluster_size_counts"]
    cv["cluster_size_distribution"] = (np.arange(1, N + 1), counts.astype(float))

    # --- hexatic order and correlations
    cf = set(_evenly(vf, int(settings["correlation_frames"])).tolist()) if curves else set()
    mods, g6s, grs, cgs = [], [], [], []
    r = dxs = None
    spacing = cage.neighbour_spacing(N, boxr)
    for f, P in zip(vf, pos) if (psi6 or curves) else ():  # G6 and G_r need Psi6 too
        vn = voronoi.voronoi_neighbors(P, boxr)
        ps = order.psi6(P, boxr, vn.nlist)
        mod, ang = order.global_psi6(ps)
        mods.append(mod)
        if int(f) in cf:
            r, g = order.g6(P, boxr, ps, dr=float(settings["g6_dr"]))
            pairs = order.pair_vectors(P, boxr, order.max_range(boxr))  # one query for G_r and C_G1
            dxs, gr = order.gr_cut(P, boxr, ang, dx=float(settings["gr_dx"]), vectors=pairs)
            G1 = order.first_shell_vectors(P, boxr, ang, spacing)
            _, cg = order.shell_correlation(pairs, G1, dr=float(settings["g6_dr"]), r_max=order.max_range(boxr))
            del pairs
            g6s.append(g)
            grs.append(gr)
            cgs.append(cg)
    if mods:
        ta = time_average(np.asarray(mods))
        sc["psi6"], sc["psi6_err"] = ta.mean, ta.err
    else:
        sc["psi6"] = sc["psi6_err"] = np.nan
    if curves:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # bins without pairs in every frame
            cv["G6"] = (r, np.nanmean(np.asarray(g6s), axis=0) if r.size else r.copy())
            cv["Gr"] = (dxs, np.mean(np.asarray(grs), axis=0))
            cv["C_G1"] = (r, np.nanmean(np.asarray(cgs), axis=0) if r.size else r.copy())
        sc.update(_kthny(r, np.asarray(g6s), dxs, np.asarray(grs), N, float(settings["label_confidence"]),
                         spacing, np.asarray(cgs), boxr))
    else:
        sc.update(_kthny(None, None, None, None, N, float(settings["label_confidence"]), np.nan))

    # --- MSD (all frames, for the curve) and D_eff (from the equilibrated frames)
    eq = equilibrated_frames(frames, starts)
    x = traj.unwrapped(frames)
    if not np.all(np.isfinite(x)):
        raise AnalysisError(f"{traj.path}: non-finite positions after the transient")
    if curves:
        msd, _ = msd_curve(x, subtract_drift=bool(settings["subtract_drift"]), n_blocks=1)
        lags = log_lag_indices(frames.size, int(settings["msd_lags"]))
        cv["msd"] = (time[lags], msd[lags])
    x = x[eq - frames[0]]
    est = diffusion.estimate_diffusion(
        traj.time[eq] - traj.time[eq[0]], x, Dr=Dr, max_time_blocks=int(settings["max_time_blocks"]),
        min_block_persistence=float(settings["min_block_persistence"]),
        fit_start=float(settings["fit_start"]),
        settle_tol=0.1 * diffusion.D_EFF_SOLID * diffusion.free_diffusion(v0, Dr))
    cb = cage.cage_breaking(traj.time[eq] - traj.time[eq[0]], x, boxr)
    del x
    D0 = diffusion.free_diffusion(v0, Dr)
    conv = (lambda d: diffusion.effective_diffusion(d, 0.0, v0, Dr)[0])
    sc.update(D_s=est.D, D_s_err=est.D_err, D0=D0, D_eff=conv(est.D), D_eff_err=conv(est.D_err),
              D_eff_err_time=conv(est.D_err_time), D_eff_err_cells=conv(est.D_err_cells),
              D_eff_late=conv(est.D_late), D_eff_late_err=conv(est.D_late_err),
              D_eff_long=conv(est.D_long), D_eff_long_err=conv(est.D_long_err),
              msd_diffusive=float(est.diffusive), msd_long_enough=float(est.long_enough),
              n_time_blocks=float(est.n_time_blocks), block_span=est.block_span,
              fit_t_min=est.t_min, fit_t_max=est.t_max, D_eff_g_cells=est.g_cells,
              **cb.scalars(v0, Dr),
              D_eff_cr=conv(cb.D_cr), D_eff_cr_err=conv(cb.D_cr_err),
              n_frames=float(eq.size), t_start=float(traj.time[frames[0]]),
              t_end=float(traj.time[frames[-1]]), t_equilibrated=float(traj.time[eq[0]]))

    # --- labels with their confidence
    note = ""
    if not est.long_enough:
        note = (f"run too short for D_eff: {est.block_span:.4g} time units analysed, "
                f"need {float(settings['min_block_persistence']):g}/Dr = "
                f"{float(settings['min_block_persistence']) / Dr:.4g}")
    elif not est.diffusive and not np.isfinite(sc["D_eff_cr"]):
        note = (f"MSD not diffusive within the run: D_eff {sc['D_eff']:.3g} +- {sc['D_eff_err']:.2g}, "
                f"from the late half of the fit window {sc['D_eff_late']:.3g} +- {sc['D_eff_late_err']:.2g}, "
                f"at another block length {sc['D_eff_long']:.3g} +- {sc['D_eff_long_err']:.2g}")
    conf = float(settings["label_confidence"])
    lab = phase_label(phase_evidence(sc, note), min_confidence=conf)
    sc.update(phase=float(lab.code), phase_confidence=lab.confidence, phase_reason=lab.reason)
    lab = classify_percolation(sc["rho_d"], sc["rho_d_err"], min_confidence=conf,
                               threshold=float(settings["percolation_threshold"]))
    sc.update(percolated=float(lab.code), percolated_confidence=lab.confidence,
              percolated_reason=lab.reason)
    if curves:
        cv["F_s"] = (cb.lags, cb.F_s)
        cv["cage_msd"] = (cb.lags, cb.cr_msd)
    extra = {"n_sides_counts": ds["n_sides_counts"], "frames": frames,
             "structure_frames": vf, "shape_frames": sf}
    return sc, cv, extra


def equilibrated_frames(frames: np.ndarray, starts) -> np.ndarray:
    """The frames D_eff and the cage test use: those from the latest equilibration start.

    Each start comes from its own series (``<q>`` on the shape frames, ``rho_d`` on the
    structure frames), which :func:`fcsweep.analysis.stats.detect_equilibration` cuts by
    at most half; on their coarser frame grids that half can reach a few frames past the
    half of ``frames``, so the cut is capped there: at least half of the frames after the
    transient stay (a run of 2 x 8/Dr after the transient always has a window of 8/Dr).

    Parameters
    ----------
    frames : ndarray of int
        Frame indices after the transient, increasing.
    starts : sequence of int
        Frame indices where each series is stationary.

    Returns
    -------
    ndarray of int
    """
    frames = np.asarray(frames)
    if frames.size < 3 or not len(starts):
        return frames
    start = min(max(starts), frames[(frames.size - 1) // 2])
    eq = frames[frames >= start]
    return eq if eq.size >= 3 else frames


def _frame_mean(curves: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean over frames of per-frame curves and its standard error (NaN with one frame)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # bins without pairs in some frames
        m = np.nanmean(curves, axis=0)
        n = np.sum(np.isfinite(curves), axis=0)
        if curves.shape[0] > 1:
            e = np.nanstd(curves, axis=0, ddof=1) / np.sqrt(np.maximum(n, 1))
        else:
            e = np.full(m.shape, np.nan)
    return m, e


def _kthny(r, g6_frames, dx, gr_frames, n_cells: int, confidence: float, spacing: float,
           cg_frames=None, box=None) -> dict:
    """KTHNY fits and label from the per-frame G6(r), G_r(dx, 0) and C_G1(r) (NaN without curves)."""
    out = {k: np.nan for k in KTHNY_SCALARS}
    out["kthny_reason"] = "correlations not computed"
    if r is None or g6_frames.size == 0 or gr_frames.size == 0:
        return out
    G6, G6e = _frame_mean(g6_frames)
    Gr, Gre = _frame_mean(gr_frames)
    CG, CGe = _frame_mean(cg_frames) if cg_frames is not None and cg_frames.size else (None, None)
    fits = kthny.kthny_fits(r, G6, dx, Gr, G6_err=G6e, Gr_err=Gre, spacing=spacing, C_G1=CG, C_G1_err=CGe,
                            box=box)
    lab = kthny.classify_kthny(fits, min_confidence=confidence, n_cells=n_cells)
    for k in KTHNY_FIT_KEYS:
        out[k] = float(fits.get(k, np.nan))
    out.update(kthny=float(lab.code), kthny_confidence=lab.confidence, kthny_reason=lab.reason)
    return out


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
        f.attrs["parameters_json"] = json.dumps(traj.params, sort_keys=True, default=str)
        f.attrs["run_id"] = str(traj.params.get("run_id", ""))
        g = f.create_group("observables")
        for k in SCALARS:
            g.attrs[k] = np.float64(sc[k])
        for k in REASONS:
            g.attrs[k] = str(sc[k])
        c = f.create_group("curves")
        for name, coord in CURVES.items():
            x, y = cv[name]
            if coord not in c:
                c.create_dataset(coord, data=np.asarray(x))
            c.create_dataset(name, data=np.asarray(y, dtype=float))
        f.create_dataset("n_sides_counts", data=extra["n_sides_counts"])
        f.create_dataset("frames", data=extra["frames"])


def analyze_run(traj_path, out_path=None, *, transient=0.2, force=False, settings=None) -> dict:
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
    s = settings_with(settings, transient=transient)
    if out_path.exists() and not force:
        try:
            old = read_analysis(out_path)
            if old["settings"] == s:
                return {"status": "skipped", "message": "up to date", "path": str(out_path),
                        **old["scalars"]}
        except (OSError, KeyError, ValueError):
            pass  # unreadable: recompute
    traj = open_trajectory(traj_path)
    sc, cv, extra = compute_observables(traj, s)
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
