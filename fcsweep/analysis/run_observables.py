"""Every observable of one run, from its arrays: arrays in, a dict of numbers out.

:func:`compute_observables` takes a :class:`RunFrames` (the frame times, the box, the
parameters and the per-cell arrays of the frames the analysis reads, chosen by
:func:`frame_plan`) and returns the scalars, curves and frame indices of docs/model.md.
Reading them from a trajectory and writing ``analysis.h5`` is :mod:`fcsweep.results.analyze`.
The steps, each on its own frames after the transient:

- shape index ``q`` on up to ``shape_frames`` evenly spaced frames (:func:`shape_observables`);
- Voronoi defects and clusters on up to ``structure_frames`` frames (:func:`structure_observables`);
- |Psi6|, G6, G_r and C_G1 and the KTHNY fits and label (:mod:`fcsweep.analysis.run_order`), the
  correlations from the pair counts or, with ``settings["correlations"] == "fft"``, by FFT
  on a grid (:func:`fcsweep.analysis.correlation_fft.pipeline_spacing`);
- MSD, D_eff and cage breaking over the equilibrated frames (:func:`diffusion_observables`);
- the phase and percolation labels with their confidence (:func:`label_observables`);
- on a periodic coexistence start (``initial: coexistence``), the crystal fraction of the
  structure frames on their tessellations and the ``phase_coexistence`` label
  (:func:`fcsweep.analysis.crystal.coexistence_observables`; NaN for other starts).

A confined run (``boundary`` ``well`` or ``channel``, :func:`run_confinement`) takes the
same steps with the walls (:mod:`fcsweep.analysis.confined`): defects, clusters and |Psi6|
over the cells counted away from the walls (:func:`confined_structure_observables`), the
cage rule over the cells at least 2a from the walls, the whole-cell MSD flagged as bounded
(``msd_bounded``), the KTHNY correlations not computed (reason code ``not_periodic``), and
the pressure on the wall (:func:`wall_observables`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from fcsweep.analysis import cage, confined, diffusion, shapes, voronoi
from fcsweep.analysis.crystal import COEXISTENCE_SCALARS, coexistence_observables, crystalline
from fcsweep.analysis.frames import as_source
from fcsweep.analysis.msd import frame_drift, log_lag_indices, msd_curve_streamed
from fcsweep.analysis.phase import classify_percolation, phase_evidence, phase_label, solid_kind
from fcsweep.analysis.reasons import reason_value
from fcsweep.analysis.stats import time_average
from fcsweep.model.confinement import confinement_of_params
from fcsweep.model.systematics import CONVERGED_DT, rule_bias
from fcsweep.analysis.run_order import (KTHNY_SCALARS, OrderFrames, evenly, frame_mean, kthny_observables,
                                        not_periodic_kthny, order_observables)

__all__ = ["AnalysisError", "FramePlan", "RunFrames", "KTHNY_SCALARS", "frame_plan", "evenly", "compute_observables",
           "shape_observables", "structure_observables", "order_observables", "kthny_observables",
           "diffusion_observables", "label_observables", "equilibrated_frames", "cut_at_limit", "frame_mean",
           "run_confinement", "confined_structure_observables", "wall_observables", "not_periodic_kthny"]


class AnalysisError(RuntimeError):
    """A run that cannot be analysed (too few frames, missing fields, ...)."""


@dataclass(frozen=True)
class FramePlan:
    """The frame indices each step reads: ``frames`` after the transient, the evenly spaced
    ``shape_frames`` and ``structure_frames`` among them."""

    frames: np.ndarray
    shape_frames: np.ndarray
    structure_frames: np.ndarray


@dataclass(frozen=True)
class RunFrames:
    """The arrays of one run the observables are computed from.

    Attributes
    ----------
    source : str
        Where they come from (the trajectory path), for error messages.
    params : mapping
        Run parameters (``R0``, ``v0``, ``Dr``, ``modes``, ...).
    box : ndarray, shape (2,)
    time : ndarray, shape (T,)
        Times of all recorded frames.
    plan : FramePlan
    shape_a, shape_b : ndarray, shape (len(plan.shape_frames), N, M - 1), or None
        Mode amplitudes on the shape frames; None for rigid discs or shapes not stored.
    rigid : bool
        Rigid discs (q is that of a circle).
    positions : ndarray, shape (len(plan.structure_frames), N, 2)
        Wrapped centroids on the structure frames.
    unwrapped : ndarray, shape (len(plan.frames), N, 2)
        Unwrapped centroids on every frame after the transient.
    radii : ndarray, shape (N,), or None
        Per-cell radii R0,i when sizes differ (the defects then use the radical
        tessellation, :func:`fcsweep.analysis.voronoi.laguerre_bonds`).
    wall_positions, wall_theta : ndarray, shapes (len(plan.shape_frames), N, 2) and
        (len(plan.shape_frames), N), or None
        Wrapped centroids and orientations on the shape frames: the pressure on the wall
        of a confined run (None for a periodic run, or not read).

    Each array may be a :class:`fcsweep.analysis.frames.FrameSource` of that shape
    instead: the steps then read it a block of frames or of cells at a time
    (:func:`fcsweep.results.analyze.read_run_frames` passes a trajectory's that way), and
    the peak memory is linear in N and bounded in frames.
    """

    source: str
    params: Mapping
    box: np.ndarray
    time: np.ndarray
    plan: FramePlan
    shape_a: np.ndarray | None
    shape_b: np.ndarray | None
    rigid: bool
    positions: np.ndarray
    unwrapped: np.ndarray
    radii: np.ndarray | None = None
    wall_positions: np.ndarray | None = None
    wall_theta: np.ndarray | None = None

    @property
    def n_cells(self) -> int:
        return int(self.positions.shape[1])


def frame_plan(n_frames: int, settings: Mapping, source: str = "run") -> FramePlan:
    """The frames after the ``transient`` fraction of ``n_frames``, and those the shape
    and structure steps read (``shape_frames``, ``structure_frames`` of ``settings``).

    Raises
    ------
    AnalysisError
        With fewer than 3 frames after the transient.
    """
    first = int(np.ceil(float(settings["transient"]) * (n_frames - 1) - 1e-9))
    frames = np.arange(first, n_frames)
    if frames.size < 3:
        raise AnalysisError(f"{source}: only {frames.size} frames after the transient "
                            f"({n_frames} recorded, transient {settings['transient']}); need >= 3")
    return FramePlan(frames, evenly(frames, int(settings["shape_frames"])),
                     evenly(frames, int(settings["structure_frames"])))


def compute_observables(run: RunFrames, settings: Mapping, *, curves: bool = True,
                        psi6: bool = True) -> tuple[dict, dict, dict]:
    """All observables of one run.

    Parameters
    ----------
    run : RunFrames
        The run's arrays on the frames of ``run.plan``.
    settings : mapping
        Analysis settings (:func:`fcsweep.results.analyze.settings_with`).
    curves : bool
        Compute the curves (MSD, G6, G_r).  The in-run check of ``run.until`` leaves them
        out: no label depends on them.
    psi6 : bool
        Compute |Psi6| (a second Voronoi pass over the structure frames); NaN otherwise.

    Returns
    -------
    scalars : dict
        name -> float, and the ``<label>_reason`` strings.
    curves : dict
        name -> (coordinate values, values).
    extra : dict
        ``n_sides_counts`` and the analysed frame indices.
    """
    plan = run.plan
    time = run.time[plan.frames] - run.time[plan.frames[0]]
    if np.any(np.diff(time) <= 0):
        raise AnalysisError(f"{run.source}: frame times are not increasing")
    if not np.allclose(np.diff(time), time[1] - time[0], rtol=1e-6, atol=1e-12):
        raise AnalysisError(f"{run.source}: frames are not equally spaced in time")
    R0 = float(run.params.get("R0", 1.0))
    boxr = run.box / R0  # lengths in units of R0 from here on
    pos = as_source(run.positions).scaled(R0)
    conf = run_confinement(run)
    coexistence = conf is None and str(run.params.get("initial", "")) == "coexistence"
    crystal = []  # crystal fraction of each structure frame of a coexistence start
    sc, cv, q_start = shape_observables(run, settings)
    sf = plan.structure_frames
    radii = None if run.radii is None else np.asarray(run.radii, dtype=float) / R0
    if conf is None:
        # one Voronoi tessellation per structure frame serves the defects and Psi6
        try:
            acc = OrderFrames(pos.shape[1], boxr, plan.structure_frames, settings, curves)
        except ValueError as exc:  # an unknown correlations method
            raise AnalysisError(str(exc)) from None
        each = (lambda k, vn: acc.add(sf[k], pos[k], vn)) if (psi6 or curves) else None  # G6, G_r need Psi6
        if coexistence:
            each = _with_crystal(each, pos, boxr, radii, crystal)
        s2, c2, ds = structure_observables(pos, boxr, sf, each=each, radii=radii)
        sc.update(s2)
        cv.update(c2)
        s3, c3 = acc.finish()
        sc.update(s3)
        cv.update(c3)
    else:
        s2, c2, ds = confined_structure_observables(pos, conf, sf, psi6=psi6, radii=radii)
        sc.update(s2)
        cv.update(c2)
        sc.update(not_periodic_kthny())
        if curves:
            cv.update({name: (np.zeros(0), np.zeros(0)) for name in ("G6", "Gr", "C_G1")})
    starts = ([] if q_start is None else [q_start]) + [plan.structure_frames[ds["rho_d_start"]]]
    eq = equilibrated_frames(plan.frames, starts)
    sc["equilibration_at_limit"] = float(cut_at_limit(plan.frames, starts))
    s4, c4, est = diffusion_observables(run, eq, boxr, settings, curves=curves, conf=conf)
    sc.update(s4)
    cv.update(c4)
    sc.update(wall_observables(run, conf, eq))
    p = run.params
    sc.update(rule_bias(str(p.get("quadrature", "binary")), int(p.get("contour_points", 40)),
                        float(p.get("dt", CONVERGED_DT)), int(p.get("modes", 6))))
    sc.update(label_observables(sc, est, settings, float(run.params.get("Dr", np.nan))))
    sc.update(coexistence_observables(run.time[sf] - run.time[0], crystal, boxr, pos.shape[1],
                                      min_confidence=float(settings["label_confidence"])) if coexistence
              else dict.fromkeys(COEXISTENCE_SCALARS, np.nan))
    extra = {"n_sides_counts": ds["n_sides_counts"], "frames": plan.frames,
             "structure_frames": plan.structure_frames, "shape_frames": plan.shape_frames}
    return sc, cv, extra


def shape_observables(run: RunFrames, settings: Mapping):
    """Per-frame ``<q>`` and fraction above q*, time averages with errors, and the q histogram.

    Returns
    -------
    scalars, curves : dict
    start : int or None
        Frame index where the ``<q>`` series is stationary (None without shapes).
    """
    sf = run.plan.shape_frames
    lo, hi, nb = settings["q_edges"]
    edges = np.linspace(float(lo), float(hi), int(nb) + 1)
    centres = 0.5 * (edges[1:] + edges[:-1])
    acc = shapes.QStatistics(edges)
    if run.rigid:
        acc.add(np.full((sf.size, run.n_cells), shapes.Q_CIRCLE))
    elif run.shape_a is not None and run.shape_b is not None:
        a, b = as_source(run.shape_a), as_source(run.shape_b)
        for s, e in a.frame_blocks():  # q of a block of frames at a time
            acc.add(shapes.shape_indices(a.frames(s, e), b.frames(s, e), 1.0, int(settings["q_points"])))
    else:
        acc.add(np.full((1, run.n_cells), np.nan))  # shapes not stored
    qs = acc.result()
    sc, cv = {"q_std": qs["q_std"]}, {"q_hist": (centres, qs["q_hist"])}
    start = None
    if acc.finite:
        for name, series in (("q_mean", qs["q_mean_frames"]), ("q_frac_above", qs["q_frac_above_frames"])):
            ta = time_average(series)
            sc[name], sc[f"{name}_err"] = ta.mean, ta.err
            if name == "q_mean":
                start = sf[ta.start]
    else:
        sc.update(q_mean=np.nan, q_mean_err=np.nan, q_frac_above=np.nan, q_frac_above_err=np.nan)
    return sc, cv, start


def _with_crystal(each, pos, boxr, radii, out: list):
    """``each`` of :func:`structure_observables` that also appends each frame's crystal
    fraction (:func:`fcsweep.analysis.crystal.crystalline`, on the same tessellation) to ``out``."""
    def both(k, vn):
        if each is not None:
            each(k, vn)
        out.append(float(crystalline(pos[k], boxr, radii, vn).mean()))
    return both


def structure_observables(pos: np.ndarray, boxr: np.ndarray, frames: np.ndarray, each=None, radii=None):
    """Voronoi defect fraction, largest clusters (also with shuffled labels) and cluster sizes
    (``each``: called with every frame's tessellation, :func:`voronoi.defect_statistics`;
    ``radii``: per-cell radii, the radical tessellation).

    Returns
    -------
    scalars, curves : dict
    stats : dict
        :func:`fcsweep.analysis.voronoi.defect_statistics` (``rho_d_start``, ``n_sides_counts``).
    """
    ds = voronoi.defect_statistics(pos, boxr, frame_indices=frames, each=each, radii=radii)
    sc = {}
    for name in ("rho_d", "largest_cluster_fraction", "largest_cluster_fraction_shuffled"):
        sc[name], sc[f"{name}_err"] = ds[name], ds[f"{name}_err"]
    counts = ds["cluster_size_counts"]
    cv = {"cluster_size_distribution": (np.arange(1, pos.shape[1] + 1), counts.astype(float))}
    return sc, cv, ds


def run_confinement(run: RunFrames):
    """The run's well or channel in units of R0 (:func:`fcsweep.model.confinement.confinement_of_params`
    with the run's radii), or None for a periodic run.

    Raises
    ------
    AnalysisError
        When the host box the parameters give is not the run's box.
    """
    R0 = float(run.params.get("R0", 1.0))
    conf = confinement_of_params({**dict(run.params), "N": run.n_cells}, run.radii)
    if conf is None:
        return None
    if not np.allclose(conf.host, run.box, rtol=1e-9, atol=1e-9 * R0):
        raise AnalysisError(f"{run.source}: the {conf.kind}'s host box {conf.host.tolist()} from the parameters is "
                            f"not the run's box {np.asarray(run.box).tolist()}")
    return confined.scaled_confinement(conf, R0)


def confined_structure_observables(pos, conf, frames: np.ndarray, *, psi6: bool = True, radii=None):
    """Defects, clusters and |Psi6| of a confined run over the counted cells of each frame
    (:mod:`fcsweep.analysis.confined`: certain sides, at least 2a from the walls).

    Returns
    -------
    scalars, curves : dict
        As :func:`structure_observables`, plus ``psi6``, ``psi6_err`` and
        ``n_counted_cells``.
    stats : dict
        :func:`fcsweep.analysis.confined.confined_defect_statistics`.
    """
    N = pos.shape[1]
    a = confined.lattice_spacing(conf, N)
    mods = []
    each = (lambda f, tess, counted: mods.append(confined.confined_psi6(tess, counted))) if psi6 else None
    ds = confined.confined_defect_statistics(pos, conf, a, frame_indices=frames, each=each, radii=radii)
    sc = {"n_counted_cells": ds["n_counted_cells"]}
    for name in ("rho_d", "largest_cluster_fraction", "largest_cluster_fraction_shuffled"):
        sc[name], sc[f"{name}_err"] = ds[name], ds[f"{name}_err"]
    m = np.asarray(mods, dtype=float)
    if m.size and np.all(np.isfinite(m)):
        ta = time_average(m)
        sc["psi6"], sc["psi6_err"] = ta.mean, ta.err
    else:
        sc["psi6"] = sc["psi6_err"] = np.nan
    cv = {"cluster_size_distribution": (np.arange(1, N + 1), ds["cluster_size_counts"].astype(float))}
    return sc, cv, ds


def wall_observables(run: RunFrames, conf, eq: np.ndarray) -> dict:
    """``area_fraction``, ``wall_pressure`` and its error (NaN for a periodic run, and the
    pressure NaN where the orientations or shapes were not read), ``msd_bounded``, and
    ``n_counted_cells`` of a periodic run (N).

    The pressure is read on the shape frames from the first equilibrated frame ``eq[0]``
    on (:func:`fcsweep.analysis.confined.pressure_series`), its mean and error those of a
    correlated series (:func:`fcsweep.analysis.confined.pressure_observables`)."""
    nan = float("nan")
    if conf is None:
        return {"area_fraction": nan, "wall_pressure": nan, "wall_pressure_err": nan, "msd_bounded": 0.0,
                "n_counted_cells": float(run.n_cells)}
    out = {"area_fraction": float(conf.area_fraction), "msd_bounded": 1.0}
    sf = run.plan.shape_frames
    keep = np.flatnonzero(sf >= eq[0])
    shapes_ok = run.rigid or (run.shape_a is not None and run.shape_b is not None)
    if run.wall_positions is None or run.wall_theta is None or not shapes_ok or keep.size == 0:
        return {**out, "wall_pressure": nan, "wall_pressure_err": nan}
    R0 = float(run.params.get("R0", 1.0))
    radii = None if run.radii is None else np.asarray(run.radii, dtype=float) / R0
    ab = (None, None) if run.rigid else (as_source(run.shape_a).select(keep), as_source(run.shape_b).select(keep))
    series = confined.pressure_series(
        as_source(run.wall_positions).scaled(R0).select(keep), as_source(run.wall_theta).select(keep), *ab, conf,
        contour_points=int(run.params.get("contour_points", 40)), quadrature=str(run.params.get("quadrature", "arc")),
        radii=radii)
    return {**out, **confined.pressure_observables(series)}


def diffusion_observables(run: RunFrames, eq: np.ndarray, boxr: np.ndarray, settings: Mapping, *,
                          curves: bool = True, conf=None):
    """MSD (all frames after the transient, for the curve), D_eff and cage breaking (from the
    equilibrated frames ``eq``).  In a confined run (``conf``, lengths in R0) the cage rule
    counts the cells at least 2a from the walls, its neighbours are the confined
    Voronoi's and ``a`` the spacing on the area inside the walls.

    Returns
    -------
    scalars, curves : dict
    estimate : fcsweep.analysis.diffusion.DiffusionEstimate
    """
    frames, t = run.plan.frames, run.time
    v0, Dr = float(run.params.get("v0", np.nan)), float(run.params.get("Dr", np.nan))
    x = as_source(run.unwrapped)  # read a block of frames or of cells at a time
    try:
        drift = frame_drift(x)
    except ValueError:
        raise AnalysisError(f"{run.source}: non-finite positions after the transient") from None
    cv = {}
    if curves:
        msd = msd_curve_streamed(x, subtract_drift=bool(settings["subtract_drift"]), drift=drift)
        lags = log_lag_indices(frames.size, int(settings["msd_lags"]))
        cv["msd"] = ((t[frames] - t[frames[0]])[lags], msd[lags])
    x = x.select(eq - frames[0])
    est = diffusion.estimate_diffusion(
        t[eq] - t[eq[0]], x, Dr=Dr, max_time_blocks=int(settings["max_time_blocks"]),
        min_block_persistence=float(settings["min_block_persistence"]),
        fit_start=float(settings["fit_start"]),
        settle_tol=0.1 * diffusion.D_EFF_SOLID * diffusion.free_diffusion(v0, Dr))
    cb = cage.cage_breaking(t[eq] - t[eq[0]], x, boxr, **_cage_options(conf, x.shape[1]))
    D0 = diffusion.free_diffusion(v0, Dr)
    conv = (lambda d: diffusion.effective_diffusion(d, 0.0, v0, Dr)[0])
    sc = dict(D_s=est.D, D_s_err=est.D_err, D0=D0, D_eff=conv(est.D), D_eff_err=conv(est.D_err),
              D_eff_err_time=conv(est.D_err_time), D_eff_err_cells=conv(est.D_err_cells),
              D_eff_late=conv(est.D_late), D_eff_late_err=conv(est.D_late_err),
              D_eff_long=conv(est.D_long), D_eff_long_err=conv(est.D_long_err),
              msd_diffusive=float(est.diffusive), msd_long_enough=float(est.long_enough),
              n_time_blocks=float(est.n_time_blocks), block_span=est.block_span,
              fit_t_min=est.t_min, fit_t_max=est.t_max, D_eff_g_cells=est.g_cells,
              **cb.scalars(v0, Dr),
              D_eff_cr=conv(cb.D_cr), D_eff_cr_err=conv(cb.D_cr_err),
              n_frames=float(eq.size), t_start=float(t[frames[0]]),
              t_end=float(t[frames[-1]]), t_equilibrated=float(t[eq[0]]))
    if curves:
        cv["F_s"] = (cb.lags, cb.F_s)
        cv["cage_msd"] = (cb.lags, cb.cr_msd)
    return sc, cv, est


def _cage_options(conf, n_cells: int) -> dict:
    """The options of :func:`fcsweep.analysis.cage.cage_breaking` for a confined run ({} if periodic)."""
    if conf is None:
        return {}
    a = confined.lattice_spacing(conf, n_cells)

    def neighbours(p):
        tess = confined.confined_voronoi(np.mod(p, conf.host), conf)
        return tess.i, tess.j

    return {"spacing": a, "neighbours": neighbours, "cells": lambda p: confined.wall_distance_mask(p, conf, a)}


def label_observables(sc: Mapping, est, settings: Mapping, Dr: float) -> dict:
    """The phase and percolation labels with their confidence and reason, from the scalars
    ``sc`` and the diffusion estimate ``est`` (a run too short or not diffusive says so)."""
    note = ""
    if not est.long_enough:
        cut = sc["t_equilibrated"] - sc["t_start"]
        after = (f"after the equilibration cut at t = {sc['t_equilibrated']:.4g} ({cut:.4g} time units past the "
                 f"transient, where the shape and defect series became stationary)" if cut > 0 else
                 "after the transient")
        note = (f"run too short for D_eff: {est.block_span:.4g} time units analysed {after}, "
                f"need {float(settings['min_block_persistence']):g}/Dr = "
                f"{float(settings['min_block_persistence']) / Dr:.4g}")
    elif not est.diffusive and not np.isfinite(sc["D_eff_cr"]):
        note = (f"MSD not diffusive within the run: D_eff {sc['D_eff']:.3g} +- {sc['D_eff_err']:.2g}, "
                f"from the late half of the fit window {sc['D_eff_late']:.3g} +- {sc['D_eff_late_err']:.2g}, "
                f"at another block length {sc['D_eff_long']:.3g} +- {sc['D_eff_long_err']:.2g}")
    conf = float(settings["label_confidence"])
    out = {}
    lab = phase_label(phase_evidence(sc, note), min_confidence=conf)
    out.update(phase=float(lab.code), phase_confidence=lab.confidence, phase_reason=lab.reason,
               phase_reason_code=float(reason_value(lab.reason_code)))
    kind, kind_p = solid_kind(lab.code, sc.get("psi6", np.nan), sc.get("psi6_err", np.nan), sc["rho_d"],
                              sc["rho_d_err"], min_confidence=conf)
    out.update(solid_kind=float(kind), solid_kind_confidence=kind_p)
    lab = classify_percolation(sc["rho_d"], sc["rho_d_err"], min_confidence=conf,
                               threshold=float(settings["percolation_threshold"]),
                               stationary=not sc.get("equilibration_at_limit", 0.0) >= 0.5)
    out.update(percolated=float(lab.code), percolated_confidence=lab.confidence, percolated_reason=lab.reason,
               percolated_reason_code=float(reason_value(lab.reason_code)))
    return out


def cut_at_limit(frames: np.ndarray, starts) -> bool:
    """Whether the equilibration cut reached its limit (:func:`equilibrated_frames` caps it
    at half the frames after the transient): a series whose stationary part starts there or
    later still drifts, and the labels are not decided on that window."""
    frames = np.asarray(frames)
    return bool(frames.size >= 3 and len(starts) and max(starts) >= frames[(frames.size - 1) // 2])


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
